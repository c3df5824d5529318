//! `r(x) = p(x) / q(x)` with `p` and `q` in the same graded basis.

use crate::{Basis, FitError};
use serde::{Deserialize, Serialize};

/// A rational function: numerator and denominator coefficients on the first
/// `n_p` and `n_q` functions of one basis.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RationalSpec")]
pub struct RationalFunction {
    basis: Basis,
    numerator: Vec<f64>,
    denominator: Vec<f64>,
}

#[derive(Deserialize)]
struct RationalSpec {
    basis: Basis,
    numerator: Vec<f64>,
    denominator: Vec<f64>,
}

impl TryFrom<RationalSpec> for RationalFunction {
    type Error = FitError;
    fn try_from(s: RationalSpec) -> Result<Self, FitError> {
        Self::new(s.basis, s.numerator, s.denominator)
    }
}

impl RationalFunction {
    /// Builds `p/q`; the basis must have at least `max(n_p, n_q)` functions.
    ///
    /// # Errors
    /// Empty or too long coefficient vectors, non-finite coefficients, a
    /// denominator whose coefficients are all zero.
    pub fn new(basis: Basis, numerator: Vec<f64>, denominator: Vec<f64>) -> Result<Self, FitError> {
        if numerator.is_empty() || denominator.is_empty() {
            return Err(FitError::Malformed(
                "numerator and denominator need at least one coefficient".into(),
            ));
        }
        if numerator.len().max(denominator.len()) > basis.len() {
            return Err(FitError::Malformed(format!(
                "{} + {} coefficients for a basis of {} functions",
                numerator.len(),
                denominator.len(),
                basis.len()
            )));
        }
        if numerator.iter().chain(&denominator).any(|c| !c.is_finite()) {
            return Err(FitError::Malformed("non-finite coefficient".into()));
        }
        if denominator.iter().all(|&c| c == 0.0) {
            return Err(FitError::Malformed(
                "the denominator is identically zero".into(),
            ));
        }
        Ok(Self {
            basis,
            numerator,
            denominator,
        })
    }

    /// The basis.
    pub fn basis(&self) -> &Basis {
        &self.basis
    }

    /// Numerator coefficients.
    pub fn numerator(&self) -> &[f64] {
        &self.numerator
    }

    /// Denominator coefficients.
    pub fn denominator(&self) -> &[f64] {
        &self.denominator
    }

    /// `(n_p, n_q)`.
    pub fn split(&self) -> (usize, usize) {
        (self.numerator.len(), self.denominator.len())
    }

    /// Number of variables.
    pub fn dim(&self) -> usize {
        self.basis.dim()
    }

    /// `(p(x), q(x))`.
    pub fn eval_parts(&self, x: &[f64]) -> (f64, f64) {
        if self.dim() == 1 {
            return (
                self.basis.combine(&self.numerator, x),
                self.basis.combine(&self.denominator, x),
            );
        }
        let (p, q) = (&self.numerator[..], &self.denominator[..]);
        let unrolled = match self.dim() {
            2 => crate::basis::rational_sums::<2>(&self.basis, p, q, x),
            3 => crate::basis::rational_sums::<3>(&self.basis, p, q, x),
            4 => crate::basis::rational_sums::<4>(&self.basis, p, q, x),
            _ => None,
        };
        if let Some(parts) = unrolled {
            return parts;
        }
        let (mut p, mut q) = (0.0, 0.0);
        let (np, nq) = (self.numerator.len(), self.denominator.len());
        self.basis.for_each_value(x, np.max(nq), |j, v| {
            if j < np {
                p += self.numerator[j] * v;
            }
            if j < nq {
                q += self.denominator[j] * v;
            }
        });
        (p, q)
    }

    /// `r(x)`.
    pub fn eval(&self, x: &[f64]) -> f64 {
        let (p, q) = self.eval_parts(x);
        p / q
    }

    /// `r` at many points (row-major, `dim` per point), in parallel.
    pub fn eval_many(&self, points: &[f64]) -> Vec<f64> {
        use rayon::prelude::*;
        points
            .par_chunks(self.dim())
            .map(|x| self.eval(x))
            .collect()
    }

    /// Gradient of `r` at `x`: `(p' q - p q') / q^2`.
    pub fn gradient(&self, x: &[f64]) -> Vec<f64> {
        self.value_and_gradient(x).1
    }

    /// `r(x)` and `d r / d x_k` in one pass over the basis, without the
    /// other partial derivatives (what an inverse CDF's Jacobian needs).
    pub fn value_and_partial(&self, x: &[f64], k: usize) -> (f64, f64) {
        let [p, q, dp, dq] = self.parts_and_partials(x, k);
        (p / q, (dp * q - p * dq) / (q * q))
    }

    /// `[p, q, dp/dx_k, dq/dx_k]` at `x` from one pass over the basis (as
    /// [`RationalFunction::value_and_partial`], which divides them): for
    /// callers that also need the sign of `q`.
    pub fn parts_and_partials(&self, x: &[f64], k: usize) -> [f64; 4] {
        self.basis
            .combine_with_partial(x, k, &self.numerator, &self.denominator)
    }

    /// `r(x)` and its gradient from one evaluation of the basis.
    pub fn value_and_gradient(&self, x: &[f64]) -> (f64, Vec<f64>) {
        let d = self.dim();
        let n = self.basis.len();
        let mut phi = vec![0.0; n];
        let mut dphi = vec![vec![0.0; n]; d];
        self.basis.eval_with_gradient(x, &mut phi, &mut dphi);
        let dotp = |a: &[f64], c: &[f64]| a.iter().zip(c).map(|(u, v)| u * v).sum::<f64>();
        let p = dotp(&phi, &self.numerator);
        let q = dotp(&phi, &self.denominator);
        let grad = (0..d)
            .map(|k| {
                let dp = dotp(&dphi[k], &self.numerator);
                let dq = dotp(&dphi[k], &self.denominator);
                (dp * q - p * dq) / (q * q)
            })
            .collect();
        (p / q, grad)
    }

    /// Bytes of the coefficients stored as f32 (the representation a shader
    /// uploads); the domain map adds `8 * dim` bytes.
    pub fn byte_size_f32(&self) -> usize {
        4 * (self.numerator.len() + self.denominator.len())
    }

    /// Scales both coefficient vectors together so that `||(a, b)|| = 1`
    /// (the function is unchanged).
    pub(crate) fn normalised(mut self) -> Self {
        let n = self
            .numerator
            .iter()
            .chain(&self.denominator)
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt();
        if n > 0.0 && n.is_finite() {
            self.numerator.iter_mut().for_each(|v| *v /= n);
            self.denominator.iter_mut().for_each(|v| *v /= n);
        }
        self
    }

    /// JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a rational function always serialises")
    }

    /// Parses JSON text.
    ///
    /// # Errors
    /// [`FitError::Malformed`] with the parser's message.
    pub fn from_json(s: &str) -> Result<Self, FitError> {
        serde_json::from_str(s).map_err(|e| FitError::Malformed(e.to_string()))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BasisFamily, Domain};

    #[test]
    fn the_unrolled_sums_match_the_general_path_to_the_last_bit() {
        let families = [
            BasisFamily::Monomial,
            BasisFamily::Chebyshev,
            BasisFamily::Legendre,
        ];
        let mut rng = ratfit_tests::SplitMix64::new(2012);
        let mut next = move || rng.next_f64();
        for dim in 2..=5 {
            for (case, family) in families.iter().enumerate() {
                let domain = Domain::new(vec![-0.5; dim], vec![1.5; dim]).unwrap();
                let weights: Vec<u16> = (0..dim).map(|k| 1 + ((k + case) % 2) as u16).collect();
                let basis = Basis::weighted(*family, domain, 60, &weights).unwrap();
                // Numerator longer, denominator longer, and equal lengths.
                for (np, nq) in [(37, 11), (9, 52), (23, 23)] {
                    let coeffs = |n: usize, next: &mut dyn FnMut() -> f64| -> Vec<f64> {
                        (0..n).map(|_| 2.0 * next() - 1.0).collect()
                    };
                    let (p, q) = (coeffs(np, &mut next), coeffs(nq, &mut next));
                    let r = RationalFunction::new(basis.clone(), p.clone(), q.clone()).unwrap();
                    for _ in 0..50 {
                        let x: Vec<f64> = (0..dim).map(|_| 2.2 * next() - 0.6).collect();
                        let (mut gp, mut gq) = (0.0, 0.0);
                        basis.for_each_value(&x, np.max(nq), |j, v| {
                            if j < np {
                                gp += p[j] * v;
                            }
                            if j < nq {
                                gq += q[j] * v;
                            }
                        });
                        let (fp, fq) = r.eval_parts(&x);
                        assert_eq!(
                            (fp.to_bits(), fq.to_bits()),
                            (gp.to_bits(), gq.to_bits()),
                            "{family} in {dim} coordinates, split ({np}, {nq}) at {x:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn json_round_trip_is_exact() {
        let d = Domain::new(vec![-0.3, 1.0], vec![2.0, 7.5]).unwrap();
        let b = Basis::new(BasisFamily::Chebyshev, d, 6).unwrap();
        let r = RationalFunction::new(
            b,
            vec![0.1, 1.0 / 3.0, -2e-300, 5.0],
            vec![1.0, 0.2, std::f64::consts::PI],
        )
        .unwrap();
        let back = RationalFunction::from_json(&r.to_json()).unwrap();
        assert_eq!(r, back);
    }

    #[test]
    fn malformed_json_is_an_error() {
        assert!(RationalFunction::from_json("{").is_err());
        let d = Domain::new(vec![0.0], vec![1.0]).unwrap();
        let b = Basis::new(BasisFamily::Chebyshev, d, 2).unwrap();
        let r = RationalFunction::new(b, vec![1.0, 2.0], vec![1.0]).unwrap();
        let bad = r.to_json().replace("\"len\": 2", "\"len\": 1");
        assert!(RationalFunction::from_json(&bad).is_err());
    }

    #[test]
    fn gradient_matches_finite_differences() {
        let d = Domain::new(vec![0.0, 0.0], vec![1.0, 2.0]).unwrap();
        let b = Basis::new(BasisFamily::Legendre, d, 6).unwrap();
        let r = RationalFunction::new(
            b,
            vec![0.3, 1.0, -0.5, 0.2],
            vec![2.0, 0.1, 0.3, 0.05, 0.1, 0.0],
        )
        .unwrap();
        let x = [0.4, 1.3];
        let g = r.gradient(&x);
        for k in 0..2 {
            let h = 1e-6;
            let (mut a, mut b) = (x, x);
            a[k] += h;
            b[k] -= h;
            let fd = (r.eval(&a) - r.eval(&b)) / (2.0 * h);
            assert!((fd - g[k]).abs() < 1e-6, "{k}: {fd} vs {}", g[k]);
        }
    }

    #[test]
    fn one_partial_matches_the_gradient() {
        let d = Domain::new(vec![0.0, -1.0, 0.5], vec![1.0, 2.0, 3.0]).unwrap();
        for family in [
            BasisFamily::Chebyshev,
            BasisFamily::Legendre,
            BasisFamily::Monomial,
        ] {
            let b = Basis::new(family, d.clone(), 10).unwrap();
            let r = RationalFunction::new(
                b,
                vec![0.3, 1.0, -0.5, 0.2, 0.7, -0.1, 0.05],
                vec![2.0, 0.1, 0.3, 0.05, 0.1, 0.0, 0.02, -0.03, 0.01, 0.04],
            )
            .unwrap();
            for x in [[0.4, 1.3, 1.0], [0.9, -0.7, 2.9], [0.0, 0.0, 0.5]] {
                let (v, g) = r.value_and_gradient(&x);
                for k in 0..3 {
                    let (v1, g1) = r.value_and_partial(&x, k);
                    let tol = 1e-13 * (1.0 + v.abs() + g[k].abs());
                    assert!(
                        (v1 - v).abs() < tol && (g1 - g[k]).abs() < tol,
                        "{family:?} {x:?} {k}"
                    );
                }
            }
        }
    }
}
