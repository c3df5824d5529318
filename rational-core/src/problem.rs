//! The paper's P(n_p, n_q): two linear inequalities per sample, each row
//! divided by its Euclidean norm, `G c >= 1`.

use crate::{Basis, FitError, IntervalData, RationalFunction};
use faer::{Mat, MatRef};
use qp_backends::LdpProblem;
use rayon::prelude::*;
use std::sync::{Arc, RwLock};

/// Basis values at every sample (`samples x cols`, row-major), computed once
/// and shared by every split of a sweep: the problems of the splits generate
/// their rows from it instead of storing them.
#[derive(Debug, Clone)]
pub(crate) struct DesignMatrix {
    cols: usize,
    values: Arc<[f64]>,
}

impl DesignMatrix {
    /// Evaluates the first `basis.len()` functions at every point of `data`.
    pub fn new(basis: &Basis, data: &IntervalData) -> Self {
        let cols = basis.len();
        // Collected from a sized iterator the shared slice is allocated
        // once, filled in place: no second copy of a large design.
        let mut values: Arc<[f64]> = std::iter::repeat_n(0.0, data.len() * cols).collect();
        Arc::get_mut(&mut values)
            .expect("a new slice has one owner")
            .par_chunks_mut(cols)
            .enumerate()
            .for_each(|(i, row)| basis.eval_into(data.point(i), row));
        Self { cols, values }
    }

    /// Number of basis functions.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// The basis values at sample `i`.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.values[i * self.cols..(i + 1) * self.cols]
    }
}

/// Basis values that several fits of the same points share: the channels
/// of a colour material are fitted at one set of directions with the same
/// basis, so one design matrix serves all of them (a third of the memory of
/// three). Give clones of one handle to the fits'
/// [`FitSettings::with_shared_design`](crate::FitSettings::with_shared_design);
/// the first fit's points and basis claim it, and a fit whose points or
/// basis differ evaluates its own.
#[derive(Debug, Clone, Default)]
pub struct SharedDesign(Arc<RwLock<Option<SharedEntry>>>);

#[derive(Debug)]
struct SharedEntry {
    basis: Basis,
    points: Arc<[f64]>,
    design: DesignMatrix,
}

impl SharedDesign {
    /// A handle with no design yet.
    pub fn new() -> Self {
        Self::default()
    }

    /// The design of `data` under `basis` with at least `width` functions
    /// (grown by doubling up to the basis' length), or `None` when the
    /// handle holds another fit's points or basis.
    pub(crate) fn of_width(
        &self,
        basis: &Basis,
        data: &IntervalData,
        width: usize,
    ) -> Result<Option<DesignMatrix>, FitError> {
        let matches = |e: &SharedEntry| e.basis == *basis && *e.points == *data.points();
        {
            let entry = self.0.read().unwrap_or_else(|e| e.into_inner());
            match entry.as_ref() {
                Some(e) if !matches(e) => return Ok(None),
                Some(e) if e.design.cols() >= width => return Ok(Some(e.design.clone())),
                _ => {}
            }
        }
        let mut entry = self.0.write().unwrap_or_else(|e| e.into_inner());
        match entry.as_mut() {
            Some(e) if !matches(e) => Ok(None),
            Some(e) => {
                if e.design.cols() < width {
                    let grown = (2 * e.design.cols()).max(width).min(basis.len());
                    e.design = DesignMatrix::new(&basis.with_len(grown)?, data);
                }
                Ok(Some(e.design.clone()))
            }
            None => {
                let design = DesignMatrix::new(&basis.with_len(width.min(basis.len()))?, data);
                *entry = Some(SharedEntry {
                    basis: basis.clone(),
                    points: data.points().into(),
                    design: design.clone(),
                });
                Ok(Some(design))
            }
        }
    }
}

/// Linear constraints on the coefficient vector `c = (a, b)` that callers add
/// to P(n_p, n_q), each read as `row . c > 0` (with the same normalised
/// margin as the data rows), and the refinement of a verified candidate.
/// The `cdf` crate keeps inverse CDFs monotone this way: rows at the
/// samples up front, then rows where a dense check finds the derivative
/// negative.
pub trait ExtraConstraints: Sync {
    /// Rows of length `n_p + n_q` for this split.
    fn rows(&self, basis: &Basis, n_p: usize, n_q: usize) -> Vec<Vec<f64>>;

    /// Called on each candidate of P(n_p, n_q) (its split is
    /// `candidate.split()`) that passed verification and the pole check,
    /// with the rounds of rows this hook already
    /// added to the split: accept it, refuse it, or return rows (in the
    /// candidate's coefficients, as [`ExtraConstraints::rows`]) to add
    /// before solving the split again. The pole control's dense grid works
    /// the same way. The default accepts.
    fn refine(&self, _candidate: &RationalFunction, _round: usize) -> Refinement {
        Refinement::Accept
    }
}

/// What a refinement check makes of a verified candidate.
#[derive(Debug, Clone, PartialEq)]
#[non_exhaustive]
pub enum Refinement {
    /// The candidate stands.
    Accept,
    /// The split is refused, for this reason (the split's note).
    Reject {
        /// Why, for the report.
        reason: String,
    },
    /// Solve the split again with these rows added (each of length
    /// `n_p + n_q`, read as [`ExtraConstraints::rows`] are).
    AddRows(Vec<Vec<f64>>),
}

/// No extra constraints.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoExtraConstraints;

impl ExtraConstraints for NoExtraConstraints {
    fn rows(&self, _: &Basis, _: usize, _: usize) -> Vec<Vec<f64>> {
        Vec::new()
    }
}

/// Builds P(n_p, n_q): for sample `i` the rows `(phi_p, -lo_i phi_q)` and
/// `(-phi_p, hi_i phi_q)`, then `extra` rows, each divided by its norm, with
/// `h = 1`; the bounds are divided by `value_scale` (and the numerator part
/// of every extra row multiplied by it), so the solution is
/// `(a / value_scale, b)`: dividing by the data's magnitude makes the fit
/// independent of the data's units (the least-norm objective is not). The
/// rows are generated from `design` by the solver
/// (`LdpProblem::from_intervals`), so no split stores its `G`.
///
/// # Errors
/// A split larger than the design matrix, extra rows of the wrong length,
/// or a scale that is not finite and positive.
pub(crate) fn build_problem_in(
    design: &DesignMatrix,
    data: &IntervalData,
    n_p: usize,
    n_q: usize,
    extra: &[Vec<f64>],
    value_scale: f64,
) -> Result<LdpProblem, FitError> {
    if !(value_scale.is_finite() && value_scale > 0.0) {
        return Err(FitError::InvalidSetting {
            name: "value scale",
            reason: format!("{value_scale}"),
        });
    }
    let n = n_p + n_q;
    if n_p == 0 || n_q == 0 || n_p.max(n_q) > design.cols() {
        return Err(FitError::InvalidSetting {
            name: "split",
            reason: format!(
                "({n_p}, {n_q}) needs 1..={} coefficients in each part",
                design.cols()
            ),
        });
    }
    if let Some(r) = extra.iter().find(|r| r.len() != n) {
        return Err(FitError::DimensionMismatch(format!(
            "extra row of length {} for {n} coefficients",
            r.len()
        )));
    }
    // Divide (not multiply by the inverse): 1/scale overflows for subnormal data.
    let lo = data.lo().iter().map(|v| v / value_scale).collect();
    let hi = data.hi().iter().map(|v| v / value_scale).collect();
    let extra: Vec<Vec<f64>> = extra
        .iter()
        .map(|row| {
            let mut r = row.clone();
            r[..n_p].iter_mut().for_each(|v| *v *= value_scale);
            normalise(&mut r);
            r
        })
        .collect();
    Ok(LdpProblem::from_intervals(
        design.values.clone(),
        design.cols(),
        (n_p, n_q),
        lo,
        hi,
        &extra,
    )?)
}

fn normalise(row: &mut [f64]) {
    let scale = row.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    if scale > 0.0 {
        let inv = 1.0 / scale;
        let nrm = scale
            * row
                .iter()
                .map(|v| (v * inv) * (v * inv))
                .sum::<f64>()
                .sqrt();
        row.iter_mut().for_each(|v| *v /= nrm);
    }
}

/// Rows per block of [`blocked_triangular_factor`]: large enough to amortise
/// each factorisation, small enough that a million-row matrix never holds
/// more than a few megabytes at once.
const QR_BLOCK_ROWS: usize = 8192;

/// The `R` factor (`min(rows, cols) x cols`, upper triangular) of the thin
/// QR of a tall matrix given row by row: `fill_row(i, out)` writes row `i`.
///
/// Each block of rows is factorised on its own (on several threads) and the
/// triangular factors are stacked and factorised again in a fixed order, so
/// the matrix is never stored whole and the result does not depend on the
/// thread count. `R` is that of the whole matrix up to the signs of its
/// rows: its singular values are the matrix's, and least squares follow by
/// appending the right-hand side as a last column.
pub fn blocked_triangular_factor(
    rows: usize,
    cols: usize,
    fill_row: impl Fn(usize, &mut [f64]) + Sync,
) -> Mat<f64> {
    if rows == 0 || cols == 0 {
        return Mat::zeros(0, cols);
    }
    let block = QR_BLOCK_ROWS.max(4 * cols);
    let factors: Vec<Mat<f64>> = (0..rows.div_ceil(block))
        .into_par_iter()
        .map(|b| {
            let range = b * block..((b + 1) * block).min(rows);
            let mut values = vec![0.0; range.len() * cols];
            for (i, out) in range.clone().zip(values.chunks_mut(cols)) {
                fill_row(i, out);
            }
            triangular_factor(&[MatRef::from_row_major_slice(&values, range.len(), cols)])
        })
        .collect();
    factors.iter().skip(1).fold(factors[0].clone(), |r, next| {
        triangular_factor(&[r.as_ref(), next.as_ref()])
    })
}

/// 2-norm condition number of `G` (the singular values of `R` from
/// [`blocked_triangular_factor`], so a generated `G` is never stored whole);
/// `+inf` when `G` is rank deficient.
pub fn condition_number(problem: &LdpProblem) -> f64 {
    let (m, n) = (problem.rows(), problem.cols());
    if m < n || n == 0 {
        return f64::INFINITY;
    }
    let r = blocked_triangular_factor(m, n, |i, out| problem.row_into(i, out));
    match r.singular_values() {
        Ok(sv) => {
            let max = sv.iter().cloned().fold(0.0, f64::max);
            let min = sv.iter().cloned().fold(f64::INFINITY, f64::min);
            if min > 0.0 {
                max / min
            } else {
                f64::INFINITY
            }
        }
        Err(_) => f64::NAN,
    }
}

/// The `R` factor of the thin QR of `parts` stacked one above the other.
fn triangular_factor(parts: &[MatRef<'_, f64>]) -> Mat<f64> {
    let n = parts[0].ncols();
    let m: usize = parts.iter().map(|p| p.nrows()).sum();
    let mut stacked = Mat::<f64>::zeros(m, n);
    let mut at = 0;
    for p in parts {
        stacked
            .as_mut()
            .submatrix_mut(at, 0, p.nrows(), n)
            .copy_from(p);
        at += p.nrows();
    }
    stacked.qr().thin_R().to_owned()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BasisFamily, Domain};

    #[test]
    fn rows_are_unit_and_encode_the_interval() {
        let data = IntervalData::new(
            1,
            vec![0.0, 0.5, 1.0],
            vec![1.0, 2.0, 3.0],
            vec![1.5, 2.5, 3.5],
        )
        .unwrap();
        let basis = Basis::new(
            BasisFamily::Chebyshev,
            Domain::new(vec![0.0], vec![1.0]).unwrap(),
            3,
        )
        .unwrap();
        let design = DesignMatrix::new(&basis, &data);
        let p = build_problem_in(&design, &data, 2, 1, &[], 1.0).unwrap();
        assert_eq!(p.rows(), 6);
        for j in 0..6 {
            let n: f64 = p.row(j).iter().map(|v| v * v).sum::<f64>().sqrt();
            assert!((n - 1.0).abs() < 1e-15);
        }
        // r = const 2 (a = (2,0), b = (1)) lies inside sample 1 only.
        let c = [2.0, 0.0, 1.0];
        let s1: f64 = p.row(2).iter().zip(&c).map(|(a, b)| a * b).sum();
        assert!(s1 >= 0.0);
        let s0: f64 = p.row(1).iter().zip(&c).map(|(a, b)| a * b).sum();
        assert!(s0 < 0.0, "2 is above the first interval's upper bound 1.5");
    }

    #[test]
    fn condition_number_of_orthogonal_rows_is_one() {
        let p = LdpProblem::from_rows(
            &[vec![1.0, 0.0], vec![0.0, 1.0], vec![-1.0, 0.0]],
            vec![1.0; 3],
        )
        .unwrap();
        let k = condition_number(&p);
        assert!((k - 2f64.sqrt()).abs() < 1e-12, "{k}");
    }

    #[test]
    fn the_blocked_condition_number_is_that_of_the_whole_matrix() {
        // Two full blocks and a short one, from an interval fit whose rows
        // are generated: the blocked QR must agree with one QR of all of `G`.
        let samples = QR_BLOCK_ROWS + QR_BLOCK_ROWS / 3;
        let x: Vec<f64> = (0..samples).map(|i| i as f64 / samples as f64).collect();
        let lo: Vec<f64> = x.iter().map(|t| 1.0 + t * t).collect();
        let hi: Vec<f64> = lo.iter().map(|v| v * 1.1).collect();
        let data = IntervalData::new(1, x, lo, hi).unwrap();
        let basis = Basis::new(
            BasisFamily::Chebyshev,
            Domain::new(vec![0.0], vec![1.0]).unwrap(),
            6,
        )
        .unwrap();
        let design = DesignMatrix::new(&basis, &data);
        let p = build_problem_in(&design, &data, 6, 4, &[], 1.0).unwrap();
        let g = p.g();
        let whole = MatRef::from_row_major_slice(&g, p.rows(), p.cols())
            .qr()
            .thin_R()
            .to_owned()
            .singular_values()
            .unwrap();
        let max = whole.iter().cloned().fold(0.0, f64::max);
        let min = whole.iter().cloned().fold(f64::INFINITY, f64::min);
        let blocked = condition_number(&p);
        assert!(
            (blocked / (max / min) - 1.0).abs() < 1e-9,
            "{blocked} against {}",
            max / min
        );
        assert!(
            blocked > 10.0,
            "rows scaled by the bounds are far from orthogonal"
        );
    }
}
