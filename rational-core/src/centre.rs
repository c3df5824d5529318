//! The least-squares fit within the intervals of an accepted split.
//!
//! P(n_p, n_q) returns the point of largest margin: its error swings
//! between the bounds like a minimax fit's, so on most samples it is
//! near its largest. Among the coefficients that keep every row of the
//! split with a fraction of that margin, this solves for the one closest
//! to the intervals' centres in least squares (each residual in units of
//! its half-width), a convex program turned into a least-distance one:
//! `min ||A c - d||^2` with `R = qr(A | d)` becomes `min ||z||^2` for
//! `z = R_A c - f`, subject to `G R_A^-1 z >= kappa - G R_A^-1 f`.

use crate::fit::{Centring, Prepared, SplitFit};
use crate::problem::{DesignMatrix, Refinement};
use crate::report::LargestMargin;
use crate::verify::error_figures;
use crate::{blocked_triangular_factor, FitError, IntervalData};
use faer::{Mat, MatRef, Par};
use qp_backends::{Backend, LdpProblem, SolveOptions, Status};

/// The fraction of the largest-margin point's margin every row keeps.
const MARGIN_KEPT: f64 = 0.2;

/// Weight of the row that fixes the scale (`mean q / q_hat = 1`); any
/// positive weight fixes it, this one within about `1 / (10 n)`.
const SCALE_WEIGHT: f64 = 10.0;

/// Ridge, relative to the largest-margin point's squared residuals: keeps
/// the least squares well posed on a nearly dependent basis.
const RIDGE: f64 = 1e-3;

/// Solves of the centred point with the rows its refinement asks for
/// (the pole check's `q > 0` at grid points where it dips) before the
/// largest-margin point is kept instead.
const MAX_CENTRE_ROUNDS: usize = 4;

/// Largest dense `G R_A^-1` built (entries): about 130 MB.
const MAX_ENTRIES: usize = 1 << 24;

impl Prepared<'_> {
    /// `fit` with its function the least-squares fit within its intervals
    /// ([`crate::FitSettings::with_centred_fit`]) when it kept its
    /// largest-margin point for it and the centred point passes
    /// verification and the refinement: where the pole check (or the
    /// caller's refinement) asks for rows, the centred point is solved
    /// again with them, as the split's own solve is, at most
    /// [`MAX_CENTRE_ROUNDS`] times. As it is otherwise. The sweep centres
    /// only the split it returns.
    pub(crate) fn centre(
        &self,
        mut fit: SplitFit,
        data: &IntervalData,
    ) -> Result<SplitFit, FitError> {
        let Centring::Pending(point) = std::mem::take(&mut fit.centring) else {
            return Ok(fit);
        };
        let (n_p, n_q) = (fit.summary.n_p, fit.summary.n_q);
        let design = self.design_of_width(n_p.max(n_q))?;
        let (mut trial, mut poles) = (fit.summary.clone(), fit.poles);
        let mut rows = point.rows;
        for _ in 0..=MAX_CENTRE_ROUNDS {
            let problem = self.problem(data, n_p, n_q, &rows)?;
            let input = CentreInput {
                problem: &problem,
                design: &design,
                data,
                scale: self.scale,
                split: (n_p, n_q),
            };
            let Some(c) = centred(&input, &point.x, self.settings.backend) else {
                return Ok(fit);
            };
            let f = self.candidate(&self.basis.with_len(n_p.max(n_q))?, &c, n_p)?;
            let ver = self.verify(&f, data, &rows)?;
            if !ver.satisfied {
                return Ok(fit);
            }
            match self.refine(&f, &ver, data, &mut trial, &mut poles) {
                Refinement::Accept => {
                    if let (Some(function), Some(verification)) =
                        (fit.function.take(), fit.verification)
                    {
                        fit.centring = Centring::Replaced(Box::new(LargestMargin {
                            errors: error_figures(&function, data),
                            function,
                            verification,
                            poles: fit.poles,
                        }));
                    }
                    fit.function = Some(f);
                    fit.verification = Some(ver);
                    fit.poles = poles;
                    fit.summary.centred = true;
                    return Ok(fit);
                }
                Refinement::AddRows(more) => rows.extend(more),
                Refinement::Reject { .. } => return Ok(fit),
            }
        }
        Ok(fit)
    }
}

/// The split being centred: its program (unit rows, `h = 1`), its design
/// and its bounds divided by `scale`.
struct CentreInput<'a> {
    pub problem: &'a LdpProblem,
    pub design: &'a DesignMatrix,
    pub data: &'a IntervalData,
    pub scale: f64,
    pub split: (usize, usize),
}

/// The coefficients (in the program's scaled values) of the least-squares
/// fit within the intervals, from the largest-margin point `x_hat`; `None`
/// when the program is too large to store densely, a bound is degenerate,
/// the factor is singular or the solver finds no point.
fn centred(input: &CentreInput<'_>, x_hat: &[f64], backend: Backend) -> Option<Vec<f64>> {
    let (n_p, n_q) = input.split;
    let n = n_p + n_q;
    if input.problem.rows().saturating_mul(n) > MAX_ENTRIES || x_hat.len() != n {
        return None;
    }
    let r = residual_factor(input, x_hat)?;
    let r_a = r.as_ref().submatrix(0, 0, n, n);
    let largest = (0..n).map(|j| r_a[(j, j)].abs()).fold(0.0, f64::max);
    if (0..n).any(|j| r_a[(j, j)].abs() <= 1e-13 * largest) {
        return None;
    }
    // u = R_A^-1 f, the unconstrained least-squares point.
    let mut u = r.as_ref().submatrix(0, n, n, 1).to_owned();
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(r_a, u.as_mut(), Par::Seq);
    let u: Vec<f64> = (0..n).map(|j| u[(j, 0)]).collect();
    let ldp = program_in_z(input.problem, r_a, &u)?;
    let sol = backend.solve(&ldp, &SolveOptions::default()).ok()?;
    if !matches!(sol.status, Status::Solved | Status::Inaccurate) {
        return None;
    }
    // c = R_A^-1 z + u.
    let mut c = Mat::<f64>::from_fn(n, 1, |j, _| sol.x[j]);
    faer::linalg::triangular_solve::solve_upper_triangular_in_place(r_a, c.as_mut(), Par::Seq);
    let c: Vec<f64> = (0..n).map(|j| c[(j, 0)] + u[j]).collect();
    c.iter().all(|v| v.is_finite()).then_some(c)
}

/// The `R` factor of `[A | d]`: the residual of each sample in
/// half-widths, linearised about `x_hat`'s denominator, then the row that
/// fixes the scale and the ridge; `None` for a degenerate weight.
fn residual_factor(input: &CentreInput<'_>, x_hat: &[f64]) -> Option<Mat<f64>> {
    let CentreInput {
        design,
        data,
        scale,
        split: (n_p, n_q),
        ..
    } = *input;
    let n = n_p + n_q;
    let samples = data.len();
    let q_hat: Vec<f64> = (0..samples)
        .map(|i| dot(&design.row(i)[..n_q], &x_hat[n_p..]))
        .collect();
    let (lo, hi) = (data.lo(), data.hi());
    let weight = |i: usize| 2.0 * scale / ((hi[i] - lo[i]) * q_hat[i]);
    if (0..samples).any(|i| !(weight(i).is_finite() && weight(i) > 0.0)) {
        return None;
    }
    let mut scale_row = vec![0.0; n];
    for (i, q) in q_hat.iter().enumerate() {
        for (s, v) in scale_row[n_p..].iter_mut().zip(&design.row(i)[..n_q]) {
            *s += v / q;
        }
    }
    let ridge = (RIDGE * samples as f64 / dot(x_hat, x_hat)).sqrt();
    let sw = SCALE_WEIGHT.sqrt();
    let r = blocked_triangular_factor(samples + 1 + n, n + 1, |k, out| {
        out.fill(0.0);
        if k < samples {
            let (phi, w) = (design.row(k), weight(k));
            let centre = 0.5 * (lo[k] + hi[k]) / scale;
            for (o, v) in out[..n_p].iter_mut().zip(phi) {
                *o = w * v;
            }
            for (o, v) in out[n_p..n].iter_mut().zip(phi) {
                *o = -w * centre * v;
            }
        } else if k == samples {
            for (o, v) in out[..n].iter_mut().zip(&scale_row) {
                *o = sw * v;
            }
            out[n] = sw * samples as f64;
        } else {
            out[k - samples - 1] = ridge;
        }
    });
    (r.nrows() == n + 1).then_some(r)
}

/// The split's rows in `z = R_A c - f`: `G R_A^-1 z >= kappa - G u` with
/// `u = R_A^-1 f`, stored densely.
fn program_in_z(problem: &LdpProblem, r_a: MatRef<'_, f64>, u: &[f64]) -> Option<LdpProblem> {
    let (rows, n) = (problem.rows(), problem.cols());
    // (G R_A^-1)^T = R_A^-T G^T, column j the transformed row j.
    let mut transformed = Mat::<f64>::zeros(n, rows);
    let mut row = vec![0.0; n];
    for j in 0..rows {
        problem.row_into(j, &mut row);
        for (k, v) in row.iter().enumerate() {
            transformed[(k, j)] = *v;
        }
    }
    faer::linalg::triangular_solve::solve_lower_triangular_in_place(
        r_a.transpose(),
        transformed.as_mut(),
        Par::Seq,
    );
    let mut g_u = vec![0.0; rows];
    problem.products(u, &mut g_u);
    let h: Vec<f64> = problem
        .h()
        .iter()
        .zip(&g_u)
        .map(|(h, gu)| MARGIN_KEPT * h - gu)
        .collect();
    let mut g = Vec::with_capacity(rows * n);
    for j in 0..rows {
        g.extend((0..n).map(|k| transformed[(k, j)]));
    }
    LdpProblem::new(g, h, n).ok()
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}
