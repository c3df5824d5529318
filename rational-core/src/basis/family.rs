//! The univariate families and the box domain a basis maps to `[-1, 1]`.

use crate::FitError;
use serde::{Deserialize, Serialize};

/// Univariate polynomial family. Deliberately exhaustive: every evaluator
/// of a fit (the f32 form, the shaders, the binary format) must know each
/// family, so a new one is a breaking change by nature.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
pub enum BasisFamily {
    /// `x^k`: simple, ill-conditioned beyond modest degrees.
    Monomial,
    /// Chebyshev polynomials of the first kind `T_k`: the sensible default.
    #[default]
    Chebyshev,
    /// Legendre polynomials `P_k`.
    Legendre,
}

impl std::str::FromStr for BasisFamily {
    type Err = FitError;
    fn from_str(s: &str) -> Result<Self, FitError> {
        match s.to_ascii_lowercase().as_str() {
            "monomial" | "power" => Ok(Self::Monomial),
            "chebyshev" | "cheb" => Ok(Self::Chebyshev),
            "legendre" => Ok(Self::Legendre),
            _ => Err(FitError::InvalidSetting {
                name: "basis",
                reason: format!("unknown family `{s}` (monomial, chebyshev, legendre)"),
            }),
        }
    }
}

impl std::fmt::Display for BasisFamily {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            Self::Monomial => "monomial",
            Self::Chebyshev => "chebyshev",
            Self::Legendre => "legendre",
        })
    }
}

impl BasisFamily {
    /// Values `phi_0..=phi_deg` at `t` (and derivatives when `dv` is given).
    pub(crate) fn values(self, t: f64, v: &mut [f64], dv: Option<&mut [f64]>) {
        let deg = v.len() - 1;
        v[0] = 1.0;
        if deg >= 1 {
            v[1] = t;
        }
        for k in 1..deg {
            let kf = k as f64;
            v[k + 1] = match self {
                Self::Monomial => v[k] * t,
                Self::Chebyshev => 2.0 * t * v[k] - v[k - 1],
                Self::Legendre => ((2.0 * kf + 1.0) * t * v[k] - kf * v[k - 1]) / (kf + 1.0),
            };
        }
        if let Some(d) = dv {
            d[0] = 0.0;
            if deg >= 1 {
                d[1] = 1.0;
            }
            for k in 1..deg {
                let kf = k as f64;
                d[k + 1] = match self {
                    Self::Monomial => (kf + 1.0) * v[k],
                    // T'_{k+1} = 2 T_k + 2 t T'_k - T'_{k-1}
                    Self::Chebyshev => 2.0 * v[k] + 2.0 * t * d[k] - d[k - 1],
                    // P'_{k+1} = P'_{k-1} + (2k + 1) P_k
                    Self::Legendre => d[k - 1] + (2.0 * kf + 1.0) * v[k],
                };
            }
        }
    }

    /// Power-series coefficients (in the mapped variable) of `phi_0..=phi_deg`.
    pub(crate) fn power_coefficients(self, deg: usize) -> Vec<Vec<f64>> {
        let mut out: Vec<Vec<f64>> = Vec::with_capacity(deg + 1);
        for k in 0..=deg {
            let mut c = vec![0.0; deg + 1];
            match (self, k) {
                (_, 0) => c[0] = 1.0,
                (_, 1) => c[1] = 1.0,
                (Self::Monomial, _) => c[k] = 1.0,
                (Self::Chebyshev, _) => {
                    for j in 0..deg {
                        c[j + 1] += 2.0 * out[k - 1][j];
                    }
                    for j in 0..=deg {
                        c[j] -= out[k - 2][j];
                    }
                }
                (Self::Legendre, _) => {
                    let m = (k - 1) as f64;
                    for j in 0..deg {
                        c[j + 1] += (2.0 * m + 1.0) / (m + 1.0) * out[k - 1][j];
                    }
                    for j in 0..=deg {
                        c[j] -= m / (m + 1.0) * out[k - 2][j];
                    }
                }
            }
            out.push(c);
        }
        out
    }
}

/// An axis-aligned box; every coordinate is mapped affinely onto `[-1, 1]`.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Domain {
    /// Lower corner.
    pub lower: Vec<f64>,
    /// Upper corner.
    pub upper: Vec<f64>,
}

impl Domain {
    /// A box from its corners.
    ///
    /// # Errors
    /// Mismatched lengths, non-finite corners or `lower > upper`.
    pub fn new(lower: Vec<f64>, upper: Vec<f64>) -> Result<Self, FitError> {
        if lower.len() != upper.len() || lower.is_empty() {
            return Err(FitError::DimensionMismatch(format!(
                "domain corners have {} and {} coordinates",
                lower.len(),
                upper.len()
            )));
        }
        for (k, (&a, &b)) in lower.iter().zip(&upper).enumerate() {
            if !a.is_finite() || !b.is_finite() {
                return Err(FitError::NonFinite {
                    what: "domain corner of coordinate",
                    index: k,
                    value: if a.is_finite() { b } else { a },
                });
            }
            if a > b {
                return Err(FitError::InvalidSetting {
                    name: "domain",
                    reason: format!("coordinate {k}: lower {a} above upper {b}"),
                });
            }
        }
        Ok(Self { lower, upper })
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.lower.len()
    }

    /// Maps coordinate `k` of `x` to `[-1, 1]`; a degenerate side maps to 0.
    #[inline]
    pub fn map(&self, k: usize, x: f64) -> f64 {
        let w = self.upper[k] - self.lower[k];
        if w > 0.0 {
            (2.0 * (x - self.lower[k]) / w - 1.0).clamp(-1.0e300, 1.0e300)
        } else {
            0.0
        }
    }

    /// `d t / d x` of the map of coordinate `k`.
    #[inline]
    pub fn scale(&self, k: usize) -> f64 {
        let w = self.upper[k] - self.lower[k];
        if w > 0.0 {
            2.0 / w
        } else {
            0.0
        }
    }
}
