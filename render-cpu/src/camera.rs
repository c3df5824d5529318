//! A pinhole camera.

use crate::geometry::Ray;
use crate::math::{add, add_scaled, cross, normalize, scale, sub, Vec3};

/// A pinhole camera looking from `from` to `to`, vertical field of view in
/// degrees.
#[derive(Debug, Clone, Copy)]
pub struct Camera {
    origin: Vec3,
    forward: Vec3,
    right: Vec3,
    up: Vec3,
    tan_half: f64,
    width: usize,
    height: usize,
}

impl Camera {
    /// A camera with an image of `width x height` pixels.
    pub fn new(from: Vec3, to: Vec3, up: Vec3, fov_deg: f64, width: usize, height: usize) -> Self {
        let forward = normalize(sub(to, from));
        let right = normalize(cross(forward, up));
        let up = cross(right, forward);
        Self {
            origin: from,
            forward,
            right,
            up,
            tan_half: (0.5 * fov_deg.to_radians()).tan(),
            width,
            height,
        }
    }

    /// The eye.
    pub fn origin(&self) -> Vec3 {
        self.origin
    }

    /// Unit view direction.
    pub fn forward(&self) -> Vec3 {
        self.forward
    }

    /// Unit vector to the right of the image.
    pub fn right(&self) -> Vec3 {
        self.right
    }

    /// Unit vector to the top of the image.
    pub fn up(&self) -> Vec3 {
        self.up
    }

    /// Tangent of half the vertical field of view.
    pub fn tan_half_fov(&self) -> f64 {
        self.tan_half
    }

    /// Image width in pixels.
    pub fn width(&self) -> usize {
        self.width
    }

    /// Image height in pixels.
    pub fn height(&self) -> usize {
        self.height
    }

    /// The same camera with another resolution.
    pub fn with_resolution(mut self, width: usize, height: usize) -> Self {
        self.width = width;
        self.height = height;
        self
    }

    /// The ray through the image point `(x, y)` in pixels (`y` down).
    pub fn ray(&self, x: f64, y: f64) -> Ray {
        let aspect = self.width as f64 / self.height as f64;
        let sx = (2.0 * x / self.width as f64 - 1.0) * self.tan_half * aspect;
        let sy = (1.0 - 2.0 * y / self.height as f64) * self.tan_half;
        let d = add(self.forward, add(scale(self.right, sx), scale(self.up, sy)));
        Ray::new(self.origin, normalize(d))
    }

    /// The point `t` along the ray through the image centre.
    pub fn centre_point(&self, t: f64) -> Vec3 {
        add_scaled(self.origin, self.forward, t)
    }
}
