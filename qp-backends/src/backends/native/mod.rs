//! The native backend: the dual active-set method of Goldfarb and Idnani
//! (Math. Programming 27, 1983) specialised to the identity Hessian, with
//! constraint generation for large row counts.
//!
//! With `H = I` the method needs no Hessian factorisation: it starts at the
//! unconstrained minimum `x = 0`, repeatedly adds the most violated row, and
//! drops rows whose multiplier would turn negative. It keeps `N_A = J R`, a QR
//! factorisation of the active rows (as columns), updated by Givens rotations.
//! The active rows are linearly independent, so at most `cols` are active.
//!
//! Accuracy at tiny depths: after every addition `x` is recomputed as the
//! least-norm solution of the active rows taken as equalities,
//! `x = J_1 R^{-T} h_A`, instead of being accumulated by steps whose length
//! grows like `1 / depth^2`; the final active set is polished by a fresh
//! Householder QR (faer). Both are backward stable, so the residual of every
//! active row stays at rounding level even when `||x|| = 1e9`.

mod dual;

use crate::problem::norm;
use crate::tolerance::rounding_tolerance;
use crate::{Error, LdpProblem, LdpSolver, Solution, SolveOptions, Status};
use dual::{DualActiveSet, InnerEnd, WorkingSet};

/// The always-compiled default backend.
#[derive(Debug, Clone, Copy, Default)]
pub struct NativeSolver;

impl LdpSolver for NativeSolver {
    fn name(&self) -> &'static str {
        "native"
    }

    fn solve(&self, problem: &LdpProblem, options: &SolveOptions) -> Result<Solution, Error> {
        Ok(solve_native(problem, options))
    }
}

/// Least-norm solution of the active rows as equalities by a fresh
/// Householder QR of `N_A` (columns = active rows): `x = Q_1 R^{-T} h_A`.
fn polish(ws: &WorkingSet, active: &[usize], n: usize) -> Option<Vec<f64>> {
    let q = active.len();
    if q == 0 {
        return Some(vec![0.0; n]);
    }
    let a = faer::Mat::<f64>::from_fn(n, q, |i, k| ws.row(active[k])[i]);
    let qr = a.qr();
    let r = qr.thin_R();
    let qthin = qr.compute_thin_Q();
    let mut y = vec![0.0; q];
    for i in 0..q {
        let mut s = ws.h[active[i]];
        for (k, yk) in y.iter().enumerate().take(i) {
            s -= r[(k, i)] * yk;
        }
        let diag = r[(i, i)];
        if diag == 0.0 || !diag.is_finite() {
            return None;
        }
        y[i] = s / diag;
    }
    let mut x = vec![0.0; n];
    for (k, yk) in y.iter().enumerate() {
        for (i, xi) in x.iter_mut().enumerate() {
            *xi += qthin[(i, k)] * yk;
        }
    }
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Largest normalised violation relative to the rounding tolerance scale.
fn worst_violation(problem: &LdpProblem, inv_norm: &[f64], x: &[f64], parallel: bool) -> f64 {
    let norm_x = norm(x);
    let mut gx = vec![0.0; problem.rows()];
    problem.products_on(x, &mut gx, parallel);
    (0..problem.rows())
        .filter(|&j| inv_norm[j] != 0.0)
        .map(|j| {
            let hn = problem.h()[j] * inv_norm[j];
            (hn - gx[j] * inv_norm[j]) / (hn.abs() + norm_x)
        })
        .fold(f64::NEG_INFINITY, f64::max)
}

fn solve_native(problem: &LdpProblem, options: &SolveOptions) -> Solution {
    let n = problem.cols();
    let m = problem.rows();
    let inv_norm: Vec<f64> = problem
        .row_norms()
        .into_iter()
        .map(|v| if v > 0.0 { 1.0 / v } else { 0.0 })
        .collect();
    // A zero row with h > 0 can never hold.
    if let Some(j) = (0..m).find(|&j| inv_norm[j] == 0.0 && problem.h()[j] > 0.0) {
        return Solution::measured(
            problem,
            Status::Infeasible,
            vec![0.0; n],
            0,
            vec![j],
            "native",
        );
    }
    let usable: Vec<usize> = (0..m).filter(|&j| inv_norm[j] > 0.0).collect();
    let generate = usable.len() > options.working_set_threshold;
    let (mut ws, mut in_ws) = initial_working_set(problem, &inv_norm, &usable, options, generate);
    let tol = rounding_tolerance(n);
    let mut state = DualActiveSet::new(
        n,
        options.dependency_tolerance_for(n),
        options.max_iterations_for(n),
    );
    let mut is_active = Vec::new();
    if !options.warm_start.is_empty() {
        let warm = working_set_positions(&ws, &options.warm_start, m);
        state.start_from(&ws, &warm, &mut is_active);
    }
    let status = loop {
        match state.solve(&ws, &mut is_active, options) {
            InnerEnd::Infeasible { blocking } => {
                // The active rows and the row that cannot be added hold the
                // proof: rows a caller may want to keep for related problems.
                state.active.push(blocking);
                break Status::Infeasible;
            }
            InnerEnd::IterationLimit => break Status::IterationLimit,
            InnerEnd::Cancelled => break Status::Cancelled,
            InnerEnd::Converged => {}
        }
        if !generate {
            break Status::Solved;
        }
        let mut violated =
            violated_rows(problem, &inv_norm, &in_ws, &state.x, tol, options.parallel);
        if violated.is_empty() {
            break Status::Solved;
        }
        let batch = options.generation_batch_for(n, ws.len());
        if violated.len() > batch {
            violated.select_nth_unstable_by(batch, |a, b| a.0.total_cmp(&b.0));
            violated.truncate(batch);
        }
        for &(_, j) in &violated {
            in_ws[j] = true;
            ws.push(problem, &inv_norm, j);
        }
    };
    let active_global: Vec<usize> = state.active.iter().map(|&k| ws.global[k]).collect();
    if status != Status::Solved {
        let x = if status == Status::Infeasible {
            vec![0.0; n]
        } else {
            state.x.clone()
        };
        return Solution::measured(
            problem,
            status,
            x,
            state.iterations,
            active_global,
            "native",
        );
    }
    polished_solution(problem, options, &ws, &state, &inv_norm, tol, active_global)
}

/// The rows the dual method starts on, and which rows of the problem they
/// are: every usable row, or with constraint generation the warm start and
/// a well-spread subset.
fn initial_working_set(
    problem: &LdpProblem,
    inv_norm: &[f64],
    usable: &[usize],
    options: &SolveOptions,
    generate: bool,
) -> (WorkingSet, Vec<bool>) {
    let n = problem.cols();
    let m = problem.rows();
    let mut ws = WorkingSet {
        cols: n,
        rows: Vec::new(),
        h: Vec::new(),
        global: Vec::new(),
    };
    let mut in_ws = vec![false; m];
    let mut seed = |j: usize, ws: &mut WorkingSet| {
        if j < m && inv_norm[j] > 0.0 && !in_ws[j] {
            in_ws[j] = true;
            ws.push(problem, inv_norm, j);
        }
    };
    if generate {
        for &j in &options.warm_start {
            seed(j, &mut ws);
        }
        // A well-spread subset: the golden-ratio sequence, which does not
        // alias with periodic row structure (such as lower/upper pairs).
        let initial = (8 * n).max(256).min(usable.len());
        let phi = 0.618_033_988_749_894_9_f64;
        for k in 0..initial {
            let u = (k as f64 * phi).fract();
            seed(
                usable[((u * usable.len() as f64) as usize).min(usable.len() - 1)],
                &mut ws,
            );
        }
    } else {
        for &j in usable {
            seed(j, &mut ws);
        }
    }
    (ws, in_ws)
}

/// The working-set positions of the rows of `rows` it holds (of a problem
/// of `m` rows).
fn working_set_positions(ws: &WorkingSet, rows: &[usize], m: usize) -> Vec<usize> {
    let mut position = vec![usize::MAX; m];
    for (k, &j) in ws.global.iter().enumerate() {
        position[j] = k;
    }
    rows.iter()
        .filter(|&&j| j < m && position[j] != usize::MAX)
        .map(|&j| position[j])
        .collect()
}

/// One pass over every row: the rows outside the working set that `x`
/// violates beyond the rounding tolerance, with their scaled slacks.
fn violated_rows(
    problem: &LdpProblem,
    inv_norm: &[f64],
    in_ws: &[bool],
    x: &[f64],
    tol: f64,
    parallel: bool,
) -> Vec<(f64, usize)> {
    let norm_x = norm(x);
    let mut gx = vec![0.0; problem.rows()];
    problem.products_on(x, &mut gx, parallel);
    (0..problem.rows())
        .filter_map(|j| {
            if in_ws[j] || inv_norm[j] == 0.0 {
                return None;
            }
            let hn = problem.h()[j] * inv_norm[j];
            let s = gx[j] * inv_norm[j] - hn;
            (s < -tol * (hn.abs() + norm_x)).then_some((s, j))
        })
        .collect()
}

/// The solved point, polished on its active set when that does not worsen
/// the largest violation, measured; numerical trouble when the residuals
/// fail.
fn polished_solution(
    problem: &LdpProblem,
    options: &SolveOptions,
    ws: &WorkingSet,
    state: &DualActiveSet,
    inv_norm: &[f64],
    tol: f64,
    active_global: Vec<usize>,
) -> Solution {
    let n = problem.cols();
    let mut x = state.x.clone();
    if options.polish {
        if let Some(px) = polish(ws, &state.active, n) {
            let before = worst_violation(problem, inv_norm, &x, options.parallel);
            let after = worst_violation(problem, inv_norm, &px, options.parallel);
            if after <= before.max(0.0) || after <= tol {
                x = px;
            }
        }
    }
    let sol = Solution::measured(
        problem,
        Status::Solved,
        x,
        state.iterations,
        active_global,
        "native",
    );
    if sol.residuals.satisfied {
        sol
    } else {
        Solution {
            status: Status::NumericalTrouble,
            ..sol
        }
    }
}
