//! Fitting the two inverse CDFs of a [`CdfTable`] with rational-core: the
//! data are the tabulated inverse CDFs with intervals taken in CDF space
//! (`[F^-1(u - delta), F^-1(u + delta)]`: narrow where the density is high,
//! wide where it is low), the known part of the model subtracted, and the
//! monotonicity rows added; the budget is searched by doubling and bisection
//! over five splits per budget (rational-core's `Search::Probe`);
//! monotonicity is then checked on a grid denser than the data, and points
//! where the derivative is negative are added as constraints before solving
//! again.

use crate::model::{Component, InverseCdf, RationalCdf};
use crate::monotone::{MonotonePoint, MonotoneRows};
use crate::report::{CdfFitReport, ComponentReport};
use crate::settings::CdfFitSettings;
use crate::{CdfError, CdfTable};
use rational_core::{
    Domain, FitError, FitSettings, Fitter, IntervalData, PoleControl, RationalFunction, Search,
};
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_2;
use std::time::Instant;

/// Fits both inverse CDFs of `table`.
///
/// # Errors
/// Bad settings, no feasible fit within the budgets and doublings, or a fit
/// that stays non-monotone on the check grid after the refinement rounds.
pub fn fit_table(
    table: &CdfTable,
    settings: &CdfFitSettings,
) -> Result<(RationalCdf, CdfFitReport), CdfError> {
    let start = Instant::now();
    let (theta, phi) = rayon::join(
        || fit_component(table, Component::Theta, settings),
        || fit_component(table, Component::Phi, settings),
    );
    let (theta, theta_report) = theta?;
    let (phi, phi_report) = phi?;
    let cdf = RationalCdf {
        material: table.material().to_string(),
        max_view: table.settings().max_view(),
        theta,
        phi,
    };
    let report = CdfFitReport {
        material: cdf.material.clone(),
        bytes: cdf.byte_size_f32(),
        table_bytes: table.byte_size_f32(),
        theta: theta_report,
        phi: phi_report,
        seconds: start.elapsed().as_secs_f64(),
    };
    Ok((cdf, report))
}

/// The tabulated inverse CDF and its CDF-space interval at any natural
/// point, as [`tabulated_interval`]. The azimuth map is a function of the
/// two elevations' sum and product (reciprocity), but a measured table is
/// not exactly reciprocal: its conditional CDFs at `(a, b)` and `(b, a)`
/// differ by more than 0.1 in places on real files, and no symmetric
/// function fits both at a tolerance of 0.05. So the azimuth map is fitted
/// to the mean of the table's maps at the two orders (when the swapped
/// view is tabulated): a reciprocal table, as the measured one would be
/// without noise.
fn interval_at(
    table: &CdfTable,
    c: Component,
    x: &[f64],
    delta: f64,
    min_half: f64,
) -> (f64, f64, f64) {
    let (lo, hi, value) = tabulated_interval(table, c, x, delta, min_half);
    if c == Component::Phi && x[1] <= table.settings().max_view() {
        let swapped = [x[1], x[0], x[2]];
        let (lo_s, hi_s, value_s) = tabulated_interval(table, c, &swapped, delta, min_half);
        return (
            (lo + lo_s) / 2.0,
            (hi + hi_s) / 2.0,
            (value + value_s) / 2.0,
        );
    }
    (lo, hi, value)
}

/// The table's inverse CDF and its CDF-space interval at a natural point:
/// between tabulated views (and `theta_l` rows) the interval is the hull of
/// the neighbours' intervals and the value their linear blend.
fn tabulated_interval(
    table: &CdfTable,
    c: Component,
    x: &[f64],
    delta: f64,
    min_half: f64,
) -> (f64, f64, f64) {
    let u = x[c.sampled()];
    let snap = |w: f64| {
        if w < 1e-9 {
            0.0
        } else if w > 1.0 - 1e-9 {
            1.0
        } else {
            w
        }
    };
    let (i0, i1, fv) = table.bracket_view(x[0]);
    let views = [(i0, 1.0 - snap(fv)), (i1, snap(fv))];
    let rows = match c {
        Component::Theta => vec![(0, 1.0)],
        Component::Phi => {
            let nt = table.cells().0;
            let r = (x[1] / table.cell_size().0 - 0.5).clamp(0.0, (nt - 1) as f64);
            let j0 = (r.floor() as usize).min(nt - 1);
            let j1 = (j0 + 1).min(nt - 1);
            let fr = snap(r - j0 as f64);
            vec![(j0, 1.0 - fr), (j1, fr)]
        }
    };
    let inv = |i: usize, j: usize, u: f64| match c {
        Component::Theta => table.inverse_theta(i, u),
        Component::Phi => table.inverse_phi(i, j, u),
    };
    let (mut lo, mut hi, mut value) = (f64::INFINITY, f64::NEG_INFINITY, 0.0);
    for &(i, wi) in &views {
        for &(j, wj) in &rows {
            if wi * wj == 0.0 {
                continue;
            }
            value += wi * wj * inv(i, j, u);
            lo = lo.min(inv(i, j, (u - delta).max(0.0)));
            hi = hi.max(inv(i, j, (u + delta).min(1.0)));
        }
    }
    (lo.min(value - min_half), hi.max(value + min_half), value)
}

fn uniform(n: usize, a: f64, b: f64) -> Vec<f64> {
    (0..n)
        .map(|k| a + (b - a) * k as f64 / (n - 1).max(1) as f64)
        .collect()
}

/// Natural coordinates of the data (row-major).
fn sample_points(table: &CdfTable, c: Component, s: &CdfFitSettings) -> Vec<f64> {
    let nv = table.settings().views();
    let mut pts = Vec::new();
    match c {
        Component::Theta => {
            for i in 0..nv {
                for j in 1..s.mu_samples {
                    pts.extend([table.view(i), j as f64 / s.mu_samples as f64]);
                }
            }
        }
        Component::Phi => {
            let nt = table.cells().0;
            let mut views: Vec<usize> = (0..nv).step_by(s.phi_view_stride).collect();
            if views.last() != Some(&(nv - 1)) {
                views.push(nv - 1);
            }
            let rows: Vec<usize> = (0..s.phi_rows.min(nt))
                .map(|r| {
                    (((r as f64 + 0.5) * nt as f64 / s.phi_rows.min(nt) as f64) as usize)
                        .min(nt - 1)
                })
                .collect();
            for &i in &views {
                for &j in &rows {
                    for k in 1..s.tau_samples {
                        pts.extend([
                            table.view(i),
                            table.row_theta(j),
                            k as f64 / s.tau_samples as f64,
                        ]);
                    }
                }
            }
        }
    }
    pts
}

/// Natural coordinates of the monotonicity check grid.
fn check_points(table: &CdfTable, c: Component, s: &CdfFitSettings) -> Vec<f64> {
    let d = s.check_density;
    let nv = table.settings().views();
    let mut pts = Vec::new();
    match c {
        Component::Theta => {
            for tv in uniform(d * nv, 0.0, table.settings().max_view()) {
                for mu in uniform(d * s.mu_samples + 1, 0.0, 1.0) {
                    pts.extend([tv, mu]);
                }
            }
        }
        Component::Phi => {
            let views = nv.div_ceil(s.phi_view_stride);
            for tv in uniform(d * views, 0.0, table.settings().max_view()) {
                for tl in uniform(d * s.phi_rows, 0.0, FRAC_PI_2) {
                    for tau in uniform(d * s.tau_samples + 1, 0.0, 1.0) {
                        pts.extend([tv, tl, tau]);
                    }
                }
            }
        }
    }
    pts
}

/// The problem pieces for a set of natural points.
struct Assembled {
    data: IntervalData,
    monotone: MonotoneRows,
    /// Natural coordinates and tabulated values of every sample (for errors).
    natural: Vec<f64>,
    values: Vec<f64>,
}

fn assemble(
    table: &CdfTable,
    c: Component,
    natural: &[f64],
    zero_weight_checks: &[f64],
    delta: f64,
    min_half: f64,
) -> Result<Assembled, CdfError> {
    let d = c.dim();
    let n = natural.len() / d;
    let (mut fit_pts, mut lo, mut hi, mut values, mut base, mut weight) = (
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
        Vec::new(),
    );
    for x in natural.chunks(d) {
        let (l, h, v) = interval_at(table, c, x, delta, min_half);
        let k = c.known_part(x);
        fit_pts.extend(c.fit_coordinates(x));
        lo.push(l);
        hi.push(h);
        values.push(v);
        base.push(k.base);
        weight.push(k.weight);
    }
    let full = IntervalData::new(d, fit_pts, lo, hi)?.with_values(values.clone())?;
    let (data, kept) = full.with_known_part(&base, &weight)?;
    let mut monotone = MonotoneRows::new(d, c.sampled());
    for (m, &i) in kept.iter().enumerate() {
        let x = &natural[i * d..(i + 1) * d];
        monotone.push(
            data.point(m),
            MonotonePoint {
                known: c.known_part(x),
                lo: data.lo()[m],
                hi: data.hi()[m],
            },
        );
    }
    for x in zero_weight_checks.chunks(d) {
        let known = c.known_part(x);
        monotone.push(
            &c.fit_coordinates(x),
            MonotonePoint {
                known,
                lo: 0.0,
                hi: 0.0,
            },
        );
    }
    debug_assert_eq!(values.len(), n);
    Ok(Assembled {
        data,
        monotone,
        natural: natural.to_vec(),
        values,
    })
}

fn domain(c: Component, max_view: f64) -> Result<Domain, CdfError> {
    Ok(match c {
        Component::Theta => Domain::new(vec![0.0, 0.0], vec![max_view, 1.0])?,
        Component::Phi => Domain::new(
            vec![0.0, 0.0, 0.0],
            vec![max_view + FRAC_PI_2, max_view * FRAC_PI_2, 1.0],
        )?,
    })
}

/// An accepted split of one budget.
struct Found {
    n_p: usize,
    n_q: usize,
    function: RationalFunction,
    min_q_ratio: f64,
}

/// The smallest budget at or above `start` that the library's probing
/// search ([`Search::Probe`]: doubling, then bisection, five splits per
/// budget) finds feasible, with its accepted split of smallest condition
/// number; `None` when no budget up to `max` is. The budgets probed are
/// appended to `tried`.
fn search_budget(
    a: &Assembled,
    engine: &FitSettings,
    start: usize,
    max: usize,
    tried: &mut Vec<usize>,
) -> Result<Option<Found>, CdfError> {
    let start = start.max(2);
    if start > max.min(a.data.len()) {
        return Ok(None);
    }
    // This crate widens its own intervals (in CDF space), not the engine.
    let settings = engine
        .clone()
        .with_coeff_range(start, max)?
        .with_search(Search::Probe)
        .with_widening(2.0, 0)?;
    let result = Fitter::new(&a.data)
        .settings(settings)
        .constraints(&a.monotone)
        .fit();
    let splits = match &result {
        Ok(r) => r.splits.as_slice(),
        Err(FitError::NoFeasibleFit { splits, .. }) => splits.as_slice(),
        Err(_) => &[],
    };
    let mut budgets: Vec<usize> = splits.iter().map(|s| s.n_p + s.n_q).collect();
    budgets.dedup();
    tried.extend(budgets);
    match result {
        Ok(r) => Ok(Some(Found {
            n_p: r.n_p,
            n_q: r.n_q,
            min_q_ratio: r.verification.min_q_ratio,
            function: r.function,
        })),
        Err(FitError::NoFeasibleFit { .. }) => Ok(None),
        Err(e) => Err(e.into()),
    }
}

fn fit_component(
    table: &CdfTable,
    c: Component,
    s: &CdfFitSettings,
) -> Result<(InverseCdf, ComponentReport), CdfError> {
    let start = Instant::now();
    let max_view = table.settings().max_view();
    // Poles are checked on the check grid of reachable points below; the
    // engine's box grid would also cover (s, w) pairs no elevations produce.
    let engine = s
        .engine
        .clone()
        .with_domain(domain(c, max_view)?)
        .with_pole_control(PoleControl::None);
    let max_coeffs = s.max_coeffs[match c {
        Component::Theta => 0,
        Component::Phi => 1,
    }];
    let checks = check_points(table, c, s);
    let mut delta = s.cdf_tolerance;
    let mut tried = Vec::new();
    let mut last_failure = None;
    'widen: for widening in 0..=s.widenings {
        if widening > 0 {
            delta = (2.0 * delta).min(0.49);
        }
        let mut natural = sample_points(table, c, s);
        let mut zero_weight = Vec::new();
        let mut budget = 2;
        for round in 0..=s.refinement_rounds {
            let a = assemble(table, c, &natural, &zero_weight, delta, s.min_half_width)?;
            let Some(found) = search_budget(&a, &engine, budget, max_coeffs, &mut tried)? else {
                continue 'widen;
            };
            budget = found.n_p + found.n_q;
            let inv = InverseCdf::new(c, found.function.clone())?;
            let (min_derivative, at, failing) = check_monotone(&inv, &checks);
            if failing.is_empty() {
                let report = component_report(
                    c,
                    &inv,
                    &a,
                    &found,
                    delta,
                    min_derivative,
                    checks.len() / c.dim(),
                    round,
                    tried,
                    start,
                );
                return Ok((inv, report));
            }
            if round == s.refinement_rounds {
                // Still not monotone: wider intervals give the solver room.
                last_failure = Some(CdfError::NotMonotone {
                    function: c.name(),
                    min_derivative,
                    at,
                    rounds: round,
                });
                continue 'widen;
            }
            for x in failing.chunks(c.dim()) {
                if c.known_part(x).weight == 0.0 {
                    zero_weight.extend_from_slice(x);
                } else {
                    natural.extend_from_slice(x);
                }
            }
        }
    }
    Err(last_failure.unwrap_or(CdfError::Infeasible {
        function: c.name(),
        max_coeffs,
        cdf_tolerance: delta,
        doublings: s.widenings,
    }))
}

/// Smallest derivative on the grid, where, and the failing points (at most
/// the 1024 worst): a negative derivative, or a denominator that is not
/// positive (a pole between samples).
fn check_monotone(inv: &InverseCdf, grid: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
    let d = inv.component.dim();
    let mut derivs: Vec<(f64, usize)> = grid
        .par_chunks(d)
        .enumerate()
        .map(|(i, x)| {
            let (_, q) = inv.rational.eval_parts(&inv.component.fit_coordinates(x));
            let dr = inv.eval_with_derivative(x).1;
            (
                if q > 0.0 && dr.is_finite() {
                    dr
                } else {
                    f64::NEG_INFINITY
                },
                i,
            )
        })
        .collect();
    derivs.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (min, at) = derivs[0];
    let failing = derivs
        .iter()
        .take_while(|(v, _)| *v < 0.0)
        .take(1024)
        .flat_map(|&(_, i)| grid[i * d..(i + 1) * d].iter().copied())
        .collect();
    (min, grid[at * d..(at + 1) * d].to_vec(), failing)
}

#[allow(clippy::too_many_arguments)]
fn component_report(
    c: Component,
    inv: &InverseCdf,
    a: &Assembled,
    fit: &Found,
    delta: f64,
    min_derivative: f64,
    check_points: usize,
    rounds: usize,
    budgets_tried: Vec<usize>,
    start: Instant,
) -> ComponentReport {
    let errors: Vec<f64> = a
        .natural
        .par_chunks(c.dim())
        .zip(a.values.par_iter())
        .map(|(x, v)| (inv.eval(x) - v).abs())
        .collect();
    ComponentReport {
        component: c,
        n_p: fit.n_p,
        n_q: fit.n_q,
        samples: errors.len(),
        monotone_points: a.monotone.len(),
        cdf_tolerance: delta,
        max_error_rad: errors.iter().cloned().fold(0.0, f64::max),
        mean_error_rad: errors.iter().sum::<f64>() / errors.len() as f64,
        min_derivative,
        check_points,
        refinement_rounds: rounds,
        budgets_tried,
        min_q_ratio: fit.min_q_ratio,
        seconds: start.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::TableSettings;
    use brdf::{Brdf, Vec3};

    /// Blinn-Phong times a factor of the incident elevation alone: not
    /// reciprocal, as measured tables are not quite.
    struct Skewed;

    impl Brdf for Skewed {
        fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
            let lobe = brdf::BlinnPhong {
                kd: [0.3; 3],
                ks: [0.5; 3],
                exponent: 40.0,
            };
            lobe.eval(wi, wo).map(|v| v * (1.0 + 0.8 * wi[2]))
        }

        fn name(&self) -> String {
            "skewed".into()
        }
    }

    #[test]
    fn azimuth_intervals_are_reciprocal_though_the_table_is_not() {
        let settings = TableSettings::default()
            .with_views(6)
            .unwrap()
            .with_cells(30, 24)
            .unwrap();
        let table = CdfTable::new(&Skewed, settings).unwrap();
        let (a, b) = (table.view(1), table.view(4));
        let mut table_differs = false;
        for q in 1..8 {
            let tau = f64::from(q) / 8.0;
            let (x, swapped) = ([a, b, tau], [b, a, tau]);
            let fitted = interval_at(&table, Component::Phi, &x, 0.05, 1e-3);
            let fitted_swapped = interval_at(&table, Component::Phi, &swapped, 0.05, 1e-3);
            assert_eq!(fitted, fitted_swapped, "tau {tau}");
            let own = tabulated_interval(&table, Component::Phi, &x, 0.05, 1e-3);
            let own_swapped = tabulated_interval(&table, Component::Phi, &swapped, 0.05, 1e-3);
            table_differs |= (own.2 - own_swapped.2).abs() > 1e-3;
        }
        assert!(table_differs, "the test material should not be reciprocal");
    }
}
