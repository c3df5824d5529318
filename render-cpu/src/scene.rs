//! A prepared scene: geometry, lights and materials ready to render.

use crate::camera::Camera;
use crate::description::{IntegratorKind, SamplerKind};
use crate::geometry::{Hit, Ray, Shape};
use crate::light::{Environment, Light};
use brdf::Brdf;
use cdf::Sampler;
use std::sync::Arc;

/// A rational fit as the renderer evaluates it: the compact f32 form (as a
/// GPU would; about twice the speed of the batched f64 path) when it agrees
/// with the f64 path within [`F32_TOLERANCE`] on a dense grid of direction
/// pairs, else the f64 path ([`brdf::BatchedFit`]). The two agree to the conditioning of the
/// evaluation, and a fit whose denominator nearly cancels (at a sharp peak,
/// or between samples) loses every digit in f32: an ilm_solo_m_68 fit read
/// 1,512 in f32 against 1,809 in f64 at its highlight, and infinity beside
/// it. Beyond an elevation cut of
/// the fit's reduction, directions are moved to the cut, by the rule every
/// evaluation path shares (`brdf::clamp_elevation`): outside its samples
/// nothing constrains a fit, and fits were seen to reach 1e4 times their
/// peak there. Fits of the whole hemisphere have no cut.
#[derive(Debug, Clone)]
pub struct FitInDomain {
    batched: brdf::BatchedFit,
    compact: brdf::CompactBrdf,
    f32_error: f64,
    uses_f32: bool,
}

/// Largest relative difference of the f32 path from the f64 one (over
/// values above a thousandth of the fit's largest) with which the renderer
/// evaluates a fit in f32; about a fortieth of a CIEDE2000 unit at mid grey
/// (4% of luminance is about one unit).
pub const F32_TOLERANCE: f64 = 1e-3;

impl FitInDomain {
    /// Wraps a fit, and compares its f32 form with f64 on a grid of
    /// `24 x 24 x 12` half-difference cells.
    pub fn new(fit: brdf::FittedBrdf) -> Self {
        let compact = brdf::CompactBrdf::from_fitted(&fit);
        let f32_error = f32_error(&fit, &compact);
        Self {
            batched: brdf::BatchedFit::new(fit),
            compact,
            f32_error,
            uses_f32: f32_error <= F32_TOLERANCE,
        }
    }

    /// [`FitInDomain::new`] evaluated in f32 or in f64 as `uses_f32` says,
    /// whatever its own comparison: the values another evaluation of the
    /// same functions takes where the two agree (`crate::fidelity`'s cut
    /// choice reuses them).
    pub(crate) fn on_path(fit: brdf::FittedBrdf, uses_f32: bool) -> Self {
        Self {
            uses_f32,
            ..Self::new(fit)
        }
    }

    /// Largest relative difference of the f32 form from the f64 fit on the
    /// grid (over values above a thousandth of the largest; infinite where
    /// the f32 form is not finite).
    pub fn f32_error(&self) -> f64 {
        self.f32_error
    }

    /// Whether the renderer evaluates the compact f32 form (it agrees with
    /// the f64 fit within [`F32_TOLERANCE`]); else the f64 fit.
    pub fn uses_f32(&self) -> bool {
        self.uses_f32
    }

    /// The fit.
    pub fn fit(&self) -> &brdf::FittedBrdf {
        self.batched.fit()
    }

    /// The f32 form used for evaluation.
    pub fn compact(&self) -> &brdf::CompactBrdf {
        &self.compact
    }

    /// The elevation cut in radians (`pi / 2` without one).
    pub fn max_elevation(&self) -> f64 {
        f64::from(self.compact.max_elevation)
    }
}

/// See [`FitInDomain::f32_error`].
fn f32_error(fit: &brdf::FittedBrdf, compact: &brdf::CompactBrdf) -> f64 {
    use rayon::prelude::*;
    let pairs = brdf::HalfDiff::cell_centres([24, 24, 12]);
    let values: Vec<([f64; 3], [f32; 3])> = pairs
        .par_iter()
        .map(|&(wi, wo)| {
            let f32_value = compact.eval(wi.map(|v| v as f32), wo.map(|v| v as f32));
            (fit.eval(wi, wo), f32_value)
        })
        .collect();
    let largest = values
        .iter()
        .flat_map(|(a, _)| a.iter())
        .fold(0.0_f64, |m, &v| m.max(v));
    let floor = 1e-3 * largest;
    let mut worst = 0.0_f64;
    for (a, b) in &values {
        for c in 0..3 {
            let b = f64::from(b[c]);
            if !b.is_finite() || !a[c].is_finite() {
                return f64::INFINITY;
            }
            if a[c].abs() > floor {
                worst = worst.max((b - a[c]).abs() / a[c].abs());
            }
        }
    }
    worst
}

impl Brdf for FitInDomain {
    fn eval(&self, wi: brdf::Vec3, wo: brdf::Vec3) -> [f64; 3] {
        if !self.uses_f32() {
            return self.fit().eval(wi, wo);
        }
        self.compact
            .eval(wi.map(|v| v as f32), wo.map(|v| v as f32))
            .map(f64::from)
    }

    /// The batched path of the compact form, in blocks on the stack, or of
    /// the f64 fit ([`brdf::BatchedFit`]).
    fn eval_incident(&self, wi: &[brdf::Vec3], wo: brdf::Vec3, out: &mut [[f64; 3]]) {
        assert_eq!(
            wi.len(),
            out.len(),
            "eval_incident: one output per direction"
        );
        const BLOCK: usize = 64;
        if !self.uses_f32() {
            let wo = [wo; BLOCK];
            for (w, o) in wi.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
                self.batched.eval_batch(w, &wo[..w.len()], o);
            }
            return;
        }
        let wo32 = [wo.map(|v| v as f32); BLOCK];
        let (mut a, mut r) = ([[0.0f32; 3]; BLOCK], [[0.0f32; 3]; BLOCK]);
        for (w, o) in wi.chunks(BLOCK).zip(out.chunks_mut(BLOCK)) {
            let n = w.len();
            for (dst, src) in a.iter_mut().zip(w) {
                *dst = src.map(|v| v as f32);
            }
            self.compact.eval_batch(&a[..n], &wo32[..n], &mut r[..n]);
            for (dst, src) in o.iter_mut().zip(&r) {
                *dst = src.map(f64::from);
            }
        }
    }

    fn name(&self) -> String {
        self.fit().name()
    }
}

/// A material as the renderer uses it: the BRDF and its sampler.
#[derive(Clone)]
pub struct PreparedMaterial {
    /// Name in the scene.
    pub name: String,
    /// What it is (for logs).
    pub description: String,
    /// The reflectance.
    pub brdf: Arc<dyn Brdf>,
    /// Bytes of the reflectance representation.
    pub brdf_bytes: usize,
    /// The BRDF sampler (cosine when the scene asks for it or never samples).
    pub sampler: Arc<dyn Sampler>,
    /// Bytes the sampler stores.
    pub sampler_bytes: usize,
    /// The reflectance in a form other evaluators (shaders) can reproduce,
    /// when it has one: Lambert and rational fits.
    pub closed_form: Option<ClosedForm>,
}

/// A material's reflectance in closed form.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum ClosedForm {
    /// `albedo / pi`.
    Lambert {
        /// RGB albedo.
        albedo: [f64; 3],
    },
    /// A rational fit, evaluated inside its sampled elevations.
    Fit(Arc<FitInDomain>),
}

impl PreparedMaterial {
    /// The BRDF with negative values set to zero: measured tables can
    /// interpolate to small negative values, which no surface reflects.
    pub fn eval(&self, wi: brdf::Vec3, wo: brdf::Vec3) -> [f64; 3] {
        self.brdf.eval(wi, wo).map(|v| v.max(0.0))
    }

    /// [`PreparedMaterial::eval`] at many incident directions and one
    /// outgoing direction (the BRDF's batched path where it has one).
    pub fn eval_incident(&self, wi: &[brdf::Vec3], wo: brdf::Vec3, out: &mut [[f64; 3]]) {
        self.brdf.eval_incident(wi, wo, out);
        for o in out.iter_mut() {
            *o = o.map(|v| v.max(0.0));
        }
    }
}

impl std::fmt::Debug for PreparedMaterial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PreparedMaterial")
            .field("name", &self.name)
            .field("description", &self.description)
            .field("brdf_bytes", &self.brdf_bytes)
            .field("sampler", &self.sampler.name())
            .field("sampler_bytes", &self.sampler_bytes)
            .finish()
    }
}

/// An object of the scene.
#[derive(Debug, Clone)]
pub struct Object {
    /// Its shape.
    pub shape: Shape,
    /// Index into [`Scene::materials`]; `None` for emitters.
    pub material: Option<usize>,
    /// Radiance emitted on the front side (area lights).
    pub emission: Option<[f64; 3]>,
}

/// Integrator settings after overrides.
#[derive(Debug, Clone, Copy)]
pub struct IntegratorSettings {
    /// Direct lighting or path tracing.
    pub kind: IntegratorKind,
    /// Samples per pixel.
    pub spp: usize,
    /// Seed.
    pub seed: u64,
    /// BRDF sampling strategy.
    pub sampler: SamplerKind,
    /// Combine BRDF and light sampling with the balance heuristic.
    pub mis: bool,
    /// Where each pixel's samples come from.
    pub pattern: crate::description::SamplePattern,
    /// Spread a pixel's samples over its area.
    pub jitter: bool,
    /// Bounces of the path tracer.
    pub max_depth: usize,
    /// Shadow rays towards directional and point lights.
    pub shadows: bool,
}

/// A scene ready to render.
#[derive(Debug, Clone)]
pub struct Scene {
    /// The camera.
    pub camera: Camera,
    /// PNG and comparison exposure.
    pub exposure: f64,
    /// Objects.
    pub objects: Vec<Object>,
    /// Lights (area lights also appear in `objects`).
    pub lights: Vec<Light>,
    /// Light from far away.
    pub environment: Option<Environment>,
    /// Materials objects use.
    pub materials: Vec<PreparedMaterial>,
    /// How to render.
    pub integrator: IntegratorSettings,
}

impl Scene {
    /// The nearest hit and the object hit.
    pub fn intersect(&self, ray: &Ray) -> Option<(Hit, usize)> {
        let mut r = *ray;
        let mut best = None;
        for (i, o) in self.objects.iter().enumerate() {
            if let Some(h) = o.shape.intersect(&r) {
                r.t_max = h.t;
                best = Some((h, i));
            }
        }
        best
    }

    /// Whether nothing blocks `ray` up to its `t_max`.
    pub fn unoccluded(&self, ray: &Ray) -> bool {
        self.objects
            .iter()
            .all(|o| o.shape.intersect(ray).is_none())
    }

    /// Bytes of all material representations: reflectance and samplers.
    pub fn material_bytes(&self) -> (usize, usize) {
        self.materials
            .iter()
            .fold((0, 0), |(a, b), m| (a + m.brdf_bytes, b + m.sampler_bytes))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf::{fit_brdf, from_spherical, BlinnPhong, BrdfFitSettings, Reduction};

    #[test]
    fn fits_are_evaluated_at_the_cut_beyond_their_sampled_elevations() {
        let material = BlinnPhong {
            kd: [0.2; 3],
            ks: [0.4; 3],
            exponent: 20.0,
        };
        let settings = BrdfFitSettings::default()
            .with_reduction(Reduction::default().with_resolution(24, 24))
            .with_baselines(false);
        let (fit, _) = fit_brdf(&material, &settings).unwrap();
        let limit = fit.reduction.max_elevation_deg.to_radians();
        let wrapped = FitInDomain::new(fit.clone());
        let bits = |v: [f64; 3]| v.map(f64::to_bits);
        let f32_dir = |d: brdf::Vec3| d.map(|v| v as f32);
        let compact = |wi: brdf::Vec3, wo: brdf::Vec3| {
            wrapped
                .compact()
                .eval(f32_dir(wi), f32_dir(wo))
                .map(f64::from)
        };
        // Inside the sampled elevations: the fit itself (f32 form, close to f64).
        let (wi, wo) = (from_spherical(0.4, 0.1), from_spherical(0.9, 2.5));
        assert_eq!(bits(wrapped.eval(wi, wo)), bits(compact(wi, wo)));
        let exact = fit.eval(wi, wo);
        for c in 0..3 {
            assert!(
                (wrapped.eval(wi, wo)[c] - exact[c]).abs() < 1e-4 * exact[c],
                "{c}"
            );
        }
        // Beyond: the value at the cut, same azimuths, on the f32 and the
        // f64 paths alike.
        let (wi, wo) = (from_spherical(1.45, 0.1), from_spherical(0.9, 2.5));
        let at_cut = fit.eval(from_spherical(limit, 0.1), wo);
        let beyond = fit.eval(wi, wo);
        for c in 0..3 {
            assert!((beyond[c] - at_cut[c]).abs() < 1e-12 * at_cut[c], "{c}");
        }
        assert_eq!(bits(wrapped.eval(wi, wo)), bits(compact(wi, wo)));
        for c in 0..3 {
            assert!(
                (wrapped.eval(wi, wo)[c] - at_cut[c]).abs() < 1e-4 * at_cut[c],
                "{c}: {:?} against {at_cut:?}",
                wrapped.eval(wi, wo)
            );
        }
        assert_eq!(bits(wrapped.eval([0.0, 0.6, -0.8], wo)), bits([0.0; 3]));
    }
}
