//! [`choose_evaluation_cut`]: a whole-hemisphere fit evaluated within the
//! elevation cut its validation renders prefer, without fitting the
//! functions again, with or without a shell factor beyond the cut.

use super::fit_parts::FitParts;
use super::{RenderErrors, SampleValues, Validator, RENDER_CHECK};
use crate::RenderError;
use brdf::{Brdf, FittedBrdf, ShellFactor, ShellLayout, SHELL_BIN_CHOICES, SHELL_CHOICES};
use serde::Serialize;
use std::sync::Arc;

/// The elevation cuts (degrees) [`choose_evaluation_cut`] tries besides
/// none. 65 degrees wins on two clear coats' slices (cc_iris_purple_gem
/// and cc_green_malachite, docs/results/fidelity-2026-12-05-replay.md);
/// each cut costs three more validations per fit, which evaluate the fit
/// only at the samples beyond the cut (the rest are the uncut fit's).
pub const EVALUATION_CUTS: [f64; 4] = [80.0, 75.0, 70.0, 65.0];

/// Cuts below [`EVALUATION_CUTS`], tried in turn while the lowest cut
/// measured gives the best evaluation: the clear coats' slices keep
/// improving below 65 degrees (docs/results/fidelity-2026-12-06-lower-cuts.md),
/// and a fit whose best cut is higher pays nothing for them.
pub const LOWER_CUTS: [f64; 2] = [60.0, 55.0];

/// Samples whose directions are this much (degrees) inside a cut take the
/// uncut fit's values: every evaluation path leaves them unmoved, in f32
/// as in f64, and the shell factor is 1 there.
const INSIDE_MARGIN_DEG: f64 = 0.01;

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
    /// Every evaluation measured, the fit as given first.
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
    /// Its cells, with a shell factor.
    pub shell_layout: Option<ShellLayout>,
    /// Bytes of the evaluation (f32), the shell factor included.
    pub bytes: usize,
    /// The worse scene's mean CIEDE2000.
    pub worst_mean_de: f64,
}

impl CutTried {
    fn label(&self) -> String {
        let cut = self.cut.map_or("none".to_string(), |c| format!("{c}"));
        match self.shell_layout {
            Some(layout) => format!("{cut}+shell {}", layout.label()),
            None => cut,
        }
    }
}

impl CutChoice {
    /// One line: the cut chosen and the error of each evaluation tried.
    pub fn describe(&self) -> String {
        let tried: Vec<String> = self
            .tried
            .iter()
            .map(|t| format!("{} {:.2} ({} B)", t.label(), t.worst_mean_de, t.bytes))
            .collect();
        let own = self.fitted.reduction.max_elevation_deg;
        let chosen = match (self.cut, self.fitted.shell.as_ref()) {
            (Some(c), Some(shell)) if self.shell => format!(
                "{c} degrees and a shell factor of {} bytes ({})",
                shell.byte_size_f32(),
                shell.layout().describe()
            ),
            (Some(c), _) => format!("{c} degrees"),
            (None, Some(_)) => {
                format!("none; the fit's own cut of {own} degrees and its shell factor")
            }
            (None, _) if own < 90.0 => format!("none; the fit's own cut of {own} degrees"),
            (None, _) => "none, the whole hemisphere".to_string(),
        };
        format!(
            "evaluation cut chosen by the validation renders: {chosen} (worse scene's mean CIEDE2000 and bytes by cut; +shell: with a shell factor of theta_h x theta_d cells beyond it, cos: theta_d bins uniform in cosine, colour: a factor per function: {})",
            tried.join(", ")
        )
    }
}

/// The index of the evaluation to keep among `tried`, among those within
/// `max_bytes` when any is (the first, the fit as given, is the smallest):
/// with a target, the fewest bytes among those whose worse scene reaches it
/// (the lower error between equal sizes); without one, or when none reaches
/// it, the lowest error (the fewer bytes between equal errors).
fn preferred(tried: &[CutTried], target_de: Option<f64>, max_bytes: Option<usize>) -> usize {
    let by_error = |a: &CutTried, b: &CutTried| {
        a.worst_mean_de
            .total_cmp(&b.worst_mean_de)
            .then(a.bytes.cmp(&b.bytes))
    };
    let within = |t: &CutTried| max_bytes.is_none_or(|m| t.bytes <= m);
    let any_within = tried.iter().any(within);
    let indexed = || {
        tried
            .iter()
            .enumerate()
            .filter(move |(_, t)| !any_within || within(t))
    };
    indexed()
        .filter(|(_, t)| target_de.is_some_and(|d| t.worst_mean_de <= d))
        .min_by(|(_, a), (_, b)| a.bytes.cmp(&b.bytes).then(by_error(a, b)))
        .or_else(|| indexed().min_by(|(_, a), (_, b)| by_error(a, b)))
        .map_or(0, |(k, _)| k)
}

/// A fit over the whole hemisphere (its reduction has no elevation cut)
/// evaluated within the cut among none, [`EVALUATION_CUTS`] and, in turn
/// while the lowest cut measured does best, [`LOWER_CUTS`], each
/// without and with a shell factor fitted to `table` beyond it
/// ([`brdf::ShellFactor`], in each layout of [`SHELL_BIN_CHOICES`], and
/// in the other layouts of [`SHELL_CHOICES`] at the cut that did best with
/// those), measured on
/// the validation renders. The evaluation kept has the lowest worse-scene
/// mean CIEDE2000 or, given `target_de`, the fewest bytes among those that
/// reach it (the smallest representation is what a target asks for); given
/// `max_bytes`, only evaluations within it are kept (a shell factor that
/// would pass it is not, and beside a fit with its own cut it is not
/// measured either), unless the fit alone passes it. The
/// functions are not fitted again: directions beyond the cut are moved onto
/// it ([`brdf::clamp_elevation`]), so grazing views show the fit's value at
/// the cut instead of its loosely bounded grazing cells (a silhouette under
/// a sky mirrors the bright horizon through them), and the shell factor
/// gives them the table's luminance there, cell by cell. `errors` are the
/// fit's own errors under `validator`. A fit with a cut of its own keeps
/// it, and is measured with the shell factors beyond it as well (`cut` is
/// then its own cut when a shell is chosen, `None` when none is).
///
/// # Errors
/// As [`Validator::measure`], and [`RenderError::Material`] when the shell
/// factor cannot be fitted (a table of non-finite values).
pub fn choose_evaluation_cut(
    validator: &Validator,
    table: &dyn Brdf,
    fitted: FittedBrdf,
    errors: RenderErrors,
    target_de: Option<f64>,
    max_bytes: Option<usize>,
) -> Result<CutChoice, RenderError> {
    let tried = vec![CutTried {
        cut: None,
        shell: fitted.shell.is_some(),
        shell_layout: fitted.shell.as_ref().map(ShellFactor::layout),
        bytes: fitted.byte_size_f32(),
        worst_mean_de: errors.worst_mean(),
    }];
    // (cut, the fit evaluated within it, whether that evaluation is still
    // to be measured): a fit with its own cut is measured already.
    let own = fitted.reduction.max_elevation_deg;
    let mut within: Vec<(f64, FittedBrdf, bool)> = if own < 90.0 {
        if fitted.shell.is_some() {
            Vec::new()
        } else {
            vec![(own, fitted.clone(), false)]
        }
    } else {
        EVALUATION_CUTS
            .iter()
            .filter_map(|&degrees| Some((degrees, fitted.evaluated_within(degrees)?, true)))
            .collect()
    };
    // With several cuts, the layouts added to the luminance factors of
    // SHELL_BIN_CHOICES are measured at the cut whose evaluations did best
    // only: each cut costs a validation per layout.
    let staged = within.len() > 1;
    let (first, more) = SHELL_CHOICES.split_at(if staged {
        SHELL_BIN_CHOICES.len()
    } else {
        SHELL_CHOICES.len()
    });
    let mut evaluations = Evaluations {
        validator,
        table,
        base_fit: fitted.clone(),
        bases: [None, None],
        parts: None,
        max_bytes,
        staged,
        tried,
        measured: vec![(fitted, errors)],
    };
    for stage in 0..2 {
        for job in stage_jobs(stage, &within, (first, more), &evaluations.tried) {
            evaluations.measure(job)?;
        }
        // Lower cuts while the lowest so far does best (whole-hemisphere
        // fits only: a fit with its own cut keeps it).
        if stage == 0 && own >= 90.0 {
            while let Some(degrees) = next_lower_cut(&evaluations.tried, within.last().map(|w| w.0))
            {
                let Some(plain) = evaluations.base_fit.evaluated_within(degrees) else {
                    break;
                };
                within.push((degrees, plain, true));
                let added = &within[within.len() - 1..];
                for job in stage_jobs(0, added, (first, more), &evaluations.tried) {
                    evaluations.measure(job)?;
                }
            }
        }
    }
    let Evaluations {
        tried,
        mut measured,
        ..
    } = evaluations;
    let k = preferred(&tried, target_de, max_bytes);
    let (fitted, errors) = measured.swap_remove(k);
    Ok(CutChoice {
        fitted,
        cut: if k == 0 { None } else { tried[k].cut },
        shell: tried[k].shell,
        errors,
        tried,
    })
}

/// The evaluations [`choose_evaluation_cut`] measured, in `tried` and
/// `measured` (the same order), and what their measurements share.
struct Evaluations<'a> {
    validator: &'a Validator,
    table: &'a dyn Brdf,
    /// The fit as given: every variant equals it within its cut, where
    /// most samples lie, so their values there come from one evaluation of
    /// it on each evaluation path (f32 or f64) a variant takes (`bases`).
    base_fit: FittedBrdf,
    bases: [Option<SampleValues>; 2],
    /// The f64 parts of the fit at the last cut measured on that path.
    parts: Option<FitParts>,
    max_bytes: Option<usize>,
    /// Several cuts are measured (the second stage's layouts at the best).
    staged: bool,
    tried: Vec<CutTried>,
    measured: Vec<(FittedBrdf, RenderErrors)>,
}

impl Evaluations<'_> {
    /// Measures `plain` (the fit within `degrees`) with the shell factor
    /// of `shell_layout`, if any, fitted to the table beyond the cut.
    fn measure(
        &mut self,
        (degrees, plain, shell_layout): (f64, &FittedBrdf, Option<ShellLayout>),
    ) -> Result<(), RenderError> {
        // With one cut, a layout that passes the byte budget beside a fit
        // within it can never be kept (`preferred` keeps evaluations within
        // the budget when there is one): it is not measured. With several,
        // every layout is measured, since the cut whose evaluations did
        // best chooses the second stage's.
        let shell_bytes = shell_layout.map_or(0, |l| l.byte_size_f32());
        let fit_bytes = plain.byte_size_f32();
        if !self.staged
            && self
                .max_bytes
                .is_some_and(|m| fit_bytes <= m && fit_bytes + shell_bytes > m)
        {
            return Ok(());
        }
        let material_error = |source| RenderError::Material {
            name: self.table.name(),
            source,
        };
        let variant = match shell_layout {
            Some(layout) => {
                let shell =
                    ShellFactor::fit_layout(self.table, plain, layout).map_err(material_error)?;
                plain.clone().with_shell(shell).map_err(material_error)?
            }
            None => plain.clone(),
        };
        let cos_inside = (degrees - INSIDE_MARGIN_DEG).to_radians().cos();
        let inside =
            move |wi: brdf::Vec3, wo: brdf::Vec3| wi[2] >= cos_inside && wo[2] >= cos_inside;
        let material = crate::FitInDomain::new(variant.clone());
        let path = material.uses_f32();
        let (validator, base_fit) = (self.validator, &self.base_fit);
        let base = self.bases[usize::from(path)].get_or_insert_with(|| {
            let on_path: Arc<dyn Brdf> =
                Arc::new(crate::FitInDomain::on_path(base_fit.clone(), path));
            validator.sample_values(&on_path)
        });
        let errors = if path {
            validator.measure_reusing(Arc::new(material), base, &inside)?
        } else {
            // In f64, the evaluations at one cut share the fit's functions
            // beyond it: only the shell factors differ.
            let parts = match self.parts.take() {
                Some(p) if p.cut_deg().to_bits() == degrees.to_bits() => p,
                _ => FitParts::new(validator, plain, &inside),
            };
            let errors =
                validator.measure_with_parts(Arc::new(material), &variant, base, &inside, &parts);
            self.parts = Some(parts);
            errors?
        };
        self.tried.push(CutTried {
            cut: Some(degrees),
            shell: shell_layout.is_some(),
            shell_layout,
            bytes: variant.byte_size_f32(),
            worst_mean_de: errors.worst_mean(),
        });
        self.measured.push((variant, errors));
        Ok(())
    }
}

/// The cut of the best evaluation within a cut among `tried` (the first
/// between equal errors); `None` when none has a cut.
fn best_cut(tried: &[CutTried]) -> Option<f64> {
    tried
        .iter()
        .filter(|t| t.cut.is_some())
        .min_by(|a, b| a.worst_mean_de.total_cmp(&b.worst_mean_de))
        .and_then(|t| t.cut)
}

/// The next of [`LOWER_CUTS`] below `lowest` (the lowest cut measured),
/// when the best evaluation of `tried` (the first between equal errors,
/// the fit as given included) is within `lowest`: the error still falls
/// as the cut comes down.
fn next_lower_cut(tried: &[CutTried], lowest: Option<f64>) -> Option<f64> {
    let lowest = lowest?;
    let best = tried
        .iter()
        .min_by(|a, b| a.worst_mean_de.total_cmp(&b.worst_mean_de))?;
    if best.cut != Some(lowest) {
        return None;
    }
    LOWER_CUTS.iter().copied().find(|&c| c < lowest)
}

/// The evaluations of one stage of [`choose_evaluation_cut`]: at stage 0
/// each cut of `within`, without a shell factor where it is still to be
/// measured and with each of the first layouts; at stage 1 the other
/// layouts at the cut whose evaluations in `tried` did best.
fn stage_jobs<'a>(
    stage: usize,
    within: &'a [(f64, FittedBrdf, bool)],
    (first, more): (&'a [ShellLayout], &'a [ShellLayout]),
    tried: &[CutTried],
) -> Vec<(f64, &'a FittedBrdf, Option<ShellLayout>)> {
    if stage == 0 {
        return within
            .iter()
            .flat_map(|(degrees, plain, measure_plain)| {
                let layouts = first.iter().map(|&l| Some(l));
                measure_plain
                    .then_some(None)
                    .into_iter()
                    .chain(layouts)
                    .map(move |l| (*degrees, plain, l))
            })
            .collect();
    }
    let best = best_cut(tried);
    within
        .iter()
        .filter(|(degrees, _, _)| Some(*degrees) == best)
        .flat_map(|(degrees, plain, _)| more.iter().map(move |&l| (*degrees, plain, Some(l))))
        .collect()
}

/// [`super::render_check`] with the evaluation cut chosen
/// ([`choose_evaluation_cut`]) on the same renders; the chosen
/// evaluation's errors carry its [`super::colour_split`].
///
/// # Errors
/// As [`Validator::new`] and [`Validator::measure`].
pub fn render_check_choosing_cut(
    table: Arc<dyn Brdf>,
    fitted: FittedBrdf,
) -> Result<CutChoice, RenderError> {
    let validator = Validator::new(table.clone(), RENDER_CHECK)?;
    let errors = validator.measure(Arc::new(crate::FitInDomain::new(fitted.clone())))?;
    let mut choice = choose_evaluation_cut(&validator, table.as_ref(), fitted, errors, None, None)?;
    choice.errors.images.clear();
    let chosen: Arc<dyn Brdf> = Arc::new(crate::FitInDomain::new(choice.fitted.clone()));
    choice.errors.colour_split = Some(super::colour_split(&validator, table, chosen)?);
    Ok(choice)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::fidelity::ValidationSettings;

    /// A glossy material, its 3-D fit over the whole hemisphere on a
    /// coarse grid, and small validation renders of it.
    fn glossy_fit() -> (brdf::BlinnPhong, FittedBrdf, Validator) {
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
        (glossy, fitted, validator)
    }

    /// Reusing the uncut fit's values inside a cut renders every variant
    /// (each cut, with and without a shell factor, on both evaluation
    /// paths) exactly as rendering it whole does.
    #[test]
    fn variants_inside_their_cut_reuse_the_uncut_values_to_the_last_bit() {
        let (glossy, fitted, validator) = glossy_fit();
        let mut reused = 0;
        for uses_f32 in [false, true] {
            let on_path = |fit: &FittedBrdf| -> Arc<dyn Brdf> {
                Arc::new(crate::FitInDomain::on_path(fit.clone(), uses_f32))
            };
            let base = validator.sample_values(&on_path(&fitted));
            for degrees in EVALUATION_CUTS {
                let plain = fitted.evaluated_within(degrees).unwrap();
                let shell = ShellFactor::fit(&glossy, &plain, [4, 4]).unwrap();
                let shelled = plain.clone().with_shell(shell).unwrap();
                let cos_inside = (degrees - INSIDE_MARGIN_DEG).to_radians().cos();
                let inside = move |wi: brdf::Vec3, wo: brdf::Vec3| {
                    wi[2] >= cos_inside && wo[2] >= cos_inside
                };
                for variant in [plain, shelled] {
                    let whole = validator.measure(on_path(&variant)).unwrap();
                    let fast = validator
                        .measure_reusing(on_path(&variant), &base, &inside)
                        .unwrap();
                    assert_eq!(whole.images.len(), fast.images.len());
                    for (a, b) in whole.images.iter().zip(&fast.images) {
                        assert!(a.pixels == b.pixels, "cut {degrees}, f32 {uses_f32}");
                    }
                    reused += 1;
                }
            }
        }
        assert_eq!(reused, 2 * 2 * EVALUATION_CUTS.len());
        // In f64, the fit's parts beyond each cut, taken once, give every
        // variant there (each shell layout) the render's values too.
        let base = validator.sample_values(&on_path_f64(&fitted));
        let mut shared = 0;
        for degrees in EVALUATION_CUTS {
            let plain = fitted.evaluated_within(degrees).unwrap();
            let cos_inside = (degrees - INSIDE_MARGIN_DEG).to_radians().cos();
            let inside =
                move |wi: brdf::Vec3, wo: brdf::Vec3| wi[2] >= cos_inside && wo[2] >= cos_inside;
            let parts = FitParts::new(&validator, &plain, &inside);
            let shelled = SHELL_CHOICES.iter().map(|&layout| {
                let shell = ShellFactor::fit_layout(&glossy, &plain, layout).unwrap();
                plain.clone().with_shell(shell).unwrap()
            });
            for variant in std::iter::once(plain.clone()).chain(shelled) {
                let whole = validator.measure(on_path_f64(&variant)).unwrap();
                let fast = validator
                    .measure_with_parts(on_path_f64(&variant), &variant, &base, &inside, &parts)
                    .unwrap();
                for (a, b) in whole.images.iter().zip(&fast.images) {
                    let bits = |i: &crate::image::Image| {
                        i.pixels
                            .iter()
                            .flat_map(|p| p.map(f32::to_bits))
                            .collect::<Vec<_>>()
                    };
                    assert!(bits(a) == bits(b), "cut {degrees}");
                }
                shared += 1;
            }
        }
        assert_eq!(shared, EVALUATION_CUTS.len() * (1 + SHELL_CHOICES.len()));
        // The uncut fit differs beyond a cut: reusing its values
        // everywhere would render another image.
        let base = validator.sample_values(&on_path_f64(&fitted));
        let cut = on_path_f64(&fitted.evaluated_within(65.0).unwrap());
        let everywhere = |_: brdf::Vec3, _: brdf::Vec3| true;
        let wrong = validator
            .measure_reusing(cut.clone(), &base, &everywhere)
            .unwrap();
        let right = validator.measure(cut).unwrap();
        assert!(wrong.images[1].pixels != right.images[1].pixels);
    }

    /// A lower cut is tried only while the lowest cut measured gives the
    /// best evaluation, the fit as given included, and only down to the
    /// last of the lower cuts.
    #[test]
    fn lower_cuts_follow_while_the_lowest_cut_does_best() {
        let t = |cut: Option<f64>, de: f64| CutTried {
            cut,
            shell: false,
            shell_layout: None,
            bytes: 100,
            worst_mean_de: de,
        };
        let standard = [t(None, 3.0), t(Some(80.0), 2.5), t(Some(65.0), 2.0)];
        let bits = |c: Option<f64>| c.map(f64::to_bits);
        assert_eq!(
            bits(next_lower_cut(&standard, Some(65.0))),
            bits(Some(LOWER_CUTS[0]))
        );
        // A higher cut, or the whole hemisphere, does best: no lower cut.
        let higher = [t(None, 3.0), t(Some(70.0), 1.5), t(Some(65.0), 2.0)];
        assert!(next_lower_cut(&higher, Some(65.0)).is_none());
        let whole = [t(None, 1.0), t(Some(65.0), 2.0)];
        assert!(next_lower_cut(&whole, Some(65.0)).is_none());
        // Equal errors: the first measured (the higher cut) is the best.
        let tie = [t(None, 3.0), t(Some(70.0), 2.0), t(Some(65.0), 2.0)];
        assert!(next_lower_cut(&tie, Some(65.0)).is_none());
        // Each lower cut in turn, then none below the last.
        let mut more = standard.to_vec();
        more.push(t(Some(LOWER_CUTS[0]), 1.0));
        assert_eq!(
            bits(next_lower_cut(&more, Some(LOWER_CUTS[0]))),
            bits(Some(LOWER_CUTS[1]))
        );
        let last = LOWER_CUTS[LOWER_CUTS.len() - 1];
        more.push(t(Some(last), 0.5));
        assert!(next_lower_cut(&more, Some(last)).is_none());
        assert!(next_lower_cut(&more, None).is_none());
    }

    fn on_path_f64(fit: &FittedBrdf) -> Arc<dyn Brdf> {
        Arc::new(crate::FitInDomain::on_path(fit.clone(), false))
    }

    #[test]
    fn the_cut_chosen_is_the_best_of_those_measured_and_cut_fits_are_kept() {
        let (glossy, fitted, validator) = glossy_fit();
        let errors = validator
            .measure(Arc::new(crate::FitInDomain::new(fitted.clone())))
            .unwrap();
        let whole = errors.worst_mean();
        let choice = choose_evaluation_cut(
            &validator,
            &glossy,
            fitted.clone(),
            errors.clone(),
            None,
            None,
        )
        .unwrap();
        // None and every cut measured, without and with each shell factor
        // on uniform luminance bins, and the other layouts at the best of
        // those cuts; the chosen one has the lowest error.
        let (first, more) = (
            SHELL_BIN_CHOICES.len(),
            SHELL_CHOICES.len() - SHELL_BIN_CHOICES.len(),
        );
        // The standard cuts, then the lower ones in turn while the lowest
        // did best.
        let mut measured_cuts: Vec<f64> = Vec::new();
        for c in choice.tried.iter().filter_map(|t| t.cut) {
            if !measured_cuts.iter().any(|m| m.to_bits() == c.to_bits()) {
                measured_cuts.push(c);
            }
        }
        let standard = EVALUATION_CUTS.len();
        let lower = &measured_cuts[standard..];
        let bits = |v: &[f64]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
        assert_eq!(bits(&measured_cuts[..standard]), bits(&EVALUATION_CUTS));
        assert_eq!(bits(lower), bits(&LOWER_CUTS[..lower.len()]));
        let cuts = measured_cuts.len();
        assert_eq!(choice.tried.len(), 1 + (1 + first) * cuts + more);
        assert_eq!(choice.shell, choice.fitted.shell.is_some());
        assert_eq!(
            choice.tried.iter().filter(|t| t.shell).count(),
            first * cuts + more
        );
        let stage_one = &choice.tried[1..1 + (1 + first) * cuts];
        let best_cut = stage_one
            .iter()
            .min_by(|a, b| a.worst_mean_de.total_cmp(&b.worst_mean_de))
            .unwrap()
            .cut;
        for t in &choice.tried[1 + (1 + first) * cuts..] {
            assert_eq!(t.cut, best_cut);
            assert!(!SHELL_BIN_CHOICES
                .iter()
                .any(|&bins| t.shell_layout == Some(ShellLayout::luminance(bins))));
        }
        for t in &choice.tried {
            let shell_bytes = t.shell_layout.map_or(0, |l| l.byte_size_f32());
            assert_eq!(t.bytes, fitted.byte_size_f32() + shell_bytes);
        }
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
        // A target every evaluation reaches takes the fewest bytes; one
        // none reaches, the lowest error.
        let reached = choose_evaluation_cut(
            &validator,
            &glossy,
            fitted.clone(),
            errors.clone(),
            Some(1e9),
            None,
        )
        .unwrap();
        assert_eq!(
            reached.fitted.byte_size_f32(),
            fitted.byte_size_f32(),
            "{}",
            reached.describe()
        );
        assert!(!reached.shell);
        let missed = choose_evaluation_cut(
            &validator,
            &glossy,
            fitted.clone(),
            errors.clone(),
            Some(1e-9),
            None,
        )
        .unwrap();
        assert!((missed.errors.worst_mean() - lowest).abs() < 1e-12);
        // A byte budget no shell factor fits in keeps the fit without one.
        let budget = fitted.byte_size_f32();
        let small = choose_evaluation_cut(
            &validator,
            &glossy,
            fitted.clone(),
            errors.clone(),
            None,
            Some(budget),
        )
        .unwrap();
        assert!(!small.shell && small.fitted.byte_size_f32() == budget);
        let plain_lowest = choice
            .tried
            .iter()
            .filter(|t| !t.shell)
            .map(|t| t.worst_mean_de)
            .fold(f64::INFINITY, f64::min);
        assert!((small.errors.worst_mean() - plain_lowest).abs() < 1e-12);
        // A fit that already has a cut keeps it, with or without the shell.
        let mut within = fitted;
        within.reduction = within.reduction.with_max_elevation(75.0);
        let errors = validator
            .measure(Arc::new(crate::FitInDomain::new(within.clone())))
            .unwrap();
        let kept = choose_evaluation_cut(
            &validator,
            &glossy,
            within.clone(),
            errors.clone(),
            None,
            None,
        )
        .unwrap();
        // Every layout at its own cut.
        assert_eq!(kept.tried.len(), 1 + SHELL_CHOICES.len());
        // Under a byte budget 48 bytes above the fit, the layouts that
        // would pass it are not measured, and the choice is the best of
        // the full measurement within the budget.
        let budget = within.byte_size_f32() + 48;
        let budgeted = choose_evaluation_cut(
            &validator,
            &glossy,
            within.clone(),
            errors,
            None,
            Some(budget),
        )
        .unwrap();
        let fits = |t: &&CutTried| t.bytes <= budget;
        let affordable: Vec<&CutTried> = kept.tried.iter().filter(fits).collect();
        assert_eq!(
            affordable.len(),
            3,
            "the fit, 1 x 4 cos and 1 x 4 cos colour"
        );
        assert_eq!(budgeted.tried.len(), affordable.len());
        assert!(budgeted.tried.iter().all(|t| t.bytes <= budget));
        let best = affordable
            .iter()
            .map(|t| t.worst_mean_de)
            .fold(f64::INFINITY, f64::min);
        assert!((budgeted.errors.worst_mean() - best).abs() < 1e-12);
        for t in &kept.tried[1..] {
            assert_eq!((t.cut, t.shell), (Some(75.0), true));
        }
        assert_eq!(kept.fitted.reduction, within.reduction);
        if kept.shell {
            assert_eq!(kept.cut, Some(75.0));
            let bytes = kept.fitted.shell.as_ref().unwrap().byte_size_f32();
            assert!(kept
                .describe()
                .contains(&format!("75 degrees and a shell factor of {bytes} bytes")));
        } else {
            assert_eq!(kept.cut, None);
            assert!(kept.describe().contains("the fit's own cut of 75 degrees"));
        }
        // With its shell it is measured as it is.
        let shelled = within
            .clone()
            .with_shell(ShellFactor::fit(&glossy, &within, brdf::DEFAULT_SHELL_BINS).unwrap())
            .unwrap();
        let errors = validator
            .measure(Arc::new(crate::FitInDomain::new(shelled.clone())))
            .unwrap();
        let kept = choose_evaluation_cut(&validator, &glossy, shelled, errors, None, None).unwrap();
        assert_eq!((kept.cut, kept.shell, kept.tried.len()), (None, true, 1));
        assert!(kept
            .describe()
            .contains("own cut of 75 degrees and its shell factor"));
    }

    fn tried(worst_mean_de: f64, bytes: usize) -> CutTried {
        CutTried {
            cut: Some(70.0),
            shell: true,
            shell_layout: Some(ShellLayout::luminance([4, 4])),
            bytes,
            worst_mean_de,
        }
    }

    #[test]
    fn a_target_prefers_the_smallest_evaluation_that_reaches_it() {
        let list = [
            tried(1.4, 960),
            tried(1.1, 1088),
            tried(0.97, 1024),
            tried(0.95, 1088),
        ];
        // Without a target, or one none reaches: the lowest error.
        assert_eq!(preferred(&list, None, None), 3);
        assert_eq!(preferred(&list, Some(0.5), None), 3);
        // The smallest that reaches it; the lower error between equal sizes.
        assert_eq!(preferred(&list, Some(1.0), None), 2);
        assert_eq!(preferred(&list, Some(1.2), None), 2);
        assert_eq!(preferred(&list, Some(1.5), None), 0);
        // Equal errors: the fewer bytes.
        assert_eq!(
            preferred(&[tried(1.0, 1088), tried(1.0, 1024)], None, None),
            1
        );
        // A byte budget leaves out what passes it, unless everything does.
        assert_eq!(preferred(&list, None, Some(1024)), 2);
        assert_eq!(preferred(&list, Some(0.5), Some(1000)), 0);
        assert_eq!(preferred(&list, Some(1.0), Some(1000)), 0);
        assert_eq!(preferred(&list, None, Some(900)), 3);
    }
}
