//! The dense cap check: between the samples nothing bounds `p / q`, and
//! beyond the outermost cells a fit extrapolates. Every fit is evaluated on
//! a grid of the whole domain evaluation reaches; where it exceeds its cap
//! the points are added as `[0, cap]` constraints and the data fitted again.

use crate::fit_settings::BrdfFitSettings;
use crate::geometry::HalfDiff;
use crate::reduce::{Reduction, HORIZON_INSET_RAD};
use crate::value_scale::ValueScale;
use rational_core::{FitError, FitReport, Fitter, IntervalData, RationalFunction};
use serde::{Deserialize, Serialize};
use std::fmt;

/// What the dense cap check found for one function: between the samples
/// nothing bounds `p / q`, so the fit is evaluated on a grid of its whole
/// evaluation domain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CapCheck {
    /// The cap on the fitted value (of the product, with a lobe) in the
    /// function's units.
    pub cap: f64,
    /// Grid points the check evaluated.
    pub grid_points: usize,
    /// Points where a fit exceeded the cap, added as `[0, cap]`
    /// constraints before fitting again.
    pub points: usize,
    /// Refits made.
    pub refits: usize,
    /// Largest ratio of the final fit to the cap over the grid's finite
    /// values (at most about 1.01 when the check succeeded).
    pub largest: f64,
    /// Grid points where the final fit is not finite (a pole).
    pub non_finite: usize,
}

impl CapCheck {
    /// The final fit stays within 1% of its cap on the whole grid.
    pub fn held(&self) -> bool {
        self.non_finite == 0 && self.largest <= 1.01
    }
}

/// One line of the fit report: the grid, what was added, what is left.
impl fmt::Display for CapCheck {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(
            f,
            "cap check on {} points of the evaluation domain: cap {:.4e}, {} points added in {} refits, largest value {:.2}x the cap",
            self.grid_points, self.cap, self.points, self.refits, self.largest
        )?;
        if self.non_finite > 0 {
            write!(f, ", NOT FINITE at {} points", self.non_finite)?;
        }
        if !self.held() {
            write!(f, " (ABOVE the cap)")?;
        }
        Ok(())
    }
}

/// Most points one round of the cap check adds (the largest excesses).
const CAP_POINTS_PER_ROUND: usize = 400;

/// Most points of the cap check's grid: 512 per axis in 2-D, 64 in 3-D.
const CAP_GRID_MAX_POINTS: usize = 1 << 18;

/// The dense grid of the cap check: the reduction's whole evaluation domain
/// ([`Reduction::domain`], corners and faces included, so the
/// extrapolation beyond the outermost cells is covered), twice as dense as
/// the data along each coordinate (at least 4 points, at most
/// [`CAP_GRID_MAX_POINTS`] in all), only points whose two directions are
/// above the horizon and, when the reduction has an elevation cut (where
/// evaluation clamps directions), within it. The `phi_d = pi / 2` slice
/// holds both directions nearest the normal, so in 2-D these are exactly the
/// coordinates that evaluation reaches. Each line of constant `theta_h`
/// (and `phi_d`) also gets the point where the cut or the horizon ends it:
/// the last grid point inside stops up to a step short, and fits rise
/// steepest at that edge.
fn cap_grid(data: &IntervalData, reduction: &Reduction) -> Vec<Vec<f64>> {
    let dim = data.dim();
    let (lower, upper) = reduction.domain();
    let most_per_axis = (CAP_GRID_MAX_POINTS as f64).powf(1.0 / dim as f64).floor() as usize;
    // Distinct coordinate values per axis give the data's resolution.
    let per_axis: Vec<usize> = (0..dim)
        .map(|k| {
            let mut v: Vec<f64> = data.points().chunks_exact(dim).map(|p| p[k]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            (2 * v.len()).clamp(4, most_per_axis.max(4))
        })
        .collect();
    // A hair below the cut's cosine: points on the cut itself stay.
    let min_cos = if reduction.max_elevation_deg < 90.0 {
        reduction.max_elevation_deg.to_radians().cos() - 1e-9
    } else {
        0.0
    };
    let total: usize = per_axis.iter().product();
    let mut grid = Vec::with_capacity(total);
    for idx in 0..total {
        let mut rest = idx;
        let x: Vec<f64> = (0..dim)
            .map(|k| {
                let n = per_axis[k];
                let t = (rest % n) as f64 / (n - 1) as f64;
                rest /= n;
                lower[k] + t * (upper[k] - lower[k])
            })
            .collect();
        let (wi, wo) = HalfDiff::pair_at(reduction.angles(&x));
        if wi[2] > 0.0 && wo[2] > 0.0 && wi[2].min(wo[2]) >= min_cos {
            grid.push(x);
        }
    }
    grid.extend(boundary_points(reduction, &lower, &upper, &per_axis));
    grid
}

/// The points where the elevation cut (or, without one, the inset horizon)
/// ends each line of constant `theta_h` and `phi_d` of the cap grid: the
/// smaller elevation of the pair, `cos theta_h cos theta_d - sin theta_h
/// sin theta_d |cos phi_d|`, equals the cut's cosine there.
fn boundary_points(
    reduction: &Reduction,
    lower: &[f64],
    upper: &[f64],
    per_axis: &[usize],
) -> Vec<Vec<f64>> {
    let dim = per_axis.len();
    let horizon = std::f64::consts::FRAC_PI_2 - HORIZON_INSET_RAD;
    let edge = reduction.max_elevation_deg.to_radians().min(horizon);
    let theta_d_max = reduction.max_theta_d_deg.to_radians().min(horizon);
    let n_phi = if dim == 3 { per_axis[2] } else { 1 };
    let at =
        |k: usize, i: usize| lower[k] + i as f64 / (per_axis[k] - 1) as f64 * (upper[k] - lower[k]);
    let mut out = Vec::new();
    for i in 0..per_axis[0] {
        for j in 0..n_phi {
            let mut x = vec![at(0, i), lower[1]];
            if dim == 3 {
                x.push(at(2, j));
            }
            let [theta_h, _, phi_d] = reduction.angles(&x);
            // a cos(theta_d) - b sin(theta_d) = r cos(theta_d + atan2(b, a)).
            let (a, b) = (theta_h.cos(), theta_h.sin() * phi_d.cos().abs());
            let r = a.hypot(b);
            if edge.cos() >= r {
                continue; // the whole line is beyond the edge
            }
            let theta_d = (edge.cos() / r).acos() - b.atan2(a);
            if theta_d > 0.0 && theta_d < theta_d_max {
                out.push(reduction.point(theta_h, theta_d, phi_d));
            }
        }
    }
    out
}

/// One scan of the cap check's grid.
struct CapScan {
    /// The points to add (flattened), the largest excesses first.
    points: Vec<f64>,
    /// The cap at each point to add.
    caps: Vec<f64>,
    /// Largest ratio of `f` to its cap over the finite values.
    largest: f64,
    /// Grid points where `f` is not finite.
    non_finite: usize,
}

/// The points of `grid` where `f` exceeds `cap_at` by more than 1% or is
/// not finite (the largest [`CAP_POINTS_PER_ROUND`] excesses relative to
/// the cap, non-finite ones first), each with its cap.
fn points_above_cap(
    grid: &[Vec<f64>],
    f: &RationalFunction,
    scale: ValueScale,
    cap_at: &dyn Fn(&[f64]) -> f64,
) -> CapScan {
    let mut found: Vec<(f64, f64, &[f64])> = Vec::new();
    let (mut largest, mut non_finite) = (0.0_f64, 0usize);
    for x in grid {
        // The value without the exponent limit: the excesses rank the
        // points, and an infinite one counts as not finite.
        let r = f.eval(x);
        let v = if scale.is_linear() { r } else { r.exp() };
        let cap = cap_at(x);
        let excess = if v.is_finite() {
            largest = largest.max(v / cap);
            v / cap
        } else {
            non_finite += 1;
            f64::INFINITY
        };
        if excess > 1.01 {
            found.push((excess, cap, x));
        }
    }
    found.sort_by(|a, b| b.0.total_cmp(&a.0));
    found.truncate(CAP_POINTS_PER_ROUND);
    CapScan {
        caps: found.iter().map(|p| p.1).collect(),
        points: found.iter().flat_map(|p| p.2.iter().copied()).collect(),
        largest,
        non_finite,
    }
}

/// `data` with `points` added as `[0, cap]` constraints, one cap each, on
/// the data's `scale` (on the log scale `[cap / LOG_SPAN, cap]`,
/// [`ValueScale::interval`]).
fn with_cap_points(
    data: &IntervalData,
    points: Vec<f64>,
    caps: &[f64],
    scale: ValueScale,
) -> Result<IntervalData, FitError> {
    let mut all = data.points().to_vec();
    all.extend(points);
    let mut lo = data.lo().to_vec();
    let mut hi = data.hi().to_vec();
    let mut values: Vec<f64> = (0..data.len()).map(|i| data.value(i)).collect();
    for &cap in caps {
        // Caps are positive (a multiple of a positive peak), so every scale
        // has the interval.
        let (a, b) = scale.interval(0.0, cap).unwrap_or((0.0, cap));
        lo.push(a);
        hi.push(b);
        values.push(0.5 * (a + b));
    }
    IntervalData::new(data.dim(), all, lo, hi)?.with_values(values)
}

/// Fits `more` (the data with cap points) again, widening nothing. The
/// added constraints only shrink the feasible set, so the smallest budget
/// cannot fall below the previous fit's, and a split proved infeasible
/// before (`known`, the fits before on fewer rows at the same intervals)
/// is infeasible still and is not solved again. When the previous split
/// still holds, that budget is the smallest, and it alone is searched
/// (under condition-number selection its splits are solved in order of
/// condition number until one holds, `rational_core::Search`); otherwise
/// the search runs from that budget up, without first solving every split
/// of a budget that may hold none. Splits proved infeasible here are added
/// to `known`.
fn refit(
    more: &IntervalData,
    s: &BrdfFitSettings,
    (n_p, n_q): (usize, usize),
    known: &mut Vec<(usize, usize)>,
) -> Result<FitReport, FitError> {
    let (_, max_coeffs) = s.fit_settings().coeff_range();
    let budget = (n_p + n_q).min(max_coeffs);
    let from_budget = s
        .fit_settings()
        .clone()
        .with_coeff_range(budget, max_coeffs)?
        .with_widening(2.0, 0)?;
    let previous = Fitter::new(more)
        .settings(from_budget.clone())
        .split(n_p, n_q)?
        .summary;
    if previous.proved_infeasible() {
        known.push((n_p, n_q));
    }
    let settings = if previous.accepted {
        from_budget.with_coeff_range(budget, budget)?
    } else {
        from_budget
    };
    let result = Fitter::new(more)
        .settings(settings)
        .known_infeasible(known)
        .fit();
    match &result {
        Ok(r) => known.extend(r.proved_infeasible()),
        Err(FitError::NoFeasibleFit { splits, .. }) => known.extend(
            splits
                .iter()
                .filter(|x| x.proved_infeasible())
                .map(|x| (x.n_p, x.n_q)),
        ),
        Err(_) => {}
    }
    result
}

/// Channel `c`'s cap at a point: `cap`, divided by the lobe with one.
fn cap_at(s: &BrdfFitSettings, c: usize, cap: f64) -> impl Fn(&[f64]) -> f64 + '_ {
    let reduction = *s.reduction();
    move |x: &[f64]| match s.lobe() {
        Some(lobe) => cap / lobe.factors_at(reduction.angles(x), s.colour_mode())[c],
        None => cap,
    }
}

/// The largest-margin point of `report`'s split, where it was centred
/// (`FitReport::largest_margin`), unless it passes the cap check `check`
/// (if any) worse than the returned function did.
pub(crate) fn largest_margin_as_capped(
    report: &FitReport,
    data: &IntervalData,
    s: &BrdfFitSettings,
    c: usize,
    check: Option<&CapCheck>,
) -> Option<RationalFunction> {
    let f = &report.largest_margin.as_ref()?.function;
    check
        .is_none_or(|check| as_capped_as(f, data, s, c, check))
        .then(|| f.clone())
}

/// Whether `f`, another function for channel `c` of `data`, passes the
/// cap check on its grid at least as well as the function `check` judged:
/// nowhere above the cap, or above it by no more and at no more poles.
fn as_capped_as(
    f: &RationalFunction,
    data: &IntervalData,
    s: &BrdfFitSettings,
    c: usize,
    check: &CapCheck,
) -> bool {
    let grid = cap_grid(data, s.reduction());
    let value_scale = s.value_scale().of(s.colour_mode(), c);
    let scan = points_above_cap(&grid, f, value_scale, &cap_at(s, c, check.cap));
    scan.non_finite == 0 && scan.caps.is_empty()
        || scan.non_finite <= check.non_finite && scan.largest <= check.largest
}

/// The dense cap check ([`BrdfFitSettings::with_cap_rounds`]): between the
/// samples nothing bounds `p / q`, so the fit is evaluated on a grid of its
/// whole evaluation domain twice as dense as the data; the points above
/// `cap` (divided by the lobe, with one) are added to `data` as `[0, cap]`
/// and the data fitted again, at most `cap_rounds` times. When the first fit
/// needed wider intervals, the refits keep the data at that width and widen
/// nothing more (widening the cap points would lift the cap). A refit with
/// no feasible fit within the budget keeps the fit before it (the check
/// then reports the excess).
pub(crate) fn hold_below_cap(
    mut report: FitReport,
    data: &IntervalData,
    s: &BrdfFitSettings,
    c: usize,
    cap: f64,
) -> Result<(FitReport, CapCheck), FitError> {
    let cap_at = cap_at(s, c, cap);
    let started = std::time::Instant::now();
    let first_fit_s = report.seconds;
    let grid = cap_grid(data, s.reduction());
    let mut check = CapCheck {
        cap,
        grid_points: grid.len(),
        points: 0,
        refits: 0,
        largest: 0.0,
        non_finite: 0,
    };
    // The intervals the first fit was accepted at.
    let scale = report.interval_scale;
    let accepted = (scale > 1.0).then(|| data.widened(scale));
    let mut augmented: Option<IntervalData> = None;
    // Infeasible at these intervals on fewer rows: infeasible in every refit.
    let mut known = report.proved_infeasible();
    let value_scale = s.value_scale().of(s.colour_mode(), c);
    loop {
        let scan = points_above_cap(&grid, &report.function, value_scale, &cap_at);
        check.largest = scan.largest;
        check.non_finite = scan.non_finite;
        if scan.caps.is_empty() || check.refits == s.cap_rounds() {
            break;
        }
        let so_far = augmented.as_ref().or(accepted.as_ref()).unwrap_or(data);
        let more = with_cap_points(so_far, scan.points, &scan.caps, value_scale)?;
        match refit(&more, s, (report.n_p, report.n_q), &mut known) {
            Ok(r) => {
                report = r;
                report.interval_scale = scale;
            }
            Err(FitError::NoFeasibleFit { .. }) => break,
            Err(e) => return Err(e),
        }
        check.points += scan.caps.len();
        check.refits += 1;
        augmented = Some(more);
    }
    // The channel's time: the first fit, the scans and every refit (a
    // refit's own report times only itself).
    report.seconds = first_fit_s + started.elapsed().as_secs_f64();
    Ok((report, check))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reduce::ReductionKind;
    use std::f64::consts::PI;

    #[test]
    fn the_cap_grid_reaches_the_horizon_beyond_the_outermost_cells() {
        let reduction = Reduction::default()
            .with_kind(ReductionKind::Full3d)
            .with_resolution(8, 8)
            .with_phi_resolution(8)
            .whole_hemisphere();
        let lambert = crate::Lambert {
            albedo: [0.5, 0.5, 0.5],
        };
        let samples = reduction.sample(&lambert);
        let (data, _) = samples.channel(0, 0.1, 1e-2).unwrap();
        let grid = cap_grid(&data, &reduction);
        let angles: Vec<[f64; 3]> = grid.iter().map(|x| reduction.angles(x)).collect();
        // The cells' centres stop half a bin short of each end; the grid
        // goes to the ends (theta_d to the inset horizon, phi_d to 0 and pi).
        let max_theta_d = angles.iter().map(|a| a[1]).fold(0.0, f64::max);
        assert!((max_theta_d - (PI / 2.0 - HORIZON_INSET_RAD)).abs() < 1e-12);
        assert!(angles.iter().any(|a| a[0] == 0.0 && a[2] == 0.0));
        assert!(angles.iter().any(|a| (a[2] - PI).abs() < 1e-12));
        // Only pairs above the horizon.
        for a in &angles {
            let (wi, wo) = HalfDiff::pair_at(*a);
            assert!(wi[2] > 0.0 && wo[2] > 0.0, "{a:?}");
        }
        // 16 points per axis (twice the data's 8), less those below the horizon.
        assert!(grid.len() < 16 * 16 * 16 && grid.len() > 16 * 16 * 16 / 3);
    }

    #[test]
    fn the_cap_grid_of_a_cut_slice_stays_within_the_cut_and_reaches_it() {
        let reduction = Reduction::default().with_resolution(20, 20);
        let samples = reduction.sample(&crate::Lambert {
            albedo: [0.5, 0.5, 0.5],
        });
        let (data, _) = samples.channel(0, 0.1, 1e-2).unwrap();
        let grid = cap_grid(&data, &reduction);
        let cut = reduction.max_elevation_deg;
        let elevations: Vec<f64> = grid
            .iter()
            .map(|x| crate::design::max_elevation_deg(reduction.angles(x)))
            .collect();
        assert!(
            elevations.iter().all(|&e| e <= cut + 1e-6),
            "beyond the cut"
        );
        // Every line of theta_h below the cut ends on it: 40 lines (twice
        // the data's 20), less those at or beyond 70 degrees.
        let on_cut = elevations
            .iter()
            .filter(|&&e| (e - cut).abs() < 1e-6)
            .count();
        assert!(on_cut >= 30, "{on_cut} points on the cut");
    }

    #[test]
    fn points_above_cap_keep_the_largest_excesses_and_report_the_largest_ratio() {
        // p(x) = 5 + 5 T1(x / 5 - 1) = x on [0, 10], q = 1.
        let domain = rational_core::Domain::new(vec![0.0], vec![10.0]).unwrap();
        let basis =
            rational_core::Basis::new(rational_core::BasisFamily::Chebyshev, domain, 2).unwrap();
        let f = RationalFunction::new(basis, vec![5.0, 5.0], vec![1.0]).unwrap();
        let grid: Vec<Vec<f64>> = (0..10).map(|i| vec![i as f64]).collect();
        let scan = points_above_cap(&grid, &f, ValueScale::Linear, &|_| 4.0);
        // f(x) = x exceeds 4.04 at x = 5..9; the largest ratio is 9 / 4.
        assert_eq!(scan.points, vec![9.0, 8.0, 7.0, 6.0, 5.0]);
        assert_eq!(scan.caps, vec![4.0; 5]);
        assert!((scan.largest - 2.25).abs() < 1e-12);
        assert_eq!(scan.non_finite, 0);
    }
}
