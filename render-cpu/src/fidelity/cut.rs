//! [`choose_evaluation_cut`]: a whole-hemisphere fit evaluated within the
//! elevation cut its validation renders prefer, without fitting the
//! functions again, with or without a shell factor beyond the cut.

use super::{RenderErrors, Validator, RENDER_CHECK};
use crate::RenderError;
use brdf::{Brdf, FittedBrdf, ShellFactor, DEFAULT_SHELL_BINS};
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
    /// Whether the chosen evaluation has a shell factor beyond the cut
    /// (in `fitted`).
    pub shell: bool,
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
    /// Whether a shell factor ([`brdf::ShellFactor`]) multiplies the fit
    /// beyond the cut.
    pub shell: bool,
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
                    "{}{} {:.2}",
                    t.cut.map_or("none".to_string(), |c| format!("{c}")),
                    if t.shell { "+shell" } else { "" },
                    t.worst_mean_de
                )
            })
            .collect();
        let own = self.fitted.reduction.max_elevation_deg;
        let chosen = match self.cut {
            Some(c) if self.shell => format!(
                "{c} degrees and a shell factor of {} bytes",
                self.fitted
                    .shell
                    .as_ref()
                    .map_or(0, ShellFactor::byte_size_f32)
            ),
            Some(c) => format!("{c} degrees"),
            None if own < 90.0 => format!("none; the fit's own cut of {own} degrees"),
            None => "none, the whole hemisphere".to_string(),
        };
        format!(
            "evaluation cut chosen by the validation renders: {chosen} (worse scene's mean CIEDE2000 by cut; +shell: with the shell factor beyond it: {})",
            tried.join(", ")
        )
    }
}

/// A fit over the whole hemisphere (its reduction has no elevation cut)
/// evaluated within the cut among none and [`EVALUATION_CUTS`], each
/// with and without a shell factor fitted to `table` beyond it
/// ([`brdf::ShellFactor`], [`DEFAULT_SHELL_BINS`]), whose validation
/// renders have the lowest worse-scene mean CIEDE2000. The functions are
/// not fitted again: directions beyond the cut are moved onto it
/// ([`brdf::clamp_elevation`]), so grazing views show the fit's value at
/// the cut instead of its loosely bounded grazing cells (a silhouette under
/// a sky mirrors the bright horizon through them), and the shell factor
/// gives them the table's luminance there, cell by cell. `errors` are the
/// fit's own errors under `validator`. A fit with a cut of its own keeps
/// it, and is measured with a shell factor beyond it as well (`cut` is then
/// its own cut when the shell is chosen, `None` when it is not).
///
/// # Errors
/// As [`Validator::measure`], and [`RenderError::Material`] when the shell
/// factor cannot be fitted (a table of non-finite values).
pub fn choose_evaluation_cut(
    validator: &Validator,
    table: &dyn Brdf,
    fitted: FittedBrdf,
    errors: RenderErrors,
) -> Result<CutChoice, RenderError> {
    let mut tried = vec![CutTried {
        cut: None,
        shell: false,
        worst_mean_de: errors.worst_mean(),
    }];
    let mut best = CutChoice {
        fitted,
        cut: None,
        shell: false,
        errors,
        tried: Vec::new(),
    };
    // (cut, the fit evaluated within it, whether that evaluation is still
    // to be measured): a fit with its own cut is measured already.
    let own = best.fitted.reduction.max_elevation_deg;
    let within: Vec<(f64, FittedBrdf, bool)> = if own < 90.0 {
        if best.fitted.shell.is_some() {
            Vec::new()
        } else {
            vec![(own, best.fitted.clone(), false)]
        }
    } else {
        EVALUATION_CUTS
            .iter()
            .filter_map(|&degrees| Some((degrees, best.fitted.evaluated_within(degrees)?, true)))
            .collect()
    };
    let material_error = |source| RenderError::Material {
        name: table.name(),
        source,
    };
    for (degrees, plain, measure_plain) in within {
        let shell = ShellFactor::fit(table, &plain, DEFAULT_SHELL_BINS).map_err(material_error)?;
        let shelled = plain.clone().with_shell(shell).map_err(material_error)?;
        let variants = [(plain, false), (shelled, true)];
        for (variant, has_shell) in variants.into_iter().filter(|v| v.1 || measure_plain) {
            let errors = validator.measure(Arc::new(crate::FitInDomain::new(variant.clone())))?;
            let worst = errors.worst_mean();
            tried.push(CutTried {
                cut: Some(degrees),
                shell: has_shell,
                worst_mean_de: worst,
            });
            if worst < best.errors.worst_mean() {
                best = CutChoice {
                    fitted: variant,
                    cut: Some(degrees),
                    shell: has_shell,
                    errors,
                    tried: Vec::new(),
                };
            }
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
    let validator = Validator::new(table.clone(), RENDER_CHECK)?;
    let errors = validator.measure(Arc::new(crate::FitInDomain::new(fitted.clone())))?;
    let mut choice = choose_evaluation_cut(&validator, table.as_ref(), fitted, errors)?;
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
        let choice = choose_evaluation_cut(&validator, &glossy, fitted.clone(), errors).unwrap();
        // None and every cut measured, with and without the shell factor;
        // the chosen one has the lowest error.
        assert_eq!(choice.tried.len(), 1 + 2 * EVALUATION_CUTS.len());
        assert_eq!(choice.shell, choice.fitted.shell.is_some());
        assert_eq!(
            choice.tried.iter().filter(|t| t.shell).count(),
            EVALUATION_CUTS.len()
        );
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
        // A fit that already has a cut keeps it, with or without the shell.
        let mut within = fitted;
        within.reduction = within.reduction.with_max_elevation(75.0);
        let errors = validator
            .measure(Arc::new(crate::FitInDomain::new(within.clone())))
            .unwrap();
        let kept = choose_evaluation_cut(&validator, &glossy, within.clone(), errors).unwrap();
        assert_eq!(kept.tried.len(), 2);
        assert_eq!((kept.tried[1].cut, kept.tried[1].shell), (Some(75.0), true));
        assert_eq!(kept.fitted.reduction, within.reduction);
        if kept.shell {
            assert_eq!(kept.cut, Some(75.0));
            assert!(kept
                .describe()
                .contains("75 degrees and a shell factor of 128 bytes"));
        } else {
            assert_eq!(kept.cut, None);
            assert!(kept.describe().contains("the fit's own cut of 75 degrees"));
        }
        // With its shell it is measured as it is.
        let shelled = within
            .clone()
            .with_shell(ShellFactor::fit(&glossy, &within, DEFAULT_SHELL_BINS).unwrap())
            .unwrap();
        let errors = validator
            .measure(Arc::new(crate::FitInDomain::new(shelled.clone())))
            .unwrap();
        let kept = choose_evaluation_cut(&validator, &glossy, shelled, errors).unwrap();
        assert_eq!((kept.cut, kept.tried.len()), (None, 1));
    }
}
