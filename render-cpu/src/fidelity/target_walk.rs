//! The order in which a target search tries tolerances
//! ([`super::target_search::search_tolerances`]): loosest first, looser
//! ones when none is feasible or the byte budget is passed, and
//! geometric bisection of the bracket around the budget.

use super::target_search::{Goal, LOOSER};

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

/// `queue` without the tolerances looser than `loosest` (the same
/// tolerance reached by other steps, within rounding, is kept).
fn within_loosest(queue: Vec<f64>, loosest: Option<f64>) -> Vec<f64> {
    match loosest {
        Some(l) => queue
            .into_iter()
            .filter(|&t| t <= l * (1.0 + 1e-9))
            .collect(),
        None => queue,
    }
}

/// How many times a search bisects (geometrically) the bracket between a
/// tolerance whose fit is within the byte budget and a tighter one past
/// it: twice narrows a factor of 2 to 2^(1/4), about 19%.
pub(super) const MAX_REFINEMENTS: usize = 2;

/// The order of a search's tolerances: the queue,
/// and what the fits so far decided about what follows.
#[derive(Clone)]
pub(super) struct Walk {
    queue: Vec<f64>,
    next: usize,
    loosened: bool,
    loosened_for_bytes: bool,
    /// The last tolerance whose fit passed the byte budget and the last
    /// whose fit was within it (they bracket the tightest within it), and
    /// how many tolerances between them were tried.
    over_at: Option<f64>,
    within_at: Option<f64>,
    refinements: usize,
    /// The lowest worse-scene error so far.
    previous: f64,
    /// Seconds from the target search's start after which no tolerance
    /// between two tried ones follows.
    deadline_s: f64,
    /// Whether a tighter tolerance that improves the error by less than
    /// 10% ends the search (the reduction's own error dominates).
    stop_at_floor: bool,
    /// The loosest tolerance the search may try, if any: looser ones in
    /// the queue, and those that loosening would add, are left out.
    loosest: Option<f64>,
    /// Whether an earlier search holds a fit within the budgets: past the
    /// deadline no fit follows then, not even a looser one for lack of a
    /// fit of this search's own.
    fit_in_hand: bool,
}

/// What a validation said of a fit within the byte budget, for [`Walk`]:
/// whether it reached the target, and its worse-scene error.
#[derive(Clone, Copy)]
pub(super) struct Verdict {
    pub(super) reached: bool,
    pub(super) worst: f64,
}

impl Walk {
    /// A walk over `tolerances` (loosest first); with `loosest`, no
    /// tolerance looser than it is tried, given or added by loosening.
    /// `fit_in_hand`: an earlier search holds a fit within the budgets, so
    /// that past the deadline nothing follows.
    pub(super) fn new(
        tolerances: &[f64],
        deadline_s: f64,
        stop_at_floor: bool,
        loosest: Option<f64>,
        fit_in_hand: bool,
    ) -> Self {
        Self {
            queue: within_loosest(tolerances.to_vec(), loosest),
            next: 0,
            loosened: false,
            loosened_for_bytes: false,
            over_at: None,
            within_at: None,
            refinements: 0,
            previous: f64::INFINITY,
            deadline_s,
            stop_at_floor,
            loosest,
            fit_in_hand,
        }
    }

    pub(super) fn past_deadline(&self, goal: &Goal) -> bool {
        goal.start.elapsed().as_secs_f64() > self.deadline_s
    }

    /// The tolerance [`Walk::next_tolerance`] will give, if any.
    pub(super) fn upcoming(&self) -> Option<f64> {
        self.queue.get(self.next).copied()
    }

    pub(super) fn next_tolerance(&mut self) -> Option<f64> {
        let t = *self.queue.get(self.next)?;
        self.next += 1;
        Some(t)
    }

    fn restart_with(&mut self, queue: Vec<f64>) {
        self.queue = within_loosest(queue, self.loosest);
        self.next = 0;
    }

    /// After no fit within the coefficient budget: whether the search goes
    /// on (`have_best`: a fit within the budgets was found before).
    pub(super) fn after_no_fit(&mut self, have_best: bool, past_deadline: bool) -> bool {
        if past_deadline && self.fit_in_hand {
            return false;
        }
        if !have_best && !self.loosened {
            // Even the loosest is infeasible: loosen instead.
            self.restart_with(LOOSER.to_vec());
            self.loosened = true;
            return true;
        }
        !have_best && self.next < self.queue.len()
    }

    /// After the fit at `t`: whether the search goes on. `verdict` is
    /// `None` for a fit over the byte budget (whose error decides nothing),
    /// and for the guess made before a validation that the fit neither
    /// reaches the target nor the floor.
    pub(super) fn after_fit(
        &mut self,
        t: f64,
        over_budget: bool,
        verdict: Option<Verdict>,
        past_deadline: bool,
    ) -> bool {
        if over_budget {
            self.over_at = Some(t);
            if let Some(within) = self.within_at {
                // Between a fit within the budget and this tighter one past
                // it, the tolerance halfway (geometrically); tighter ones
                // only grow.
                if self.refinements < MAX_REFINEMENTS && !past_deadline {
                    self.restart_with(vec![(within * t).sqrt()]);
                    self.refinements += 1;
                    return true;
                }
                return false;
            }
            // Nothing within the byte budget yet: looser tolerances follow
            // even past the deadline, as they do when nothing is feasible
            // (a search cut here returns nothing for the time it spent),
            // unless an earlier search's fit is there to return.
            if past_deadline && self.fit_in_hand {
                return false;
            }
            if !self.loosened_for_bytes {
                self.restart_with(looser_for_bytes(t));
                self.loosened_for_bytes = true;
            }
            return true;
        }
        self.within_at = Some(t);
        let (reached, at_floor) = verdict.map_or((false, false), |v| {
            (
                v.reached,
                self.stop_at_floor && v.worst > 0.9 * self.previous,
            )
        });
        if let Some(v) = verdict {
            self.previous = self.previous.min(v.worst);
        }
        // Loosened for bytes by sqrt 2 (or after a tolerance between), a
        // fit within the budget may leave much of it unused: the tolerance
        // halfway (geometrically) to the last one over the budget follows.
        let bracketed = self.loosened_for_bytes || self.refinements > 0;
        if let (true, false, Some(over)) = (bracketed, reached, self.over_at) {
            if self.refinements < MAX_REFINEMENTS && !past_deadline {
                self.restart_with(vec![(over * t).sqrt()]);
                self.refinements += 1;
                return true;
            }
        }
        // Among the loosened tolerances the first feasible one (within the
        // byte budget) is the best.
        !(reached || at_floor || self.loosened || self.loosened_for_bytes || past_deadline)
    }

    /// The tolerance that follows the fit at `t` if its validation neither
    /// reaches the target nor the floor, without deciding it.
    pub(super) fn guess_after(
        &self,
        t: f64,
        over_budget: bool,
        past_deadline: bool,
    ) -> Option<f64> {
        let mut walk = self.clone();
        walk.after_fit(t, over_budget, None, past_deadline)
            .then(|| walk.next_tolerance())
            .flatten()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MISSED: Option<Verdict> = Some(Verdict {
        reached: false,
        worst: 3.0,
    });

    #[test]
    fn a_walk_with_a_loosest_tolerance_never_tries_a_looser_one() {
        // Past the byte budget at 16%: looser tolerances follow, unless
        // 16% is the loosest allowed.
        let mut free = Walk::new(&[0.16, 0.08], 600.0, false, None, false);
        assert_eq!(free.next_tolerance(), Some(0.16));
        assert!(free.after_fit(0.16, true, None, false));
        assert!(free.next_tolerance().is_some_and(|t| t > 0.16));
        let mut capped = Walk::new(&[0.16, 0.08], 600.0, false, Some(0.16), false);
        assert_eq!(capped.next_tolerance(), Some(0.16));
        capped.after_fit(0.16, true, None, false);
        assert_eq!(capped.next_tolerance(), None);

        // No fit at any given tolerance: the looser ones follow up to the
        // loosest allowed, and loosening for bytes stops there too.
        let mut w = Walk::new(&[0.16], 600.0, false, Some(0.32), false);
        assert_eq!(w.next_tolerance(), Some(0.16));
        assert!(w.after_no_fit(false, false));
        assert_eq!(w.next_tolerance(), Some(0.32));
        w.after_fit(0.32, true, None, false);
        assert_eq!(w.next_tolerance(), None);

        // Given tolerances looser than it are left out; the tolerance
        // between a fit within the budget and one past it is kept.
        let mut w = Walk::new(&[0.16, 0.08, 0.04], 600.0, false, Some(0.1), false);
        assert_eq!(w.next_tolerance(), Some(0.08));
        assert!(w.after_fit(0.08, false, MISSED, false));
        assert_eq!(w.next_tolerance(), Some(0.04));
        assert!(w.after_fit(0.04, true, None, false));
        let between = w.next_tolerance().expect("the tolerance between");
        assert!((between - (0.08_f64 * 0.04).sqrt()).abs() < 1e-12);
    }

    #[test]
    fn past_the_deadline_a_walk_loosens_only_while_no_search_has_a_fit() {
        // No fit, or a fit past the byte budget, past the deadline: looser
        // tolerances follow when nothing else could be returned, and
        // nothing follows when an earlier search's fit could.
        for fit_in_hand in [false, true] {
            let mut w = Walk::new(&[0.16], 600.0, false, None, fit_in_hand);
            assert_eq!(w.next_tolerance(), Some(0.16));
            assert_eq!(w.after_no_fit(false, true), !fit_in_hand);
            let mut w = Walk::new(&[0.16], 600.0, false, None, fit_in_hand);
            assert_eq!(w.next_tolerance(), Some(0.16));
            assert_eq!(w.after_fit(0.16, true, None, true), !fit_in_hand);
            // Before the deadline the walk is the same either way.
            let mut w = Walk::new(&[0.16], 600.0, false, None, fit_in_hand);
            assert_eq!(w.next_tolerance(), Some(0.16));
            assert!(w.after_fit(0.16, true, None, false));
            assert!(w.next_tolerance().is_some_and(|t| t > 0.16));
        }
    }
}
