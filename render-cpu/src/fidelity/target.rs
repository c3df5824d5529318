//! [`fit_to_target`]: the smallest perceptual fit whose validation renders
//! reach a mean CIEDE2000.

use super::target_choices::{
    on_target_grid, TargetChoices, TargetColour, TargetReduction, TargetScale,
};
use super::target_grid::{choose_grid, grid_floor};
use super::target_larger_budget::larger_budget_search;
use super::target_report::{SliceFloor, TargetAttempt, TargetBudget, TargetReport};
use super::target_search::{
    search_tolerances, split_budget_search, split_cap, Goal, Measured, Search, LOOSER, TOLERANCES,
};
use super::target_searches::{conclude, fit_in_hand, lowest_error, Searched, Searches};
use super::target_within_cut::{within_cut_search, WholeHemisphere};
use super::{ValidationSettings, Validator};
use crate::RenderError;
use brdf::Brdf;
use std::sync::Arc;
use std::time::Instant;

/// The share of the time budget the search in the other colour mode
/// ([`TargetColour::Auto`]) may start fits within, from its own start
/// (and never past the budget itself).
const OTHER_COLOUR_SHARE: f64 = 0.6;

/// The share of the time budget the slice's search may start fits within:
/// from the start of the target fit when it comes first, from its own
/// start when it follows the 3-D fits (and never past the budget itself).
const SLICE_SHARE: f64 = 0.4;

/// A search of the slice (or of the first reduction in another colour
/// mode) with `settings`: the three loosest tolerances, ending where a
/// tighter one improves by less than 10% (the reduction's own error
/// dominates), starting fits until `deadline_s` (seconds from the start
/// of the target fit; `fit_in_hand` as in [`search_tolerances`]).
fn reduction_search(
    goal: &Goal,
    settings: &brdf::BrdfFitSettings,
    deadline_s: f64,
    fit_in_hand: bool,
) -> Result<Search, RenderError> {
    search_tolerances(
        goal,
        settings,
        &TOLERANCES[..3],
        deadline_s,
        true,
        None,
        fit_in_hand,
    )
}

/// The deadline (seconds from the start of the target fit) `share` of the
/// time budget from now, and never past the budget itself.
fn share_from_now(goal: &Goal, share: f64) -> f64 {
    (goal.start.elapsed().as_secs_f64() + share * goal.budget.seconds).min(goal.budget.seconds)
}

/// The colour mode [`TargetColour::Auto`] tries after `mode`.
fn other_colour(mode: brdf::ColourMode) -> brdf::ColourMode {
    match mode {
        brdf::ColourMode::Rgb => brdf::ColourMode::LuminanceChroma,
        _ => brdf::ColourMode::Rgb,
    }
}

/// Whether the other colour mode is worth a search after `tried` in
/// `mode`: after RGB always; after luminance-chroma when a chroma ratio,
/// never the luminance, limited a fit (widened most or with no fit). RGB
/// channels each carry the luminance's shape, so where the luminance
/// itself is short of coefficients they are too (on the 11 RGL files, RGB
/// slices lost or had no fit wherever the luminance limited).
fn other_colour_may_help(mode: brdf::ColourMode, tried: &[TargetAttempt]) -> bool {
    if mode != brdf::ColourMode::LuminanceChroma {
        return true;
    }
    let limiting: Vec<char> = tried.iter().filter_map(|a| a.limiting).collect();
    let luminance = mode.names()[0];
    !limiting.is_empty() && !limiting.contains(&luminance)
}

/// The worse-scene error of the table seen through the 2-D slice
/// ([`brdf::SliceView`]) within the smallest of
/// [`super::EVALUATION_CUTS`], the table itself beyond: about the least
/// any slice fit renders at, since the slice's fits are evaluated within
/// one of those cuts or none (or within a lower cut of
/// [`super::LOWER_CUTS`] where that one does best, which this floor, an
/// ordering of the searches, leaves aside).
fn slice_floor(goal: &Goal) -> Result<SliceFloor, RenderError> {
    let within_deg = super::EVALUATION_CUTS.iter().copied().fold(90.0, f64::min);
    let view = brdf::SliceView::new(goal.table.clone(), within_deg);
    Ok(SliceFloor {
        within_deg,
        worst_mean_de: goal.validator.measure(Arc::new(view))?.worst_mean(),
        searched: false,
        left_for_time: false,
    })
}

/// The searches of [`fit_to_target`] in turn, each only while the target is
/// unreached: the 2-D slice (with [`TargetReduction::Auto`]), `base`'s 3-D
/// grid, and with a byte budget, the 3-D grid fitted within a cut
/// ([`within_cut_search`]: 70 degrees or the lower cut the whole
/// hemisphere's best fit is evaluated within, from the tightest tolerance
/// the whole-hemisphere fits passed the budget at, and never looser than
/// the tolerance of their best fit) and, when
/// nothing is within the budget yet, the 3-D grid with the budget split
/// evenly between the functions; with
/// [`TargetColour::Auto`], the first reduction in the other colour mode
/// comes before that last one (see [`TargetColour::Auto`]), and with
/// [`super::TargetCoefficients::Auto`], the best search again with a larger
/// coefficient budget ([`larger_budget_search`]) before it too. The slice is
/// searched first only when the table seen through it ([`SliceFloor`])
/// reaches the target; otherwise after the 3-D searches, and only when
/// their best fit renders above that floor (below it, a slice fit would
/// have to render under what the slice itself loses to do better). Every
/// 3-D search samples the grid [`choose_grid`] chooses. Returns why the
/// fit was chosen, the fit with the lowest worse-scene error (the earlier
/// search between equal errors), and every attempt.
fn run_searches(
    goal: &Goal,
    base: &brdf::BrdfFitSettings,
    choices: TargetChoices,
) -> Result<Searched, RenderError> {
    let TargetChoices {
        reduction,
        colour,
        scale,
        grid,
        coefficients,
    } = choices;
    // The slice keeps the caller's settings; the 3-D searches take the grid.
    let slice_base = base;
    let (base, grid_choice) = choose_grid(goal, base, grid)?;
    let base = &base;
    let budget_s = goal.budget.seconds;
    let dims = base.reduction().dims();
    let mut run = Searches::default();
    let reached = |searches: &Searches| searches.reached(goal.target_de);
    let in_mode = |what: &str, mode: brdf::ColourMode| in_mode(colour, what, mode);
    let slice_name = in_mode("the 2-D slice", base.colour_mode());
    // The first reduction searched and its index: the other colour mode is
    // tried on it (not on a slice left unsearched).
    let mut first = Some((base.clone(), 0));
    // The slice's settings and floor, when its search waits for the 3-D
    // fits.
    let mut deferred = None;
    let mut floor = None;
    if reduction == TargetReduction::Auto {
        let (settings, f, searched) = slice_first(goal, slice_base)?;
        floor = Some(f);
        if let Some(s) = searched {
            run.searches.push((slice_name.clone(), s));
            first = Some((settings, 0));
        } else {
            deferred = Some(settings);
            first = None;
        }
    }
    // What the whole hemisphere's search found, when it ran.
    let mut whole = None;
    if !reached(&run) {
        let (what, own) = own_reduction(base, scale);
        let what = in_mode(&what, base.colour_mode());
        if let Some(s) = run.unless_spent(goal, what, |in_hand| {
            search_tolerances(goal, &own, &TOLERANCES, budget_s, false, None, in_hand)
        })? {
            whole = Some(WholeHemisphere::of(s));
        }
    }
    let whole_3d = base.reduction().kind == brdf::ReductionKind::Full3d
        && base.reduction().max_elevation_deg >= 90.0;
    if let (Some(_), true, false) = (goal.budget.bytes, whole_3d, reached(&run)) {
        let cut = whole.as_ref().map_or("a cut".to_string(), |w| {
            format!("{} degrees", w.cut_degrees())
        });
        let what = in_mode(
            &format!("the {dims}-D fits within {cut}"),
            base.colour_mode(),
        );
        let whole = whole.unwrap_or_default();
        run.unless_spent(goal, what, |in_hand| {
            within_cut_search(goal, base, &whole, in_hand)
        })?;
    }
    if let (Some(settings), Some(f)) = (deferred, floor.as_mut()) {
        let best = lowest_error(&run.searches).map_or(f64::INFINITY, |k| run.searches[k].1.worst());
        if best > f.worst_mean_de {
            // Its own allowance, as when it is searched first.
            let deadline_s = share_from_now(goal, SLICE_SHARE);
            let searched = run.unless_spent(goal, slice_name, |in_hand| {
                reduction_search(goal, &settings, deadline_s, in_hand)
            })?;
            f.searched = searched.is_some();
            f.left_for_time = searched.is_none();
            if f.searched {
                first = Some((settings, run.searches.len() - 1));
            }
        }
    }
    if let (TargetColour::Auto, false, Some(first)) = (colour, reached(&run), first) {
        let what = match reduction {
            TargetReduction::Auto => "the 2-D slice".to_string(),
            TargetReduction::Fixed => format!("the {dims}-D fits"),
        };
        other_colour_search(goal, &mut run, base.colour_mode(), first, &what)?;
    }
    larger_budget_search(goal, &mut run, coefficients)?;
    if let (Some(bytes), false) = (goal.budget.bytes, fit_in_hand(&run.searches)) {
        let name = format!(
            "the {dims}-D fits with the budget split evenly between the {} functions ({} coefficients each at most)",
            base.colour_mode().names().len(),
            split_cap(base, bytes)
        );
        run.searches
            .push((name, split_budget_search(goal, base, bytes, budget_s)?));
    }
    Ok(conclude(run, floor, grid_choice, budget_s))
}

/// A search's name: `what`, in `mode` when the colour mode is left to the
/// search (two modes may then be tried).
fn in_mode(colour: TargetColour, what: &str, mode: brdf::ColourMode) -> String {
    match colour {
        TargetColour::Auto => format!("{what} in {mode}"),
        TargetColour::Fixed => what.to_string(),
    }
}

/// The search of `first`'s reduction (its settings and index among the
/// searches, named `what`) in the other colour mode than `mode`, recorded
/// in `run`: only where that reduction still holds the best fit and
/// [`other_colour_may_help`], and with a time allowance of its own from
/// its start, within the budget.
fn other_colour_search(
    goal: &Goal,
    run: &mut Searches,
    mode: brdf::ColourMode,
    (settings, k): (brdf::BrdfFitSettings, usize),
    what: &str,
) -> Result<(), RenderError> {
    let searches = &run.searches;
    if lowest_error(searches) != Some(k) || !other_colour_may_help(mode, &searches[k].1.tried) {
        return Ok(());
    }
    let other = other_colour(mode);
    let settings = settings.with_colour_mode(other);
    let deadline_s = share_from_now(goal, OTHER_COLOUR_SHARE);
    run.unless_spent(goal, in_mode(TargetColour::Auto, what, other), |in_hand| {
        reduction_search(goal, &settings, deadline_s, in_hand)
    })?;
    Ok(())
}

/// With [`TargetReduction::Auto`]: the slice's settings (from
/// `slice_base`), what the table seen through it renders at, and the
/// slice's search when that reaches the target, so that the slice is
/// searched first; otherwise its search waits for the 3-D fits.
fn slice_first(
    goal: &Goal,
    slice_base: &brdf::BrdfFitSettings,
) -> Result<(brdf::BrdfFitSettings, SliceFloor, Option<Search>), RenderError> {
    let r = on_target_grid(
        slice_base
            .reduction()
            .with_kind(brdf::ReductionKind::Slice2d)
            .whole_hemisphere(),
    );
    let settings = slice_base.clone().with_reduction(r);
    let f = slice_floor(goal)?;
    if f.worst_mean_de > goal.target_de {
        return Ok((settings, f, None));
    }
    let s = reduction_search(goal, &settings, SLICE_SHARE * goal.budget.seconds, false)?;
    let searched = SliceFloor {
        searched: true,
        ..f
    };
    Ok((settings, searched, Some(s)))
}

/// The settings of `base`'s own reduction's search, on the log scale with
/// [`TargetScale::Auto`], and its name.
fn own_reduction(
    base: &brdf::BrdfFitSettings,
    scale: TargetScale,
) -> (String, brdf::BrdfFitSettings) {
    let own = match scale {
        TargetScale::Auto => base.clone().with_value_scale(brdf::ValueScale::Log),
        TargetScale::Fixed => base.clone(),
    };
    let on_scale = match own.value_scale() {
        brdf::ValueScale::Linear => String::new(),
        other => format!(" ({other} scale)"),
    };
    let dims = base.reduction().dims();
    (format!("the {dims}-D fits{on_scale}"), own)
}

/// The smallest perceptual fit whose validation renders reach mean
/// CIEDE2000 `<= target_de` on both scenes. The fits cover the whole
/// hemisphere unless `base` has an elevation cut; each whole-hemisphere
/// fit is judged at the evaluation cut its renders prefer
/// ([`super::choose_evaluation_cut`]). Tolerances from
/// `+-16%` down to `+-2%` are tried in turn (looser intervals give fewer
/// coefficients, usually), stopping at the first that reaches the target
/// or when `budget.seconds` is spent; when none does, the fit
/// with the lowest error is returned and the report says so. The time
/// budget is checked between fits, so the last fit and its validation may
/// run past it; past it no fit starts, in any search, once one fit within
/// the coefficient and byte budgets is in hand (until then the searches go
/// on loosening: a search cut short then would return nothing), and the
/// report names the searches left out. With `budget.bytes`, only fits within
/// it are returned: no function is given more coefficients than the budget
/// holds (an RGB channel a third of it), a shell factor that would pass it is left out, and a tolerance
/// whose fit passes it is followed by looser ones (by sqrt 2, to +-64%;
/// within a cut, to the whole hemisphere's best tolerance at most)
/// instead of tighter ones; when still no fit is within it, the 3-D
/// search runs again with the budget split evenly between the functions.
/// With [`super::TargetCoefficients::Auto`], while the target is unreached and
/// the best fit renders within twice it ([`super::LARGER_BUDGET_REACH`]),
/// the search with the lowest error runs again with twice the coefficient
/// budget per function ([`super::LARGER_BUDGET_FACTOR`]) from its tightest
/// tolerance, where that budget rather than the byte budget stopped it (a
/// function had no fit within it or was widened there, and the byte budget
/// holds every function at it): without a byte budget, the target then
/// decides the size beyond the base settings' budget too.
///
/// With [`TargetReduction::Auto`], the 2-D slice (90 x 90 grid) is also
/// searched, for at most 40% of the budget from its own start: it costs fewer bytes, but its
/// error stops falling at what the reduction itself loses (a tighter
/// tolerance that improves by less than 10% ends it). What the table seen
/// through the slice renders at ([`super::SliceFloor`], one validation)
/// orders the searches: at or below the target the slice comes first and
/// the 3-D fits of `base` follow unless it reached the target; above it a
/// slice fit would have to render under what the slice itself loses to
/// reach the target, so the 3-D fits come first and the slice follows
/// only when their best renders above that floor. The
/// report names the reduction chosen, why, the floor and each search's
/// best error. With
/// [`TargetReduction::Fixed`], `base`'s reduction alone is used. With
/// [`TargetColour::Auto`], the first reduction is then also searched in
/// the other colour mode (RGB after luminance-chroma) when the target is
/// unreached, that reduction holds the best fit and the chroma ratios,
/// not the luminance, limited it; that search starts fits within 60% of
/// the time budget from its own start (within the budget itself). With [`TargetScale::Auto`], the
/// search of `base`'s own reduction fits every function on the log scale
/// and the others on `base`'s scale. `base`
/// gives the engine, grid and design (its relative half-width is
/// replaced). When a 3-D fit does not reach the target, the report also
/// gives what the table itself renders at on that fit's grid
/// ([`super::GridFloor`]).
///
/// # Errors
/// A non-positive target or time budget, a byte budget under 8 bytes, no
/// fit within the coefficient or byte budget even at the loosest
/// tolerance, or a fit or render that fails.
pub fn fit_to_target(
    table: Arc<dyn Brdf>,
    target_de: f64,
    base: &brdf::BrdfFitSettings,
    choices: TargetChoices,
    validation: ValidationSettings,
    budget: TargetBudget,
) -> Result<(brdf::FittedBrdf, TargetReport), RenderError> {
    let start = Instant::now();
    check_target(target_de, &budget)?;
    let validator = Validator::new(table.clone(), validation)?;
    let goal = Goal {
        validator: &validator,
        table: &table,
        target_de,
        budget,
        start,
        overlap: true,
    };
    let Searched {
        why,
        best,
        tried,
        slice_floor,
        grid_choice,
    } = run_searches(&goal, base, choices)?;
    let Some(best) = best else {
        return Err(no_fit_within_budgets(&table.name(), budget.bytes, &tried));
    };
    let Measured {
        fitted,
        errors,
        attempt,
        point_choice,
        ..
    } = best;
    let reached = errors.worst_mean() <= target_de;
    let grid_floor = if !reached && fitted.reduction.kind == brdf::ReductionKind::Full3d {
        let r = &fitted.reduction;
        let bins = [r.n_theta_h, r.n_theta_d, r.n_phi_d];
        // The grid choice measured the base grid already.
        match grid_choice.map(|c| c.base).filter(|f| f.bins == bins) {
            Some(floor) => Some(floor),
            None => Some(grid_floor(&goal, bins)?),
        }
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
        grid_choice,
        slice_floor,
        colour_split,
        dims: fitted.reduction.dims(),
        colour: fitted.mode,
        scale: fitted.scale,
        why,
        rel_tol: attempt.rel_tol,
        bytes: fitted.byte_size_f32(),
        max_bytes: budget.bytes,
        evaluation_cut: attempt.cut,
        fitted_within: attempt.fitted_within,
        widened: attempt.widened,
        shell_bytes: fitted.shell.as_ref().map(brdf::ShellFactor::byte_size_f32),
        shell_layout: fitted.shell.as_ref().map(brdf::ShellFactor::layout),
        scenes: errors.scenes.clone(),
        noise: validator.noise.clone(),
        point_choice,
        tried,
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((fitted, report))
}

/// The target and the budgets [`fit_to_target`] accepts.
fn check_target(target_de: f64, budget: &TargetBudget) -> Result<(), RenderError> {
    if !(target_de > 0.0 && target_de.is_finite()) {
        return Err(crate::error::invalid(
            "target_de",
            format!("{target_de} is not a positive number"),
        ));
    }
    if !(budget.seconds > 0.0 && budget.seconds.is_finite()) {
        return Err(crate::error::invalid(
            "time budget",
            format!("{} is not a positive number of seconds", budget.seconds),
        ));
    }
    if let Some(bytes) = budget.bytes.filter(|&b| b < 8) {
        return Err(crate::error::invalid(
            "max_bytes",
            format!("{bytes} bytes cannot hold a rational function (at least 2 coefficients of 4 bytes)"),
        ));
    }
    Ok(())
}

/// The error of a target search that found no fit within the coefficient
/// budget, or within `max_bytes`, even at the loosest tolerance.
fn no_fit_within_budgets(
    name: &str,
    max_bytes: Option<usize>,
    tried: &[TargetAttempt],
) -> RenderError {
    let smallest = tried
        .iter()
        .filter_map(|a| a.result.map(|(bytes, _)| bytes))
        .min();
    let loosest_tried = tried.iter().map(|a| a.rel_tol).fold(0.0, f64::max);
    match (max_bytes, smallest) {
        (Some(max), Some(smallest)) => crate::error::invalid(
            "max_bytes",
            format!(
                "no perceptual fit of {} within {max} bytes, even at +-{}%: the smallest tried has {smallest} bytes",
                name,
                brdf::scale_text(loosest_tried * 100.0)
            ),
        ),
        _ => crate::error::invalid(
            "target_de",
            format!(
                "no perceptual fit of {} within the coefficient budget, even at +-{}%",
                name,
                brdf::scale_text(LOOSER[LOOSER.len() - 1] * 100.0)
            ),
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf::ColourMode;

    fn attempt(limiting: Option<char>) -> TargetAttempt {
        TargetAttempt {
            dims: 2,
            colour: ColourMode::LuminanceChroma,
            scale: brdf::ValueScale::Linear,
            rel_tol: 0.16,
            seconds: 1.0,
            result: limiting.map(|_| (400, 3.0)),
            widened: if limiting.is_some() { 2.0 } else { 1.0 },
            limiting,
            cut: None,
            shell: false,
            over_budget: false,
            fitted_within: None,
            larger_budget: None,
        }
    }

    /// RGB follows luminance-chroma only where a chroma ratio, never the
    /// luminance, limited a fit; luminance-chroma follows RGB always.
    #[test]
    fn rgb_is_tried_where_the_chroma_ratios_limit() {
        let lc = ColourMode::LuminanceChroma;
        let may = |limits: &[Option<char>]| {
            let tried: Vec<TargetAttempt> = limits.iter().map(|&l| attempt(l)).collect();
            other_colour_may_help(lc, &tried)
        };
        assert!(!may(&[]));
        assert!(!may(&[None, None]));
        assert!(may(&[Some('r')]));
        assert!(may(&[None, Some('b'), Some('r')]));
        assert!(!may(&[Some('r'), Some('Y')]));
        assert!(!may(&[Some('Y')]));
        assert!(other_colour_may_help(ColourMode::Rgb, &[]));
        assert_eq!(other_colour(lc), ColourMode::Rgb);
        assert_eq!(other_colour(ColourMode::Rgb), lc);
    }
}
