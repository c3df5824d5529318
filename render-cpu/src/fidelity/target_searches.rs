//! The searches of a target fit as they ran ([`super::target`]): their
//! record, the searches the time budget left out, and the choice of the
//! fit among them.

use super::target_grid::GridChoice;
use super::target_report::{SliceFloor, TargetAttempt};
use super::target_search::{Best, Goal, Search};
use crate::RenderError;

/// Whether a search that has not started may be left out: a fit within
/// the budgets is in hand and the time budget is spent.
fn time_spent(goal: &Goal, searches: &[(String, Search)]) -> bool {
    fit_in_hand(searches) && goal.start.elapsed().as_secs_f64() > goal.budget.seconds
}

/// Whether any of `searches` has a fit within the budgets.
pub(super) fn fit_in_hand(searches: &[(String, Search)]) -> bool {
    searches.iter().any(|(_, s)| s.best.is_some())
}

/// What the searches of a target fit found: why the fit was chosen, the
/// fit, every attempt and the slice's floor.
pub(super) struct Searched {
    pub(super) why: String,
    pub(super) best: Best,
    pub(super) tried: Vec<TargetAttempt>,
    pub(super) slice_floor: Option<SliceFloor>,
    pub(super) grid_choice: Option<GridChoice>,
}

/// The searches of a target fit, in the order they ran, with their names,
/// and the names of those left out because the time budget was spent.
#[derive(Default)]
pub(super) struct Searches {
    pub(super) searches: Vec<(String, Search)>,
    pub(super) left_for_time: Vec<String>,
}

impl Searches {
    /// Whether a search's best fit reaches `target_de`.
    pub(super) fn reached(&self, target_de: f64) -> bool {
        self.searches.iter().any(|(_, s)| s.worst() <= target_de)
    }

    /// Runs `search` (given whether a fit within the budgets is in hand)
    /// and records it as `name`, unless [`time_spent`]: then `name` is
    /// recorded as left out. Returns the search when it ran.
    pub(super) fn unless_spent(
        &mut self,
        goal: &Goal,
        name: String,
        search: impl FnOnce(bool) -> Result<Search, RenderError>,
    ) -> Result<Option<&Search>, RenderError> {
        if time_spent(goal, &self.searches) {
            self.left_for_time.push(name);
            return Ok(None);
        }
        let s = search(fit_in_hand(&self.searches))?;
        self.searches.push((name, s));
        Ok(self.searches.last().map(|(_, s)| s))
    }
}

/// Every attempt of `run`'s searches, and the best fit of the one with the
/// lowest worse-scene error, with why it was chosen and which searches the
/// time budget (`budget_s`) left out.
pub(super) fn conclude(
    run: Searches,
    slice_floor: Option<SliceFloor>,
    grid_choice: Option<GridChoice>,
    budget_s: f64,
) -> Searched {
    let Searches {
        mut searches,
        left_for_time,
    } = run;
    let tried = searches
        .iter()
        .flat_map(|(_, s)| s.tried.iter().cloned())
        .collect();
    let k = lowest_error(&searches).unwrap_or(0);
    let mut why = why_chosen(&searches, k);
    if !left_for_time.is_empty() {
        why.push_str(&format!(
            "; not searched, the time budget of {budget_s} s being spent: {}",
            left_for_time.join(", ")
        ));
    }
    let best = if searches.is_empty() {
        None
    } else {
        searches.swap_remove(k).1.best
    };
    Searched {
        why,
        best,
        tried,
        slice_floor,
        grid_choice,
    }
}

/// The search with the lowest worse-scene error (the earlier between equal
/// errors); `None` when there is none.
pub(super) fn lowest_error(searches: &[(String, Search)]) -> Option<usize> {
    (0..searches.len()).min_by(|&a, &b| searches[a].1.worst().total_cmp(&searches[b].1.worst()))
}

/// Why search `k` was chosen, with the best error of every search.
fn why_chosen(searches: &[(String, Search)], k: usize) -> String {
    let parts: Vec<String> = searches
        .iter()
        .map(|(what, s)| {
            let w = s.worst();
            match (w.is_finite(), what.contains("slice")) {
                (true, true) => format!("{what} {w:.3} (what that reduction loses)"),
                (true, false) => format!("{what} {w:.3}"),
                (false, _) => format!("{what} none within the budget"),
            }
        })
        .collect();
    match searches.get(k) {
        Some((what, s)) if s.best.is_some() => format!(
            "{what} chosen; the best fit of each search renders at (worse scene): {}",
            parts.join(", ")
        ),
        _ => format!(
            "no fit within the budget; the best fit of each search renders at (worse scene): {}",
            parts.join(", ")
        ),
    }
}
