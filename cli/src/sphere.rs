//! A sphere lit by directional lights, seen from far away: the picture a
//! user checks first. Left half: the reference material; right half: the fit.

use brdf::{cross, normalize, Brdf, Vec3};

/// A directional light: unit direction towards the light, RGB irradiance.
pub struct Light {
    /// Towards the light.
    pub dir: Vec3,
    /// Irradiance at normal incidence.
    pub rgb: [f64; 3],
}

/// Three lights: key, fill and rim.
pub fn default_lights() -> Vec<Light> {
    vec![
        Light {
            dir: normalize([0.5, 0.6, 0.8]),
            rgb: [2.2; 3],
        },
        Light {
            dir: normalize([-0.7, 0.1, 0.6]),
            rgb: [0.7; 3],
        },
        Light {
            dir: normalize([0.1, -0.8, 0.3]),
            rgb: [0.5; 3],
        },
    ]
}

fn local(v: Vec3, n: Vec3, t: Vec3, b: Vec3) -> Vec3 {
    [brdf::dot(v, t), brdf::dot(v, b), brdf::dot(v, n)]
}

/// Linear radiance of a `size x size` image; pixels left of the centre use
/// `left`, the others `right`.
pub fn render(left: &dyn Brdf, right: &dyn Brdf, size: usize, lights: &[Light]) -> Vec<[f64; 3]> {
    use rayon::prelude::*;
    (0..size * size)
        .into_par_iter()
        .map(|idx| {
            let (px, py) = (idx % size, idx / size);
            let x = 2.0 * (px as f64 + 0.5) / size as f64 - 1.0;
            let y = 1.0 - 2.0 * (py as f64 + 0.5) / size as f64;
            let r2 = x * x + y * y;
            if r2 >= 1.0 {
                return [0.02; 3];
            }
            let n = [x, y, (1.0 - r2).sqrt()];
            let helper = if n[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 1.0, 0.0]
            };
            let t = normalize(cross(helper, n));
            let b = cross(n, t);
            let view = local([0.0, 0.0, 1.0], n, t, b);
            let material = if px < size / 2 { left } else { right };
            let mut out = [0.0; 3];
            for l in lights {
                let wl = local(l.dir, n, t, b);
                if wl[2] <= 0.0 || view[2] <= 0.0 {
                    continue;
                }
                let f = material.eval(view, wl);
                for c in 0..3 {
                    out[c] += f[c] * wl[2] * l.rgb[c];
                }
            }
            out
        })
        .collect()
}
