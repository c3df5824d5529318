//! The best search of a target fit again with a larger coefficient budget
//! ([`super::TargetCoefficients::Auto`]).

use super::target_choices::{TargetCoefficients, LARGER_BUDGET_FACTOR, LARGER_BUDGET_REACH};
use super::target_report::TargetAttempt;
use super::target_search::{search_tolerances, Goal, TOLERANCES};
use super::target_searches::{lowest_error, Searches};
use crate::RenderError;

/// The tolerance a larger coefficient budget is tried from: the tightest
/// of `tried`, when the budget bounded it (a function had no fit within
/// it, or was widened) rather than the byte budget.
fn bounded_by_coefficients(tried: &[TargetAttempt]) -> Option<f64> {
    let tightest = tried
        .iter()
        .min_by(|a, b| a.rel_tol.total_cmp(&b.rel_tol))?;
    let bounded = match tightest.result {
        None => true,
        Some(_) => tightest.widened > 1.0 && !tightest.over_budget,
    };
    bounded.then_some(tightest.rel_tol)
}

/// The tolerances of the larger budget's search from `from`: `from`, then
/// the tighter of [`TOLERANCES`].
fn tolerances_from(from: f64) -> Vec<f64> {
    std::iter::once(from)
        .chain(TOLERANCES.iter().copied().filter(|&t| t < from))
        .collect()
}

/// The search with the lowest error in `run`, searched again with
/// [`LARGER_BUDGET_FACTOR`] times its coefficient budget per function,
/// from the tolerance that budget bounded ([`bounded_by_coefficients`])
/// to the tightest of [`TOLERANCES`] and never looser; recorded in `run`
/// (unless the time budget is spent), each attempt marked with the
/// budget. Nothing with [`TargetCoefficients::Fixed`], when the target is
/// reached, or when that search has no fit, its best renders above
/// [`LARGER_BUDGET_REACH`] times the target, its coefficient budget did
/// not bound it, or the byte budget cannot hold every function at that
/// budget (the bytes then bound the fits first).
pub(super) fn larger_budget_search(
    goal: &Goal,
    run: &mut Searches,
    coefficients: TargetCoefficients,
) -> Result<(), RenderError> {
    if coefficients == TargetCoefficients::Fixed || run.reached(goal.target_de) {
        return Ok(());
    }
    let Some(k) = lowest_error(&run.searches) else {
        return Ok(());
    };
    let (name, search) = &run.searches[k];
    if search.best.is_none() || search.worst() > LARGER_BUDGET_REACH * goal.target_de {
        return Ok(());
    }
    let Some(from) = bounded_by_coefficients(&search.tried) else {
        return Ok(());
    };
    let (lo, hi) = search.settings.fit_settings().coeff_range();
    let functions = search.settings.colour_mode().names().len();
    if goal.budget.bytes.is_some_and(|b| b < functions * hi * 4) {
        return Ok(());
    }
    let larger = hi * LARGER_BUDGET_FACTOR;
    let engine = (search.settings.fit_settings().clone())
        .with_coeff_range(lo, larger)
        .map_err(|e| crate::error::invalid("fit settings", e.to_string()))?;
    let settings = search.settings.clone().with_fit_settings(engine);
    // The slice's search ends where a tighter tolerance stops improving,
    // as its first search did.
    let stop_at_floor = settings.reduction().dims() == 2;
    let name = format!("{name} with up to {larger} coefficients per function");
    let tolerances = tolerances_from(from);
    run.unless_spent(goal, name, |in_hand| {
        let mut s = search_tolerances(
            goal,
            &settings,
            &tolerances,
            goal.budget.seconds,
            stop_at_floor,
            Some(from),
            in_hand,
        )?;
        s.tried
            .iter_mut()
            .for_each(|a| a.larger_budget = Some(larger));
        if let Some(best) = s.best.as_mut() {
            best.attempt.larger_budget = Some(larger);
        }
        Ok(s)
    })?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn attempt(rel_tol: f64, result: Option<usize>, widened: f64, over: bool) -> TargetAttempt {
        TargetAttempt {
            dims: 3,
            colour: brdf::ColourMode::LuminanceChroma,
            scale: brdf::ValueScale::Log,
            rel_tol,
            seconds: 1.0,
            result: result.map(|bytes| (bytes, 2.0)),
            widened,
            limiting: (widened > 1.0 || result.is_none()).then_some('Y'),
            cut: None,
            shell: false,
            over_budget: over,
            fitted_within: None,
            larger_budget: None,
        }
    }

    /// A larger budget starts at the tightest tolerance, and only where
    /// the coefficient budget, not the byte budget, stopped the search.
    #[test]
    fn a_larger_budget_follows_only_a_search_its_coefficients_bounded() {
        let no_fit_at_2 = [
            attempt(0.16, Some(700), 1.0, false),
            attempt(0.04, Some(1100), 2.0, false),
            attempt(0.02, None, 1.0, false),
        ];
        assert_eq!(bounded_by_coefficients(&no_fit_at_2), Some(0.02));
        let widened_at_2 = [
            attempt(0.04, Some(900), 1.0, false),
            attempt(0.02, Some(1000), 2.0, false),
        ];
        assert_eq!(bounded_by_coefficients(&widened_at_2), Some(0.02));
        let within_at_2 = [
            attempt(0.04, Some(900), 2.0, false),
            attempt(0.02, Some(1000), 1.0, false),
        ];
        assert_eq!(bounded_by_coefficients(&within_at_2), None);
        let over_bytes = [
            attempt(0.08, Some(900), 1.0, false),
            attempt(0.04, Some(1100), 2.0, true),
        ];
        assert_eq!(bounded_by_coefficients(&over_bytes), None);
        assert_eq!(bounded_by_coefficients(&[]), None);
        assert_eq!(tolerances_from(0.16), TOLERANCES.to_vec());
        assert_eq!(tolerances_from(0.05), vec![0.05, 0.04, 0.02]);
        assert_eq!(
            tolerances_from(0.32),
            [&[0.32][..], &TOLERANCES[..]].concat()
        );
    }
}
