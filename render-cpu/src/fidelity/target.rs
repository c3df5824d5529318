//! [`fit_to_target`]: the smallest perceptual fit whose validation renders
//! reach a mean CIEDE2000.

use super::{
    choose_evaluation_cut, RenderErrors, SceneError, ValidationScene, ValidationSettings, Validator,
};
use crate::RenderError;
use brdf::Brdf;
use serde::Serialize;
use std::sync::Arc;
use std::time::Instant;
/// Which reductions [`fit_to_target`] may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum TargetReduction {
    /// The 2-D `phi_d = pi/2` slice first (fewer bytes, fast fits); the
    /// 3-D grid when the slice's fits stop improving above the target.
    Auto,
    /// The base settings' reduction only.
    Fixed,
}

/// One fit tried by [`fit_to_target`].
#[derive(Debug, Clone, Serialize)]
pub struct TargetAttempt {
    /// Fitting coordinates: 2 (the slice) or 3.
    pub dims: usize,
    /// Perceptual relative half-width.
    pub rel_tol: f64,
    /// Bytes (f32) and the worse mean CIEDE2000 of the two scenes; `None`
    /// when no fit within the coefficient budget meets these intervals.
    pub result: Option<(usize, f64)>,
    /// The largest factor a channel's intervals were widened by (1: none).
    pub widened: f64,
    /// The evaluation cut chosen for this fit by the validation renders
    /// (degrees; `None`: the whole hemisphere). See
    /// [`super::choose_evaluation_cut`].
    pub cut: Option<f64>,
    /// Whether a shell factor beyond that cut was chosen with it.
    pub shell: bool,
}

/// The table averaged over the cells of the grid a 3-D fit samples
/// ([`brdf::DownsampledTable`], interpolated between cell centres) and
/// rendered on the validation scenes: what that sampling alone loses. A
/// fit of those samples rarely renders much below it, so a target under it
/// asks for a finer grid (`theta_h` first) before tighter intervals.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct GridFloor {
    /// `theta_h`, `theta_d` and `phi_d` bins of the grid.
    pub bins: [usize; 3],
    /// The larger mean CIEDE2000 of the two scenes.
    pub worst_mean_de: f64,
}

/// What [`fit_to_target`] reached.
#[derive(Debug, Clone, Serialize)]
pub struct TargetReport {
    /// The target: mean CIEDE2000 on both validation scenes.
    pub target_de: f64,
    /// Whether the chosen fit reaches it.
    pub reached: bool,
    /// Fitting coordinates of the chosen fit.
    pub dims: usize,
    /// Why this reduction was chosen.
    pub why: String,
    /// The perceptual half-width of the chosen fit.
    pub rel_tol: f64,
    /// Bytes of the chosen fit (f32).
    pub bytes: usize,
    /// The evaluation cut chosen by the validation renders for a fit over
    /// the whole hemisphere (degrees; `None`: none).
    pub evaluation_cut: Option<f64>,
    /// Bytes of the shell factor beyond that cut ([`brdf::ShellFactor`]),
    /// included in `bytes`, when the renders chose one.
    pub shell_bytes: Option<usize>,
    /// Its render errors, lights first.
    pub scenes: Vec<SceneError>,
    /// The table against itself with another seed (noise of the comparison).
    pub noise: Vec<SceneError>,
    /// When the target is not reached by a 3-D fit: what the table itself
    /// renders at on the grid that fit samples (see [`GridFloor`]).
    pub grid_floor: Option<GridFloor>,
    /// When the target is not reached: the render error of the fit's
    /// luminance alone and of its colour alone ([`super::colour_split`]),
    /// which says which functions to improve.
    pub colour_split: Option<super::ColourSplit>,
    /// Every fit tried, in order.
    pub tried: Vec<TargetAttempt>,
    /// Total time in seconds (fits and renders).
    pub seconds: f64,
}

impl std::fmt::Display for TargetReport {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "target mean CIEDE2000 <= {}: {} with a {}-D fit, perceptual intervals of +-{}% ({} bytes)",
            self.target_de,
            if self.reached {
                "reached"
            } else {
                "NOT reached; the closest fit within the budget"
            },
            self.dims,
            self.rel_tol * 100.0,
            self.bytes
        )?;
        writeln!(f, "  {}", self.why)?;
        if let Some(c) = self.evaluation_cut {
            writeln!(
                f,
                "  evaluated within {c} degrees of the normal (directions beyond moved onto the cut; chosen by the validation renders)"
            )?;
        }
        if let Some(b) = self.shell_bytes {
            writeln!(
                f,
                "  beyond the cut, a shell factor of {b} bytes scales the fit to the table's luminance, cell by cell of theta_h x theta_d (chosen by the validation renders)"
            )?;
        }
        for (k, scene) in ValidationScene::ALL.iter().enumerate() {
            writeln!(
                f,
                "  {:<6} mean CIEDE2000 {:.3}, p99 {:.2} (table against itself: {:.3})",
                scene.name(),
                self.scenes[k].mean_de,
                self.scenes[k].p99_de,
                self.noise[k].mean_de
            )?;
        }
        if let Some(g) = self.grid_floor {
            let [h, d, p] = g.bins;
            writeln!(
                f,
                "  the table itself, averaged over the {h} x {d} x {p} grid the fit samples, renders at {:.3} (worse scene){}",
                g.worst_mean_de,
                if g.worst_mean_de > self.target_de {
                    ": the target needs a finer grid (theta_h first)"
                } else {
                    ""
                }
            )?;
        }
        if let Some(split) = &self.colour_split {
            writeln!(f, "  {}", split.describe("the fit"))?;
        }
        for a in &self.tried {
            match a.result {
                Some((bytes, worst)) => writeln!(
                    f,
                    "  tried {}-D +-{}%{}: {bytes} bytes, worse mean CIEDE2000 {worst:.3}{}",
                    a.dims,
                    a.rel_tol * 100.0,
                    if a.widened > 1.0 {
                        format!(" (widened x{})", brdf::scale_text(a.widened))
                    } else {
                        String::new()
                    },
                    a.cut.map_or(String::new(), |c| format!(
                        " evaluated within {c} degrees{}",
                        if a.shell { " with a shell factor" } else { "" }
                    ))
                )?,
                None => writeln!(
                    f,
                    "  tried {}-D +-{}%: no fit within the coefficient budget",
                    a.dims,
                    a.rel_tol * 100.0
                )?,
            }
        }
        write!(f, "  {:.1} s", self.seconds)
    }
}

/// The best fit of one reduction and every attempt.
struct Search {
    /// The fit, its errors, its tolerance and the evaluation cut chosen.
    best: Option<(brdf::FittedBrdf, RenderErrors, f64, Option<f64>)>,
    tried: Vec<TargetAttempt>,
}

impl Search {
    fn worst(&self) -> f64 {
        self.best
            .as_ref()
            .map_or(f64::INFINITY, |b| b.1.worst_mean())
    }
}

/// Bins (`theta_h`, `theta_d`, `phi_d`) of the 3-D grid a target fit
/// samples unless its caller names one. A finer grid renders closer as a
/// table, but its fits need more coefficients at the same intervals and are
/// widened sooner: on the RGL files a 16^3 grid reaches lower errors in
/// fewer bytes than 24^3 (docs/results/fidelity-2026-12-04-target-grid.md).
pub const TARGET_GRID_3D: [usize; 3] = [16, 16, 16];

/// Bins (`theta_h`, `theta_d`) of the 2-D slice a target fit samples.
pub const TARGET_SLICE: [usize; 2] = [90, 90];

/// `reduction` on the grid a target fit samples unless its caller names
/// one: [`TARGET_GRID_3D`] for a 3-D reduction, [`TARGET_SLICE`] for a 2-D
/// one.
pub fn on_target_grid(reduction: brdf::Reduction) -> brdf::Reduction {
    if reduction.kind == brdf::ReductionKind::Full3d {
        let [h, d, p] = TARGET_GRID_3D;
        reduction.with_resolution(h, d).with_phi_resolution(p)
    } else {
        let [h, d] = TARGET_SLICE;
        reduction.with_resolution(h, d)
    }
}

/// Tolerances tried, loosest first.
const TOLERANCES: [f64; 4] = [0.16, 0.08, 0.04, 0.02];

/// Tolerances looser than [`TOLERANCES`], tried when none of them is
/// feasible within the coefficient budget.
const LOOSER: [f64; 2] = [0.32, 0.64];

/// Each widening of a target fit's intervals. Each function is fitted on
/// its own, so only one that misses its tolerance is widened, and it lands
/// at 1.41 times the tolerance rather than 2.
const WIDEN_STEP: f64 = std::f64::consts::SQRT_2;

/// Widenings allowed, to at most twice the tolerance ([`WIDEN_STEP`]
/// squared).
const MAX_WIDENINGS: usize = 2;

/// Tries tolerances with `settings`' reduction, loosest first, until one
/// reaches the target, `deadline` passes (checked between fits), a
/// tolerance has no fit within the coefficient budget (tighter ones would
/// not either), or, with `stop_at_floor`, a tighter tolerance improves the
/// error by less than 10% (the reduction's own error dominates). When even
/// the loosest has no fit, looser ones follow. A channel's intervals are
/// widened by [`WIDEN_STEP`] at most [`MAX_WIDENINGS`] times (reported):
/// widened further, a perceptual design's floors and caps stop meaning
/// anything.
fn search_tolerances(
    validator: &Validator,
    table: &Arc<dyn Brdf>,
    target_de: f64,
    settings: &brdf::BrdfFitSettings,
    tolerances: usize,
    deadline: (Instant, f64),
    stop_at_floor: bool,
) -> Result<Search, RenderError> {
    let design = settings.design().copied().unwrap_or_default();
    let dims = settings.reduction().dims();
    let engine = settings
        .fit_settings()
        .clone()
        .with_widening(WIDEN_STEP, MAX_WIDENINGS)
        .map_err(|e| crate::error::invalid("fit settings", e.to_string()))?;
    let mut search = Search {
        best: None,
        tried: Vec::new(),
    };
    let mut previous = f64::INFINITY;
    let mut queue: Vec<f64> = TOLERANCES[..tolerances].to_vec();
    let (mut k, mut loosened) = (0, false);
    while k < queue.len() {
        let t = queue[k];
        k += 1;
        let s = settings
            .clone()
            .with_fit_settings(engine.clone())
            .with_design(brdf::PerceptualBounds {
                rel_tol: t,
                ..design
            });
        let (fitted, widened) = match brdf::fit_brdf(table.as_ref(), &s) {
            Ok((f, r)) => {
                let w = r
                    .channels
                    .iter()
                    .map(|c| c.interval_scale)
                    .fold(1.0, f64::max);
                (f, w)
            }
            Err(brdf::BrdfError::Fit {
                source: rational_core::FitError::NoFeasibleFit { .. },
                ..
            }) => {
                search.tried.push(TargetAttempt {
                    dims,
                    rel_tol: t,
                    result: None,
                    widened: 1.0,
                    cut: None,
                    shell: false,
                });
                if search.best.is_none() && !loosened {
                    // Even the loosest is infeasible: loosen instead.
                    queue = LOOSER.to_vec();
                    k = 0;
                    loosened = true;
                    continue;
                }
                if search.best.is_none() && k < queue.len() {
                    continue;
                }
                break;
            }
            Err(e) => {
                return Err(RenderError::Material {
                    name: table.name(),
                    source: e,
                })
            }
        };
        let errors = validator.measure(Arc::new(crate::scene::FitInDomain::new(fitted.clone())))?;
        let choice =
            choose_evaluation_cut(validator, table.as_ref(), fitted, errors, Some(target_de))?;
        let (fitted, errors) = (choice.fitted, choice.errors);
        let worst = errors.worst_mean();
        search.tried.push(TargetAttempt {
            dims,
            rel_tol: t,
            result: Some((fitted.byte_size_f32(), worst)),
            widened,
            cut: choice.cut,
            shell: choice.shell,
        });
        let reached = worst <= target_de;
        if reached || worst < search.worst() {
            search.best = Some((fitted, errors, t, choice.cut));
        }
        let at_floor = stop_at_floor && worst > 0.9 * previous;
        previous = previous.min(worst);
        // Among the loosened tolerances the first feasible one is the best.
        if reached || at_floor || loosened || deadline.0.elapsed().as_secs_f64() > deadline.1 {
            break;
        }
    }
    Ok(search)
}

/// The smallest perceptual fit whose validation renders reach mean
/// CIEDE2000 `<= target_de` on both scenes. The fits cover the whole
/// hemisphere unless `base` has an elevation cut; each whole-hemisphere
/// fit is judged at the evaluation cut its renders prefer
/// ([`super::choose_evaluation_cut`]). Tolerances from
/// `+-16%` down to `+-2%` are tried in turn (looser intervals give fewer
/// coefficients, usually), stopping at the first that reaches the target
/// or when `budget_s` is spent (checked between fits, so the last fit may
/// run past it); when none does, the fit with the lowest error is returned
/// and the report says so.
///
/// With [`TargetReduction::Auto`], the 2-D slice (90 x 90 grid) is tried
/// first, at most 40% of the budget: it costs fewer bytes, but its
/// error stops falling at what the reduction itself loses (a tighter
/// tolerance that improves by less than 10% ends it). The 3-D fits of
/// `base` follow unless the slice reached the target; the report names
/// the reduction chosen, why, and the slice's best error. With
/// [`TargetReduction::Fixed`], `base`'s reduction alone is used. `base`
/// gives the engine, grid and design (its relative half-width is
/// replaced). When a 3-D fit does not reach the target, the report also
/// gives what the table itself renders at on that fit's grid
/// ([`GridFloor`]).
///
/// # Errors
/// A non-positive target, or a fit or render that fails.
pub fn fit_to_target(
    table: Arc<dyn Brdf>,
    target_de: f64,
    base: &brdf::BrdfFitSettings,
    reduction: TargetReduction,
    validation: ValidationSettings,
    budget_s: f64,
) -> Result<(brdf::FittedBrdf, TargetReport), RenderError> {
    let start = Instant::now();
    if !(target_de > 0.0 && target_de.is_finite()) {
        return Err(crate::error::invalid(
            "target_de",
            format!("{target_de} is not a positive number"),
        ));
    }
    let validator = Validator::new(table.clone(), validation)?;
    let mut tried = Vec::new();
    let mut slice: Option<Search> = None;
    if reduction == TargetReduction::Auto {
        let r = on_target_grid(
            base.reduction()
                .with_kind(brdf::ReductionKind::Slice2d)
                .whole_hemisphere(),
        );
        let settings = base.clone().with_reduction(r);
        let s = search_tolerances(
            &validator,
            &table,
            target_de,
            &settings,
            3,
            (start, 0.4 * budget_s),
            true,
        )?;
        tried.extend(s.tried.iter().cloned());
        slice = Some(s);
    }
    let slice_reached = slice.as_ref().is_some_and(|s| s.worst() <= target_de);
    let full = if slice_reached {
        None
    } else {
        let s = search_tolerances(
            &validator,
            &table,
            target_de,
            base,
            TOLERANCES.len(),
            (start, budget_s),
            false,
        )?;
        tried.extend(s.tried.iter().cloned());
        Some(s)
    };
    let slice_worst = slice.as_ref().map_or(f64::INFINITY, Search::worst);
    let full_worst = full.as_ref().map_or(f64::INFINITY, Search::worst);
    let why = match (&slice, &full) {
        (Some(_), None) => {
            format!("the 2-D slice reaches the target ({slice_worst:.3}); no 3-D fit needed")
        }
        (Some(_), Some(_)) => format!(
            "the 2-D slice's best fit renders at {slice_worst:.3} (what the reduction loses); \
             the {}-D fits reach {full_worst:.3}",
            base.reduction().dims()
        ),
        _ => format!("the {}-D reduction was asked for", base.reduction().dims()),
    };
    let chosen = match (slice, full) {
        (Some(s), Some(f)) if s.worst() < f.worst() => s,
        (Some(s), None) => s,
        (_, Some(f)) => f,
        (None, None) => unreachable!("one reduction is always searched"),
    };
    let Some((fitted, errors, rel_tol, evaluation_cut)) = chosen.best else {
        return Err(crate::error::invalid(
            "target_de",
            format!(
                "no perceptual fit of {} within the coefficient budget, even at +-{}%",
                table.name(),
                LOOSER[LOOSER.len() - 1] * 100.0
            ),
        ));
    };
    let reached = errors.worst_mean() <= target_de;
    let grid_floor = if !reached && fitted.reduction.kind == brdf::ReductionKind::Full3d {
        let r = &fitted.reduction;
        let bins = [r.n_theta_h, r.n_theta_d, r.n_phi_d];
        let on_grid = brdf::DownsampledTable::new(table.as_ref(), bins);
        Some(GridFloor {
            bins,
            worst_mean_de: validator.measure(Arc::new(on_grid))?.worst_mean(),
        })
    } else {
        None
    };
    let colour_split = if reached {
        None
    } else {
        let candidate: Arc<dyn Brdf> = Arc::new(crate::scene::FitInDomain::new(fitted.clone()));
        Some(super::colour_split(&validator, table.clone(), candidate)?)
    };
    let report = TargetReport {
        target_de,
        reached,
        grid_floor,
        colour_split,
        dims: fitted.reduction.dims(),
        why,
        rel_tol,
        bytes: fitted.byte_size_f32(),
        evaluation_cut,
        shell_bytes: fitted.shell.as_ref().map(brdf::ShellFactor::byte_size_f32),
        scenes: errors.scenes.clone(),
        noise: validator.noise.clone(),
        tried,
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((fitted, report))
}
