//! The interface every reflectance source implements.

use crate::geometry::Vec3;

/// An isotropic BRDF: RGB reflectance (the cosine factor not included) for
/// the incident direction `wi` and the outgoing direction `wo`, both unit
/// vectors with z along the normal. Zero when either is below the horizon.
///
/// Convention: `wi` points towards the light and `wo` towards the viewer
/// (the renderers call `eval(light, view)`). It matters for measured
/// tables, which are not reciprocal: [`crate::RglBrdf`] puts the table's
/// incident (illumination) direction at `wi`, as the material was measured;
/// Mitsuba 3's path tracer evaluates the same files with the camera in that
/// slot, and near normal incidence the directional albedos of the two
/// conventions differ by up to 16%.
pub trait Brdf: Send + Sync {
    /// RGB value of the BRDF.
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3];

    /// `out[i] = eval(wi[i], wo)`: many incident directions and one
    /// outgoing direction, as at a point lit by many lights. Evaluators
    /// with a batched path (compact fits) override it.
    ///
    /// # Panics
    /// If `wi` and `out` differ in length.
    fn eval_incident(&self, wi: &[Vec3], wo: Vec3, out: &mut [[f64; 3]]) {
        assert_eq!(
            wi.len(),
            out.len(),
            "eval_incident: one output per direction"
        );
        for (w, o) in wi.iter().zip(out.iter_mut()) {
            *o = self.eval(*w, wo);
        }
    }

    /// A short description for reports.
    fn name(&self) -> String;
}

/// A BRDF behind a `Box` or an `Arc` is a BRDF: tables are shared
/// between scenes and the wrappers that view them.
macro_rules! forward_brdf {
    ($($pointer:ty),*) => {$(
        impl<T: Brdf + ?Sized> Brdf for $pointer {
            fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
                (**self).eval(wi, wo)
            }
            fn eval_incident(&self, wi: &[Vec3], wo: Vec3, out: &mut [[f64; 3]]) {
                (**self).eval_incident(wi, wo, out)
            }
            fn name(&self) -> String {
                (**self).name()
            }
        }
    )*};
}

forward_brdf!(Box<T>, std::sync::Arc<T>);
