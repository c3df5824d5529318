//! The fitted inverse CDFs with their boundary conditions built in:
//!
//! ```text
//! r_theta(theta_v, mu)         = (pi/2) mu + mu (1 - mu) g(theta_v, mu)
//! r_phi(theta_v, theta_l, tau) = pi tau + tau (1 - tau) theta_v theta_l h(s, w, tau)
//! ```
//!
//! with `g`, `h` rational and `s = theta_v + theta_l`, `w = theta_v theta_l`.
//! Every symmetric polynomial in two variables is a polynomial in their sum
//! and product, so a basis in `(s, w)` is a symmetrised basis: `r_phi` is
//! symmetric in `theta_v` and `theta_l` exactly (bit for bit: `+` and `*`
//! commute in floating point), with fewer coefficients than a full basis.

use crate::CdfError;
use rational_core::{PowerForm, RationalFunction};
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// Which of the two inverse CDFs.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Component {
    /// `theta_l = r_theta(theta_v, mu)`.
    Theta,
    /// `phi_l = r_phi(theta_v, theta_l, tau)` on `[0, pi]`.
    Phi,
}

impl Component {
    /// Dimension of the natural coordinates.
    pub fn dim(self) -> usize {
        match self {
            Self::Theta => 2,
            Self::Phi => 3,
        }
    }

    /// Index of the sampled variable (`mu` or `tau`) in the coordinates.
    pub fn sampled(self) -> usize {
        self.dim() - 1
    }

    /// Coordinates of the rational part: `(theta_v, mu)` for theta,
    /// `(theta_v + theta_l, theta_v theta_l, tau)` for phi.
    pub fn fit_coordinates(self, natural: &[f64]) -> Vec<f64> {
        let (x, n) = self.fit_coordinates_array(natural);
        x[..n].to_vec()
    }

    /// [`Component::fit_coordinates`] on the stack (the per-sample path):
    /// the coordinates and how many there are.
    #[inline]
    pub fn fit_coordinates_array(self, natural: &[f64]) -> ([f64; 3], usize) {
        match self {
            Self::Theta => ([natural[0], natural[1], 0.0], 2),
            Self::Phi => (
                [natural[0] + natural[1], natural[0] * natural[1], natural[2]],
                3,
            ),
        }
    }

    /// Known part `(base, weight)` of `r = base + weight * rational` and
    /// their derivatives in the sampled variable.
    #[inline]
    pub fn known_part(self, natural: &[f64]) -> KnownPart {
        match self {
            Self::Theta => {
                let mu = natural[1];
                KnownPart {
                    base: FRAC_PI_2 * mu,
                    weight: mu * (1.0 - mu),
                    base_d: FRAC_PI_2,
                    weight_d: 1.0 - 2.0 * mu,
                }
            }
            Self::Phi => {
                let (tv, tl, tau) = (natural[0], natural[1], natural[2]);
                let w = tv * tl;
                KnownPart {
                    base: PI * tau,
                    weight: tau * (1.0 - tau) * w,
                    base_d: PI,
                    weight_d: (1.0 - 2.0 * tau) * w,
                }
            }
        }
    }

    /// Upper end of the sampled range (`pi/2` or `pi`).
    pub fn range(self) -> f64 {
        match self {
            Self::Theta => FRAC_PI_2,
            Self::Phi => PI,
        }
    }

    /// Name for reports.
    pub fn name(self) -> &'static str {
        match self {
            Self::Theta => "theta",
            Self::Phi => "phi",
        }
    }
}

/// The known part of a boundary-embedded model at one point.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KnownPart {
    /// `base(x)`.
    pub base: f64,
    /// `weight(x)`.
    pub weight: f64,
    /// `d base / d u` (u the sampled variable).
    pub base_d: f64,
    /// `d weight / d u`.
    pub weight_d: f64,
}

impl KnownPart {
    /// `(r, d r / d u)` of `r = base + weight * p / q` from the rational
    /// part's `[p, q, dp/du, dq/du]`; where the weight vanishes the value is
    /// the base exactly (the boundaries), whatever the rational part is.
    #[inline]
    fn with_rational(self, [p, q, dp, dq]: [f64; 4]) -> (f64, f64) {
        let (g, dg) = (p / q, (dp * q - p * dq) / (q * q));
        let value = if self.weight == 0.0 {
            self.base
        } else {
            self.base + self.weight * g
        };
        (value, self.base_d + self.weight_d * g + self.weight * dg)
    }
}

/// A rational inverse CDF: the model of one [`Component`] and its fitted
/// rational part.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct InverseCdf {
    /// Which inverse CDF.
    pub component: Component,
    /// The rational part in fit coordinates.
    pub rational: RationalFunction,
}

impl InverseCdf {
    /// Builds one; the rational part must have the component's dimension.
    ///
    /// # Errors
    /// Dimension mismatch.
    pub fn new(component: Component, rational: RationalFunction) -> Result<Self, CdfError> {
        if rational.dim() != component.dim() {
            return Err(CdfError::Malformed(format!(
                "{} inverse CDF needs {} coordinates, the function has {}",
                component.name(),
                component.dim(),
                rational.dim()
            )));
        }
        Ok(Self {
            component,
            rational,
        })
    }

    /// `r(x)` at natural coordinates.
    pub fn eval(&self, natural: &[f64]) -> f64 {
        let k = self.component.known_part(natural);
        if k.weight == 0.0 {
            // Exact boundary values, whatever the rational part is there.
            return k.base;
        }
        let (x, n) = self.component.fit_coordinates_array(natural);
        k.base + k.weight * self.rational.eval(&x[..n])
    }

    /// `(r(x), d r / d u)` with `u` the sampled variable.
    pub fn eval_with_derivative(&self, natural: &[f64]) -> (f64, f64) {
        self.eval_with_derivative_in(natural, None)
    }

    /// [`InverseCdf::eval_with_derivative`] with the rational part in
    /// `power`, its [`PowerForm`] (the sampled variable is the last fit
    /// coordinate), when given: the same values to rounding, faster.
    #[inline]
    pub(crate) fn eval_with_derivative_in(
        &self,
        natural: &[f64],
        power: Option<&PowerForm>,
    ) -> (f64, f64) {
        let c = self.component;
        let known = c.known_part(natural);
        if known.weight == 0.0 && known.weight_d == 0.0 {
            // The rational part does not enter (phi at a view along the
            // normal, where the map is `pi tau` exactly).
            return (known.base, known.base_d);
        }
        let (x, n) = c.fit_coordinates_array(natural);
        let parts = match power {
            Some(power) => power.parts_and_last_partial(&x[..n]),
            None => self.rational.parts_and_partials(&x[..n], c.sampled()),
        };
        known.with_rational(parts)
    }

    /// `d r / d u` and the rational part's denominator `q` at a natural
    /// point, from one pass (the monotonicity check's figures; the
    /// derivative is [`InverseCdf::eval_with_derivative`]'s, bit for bit).
    pub(crate) fn derivative_and_denominator(&self, natural: &[f64]) -> (f64, f64) {
        let c = self.component;
        let k = c.known_part(natural);
        let (x, n) = c.fit_coordinates_array(natural);
        let [p, q, dp, dq] = self.rational.parts_and_partials(&x[..n], c.sampled());
        let (g, dg) = (p / q, (dp * q - p * dq) / (q * q));
        (k.base_d + k.weight_d * g + k.weight * dg, q)
    }

    /// The `u` in `[0, 1]` with `r(.., u) = target` (the other coordinates
    /// from `natural`), by safeguarded Newton iteration; `None` when the
    /// target is outside `[r(0), r(1)]`.
    pub fn invert(&self, natural: &[f64], target: f64) -> Option<f64> {
        self.invert_in(natural, target, None)
    }

    /// [`InverseCdf::invert`] evaluating the rational part in `power` when
    /// given (see [`InverseCdf::eval_with_derivative_in`]).
    pub(crate) fn invert_in(
        &self,
        natural: &[f64],
        target: f64,
        power: Option<&PowerForm>,
    ) -> Option<f64> {
        let s = self.component.sampled();
        let dim = self.component.dim();
        let mut x = [0.0; 3];
        x[..dim].copy_from_slice(&natural[..dim]);
        let (mut lo, mut hi) = (0.0_f64, 1.0_f64);
        if !(0.0..=self.component.range()).contains(&target) {
            return None;
        }
        // The model maps [0, 1] onto [0, range] (boundaries built in).
        let mut u = target / self.component.range();
        for _ in 0..100 {
            x[s] = u;
            let (r, d) = self.eval_with_derivative_in(&x[..dim], power);
            let f = r - target;
            if f.abs() <= 4.0 * f64::EPSILON * self.component.range() {
                return Some(u);
            }
            if f > 0.0 {
                hi = u;
            } else {
                lo = u;
            }
            let newton = u - f / d;
            u = if d > 0.0 && newton > lo && newton < hi {
                newton
            } else {
                0.5 * (lo + hi)
            };
            if hi - lo <= f64::EPSILON {
                return Some(u);
            }
        }
        Some(u)
    }

    /// Coefficients stored (f32 bytes = 4 x this).
    pub fn coefficients(&self) -> usize {
        let (p, q) = self.rational.split();
        p + q
    }
}

/// The pair of inverse CDFs a sampler needs, for view elevations up to
/// `max_view` (larger ones are clamped). Deserialisation checks the
/// components' order and dimensions and the view range.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "RationalCdfSpec")]
pub struct RationalCdf {
    /// Material the fit was made for.
    pub material: String,
    /// Largest fitted view elevation (radians).
    pub max_view: f64,
    /// `theta_l = r_theta(theta_v, mu)`.
    pub theta: InverseCdf,
    /// `phi_l = r_phi(theta_v, theta_l, tau)`.
    pub phi: InverseCdf,
}

/// The serialised form of a [`RationalCdf`], checked on the way in.
#[derive(Deserialize)]
struct RationalCdfSpec {
    material: String,
    max_view: f64,
    theta: InverseCdf,
    phi: InverseCdf,
}

impl TryFrom<RationalCdfSpec> for RationalCdf {
    type Error = CdfError;
    fn try_from(c: RationalCdfSpec) -> Result<Self, CdfError> {
        if c.theta.component != Component::Theta || c.phi.component != Component::Phi {
            return Err(CdfError::Malformed("components out of order".into()));
        }
        InverseCdf::new(Component::Theta, c.theta.rational.clone())?;
        InverseCdf::new(Component::Phi, c.phi.rational.clone())?;
        if !(c.max_view > 0.0 && c.max_view < FRAC_PI_2) {
            return Err(CdfError::Malformed(format!(
                "max view {} rad is outside (0, pi/2)",
                c.max_view
            )));
        }
        Ok(Self {
            material: c.material,
            max_view: c.max_view,
            theta: c.theta,
            phi: c.phi,
        })
    }
}

impl RationalCdf {
    /// Coefficient bytes stored as f32.
    pub fn byte_size_f32(&self) -> usize {
        4 * (self.theta.coefficients() + self.phi.coefficients())
    }

    /// `(theta_l, phi_l, alpha)` for view elevation `theta_v` and `(mu, tau)`,
    /// `phi_l` on `[0, pi]`; `alpha = d theta/d mu * d phi/d tau * sin(theta_l)`
    /// is the inverse of the density (per steradian, on the half range of
    /// `phi`) of the directions this map produces.
    pub fn map(&self, theta_v: f64, mu: f64, tau: f64) -> (f64, f64, f64) {
        self.map_in(theta_v, mu, tau, [None, None])
    }

    /// [`RationalCdf::map`] with the rational parts of theta and phi in
    /// their power forms where given.
    pub(crate) fn map_in(
        &self,
        theta_v: f64,
        mu: f64,
        tau: f64,
        power: [Option<&PowerForm>; 2],
    ) -> (f64, f64, f64) {
        let tv = theta_v.clamp(0.0, self.max_view);
        let (theta, dt) = self.theta.eval_with_derivative_in(&[tv, mu], power[0]);
        let theta = theta.clamp(0.0, FRAC_PI_2);
        let (phi, dp) = self
            .phi
            .eval_with_derivative_in(&[tv, theta, tau], power[1]);
        (theta, phi.clamp(0.0, PI), dt * dp * theta.sin())
    }

    /// JSON text.
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("an inverse CDF always serialises")
    }

    /// Parses JSON text and checks the components.
    ///
    /// # Errors
    /// [`CdfError::Malformed`] with the parser's message or the mismatch.
    pub fn from_json(s: &str) -> Result<Self, CdfError> {
        serde_json::from_str(s).map_err(|e| CdfError::Malformed(e.to_string()))
    }
}
