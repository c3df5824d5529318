//! Lights: directional, point, area (emitting quads) and the environment
//! (uniform, a procedural sky or a latitude-longitude HDR image).
//!
//! The environment's up axis is +y; an image's column `u` maps to the
//! azimuth `atan2(x, -z)` (u = 0.5 looks down -z) and its row `v` to the
//! angle from +y.

use crate::image::Image;
use crate::math::{normalize, Vec3};
use std::f64::consts::PI;

/// A light that is not part of the geometry, or an emitting quad.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Light {
    /// Parallel light: unit direction towards the light, irradiance on a
    /// surface facing it.
    Directional {
        /// Towards the light.
        direction: Vec3,
        /// RGB irradiance.
        irradiance: [f64; 3],
    },
    /// Isotropic point light.
    Point {
        /// Position.
        position: Vec3,
        /// RGB intensity (W/sr).
        intensity: [f64; 3],
    },
    /// A one-sided emitting parallelogram `corner + a u + b v`, emitting
    /// towards `u x v`; it is also an object of the scene.
    Area {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
        /// RGB radiance.
        radiance: [f64; 3],
        /// Index of its object.
        object: usize,
    },
}

/// Uniform-sphere density.
const UNIFORM_SPHERE_PDF: f64 = 1.0 / (4.0 * PI);

/// Radiance arriving from infinitely far away.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Environment {
    /// The same radiance from every direction (the white furnace).
    Uniform([f64; 3]),
    /// Sky above the horizon (`zenith` at +y blending to `horizon`), a
    /// uniform `ground` below.
    Sky {
        /// Radiance straight up.
        zenith: [f64; 3],
        /// Radiance at the horizon.
        horizon: [f64; 3],
        /// Radiance from below.
        ground: [f64; 3],
    },
    /// A latitude-longitude image, importance-sampled by its luminance.
    Image(Box<EnvironmentMap>),
}

impl Environment {
    /// Radiance arriving along `-dir` (seen looking along `dir`).
    pub fn radiance(&self, dir: Vec3) -> [f64; 3] {
        match self {
            Environment::Uniform(l) => *l,
            Environment::Sky {
                zenith,
                horizon,
                ground,
            } => {
                if dir[1] <= 0.0 {
                    *ground
                } else {
                    let t = dir[1].sqrt();
                    [0, 1, 2].map(|c| horizon[c] + (zenith[c] - horizon[c]) * t)
                }
            }
            Environment::Image(map) => map.radiance(dir),
        }
    }

    /// A direction drawn by the environment's own density and that density.
    pub fn sample(&self, u: [f64; 2]) -> (Vec3, f64) {
        match self {
            Environment::Image(map) => map.sample(u),
            _ => {
                let z = 1.0 - 2.0 * u[0];
                let r = (1.0 - z * z).max(0.0).sqrt();
                let phi = 2.0 * PI * u[1];
                ([r * phi.cos(), z, r * phi.sin()], UNIFORM_SPHERE_PDF)
            }
        }
    }

    /// The density of [`Environment::sample`] per steradian.
    pub fn pdf(&self, dir: Vec3) -> f64 {
        match self {
            Environment::Image(map) => map.pdf(dir),
            _ => UNIFORM_SPHERE_PDF,
        }
    }
}

/// A latitude-longitude environment image with a piecewise-constant 2-D
/// distribution proportional to luminance times `sin(theta)`.
#[derive(Debug, Clone)]
pub struct EnvironmentMap {
    image: Image,
    scale: f64,
    /// Cumulative row masses, `height + 1` entries from 0 to 1.
    marginal: Vec<f64>,
    /// Per row, cumulative column masses, `width + 1` entries from 0 to 1.
    conditional: Vec<f64>,
    /// Probability of each pixel.
    mass: Vec<f64>,
}

fn cumulate(w: &[f64]) -> Vec<f64> {
    let total: f64 = w.iter().sum();
    let mut out = Vec::with_capacity(w.len() + 1);
    out.push(0.0);
    let mut acc = 0.0;
    for &x in w {
        acc += x;
        out.push(if total > 0.0 { acc / total } else { 0.0 });
    }
    if let Some(last) = out.last_mut() {
        *last = 1.0;
    }
    out
}

/// Index `i` with `cdf[i] <= u < cdf[i+1]` and the fraction inside.
fn invert(cdf: &[f64], u: f64) -> (usize, f64) {
    let n = cdf.len() - 1;
    let i = cdf
        .partition_point(|&c| c <= u)
        .saturating_sub(1)
        .min(n - 1);
    let w = cdf[i + 1] - cdf[i];
    let f = if w > 0.0 { (u - cdf[i]) / w } else { 0.5 };
    (i, f.clamp(0.0, 1.0))
}

impl EnvironmentMap {
    /// A map from a linear image, radiance multiplied by `scale`.
    pub fn new(image: Image, scale: f64) -> Self {
        let (w, h) = (image.width, image.height);
        let mut mass = vec![0.0; w * h];
        let mut rows = vec![0.0; h];
        for y in 0..h {
            let sin = (PI * (y as f64 + 0.5) / h as f64).sin();
            for x in 0..w {
                // A floor keeps every direction reachable (needed for MIS).
                let m =
                    (cdf::luminance(image.pixels[y * w + x].map(f64::from)).max(0.0) + 1e-6) * sin;
                mass[y * w + x] = m;
                rows[y] += m;
            }
        }
        let total: f64 = rows.iter().sum();
        let marginal = cumulate(&rows);
        let mut conditional = Vec::with_capacity(h * (w + 1));
        for y in 0..h {
            conditional.extend(cumulate(&mass[y * w..(y + 1) * w]));
        }
        mass.iter_mut().for_each(|m| *m /= total);
        Self {
            image,
            scale,
            marginal,
            conditional,
            mass,
        }
    }

    fn pixel_of(&self, dir: Vec3) -> (usize, usize, f64) {
        let d = normalize(dir);
        let theta = d[1].clamp(-1.0, 1.0).acos();
        let u = 0.5 + d[0].atan2(-d[2]) / (2.0 * PI);
        let (w, h) = (self.image.width, self.image.height);
        let x = ((u * w as f64) as usize).min(w - 1);
        let y = ((theta / PI * h as f64) as usize).min(h - 1);
        (x, y, theta)
    }

    fn radiance(&self, dir: Vec3) -> [f64; 3] {
        let (x, y, _) = self.pixel_of(dir);
        self.image.pixels[y * self.image.width + x].map(|v| f64::from(v) * self.scale)
    }

    fn sample(&self, u: [f64; 2]) -> (Vec3, f64) {
        let (w, h) = (self.image.width, self.image.height);
        let (y, fy) = invert(&self.marginal, u[0]);
        let (x, fx) = invert(&self.conditional[y * (w + 1)..(y + 1) * (w + 1)], u[1]);
        let theta = PI * (y as f64 + fy) / h as f64;
        let phi = 2.0 * PI * ((x as f64 + fx) / w as f64 - 0.5);
        let (st, ct) = theta.sin_cos();
        let dir = [st * phi.sin(), ct, -st * phi.cos()];
        (dir, self.pdf_at(x, y, theta))
    }

    fn pdf_at(&self, x: usize, y: usize, theta: f64) -> f64 {
        let (w, h) = (self.image.width, self.image.height);
        let sin = theta.sin();
        if sin <= 0.0 {
            return 0.0;
        }
        // Pixel mass over its solid-angle measure (2 pi^2 / (w h)) sin(theta).
        self.mass[y * w + x] * (w * h) as f64 / (2.0 * PI * PI * sin)
    }

    fn pdf(&self, dir: Vec3) -> f64 {
        let (x, y, theta) = self.pixel_of(dir);
        self.pdf_at(x, y, theta)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::math::Rng;

    #[test]
    fn image_sampling_density_integrates_to_one_and_matches_pdf() {
        let (w, h) = (16, 8);
        let pixels = (0..w * h)
            .map(|i| {
                let v = 0.1 + (i % 7) as f32;
                [v, 0.5 * v, 0.2]
            })
            .collect();
        let map = EnvironmentMap::new(Image::new(w, h, pixels), 1.0);
        let env = Environment::Image(Box::new(map));
        // E[1/pdf] over the sampling density is the sphere's area.
        let mut rng = Rng::new(1, 2);
        let n = 200_000;
        let mut sum = 0.0;
        for _ in 0..n {
            let (d, pdf) = env.sample(rng.pair());
            assert!(
                (pdf - env.pdf(d)).abs() < 1e-6 * pdf.max(1.0),
                "{pdf} vs {}",
                env.pdf(d)
            );
            sum += 1.0 / pdf;
        }
        let area = sum / n as f64;
        assert!((area - 4.0 * PI).abs() < 0.05 * 4.0 * PI, "{area}");
    }
}
