//! Rays and the shapes a scene is made of: spheres, planes, quads and
//! triangle meshes (each mesh with its own bounding-volume hierarchy).

use crate::math::{add_scaled, cross, dot, length, normalize, sub, Vec3};
use crate::mesh::TriangleMesh;

/// A ray `origin + t dir`, `t` in `(t_min, t_max)`.
#[derive(Debug, Clone, Copy)]
pub struct Ray {
    /// Origin.
    pub origin: Vec3,
    /// Unit direction.
    pub dir: Vec3,
    /// Nearest accepted distance.
    pub t_min: f64,
    /// Farthest accepted distance.
    pub t_max: f64,
}

impl Ray {
    /// A ray from `origin` along the unit `dir` to infinity.
    pub fn new(origin: Vec3, dir: Vec3) -> Self {
        Self {
            origin,
            dir,
            t_min: 0.0,
            t_max: f64::INFINITY,
        }
    }

    /// The point at distance `t`.
    pub fn at(&self, t: f64) -> Vec3 {
        add_scaled(self.origin, self.dir, t)
    }
}

/// Where a ray meets a surface.
#[derive(Debug, Clone, Copy)]
pub struct Hit {
    /// Distance along the ray.
    pub t: f64,
    /// The point.
    pub point: Vec3,
    /// Geometric normal (unit, as the shape defines it).
    pub geometric_normal: Vec3,
    /// Shading normal (unit; interpolated on meshes with vertex normals).
    pub shading_normal: Vec3,
}

/// A shape.
#[derive(Debug, Clone)]
#[non_exhaustive]
pub enum Shape {
    /// A sphere.
    Sphere {
        /// Centre.
        center: Vec3,
        /// Radius.
        radius: f64,
    },
    /// An infinite plane.
    Plane {
        /// A point on it.
        point: Vec3,
        /// Unit normal.
        normal: Vec3,
    },
    /// A parallelogram `corner + a u + b v`, `a, b` in `[0, 1]`; its normal
    /// is `u x v` normalised.
    Quad {
        /// One corner.
        corner: Vec3,
        /// First edge.
        u: Vec3,
        /// Second edge.
        v: Vec3,
    },
    /// A triangle mesh.
    Mesh(Box<TriangleMesh>),
}

impl Shape {
    /// The nearest hit inside the ray's range.
    pub fn intersect(&self, ray: &Ray) -> Option<Hit> {
        match self {
            Shape::Sphere { center, radius } => intersect_sphere(ray, *center, *radius),
            Shape::Plane { point, normal } => {
                let denom = dot(ray.dir, *normal);
                if denom.abs() < 1e-300 {
                    return None;
                }
                let t = dot(sub(*point, ray.origin), *normal) / denom;
                (t > ray.t_min && t < ray.t_max).then(|| Hit {
                    t,
                    point: ray.at(t),
                    geometric_normal: *normal,
                    shading_normal: *normal,
                })
            }
            Shape::Quad { corner, u, v } => intersect_quad(ray, *corner, *u, *v),
            Shape::Mesh(mesh) => mesh.intersect(ray),
        }
    }

    /// Surface area (infinite for planes).
    pub fn area(&self) -> f64 {
        match self {
            Shape::Sphere { radius, .. } => 4.0 * std::f64::consts::PI * radius * radius,
            Shape::Plane { .. } => f64::INFINITY,
            Shape::Quad { u, v, .. } => length(cross(*u, *v)),
            Shape::Mesh(m) => m.area(),
        }
    }
}

fn intersect_sphere(ray: &Ray, center: Vec3, radius: f64) -> Option<Hit> {
    // The numerically stable form (Ray Tracing Gems, ch. 7): the
    // discriminant from the perpendicular distance, not b^2 - 4ac.
    let f = sub(ray.origin, center);
    let b = -dot(f, ray.dir);
    let perp = add_scaled(f, ray.dir, b);
    let disc = radius * radius - dot(perp, perp);
    if disc < 0.0 {
        return None;
    }
    let s = disc.sqrt();
    let q = b + s.copysign(b);
    let c = dot(f, f) - radius * radius;
    let (t0, t1) = if q.abs() < f64::MIN_POSITIVE {
        (b, b)
    } else {
        (c / q, q)
    };
    let (t0, t1) = if t0 <= t1 { (t0, t1) } else { (t1, t0) };
    let t = if t0 > ray.t_min && t0 < ray.t_max {
        t0
    } else if t1 > ray.t_min && t1 < ray.t_max {
        t1
    } else {
        return None;
    };
    let point = ray.at(t);
    let n = normalize(sub(point, center));
    Some(Hit {
        t,
        point,
        geometric_normal: n,
        shading_normal: n,
    })
}

fn intersect_quad(ray: &Ray, corner: Vec3, u: Vec3, v: Vec3) -> Option<Hit> {
    let n = cross(u, v);
    let denom = dot(ray.dir, n);
    if denom.abs() < 1e-300 {
        return None;
    }
    let t = dot(sub(corner, ray.origin), n) / denom;
    if !(t > ray.t_min && t < ray.t_max) {
        return None;
    }
    let p = ray.at(t);
    let d = sub(p, corner);
    let nn = dot(n, n);
    let a = dot(cross(d, v), n) / nn;
    let b = dot(cross(u, d), n) / nn;
    if !(0.0..=1.0).contains(&a) || !(0.0..=1.0).contains(&b) {
        return None;
    }
    let normal = normalize(n);
    Some(Hit {
        t,
        point: p,
        geometric_normal: normal,
        shading_normal: normal,
    })
}
