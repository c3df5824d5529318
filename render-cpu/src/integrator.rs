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
    let mut rng = pixel_rng(scene, x, y, spp);
    let mut mean = [0.0; 3];
    let mut m2 = [0.0; 3];
    for s in 0..spp {
        let ray = camera_ray(scene, x, y, spp, s, &mut rng);
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

/// The random stream of pixel `(x, y)` with `spp` samples.
pub(crate) fn pixel_rng(scene: &Scene, x: usize, y: usize, spp: usize) -> Rng {
    let index = (y * scene.camera.width() + x) as u64;
    match scene.integrator.pattern {
        SamplePattern::Independent => Rng::new(scene.integrator.seed, index),
        SamplePattern::Lattice => Rng::lattice(scene.integrator.seed, index, spp),
    }
}

/// Starts sample `s` of pixel `(x, y)` and returns its camera ray
/// (jittered within the pixel when the scene asks for it).
pub(crate) fn camera_ray(
    scene: &Scene,
    x: usize,
    y: usize,
    spp: usize,
    s: usize,
    rng: &mut Rng,
) -> Ray {
    rng.start_sample(s);
    let [dx, dy] = if spp == 1 || !scene.integrator.jitter {
        [0.5, 0.5]
    } else {
        rng.pair()
    };
    scene.camera.ray(x as f64 + dx, y as f64 + dy)
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

/// Where a ray ends up, for [`radiance`] and [`crate::linear`].
pub(crate) enum Reached<'a> {
    /// The path ends there with this radiance (the environment, or an
    /// emitter seen from its front), MIS weight included.
    Light([f64; 3]),
    /// The path ends there with nothing (the back of an emitter, an
    /// object without a material).
    Dark,
    /// A reflecting surface.
    Surface(Hit, usize, &'a PreparedMaterial),
}

/// What `ray` reaches; `previous` is the density of the BRDF sample that
/// made it (`None` for a camera ray), for MIS against light sampling.
pub(crate) fn reach<'a>(scene: &'a Scene, ray: &Ray, previous: Option<f64>) -> Reached<'a> {
    let mis = scene.integrator.mis;
    let Some((hit, object)) = scene.intersect(ray) else {
        let Some(env) = &scene.environment else {
            return Reached::Dark;
        };
        let w = match previous {
            Some(p) if mis => balance(p, env.pdf(ray.dir)),
            _ => 1.0,
        };
        return Reached::Light(scale(env.radiance(ray.dir), w));
    };
    let obj = &scene.objects[object];
    if let Some(le) = obj.emission {
        let facing = dot(ray.dir, hit.geometric_normal) < 0.0;
        if !facing {
            return Reached::Dark;
        }
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
        return Reached::Light(scale(le, w));
    }
    match obj.material {
        Some(mi) => Reached::Surface(hit, mi, &scene.materials[mi]),
        None => Reached::Dark,
    }
}

/// The shading point of `ray` at `hit` (normals faced towards the viewer:
/// surfaces are two-sided); `None` when the view is below the shading
/// normal.
pub(crate) fn shading<'a>(
    ray: &Ray,
    hit: &'a Hit,
    material: &'a PreparedMaterial,
) -> Option<Shading<'a>> {
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
    (wo[2] > 0.0).then_some(Shading {
        hit,
        ng,
        frame,
        wo,
        material,
    })
}

/// A BRDF sample at a shading point: the local incident direction, the
/// factor `cos / pdf` its BRDF value is multiplied by, its MIS density
/// and the ray that continues the path.
pub(crate) struct BrdfSample {
    pub(crate) wi: Vec3,
    pub(crate) cos_over_pdf: f64,
    pub(crate) mis_pdf: f64,
    pub(crate) ray: Ray,
}

/// One BRDF sample by the material's sampler; `None` when the sampler
/// gives none or a direction below either surface or without a density.
pub(crate) fn sample_brdf(s: &Shading, rng: &mut Rng) -> Option<BrdfSample> {
    let sample = s.material.sampler.sample(s.wo, rng.pair())?;
    let cos = sample.wi[2];
    let wi_world = s.frame.to_world(sample.wi);
    if cos <= 0.0
        || dot(wi_world, s.ng) <= 0.0
        || !(sample.inv_pdf.is_finite() && sample.inv_pdf > 0.0)
    {
        return None;
    }
    Some(BrdfSample {
        wi: sample.wi,
        cos_over_pdf: cos * sample.inv_pdf,
        // The MIS weight of this direction, from the same density the light
        // samples are weighed with (the sampler's `mis_pdf`).
        mis_pdf: s.material.sampler.mis_pdf_of_sample(s.wo, &sample),
        ray: Ray::new(offset(s.hit.point, s.ng), normalize(wi_world)),
    })
}

/// Radiance along a camera ray.
pub fn radiance(scene: &Scene, camera_ray: Ray, rng: &mut Rng) -> [f64; 3] {
    let max_depth = match scene.integrator.kind {
        IntegratorKind::Direct => 1,
        IntegratorKind::Path => scene.integrator.max_depth,
    };
    let mut l = [0.0; 3];
    let mut beta = [1.0; 3];
    let mut ray = camera_ray;
    // Density of the BRDF sample that made `ray`, for MIS weights.
    let mut previous: Option<f64> = None;
    for depth in 0..=max_depth {
        let (hit, material) = match reach(scene, &ray, previous) {
            Reached::Light(le) => {
                l = add(l, mul(beta, le));
                break;
            }
            Reached::Dark => break,
            Reached::Surface(hit, _, material) => (hit, material),
        };
        if depth == max_depth {
            break;
        }
        let Some(shading) = shading(&ray, &hit, material) else {
            break;
        };
        let mut lights = LightBatch::new(&shading);
        light_samples(scene, &shading, rng, &mut lights);
        l = add(l, mul(beta, lights.finish()));

        let Some(s) = sample_brdf(&shading, rng) else {
            break;
        };
        let f = material.eval(s.wi, shading.wo);
        beta = mul(beta, f.map(|v| v * s.cos_over_pdf));
        previous = Some(s.mis_pdf);
        ray = s.ray;
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

/// A shading point: the hit, its normals faced towards the viewer, the
/// local frame and view direction, and the material.
pub(crate) struct Shading<'a> {
    pub(crate) hit: &'a Hit,
    pub(crate) ng: Vec3,
    pub(crate) frame: Frame,
    pub(crate) wo: Vec3,
    pub(crate) material: &'a PreparedMaterial,
}

impl Shading<'_> {
    /// The local direction of `wi_world`, `None` below either the
    /// shading or the geometric surface.
    fn above(&self, wi_world: Vec3) -> Option<Vec3> {
        let wi = self.frame.to_local(wi_world);
        (wi[2] > 0.0 && dot(wi_world, self.ng) > 0.0).then_some(wi)
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

/// How a BRDF value is evaluated: in a batch with the other lights of the
/// shading point, or alone. The f32 form of a fit can round differently on
/// the two paths, so a replayed render keeps each sample's.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Evaluation {
    /// With the other directional and point lights (`eval_incident`).
    Batched,
    /// On its own (`eval`): area lights, the environment, BRDF samples.
    Single,
}

/// Where the light samples of a shading point go: each adds
/// `f(wi, wo) * weight` to the pixel.
pub(crate) trait LightSink {
    /// A light sample at local direction `wi` (`weight` holds the cosine,
    /// the light and the MIS weight over the density).
    fn push(&mut self, wi: Vec3, weight: [f64; 3], evaluation: Evaluation);
}

/// Light samples of a shading point evaluated together: many directional
/// and point lights (the 256 of the frame-rate scene) go through the BRDF's
/// batched path in blocks of [`LightBatch::BLOCK`].
struct LightBatch<'a> {
    shading: &'a Shading<'a>,
    wi: [Vec3; LightBatch::BLOCK],
    weight: [[f64; 3]; LightBatch::BLOCK],
    len: usize,
    l: [f64; 3],
}

impl<'a> LightBatch<'a> {
    const BLOCK: usize = 64;

    fn new(shading: &'a Shading<'a>) -> Self {
        Self {
            shading,
            wi: [[0.0; 3]; Self::BLOCK],
            weight: [[0.0; 3]; Self::BLOCK],
            len: 0,
            l: [0.0; 3],
        }
    }

    fn flush(&mut self) {
        let n = self.len;
        let mut f = [[0.0; 3]; Self::BLOCK];
        let s = self.shading;
        s.material.eval_incident(&self.wi[..n], s.wo, &mut f[..n]);
        for i in 0..n {
            self.l = add(self.l, mul(f[i], self.weight[i]));
        }
        self.len = 0;
    }

    /// The sum of the samples' contributions.
    fn finish(mut self) -> [f64; 3] {
        self.flush();
        self.l
    }
}

impl LightSink for LightBatch<'_> {
    fn push(&mut self, wi: Vec3, weight: [f64; 3], evaluation: Evaluation) {
        if evaluation == Evaluation::Single {
            let f = self.shading.material.eval(wi, self.shading.wo);
            self.l = add(self.l, mul(f, weight));
            return;
        }
        self.wi[self.len] = wi;
        self.weight[self.len] = weight;
        self.len += 1;
        if self.len == Self::BLOCK {
            self.flush();
        }
    }
}

/// Light sampling at a surface point: each directional and point light
/// exactly, one sample of each area light and, with MIS, one of the
/// environment, each unoccluded one pushed to `sink`.
pub(crate) fn light_samples(scene: &Scene, s: &Shading, rng: &mut Rng, sink: &mut impl LightSink) {
    let mis = scene.integrator.mis;
    let shadows = scene.integrator.shadows;
    for light in &scene.lights {
        match light {
            Light::Directional {
                direction,
                irradiance,
            } => {
                if let Some(wi) = s.above(*direction) {
                    if !shadows || scene.unoccluded(&s.shadow_ray(*direction, f64::INFINITY)) {
                        sink.push(wi, scale(*irradiance, wi[2]), Evaluation::Batched);
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
                        sink.push(
                            wi,
                            scale(*intensity, wi[2] / (dist * dist)),
                            Evaluation::Batched,
                        );
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
                if let Some(wi) = s.above(dir) {
                    if scene.unoccluded(&s.shadow_ray(dir, dist * (1.0 - 1e-9))) {
                        let light_pdf = dist * dist / (area * cos_l);
                        let w = if mis {
                            balance(light_pdf, s.material.sampler.mis_pdf(s.wo, wi))
                        } else {
                            1.0
                        };
                        sink.push(
                            wi,
                            scale(*radiance, wi[2] * w / light_pdf),
                            Evaluation::Single,
                        );
                    }
                }
            }
        }
    }
    if mis {
        if let Some(env) = &scene.environment {
            let (dir, pdf) = env.sample(rng.pair());
            if let Some(wi) = s.above(dir) {
                if pdf > 0.0 && scene.unoccluded(&s.shadow_ray(dir, f64::INFINITY)) {
                    let w = balance(pdf, s.material.sampler.mis_pdf(s.wo, wi));
                    sink.push(
                        wi,
                        scale(env.radiance(dir), wi[2] * w / pdf),
                        Evaluation::Single,
                    );
                }
            }
        }
    }
}
