//! [`choose_evaluation_cut`]: a whole-hemisphere fit evaluated within the
//! elevation cut its validation renders prefer, without fitting again.

use super::{RenderErrors, Validator, RENDER_CHECK};
use crate::RenderError;
use brdf::{Brdf, FittedBrdf};
use serde::Serialize;
use std::sync::Arc;

/// The elevation cuts (degrees) [`choose_evaluation_cut`] tries besides
/// none.
pub const EVALUATION_CUTS: [f64; 3] = [80.0, 75.0, 70.0];

/// What [`choose_evaluation_cut`] chose.
#[derive(Debug, Clone)]
pub struct CutChoice {
    /// The fit, its reduction's cut set to the chosen one.
    pub fitted: FittedBrdf,
    /// The chosen cut in degrees; `None`: the whole hemisphere.
    pub cut: Option<f64>,
    /// The render errors of the chosen evaluation.
    pub errors: RenderErrors,
    /// The worse scene's mean CIEDE2000 of each evaluation tried, the whole
    /// hemisphere first.
    pub tried: Vec<CutTried>,
}

/// One evaluation [`choose_evaluation_cut`] measured.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct CutTried {
    /// Degrees; `None`: the whole hemisphere.
    pub cut: Option<f64>,
    /// The worse scene's mean CIEDE2000.
    pub worst_mean_de: f64,
}

impl CutChoice {
    /// One line: the cut chosen and the error of each evaluation tried.
    pub fn describe(&self) -> String {
        let tried: Vec<String> = self
            .tried
            .iter()
            .map(|t| {
                format!(
                    "{} {:.2}",
                    t.cut.map_or("none".to_string(), |c| format!("{c}")),
                    t.worst_mean_de
                )
            })
            .collect();
        let own = self.fitted.reduction.max_elevation_deg;
        let chosen = match self.cut {
            Some(c) => format!("{c} degrees"),
            None if own < 90.0 => format!("none; the fit's own cut of {own} degrees"),
            None => "none, the whole hemisphere".to_string(),
        };
        format!(
            "evaluation cut chosen by the validation renders: {chosen} (worse scene's mean CIEDE2000 by cut: {})",
            tried.join(", ")
        )
    }
}

/// A fit over the whole hemisphere (its reduction has no elevation cut)
/// evaluated within the cut among none and [`EVALUATION_CUTS`] whose
/// validation renders have the lowest worse-scene mean CIEDE2000. The
/// functions are not fitted again: directions beyond the cut are moved onto
/// it ([`brdf::clamp_elevation`]), so grazing views show the fit's value at
/// the cut instead of its loosely bounded grazing cells (a silhouette under
/// a sky mirrors the bright horizon through them). `errors` are the fit's
/// own errors under `validator`. A fit with a cut is returned as it is.
///
/// # Errors
/// As [`Validator::measure`].
pub fn choose_evaluation_cut(
    validator: &Validator,
    fitted: FittedBrdf,
    errors: RenderErrors,
) -> Result<CutChoice, RenderError> {
    let mut tried = vec![CutTried {
        cut: None,
        worst_mean_de: errors.worst_mean(),
    }];
    let mut best = CutChoice {
        fitted,
        cut: None,
        errors,
        tried: Vec::new(),
    };
    let variants: Vec<(f64, FittedBrdf)> = EVALUATION_CUTS
        .iter()
        .filter_map(|&degrees| Some((degrees, best.fitted.evaluated_within(degrees)?)))
        .collect();
    for (degrees, within) in variants {
        let errors = validator.measure(Arc::new(crate::FitInDomain::new(within.clone())))?;
        let worst = errors.worst_mean();
        tried.push(CutTried {
            cut: Some(degrees),
            worst_mean_de: worst,
        });
        if worst < best.errors.worst_mean() {
            best = CutChoice {
                fitted: within,
                cut: Some(degrees),
                errors,
                tried: Vec::new(),
            };
        }
    }
    best.tried = tried;
    Ok(best)
}

/// [`super::render_check`] with the evaluation cut chosen
/// ([`choose_evaluation_cut`]) on the same renders.
///
/// # Errors
/// As [`Validator::new`] and [`Validator::measure`].
pub fn render_check_choosing_cut(
    table: Arc<dyn Brdf>,
    fitted: FittedBrdf,
) -> Result<CutChoice, RenderError> {
    let validator = Validator::new(table, RENDER_CHECK)?;
    let errors = validator.measure(Arc::new(crate::FitInDomain::new(fitted.clone())))?;
    let mut choice = choose_evaluation_cut(&validator, fitted, errors)?;
    choice.errors.images.clear();
    Ok(choice)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fidelity::ValidationSettings;

    #[test]
    fn the_cut_chosen_is_the_best_of_those_measured_and_cut_fits_are_kept() {
        let glossy = brdf::BlinnPhong {
            kd: [0.2, 0.3, 0.4],
            ks: [0.4, 0.4, 0.4],
            exponent: 8.0,
        };
        let reduction = brdf::Reduction::default()
            .with_kind(brdf::ReductionKind::Full3d)
            .with_resolution(6, 6)
            .with_phi_resolution(6)
            .whole_hemisphere();
        let settings = brdf::BrdfFitSettings::default()
            .with_reduction(reduction)
            .with_baselines(false);
        let (fitted, _) = brdf::fit_brdf(&glossy, &settings).unwrap();
        let validator = Validator::new(
            Arc::new(glossy),
            ValidationSettings {
                size: 24,
                sky_spp: 4,
                ..RENDER_CHECK
            },
        )
        .unwrap();
        let errors = validator
            .measure(Arc::new(crate::FitInDomain::new(fitted.clone())))
            .unwrap();
        let whole = errors.worst_mean();
        let choice = choose_evaluation_cut(&validator, fitted.clone(), errors).unwrap();
        // None and every cut measured; the chosen one has the lowest error.
        assert_eq!(choice.tried.len(), 1 + EVALUATION_CUTS.len());
        assert!((choice.tried[0].worst_mean_de - whole).abs() < 1e-12);
        let lowest = choice
            .tried
            .iter()
            .map(|t| t.worst_mean_de)
            .fold(f64::INFINITY, f64::min);
        assert!((choice.errors.worst_mean() - lowest).abs() < 1e-12);
        let cut_in_file = choice.fitted.reduction.max_elevation_deg;
        assert!((cut_in_file - choice.cut.unwrap_or(90.0)).abs() < 1e-12);
        assert_eq!(choice.fitted.channels, fitted.channels);
        // A fit that already has a cut is measured as it is.
        let mut within = fitted;
        within.reduction = within.reduction.with_max_elevation(75.0);
        let errors = validator
            .measure(Arc::new(crate::FitInDomain::new(within.clone())))
            .unwrap();
        let kept = choose_evaluation_cut(&validator, within, errors).unwrap();
        assert_eq!((kept.cut, kept.tried.len()), (None, 1));
        assert!(kept.describe().contains("the fit's own cut of 75 degrees"));
    }
}
