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

use crate::problem::{dot, matvec, matvec_col_major, norm};
use crate::tolerance::rounding_tolerance;
use crate::{Error, LdpProblem, LdpSolver, Solution, SolveOptions, Status};

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

/// Rows of the problem divided by their norms, gathered into a working set.
struct WorkingSet {
    cols: usize,
    rows: Vec<f64>,
    h: Vec<f64>,
    global: Vec<usize>,
}

impl WorkingSet {
    fn row(&self, k: usize) -> &[f64] {
        &self.rows[k * self.cols..(k + 1) * self.cols]
    }

    fn len(&self) -> usize {
        self.global.len()
    }

    fn push(&mut self, problem: &LdpProblem, inv_norm: &[f64], j: usize) {
        let s = inv_norm[j];
        let start = self.rows.len();
        self.rows.resize(start + self.cols, 0.0);
        let row = &mut self.rows[start..];
        problem.row_into(j, row);
        row.iter_mut().for_each(|v| *v *= s);
        self.h.push(problem.h()[j] * s);
        self.global.push(j);
    }
}

/// How an inner solve on the working set ended.
enum InnerEnd {
    Converged,
    /// Working-set row `blocking` cannot hold together with the active rows.
    Infeasible {
        blocking: usize,
    },
    IterationLimit,
    Cancelled,
}

/// State of the dual method: `J` (n x n orthogonal, column-major), `R` (upper
/// triangular, column-major, leading `q x q` block used), the active rows
/// (working-set indices), their multipliers and the primal point.
struct DualActiveSet {
    n: usize,
    j: Vec<f64>,
    r: Vec<f64>,
    q: usize,
    active: Vec<usize>,
    u: Vec<f64>,
    x: Vec<f64>,
    dep_tol: f64,
    iterations: usize,
    max_iterations: usize,
    // scratch
    d: Vec<f64>,
    z: Vec<f64>,
    rr: Vec<f64>,
    slack: Vec<f64>,
}

impl DualActiveSet {
    fn new(n: usize, dep_tol: f64, max_iterations: usize) -> Self {
        let mut j = vec![0.0; n * n];
        for k in 0..n {
            j[k * n + k] = 1.0;
        }
        Self {
            n,
            j,
            r: vec![0.0; n * n],
            q: 0,
            active: Vec::with_capacity(n),
            u: Vec::with_capacity(n),
            x: vec![0.0; n],
            dep_tol,
            iterations: 0,
            max_iterations,
            d: vec![0.0; n],
            z: vec![0.0; n],
            rr: vec![0.0; n],
            slack: Vec::new(),
        }
    }

    /// `d = J^T np`, `z = J_2 d_2` (step direction), `rr = R^{-1} d_1`;
    /// returns `||d_2||`.
    fn directions(&mut self, np: &[f64]) -> f64 {
        let n = self.n;
        // J is column-major, so its storage is J^T row-major.
        matvec(&self.j, np, &mut self.d);
        matvec_col_major(&self.j[self.q * n..], &self.d[self.q..], &mut self.z);
        // R rr = d_1.
        self.rr[..self.q].copy_from_slice(&self.d[..self.q]);
        back_substitute(&self.r, n, &mut self.rr[..self.q]);
        norm(&self.d[self.q..n])
    }

    /// Appends the column whose `J^T` image is `self.d` to the factorisation.
    fn add_column(&mut self) {
        let n = self.n;
        let q = self.q;
        for jj in (q + 1..n).rev() {
            let (cc, ss) = (self.d[jj - 1], self.d[jj]);
            let h = cc.hypot(ss);
            if h == 0.0 {
                continue;
            }
            self.d[jj] = 0.0;
            let (mut c, mut s) = (cc / h, ss / h);
            if c < 0.0 {
                c = -c;
                s = -s;
                self.d[jj - 1] = -h;
            } else {
                self.d[jj - 1] = h;
            }
            let (a, b) = self.j.split_at_mut(jj * n);
            rotate(&mut a[(jj - 1) * n..], &mut b[..n], c, s);
        }
        for i in 0..=q {
            self.r[q * n + i] = self.d[i];
        }
        self.q += 1;
    }

    /// Removes active position `pos`, restoring the triangular form.
    fn drop_column(&mut self, pos: usize) {
        let n = self.n;
        self.active.remove(pos);
        self.u.remove(pos);
        for k in pos..self.q - 1 {
            for i in 0..n {
                self.r[k * n + i] = self.r[(k + 1) * n + i];
            }
        }
        for i in 0..n {
            self.r[(self.q - 1) * n + i] = 0.0;
        }
        self.q -= 1;
        for k in pos..self.q {
            let (cc, ss) = (self.r[k * n + k], self.r[k * n + k + 1]);
            let h = cc.hypot(ss);
            if h == 0.0 {
                continue;
            }
            let (mut c, mut s) = (cc / h, ss / h);
            self.r[k * n + k + 1] = 0.0;
            if c < 0.0 {
                self.r[k * n + k] = -h;
                c = -c;
                s = -s;
            } else {
                self.r[k * n + k] = h;
            }
            // Rows k and k+1 of R, columns k+1..q.
            let xny = s / (1.0 + c);
            for col in k + 1..self.q {
                let t1 = self.r[col * n + k];
                let t2 = self.r[col * n + k + 1];
                let new1 = t1 * c + t2 * s;
                self.r[col * n + k] = new1;
                self.r[col * n + k + 1] = xny * (t1 + new1) - t2;
            }
            let (a, b) = self.j.split_at_mut((k + 1) * n);
            rotate(&mut a[k * n..], &mut b[..n], c, s);
        }
    }

    /// Least-norm point of the active rows as equalities, and its multipliers.
    fn recompute_point(&mut self, ws: &WorkingSet) {
        let n = self.n;
        let q = self.q;
        // Forward substitution R^T y = h_A (stored in rr).
        for i in 0..q {
            let s = ws.h[self.active[i]] - dot(&self.r[i * n..i * n + i], &self.rr[..i]);
            self.rr[i] = s / self.r[i * n + i];
        }
        matvec_col_major(&self.j[..q * n], &self.rr[..q], &mut self.x);
        // u = R^{-1} y.
        self.u[..q].copy_from_slice(&self.rr[..q]);
        back_substitute(&self.r, n, &mut self.u[..q]);
    }

    /// Starts the dual method from the given working-set rows instead of
    /// `x = 0`: the rows are factorised in order (skipping any nearly
    /// dependent on those before), the least-norm point of them as
    /// equalities is computed, and rows with a negative multiplier are
    /// dropped, most negative first, until every multiplier is
    /// non-negative. The point is then the optimum of the program restricted
    /// to the active rows, the dual method's invariant, so the iterations
    /// that follow reach the same optimum as a cold start; a good guess (the
    /// active set of a neighbouring problem) leaves few of them.
    fn start_from(&mut self, ws: &WorkingSet, rows: &[usize], is_active: &mut Vec<bool>) {
        // Looser than `dep_tol`: a row of another problem's active set that
        // is almost dependent here would only make `R` ill-conditioned.
        const WARM_DEPENDENCY: f64 = 1e-8;
        is_active.resize(ws.len(), false);
        for &k in rows {
            if self.q == self.n {
                break;
            }
            if is_active[k] {
                continue;
            }
            let np = ws.row(k).to_vec();
            if self.directions(&np) <= WARM_DEPENDENCY.max(self.dep_tol) {
                continue;
            }
            self.add_column();
            self.active.push(k);
            self.u.push(0.0);
            is_active[k] = true;
        }
        while self.q > 0 {
            self.recompute_point(ws);
            let negative = (0..self.q)
                .filter(|&i| self.u[i] < 0.0)
                .min_by(|&a, &b| self.u[a].total_cmp(&self.u[b]));
            let Some(pos) = negative else { return };
            is_active[self.active[pos]] = false;
            self.drop_column(pos);
        }
        self.x.iter_mut().for_each(|v| *v = 0.0);
    }

    /// Partial step: the step at which the first active multiplier reaches
    /// zero along the dual direction, and its position; infinite and `None`
    /// when no multiplier decreases.
    fn partial_step(&self) -> (f64, Option<usize>) {
        let mut t1 = f64::INFINITY;
        let mut drop_at = None;
        for k in 0..self.q {
            if self.rr[k] > 0.0 {
                let t = self.u[k] / self.rr[k];
                if t < t1 {
                    t1 = t;
                    drop_at = Some(k);
                }
            }
        }
        (t1, drop_at)
    }

    /// Runs the dual method until no working-set row is violated.
    ///
    /// Large working sets are priced partially: a full pass over the set
    /// keeps the rows closest to violation as candidates, and the following
    /// iterations price only those; when no candidate is violated a full pass
    /// decides between convergence and new candidates. Any violated row is a
    /// valid next row for the dual method, so the optimum is the same; sets
    /// no larger than the candidate list are priced in full every
    /// iteration. The list is short (half the columns, at least 64 rows): a
    /// full pass costs a product with every working-set row, and on the
    /// 3-D BRDF fits (120 columns, about 1,000 to 2,000 rows) pricing 480
    /// candidates, and every row below 1,920, took 2.4 times as long in
    /// all as 64 candidates (irid_flake_paint1_fine's `ratfit fit`, 49.0 s
    /// against 20.3 s, 2026-12-04).
    fn solve(
        &mut self,
        ws: &WorkingSet,
        is_active: &mut Vec<bool>,
        options: &SolveOptions,
    ) -> InnerEnd {
        let tol = rounding_tolerance(self.n);
        is_active.resize(ws.len(), false);
        let keep = (self.n / 2).max(64);
        let partial = ws.len() > keep;
        let mut candidates: Vec<usize> = Vec::new();
        let mut full_pass = true;
        loop {
            // Most violated inactive row (of the candidates, or of every row).
            let norm_x = norm(&self.x);
            let violation = |k: usize, slack: f64| -> Option<f64> {
                let s = slack - ws.h[k];
                (s < -tol * (ws.h[k].abs() + norm_x)).then_some(s)
            };
            let mut best: Option<(usize, f64)> = None;
            if full_pass {
                self.slack.resize(ws.len(), 0.0);
                matvec(&ws.rows, &self.x, &mut self.slack);
                for k in 0..ws.len() {
                    if is_active[k] {
                        continue;
                    }
                    if let Some(s) = violation(k, self.slack[k]) {
                        if best.is_none_or(|(_, b)| s < b) {
                            best = Some((k, s));
                        }
                    }
                }
                if partial {
                    let mut by_slack: Vec<(f64, usize)> = (0..ws.len())
                        .filter(|&k| !is_active[k])
                        .map(|k| (self.slack[k] - ws.h[k], k))
                        .collect();
                    if by_slack.len() > keep {
                        by_slack.select_nth_unstable_by(keep, |a, b| a.0.total_cmp(&b.0));
                        by_slack.truncate(keep);
                    }
                    candidates = by_slack.into_iter().map(|(_, k)| k).collect();
                }
            } else {
                for &k in &candidates {
                    if is_active[k] {
                        continue;
                    }
                    if let Some(s) = violation(k, dot(ws.row(k), &self.x)) {
                        if best.is_none_or(|(_, b)| s < b) {
                            best = Some((k, s));
                        }
                    }
                }
            }
            let Some((p, mut sp)) = best else {
                if full_pass {
                    return InnerEnd::Converged;
                }
                full_pass = true;
                continue;
            };
            full_pass = !partial;
            let np = ws.row(p).to_vec();
            let mut u_plus = 0.0;
            loop {
                self.iterations += 1;
                if self.iterations > self.max_iterations {
                    return InnerEnd::IterationLimit;
                }
                if options.cancelled() {
                    return InnerEnd::Cancelled;
                }
                let z_norm = self.directions(&np);
                let (t1, drop_at) = self.partial_step();
                // Full step: the new row becomes tight.
                let t2 = if z_norm > self.dep_tol {
                    -sp / (z_norm * z_norm)
                } else {
                    f64::INFINITY
                };
                if t1.is_infinite() && t2.is_infinite() {
                    return InnerEnd::Infeasible { blocking: p };
                }
                if t2.is_infinite() {
                    // Dual step only: the new row is dependent on active rows.
                    for k in 0..self.q {
                        self.u[k] -= t1 * self.rr[k];
                    }
                    u_plus += t1;
                    let pos = drop_at.expect("finite t1 has an index");
                    is_active[self.active[pos]] = false;
                    self.drop_column(pos);
                    continue;
                }
                let t = t1.min(t2);
                for (xi, zi) in self.x.iter_mut().zip(&self.z) {
                    *xi += t * zi;
                }
                for k in 0..self.q {
                    self.u[k] -= t * self.rr[k];
                }
                u_plus += t;
                if t2 <= t1 {
                    self.add_column();
                    self.active.push(p);
                    self.u.push(u_plus);
                    is_active[p] = true;
                    self.recompute_point(ws);
                    break;
                }
                let pos = drop_at.expect("partial step has an index");
                is_active[self.active[pos]] = false;
                self.drop_column(pos);
                sp = dot(&np, &self.x) - ws.h[p];
            }
        }
    }
}

/// Solves `R x = b` in place (`x` holds `b` on entry) for the leading
/// `x.len()` square of the upper triangular `R`, column-major with leading
/// dimension `n`. Column by column: each step reads one contiguous column
/// of `R` and updates the unknowns above it, which vectorises; the
/// row-by-row form reads `R` with stride `n`.
fn back_substitute(r: &[f64], n: usize, x: &mut [f64]) {
    for i in (0..x.len()).rev() {
        let xi = x[i] / r[i * n + i];
        x[i] = xi;
        let (above, _) = x.split_at_mut(i);
        for (xk, rk) in above.iter_mut().zip(&r[i * n..i * n + i]) {
            *xk -= xi * rk;
        }
    }
}

/// Plane rotation of two columns: `a' = c a + s b`, `b' = xny (a + a') - b`.
fn rotate(a: &mut [f64], b: &mut [f64], c: f64, s: f64) {
    let xny = s / (1.0 + c);
    for (ai, bi) in a.iter_mut().zip(b.iter_mut()) {
        let t1 = *ai;
        let t2 = *bi;
        *ai = t1 * c + t2 * s;
        *bi = xny * (*ai + t1) - t2;
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
            ws.push(problem, &inv_norm, j);
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
        for &j in &usable {
            seed(j, &mut ws);
        }
    }
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
