//! Fitting the two inverse CDFs of a [`CdfTable`] with rational-core: the
//! data are the tabulated inverse CDFs with intervals taken in CDF space
//! (`[F^-1(u - delta), F^-1(u + delta)]`: narrow where the density is high,
//! wide where it is low), the known part of the model subtracted, and the
//! monotonicity rows added at the samples; the budget is searched by
//! doubling and bisection over five splits per budget (rational-core's
//! `Search::Probe`). Each verified candidate is then checked for
//! monotonicity on a grid denser than the data, through rational-core's
//! refinement hook ([`ExtraConstraints::refine`]): where the derivative is
//! negative, the point's interval and monotonicity rows are added and the
//! split is solved again, so a split is accepted only when monotone on the
//! whole grid.

use crate::model::{Component, InverseCdf, RationalCdf};
use crate::monotone::{MonotonePoint, MonotoneRows};
use crate::report::{CdfFitReport, ComponentReport};
use crate::settings::CdfFitSettings;
use crate::{CdfError, CdfTable};
use rational_core::{
    Basis, Domain, ExtraConstraints, FitError, FitSettings, Fitter, IntervalData, PoleControl,
    RationalFunction, Refinement, Search,
};
use rayon::prelude::*;
use std::f64::consts::FRAC_PI_2;
use std::sync::Mutex;
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

/// The monotonicity of an inverse CDF as rational-core's extra
/// constraints: rows at the samples up front, then, on each verified
/// candidate, a check on the dense grid; where the derivative is negative
/// (or `q` not positive) the point's interval rows and monotonicity rows are
/// added and the split solved again, at most `max_rounds` times.
struct MonotoneRefiner<'a> {
    table: &'a CdfTable,
    c: Component,
    delta: f64,
    min_half: f64,
    at_samples: &'a MonotoneRows,
    checks: &'a [f64],
    max_rounds: usize,
    /// The last split refused: smallest derivative, where, rounds.
    refused: Mutex<Option<(f64, Vec<f64>, usize)>>,
}

impl MonotoneRefiner<'_> {
    /// Interval and monotonicity rows at the natural points `failing`.
    fn rows_at(&self, failing: &[f64], basis: &Basis, n_p: usize, n_q: usize) -> Vec<Vec<f64>> {
        let mut monotone = MonotoneRows::new(self.c.dim(), self.c.sampled());
        let mut rows = Vec::new();
        let mut phi = vec![0.0; basis.len()];
        for x in failing.chunks(self.c.dim()) {
            let known = self.c.known_part(x);
            let fit_x = self.c.fit_coordinates(x);
            if known.weight == 0.0 {
                monotone.push(
                    &fit_x,
                    MonotonePoint {
                        known,
                        lo: 0.0,
                        hi: 0.0,
                    },
                );
                continue;
            }
            // The rational part's bounds, as `IntervalData::with_known_part`.
            let (l, h, _) = interval_at(self.table, self.c, x, self.delta, self.min_half);
            let (a, b) = (
                (l - known.base) / known.weight,
                (h - known.base) / known.weight,
            );
            let (lo, hi) = (a.min(b), a.max(b));
            basis.eval_into(&fit_x, &mut phi);
            let side = |sign: f64, bound: f64| -> Vec<f64> {
                let numerator = phi[..n_p].iter().map(|v| sign * v);
                numerator
                    .chain(phi[..n_q].iter().map(|v| -sign * bound * v))
                    .collect()
            };
            rows.push(side(1.0, lo));
            rows.push(side(-1.0, hi));
            monotone.push(&fit_x, MonotonePoint { known, lo, hi });
        }
        rows.extend(monotone.rows(basis, n_p, n_q));
        rows
    }
}

impl ExtraConstraints for MonotoneRefiner<'_> {
    fn rows(&self, basis: &Basis, n_p: usize, n_q: usize) -> Vec<Vec<f64>> {
        self.at_samples.rows(basis, n_p, n_q)
    }

    fn refine(&self, candidate: &RationalFunction, round: usize) -> Refinement {
        let inv = match InverseCdf::new(self.c, candidate.clone()) {
            Ok(inv) => inv,
            Err(e) => {
                return Refinement::Reject {
                    reason: e.to_string(),
                }
            }
        };
        let (min_derivative, at, failing) = check_monotone(&inv, self.checks);
        if failing.is_empty() {
            return Refinement::Accept;
        }
        if round >= self.max_rounds {
            let reason = format!(
                "not monotone: derivative {min_derivative:.3e} at {at:?} after {round} rounds"
            );
            if let Ok(mut refused) = self.refused.lock() {
                *refused = Some((min_derivative, at, round));
            }
            return Refinement::Reject { reason };
        }
        let (n_p, n_q) = candidate.split();
        Refinement::AddRows(self.rows_at(&failing, candidate.basis(), n_p, n_q))
    }
}

/// An accepted split of one budget.
struct Found {
    n_p: usize,
    n_q: usize,
    function: RationalFunction,
    min_q_ratio: f64,
    /// Rounds of rows the refinement added to it.
    refine_rounds: usize,
}

/// The smallest budget at or above `start` that the library's probing
/// search ([`Search::Probe`]: doubling, then bisection, five splits per
/// budget) finds feasible and monotone, with its accepted split of smallest
/// condition number; `None` when no budget up to `max` is. The budgets
/// probed are appended to `tried`.
fn search_budget(
    data: &IntervalData,
    refiner: &MonotoneRefiner,
    engine: &FitSettings,
    start: usize,
    max: usize,
    tried: &mut Vec<usize>,
) -> Result<Option<Found>, CdfError> {
    let start = start.max(2);
    if start > max.min(data.len()) {
        return Ok(None);
    }
    // This crate widens its own intervals (in CDF space), not the engine.
    let settings = engine
        .clone()
        .with_coeff_range(start, max)?
        .with_search(Search::Probe)
        .with_widening(2.0, 0)?;
    let result = Fitter::new(data)
        .settings(settings)
        .constraints(refiner)
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
            refine_rounds: r
                .splits
                .iter()
                .find(|s| s.accepted && (s.n_p, s.n_q) == (r.n_p, r.n_q))
                .map_or(0, |s| s.refine_rounds),
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
    let natural = sample_points(table, c, s);
    let mut delta = s.cdf_tolerance;
    let mut tried = Vec::new();
    let mut refused = None;
    for widening in 0..=s.widenings {
        if widening > 0 {
            // Wider intervals give the solver room.
            delta = (2.0 * delta).min(0.49);
        }
        let a = assemble(table, c, &natural, delta, s.min_half_width)?;
        let refiner = MonotoneRefiner {
            table,
            c,
            delta,
            min_half: s.min_half_width,
            at_samples: &a.monotone,
            checks: &checks,
            max_rounds: s.refinement_rounds,
            refused: Mutex::new(None),
        };
        let found = search_budget(&a.data, &refiner, &engine, 2, max_coeffs, &mut tried)?;
        if let Some(r) = refiner.refused.into_inner().ok().flatten() {
            refused = Some(r);
        }
        let Some(found) = found else {
            continue;
        };
        let inv = InverseCdf::new(c, found.function.clone())?;
        let (min_derivative, _, failing) = check_monotone(&inv, &checks);
        debug_assert!(failing.is_empty(), "the refinement accepted it");
        let report = component_report(
            c,
            &inv,
            &a,
            &found,
            delta,
            min_derivative,
            checks.len() / c.dim(),
            tried,
            start,
        );
        return Ok((inv, report));
    }
    Err(match refused {
        Some((min_derivative, at, rounds)) => CdfError::NotMonotone {
            function: c.name(),
            min_derivative,
            at,
            rounds,
        },
        None => CdfError::Infeasible {
            function: c.name(),
            max_coeffs,
            cdf_tolerance: delta,
            doublings: s.widenings,
        },
    })
}

/// Smallest derivative on the grid, where, and the failing points (at most
/// the 1024 worst): a negative derivative, or a denominator that is not
/// positive (a pole between samples).
fn check_monotone(inv: &InverseCdf, grid: &[f64]) -> (f64, Vec<f64>, Vec<f64>) {
    let d = inv.component.dim();
    let derivs: Vec<(f64, usize)> = grid
        .par_chunks(d)
        .enumerate()
        .map(|(i, x)| {
            let (dr, q) = inv.derivative_and_denominator(x);
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
    // The smallest (first in grid order among equals), then only the
    // negative ones sorted: most candidates have few or none.
    let (min, at) = derivs
        .iter()
        .copied()
        .reduce(|a, b| if b.0.total_cmp(&a.0).is_lt() { b } else { a })
        .unwrap_or((f64::INFINITY, 0));
    let mut negative: Vec<(f64, usize)> = derivs.into_iter().filter(|(v, _)| *v < 0.0).collect();
    negative.sort_by(|a, b| a.0.total_cmp(&b.0));
    let failing = negative
        .iter()
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
        refinement_rounds: fit.refine_rounds,
        budgets_tried,
        min_q_ratio: fit.min_q_ratio,
        seconds: start.elapsed().as_secs_f64(),
    }
}

#[cfg(test)]
mod tests;
