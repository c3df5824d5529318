//! The dual active-set iterations on a working set of rows: the QR
//! factorisation `N_A = J R` of the active rows, updated by Givens rotations
//! as rows are added and dropped, and the pricing of violated rows.

use crate::problem::{dot, matvec, matvec_col_major, norm};
use crate::tolerance::rounding_tolerance;
use crate::{LdpProblem, SolveOptions};

/// Rows of the problem divided by their norms, gathered into a working set.
pub(super) struct WorkingSet {
    pub(super) cols: usize,
    pub(super) rows: Vec<f64>,
    pub(super) h: Vec<f64>,
    pub(super) global: Vec<usize>,
}

impl WorkingSet {
    pub(super) fn row(&self, k: usize) -> &[f64] {
        &self.rows[k * self.cols..(k + 1) * self.cols]
    }

    pub(super) fn len(&self) -> usize {
        self.global.len()
    }

    pub(super) fn push(&mut self, problem: &LdpProblem, inv_norm: &[f64], j: usize) {
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
pub(super) enum InnerEnd {
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
pub(super) struct DualActiveSet {
    n: usize,
    j: Vec<f64>,
    r: Vec<f64>,
    q: usize,
    pub(super) active: Vec<usize>,
    pub(super) u: Vec<f64>,
    pub(super) x: Vec<f64>,
    dep_tol: f64,
    pub(super) iterations: usize,
    max_iterations: usize,
    // scratch
    d: Vec<f64>,
    z: Vec<f64>,
    rr: Vec<f64>,
    slack: Vec<f64>,
}

impl DualActiveSet {
    pub(super) fn new(n: usize, dep_tol: f64, max_iterations: usize) -> Self {
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
    pub(super) fn start_from(
        &mut self,
        ws: &WorkingSet,
        rows: &[usize],
        is_active: &mut Vec<bool>,
    ) {
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
    pub(super) fn solve(
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
            let best = if full_pass {
                self.price_all(
                    ws,
                    is_active,
                    tol,
                    partial.then_some((keep, &mut candidates)),
                )
            } else {
                self.price_candidates(ws, is_active, tol, &candidates)
            };
            let Some((p, sp)) = best else {
                if full_pass {
                    return InnerEnd::Converged;
                }
                full_pass = true;
                continue;
            };
            full_pass = !partial;
            if let Err(end) = self.add_row(ws, is_active, p, sp, options) {
                return end;
            }
        }
    }

    /// How far working-set row `k` is violated at `x` (its slack is
    /// `slack`), if beyond the rounding tolerance.
    fn violation(ws: &WorkingSet, k: usize, slack: f64, tol: f64, norm_x: f64) -> Option<f64> {
        let s = slack - ws.h[k];
        (s < -tol * (ws.h[k].abs() + norm_x)).then_some(s)
    }

    /// The most violated inactive row of the whole working set. With
    /// `candidates`, also keeps the `keep` inactive rows closest to
    /// violation as the candidates priced next.
    fn price_all(
        &mut self,
        ws: &WorkingSet,
        is_active: &[bool],
        tol: f64,
        candidates: Option<(usize, &mut Vec<usize>)>,
    ) -> Option<(usize, f64)> {
        let norm_x = norm(&self.x);
        let mut best: Option<(usize, f64)> = None;
        self.slack.resize(ws.len(), 0.0);
        matvec(&ws.rows, &self.x, &mut self.slack);
        for k in 0..ws.len() {
            if is_active[k] {
                continue;
            }
            if let Some(s) = Self::violation(ws, k, self.slack[k], tol, norm_x) {
                if best.is_none_or(|(_, b)| s < b) {
                    best = Some((k, s));
                }
            }
        }
        if let Some((keep, candidates)) = candidates {
            let mut by_slack: Vec<(f64, usize)> = (0..ws.len())
                .filter(|&k| !is_active[k])
                .map(|k| (self.slack[k] - ws.h[k], k))
                .collect();
            if by_slack.len() > keep {
                by_slack.select_nth_unstable_by(keep, |a, b| a.0.total_cmp(&b.0));
                by_slack.truncate(keep);
            }
            *candidates = by_slack.into_iter().map(|(_, k)| k).collect();
        }
        best
    }

    /// The most violated inactive row among `candidates`.
    fn price_candidates(
        &self,
        ws: &WorkingSet,
        is_active: &[bool],
        tol: f64,
        candidates: &[usize],
    ) -> Option<(usize, f64)> {
        let norm_x = norm(&self.x);
        let mut best: Option<(usize, f64)> = None;
        for &k in candidates {
            if is_active[k] {
                continue;
            }
            if let Some(s) = Self::violation(ws, k, dot(ws.row(k), &self.x), tol, norm_x) {
                if best.is_none_or(|(_, b)| s < b) {
                    best = Some((k, s));
                }
            }
        }
        best
    }

    /// Makes the violated row `p` (slack `sp`) active: full steps, partial
    /// steps that drop the active row whose multiplier reaches zero first,
    /// or the proof that `p` cannot hold with the active rows.
    fn add_row(
        &mut self,
        ws: &WorkingSet,
        is_active: &mut [bool],
        p: usize,
        mut sp: f64,
        options: &SolveOptions,
    ) -> Result<(), InnerEnd> {
        let np = ws.row(p).to_vec();
        let mut u_plus = 0.0;
        loop {
            self.iterations += 1;
            if self.iterations > self.max_iterations {
                return Err(InnerEnd::IterationLimit);
            }
            if options.cancelled() {
                return Err(InnerEnd::Cancelled);
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
                return Err(InnerEnd::Infeasible { blocking: p });
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
                return Ok(());
            }
            let pos = drop_at.expect("partial step has an index");
            is_active[self.active[pos]] = false;
            self.drop_column(pos);
            sp = dot(&np, &self.x) - ws.h[p];
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
