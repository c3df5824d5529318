//! Which 3-D grid a target fit samples: the default grid, or one finer in
//! `theta_h` where the table on the default grid itself renders far above
//! the target.

use super::target_report::GridFloor;
use super::target_search::Goal;
use crate::RenderError;
use serde::Serialize;
use std::sync::Arc;

/// Which 3-D grids [`super::fit_to_target`] may sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum TargetGrid {
    /// The base settings' grid, or [`TARGET_FINE_GRID_3D`] when the table
    /// averaged over the base grid renders above [`FINE_GRID_FLOOR_FACTOR`]
    /// times the target: there the grid's smeared highlight, not the
    /// intervals, is what limits the fits.
    Auto,
    /// The base settings' grid only (a grid the user named).
    Fixed,
}

/// Bins (`theta_h`, `theta_d`, `phi_d`) of the 3-D grid [`TargetGrid::Auto`]
/// moves to: half again the `theta_h` bins of the default 16^3, where the
/// narrow highlights lack samples, paid for with half the `phi_d` bins
/// (3,072 cells against 4,096). On the five RGL files whose table renders
/// above 3 on 16^3, their worse scene falls from 23.48 to 21.48 in all
/// (chm_mint 5.29 to 4.27); on five of the six below 2, where the extra
/// `theta_h` cells take coefficients the byte budget cannot spare, it
/// rises (vch_silk_blue's falls by 0.03;
/// docs/results/fidelity-2026-12-07-grid-bins.md).
pub const TARGET_FINE_GRID_3D: [usize; 3] = [24, 16, 8];

/// The multiple of the target above which the table's own error on the
/// base grid moves [`TargetGrid::Auto`] to [`TARGET_FINE_GRID_3D`]. A fit
/// renders below its grid's table by up to about 2 times on the RGL files
/// (chm_light_blue's 3.71 on a grid whose table renders at 6.56), so a
/// floor under 3 times the target leaves the target to the intervals; the
/// RGL files' floors are 1.1 to 1.8 or 3.6 to 7.7 at a target of 1.
pub const FINE_GRID_FLOOR_FACTOR: f64 = 3.0;

/// What [`TargetGrid::Auto`] measured and chose.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct GridChoice {
    /// The table on the base settings' grid.
    pub base: GridFloor,
    /// The grid the 3-D fits sample instead, if any.
    pub fine: Option<[usize; 3]>,
}

/// The table averaged over a `bins` grid ([`brdf::DownsampledTable`])
/// measured on the validation renders.
pub(super) fn grid_floor(goal: &Goal, bins: [usize; 3]) -> Result<GridFloor, RenderError> {
    let on_grid = brdf::DownsampledTable::new(goal.table.as_ref(), bins);
    Ok(GridFloor {
        bins,
        worst_mean_de: goal.validator.measure(Arc::new(on_grid))?.worst_mean(),
    })
}

/// Whether a table rendering at `floor_de` on the base grid calls for
/// [`TARGET_FINE_GRID_3D`] at a target of `target_de`.
fn wants_fine_grid(floor_de: f64, target_de: f64) -> bool {
    floor_de > FINE_GRID_FLOOR_FACTOR * target_de
}

/// `base` on the grid [`TargetGrid::Auto`] chooses, and what it measured;
/// `base` itself (and `None`) with [`TargetGrid::Fixed`], for a 2-D base,
/// or when the base grid is already [`TARGET_FINE_GRID_3D`].
pub(super) fn choose_grid(
    goal: &Goal,
    base: &brdf::BrdfFitSettings,
    grid: TargetGrid,
) -> Result<(brdf::BrdfFitSettings, Option<GridChoice>), RenderError> {
    let r = base.reduction();
    let bins = [r.n_theta_h, r.n_theta_d, r.n_phi_d];
    if grid == TargetGrid::Fixed
        || r.kind != brdf::ReductionKind::Full3d
        || bins == TARGET_FINE_GRID_3D
    {
        return Ok((base.clone(), None));
    }
    let floor = grid_floor(goal, bins)?;
    if !wants_fine_grid(floor.worst_mean_de, goal.target_de) {
        return Ok((
            base.clone(),
            Some(GridChoice {
                base: floor,
                fine: None,
            }),
        ));
    }
    let [h, d, p] = TARGET_FINE_GRID_3D;
    let fine = base
        .clone()
        .with_reduction(r.with_resolution(h, d).with_phi_resolution(p));
    let choice = GridChoice {
        base: floor,
        fine: Some(TARGET_FINE_GRID_3D),
    };
    Ok((fine, Some(choice)))
}

impl GridChoice {
    /// One line for the report.
    pub fn describe(&self, target_de: f64) -> String {
        let [h, d, p] = self.base.bins;
        let floor = self.base.worst_mean_de;
        match self.fine {
            Some([fh, fd, fp]) => format!(
                "the table itself, averaged over the {h} x {d} x {p} grid, renders at {floor:.3} \
                 (worse scene), over {FINE_GRID_FLOOR_FACTOR} times the target: the 3-D fits \
                 sample a {fh} x {fd} x {fp} grid instead (finer theta_h, for the highlight)"
            ),
            None => format!(
                "the table itself, averaged over the {h} x {d} x {p} grid, renders at {floor:.3} \
                 (worse scene), within {FINE_GRID_FLOOR_FACTOR} times the target ({}): the 3-D \
                 fits sample that grid",
                FINE_GRID_FLOOR_FACTOR * target_de
            ),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_floor_over_three_times_the_target_moves_to_the_fine_grid() {
        assert!(!wants_fine_grid(1.8, 1.0));
        assert!(!wants_fine_grid(3.0, 1.0));
        assert!(wants_fine_grid(3.01, 1.0));
        assert!(wants_fine_grid(3.6, 1.0));
        // Relative to the target: a looser target keeps the base grid.
        assert!(!wants_fine_grid(3.6, 2.0));
        // The fine grid has no more cells than the default it replaces.
        let cells = |b: [usize; 3]| b.iter().product::<usize>();
        assert!(cells(TARGET_FINE_GRID_3D) <= cells(super::super::TARGET_GRID_3D));
        assert!(TARGET_FINE_GRID_3D[0] > super::super::TARGET_GRID_3D[0]);
    }
}
