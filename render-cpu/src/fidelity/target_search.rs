//! The search of one reduction for [`super::fit_to_target`]: tolerances
//! tried in turn, each fit widened at most twice, measured on the
//! validation renders and given its evaluation cut.

use super::target_report::{TargetAttempt, TargetBudget};
use super::{choose_evaluation_cut, RenderErrors, Validator};
use crate::RenderError;
use brdf::Brdf;
use std::sync::Arc;
use std::time::Instant;

/// The best fit of one reduction and every attempt.
pub(super) struct Search {
    pub(super) best: Best,
    pub(super) tried: Vec<TargetAttempt>,
}

impl Search {
    pub(super) fn worst(&self) -> f64 {
        self.best
            .as_ref()
            .map_or(f64::INFINITY, |b| b.errors.worst_mean())
    }
}

/// The best fit of a search, if any, with its attempt.
pub(super) type Best = Option<Measured>;

/// Tolerances tried, loosest first.
pub(super) const TOLERANCES: [f64; 4] = [0.16, 0.08, 0.04, 0.02];

/// Tolerances looser than [`TOLERANCES`], tried when none of them is
/// feasible within the coefficient budget.
pub(super) const LOOSER: [f64; 2] = [0.32, 0.64];

/// The loosest tolerance tried when fits pass the byte budget.
const LOOSEST: f64 = LOOSER[LOOSER.len() - 1];

/// Tolerances after `t` tried when its fit passes the byte budget: looser
/// by sqrt 2 each, up to [`LOOSEST`] (fewer coefficients, and bytes are
/// what is short).
fn looser_for_bytes(t: f64) -> Vec<f64> {
    (1..)
        .map(|k| t * std::f64::consts::SQRT_2.powi(k))
        .take_while(|&u| u <= LOOSEST * (1.0 + 1e-9))
        .collect()
}

/// Each widening of a target fit's intervals. Each function is fitted on
/// its own, so only one that misses its tolerance is widened, and it lands
/// at 1.41 times the tolerance rather than 2.
const WIDEN_STEP: f64 = std::f64::consts::SQRT_2;

/// Widenings allowed, to at most twice the tolerance ([`WIDEN_STEP`]
/// squared).
const MAX_WIDENINGS: usize = 2;

/// How many times a search bisects (geometrically) the bracket between a
/// tolerance whose fit is within the byte budget and a tighter one past
/// it: twice narrows a factor of 2 to 2^(1/4), about 19%.
const MAX_REFINEMENTS: usize = 2;

/// The engine of a target fit: `settings`' with the target's widening,
/// and no function given more coefficients than the byte budget holds (its
/// fits stop there and widen instead of searching sizes that could not be
/// returned). In RGB each channel carries the material's whole shape, so
/// the three need about as many coefficients each and each is held to an
/// even third; in luminance-chroma the luminance alone carries it.
fn target_engine(
    settings: &brdf::BrdfFitSettings,
    budget: TargetBudget,
) -> Result<rational_core::FitSettings, RenderError> {
    let invalid = |e: rational_core::FitError| crate::error::invalid("fit settings", e.to_string());
    let mut engine = settings
        .fit_settings()
        .clone()
        .with_widening(WIDEN_STEP, MAX_WIDENINGS)
        .map_err(invalid)?;
    if let Some(bytes) = budget.bytes {
        let (lo, hi) = engine.coeff_range();
        let sharing = match settings.colour_mode() {
            brdf::ColourMode::Rgb => settings.colour_mode().names().len(),
            _ => 1,
        };
        let cap = (bytes / 4 / sharing).max(lo);
        if cap < hi {
            engine = engine.with_coeff_range(lo, cap).map_err(invalid)?;
        }
    }
    Ok(engine)
}

/// Coefficients per function when a byte budget is split evenly between
/// the fitted functions (at least the engine's smallest budget).
pub(super) fn split_cap(settings: &brdf::BrdfFitSettings, bytes: usize) -> usize {
    let functions = settings.colour_mode().names().len();
    let (lo, hi) = settings.fit_settings().coeff_range();
    (bytes / 4 / functions).clamp(lo, hi.max(lo))
}

/// The 3-D search of `base` with each function held to an even share of
/// the byte budget ([`split_cap`]): run when no fit with the whole budget
/// for each function came within it, so that each function is widened (or
/// the tolerance loosened) until the three together fit.
pub(super) fn split_budget_search(
    goal: &Goal,
    base: &brdf::BrdfFitSettings,
    bytes: usize,
    deadline_s: f64,
) -> Result<Search, RenderError> {
    let (lo, _) = base.fit_settings().coeff_range();
    let engine = base
        .fit_settings()
        .clone()
        .with_coeff_range(lo, split_cap(base, bytes))
        .map_err(|e| crate::error::invalid("fit settings", e.to_string()))?;
    let settings = base.clone().with_fit_settings(engine);
    search_tolerances(goal, &settings, &TOLERANCES, deadline_s, false)
}

/// What every fit of one [`super::fit_to_target`] call is judged against.
pub(super) struct Goal<'a> {
    pub(super) validator: &'a Validator,
    pub(super) table: &'a Arc<dyn Brdf>,
    pub(super) target_de: f64,
    pub(super) budget: TargetBudget,
    pub(super) start: Instant,
}

/// The elevation cut `settings` fits within, if any.
fn fitted_within(settings: &brdf::BrdfFitSettings) -> Option<f64> {
    let degrees = settings.reduction().max_elevation_deg;
    (degrees < 90.0).then_some(degrees)
}

/// One tolerance's fit, evaluated within the cut its renders prefer.
pub(super) struct Measured {
    pub(super) fitted: brdf::FittedBrdf,
    pub(super) errors: RenderErrors,
    pub(super) attempt: TargetAttempt,
}

/// The fit of `settings` at perceptual half-width `t`, measured and given
/// its evaluation cut ([`choose_evaluation_cut`], within the byte budget
/// when it can be; none when its functions alone pass it); `Err(name)`
/// names the first function (in the colour mode's order) with no fit
/// within the coefficient budget.
pub(super) fn fit_at(
    goal: &Goal,
    settings: &brdf::BrdfFitSettings,
    t: f64,
) -> Result<Result<Measured, char>, RenderError> {
    let started = Instant::now();
    let (validator, table, budget) = (goal.validator, goal.table, goal.budget);
    let design = settings.design().copied().unwrap_or_default();
    let s = settings.clone().with_design(brdf::PerceptualBounds {
        rel_tol: t,
        ..design
    });
    let (fitted, widened, limiting) = match brdf::fit_brdf(table.as_ref(), &s) {
        Ok((f, r)) => {
            let scales: Vec<f64> = r.channels.iter().map(|c| c.interval_scale).collect();
            let w = scales.iter().copied().fold(1.0, f64::max);
            // The first function widened most (the luminance between ties).
            let first_widest =
                (0..scales.len()).max_by(|&a, &b| scales[a].total_cmp(&scales[b]).then(b.cmp(&a)));
            let limiting = first_widest
                .filter(|_| w > 1.0)
                .map(|c| settings.colour_mode().names()[c]);
            (f, w, limiting)
        }
        Err(brdf::BrdfError::Fit {
            channel,
            source: rational_core::FitError::NoFeasibleFit { .. },
        }) => return Ok(Err(channel)),
        Err(e) => {
            return Err(RenderError::Material {
                name: table.name(),
                source: e,
            })
        }
    };
    let errors = validator.measure(Arc::new(crate::scene::FitInDomain::new(fitted.clone())))?;
    // A fit whose functions alone pass the byte budget passes it at every
    // cut, with or without a shell: it can never be returned, so its
    // evaluation cut is not chosen (a validation per cut and layout).
    let (fitted, errors, cut, shell) = if budget.passed_by(fitted.byte_size_f32()) {
        (fitted, errors, None, false)
    } else {
        let choice = choose_evaluation_cut(
            validator,
            table.as_ref(),
            fitted,
            errors,
            Some(goal.target_de),
            budget.bytes,
        )?;
        (choice.fitted, choice.errors, choice.cut, choice.shell)
    };
    let bytes = fitted.byte_size_f32();
    let attempt = TargetAttempt {
        dims: settings.reduction().dims(),
        colour: settings.colour_mode(),
        scale: settings.value_scale(),
        rel_tol: t,
        seconds: started.elapsed().as_secs_f64(),
        result: Some((bytes, errors.worst_mean())),
        widened,
        limiting,
        cut,
        shell,
        over_budget: budget.passed_by(bytes),
        fitted_within: fitted_within(settings),
    };
    Ok(Ok(Measured {
        fitted,
        errors,
        attempt,
    }))
}

/// Tries tolerances with `settings`' reduction, loosest first, until one
/// reaches the target, `deadline` passes (checked between fits), a
/// tolerance has no fit within the coefficient budget or passes the byte
/// budget (tighter ones would not do better), or, with `stop_at_floor`, a
/// tighter tolerance improves the error by less than 10% (the reduction's
/// own error dominates). When even the loosest has no fit, looser ones
/// follow; when its fit passes the byte budget, looser ones by sqrt 2
/// follow until one fits within it. A fit within the byte budget and a
/// tighter one past it bracket the tightest tolerance within it: the
/// tolerance halfway (geometrically) between them is tried, and once more
/// between it and the bracket's other end ([`MAX_REFINEMENTS`]). Both go
/// on past the deadline while the search has no fit within the budgets. A channel's intervals are
/// widened by [`WIDEN_STEP`] at most [`MAX_WIDENINGS`] times (reported):
/// widened further, a perceptual design's floors and caps stop meaning
/// anything.
pub(super) fn search_tolerances(
    goal: &Goal,
    settings: &brdf::BrdfFitSettings,
    tolerances: &[f64],
    deadline_s: f64,
    stop_at_floor: bool,
) -> Result<Search, RenderError> {
    // The tolerances of one search share their proofs of no fit: a
    // tighter tolerance, or a looser one after the widest widening, is not
    // solved again where they cover it.
    let settings = settings
        .clone()
        .with_fit_settings(target_engine(settings, goal.budget)?)
        .with_no_fit_memo(brdf::NoFitMemo::new());
    let mut search = Search {
        best: None,
        tried: Vec::new(),
    };
    let mut previous = f64::INFINITY;
    let mut queue: Vec<f64> = tolerances.to_vec();
    let (mut k, mut loosened, mut loosened_for_bytes) = (0, false, false);
    // The last tolerance whose fit passed the byte budget, the last whose
    // fit was within it (they bracket the tightest within it), and how many
    // tolerances between them were tried.
    let (mut over_at, mut within_at, mut refinements): (Option<f64>, Option<f64>, usize) =
        (None, None, 0);
    let past_deadline = || goal.start.elapsed().as_secs_f64() > deadline_s;
    while k < queue.len() {
        let t = queue[k];
        k += 1;
        let started = Instant::now();
        let m = match fit_at(goal, &settings, t)? {
            Ok(m) => m,
            Err(function) => {
                search.tried.push(TargetAttempt {
                    dims: settings.reduction().dims(),
                    colour: settings.colour_mode(),
                    scale: settings.value_scale(),
                    rel_tol: t,
                    seconds: started.elapsed().as_secs_f64(),
                    result: None,
                    widened: 1.0,
                    limiting: Some(function),
                    cut: None,
                    shell: false,
                    over_budget: false,
                    fitted_within: fitted_within(&settings),
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
        };
        let over_budget = m.attempt.over_budget;
        let worst = m.errors.worst_mean();
        search.tried.push(m.attempt.clone());
        if over_budget {
            over_at = Some(t);
            if let Some(within) = within_at {
                // Between a fit within the budget and this tighter one past
                // it, the tolerance halfway (geometrically); tighter ones
                // only grow.
                if refinements < MAX_REFINEMENTS && !past_deadline() {
                    queue = vec![(within * t).sqrt()];
                    k = 0;
                    refinements += 1;
                    continue;
                }
                break;
            }
            // Nothing within the byte budget yet: looser tolerances follow
            // even past the deadline, as they do when nothing is feasible
            // (a search cut here returns nothing for the time it spent).
            if !loosened_for_bytes {
                queue = looser_for_bytes(t);
                k = 0;
                loosened_for_bytes = true;
            }
            continue;
        }
        within_at = Some(t);
        let reached = worst <= goal.target_de;
        if reached || worst < search.worst() {
            search.best = Some(m);
        }
        let at_floor = stop_at_floor && worst > 0.9 * previous;
        previous = previous.min(worst);
        // Loosened for bytes by sqrt 2 (or after a tolerance between), a
        // fit within the budget may leave much of it unused: the tolerance
        // halfway (geometrically) to the last one over the budget follows.
        let bracketed = loosened_for_bytes || refinements > 0;
        if let (true, false, Some(over)) = (bracketed, reached, over_at) {
            if refinements < MAX_REFINEMENTS && !past_deadline() {
                queue = vec![(over * t).sqrt()];
                k = 0;
                refinements += 1;
                continue;
            }
        }
        // Among the loosened tolerances the first feasible one (within the
        // byte budget) is the best.
        if reached || at_floor || loosened || loosened_for_bytes || past_deadline() {
            break;
        }
    }
    Ok(search)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rgb_channels_share_the_byte_budget_and_the_luminance_has_it_whole() {
        let engine = rational_core::FitSettings::default()
            .with_coeff_range(4, 120)
            .unwrap();
        let base = super::super::target_settings(engine);
        let bytes = TargetBudget {
            seconds: 60.0,
            bytes: Some(1024),
        };
        let cap = |settings: &brdf::BrdfFitSettings, budget| {
            target_engine(settings, budget).unwrap().coeff_range().1
        };
        // 1,024 B hold 256 f32 coefficients: the luminance may use the
        // engine's whole 120, each RGB channel a third of 256.
        assert_eq!(cap(&base, bytes), 120);
        let rgb = base.clone().with_colour_mode(brdf::ColourMode::Rgb);
        assert_eq!(cap(&rgb, bytes), 85);
        assert_eq!(cap(&rgb, TargetBudget::seconds(60.0)), 120);
        // Never below the engine's smallest budget.
        let tiny = TargetBudget {
            seconds: 60.0,
            bytes: Some(16),
        };
        assert_eq!(cap(&rgb, tiny), 4);
    }
}
