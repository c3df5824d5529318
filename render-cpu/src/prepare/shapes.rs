//! Shapes, lights and environments from their descriptions.

use super::checks::{check_positive, check_rgb, check_vec, resolve_path, scene_error};
use super::{Action, PrepareLog};
use crate::description::{EnvironmentDescription, LightDescription, ObjectDescription};
use crate::error::RenderError;
use crate::geometry::Shape;
use crate::image::Image;
use crate::light::{Environment, EnvironmentMap, Light};
use crate::math::{normalize, Frame, Vec3};
use crate::mesh::TriangleMesh;
use crate::scene::Object;
use std::path::Path;
use std::time::Instant;

pub(super) fn build_shape(
    o: &ObjectDescription,
    base: &Path,
    origin: &str,
    log: &mut PrepareLog,
) -> Result<Shape, RenderError> {
    let v = |what: &str, x: [f64; 3]| check_vec(origin, what, x, false);
    let nz = |what: &str, x: [f64; 3]| check_vec(origin, what, x, true);
    let pos = |what: &str, x: f64| check_positive(origin, what, x);
    let tri = |n: usize| {
        if (8..=10_000_000).contains(&n) {
            Ok(n)
        } else {
            Err(scene_error(
                origin,
                format!("triangles {n} is outside 8..=10000000"),
            ))
        }
    };
    Ok(match o {
        ObjectDescription::Sphere { center, radius, .. } => Shape::Sphere {
            center: v("center", *center)?,
            radius: pos("radius", *radius)?,
        },
        ObjectDescription::Plane { point, normal, .. } => Shape::Plane {
            point: v("point", *point)?,
            normal: normalize(nz("normal", *normal)?),
        },
        ObjectDescription::Quad {
            corner, u, v: e2, ..
        } => {
            let (u, e2) = (nz("u", *u)?, nz("v", *e2)?);
            if crate::math::length(crate::math::cross(u, e2)) <= 0.0 {
                return Err(scene_error(
                    origin,
                    "quad edges u and v are parallel".into(),
                ));
            }
            Shape::Quad {
                corner: v("corner", *corner)?,
                u,
                v: e2,
            }
        }
        ObjectDescription::Mesh {
            path,
            scale,
            translate,
            ..
        } => {
            let start = Instant::now();
            let p = resolve_path(base, path)?;
            let mesh = TriangleMesh::read_obj(&p)?
                .transformed(pos("scale", *scale)?, v("translate", *translate)?);
            log.push(
                Action::Prepared,
                format!("mesh {}", p.display()),
                format!("{} triangles", mesh.triangle_count()),
                start.elapsed().as_secs_f64(),
            );
            Shape::Mesh(Box::new(mesh))
        }
        ObjectDescription::MeshSphere {
            center,
            radius,
            triangles,
            ..
        } => {
            let mesh = TriangleMesh::uv_sphere(
                v("center", *center)?,
                pos("radius", *radius)?,
                tri(*triangles)?,
            );
            log.push(
                Action::Prepared,
                "mesh sphere",
                format!("{} triangles", mesh.triangle_count()),
                0.0,
            );
            Shape::Mesh(Box::new(mesh))
        }
        ObjectDescription::Torus {
            center,
            major,
            minor,
            triangles,
            ..
        } => {
            let mesh = TriangleMesh::torus(
                v("center", *center)?,
                pos("major", *major)?,
                pos("minor", *minor)?,
                tri(*triangles)?,
            );
            log.push(
                Action::Prepared,
                "mesh torus",
                format!("{} triangles", mesh.triangle_count()),
                0.0,
            );
            Shape::Mesh(Box::new(mesh))
        }
    })
}

/// `count` unit directions on a Fibonacci spiral over the cone of
/// half-angle `max_angle` around `axis`, equal solid angle each.
pub fn spiral_directions(count: usize, axis: Vec3, max_angle: f64) -> Vec<Vec3> {
    let frame = Frame::from_normal(normalize(axis));
    let golden = std::f64::consts::PI * (3.0 - 5f64.sqrt());
    let cos_max = max_angle.cos();
    (0..count)
        .map(|i| {
            let z = 1.0 - (1.0 - cos_max) * (i as f64 + 0.5) / count as f64;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = golden * i as f64;
            frame.to_world([r * phi.cos(), r * phi.sin(), z])
        })
        .collect()
}

pub(super) fn build_light(
    l: &LightDescription,
    origin: &str,
    lights: &mut Vec<Light>,
    objects: &mut Vec<Object>,
) -> Result<(), RenderError> {
    match l {
        LightDescription::Directional {
            direction,
            irradiance,
        } => lights.push(Light::Directional {
            direction: normalize(check_vec(origin, "light direction", *direction, true)?),
            irradiance: check_rgb(origin, "irradiance", *irradiance)?,
        }),
        LightDescription::DirectionalSet {
            count,
            irradiance,
            axis,
            max_angle_deg,
        } => {
            if !(1..=100_000).contains(count) {
                return Err(scene_error(
                    origin,
                    format!("directional-set count {count} is outside 1..=100000"),
                ));
            }
            if !(*max_angle_deg > 0.0 && *max_angle_deg <= 180.0) {
                return Err(scene_error(
                    origin,
                    format!("max_angle_deg {max_angle_deg} is outside (0, 180]"),
                ));
            }
            let e = check_rgb(origin, "irradiance", *irradiance)?.map(|x| x / *count as f64);
            let axis = check_vec(origin, "axis", *axis, true)?;
            for d in spiral_directions(*count, axis, max_angle_deg.to_radians()) {
                lights.push(Light::Directional {
                    direction: d,
                    irradiance: e,
                });
            }
        }
        LightDescription::Point {
            position,
            intensity,
        } => lights.push(Light::Point {
            position: check_vec(origin, "position", *position, false)?,
            intensity: check_rgb(origin, "intensity", *intensity)?,
        }),
        LightDescription::Area {
            corner,
            u,
            v,
            radiance,
        } => {
            let (corner, u, v) = (
                check_vec(origin, "corner", *corner, false)?,
                check_vec(origin, "u", *u, true)?,
                check_vec(origin, "v", *v, true)?,
            );
            if crate::math::length(crate::math::cross(u, v)) <= 0.0 {
                return Err(scene_error(
                    origin,
                    "area light edges u and v are parallel".into(),
                ));
            }
            let radiance = check_rgb(origin, "radiance", *radiance)?;
            objects.push(Object {
                shape: Shape::Quad { corner, u, v },
                material: None,
                emission: Some(radiance),
            });
            lights.push(Light::Area {
                corner,
                u,
                v,
                radiance,
                object: objects.len() - 1,
            });
        }
    }
    Ok(())
}

pub(super) fn build_environment(
    e: &EnvironmentDescription,
    base: &Path,
    origin: &str,
    log: &mut PrepareLog,
) -> Result<Environment, RenderError> {
    Ok(match e {
        EnvironmentDescription::Uniform { radiance } => {
            Environment::Uniform(check_rgb(origin, "environment radiance", *radiance)?)
        }
        EnvironmentDescription::Sky {
            zenith,
            horizon,
            ground,
        } => Environment::Sky {
            zenith: check_rgb(origin, "zenith", *zenith)?,
            horizon: check_rgb(origin, "horizon", *horizon)?,
            ground: check_rgb(origin, "ground", *ground)?,
        },
        EnvironmentDescription::Image { path, scale } => {
            let start = Instant::now();
            let p = resolve_path(base, path)?;
            let img = Image::read_exr(&p)?;
            let (w, h) = (img.width, img.height);
            if w == 0 || h == 0 {
                return Err(scene_error(
                    origin,
                    format!("environment {}: no pixels", p.display()),
                ));
            }
            if let Some(i) = img.pixels.iter().position(|px| px.iter().any(|v| *v < 0.0)) {
                return Err(scene_error(
                    origin,
                    format!(
                        "environment {}: pixel ({}, {}) is {:?}, a negative radiance",
                        p.display(),
                        i % w,
                        i / w,
                        img.pixels[i]
                    ),
                ));
            }
            let map =
                EnvironmentMap::new(img, check_positive(origin, "environment scale", *scale)?);
            log.push(
                Action::Prepared,
                format!("environment {}", p.display()),
                format!("{w}x{h}, importance-sampling tables"),
                start.elapsed().as_secs_f64(),
            );
            Environment::Image(Box::new(map))
        }
    })
}
