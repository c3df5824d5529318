//! Analytic BRDF models: known truth for tests and the built-in default
//! "measured" material of `ratfit demo`.

use crate::geometry::{dot, normalize, Vec3};
use crate::Brdf;
use std::f64::consts::PI;

fn above(wi: Vec3, wo: Vec3) -> bool {
    wi[2] > 0.0 && wo[2] > 0.0
}

fn half(wi: Vec3, wo: Vec3) -> Vec3 {
    normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]])
}

/// Schlick's approximation of the Fresnel reflectance.
pub fn schlick(f0: f64, cos: f64) -> f64 {
    f0 + (1.0 - f0) * (1.0 - cos.clamp(0.0, 1.0)).powi(5)
}

/// Lambertian reflector: `albedo / pi`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Lambert {
    /// Directional-hemispherical reflectance per channel.
    pub albedo: [f64; 3],
}

impl Brdf for Lambert {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if !above(wi, wo) {
            return [0.0; 3];
        }
        self.albedo.map(|a| a / PI)
    }
    fn name(&self) -> String {
        format!("Lambert(albedo {:?})", self.albedo)
    }
}

/// Normalised Blinn-Phong: `kd / pi + ks (n + 8) / (8 pi) cos^n theta_h`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct BlinnPhong {
    /// Diffuse albedo.
    pub kd: [f64; 3],
    /// Specular weight.
    pub ks: [f64; 3],
    /// Exponent.
    pub exponent: f64,
}

impl Brdf for BlinnPhong {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if !above(wi, wo) {
            return [0.0; 3];
        }
        let lobe =
            (self.exponent + 8.0) / (8.0 * PI) * half(wi, wo)[2].max(0.0).powf(self.exponent);
        [0, 1, 2].map(|c| self.kd[c] / PI + self.ks[c] * lobe)
    }
    fn name(&self) -> String {
        format!("Blinn-Phong(n = {})", self.exponent)
    }
}

/// Cook-Torrance microfacet model with the GGX distribution, the separable
/// Smith shadowing term and Schlick's Fresnel, plus a Lambertian base.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct CookTorranceGgx {
    /// Diffuse albedo.
    pub kd: [f64; 3],
    /// Fresnel reflectance at normal incidence.
    pub f0: [f64; 3],
    /// GGX roughness `alpha`.
    pub alpha: f64,
}

/// The GGX normal distribution at `cos theta_h`, `a2 = alpha^2`.
pub(crate) fn ggx_d(cos_h: f64, a2: f64) -> f64 {
    let c2 = cos_h * cos_h;
    let t = c2 * (a2 - 1.0) + 1.0;
    a2 / (PI * t * t)
}

fn smith_g1(cos: f64, a2: f64) -> f64 {
    2.0 * cos / (cos + (a2 + (1.0 - a2) * cos * cos).sqrt())
}

/// The GGX Smith term over the cosine, `G1(cos) / cos`, in closed form:
/// finite and positive at grazing, where `G1 / cos` is 0 / 0.
pub(crate) fn smith_g1_over_cos(cos: f64, a2: f64) -> f64 {
    2.0 / (cos + (a2 + (1.0 - a2) * cos * cos).sqrt())
}

impl Brdf for CookTorranceGgx {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if !above(wi, wo) {
            return [0.0; 3];
        }
        let h = half(wi, wo);
        let a2 = self.alpha * self.alpha;
        let spec =
            ggx_d(h[2], a2) * smith_g1(wi[2], a2) * smith_g1(wo[2], a2) / (4.0 * wi[2] * wo[2]);
        let cos_d = dot(wi, h);
        [0, 1, 2].map(|c| self.kd[c] / PI + spec * schlick(self.f0[c], cos_d))
    }
    fn name(&self) -> String {
        format!("Cook-Torrance GGX(alpha = {})", self.alpha)
    }
}

/// Isotropic Ashikhmin-Shirley model (J. Graphics Tools 2000).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct AshikhminShirley {
    /// Diffuse reflectance.
    pub rd: [f64; 3],
    /// Specular reflectance at normal incidence.
    pub rs: [f64; 3],
    /// Phong-like exponent.
    pub exponent: f64,
}

impl Brdf for AshikhminShirley {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if !above(wi, wo) {
            return [0.0; 3];
        }
        let h = half(wi, wo);
        let kh = dot(wi, h);
        let n = self.exponent;
        let spec = (n + 1.0) / (8.0 * PI) * h[2].max(0.0).powf(n) / (kh * wi[2].max(wo[2]));
        let fi = 1.0 - (1.0 - 0.5 * wi[2]).powi(5);
        let fo = 1.0 - (1.0 - 0.5 * wo[2]).powi(5);
        [0, 1, 2].map(|c| {
            28.0 * self.rd[c] / (23.0 * PI) * (1.0 - self.rs[c]) * fi * fo
                + spec * schlick(self.rs[c], kh)
        })
    }
    fn name(&self) -> String {
        format!("Ashikhmin-Shirley(n = {})", self.exponent)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::geometry::from_spherical;

    /// Directional albedo by midpoint quadrature.
    fn albedo(b: &dyn Brdf, theta_v: f64) -> [f64; 3] {
        let wo = from_spherical(theta_v, 0.0);
        let (nt, np) = (400, 400);
        let mut acc = [0.0; 3];
        for i in 0..nt {
            let t = (i as f64 + 0.5) / nt as f64 * PI / 2.0;
            for j in 0..np {
                let p = (j as f64 + 0.5) / np as f64 * 2.0 * PI;
                let v = b.eval(from_spherical(t, p), wo);
                let w = t.cos() * t.sin() * (PI / 2.0 / nt as f64) * (2.0 * PI / np as f64);
                for c in 0..3 {
                    acc[c] += v[c] * w;
                }
            }
        }
        acc
    }

    #[test]
    fn lambert_albedo_is_exact() {
        let a = albedo(
            &Lambert {
                albedo: [0.2, 0.5, 0.9],
            },
            0.7,
        );
        for (x, y) in a.iter().zip([0.2, 0.5, 0.9]) {
            assert!((x - y).abs() < 1e-4);
        }
    }

    #[test]
    fn models_conserve_energy_and_are_reciprocal() {
        let models: Vec<Box<dyn Brdf>> = vec![
            Box::new(BlinnPhong {
                kd: [0.3; 3],
                ks: [0.5; 3],
                exponent: 50.0,
            }),
            Box::new(CookTorranceGgx {
                kd: [0.2; 3],
                f0: [0.04; 3],
                alpha: 0.3,
            }),
            Box::new(AshikhminShirley {
                rd: [0.3; 3],
                rs: [0.05; 3],
                exponent: 40.0,
            }),
        ];
        for m in &models {
            let a = albedo(m.as_ref(), 0.3);
            assert!(
                a.iter().all(|&x| x > 0.0 && x <= 1.0),
                "{}: {a:?}",
                m.name()
            );
            let (wi, wo) = (from_spherical(0.3, 0.2), from_spherical(1.1, 2.5));
            let (x, y) = (m.eval(wi, wo), m.eval(wo, wi));
            for c in 0..3 {
                assert!(
                    (x[c] - y[c]).abs() <= 1e-12 * x[c].abs().max(1.0),
                    "{}",
                    m.name()
                );
            }
        }
    }
}
