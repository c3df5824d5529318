//! The f32 form of a fitted BRDF: what a renderer or a shader evaluates.
//! The same structure feeds the compact binary format and the generated
//! WGSL/GLSL, so the f32 path here and the shaders compute the same thing in
//! the same order.

use crate::colour::ColourMode;
use crate::fitted::FittedBrdf;
use crate::geometry::Vec3;
use crate::lobe::LobeF32;
use crate::reduce::{Coordinates, PhiCoordinate, Reduction};
use crate::shell::{ShellColour, ThetaDSpacing};
use crate::value_scale::ValueScale;
use rational_core::BasisFamily;
use std::f32::consts::PI;

/// Largest coefficient magnitude a compact file may hold: far above any
/// fit's (the engine normalises the coefficient vector), and far enough
/// below `f32::MAX` that sums of up to 1e5 terms and the division by a
/// denominator of order one stay finite.
pub const MAX_COEFFICIENT: f32 = 1e30;

/// One channel in f32: basis description and coefficients.
#[derive(Debug, Clone, PartialEq)]
pub struct CompactChannel {
    /// Polynomial family.
    pub family: BasisFamily,
    /// Domain lower corner.
    pub lower: Vec<f32>,
    /// Domain upper corner.
    pub upper: Vec<f32>,
    /// Degree weight of each coordinate (all 1: the total-degree order).
    pub weights: Vec<u16>,
    /// Multi-index of each basis function ((weighted) graded order).
    pub indices: Vec<Vec<u16>>,
    /// Numerator coefficients.
    pub num: Vec<f32>,
    /// Denominator coefficients.
    pub den: Vec<f32>,
    /// Largest degree per coordinate (derived from `indices`).
    pub degrees: Vec<usize>,
}

/// A fitted BRDF in f32.
#[derive(Debug, Clone, PartialEq)]
pub struct CompactBrdf {
    /// Coordinates of the fit.
    pub coordinates: Coordinates,
    /// How `phi_d` enters the coordinates of a 3-D fit.
    pub phi: PhiCoordinate,
    /// Number of coordinates.
    pub dims: usize,
    /// Grazing cut in radians (`theta_d` is clamped to it).
    pub max_theta_d: f32,
    /// Elevation cut in radians: directions further from the normal are
    /// evaluated at the cut (see [`crate::clamp_elevation`]); `pi / 2` for
    /// a fit of the whole hemisphere.
    pub max_elevation: f32,
    /// Red, green, blue, or what `mode` says.
    pub channels: Vec<CompactChannel>,
    /// What the three functions are.
    pub mode: ColourMode,
    /// What each function's value stands for ([`FittedBrdf::scale`]).
    pub scale: ValueScale,
    /// The analytic lobe each function multiplies, when there is one.
    pub lobe: Option<LobeF32>,
    /// The largest RGB value evaluation returns ([`FittedBrdf::ceiling`]).
    pub ceiling: Option<[f32; 3]>,
    /// The factor beyond the elevation cut ([`crate::ShellFactor`]).
    pub shell: Option<ShellF32>,
}

/// [`crate::ShellFactor`] in f32: the cut is the compact form's
/// `max_elevation`.
#[derive(Debug, Clone, PartialEq)]
pub struct ShellF32 {
    /// Bins of `sqrt(theta_h / (pi / 2))`.
    pub n_theta_h: usize,
    /// Bins of `theta_d` over `[0, pi / 2]`, spaced as `spacing` says.
    pub n_theta_d: usize,
    /// Spacing of the `theta_d` bins.
    pub spacing: ThetaDSpacing,
    /// What each cell multiplies.
    pub colour: ShellColour,
    /// [`ShellColour::factors_per_cell`] factors per cell, `theta_h` major.
    pub factors: Vec<f32>,
}

impl ShellF32 {
    /// The cell of Rusinkiewicz angles, as [`crate::ShellFactor`] finds it.
    pub fn cell(&self, theta_h: f32, theta_d: f32) -> usize {
        let h = ((theta_h.max(0.0) / (PI / 2.0)).sqrt() * self.n_theta_h as f32) as usize;
        let d = match self.spacing {
            ThetaDSpacing::Uniform => theta_d.max(0.0) / (PI / 2.0),
            ThetaDSpacing::Cosine => 1.0 - theta_d.clamp(0.0, PI / 2.0).cos(),
        };
        let d = (d * self.n_theta_d as f32) as usize;
        h.min(self.n_theta_h - 1) * self.n_theta_d + d.min(self.n_theta_d - 1)
    }

    /// The multipliers of `mode`'s three functions at an (unclamped) pair:
    /// 1 when both directions are within the cut whose cosine is `cos_cut`.
    pub fn multipliers(
        &self,
        wi: [f32; 3],
        wo: [f32; 3],
        cos_cut: f32,
        mode: ColourMode,
    ) -> [f32; 3] {
        if wi[2] >= cos_cut && wo[2] >= cos_cut {
            return [1.0; 3];
        }
        let (th, td, _) = half_diff_f32(wi, wo);
        let cell = self.cell(th, td);
        match self.colour {
            ShellColour::Luminance => Self::factors_for(self.factors[cell], mode),
            ShellColour::PerFunction => {
                let k = &self.factors[3 * cell..3 * cell + 3];
                [k[0], k[1], k[2]]
            }
        }
    }

    /// What a luminance factor multiplies among the three functions.
    pub fn factors_for(k: f32, mode: ColourMode) -> [f32; 3] {
        match mode {
            ColourMode::Rgb => [k; 3],
            ColourMode::LuminanceChroma => [k, 1.0, 1.0],
        }
    }
}

/// Univariate values `phi_0..=phi_deg` at `t` in f32 (the shaders' recurrences).
pub fn univariate_f32(family: BasisFamily, t: f32, out: &mut [f32]) {
    out[0] = 1.0;
    if out.len() > 1 {
        out[1] = t;
    }
    for k in 1..out.len().saturating_sub(1) {
        let kf = k as f32;
        out[k + 1] = match family {
            BasisFamily::Monomial => out[k] * t,
            BasisFamily::Chebyshev => 2.0 * t * out[k] - out[k - 1],
            BasisFamily::Legendre => ((2.0 * kf + 1.0) * t * out[k] - kf * out[k - 1]) / (kf + 1.0),
        };
    }
}

impl CompactChannel {
    /// Largest degree per coordinate.
    pub fn max_degree(&self, k: usize) -> usize {
        self.degrees[k]
    }

    pub(crate) fn degrees_of(indices: &[Vec<u16>], dims: usize) -> Vec<usize> {
        (0..dims)
            .map(|k| indices.iter().map(|i| i[k] as usize).max().unwrap_or(0))
            .collect()
    }

    /// `p(x) / q(x)` in f32 (no allocation for degrees up to 63).
    pub fn eval(&self, x: &[f32]) -> f32 {
        let d = self.lower.len();
        let degree = (0..d).map(|k| self.max_degree(k)).max().unwrap_or(0);
        // A per-pair path: clear no larger tables than the degrees need.
        match (d, degree) {
            (3, 0..16) => self.eval_in::<3, 16>(x),
            (3, 16..64) => self.eval_in::<3, 64>(x),
            (2, 0..16) => self.eval_in::<2, 16>(x),
            (2, 16..64) => self.eval_in::<2, 64>(x),
            (1, 0..64) => self.eval_in::<1, 64>(x),
            _ => self.eval_slow(x),
        }
    }

    /// [`CompactChannel::eval`] in `D` coordinates with tables of `N` values
    /// (the degrees below `N`).
    fn eval_in<const D: usize, const N: usize>(&self, x: &[f32]) -> f32 {
        let mut tables = [[0.0f32; N]; D];
        for (k, table) in tables.iter_mut().enumerate() {
            let w = self.upper[k] - self.lower[k];
            let t = if w > 0.0 {
                2.0 * (x[k] - self.lower[k]) / w - 1.0
            } else {
                0.0
            };
            univariate_f32(self.family, t, &mut table[..=self.max_degree(k)]);
        }
        let (mut p, mut q) = (0.0f32, 0.0f32);
        for (j, idx) in self.indices.iter().enumerate() {
            let mut phi = 1.0f32;
            for (table, &i) in tables.iter().zip(&idx[..D]) {
                phi *= table[i as usize];
            }
            if let Some(c) = self.num.get(j) {
                p += c * phi;
            }
            if let Some(c) = self.den.get(j) {
                q += c * phi;
            }
        }
        p / q
    }

    fn eval_slow(&self, x: &[f32]) -> f32 {
        let d = self.lower.len();
        let mut tables: Vec<Vec<f32>> = Vec::with_capacity(d);
        for k in 0..d {
            let w = self.upper[k] - self.lower[k];
            let t = if w > 0.0 {
                2.0 * (x[k] - self.lower[k]) / w - 1.0
            } else {
                0.0
            };
            let mut v = vec![0.0; self.max_degree(k) + 1];
            univariate_f32(self.family, t, &mut v);
            tables.push(v);
        }
        let (mut p, mut q) = (0.0f32, 0.0f32);
        for (j, idx) in self.indices.iter().enumerate() {
            let phi: f32 = (0..d).map(|k| tables[k][idx[k] as usize]).product();
            if j < self.num.len() {
                p += self.num[j] * phi;
            }
            if j < self.den.len() {
                q += self.den[j] * phi;
            }
        }
        p / q
    }
}

/// Rusinkiewicz `(theta_h, theta_d, phi_d)` in f32, `phi_d` folded into
/// `[0, pi]` by mirror symmetry.
pub fn half_diff_f32(wi: [f32; 3], wo: [f32; 3]) -> (f32, f32, f32) {
    let h = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
    let n = (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
    let h = [h[0] / n, h[1] / n, h[2] / n];
    // Elevation from the normal as atan2, accurate at every angle; GPU
    // asin was measured 2e-4 off at 1.1 radians (Mesa's lavapipe).
    let elev = |v: [f32; 3]| (v[0] * v[0] + v[1] * v[1]).sqrt().atan2(v[2]);
    let theta_h = elev(h);
    // Rotate wi by -phi_h about z, then by -theta_h about y. The sines and
    // cosines come from h itself: no trigonometry, whose GPU versions may
    // be off by 2^-11 (Vulkan's bound for sin and cos).
    let s = (h[0] * h[0] + h[1] * h[1]).sqrt();
    let (cp, sp) = if s > 0.0 {
        (h[0] / s, h[1] / s)
    } else {
        (1.0, 0.0)
    };
    let a = [wi[0] * cp + wi[1] * sp, wi[1] * cp - wi[0] * sp, wi[2]];
    let (ct, st) = (h[2], s);
    let d = [a[0] * ct - a[2] * st, a[1], a[0] * st + a[2] * ct];
    let theta_d = elev(d);
    // Folded by mirror symmetry into [0, pi] (see `HalfDiff::folded_phi_d`).
    let phi_d = d[1].atan2(d[0]).abs();
    (theta_h, theta_d, phi_d)
}

/// The f32 form as a material: directions rounded to f32, values widened
/// back, so every consumer of [`crate::Brdf`] (renderers, samplers, the
/// checks of files read back) evaluates exactly what a shader would.
impl crate::Brdf for CompactBrdf {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        CompactBrdf::eval(self, wi.map(|v| v as f32), wo.map(|v| v as f32)).map(f64::from)
    }

    fn name(&self) -> String {
        "rational fit (f32 form)".into()
    }
}

/// A basis's multi-indices in order and its largest degree per coordinate:
/// what an evaluator of its functions needs besides the domain.
pub(crate) fn basis_layout(b: &rational_core::Basis) -> (Vec<Vec<u16>>, Vec<usize>) {
    let indices: Vec<Vec<u16>> = (0..b.len()).map(|j| b.multi_index(j).to_vec()).collect();
    let degrees = CompactChannel::degrees_of(&indices, b.dim());
    (indices, degrees)
}

impl CompactBrdf {
    /// The first value that f32 cannot hold (a finite f64 coefficient
    /// beyond 3.4e38 becomes infinite), named for an error message; `None`
    /// when every value is finite. The shaders and the binary format need
    /// finite values.
    pub fn first_non_finite(&self) -> Option<String> {
        let names = self.mode.names();
        for (c, ch) in self.channels.iter().enumerate() {
            let name = names.get(c).copied().unwrap_or('?');
            let parts = [
                ("numerator", &ch.num),
                ("denominator", &ch.den),
                ("domain lower corner", &ch.lower),
                ("domain upper corner", &ch.upper),
            ];
            for (what, values) in parts {
                if let Some(k) = values.iter().position(|v| !v.is_finite()) {
                    return Some(format!("channel {name}: {what} value {k}"));
                }
            }
        }
        let ceiling = self.ceiling.unwrap_or([0.0; 3]);
        if ceiling.iter().any(|v| !v.is_finite()) {
            return Some("the ceiling".into());
        }
        if let Some(l) = &self.lobe {
            let values = l.kd_over_pi.iter().chain(&l.f0).chain([&l.alpha]);
            if values.into_iter().any(|v| !v.is_finite()) {
                return Some("the lobe".into());
            }
        }
        if let Some(sh) = &self.shell {
            if let Some(k) = sh.factors.iter().position(|v| !v.is_finite()) {
                return Some(format!("shell factor {k}"));
            }
        }
        None
    }

    /// The f32 form of a fit.
    pub fn from_fitted(f: &FittedBrdf) -> Self {
        let channels = f
            .channels
            .iter()
            .map(|r| {
                let b = r.basis();
                let (indices, degrees) = basis_layout(b);
                CompactChannel {
                    degrees,
                    family: b.family(),
                    lower: b.domain().lower.iter().map(|&v| v as f32).collect(),
                    upper: b.domain().upper.iter().map(|&v| v as f32).collect(),
                    weights: b.weights().to_vec(),
                    indices,
                    num: r.numerator().iter().map(|&v| v as f32).collect(),
                    den: r.denominator().iter().map(|&v| v as f32).collect(),
                }
            })
            .collect();
        Self {
            coordinates: f.reduction.coordinates,
            phi: f.reduction.phi,
            dims: f.reduction.dims(),
            max_theta_d: f.reduction.max_theta_d_deg.to_radians() as f32,
            max_elevation: f.reduction.max_elevation_deg.min(90.0).to_radians() as f32,
            channels,
            mode: f.mode,
            scale: f.scale,
            lobe: f.lobe.map(|l| l.to_f32()),
            ceiling: f.ceiling.map(|c| c.map(|v| v as f32)),
            shell: f.shell.as_ref().map(|sh| ShellF32 {
                n_theta_h: sh.n_theta_h,
                n_theta_d: sh.n_theta_d,
                spacing: sh.spacing,
                colour: sh.colour,
                factors: sh.factors.iter().map(|&v| v as f32).collect(),
            }),
        }
    }

    /// Fitting coordinates in f32.
    pub fn coordinates(&self, wi: [f32; 3], wo: [f32; 3]) -> [f32; 3] {
        let (th, td, pd) = half_diff_f32(wi, wo);
        let td = td.min(self.max_theta_d);
        let (a, b) = match self.coordinates {
            Coordinates::Radians => (th, td),
            Coordinates::SqrtThetaH => ((th.max(0.0) / (PI / 2.0)).sqrt(), td),
            Coordinates::Cosines => (th.cos(), td.cos()),
        };
        let p = match self.phi {
            PhiCoordinate::Radians => pd,
            PhiCoordinate::Cosine => pd.cos(),
        };
        [a, b, p]
    }

    /// RGB in f32 (zero below the horizon, negative values clamped).
    pub fn eval(&self, wi: [f32; 3], wo: [f32; 3]) -> [f32; 3] {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        let shell = self.shell_factors(wi, wo);
        let (wi, wo) = if self.has_elevation_cut() {
            let (sin_cut, cos_cut) = self.max_elevation.sin_cos();
            (
                clamp_elevation_f32(wi, cos_cut, sin_cut),
                clamp_elevation_f32(wo, cos_cut, sin_cut),
            )
        } else {
            (wi, wo)
        };
        let x = self.coordinates(wi, wo);
        let v = [0, 1, 2].map(|c| self.channels[c].eval(&x[..self.dims]));
        let v = self.scale.values_f32(self.mode, v);
        let v = match &self.lobe {
            Some(lobe) => {
                let f = lobe.factors(wi, wo, self.mode);
                [v[0] * f[0], v[1] * f[1], v[2] * f[2]]
            }
            None => v,
        };
        self.finish([v[0] * shell[0], v[1] * shell[1], v[2] * shell[2]])
    }

    /// The shell factor's multipliers of the three functions at an
    /// unclamped pair (all 1 without a shell or within the cut).
    pub fn shell_factors(&self, wi: [f32; 3], wo: [f32; 3]) -> [f32; 3] {
        match &self.shell {
            Some(sh) => sh.multipliers(wi, wo, self.max_elevation.cos(), self.mode),
            None => [1.0; 3],
        }
    }

    /// RGB from the three functions' values (lobe applied): the colour
    /// mode's combination, then the ceiling, in the shaders' order.
    pub fn finish(&self, v: [f32; 3]) -> [f32; 3] {
        let rgb = self.mode.combine_f32(v);
        match self.ceiling {
            Some(c) => [rgb[0].min(c[0]), rgb[1].min(c[1]), rgb[2].min(c[2])],
            None => rgb,
        }
    }

    /// Whether directions beyond an elevation cut are moved to it.
    pub fn has_elevation_cut(&self) -> bool {
        self.max_elevation < PI / 2.0
    }

    /// Evaluates many pairs (f32, batched, in parallel).
    pub fn eval_many(&self, wi: &[[f32; 3]], wo: &[[f32; 3]]) -> Vec<[f32; 3]> {
        use rayon::prelude::*;
        wi.par_iter()
            .zip(wo.par_iter())
            .map(|(a, b)| self.eval(*a, *b))
            .collect()
    }
}

/// [`crate::clamp_elevation`] in f32, as the shaders compute it.
pub fn clamp_elevation_f32(d: [f32; 3], cos_cut: f32, sin_cut: f32) -> [f32; 3] {
    if d[2] >= cos_cut {
        return d;
    }
    let s = (d[0] * d[0] + d[1] * d[1]).sqrt();
    if s <= 0.0 {
        return d;
    }
    [d[0] * (sin_cut / s), d[1] * (sin_cut / s), cos_cut]
}

/// `f32` view of a direction.
pub fn to_f32(v: Vec3) -> [f32; 3] {
    v.map(|x| x as f32)
}

/// The reduction a compact fit corresponds to (for reports).
pub fn describe(r: &Reduction) -> String {
    r.label()
}

mod binary;
#[cfg(test)]
mod tests;
