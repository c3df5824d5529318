//! The analytic lobe of the lobe-times-rational representation.
//!
//! A glossy table spans orders of magnitude around a narrow peak; fitting
//! it directly spends most coefficients on the peak's shape. Dividing the
//! table by a fitted Cook-Torrance GGX lobe leaves a ratio close to one and
//! smooth wherever the lobe has the right shape, which a low-order rational
//! function follows within tight intervals. The fit stores the lobe's seven
//! parameters next to the rational functions: `f = lobe * p / q` per RGB
//! channel, or `Y = lobe_Y * p / q` for the luminance of the
//! luminance-chroma mode (the chroma ratios are not divided).

use crate::baseline::fit_ggx;
use crate::colour::{luminance, ColourMode};
use crate::geometry::{dot, normalize, HalfDiff, Vec3};
use crate::{Brdf, BrdfError};
use serde::{Deserialize, Serialize};

/// Cook-Torrance GGX parameters (Lambertian base, GGX distribution,
/// separable Smith shadowing, Schlick Fresnel) as a positive factor.
/// Deserialisation checks them ([`Lobe::validate`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "LobeSpec")]
pub struct Lobe {
    /// Diffuse albedo per RGB channel (positive: the lobe never vanishes,
    /// so the ratio it divides is finite everywhere).
    pub kd: [f64; 3],
    /// Fresnel reflectance at normal incidence per channel, in `[0, 1]`.
    pub f0: [f64; 3],
    /// GGX roughness.
    pub alpha: f64,
}

#[derive(Deserialize)]
struct LobeSpec {
    kd: [f64; 3],
    f0: [f64; 3],
    alpha: f64,
}

impl TryFrom<LobeSpec> for Lobe {
    type Error = BrdfError;
    fn try_from(s: LobeSpec) -> Result<Self, BrdfError> {
        let l = Lobe {
            kd: s.kd,
            f0: s.f0,
            alpha: s.alpha,
        };
        l.validate()?;
        Ok(l)
    }
}

/// Largest diffuse albedo a lobe may have: well above any reflectance, and
/// small enough that the lobe times a function stays finite in f32.
pub const MAX_LOBE_ALBEDO: f64 = 1e4;

/// Smallest and largest GGX roughness a lobe may have.
pub const LOBE_ALPHA_RANGE: (f64, f64) = (1e-3, 2.0);

impl Lobe {
    /// Fits the lobe to a material (multi-start Levenberg-Marquardt on the
    /// cosine-weighted log error, [`fit_ggx`]); the diffuse albedo is kept
    /// at least a millionth of the largest so the lobe stays positive.
    pub fn fit(material: &dyn Brdf) -> Lobe {
        let m = fit_ggx(material).model;
        let top = m.kd.iter().copied().fold(0.0_f64, f64::max).max(1e-12);
        Lobe {
            kd: m.kd.map(|k| k.max(1e-6 * top)),
            f0: m.f0.map(|f| f.clamp(0.0, 1.0)),
            alpha: m.alpha.clamp(LOBE_ALPHA_RANGE.0, LOBE_ALPHA_RANGE.1),
        }
    }

    /// Checks the parameters: `kd` in `(0, MAX_LOBE_ALBEDO]`, `f0` in
    /// `[0, 1]`, `alpha` in [`LOBE_ALPHA_RANGE`].
    ///
    /// # Errors
    /// The first parameter out of range, named.
    pub fn validate(&self) -> Result<(), BrdfError> {
        let bad = |reason: String| BrdfError::Invalid {
            name: "lobe",
            reason,
        };
        if let Some(k) = self
            .kd
            .iter()
            .find(|k| !(**k > 0.0 && **k <= MAX_LOBE_ALBEDO))
        {
            return Err(bad(format!(
                "diffuse albedo {k} is not in (0, {MAX_LOBE_ALBEDO}]"
            )));
        }
        if let Some(f) = self.f0.iter().find(|f| !(0.0..=1.0).contains(*f)) {
            return Err(bad(format!("f0 {f} is not in [0, 1]")));
        }
        let (lo, hi) = LOBE_ALPHA_RANGE;
        if !(lo..=hi).contains(&self.alpha) {
            return Err(bad(format!(
                "roughness {} is not in [{lo}, {hi}]",
                self.alpha
            )));
        }
        Ok(())
    }

    /// The lobe's RGB value at a direction pair above the surface. The
    /// Smith terms are divided by the cosines in closed form, so the value
    /// stays finite and positive up to grazing.
    pub fn rgb(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        let h = normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
        let a2 = self.alpha * self.alpha;
        let g = |c: f64| crate::analytic::smith_g1_over_cos(c.max(0.0), a2);
        let spec = 0.25 * crate::analytic::ggx_d(h[2], a2) * g(wi[2]) * g(wo[2]);
        let cos_d = dot(wi, h);
        [0, 1, 2]
            .map(|c| self.kd[c] / std::f64::consts::PI + spec * crate::schlick(self.f0[c], cos_d))
    }

    /// What each fitted function is multiplied by: the lobe per RGB
    /// channel, or its luminance for `Y` and 1 for the chroma ratios.
    pub fn factors(&self, wi: Vec3, wo: Vec3, mode: ColourMode) -> [f64; 3] {
        let v = self.rgb(wi, wo);
        match mode {
            ColourMode::Rgb => v,
            ColourMode::LuminanceChroma => [luminance(v), 1.0, 1.0],
        }
    }

    /// [`Lobe::factors`] at Rusinkiewicz angles `(theta_h, theta_d, phi_d)`.
    pub fn factors_at(&self, angles: [f64; 3], mode: ColourMode) -> [f64; 3] {
        let (wi, wo) = HalfDiff {
            theta_h: angles[0],
            phi_h: 0.0,
            theta_d: angles[1],
            phi_d: angles[2],
        }
        .to_directions();
        self.factors(wi, wo, mode)
    }

    /// The f32 form evaluated by [`crate::CompactBrdf`] and the shaders.
    pub fn to_f32(&self) -> LobeF32 {
        let narrow = |v: [f64; 3]| v.map(|x| x as f32);
        LobeF32 {
            kd_over_pi: narrow(self.kd.map(|k| k / std::f64::consts::PI)),
            f0: narrow(self.f0),
            alpha: self.alpha as f32,
        }
    }
}

/// A [`Lobe`] in f32, with the diffuse term divided by pi as stored.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct LobeF32 {
    /// `kd / pi` per channel.
    pub kd_over_pi: [f32; 3],
    /// Fresnel reflectance at normal incidence per channel.
    pub f0: [f32; 3],
    /// GGX roughness.
    pub alpha: f32,
}

impl LobeF32 {
    /// Checks what [`Lobe::validate`] checks, on the stored f32 values.
    ///
    /// # Errors
    /// The first parameter out of range, named.
    pub fn validate(&self) -> Result<(), BrdfError> {
        Lobe {
            kd: self.kd_over_pi.map(|k| f64::from(k) * std::f64::consts::PI),
            f0: self.f0.map(f64::from),
            alpha: f64::from(self.alpha),
        }
        .validate()
    }

    /// [`Lobe::factors`] in f32, in the order the shaders compute it.
    pub fn factors(&self, wi: [f32; 3], wo: [f32; 3], mode: ColourMode) -> [f32; 3] {
        let s = [wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]];
        let n = (s[0] * s[0] + s[1] * s[1] + s[2] * s[2]).sqrt();
        let h = [s[0] / n, s[1] / n, s[2] / n];
        let a2 = self.alpha * self.alpha;
        let t = h[2] * h[2] * (a2 - 1.0) + 1.0;
        let d = a2 / (std::f32::consts::PI * t * t);
        let g = |c: f32| {
            let c = c.max(0.0);
            2.0 / (c + (a2 + (1.0 - a2) * c * c).sqrt())
        };
        let spec = 0.25 * d * g(wi[2]) * g(wo[2]);
        let cos_d = (wi[0] * h[0] + wi[1] * h[1] + wi[2] * h[2]).clamp(0.0, 1.0);
        let u = 1.0 - cos_d;
        let u2 = u * u;
        let m = u2 * u2 * u;
        let v =
            [0, 1, 2].map(|c| self.kd_over_pi[c] + spec * (self.f0[c] + (1.0 - self.f0[c]) * m));
        match mode {
            ColourMode::Rgb => v,
            ColourMode::LuminanceChroma => {
                let w = crate::colour::LUMINANCE_WEIGHTS.map(|x| x as f32);
                [w[0] * v[0] + w[1] * v[1] + w[2] * v[2], 1.0, 1.0]
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{from_spherical, CookTorranceGgx};

    #[test]
    fn the_lobe_is_cook_torrance_and_stays_finite_at_grazing() {
        let lobe = Lobe {
            kd: [0.2, 0.3, 0.1],
            f0: [0.04, 0.5, 0.9],
            alpha: 0.2,
        };
        let ct = CookTorranceGgx {
            kd: lobe.kd,
            f0: lobe.f0,
            alpha: lobe.alpha,
        };
        let f32_lobe = lobe.to_f32();
        for (ti, to, p) in [(0.1, 0.2, 3.0), (0.7, 0.7, 3.1), (1.2, 0.4, 1.0)] {
            let (wi, wo) = (from_spherical(ti, 0.0), from_spherical(to, p));
            let (a, b) = (lobe.rgb(wi, wo), ct.eval(wi, wo));
            let lc = lobe.factors(wi, wo, ColourMode::LuminanceChroma);
            let single = f32_lobe.factors(
                crate::compact::to_f32(wi),
                crate::compact::to_f32(wo),
                ColourMode::Rgb,
            );
            for c in 0..3 {
                assert!((a[c] / b[c] - 1.0).abs() < 1e-12, "{a:?} {b:?}");
                assert!((f64::from(single[c]) / a[c] - 1.0).abs() < 1e-5);
            }
            assert!((lc[0] / luminance(a) - 1.0).abs() < 1e-12);
            assert_eq!(&lc[1..], &[1.0, 1.0]);
        }
        let grazing = lobe.rgb(
            from_spherical(std::f64::consts::FRAC_PI_2 - 1e-9, 0.0),
            from_spherical(std::f64::consts::FRAC_PI_2 - 1e-9, 3.0),
        );
        assert!(
            grazing.iter().all(|v| v.is_finite() && *v > 0.0),
            "{grazing:?}"
        );
    }

    #[test]
    fn a_lobe_out_of_range_is_refused() {
        for json in [
            r#"{"kd":[0,0.1,0.1],"f0":[0.1,0.1,0.1],"alpha":0.2}"#,
            r#"{"kd":[0.1,0.1,0.1],"f0":[1.5,0.1,0.1],"alpha":0.2}"#,
            r#"{"kd":[0.1,0.1,0.1],"f0":[0.1,0.1,0.1],"alpha":0}"#,
            r#"{"kd":[0.1,0.1,0.1],"f0":[0.1,0.1,0.1],"alpha":1e400}"#,
        ] {
            assert!(serde_json::from_str::<Lobe>(json).is_err(), "{json}");
        }
        let ok = r#"{"kd":[0.1,0.1,0.1],"f0":[0.1,0.1,0.1],"alpha":0.2}"#;
        assert!(serde_json::from_str::<Lobe>(ok).is_ok());
    }
}
