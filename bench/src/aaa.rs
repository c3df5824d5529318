//! The AAA algorithm (Nakatsukasa, Sete and Trefethen 2018), real version:
//! a general-purpose rational approximation in barycentric form, the peer the
//! interval method is compared with on 1-D functions. AAA minimises a
//! linearised least-squares residual and bounds nothing at any sample; the
//! benchmark measures where its fits fall against the same intervals.

use anyhow::{bail, Result};

/// `r(x) = sum_k w_k f_k / (x - z_k) / sum_k w_k / (x - z_k)`, with
/// `r(z_k) = f_k`: type `(m - 1, m - 1)` for `m` support points.
#[derive(Debug, Clone)]
pub struct Barycentric {
    /// Support points `z_k`.
    pub nodes: Vec<f64>,
    /// Values `f_k` at the support points.
    pub values: Vec<f64>,
    /// Barycentric weights `w_k`.
    pub weights: Vec<f64>,
}

impl Barycentric {
    /// `r(x)`.
    pub fn eval(&self, x: f64) -> f64 {
        let (mut n, mut d) = (0.0, 0.0);
        for k in 0..self.nodes.len() {
            let diff = x - self.nodes[k];
            if diff.abs() < f64::MIN_POSITIVE {
                return self.values[k];
            }
            let c = self.weights[k] / diff;
            n += c * self.values[k];
            d += c;
        }
        n / d
    }

    /// Number of support points `m`.
    pub fn support(&self) -> usize {
        self.nodes.len()
    }
}

/// Runs AAA on samples `(x_i, f_i)` up to `max_support` support points,
/// calling `step` with each iterate (support points 1, 2, ...). Stops early
/// when the largest residual falls below `rel_tol * max |f|`.
///
/// # Errors
/// Fewer samples than `max_support + 1`, or non-finite data.
pub fn aaa(
    x: &[f64],
    f: &[f64],
    max_support: usize,
    rel_tol: f64,
    mut step: impl FnMut(&Barycentric),
) -> Result<()> {
    let n = x.len();
    if n != f.len() || n <= max_support || max_support == 0 {
        bail!("AAA needs more samples ({n}) than support points ({max_support})");
    }
    if x.iter().chain(f).any(|v| !v.is_finite()) {
        bail!("AAA needs finite samples");
    }
    let scale = f.iter().fold(0.0_f64, |a, v| a.max(v.abs()));
    let mean = f.iter().sum::<f64>() / n as f64;
    let mut approx = vec![mean; n];
    let mut is_support = vec![false; n];
    let mut support: Vec<usize> = Vec::new();
    // Cauchy matrix columns 1 / (x_i - z_k), column-major over all samples.
    let mut cauchy: Vec<Vec<f64>> = Vec::new();
    for _ in 0..max_support {
        let next = (0..n)
            .filter(|&i| !is_support[i])
            .max_by(|&a, &b| {
                (f[a] - approx[a])
                    .abs()
                    .total_cmp(&(f[b] - approx[b]).abs())
            })
            .expect("more samples than support points");
        is_support[next] = true;
        support.push(next);
        let z = x[next];
        cauchy.push(
            x.iter()
                .map(|&xi| {
                    if (xi - z).abs() > 0.0 {
                        1.0 / (xi - z)
                    } else {
                        0.0
                    }
                })
                .collect(),
        );
        let m = support.len();
        let rows: Vec<usize> = (0..n).filter(|&i| !is_support[i]).collect();
        // Loewner matrix L[i, k] = (f_i - f_{z_k}) / (x_i - z_k) on the
        // other samples; the weights are its smallest right singular vector,
        // from the SVD of the R factor of a thin QR.
        let loewner = faer::Mat::<f64>::from_fn(rows.len(), m, |r, k| {
            let i = rows[r];
            (f[i] - f[support[k]]) * cauchy[k][i]
        });
        let r = loewner.qr().thin_R().to_owned();
        let weights: Vec<f64> = match r.svd() {
            Ok(svd) => (0..m).map(|k| svd.V()[(k, m - 1)]).collect(),
            Err(_) => bail!("AAA: the SVD of the Loewner matrix did not converge at m = {m}"),
        };
        let values: Vec<f64> = support.iter().map(|&i| f[i]).collect();
        for i in 0..n {
            if is_support[i] {
                approx[i] = f[i];
                continue;
            }
            let (mut num, mut den) = (0.0, 0.0);
            for k in 0..m {
                let c = weights[k] * cauchy[k][i];
                num += c * values[k];
                den += c;
            }
            approx[i] = num / den;
        }
        step(&Barycentric {
            nodes: support.iter().map(|&i| x[i]).collect(),
            values,
            weights,
        });
        let err = (0..n).fold(0.0_f64, |a, i| a.max((f[i] - approx[i]).abs()));
        if err <= rel_tol * scale || err.is_nan() {
            break;
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recovers_a_rational_function_exactly() {
        // Runge is type (0, 2): three support points reproduce it.
        let x: Vec<f64> = (0..400).map(|i| -1.0 + 2.0 * i as f64 / 399.0).collect();
        let f: Vec<f64> = x.iter().map(|x| 1.0 / (1.0 + 25.0 * x * x)).collect();
        let mut last = None;
        aaa(&x, &f, 10, 1e-13, |r| last = Some(r.clone())).unwrap();
        let r = last.unwrap();
        assert!(r.support() <= 4, "{}", r.support());
        let err = x
            .iter()
            .zip(&f)
            .fold(0.0_f64, |a, (x, f)| a.max((r.eval(*x) - f).abs()));
        assert!(err < 1e-12, "{err}");
    }

    #[test]
    fn converges_on_a_kink() {
        // |x| is hard for polynomials; AAA clusters poles near 0.
        let x: Vec<f64> = (0..2001).map(|i| -1.0 + i as f64 / 1000.0).collect();
        let f: Vec<f64> = x.iter().map(|x| x.abs() + 0.1).collect();
        let mut errs = Vec::new();
        aaa(&x, &f, 16, 0.0, |r| {
            errs.push(
                x.iter()
                    .zip(&f)
                    .fold(0.0_f64, |a, (x, f)| a.max((r.eval(*x) - f).abs())),
            )
        })
        .unwrap();
        assert_eq!(errs.len(), 16);
        assert!(errs[15] < 1e-3 * errs[0], "{errs:?}");
    }

    #[test]
    fn refuses_too_few_samples() {
        assert!(aaa(&[0.0, 1.0], &[1.0, 2.0], 2, 0.0, |_| {}).is_err());
        assert!(aaa(&[0.0, 1.0, 2.0], &[1.0, f64::NAN, 2.0], 2, 0.0, |_| {}).is_err());
    }
}
