//! The paper's P(n_p, n_q): two linear inequalities per sample, each row
//! divided by its Euclidean norm, `G c >= 1`.

use crate::{Basis, FitError, IntervalData};
use qp_backends::LdpProblem;
use rayon::prelude::*;
use std::sync::Arc;

/// Basis values at every sample (`samples x cols`, row-major), computed once
/// and shared by every split of a sweep: the problems of the splits generate
/// their rows from it instead of storing them.
#[derive(Debug, Clone)]
pub struct DesignMatrix {
    cols: usize,
    values: Arc<[f64]>,
}

impl DesignMatrix {
    /// Evaluates the first `basis.len()` functions at every point of `data`.
    pub fn new(basis: &Basis, data: &IntervalData) -> Self {
        let cols = basis.len();
        let mut values = vec![0.0; data.len() * cols];
        values
            .par_chunks_mut(cols)
            .enumerate()
            .for_each(|(i, row)| basis.eval_into(data.point(i), row));
        Self {
            cols,
            values: values.into(),
        }
    }

    /// Values at sample `i`.
    pub fn row(&self, i: usize) -> &[f64] {
        &self.values[i * self.cols..(i + 1) * self.cols]
    }

    /// Number of basis functions.
    pub fn cols(&self) -> usize {
        self.cols
    }
}

/// Linear constraints on the coefficient vector `c = (a, b)` that callers add
/// to P(n_p, n_q), each read as `row . c > 0` (with the same normalised
/// margin as the data rows). The `cdf` crate adds monotonicity this way.
pub trait ExtraConstraints: Sync {
    /// Rows of length `n_p + n_q` for this split.
    fn rows(&self, basis: &Basis, n_p: usize, n_q: usize) -> Vec<Vec<f64>>;
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
/// `h = 1`.
///
/// # Errors
/// A split larger than the design matrix, or extra rows of the wrong length.
pub fn build_problem(
    design: &DesignMatrix,
    data: &IntervalData,
    n_p: usize,
    n_q: usize,
    extra: &[Vec<f64>],
) -> Result<LdpProblem, FitError> {
    build_problem_scaled(design, data, n_p, n_q, extra, 1.0)
}

/// As [`build_problem`] with the bounds divided by `value_scale` (and the
/// numerator part of every extra row multiplied by it): the solution is
/// `(a / value_scale, b)`. Dividing by the data's magnitude makes the fit
/// independent of the data's units (the least-norm objective is not).
///
/// # Errors
/// As [`build_problem`], plus a scale that is not finite and positive.
pub fn build_problem_scaled(
    design: &DesignMatrix,
    data: &IntervalData,
    n_p: usize,
    n_q: usize,
    extra: &[Vec<f64>],
    value_scale: f64,
) -> Result<LdpProblem, FitError> {
    build_problem_in(design, data, n_p, n_q, extra, value_scale)
}

/// As [`build_problem_scaled`]; the rows are generated from `design` by the
/// solver (`LdpProblem::from_intervals`), so no split stores its `G`.
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

/// 2-norm condition number of `G` (thin QR by faer, then the singular values
/// of `R`); `+inf` when `G` is rank deficient.
pub fn condition_number(problem: &LdpProblem) -> f64 {
    let (m, n) = (problem.rows(), problem.cols());
    if m < n {
        return f64::INFINITY;
    }
    let g = problem.g();
    let g = faer::MatRef::from_row_major_slice(&g, m, n);
    let qr = g.qr();
    let r = qr.thin_R().to_owned();
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
        let p = build_problem(&design, &data, 2, 1, &[]).unwrap();
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
}
