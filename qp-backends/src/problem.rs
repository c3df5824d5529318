//! The dense least-distance program `minimise ||x||^2 subject to G x >= h`.

use crate::Error;

/// A dense least-distance program: minimise `||x||^2` subject to `G x >= h`.
///
/// `G` is stored row-major (`rows x cols`), so one constraint is one
/// contiguous slice. Rows of any scale are accepted: solvers work with each
/// row divided by its Euclidean norm, which leaves the solution unchanged.
#[derive(Debug, Clone, PartialEq)]
pub struct LdpProblem {
    rows: usize,
    cols: usize,
    g: Vec<f64>,
    h: Vec<f64>,
}

impl LdpProblem {
    /// Builds a problem from a row-major `G` and the right-hand side `h`.
    ///
    /// # Errors
    /// [`Error::InvalidProblem`] when the sizes disagree, there are no
    /// columns, or any entry is NaN or infinite.
    pub fn new(g: Vec<f64>, h: Vec<f64>, cols: usize) -> Result<Self, Error> {
        if cols == 0 {
            return Err(Error::InvalidProblem("the problem has no variables".into()));
        }
        if g.len() % cols != 0 {
            return Err(Error::InvalidProblem(format!(
                "G has {} entries, not a multiple of {cols} columns",
                g.len()
            )));
        }
        let rows = g.len() / cols;
        if h.len() != rows {
            return Err(Error::InvalidProblem(format!(
                "G has {rows} rows but h has {} entries",
                h.len()
            )));
        }
        if let Some(k) = g.iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidProblem(format!(
                "G[{}, {}] is not finite ({})",
                k / cols,
                k % cols,
                g[k]
            )));
        }
        if let Some(k) = h.iter().position(|v| !v.is_finite()) {
            return Err(Error::InvalidProblem(format!(
                "h[{k}] is not finite ({})",
                h[k]
            )));
        }
        Ok(Self { rows, cols, g, h })
    }

    /// Gives back `G` (row-major) and `h`, for example to reuse their
    /// storage for the next problem.
    pub fn into_parts(self) -> (Vec<f64>, Vec<f64>) {
        (self.g, self.h)
    }

    /// Builds a problem from a slice of rows.
    ///
    /// # Errors
    /// As [`LdpProblem::new`], plus rows of unequal length.
    pub fn from_rows(rows: &[Vec<f64>], h: Vec<f64>) -> Result<Self, Error> {
        let cols = rows.first().map_or(0, Vec::len);
        if let Some(i) = rows.iter().position(|r| r.len() != cols) {
            return Err(Error::InvalidProblem(format!(
                "row {i} has {} entries, row 0 has {cols}",
                rows[i].len()
            )));
        }
        Self::new(rows.concat(), h, cols)
    }

    /// Number of constraints.
    pub fn rows(&self) -> usize {
        self.rows
    }

    /// Number of variables.
    pub fn cols(&self) -> usize {
        self.cols
    }

    /// Row `i` of `G`.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.g[i * self.cols..(i + 1) * self.cols]
    }

    /// The whole of `G`, row-major.
    pub fn g(&self) -> &[f64] {
        &self.g
    }

    /// The right-hand side `h`.
    pub fn h(&self) -> &[f64] {
        &self.h
    }

    /// Euclidean norm of every row.
    pub fn row_norms(&self) -> Vec<f64> {
        self.g.chunks_exact(self.cols).map(norm).collect()
    }
}

/// Euclidean norm of a slice, scaled to avoid overflow and underflow.
pub(crate) fn norm(v: &[f64]) -> f64 {
    let scale = v.iter().fold(0.0_f64, |m, x| m.max(x.abs()));
    if scale == 0.0 || !scale.is_finite() {
        return scale;
    }
    let inv = 1.0 / scale;
    scale * v.iter().map(|x| (x * inv) * (x * inv)).sum::<f64>().sqrt()
}

/// `out = A x` for a row-major `A` (`out.len()` rows, `x.len()` columns),
/// through faer's runtime-dispatched SIMD kernels.
pub(crate) fn matvec(a: &[f64], x: &[f64], out: &mut [f64]) {
    let (m, n) = (out.len(), x.len());
    debug_assert_eq!(a.len(), m * n);
    if m == 0 {
        return;
    }
    let lhs = faer::MatRef::from_row_major_slice(a, m, n);
    let rhs = faer::MatRef::from_column_major_slice(x, n, 1);
    let dst = faer::MatMut::from_column_major_slice_mut(out, m, 1);
    faer::linalg::matmul::matmul(dst, faer::Accum::Replace, lhs, rhs, 1.0, faer::Par::Seq);
}

/// `out = A x` for a column-major `A` (`out.len()` rows, `x.len()` columns).
pub(crate) fn matvec_col_major(a: &[f64], x: &[f64], out: &mut [f64]) {
    let (m, n) = (out.len(), x.len());
    debug_assert_eq!(a.len(), m * n);
    if n == 0 {
        out.iter_mut().for_each(|v| *v = 0.0);
        return;
    }
    let lhs = faer::MatRef::from_column_major_slice(a, m, n);
    let rhs = faer::MatRef::from_column_major_slice(x, n, 1);
    let dst = faer::MatMut::from_column_major_slice_mut(out, m, 1);
    faer::linalg::matmul::matmul(dst, faer::Accum::Replace, lhs, rhs, 1.0, faer::Par::Seq);
}

/// Dot product.
#[inline]
pub(crate) fn dot(a: &[f64], b: &[f64]) -> f64 {
    // Four accumulators: vectorises and halves the rounding chain length.
    let mut acc = [0.0; 4];
    let chunks = a.len() / 4;
    for k in 0..chunks {
        for l in 0..4 {
            acc[l] += a[4 * k + l] * b[4 * k + l];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for k in 4 * chunks..a.len() {
        s += a[k] * b[k];
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_non_finite_and_bad_sizes() {
        assert!(LdpProblem::new(vec![1.0, f64::NAN], vec![1.0], 2).is_err());
        assert!(LdpProblem::new(vec![1.0, 2.0], vec![1.0, 2.0], 2).is_err());
        assert!(LdpProblem::new(vec![1.0, 2.0, 3.0], vec![1.0], 2).is_err());
        assert!(LdpProblem::new(vec![], vec![], 0).is_err());
        assert!(LdpProblem::new(vec![1.0, 2.0], vec![f64::INFINITY], 2).is_err());
    }

    #[test]
    fn norm_survives_extreme_scales() {
        assert!((norm(&[3e200, 4e200]) / 5e200 - 1.0).abs() < 1e-15);
        assert!((norm(&[3e-200, 4e-200]) / 5e-200 - 1.0).abs() < 1e-15);
        assert!(norm(&[0.0, 0.0]).abs() < f64::MIN_POSITIVE);
    }
}
