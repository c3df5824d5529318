//! The target search (`render_cpu::fidelity::fit_to_target`) on a glossy
//! analytic material and tiny renders: widening, the byte and time
//! budgets, the colour modes, scales and reductions it chooses, and the
//! larger coefficient budget.

use brdf::ColourMode;
use render_cpu::fidelity::TargetColour;

/// The glossy Blinn-Phong material of these searches (a function of
/// `theta_h` alone).
fn glossy_blinn_phong() -> std::sync::Arc<brdf::BlinnPhong> {
    std::sync::Arc::new(brdf::BlinnPhong {
        kd: [0.2, 0.3, 0.1],
        ks: [0.3, 0.3, 0.3],
        exponent: 30.0,
    })
}

/// The report of an RGB target fit of a glossy Blinn-Phong material on a
/// `bins` 3-D grid within `max_coeffs` coefficients per function and
/// `max_bytes`, validated on tiny renders.
fn glossy_target_fit(
    target: f64,
    bins: [usize; 3],
    max_coeffs: usize,
    max_bytes: Option<usize>,
) -> Result<render_cpu::fidelity::TargetReport, render_cpu::RenderError> {
    glossy_target_fit_in(
        target,
        bins,
        max_coeffs,
        max_bytes,
        (brdf::ColourMode::Rgb, TargetColour::Fixed),
    )
}

/// [`glossy_target_fit`] from colour mode `colour.0`, with the colour modes
/// `colour.1` allows.
fn glossy_target_fit_in(
    target: f64,
    bins: [usize; 3],
    max_coeffs: usize,
    max_bytes: Option<usize>,
    colour: (brdf::ColourMode, TargetColour),
) -> Result<render_cpu::fidelity::TargetReport, render_cpu::RenderError> {
    let glossy = glossy_blinn_phong();
    let fixed = render_cpu::fidelity::TargetReduction::Fixed;
    let linear = render_cpu::fidelity::TargetScale::Fixed;
    target_fit(
        glossy,
        (target, 60.0),
        (bins, max_coeffs, max_bytes),
        colour,
        (fixed, linear, NAMED),
    )
}

/// The coefficient budget of the searches that keep the test's own.
const NAMED: render_cpu::fidelity::TargetCoefficients =
    render_cpu::fidelity::TargetCoefficients::Fixed;

/// A target fit of `material` from `grid`'s 3-D grid (bins, coefficients per
/// function and byte budget), in `colour`, with the reductions, scales and
/// coefficient budgets `choices` allows (from linear functions), validated
/// on tiny renders, within `seconds`; the grid is the test's own.
fn target_fit(
    material: std::sync::Arc<dyn brdf::Brdf>,
    (target, seconds): (f64, f64),
    grid: ([usize; 3], usize, Option<usize>),
    colour: (brdf::ColourMode, TargetColour),
    choices: (
        render_cpu::fidelity::TargetReduction,
        render_cpu::fidelity::TargetScale,
        render_cpu::fidelity::TargetCoefficients,
    ),
) -> Result<render_cpu::fidelity::TargetReport, render_cpu::RenderError> {
    use brdf::{BrdfFitSettings, PerceptualBounds, Reduction, ReductionKind};
    use render_cpu::fidelity::{fit_to_target, TargetBudget, ValidationSettings};
    let (bins, max_coeffs, max_bytes) = grid;
    let grid = Reduction::default()
        .with_kind(ReductionKind::Full3d)
        .with_resolution(bins[0], bins[1])
        .with_phi_resolution(bins[2])
        .whole_hemisphere();
    let settings = BrdfFitSettings::default()
        .with_reduction(grid)
        .with_baselines(false)
        .with_colour_mode(colour.0)
        .with_design(PerceptualBounds::default())
        .with_fit_settings(
            rational_core::FitSettings::default()
                .with_coeff_range(2, max_coeffs)
                .unwrap(),
        );
    let validation = ValidationSettings {
        size: 16,
        lights_spp: 1,
        sky_spp: 4,
        seed: 1,
    };
    // The grid is the test's own.
    let choices = render_cpu::fidelity::TargetChoices {
        reduction: choices.0,
        colour: colour.1,
        scale: choices.1,
        grid: render_cpu::fidelity::TargetGrid::Fixed,
        coefficients: choices.2,
    };
    fit_to_target(
        material,
        target,
        &settings,
        choices,
        validation,
        TargetBudget::seconds(seconds).with_bytes(max_bytes),
    )
    .map(|(fitted, report)| {
        assert_eq!(fitted.byte_size_f32(), report.bytes);
        report
    })
}

/// [`glossy_target_fit`] without a byte budget.
fn glossy_target_report(
    target: f64,
    bins: [usize; 3],
    max_coeffs: usize,
) -> render_cpu::fidelity::TargetReport {
    glossy_target_fit(target, bins, max_coeffs, None).unwrap()
}

/// A target below what the 3-D grid keeps is reported as such: the report
/// gives the table's own error on that grid, and only when the target is
/// missed.
#[test]
fn a_missed_target_reports_what_the_grid_itself_renders_at() {
    let missed = glossy_target_report(1e-3, [5, 5, 4], 30);
    assert!(!missed.reached);
    let floor = missed
        .grid_floor
        .expect("a missed 3-D target gives the grid's error");
    assert_eq!(floor.bins, [5, 5, 4]);
    assert!(
        floor.worst_mean_de.is_finite() && floor.worst_mean_de > 1e-3,
        "{floor:?}"
    );
    assert!(missed.to_string().contains("5 x 5 x 4 grid"), "{missed}");
    let reached = glossy_target_report(1e3, [5, 5, 4], 30);
    assert!(reached.reached && reached.grid_floor.is_none());
}

/// A tolerance with no fit within the budget is widened by sqrt 2, channel
/// by channel, at most twice: each attempt reports 1, 1.41 or 2, and a
/// budget that only misses a little lands at 1.41 rather than 2.
#[test]
fn target_fits_widen_by_sqrt_2_at_most_twice() {
    let widened: Vec<f64> = (4..=10)
        .flat_map(|max_coeffs| {
            glossy_target_report(1e-3, [6, 6, 4], max_coeffs)
                .tried
                .iter()
                .filter(|a| a.result.is_some())
                .map(|a| a.widened)
                .collect::<Vec<_>>()
        })
        .collect();
    let allowed = [1.0, std::f64::consts::SQRT_2, 2.0];
    for w in &widened {
        assert!(
            allowed.iter().any(|a| (w / a - 1.0).abs() < 1e-9),
            "widened x{w}: {widened:?}"
        );
    }
    assert!(
        widened
            .iter()
            .any(|w| (w / std::f64::consts::SQRT_2 - 1.0).abs() < 1e-9),
        "no fit landed at x1.41: {widened:?}"
    );
}

/// A byte budget is never passed: fits over it are listed as such (measured
/// as fitted, no evaluation cut chosen) and not returned, and a tolerance whose fit passes it is followed by looser ones
/// (tighter ones would only grow); each RGB channel is held to a third of
/// it; a budget nothing fits in is an error that names it.
#[test]
fn a_target_fit_stays_within_its_byte_budget() {
    // A target every evaluation reaches: the loosest tolerance, no shell.
    let lc = (ColourMode::LuminanceChroma, TargetColour::Fixed);
    let free = glossy_target_fit_in(1e3, [6, 6, 4], 30, None, lc).unwrap();
    assert!(free.reached && free.max_bytes.is_none() && free.shell_bytes.is_none());
    assert!((free.rel_tol - 0.16).abs() < 1e-12, "{free}");
    let budget = free.bytes - 4;
    let bounded = glossy_target_fit_in(1e3, [6, 6, 4], 30, Some(budget), lc).unwrap();
    assert_eq!(bounded.max_bytes, Some(budget));
    assert!(bounded.bytes <= budget, "{bounded}");
    for a in &bounded.tried {
        let over = a.result.is_some_and(|(bytes, _)| bytes > budget);
        assert_eq!(a.over_budget, over, "{bounded}");
        // Over the budget at every cut: measured as fitted, no cut chosen.
        assert!(!over || (a.cut.is_none() && !a.shell), "{bounded}");
    }
    assert!(bounded.tried[0].over_budget, "{bounded}");
    assert!(
        bounded.tried.iter().all(|a| a.rel_tol >= 0.16),
        "a fit over the budget is followed by looser tolerances only: {bounded}"
    );
    assert!(bounded.rel_tol > 0.16, "{bounded}");
    let text = bounded.to_string();
    assert!(text.contains(&format!("of at most {budget}")), "{text}");
    assert!(
        text.contains("(over the byte budget), worse mean CIEDE2000")
            && text.contains("as fitted (no evaluation cut or shell factor tried)"),
        "{text}"
    );
    // RGB channels carry the whole shape each: held to a third of the
    // budget, no fit passes it, and the first tolerance widens instead.
    let free_rgb = glossy_target_report(1e3, [6, 6, 4], 30);
    let rgb_budget = free_rgb.bytes - 4;
    let rgb = glossy_target_fit(1e3, [6, 6, 4], 30, Some(rgb_budget)).unwrap();
    assert!(rgb.bytes <= rgb_budget, "{rgb}");
    assert!(rgb.tried.iter().all(|a| !a.over_budget), "{rgb}");
    assert!(
        (rgb.rel_tol - 0.16).abs() < 1e-12 && rgb.widened > 1.0,
        "{rgb}"
    );
    let err = glossy_target_fit(1e-3, [6, 6, 4], 30, Some(8)).unwrap_err();
    assert!(err.to_string().contains("within 8 bytes"), "{err}");
    let err = glossy_target_fit(1e-3, [6, 6, 4], 30, Some(4)).unwrap_err();
    assert!(err.to_string().contains("max_bytes"), "{err}");
}

/// A search loosened for bytes (its first fit over the budget, the next
/// looser one within) bisects that bracket twice, geometrically, and
/// returns the lowest worse-scene error of the fits within the budget.
#[test]
fn a_search_loosened_for_bytes_bisects_the_tolerance_between_twice() {
    let lc = (ColourMode::LuminanceChroma, TargetColour::Fixed);
    let free = glossy_target_fit_in(1e3, [6, 6, 4], 30, None, lc).unwrap();
    let budget = free.bytes - 4;
    let missed = glossy_target_fit_in(1e-3, [6, 6, 4], 30, Some(budget), lc).unwrap();
    assert!(!missed.reached && missed.bytes <= budget, "{missed}");
    // The whole hemisphere's search: over the budget from 16%, within it
    // looser, then the tolerance between.
    let whole: Vec<_> = missed
        .tried
        .iter()
        .filter(|a| a.fitted_within.is_none())
        .collect();
    let first_within = whole
        .iter()
        .position(|a| a.result.is_some() && !a.over_budget)
        .expect("a fit within the budget");
    assert!(first_within >= 1, "{missed}");
    let (over, within) = (&whole[first_within - 1], &whole[first_within]);
    assert!(
        over.over_budget && over.rel_tol < within.rel_tol,
        "{missed}"
    );
    // Twice the tolerance halfway (geometrically) between the tightest
    // within the budget and the loosest past it so far.
    let (mut tight, mut loose) = (over.rel_tol, within.rel_tol);
    for between in &whole[first_within + 1..] {
        let halfway = (tight * loose).sqrt();
        assert!((between.rel_tol - halfway).abs() < 1e-12, "{missed}");
        if between.over_budget {
            tight = between.rel_tol;
        } else {
            loose = between.rel_tol;
        }
    }
    assert_eq!(whole.len(), first_within + 3, "bisected twice: {missed}");
    let worst = |a: &render_cpu::fidelity::TargetAttempt| a.result.map(|(_, e)| e);
    let best_within = whole[first_within..]
        .iter()
        .filter(|a| !a.over_budget)
        .filter_map(|a| worst(a))
        .fold(f64::INFINITY, f64::min);
    let returned = missed.scenes.iter().map(|e| e.mean_de).fold(0.0, f64::max);
    assert!(returned <= best_within, "{missed}");
}

/// With the colour mode left to it, a missed target is also searched in
/// the other mode (luminance-chroma after RGB), every attempt names its
/// mode, and the fit returned is the lowest worse-scene error of all;
/// a target the first mode reaches tries no other.
#[test]
fn a_missed_target_is_searched_in_both_colour_modes() {
    use brdf::ColourMode;
    let both = glossy_target_fit_in(
        1e-3,
        [6, 6, 4],
        30,
        None,
        (ColourMode::Rgb, TargetColour::Auto),
    )
    .unwrap();
    assert!(!both.reached);
    let modes = |r: &render_cpu::fidelity::TargetReport, m: ColourMode| {
        r.tried.iter().filter(|a| a.colour == m).count()
    };
    assert!(modes(&both, ColourMode::Rgb) > 0, "{both}");
    assert!(modes(&both, ColourMode::LuminanceChroma) > 0, "{both}");
    let lowest = both
        .tried
        .iter()
        .filter(|a| !a.over_budget)
        .filter_map(|a| a.result.map(|(_, worst)| (worst, a.colour)))
        .min_by(|a, b| a.0.total_cmp(&b.0))
        .unwrap();
    let chosen = both.scenes.iter().map(|s| s.mean_de).fold(0.0, f64::max);
    assert!((chosen - lowest.0).abs() < 1e-9, "{both}");
    assert_eq!(both.colour, lowest.1, "{both}");
    let text = both.to_string();
    assert!(text.contains("in luminance-chroma"), "{text}");
    assert!(text.contains("-D rgb +-"), "{text}");
    assert!(text.contains("-D luminance-chroma +-"), "{text}");
    // The same search with the mode fixed tries RGB alone.
    let fixed = glossy_target_report(1e-3, [6, 6, 4], 30);
    assert_eq!(modes(&fixed, ColourMode::LuminanceChroma), 0, "{fixed}");
    // A target RGB reaches is not searched further.
    let reached = glossy_target_fit_in(
        1e3,
        [6, 6, 4],
        30,
        None,
        (ColourMode::Rgb, TargetColour::Auto),
    )
    .unwrap();
    assert!(reached.reached, "{reached}");
    assert_eq!(modes(&reached, ColourMode::LuminanceChroma), 0, "{reached}");
    assert_eq!(reached.colour, ColourMode::Rgb);
}

/// A target fit of `material` with the reduction left to the search (the
/// 2-D slice or the 3-D grid), in luminance-chroma.
fn auto_reduction_report(
    material: std::sync::Arc<dyn brdf::Brdf>,
    target: f64,
) -> render_cpu::fidelity::TargetReport {
    let lc = (ColourMode::LuminanceChroma, TargetColour::Fixed);
    let auto = render_cpu::fidelity::TargetReduction::Auto;
    let linear = render_cpu::fidelity::TargetScale::Fixed;
    target_fit(
        material,
        (target, 60.0),
        ([6, 6, 4], 30, None),
        lc,
        (auto, linear, NAMED),
    )
    .unwrap()
}

/// With the scales automatic, the whole hemisphere's fits have every
/// function on the log scale and the fits within a cut after them keep
/// the base settings' linear scale; the report names the scale of the fit
/// it returns, which evaluates as its functions' `exp`.
#[test]
fn automatic_scales_fit_the_whole_hemisphere_on_the_log_scale_and_the_cut_linearly() {
    let glossy = glossy_blinn_phong();
    let lc = (ColourMode::LuminanceChroma, TargetColour::Fixed);
    let choices = (
        render_cpu::fidelity::TargetReduction::Fixed,
        render_cpu::fidelity::TargetScale::Auto,
        NAMED,
    );
    // Unreachable, with a byte budget: the search within the cut runs too.
    let report = target_fit(
        glossy,
        (1e-3, 60.0),
        ([6, 6, 4], 30, Some(1024)),
        lc,
        choices,
    )
    .unwrap();
    let (whole, within): (Vec<_>, Vec<_>) =
        report.tried.iter().partition(|a| a.fitted_within.is_none());
    assert!(!whole.is_empty() && !within.is_empty(), "{report}");
    assert!(
        whole.iter().all(|a| a.scale == brdf::ValueScale::Log),
        "{report}"
    );
    assert!(within.iter().all(|a| a.scale.is_linear()), "{report}");
    let text = report.to_string();
    assert!(text.contains("luminance-chroma log +-"), "{text}");
    assert!(text.contains("(log scale)"), "{text}");
    let chosen_log = report.fitted_within.is_none();
    assert_eq!(
        report.scale == brdf::ValueScale::Log,
        chosen_log,
        "{report}"
    );
}

/// The slice is searched first when the table seen through it reaches the
/// target; otherwise the 3-D fits come first, and the slice follows only
/// when their best renders above what the table seen through it does.
#[test]
fn the_slice_is_searched_first_only_when_its_floor_reaches_the_target() {
    // Blinn-Phong depends on theta_h alone: the slice loses nothing.
    let blinn: std::sync::Arc<dyn brdf::Brdf> = glossy_blinn_phong();
    let easy = auto_reduction_report(blinn, 3.0);
    let floor = easy
        .slice_floor
        .expect("an automatic reduction measures it");
    assert!(floor.worst_mean_de <= 3.0 && floor.searched, "{easy}");
    assert_eq!(easy.tried[0].dims, 2, "{easy}");
    assert!(easy.to_string().contains("the slice was searched first"));
    // GGX's shadowing depends on phi_d: a target below the slice's floor
    // starts with the 3-D fits.
    let ggx: std::sync::Arc<dyn brdf::Brdf> = std::sync::Arc::new(brdf::CookTorranceGgx {
        kd: [0.1, 0.15, 0.2],
        f0: [0.5, 0.5, 0.5],
        alpha: 0.4,
    });
    let hard = auto_reduction_report(ggx, 1e-3);
    let floor = hard
        .slice_floor
        .expect("an automatic reduction measures it");
    assert!(floor.worst_mean_de > 1e-3, "{hard}");
    assert_eq!(hard.tried[0].dims, 3, "{hard}");
    let best_3d = hard
        .tried
        .iter()
        .filter(|a| a.dims == 3)
        .filter_map(|a| a.result.map(|(_, worst)| worst))
        .fold(f64::INFINITY, f64::min);
    let slice_tried = hard.tried.iter().any(|a| a.dims == 2);
    assert_eq!(slice_tried, floor.searched, "{hard}");
    assert_eq!(floor.searched, best_3d > floor.worst_mean_de, "{hard}");
    assert!(hard
        .to_string()
        .contains("the table seen through the 2-D slice"));
}

/// Past the time budget no search starts once a fit within the budgets is
/// in hand, and the report names the searches left out; the first search
/// goes on until it has a fit, however small the budget.
#[test]
fn a_spent_time_budget_starts_no_search_once_a_fit_is_in_hand() {
    let glossy = glossy_blinn_phong();
    let fixed = (
        render_cpu::fidelity::TargetReduction::Fixed,
        render_cpu::fidelity::TargetScale::Fixed,
        NAMED,
    );
    let auto_colour = (ColourMode::Rgb, TargetColour::Auto);
    // Unreachable, with a byte budget: with time, the search within a cut
    // and the other colour mode follow the whole hemisphere's fits.
    let search = |seconds: f64| {
        target_fit(
            glossy.clone(),
            (1e-3, seconds),
            ([6, 6, 4], 30, Some(1024)),
            auto_colour,
            fixed,
        )
        .unwrap()
    };
    let with_time = search(600.0);
    assert!(
        with_time.tried.iter().any(|a| a.fitted_within.is_some()),
        "{with_time}"
    );
    assert!(
        !with_time.to_string().contains("not searched"),
        "{with_time}"
    );
    let spent = search(1e-6);
    assert!(spent.bytes > 0 && spent.bytes <= 1024, "{spent}");
    assert!(spent
        .tried
        .iter()
        .any(|a| !a.over_budget && a.result.is_some()));
    assert!(
        spent.tried.iter().all(|a| a.fitted_within.is_none()),
        "{spent}"
    );
    assert!(
        spent.tried.iter().all(|a| a.colour == ColourMode::Rgb),
        "{spent}"
    );
    let text = spent.to_string();
    assert!(
        text.contains(
            "not searched, the time budget of 0.000001 s being spent: the 3-D fits within"
        ),
        "{text}"
    );
}

/// With the coefficient budget left to the search, a target missed by at
/// most twice, whose tightest tolerance the budget bounded, is searched
/// again with twice the budget, from that tolerance and never looser, and
/// the report names the budget of each such fit; not with the budget
/// fixed, nor where the byte budget cannot hold every function at the
/// first budget, nor for a target missed by more than twice.
#[test]
fn a_missed_target_bounded_by_coefficients_is_searched_with_twice_the_budget() {
    use render_cpu::fidelity::TargetCoefficients;
    let glossy = glossy_blinn_phong();
    let lc = (ColourMode::LuminanceChroma, TargetColour::Fixed);
    let search = |target: f64, coefficients: TargetCoefficients, max_bytes: Option<usize>| {
        let fixed = render_cpu::fidelity::TargetReduction::Fixed;
        let linear = render_cpu::fidelity::TargetScale::Fixed;
        target_fit(
            glossy.clone(),
            (target, 600.0),
            ([6, 6, 4], 8, max_bytes),
            lc,
            (fixed, linear, coefficients),
        )
        .unwrap()
    };
    let fixed = search(1e-3, TargetCoefficients::Fixed, None);
    assert!(!fixed.reached);
    // A target the first search's best fit misses by 1.5 times: no fit of
    // that search reaches it, so that search runs as for 1e-3.
    let worst = fixed.scenes.iter().map(|s| s.mean_de).fold(0.0, f64::max);
    let near = worst / 1.5;
    assert!(fixed.tried.iter().all(|a| a.larger_budget.is_none()));
    // The precondition: the budget of 8 bounds the tightest tolerance.
    let tightest = (fixed.tried.iter())
        .min_by(|a, b| a.rel_tol.total_cmp(&b.rel_tol))
        .unwrap();
    assert!(
        tightest.result.is_none() || tightest.widened > 1.0,
        "{fixed}"
    );
    let auto = search(near, TargetCoefficients::Auto, None);
    let (first, larger): (Vec<_>, Vec<_>) =
        auto.tried.iter().partition(|a| a.larger_budget.is_none());
    assert_eq!(first.len(), fixed.tried.len(), "{auto}");
    assert!(!larger.is_empty(), "{auto}");
    assert!(larger.iter().all(|a| a.larger_budget == Some(16)), "{auto}");
    assert!(
        larger.iter().all(|a| a.rel_tol <= tightest.rel_tol),
        "{auto}"
    );
    assert!(
        auto.to_string()
            .contains("with up to 16 coefficients per function"),
        "{auto}"
    );
    // Three functions of 8 coefficients need 96 bytes: the bytes bound first.
    let bytes = search(near, TargetCoefficients::Auto, Some(95));
    assert!(
        bytes.tried.iter().all(|a| a.larger_budget.is_none()),
        "{bytes}"
    );
    let far = search(worst / 3.0, TargetCoefficients::Auto, None);
    assert!(far.tried.iter().all(|a| a.larger_budget.is_none()), "{far}");
}

/// The search's fits are centred; the returned fit is the one of its two
/// points (least squares within the intervals, largest margin) whose
/// renders are closer, and the report gives both errors.
#[test]
fn the_returned_fit_has_the_point_that_renders_closer() {
    let report = glossy_target_report(1e-3, [8, 8, 4], 30);
    let choice = report
        .point_choice
        .expect("a centred fit is measured at both points");
    let worst = report.scenes.iter().map(|s| s.mean_de).fold(0.0, f64::max);
    let closer = choice.least_squares.min(choice.largest_margin);
    assert_eq!(worst.to_bits(), closer.to_bits(), "{report}");
    let kept = if choice.largest_margin_chosen() {
        "at their largest-margin points"
    } else {
        "at their least-squares points within the intervals"
    };
    assert!(report.to_string().contains(kept), "{report}");
}
