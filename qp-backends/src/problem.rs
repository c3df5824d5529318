//! The least-distance program `minimise ||x||^2 subject to G x >= h`, with
//! `G` stored densely or generated from the design matrix of an interval fit.

use crate::Error;
use rayon::prelude::*;
use std::borrow::Cow;
use std::sync::Arc;

/// Entries of `G` below which products are computed on one thread.
const PARALLEL_ENTRIES: usize = 1 << 16;

/// A least-distance program: minimise `||x||^2` subject to `G x >= h`.
///
/// `G` is either stored row-major ([`LdpProblem::new`]) or generated on
/// demand from the basis values of an interval fit
/// ([`LdpProblem::from_intervals`]), which needs no `rows x cols` copy: on
/// the full MERL grid that copy is 1.4 GB per split at 120 coefficients.
/// Rows of any scale are accepted: solvers work with each row divided by its
/// Euclidean norm, which leaves the solution unchanged.
#[derive(Debug, Clone, PartialEq)]
pub struct LdpProblem {
    rows: usize,
    cols: usize,
    source: RowSource,
    h: Vec<f64>,
}

/// Where the rows of `G` come from.
#[derive(Debug, Clone, PartialEq)]
enum RowSource {
    /// `G` row-major.
    Dense(Vec<f64>),
    /// The two rows of each sample of an interval fit, then extra rows.
    Interval(IntervalRows),
}

/// For sample `i` with basis values `phi_i` (a row of `design`, `width`
/// wide) and bounds `lo_i, hi_i`, the unit rows
/// `(phi_i[..n_p], -lo_i phi_i[..n_q]) * scale[2i]` and
/// `(-phi_i[..n_p], hi_i phi_i[..n_q]) * scale[2i + 1]`, followed by the
/// dense `extra` rows.
#[derive(Debug, Clone, PartialEq)]
struct IntervalRows {
    design: Arc<[f64]>,
    width: usize,
    n_p: usize,
    lo: Vec<f64>,
    hi: Vec<f64>,
    /// One over each generated row's norm before scaling (0 for a zero row).
    scale: Vec<f64>,
    extra: Vec<f64>,
}

impl IntervalRows {
    fn samples(&self) -> usize {
        self.lo.len()
    }

    /// Row `j < 2 samples` into `out` (`n_p + n_q` long).
    fn row_into(&self, j: usize, out: &mut [f64]) {
        let (i, upper) = (j / 2, j % 2 == 1);
        let phi = &self.design[i * self.width..(i + 1) * self.width];
        let (p_part, q_part) = out.split_at_mut(self.n_p);
        let s = self.scale[j];
        let (sp, sq) = if upper {
            (-s, self.hi[i] * s)
        } else {
            (s, -self.lo[i] * s)
        };
        for (o, v) in p_part.iter_mut().zip(phi) {
            *o = v * sp;
        }
        for (o, v) in q_part.iter_mut().zip(phi) {
            *o = v * sq;
        }
    }

    /// `G x` over the generated rows: two dot products per sample.
    fn products(&self, x: &[f64], out: &mut [f64], parallel: bool) {
        let (a, b) = x.split_at(self.n_p);
        let one = |(i, pair): (usize, &mut [f64])| {
            let phi = &self.design[i * self.width..(i + 1) * self.width];
            let pa = dot(&phi[..a.len()], a);
            let pb = dot(&phi[..b.len()], b);
            pair[0] = (pa - self.lo[i] * pb) * self.scale[2 * i];
            pair[1] = (self.hi[i] * pb - pa) * self.scale[2 * i + 1];
        };
        let generated = &mut out[..2 * self.samples()];
        if parallel && generated.len() * x.len() >= PARALLEL_ENTRIES {
            generated.par_chunks_mut(2).enumerate().for_each(one);
        } else {
            generated.chunks_mut(2).enumerate().for_each(one);
        }
    }
}

fn check_finite(values: &[f64], what: &str) -> Result<(), Error> {
    match values.iter().position(|v| !v.is_finite()) {
        Some(k) => Err(Error::InvalidProblem(format!(
            "{what}[{k}] is not finite ({})",
            values[k]
        ))),
        None => Ok(()),
    }
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
        check_finite(&h, "h")?;
        Ok(Self {
            rows,
            cols,
            source: RowSource::Dense(g),
            h,
        })
    }

    /// The program of an interval fit `lo_i <= p(x_i) / q(x_i) <= hi_i` with
    /// `p, q` on the first `n_p` and `n_q` of `width` basis functions, whose
    /// values at sample `i` are `design[i * width..(i + 1) * width]`: for
    /// each sample the rows `(phi_p, -lo_i phi_q)` and `(-phi_p, hi_i phi_q)`,
    /// each divided by its norm, then the `extra` rows as given (`n_p + n_q`
    /// long), all with `h = 1`. The rows are generated from `design` when a
    /// solver needs them, so the design matrix is shared by every split and
    /// `G` is never stored.
    ///
    /// # Errors
    /// [`Error::InvalidProblem`] when the sizes disagree, a part is empty or
    /// wider than `width`, or any value is NaN or infinite.
    pub fn from_intervals(
        design: Arc<[f64]>,
        width: usize,
        (n_p, n_q): (usize, usize),
        lo: Vec<f64>,
        hi: Vec<f64>,
        extra: &[Vec<f64>],
    ) -> Result<Self, Error> {
        let invalid = |m: String| Err(Error::InvalidProblem(m));
        if n_p == 0 || n_q == 0 || n_p.max(n_q) > width {
            return invalid(format!(
                "split ({n_p}, {n_q}) needs 1..={width} functions in each part"
            ));
        }
        let samples = lo.len();
        if hi.len() != samples || design.len() != samples * width {
            return invalid(format!(
                "{} lower and {} upper bounds for a design of {} values, {width} per sample",
                samples,
                hi.len(),
                design.len()
            ));
        }
        check_finite(&design, "design")?;
        check_finite(&lo, "lo")?;
        check_finite(&hi, "hi")?;
        let cols = n_p + n_q;
        if let Some(r) = extra.iter().find(|r| r.len() != cols) {
            return invalid(format!(
                "extra row of length {} for {cols} columns",
                r.len()
            ));
        }
        let extra = extra.concat();
        check_finite(&extra, "extra")?;
        let mut scale = vec![0.0; 2 * samples];
        scale.par_chunks_mut(2).enumerate().for_each(|(i, pair)| {
            let phi = &design[i * width..(i + 1) * width];
            let np = norm(&phi[..n_p]);
            let nq = norm(&phi[..n_q]);
            for (s, bound) in pair.iter_mut().zip([lo[i], hi[i]]) {
                let n = np.hypot(bound * nq);
                *s = if n > 0.0 { 1.0 / n } else { 0.0 };
            }
        });
        let rows = 2 * samples + extra.len() / cols;
        Ok(Self {
            rows,
            cols,
            source: RowSource::Interval(IntervalRows {
                design,
                width,
                n_p,
                lo,
                hi,
                scale,
                extra,
            }),
            h: vec![1.0; rows],
        })
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

    /// Writes row `i` of `G` into `out` (`cols` long), allocating nothing.
    pub fn row_into(&self, i: usize, out: &mut [f64]) {
        assert_eq!(out.len(), self.cols, "out has {} entries", out.len());
        match &self.source {
            RowSource::Interval(r) if i < 2 * r.samples() => r.row_into(i, out),
            _ => out.copy_from_slice(&self.row(i)),
        }
    }

    /// Row `i` of `G`: borrowed when `G` is stored, generated otherwise.
    pub fn row(&self, i: usize) -> Cow<'_, [f64]> {
        let n = self.cols;
        match &self.source {
            RowSource::Dense(g) => Cow::Borrowed(&g[i * n..(i + 1) * n]),
            RowSource::Interval(r) => {
                let generated = 2 * r.samples();
                if i < generated {
                    let mut out = vec![0.0; n];
                    r.row_into(i, &mut out);
                    Cow::Owned(out)
                } else {
                    Cow::Borrowed(&r.extra[(i - generated) * n..(i - generated + 1) * n])
                }
            }
        }
    }

    /// The whole of `G`, row-major: borrowed when stored, built otherwise
    /// (which costs the memory [`LdpProblem::from_intervals`] saves; for
    /// small problems and backends that need the matrix).
    pub fn g(&self) -> Cow<'_, [f64]> {
        match &self.source {
            RowSource::Dense(g) => Cow::Borrowed(g),
            RowSource::Interval(_) => {
                let n = self.cols;
                let mut g = vec![0.0; self.rows * n];
                g.par_chunks_mut(n)
                    .enumerate()
                    .for_each(|(i, row)| self.row_into(i, row));
                Cow::Owned(g)
            }
        }
    }

    /// `out = G x`, on several threads for large problems (each entry is
    /// computed alone, so the result does not depend on the thread count).
    pub fn products(&self, x: &[f64], out: &mut [f64]) {
        self.products_on(x, out, true);
    }

    /// As [`LdpProblem::products`], on one thread unless `parallel`.
    pub(crate) fn products_on(&self, x: &[f64], out: &mut [f64], parallel: bool) {
        let n = self.cols;
        assert_eq!(x.len(), n, "x has {} entries for {n} columns", x.len());
        assert_eq!(out.len(), self.rows, "out has {} entries", out.len());
        let dense = |g: &[f64], out: &mut [f64]| {
            if parallel && g.len() >= PARALLEL_ENTRIES {
                out.par_iter_mut()
                    .zip(g.par_chunks_exact(n))
                    .for_each(|(o, row)| *o = dot(row, x));
            } else {
                out.iter_mut()
                    .zip(g.chunks_exact(n))
                    .for_each(|(o, row)| *o = dot(row, x));
            }
        };
        match &self.source {
            RowSource::Dense(g) => dense(g, out),
            RowSource::Interval(r) => {
                r.products(x, out, parallel);
                dense(&r.extra, &mut out[2 * r.samples()..]);
            }
        }
    }

    /// The right-hand side `h`.
    pub fn h(&self) -> &[f64] {
        &self.h
    }

    /// Euclidean norm of every row.
    pub fn row_norms(&self) -> Vec<f64> {
        let n = self.cols;
        match &self.source {
            RowSource::Dense(g) => g.chunks_exact(n).map(norm).collect(),
            RowSource::Interval(r) => {
                // Generated rows are unit rows by construction (zero rows
                // stay zero).
                let mut norms: Vec<f64> = r
                    .scale
                    .iter()
                    .map(|&s| if s > 0.0 { 1.0 } else { 0.0 })
                    .collect();
                norms.resize(self.rows, 0.0);
                let generated = 2 * r.samples();
                for (v, row) in norms[generated..].iter_mut().zip(r.extra.chunks_exact(n)) {
                    *v = norm(row);
                }
                norms
            }
        }
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
    // Exact chunks of four rather than indices, so that no access needs a
    // bounds check.
    let b = &b[..a.len()];
    let (a4, b4) = (a.chunks_exact(4), b.chunks_exact(4));
    let (a_rest, b_rest) = (a4.remainder(), b4.remainder());
    let mut acc = [0.0; 4];
    for (x, y) in a4.zip(b4) {
        for l in 0..4 {
            acc[l] += x[l] * y[l];
        }
    }
    let mut s = (acc[0] + acc[1]) + (acc[2] + acc[3]);
    for (x, y) in a_rest.iter().zip(b_rest) {
        s += x * y;
    }
    s
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_dot_product_sums_in_four_lanes_then_the_tail() {
        // The order the solver's results depend on: lane l sums the
        // entries l, l + 4, ...; then (l0 + l1) + (l2 + l3), then the tail.
        for n in 0..14 {
            let a: Vec<f64> = (0..n).map(|i| 1.0 / (i as f64 + 0.3)).collect();
            let b: Vec<f64> = (0..n + 2).map(|i| (i as f64 * 0.7).sin()).collect();
            let mut acc = [0.0; 4];
            for k in 0..n / 4 {
                for (l, lane) in acc.iter_mut().enumerate() {
                    *lane += a[4 * k + l] * b[4 * k + l];
                }
            }
            let mut expected = (acc[0] + acc[1]) + (acc[2] + acc[3]);
            for k in 4 * (n / 4)..n {
                expected += a[k] * b[k];
            }
            assert_eq!(dot(&a, &b).to_bits(), expected.to_bits(), "n = {n}");
        }
    }

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
