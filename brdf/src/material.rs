//! The interface every reflectance source implements.

use crate::geometry::Vec3;

/// An isotropic BRDF: RGB reflectance (the cosine factor not included) for
/// the incident direction `wi` and the outgoing direction `wo`, both unit
/// vectors with z along the normal. Zero when either is below the horizon.
pub trait Brdf: Send + Sync {
    /// RGB value of the BRDF.
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3];

    /// A short description for reports.
    fn name(&self) -> String;
}

impl<T: Brdf + ?Sized> Brdf for Box<T> {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        (**self).eval(wi, wo)
    }
    fn name(&self) -> String {
        (**self).name()
    }
}
