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
mod tests;
