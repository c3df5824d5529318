//! The target search's 3-D fits within an elevation cut: made when a
//! byte budget leaves the target unreached by the whole hemisphere's fits,
//! within the cut and from the tolerance those fits suggest.

use super::target_search::{search_tolerances, Goal, Search, TOLERANCES};
use crate::RenderError;

/// The elevation (degrees) within which a 3-D fit is also made when a
/// byte budget leaves the target unreached: its functions spend nothing on
/// the grazing cells (the shell factor and the clamp to the cut carry
/// them), so the same intervals cost fewer coefficients. A lower cut is
/// used where the whole hemisphere's best fit is evaluated within one
/// ([`within_cut_degrees`]).
pub(super) const TARGET_CUT_DEGREES: f64 = 70.0;

/// The elevation the 3-D fits within a cut are made within: the
/// evaluation cut of the whole hemisphere's best fit (`best_cut`) where it
/// is below [`TARGET_CUT_DEGREES`] (the renders showed that the fit's
/// cells beyond it are better carried by the shell factor, so fitting them
/// spends coefficients for nothing), else [`TARGET_CUT_DEGREES`]: a cut
/// above it gives the grazing cells back coefficients that the renders
/// showed are better spent within it.
fn within_cut_degrees(best_cut: Option<f64>) -> f64 {
    best_cut.map_or(TARGET_CUT_DEGREES, |c| c.min(TARGET_CUT_DEGREES))
}

/// What the search within a cut takes from the whole hemisphere's
/// search: the tolerances whose fits passed the byte budget, and the
/// tolerance and evaluation cut of its best fit.
#[derive(Default)]
pub(super) struct WholeHemisphere {
    over_budget_at: Vec<f64>,
    best_at: Option<f64>,
    best_cut: Option<f64>,
}

impl WholeHemisphere {
    /// What `search`, the whole hemisphere's, found.
    pub(super) fn of(search: &Search) -> Self {
        Self {
            over_budget_at: (search.tried.iter())
                .filter(|a| a.over_budget)
                .map(|a| a.rel_tol)
                .collect(),
            best_at: search.best.as_ref().map(|m| m.attempt.rel_tol),
            best_cut: search.best.as_ref().and_then(|m| m.attempt.cut),
        }
    }

    /// The cut (degrees) the search within a cut fits within
    /// ([`within_cut_degrees`]).
    pub(super) fn cut_degrees(&self) -> f64 {
        within_cut_degrees(self.best_cut)
    }
}

/// The search of `base`'s 3-D grid within [`within_cut_degrees`] of the
/// normal, over [`within_cut_tolerances`] and no looser than the whole
/// hemisphere's best tolerance, until the time budget's deadline
/// (`fit_in_hand`: an earlier search has a fit within the budgets, so that
/// past the deadline nothing follows).
pub(super) fn within_cut_search(
    goal: &Goal,
    base: &brdf::BrdfFitSettings,
    whole: &WholeHemisphere,
    fit_in_hand: bool,
) -> Result<Search, RenderError> {
    let tolerances = within_cut_tolerances(&whole.over_budget_at, whole.best_at);
    let within = whole.cut_degrees();
    let settings = base
        .clone()
        .with_reduction(base.reduction().with_max_elevation(within));
    // Looser than the whole hemisphere's best, a fit within the cut
    // bounds the cells it keeps more loosely than that best does.
    search_tolerances(
        goal,
        &settings,
        &tolerances,
        goal.budget.seconds,
        false,
        whole.best_at,
        fit_in_hand,
    )
}

/// The tolerances of the search within a cut ([`within_cut_degrees`]): from the
/// tightest at which the whole-hemisphere fits passed the byte budget
/// (`over_budget_at`); when none did, from the tolerance of their best fit
/// (`best_at`): fitted within the cut, a looser tolerance's fit has fewer
/// bytes but renders no better than the whole hemisphere's at it, while the
/// best one's subset of constraints is feasible with no more coefficients;
/// the loosest of [`TOLERANCES`] when there is neither. It starts no
/// looser than `best_at`, and the search never loosens past it either
/// (for bytes or for lack of a fit): within
/// the cut such a fit bounds the cells it keeps more loosely than the
/// whole hemisphere's best, and on the 11 RGL files none rendered better
/// than it.
fn within_cut_tolerances(over_budget_at: &[f64], best_at: Option<f64>) -> Vec<f64> {
    let tightest_over = over_budget_at.iter().copied().reduce(f64::min);
    let from = tightest_over.or(best_at).unwrap_or(TOLERANCES[0]);
    // Never above the search's ceiling (a looser fit past the budget than
    // the best one happens where sizes do not fall with the tolerance).
    let from = best_at.map_or(from, |b| from.min(b));
    let tolerances: Vec<f64> = TOLERANCES
        .iter()
        .copied()
        .filter(|&t| t <= from * (1.0 + 1e-9))
        .collect();
    if tolerances.is_empty() {
        vec![from]
    } else {
        tolerances
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The search within the cut starts where the whole-hemisphere fits
    /// passed the byte budget, else at their best fit's tolerance, and
    /// never looser than the best's.
    #[test]
    fn the_search_within_the_cut_starts_where_the_whole_hemisphere_stopped() {
        assert_eq!(within_cut_tolerances(&[], None), TOLERANCES.to_vec());
        assert_eq!(
            within_cut_tolerances(&[0.08], Some(0.16)),
            [0.08, 0.04, 0.02]
        );
        assert_eq!(within_cut_tolerances(&[], Some(0.04)), [0.04, 0.02]);
        // Over the budget at 16% and best when loosened: from 16%.
        let loosened = within_cut_tolerances(&[0.16], Some(0.16 * std::f64::consts::SQRT_2));
        assert_eq!(loosened, TOLERANCES.to_vec());
        // Best only when loosened for feasibility: every tolerance.
        assert_eq!(within_cut_tolerances(&[], Some(0.32)), TOLERANCES.to_vec());
        // Past the budget at a looser tolerance than the best: from the
        // best, the loosest the search may try.
        assert_eq!(
            within_cut_tolerances(&[0.16], Some(0.08)),
            [0.08, 0.04, 0.02]
        );
    }

    /// The fits within a cut are made within the whole hemisphere's best
    /// evaluation cut where it is below 70 degrees, else within 70.
    #[test]
    fn the_fits_within_a_cut_follow_a_lower_cut_of_the_whole_hemisphere() {
        let cuts = [None, Some(65.0), Some(70.0), Some(75.0), Some(80.0)];
        let c = TARGET_CUT_DEGREES;
        // The cut is one of the inputs, never computed: compared bit for bit.
        let bits = |v: [f64; 5]| v.map(f64::to_bits);
        assert_eq!(
            bits(cuts.map(within_cut_degrees)),
            bits([c, 65.0, 70.0, c, c])
        );
    }
}
