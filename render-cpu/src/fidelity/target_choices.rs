//! What a target fit starts from and what it may choose: the default grid,
//! budgets and settings of [`super::fit_to_target`], and the choices its
//! caller leaves to it (reductions, colour modes, scales, grid).

use super::target_grid::TargetGrid;
use serde::Serialize;

/// Which reductions [`super::fit_to_target`] may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum TargetReduction {
    /// The 2-D `phi_d = pi/2` slice (fewer bytes, fast fits) and the 3-D
    /// grid: the slice first when the table seen through it reaches the
    /// target ([`super::SliceFloor`]), the 3-D grid when the slice's fits
    /// stop improving above it; otherwise the 3-D grid first, and the
    /// slice only when its fits render above that floor.
    Auto,
    /// The base settings' reduction only.
    Fixed,
}

/// Which colour modes [`super::fit_to_target`] may use.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum TargetColour {
    /// The base settings' mode; then, while the target is unreached and
    /// the first reduction (the slice with [`TargetReduction::Auto`], when
    /// it was searched) holds the best fit, the other mode on that reduction: RGB after
    /// luminance-chroma when a chroma ratio, never the luminance, limited
    /// its fits (RGB channels need no ratio, whose intervals a coloured
    /// highlight widens most), luminance-chroma after RGB always.
    Auto,
    /// The base settings' mode only.
    Fixed,
}

/// Which scales [`super::fit_to_target`] may fit the functions on
/// ([`brdf::ValueScale`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum TargetScale {
    /// The search of the base settings' own reduction (the 3-D grid over
    /// the whole hemisphere, by default) with every function on the log
    /// scale, where a sharp or coloured highlight costs the fewest
    /// coefficients; the searches after it (within a cut, the slice, the
    /// other colour mode, the split budget) on the base settings' scale.
    /// The validation renders choose among all their fits.
    Auto,
    /// The base settings' scale in every search.
    Fixed,
}

/// Which coefficient budgets [`super::fit_to_target`] may give a function.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum TargetCoefficients {
    /// The base settings' budget; then, while the target is unreached, the
    /// best search renders within [`LARGER_BUDGET_REACH`] times it, and
    /// that budget rather than the byte budget bounds that search (at its
    /// tightest tolerance a function had no fit within it, or was widened,
    /// and the byte budget holds every function at that budget), that
    /// search again from that tolerance with [`LARGER_BUDGET_FACTOR`]
    /// times the budget. A larger budget at every tolerance would widen
    /// less and spend more bytes on the looser tolerances too.
    Auto,
    /// The base settings' budget only (a budget the user named).
    Fixed,
}

impl TargetCoefficients {
    /// [`Self::Fixed`] when the caller named a coefficient budget
    /// (`--max-coeffs`, a scene's or the Python package's `max_coeffs`),
    /// [`Self::Auto`] otherwise.
    pub fn unless_named(max_coeffs: Option<usize>) -> Self {
        match max_coeffs {
            None => Self::Auto,
            Some(_) => Self::Fixed,
        }
    }
}

/// What [`TargetCoefficients::Auto`] multiplies the coefficient budget by:
/// once, since a split's solve grows quickly with its size (aurora_white's
/// luminance at 2% has no fit within 120 coefficients and one within 240,
/// whose fit takes more than half of the search's time).
pub const LARGER_BUDGET_FACTOR: usize = 2;

/// How far above the target (a multiple of it, worse scene) the best fit
/// may render for [`TargetCoefficients::Auto`] to search with a larger
/// budget. Twice the coefficients buy about one more halving of the
/// tolerance, and a halving lowers the render error by about 1.5 times on
/// the RGL files (aurora_white: 3.66, 2.32, 1.35, 0.92 at 16%, 8%, 4%,
/// 2%). Without a byte budget, the larger budget took aurora_white from
/// 1.35 to 0.92 and cc_nothern_aurora from 1.36 to 1.00, and
/// cc_iris_purple_gem from 1.85 to 1.33 (93 to 102 s for that fit); from 4.2 to
/// 4.9 it found no fit on chm_mint, a worse one on cc_green_malachite (166
/// s) and 2.99 from 4.30 on chm_light_blue in 134 s, far from the target
/// (docs/results/fidelity-2026-12-07-larger-budget.md).
pub const LARGER_BUDGET_REACH: f64 = 2.0;

/// What [`super::fit_to_target`] may choose besides the tolerance.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct TargetChoices {
    /// The reductions.
    pub reduction: TargetReduction,
    /// The colour modes.
    pub colour: TargetColour,
    /// The scales of the functions.
    pub scale: TargetScale,
    /// The 3-D grid.
    pub grid: TargetGrid,
    /// The coefficient budget per function.
    pub coefficients: TargetCoefficients,
}

impl Default for TargetChoices {
    /// Every choice automatic.
    fn default() -> Self {
        Self {
            reduction: TargetReduction::Auto,
            colour: TargetColour::Auto,
            scale: TargetScale::Auto,
            grid: TargetGrid::Auto,
            coefficients: TargetCoefficients::Auto,
        }
    }
}

/// Bins (`theta_h`, `theta_d`, `phi_d`) of the 3-D grid a target fit
/// samples unless its caller names one. A finer grid renders closer as a
/// table, but its fits need more coefficients at the same intervals and are
/// widened sooner: on the RGL files a 16^3 grid reaches lower errors in
/// fewer bytes than 24^3 (docs/results/fidelity-2026-12-04-target-grid.md),
/// and than 16 x 16 x 8 or 24 x 16 x 8 where the table on it renders
/// within 3 times the target ([`super::TargetGrid::Auto`] moves to the
/// latter beyond; docs/results/fidelity-2026-12-07-grid-bins.md).
pub const TARGET_GRID_3D: [usize; 3] = [16, 16, 16];

/// Largest coefficient budget per function of a target fit by default
/// (`ratfit fit --target-de`, a scene's `target_de`, the Python package):
/// twice the budget of a plain fit, since the tolerance is the search's.
pub const TARGET_MAX_COEFFS: usize = 120;

/// The revision of [`super::fit_to_target`]'s search, to be raised whenever the
/// fits it returns change: a scene's cached target fit is keyed by it, so
/// that a fit made by another search (or cached before the key named the
/// search) is fitted again rather than read back.
pub const TARGET_SEARCH_REVISION: u32 = 7;

/// Seconds a target fit may spend on fits and renders by default
/// (`ratfit fit --time-budget`, a scene's `target_de`, the Python package's
/// `time_budget`), checked between fits: past it no fit starts once one
/// within the budgets is in hand.
pub const TARGET_TIME_BUDGET_S: f64 = 120.0;

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

/// How `phi_d` enters a target fit's 3-D coordinates unless its caller
/// names it: as `cos phi_d`, in which the same intervals mostly need fewer
/// coefficients (docs/results/fidelity-2026-12-06-cos-phi.md).
pub const TARGET_PHI: brdf::PhiCoordinate = brdf::PhiCoordinate::Cosine;

/// The settings a target fit starts from: the 3-D grid of
/// [`TARGET_GRID_3D`] with `phi_d` as [`TARGET_PHI`] over the whole
/// hemisphere, the luminance-chroma mode, the perceptual design (its half-width is the search's) and
/// `engine` (ratfit's commands give it the staircase search), without
/// baselines. Callers change what their user chose: the grid or an
/// elevation cut, the colour mode, a lobe.
pub fn target_settings(engine: rational_core::FitSettings) -> brdf::BrdfFitSettings {
    let reduction = on_target_grid(
        brdf::Reduction::default()
            .with_kind(brdf::ReductionKind::Full3d)
            .with_phi(TARGET_PHI)
            .whole_hemisphere(),
    );
    brdf::BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_baselines(false)
        .with_colour_mode(brdf::ColourMode::LuminanceChroma)
        .with_design(brdf::PerceptualBounds::default())
        .with_fit_settings(engine)
}
