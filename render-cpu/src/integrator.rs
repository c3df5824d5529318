//! The integrators: direct lighting and path tracing, one code path.
//!
//! At every surface point: each directional and point light exactly (with a
//! shadow ray), one sample of each area light, and, with MIS on, one sample
//! of the environment; then one BRDF sample by the scene's sampler. The
//! BRDF sample collects the environment and emitters it reaches (weighted
//! by the balance heuristic when the same light was also sampled) and, in
//! the path tracer, continues the path. Direct lighting is the path tracer
//! stopped after the first BRDF sample.
//!
//! With MIS off the environment is reached only by BRDF sampling, so the
//! rational sampler's estimator uses its pdf-free weight alone; with MIS on
//! every light sample is weighed by the sampler's `mis_pdf` (for the
//! rational sampler a lookup in a grid built from the fitted map), and so
//! is every BRDF sample, so the weights sum to one.

use crate::description::{IntegratorKind, SamplePattern};
use crate::geometry::{Hit, Ray};
use crate::image::Image;
use crate::light::Light;
use crate::math::{
    add, add_scaled, cross, dot, length, max_component, mul, normalize, scale, sub, Frame, Rng,
    Vec3,
};
use crate::scene::{PreparedMaterial, Scene};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// Figures of a render.
#[derive(Debug, Clone, Copy, serde::Serialize)]
pub struct RenderStats {
    /// Wall-clock seconds of the render phase.
    pub seconds: f64,
    /// Samples per pixel.
    pub spp: usize,
    /// Pixels.
    pub pixels: usize,
    /// Mean over pixels of the variance of one sample, per channel (zero
    /// with one sample per pixel).
    pub sample_variance: [f64; 3],
}

/// An image and its figures.
#[derive(Debug, Clone)]
pub struct RenderOutput {
    /// Linear radiance.
    pub image: Image,
    /// Figures.
    pub stats: RenderStats,
}

/// Renders `scene`; `progress(rows_done, rows)` is called as rows finish.
pub fn render(scene: &Scene, progress: &(dyn Fn(usize, usize) + Sync)) -> RenderOutput {
    let start = Instant::now();
    let (w, h) = (scene.camera.width(), scene.camera.height());
    let spp = scene.integrator.spp;
    let done = AtomicUsize::new(0);
    let rows: Vec<Vec<([f64; 3], [f64; 3])>> = (0..h)
        .into_par_iter()
        .map(|y| {
            let row = (0..w).map(|x| pixel(scene, x, y, spp)).collect();
            progress(done.fetch_add(1, Ordering::Relaxed) + 1, h);
            row
        })
        .collect();
    let mut pixels = Vec::with_capacity(w * h);
    let mut var = [0.0; 3];
    for (mean, v) in rows.into_iter().flatten() {
        pixels.push(mean.map(|c| c as f32));
        for c in 0..3 {
            var[c] += v[c];
        }
    }
    RenderOutput {
        image: Image::new(w, h, pixels),
        stats: RenderStats {
            seconds: start.elapsed().as_secs_f64(),
            spp,
            pixels: w * h,
            sample_variance: var.map(|v| v / (w * h) as f64),
        },
    }
}

/// Mean and per-sample variance of one pixel (Welford).
fn pixel(scene: &Scene, x: usize, y: usize, spp: usize) -> ([f64; 3], [f64; 3]) {
    let index = (y * scene.camera.width() + x) as u64;
    let mut rng = match scene.integrator.pattern {
        SamplePattern::Independent => Rng::new(scene.integrator.seed, index),
        SamplePattern::Lattice => Rng::lattice(scene.integrator.seed, index, spp),
    };
    let mut mean = [0.0; 3];
    let mut m2 = [0.0; 3];
    for s in 0..spp {
        rng.start_sample(s);
        let [dx, dy] = if spp == 1 || !scene.integrator.jitter {
            [0.5, 0.5]
        } else {
            rng.pair()
        };
        let ray = scene.camera.ray(x as f64 + dx, y as f64 + dy);
        let l = radiance(scene, ray, &mut rng);
        for c in 0..3 {
            let d = l[c] - mean[c];
            mean[c] += d / (s + 1) as f64;
            m2[c] += d * (l[c] - mean[c]);
        }
    }
    let var = if spp > 1 {
        m2.map(|v| v / (spp - 1) as f64)
    } else {
        [0.0; 3]
    };
    (mean, var)
}

/// A point just off the surface on the side of `normal`.
fn offset(p: Vec3, normal: Vec3) -> Vec3 {
    let s = 1e-7 * (1.0 + p.iter().fold(0.0f64, |m, v| m.max(v.abs())));
    add_scaled(p, normal, s)
}

/// Balance heuristic weight of a strategy with density `a` against `b`.
fn balance(a: f64, b: f64) -> f64 {
    if a + b > 0.0 && a.is_finite() {
        a / (a + b)
    } else if a.is_infinite() {
        1.0
    } else {
        0.0
    }
}

/// Radiance along a camera ray.
pub fn radiance(scene: &Scene, camera_ray: Ray, rng: &mut Rng) -> [f64; 3] {
    let max_depth = match scene.integrator.kind {
        IntegratorKind::Direct => 1,
        IntegratorKind::Path => scene.integrator.max_depth,
    };
    let mis = scene.integrator.mis;
    let mut l = [0.0; 3];
    let mut beta = [1.0; 3];
    let mut ray = camera_ray;
    // Density of the BRDF sample that made `ray`, for MIS weights.
    let mut previous: Option<f64> = None;
    for depth in 0..=max_depth {
        let Some((hit, object)) = scene.intersect(&ray) else {
            if let Some(env) = &scene.environment {
                let w = match previous {
                    Some(p) if mis => balance(p, env.pdf(ray.dir)),
                    _ => 1.0,
                };
                l = add(l, scale(mul(beta, env.radiance(ray.dir)), w));
            }
            break;
        };
        let obj = &scene.objects[object];
        if let Some(le) = obj.emission {
            if dot(ray.dir, hit.geometric_normal) < 0.0 {
                let w = match previous {
                    None => 1.0,
                    // Area lights are always light-sampled: BRDF samples
                    // count only under MIS.
                    Some(p) if mis => {
                        let area = obj.shape.area();
                        let cos = -dot(ray.dir, hit.geometric_normal);
                        let light_pdf = hit.t * hit.t / (area * cos);
                        balance(p, light_pdf)
                    }
                    Some(_) => 0.0,
                };
                l = add(l, scale(mul(beta, le), w));
            }
            break;
        }
        if depth == max_depth {
            break;
        }
        let Some(mi) = obj.material else { break };
        let material = &scene.materials[mi];
        // Two-sided surfaces: face the normals towards the viewer.
        let (ng, ns) = if dot(ray.dir, hit.geometric_normal) > 0.0 {
            (
                scale(hit.geometric_normal, -1.0),
                scale(hit.shading_normal, -1.0),
            )
        } else {
            (hit.geometric_normal, hit.shading_normal)
        };
        let frame = Frame::from_normal(ns);
        let wo = frame.to_local(scale(ray.dir, -1.0));
        if wo[2] <= 0.0 {
            break;
        }
        let shading = Shading {
            hit: &hit,
            ng,
            frame,
            wo,
            material,
        };
        l = add(l, mul(beta, direct(scene, &shading, rng)));

        let Some(s) = material.sampler.sample(wo, rng.pair()) else {
            break;
        };
        let f = material.eval(s.wi, wo);
        let cos = s.wi[2];
        let wi_world = frame.to_world(s.wi);
        if cos <= 0.0 || dot(wi_world, ng) <= 0.0 || !(s.inv_pdf.is_finite() && s.inv_pdf > 0.0) {
            break;
        }
        beta = mul(beta, f.map(|v| v * cos * s.inv_pdf));
        // The MIS weight of this direction, from the same density the light
        // samples are weighed with (the sampler's `mis_pdf`).
        previous = Some(material.sampler.mis_pdf_of_sample(wo, &s));
        ray = Ray::new(offset(hit.point, ng), normalize(wi_world));
        if depth >= 3 {
            let q = max_component(beta).min(0.95);
            if q <= 0.0 || rng.uniform() >= q {
                break;
            }
            beta = scale(beta, 1.0 / q);
        }
    }
    l
}

struct Shading<'a> {
    hit: &'a Hit,
    ng: Vec3,
    frame: Frame,
    wo: Vec3,
    material: &'a PreparedMaterial,
}

impl Shading<'_> {
    /// The local direction of `wi_world`, `None` below either the
    /// shading or the geometric surface.
    fn above(&self, wi_world: Vec3) -> Option<Vec3> {
        let wi = self.frame.to_local(wi_world);
        (wi[2] > 0.0 && dot(wi_world, self.ng) > 0.0).then_some(wi)
    }

    /// `f cos` towards the world direction `wi_world`, zero below either
    /// the shading or the geometric surface.
    fn reflect(&self, wi_world: Vec3) -> Option<([f64; 3], Vec3)> {
        let wi = self.above(wi_world)?;
        let f = self.material.eval(wi, self.wo);
        Some((f.map(|v| v * wi[2]), wi))
    }

    fn shadow_ray(&self, dir: Vec3, distance: f64) -> Ray {
        let origin = offset(self.hit.point, self.ng);
        Ray {
            origin,
            dir,
            t_min: 0.0,
            t_max: distance,
        }
    }
}

/// Lights of a shading point evaluated together: many directional and
/// point lights (the 256 of the frame-rate scene) go through the BRDF's
/// batched path in blocks of [`LightBatch::BLOCK`].
struct LightBatch {
    wi: [Vec3; LightBatch::BLOCK],
    power: [[f64; 3]; LightBatch::BLOCK],
    factor: [f64; LightBatch::BLOCK],
    len: usize,
}

impl LightBatch {
    const BLOCK: usize = 64;

    fn new() -> Self {
        Self {
            wi: [[0.0; 3]; Self::BLOCK],
            power: [[0.0; 3]; Self::BLOCK],
            factor: [0.0; Self::BLOCK],
            len: 0,
        }
    }

    /// A visible light at local direction `wi`: it adds
    /// `f cos * power * factor` to `l` (when the block is full or flushed).
    fn push(&mut self, s: &Shading, wi: Vec3, power: [f64; 3], factor: f64, l: &mut [f64; 3]) {
        self.wi[self.len] = wi;
        self.power[self.len] = power;
        self.factor[self.len] = factor;
        self.len += 1;
        if self.len == Self::BLOCK {
            self.flush(s, l);
        }
    }

    fn flush(&mut self, s: &Shading, l: &mut [f64; 3]) {
        let n = self.len;
        let mut f = [[0.0; 3]; Self::BLOCK];
        s.material.eval_incident(&self.wi[..n], s.wo, &mut f[..n]);
        for i in 0..n {
            let fc = f[i].map(|v| v * self.wi[i][2]);
            *l = add(*l, scale(mul(fc, self.power[i]), self.factor[i]));
        }
        self.len = 0;
    }
}

/// Light sampling at a surface point.
fn direct(scene: &Scene, s: &Shading, rng: &mut Rng) -> [f64; 3] {
    let mis = scene.integrator.mis;
    let shadows = scene.integrator.shadows;
    let mut l = [0.0; 3];
    let mut batch = LightBatch::new();
    for light in &scene.lights {
        match light {
            Light::Directional {
                direction,
                irradiance,
            } => {
                if let Some(wi) = s.above(*direction) {
                    if !shadows || scene.unoccluded(&s.shadow_ray(*direction, f64::INFINITY)) {
                        batch.push(s, wi, *irradiance, 1.0, &mut l);
                    }
                }
            }
            Light::Point {
                position,
                intensity,
            } => {
                let d = sub(*position, s.hit.point);
                let dist = length(d);
                let dir = scale(d, 1.0 / dist);
                if let Some(wi) = s.above(dir) {
                    if !shadows || scene.unoccluded(&s.shadow_ray(dir, dist * (1.0 - 1e-9))) {
                        batch.push(s, wi, *intensity, 1.0 / (dist * dist), &mut l);
                    }
                }
            }
            Light::Area {
                corner,
                u,
                v,
                radiance,
                ..
            } => {
                let [a, b] = rng.pair();
                let y = add(*corner, add(scale(*u, a), scale(*v, b)));
                let n = cross(*u, *v);
                let area = length(n);
                let d = sub(y, s.hit.point);
                let dist = length(d);
                let dir = scale(d, 1.0 / dist);
                let cos_l = -dot(dir, n) / area;
                if cos_l <= 0.0 {
                    continue;
                }
                if let Some((fc, wi)) = s.reflect(dir) {
                    if scene.unoccluded(&s.shadow_ray(dir, dist * (1.0 - 1e-9))) {
                        let light_pdf = dist * dist / (area * cos_l);
                        let w = if mis {
                            balance(light_pdf, s.material.sampler.mis_pdf(s.wo, wi))
                        } else {
                            1.0
                        };
                        l = add(l, scale(mul(fc, *radiance), w / light_pdf));
                    }
                }
            }
        }
    }
    batch.flush(s, &mut l);
    if mis {
        if let Some(env) = &scene.environment {
            let (dir, pdf) = env.sample(rng.pair());
            if let Some((fc, wi)) = s.reflect(dir) {
                if pdf > 0.0 && scene.unoccluded(&s.shadow_ray(dir, f64::INFINITY)) {
                    let w = balance(pdf, s.material.sampler.mis_pdf(s.wo, wi));
                    l = add(l, scale(mul(fc, env.radiance(dir)), w / pdf));
                }
            }
        }
    }
    l
}
