//! The search of one reduction for [`super::fit_to_target`]: tolerances
//! tried in turn, each fit widened at most twice, measured on the
//! validation renders and given its evaluation cut; the best fit measured
//! again at its functions' other point within the same intervals.

use super::fit_beside::{ahead_settings, ChannelGate};
use super::target_report::{PointChoice, TargetAttempt, TargetBudget};
use super::target_walk::{Verdict, Walk};
use super::{choose_evaluation_cut, RenderErrors, Validator};
use crate::RenderError;
use brdf::Brdf;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

/// The best fit of one reduction and every attempt.
pub(super) struct Search {
    pub(super) best: Best,
    pub(super) tried: Vec<TargetAttempt>,
    /// The settings searched (before the target's engine changes), for a
    /// search of the same reduction with a larger coefficient budget.
    pub(super) settings: brdf::BrdfFitSettings,
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

/// Each widening of a target fit's intervals. Each function is fitted on
/// its own, so only one that misses its tolerance is widened, and it lands
/// at 1.41 times the tolerance rather than 2.
const WIDEN_STEP: f64 = std::f64::consts::SQRT_2;

/// Widenings allowed, to at most twice the tolerance ([`WIDEN_STEP`]
/// squared).
const MAX_WIDENINGS: usize = 2;

/// The engine of a target fit: `settings`' with the target's widening,
/// each function the least-squares fit within its intervals rather than
/// the point of largest margin (`FitSettings::with_centred_fit`: nearer
/// the table at the same bytes; docs/results/fidelity-2026-12-07-centred.md;
/// each search's best fit is then also measured at the largest-margin
/// points and keeps whichever renders closer,
/// [`super::target_point::at_better_point`]),
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
        .map_err(invalid)?
        .with_centred_fit(true);
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
    search_tolerances(goal, &settings, &TOLERANCES, deadline_s, false, None, false)
}

/// What every fit of one [`super::fit_to_target`] call is judged against.
pub(super) struct Goal<'a> {
    pub(super) validator: &'a Validator,
    pub(super) table: &'a Arc<dyn Brdf>,
    pub(super) target_de: f64,
    pub(super) budget: TargetBudget,
    pub(super) start: Instant,
    /// Each fit but a search's first is made while the one before it is
    /// validated ([`search_tolerances`]); `false` fits and validates one
    /// at a time (the same fits and result, for the tests to compare).
    pub(super) overlap: bool,
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
    /// The fit as fitted with its functions at their splits' largest-margin
    /// points ([`brdf::FittedBrdf::at_largest_margin`]), when it is within
    /// the byte budget and any function was centred.
    pub(super) largest_margin: Option<brdf::FittedBrdf>,
    /// The render errors of both points, once
    /// [`super::target_point::at_better_point`] chose.
    pub(super) point_choice: Option<PointChoice>,
}

/// One tolerance's fit before its validation renders.
struct Unmeasured {
    fitted: brdf::FittedBrdf,
    largest_margin: Option<brdf::FittedBrdf>,
    widened: f64,
    limiting: Option<char>,
    started: Instant,
}

/// The fit of `settings` at perceptual half-width `t`; `Err` names the
/// first function (in the colour mode's order) with no fit within the
/// coefficient budget, with the time the fit started.
fn fit_only(goal: &Goal, settings: &brdf::BrdfFitSettings, t: f64) -> FitOutcome {
    let started = Instant::now();
    let table = goal.table;
    let design = settings.design().copied().unwrap_or_default();
    let s = settings.clone().with_design(brdf::PerceptualBounds {
        rel_tol: t,
        ..design
    });
    match brdf::fit_brdf(table.as_ref(), &s) {
        Ok((fitted, r)) => {
            let scales: Vec<f64> = r.channels.iter().map(|c| c.interval_scale).collect();
            let widened = scales.iter().copied().fold(1.0, f64::max);
            // The first function widened most (the luminance between ties).
            let first_widest =
                (0..scales.len()).max_by(|&a, &b| scales[a].total_cmp(&scales[b]).then(b.cmp(&a)));
            let limiting = first_widest
                .filter(|_| widened > 1.0)
                .map(|c| settings.colour_mode().names()[c]);
            Ok(Ok(Unmeasured {
                largest_margin: fitted.at_largest_margin(&r),
                fitted,
                widened,
                limiting,
                started,
            }))
        }
        Err(brdf::BrdfError::Fit {
            channel,
            source: rational_core::FitError::NoFeasibleFit { .. },
        }) => Ok(Err((channel, started))),
        Err(e) => Err(RenderError::Material {
            name: table.name(),
            source: e,
        }),
    }
}

/// `fit` (at half-width `t`) measured on the validation renders and given
/// its evaluation cut ([`choose_evaluation_cut`], within the byte budget
/// when it can be; none when its functions alone pass it).
fn measure(
    goal: &Goal,
    settings: &brdf::BrdfFitSettings,
    t: f64,
    fit: Unmeasured,
) -> Result<Measured, RenderError> {
    let budget = goal.budget;
    let over_budget = budget.passed_by(fit.fitted.byte_size_f32());
    let (fitted, errors, cut, shell) = evaluated(goal, fit.fitted)?;
    let bytes = fitted.byte_size_f32();
    let attempt = TargetAttempt {
        dims: settings.reduction().dims(),
        colour: settings.colour_mode(),
        scale: settings.value_scale(),
        rel_tol: t,
        seconds: fit.started.elapsed().as_secs_f64(),
        result: Some((bytes, errors.worst_mean())),
        widened: fit.widened,
        limiting: fit.limiting,
        cut,
        shell,
        over_budget: budget.passed_by(bytes),
        fitted_within: fitted_within(settings),
        larger_budget: None,
    };
    Ok(Measured {
        fitted,
        errors,
        attempt,
        largest_margin: fit.largest_margin.filter(|_| !over_budget),
        point_choice: None,
    })
}

/// `fitted` measured on the validation renders and given its evaluation
/// cut ([`choose_evaluation_cut`], within the byte budget when it can be):
/// the fit so evaluated, its errors, the cut and whether a shell factor
/// was chosen.
fn evaluated(
    goal: &Goal,
    fitted: brdf::FittedBrdf,
) -> Result<(brdf::FittedBrdf, RenderErrors, Option<f64>, bool), RenderError> {
    let (validator, table, budget) = (goal.validator, goal.table, goal.budget);
    let errors = validator.measure(Arc::new(crate::scene::FitInDomain::new(fitted.clone())))?;
    // A fit whose functions alone pass the byte budget passes it at every
    // cut, with or without a shell: it can never be returned, so its
    // evaluation cut is not chosen (a validation per cut and layout).
    if budget.passed_by(fitted.byte_size_f32()) {
        return Ok((fitted, errors, None, false));
    }
    let choice = choose_evaluation_cut(
        validator,
        table.as_ref(),
        fitted,
        errors,
        Some(goal.target_de),
        budget.bytes,
    )?;
    Ok((choice.fitted, choice.errors, choice.cut, choice.shell))
}

/// What [`fit_only`] returns.
type FitOutcome = Result<Result<Unmeasured, (char, Instant)>, RenderError>;

/// A fit made while the one before it was validated, for the tolerance
/// that follows unless that validation stops the search.
type Ahead = Option<(f64, FitOutcome)>;

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
/// between it and the bracket's other end
/// ([`MAX_REFINEMENTS`](super::target_walk::MAX_REFINEMENTS)). Looser
/// tolerances follow past the deadline while neither this search nor an
/// earlier one (`fit_in_hand`) has a fit within the budgets: the search
/// then has nothing to return.
/// With `loosest`, no tolerance looser than it is tried, neither given nor
/// added by loosening (the search then ends). A channel's intervals are
/// widened by [`WIDEN_STEP`] at most [`MAX_WIDENINGS`] times (reported):
/// widened further, a perceptual design's floors and caps stop meaning
/// anything.
///
/// Each fit but the first is made while the one before it is validated,
/// for the tolerance that follows unless that validation stops the search
/// (it is then cancelled): the fit's last functions and the renders use
/// the cores the other leaves idle. The fits, their order and the result
/// are those of fitting and validating one at a time: what follows a fit
/// depends on its error only through whether the search stops, and a fit
/// does not depend on the validations before it.
pub(super) fn search_tolerances(
    goal: &Goal,
    settings: &brdf::BrdfFitSettings,
    tolerances: &[f64],
    deadline_s: f64,
    stop_at_floor: bool,
    loosest: Option<f64>,
    fit_in_hand: bool,
) -> Result<Search, RenderError> {
    let searched = settings.clone();
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
        settings: searched,
    };
    let mut walk = Walk::new(tolerances, deadline_s, stop_at_floor, loosest, fit_in_hand);
    let mut ahead: Ahead = None;
    // Where the validations made beside a fit run (none: one at a time).
    let validation_pool = goal
        .overlap
        .then(|| {
            rayon::ThreadPoolBuilder::new()
                .num_threads(rayon::current_num_threads())
                .thread_name(|k| format!("ratfit-validation-{k}"))
                .build()
                .ok()
        })
        .flatten();
    while let Some(t) = walk.next_tolerance() {
        let fit = match ahead.take() {
            // Tolerances are compared exactly: both come from the same steps.
            Some((u, fit)) if u.to_bits() == t.to_bits() => fit?,
            _ => fit_only(goal, &settings, t)?,
        };
        let fit = match fit {
            Ok(fit) => fit,
            Err((function, started)) => {
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
                    larger_budget: None,
                });
                if walk.after_no_fit(search.best.is_some(), walk.past_deadline(goal)) {
                    continue;
                }
                break;
            }
        };
        let over_budget = goal.budget.passed_by(fit.fitted.byte_size_f32());
        let guess = walk.guess_after(t, over_budget, walk.past_deadline(goal));
        let goes_on = match (guess, &validation_pool) {
            (Some(u), Some(pool)) => {
                let (goes_on, next_fit) = judge_beside_next(
                    goal,
                    &settings,
                    (t, fit),
                    (&mut search, &mut walk),
                    (u, pool),
                )?;
                ahead = next_fit.map(|f| (u, f));
                goes_on
            }
            _ => judge(goal, &settings, (t, fit), &mut search, &mut walk)?,
        };
        if !goes_on {
            break;
        }
    }
    if let Some(best) = search.best.take() {
        search.best = Some(super::target_point::at_better_point(goal, best)?);
    }
    Ok(search)
}

/// Validates the fit at `t` and records it in `search`: whether the
/// search goes on after it ([`Walk::after_fit`]).
fn judge(
    goal: &Goal,
    settings: &brdf::BrdfFitSettings,
    (t, fit): (f64, Unmeasured),
    search: &mut Search,
    walk: &mut Walk,
) -> Result<bool, RenderError> {
    let m = measure(goal, settings, t, fit)?;
    let worst = m.errors.worst_mean();
    let over_budget = m.attempt.over_budget;
    search.tried.push(m.attempt.clone());
    let verdict = (!over_budget).then_some(Verdict {
        reached: worst <= goal.target_de,
        worst,
    });
    if verdict.is_some_and(|v| v.reached || worst < search.worst()) {
        search.best = Some(m);
    }
    let past_deadline = walk.past_deadline(goal);
    Ok(walk.after_fit(t, over_budget, verdict, past_deadline))
}

/// [`judge`] of the fit at `t`, with the fit at `u` (the tolerance that
/// follows unless this validation stops the search) made beside it; the
/// fit at `u` is returned when `u` follows, and cancelled otherwise.
///
/// The fit runs on the calling thread, the validation beside it in `pool`
/// once the fit's functions have each started: the system then gives the
/// validation the cores the fit leaves idle as its functions end (in the
/// fit's own pool, the validation's work would hold up the parallel parts
/// of the last function's fit).
fn judge_beside_next(
    goal: &Goal,
    settings: &brdf::BrdfFitSettings,
    (t, fit): (f64, Unmeasured),
    (search, walk): (&mut Search, &mut Walk),
    (u, pool): (f64, &rayon::ThreadPool),
) -> Result<(bool, Option<FitOutcome>), RenderError> {
    let stop = Arc::new(AtomicBool::new(false));
    let gate = Arc::new(ChannelGate::new(settings.colour_mode().names().len()));
    let next_settings = ahead_settings(settings, &stop, &gate);
    let (goes_on, next_fit) = std::thread::scope(|scope| {
        let validation = scope.spawn(|| {
            gate.wait();
            let goes_on = pool.install(|| judge(goal, settings, (t, fit), search, walk));
            // The fit made meanwhile is of use only when `u` follows.
            let follows = walk.upcoming().map(f64::to_bits) == Some(u.to_bits());
            if !(goes_on.as_ref().is_ok_and(|&go| go) && follows) {
                stop.store(true, Ordering::Relaxed);
            }
            goes_on
        });
        let next_fit = {
            let _done = gate.opened_when_dropped();
            fit_only(goal, &next_settings, u)
        };
        let goes_on = validation
            .join()
            .unwrap_or_else(|panic| std::panic::resume_unwind(panic));
        (goes_on, next_fit)
    });
    let used = !stop.load(Ordering::Relaxed);
    Ok((goes_on?, used.then_some(next_fit)))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn fits_made_beside_validations_are_the_fits_made_one_at_a_time() {
        let table: Arc<dyn Brdf> = Arc::new(brdf::CookTorranceGgx {
            kd: [0.3, 0.4, 0.1],
            f0: [0.05; 3],
            alpha: 0.2,
        });
        let validation = super::super::ValidationSettings {
            size: 24,
            lights_spp: 1,
            sky_spp: 16,
            seed: 3,
        };
        let validator = Validator::new(table.clone(), validation).unwrap();
        let engine = rational_core::FitSettings::default()
            .with_coeff_range(4, 120)
            .unwrap();
        let base = super::super::target_settings(engine);
        let reduction = base
            .reduction()
            .with_resolution(8, 8)
            .with_phi_resolution(8);
        let settings = base.with_reduction(reduction);
        // A byte budget that the tighter tolerances pass: the search
        // brackets it, each fit made beside the validation of the one
        // before it. With a target no fit reaches every fit made beside is
        // used; with one the second fit reaches, the one made beside its
        // validation is cancelled and dropped.
        let budget = TargetBudget {
            seconds: 600.0,
            bytes: Some(150),
        };
        for target_de in [1e-3, 0.75] {
            let run = |overlap| {
                let goal = Goal {
                    validator: &validator,
                    table: &table,
                    target_de,
                    budget,
                    start: Instant::now(),
                    overlap,
                };
                search_tolerances(&goal, &settings, &TOLERANCES, 600.0, false, None, false).unwrap()
            };
            let (beside, alone) = (run(true), run(false));
            // Everything but the seconds.
            let attempts = |s: &Search| -> Vec<String> {
                s.tried
                    .iter()
                    .map(|a| {
                        format!(
                            "{} {:?} {} {:?} {:?} {} {}",
                            a.rel_tol,
                            a.result,
                            a.widened,
                            a.limiting,
                            a.cut,
                            a.shell,
                            a.over_budget
                        )
                    })
                    .collect()
            };
            assert_eq!(attempts(&beside), attempts(&alone));
            let fitted = alone.tried.iter().filter(|a| a.result.is_some()).count();
            let over = alone.tried.iter().filter(|a| a.over_budget).count();
            let reached = alone.worst() <= target_de;
            let expected = if reached { (2, 0) } else { (5, 2) };
            assert_eq!((fitted, over), expected, "{:?}", attempts(&alone));
            let best = |s: &Search| {
                let b = s.best.as_ref().expect("a fit within the budget");
                (format!("{:?}", b.fitted), b.errors.worst_mean().to_bits())
            };
            assert_eq!(best(&beside), best(&alone));
        }
    }

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
