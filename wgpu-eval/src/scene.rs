//! What the GPU renderer draws, taken from a prepared render-cpu scene:
//! triangles, directional and point lights, closed-form materials.

use crate::GpuError;
use render_cpu::math::{cross, dot, normalize, sub};
use render_cpu::{ClosedForm, IntegratorKind, Light, Scene, Shape};

/// The largest light count one uniform buffer holds (32 bytes per light in
/// WebGPU's guaranteed 64 KiB).
pub const MAX_LIGHTS: usize = 2048;

/// One vertex: position, shading normal, the triangle's geometric normal
/// and the material index (40 bytes).
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct Vertex {
    /// Position.
    pub position: [f32; 3],
    /// Shading normal (interpolated).
    pub shading_normal: [f32; 3],
    /// Geometric normal of the triangle.
    pub geometric_normal: [f32; 3],
    /// Index into [`GpuScene::materials`].
    pub material: u32,
}

/// A light as the shader reads it.
#[derive(Debug, Clone, Copy, PartialEq, bytemuck::Pod, bytemuck::Zeroable)]
#[repr(C)]
pub struct GpuLight {
    /// Direction towards the light with `w = 0`, or position with `w = 1`.
    pub where_: [f32; 4],
    /// Irradiance (directional) or intensity (point), `w` unused.
    pub power: [f32; 4],
}

/// A scene the GPU renderer can draw.
#[derive(Debug, Clone)]
pub struct GpuScene {
    /// Three vertices per triangle.
    pub vertices: Vec<Vertex>,
    /// Lights.
    pub lights: Vec<GpuLight>,
    /// Materials, indexed by [`Vertex::material`].
    pub materials: Vec<ClosedForm>,
    /// Names of the materials (for reports).
    pub material_names: Vec<String>,
    /// Camera: eye, forward, right, up (unit), tangent of half the vertical
    /// field of view.
    pub camera: ([f64; 3], [f64; 3], [f64; 3], [f64; 3], f64),
    /// Image size.
    pub width: usize,
    /// Image size.
    pub height: usize,
}

fn unsupported(what: impl Into<String>) -> GpuError {
    GpuError::Unsupported(what.into())
}

/// The scene's lights as the uniform buffer holds them (directional and
/// point lights only, at most [`MAX_LIGHTS`]).
fn gpu_lights(scene: &Scene) -> Result<Vec<GpuLight>, GpuError> {
    let mut lights = Vec::with_capacity(scene.lights.len());
    for l in &scene.lights {
        lights.push(match l {
            Light::Directional {
                direction,
                irradiance,
            } => GpuLight {
                where_: [
                    direction[0] as f32,
                    direction[1] as f32,
                    direction[2] as f32,
                    0.0,
                ],
                power: [
                    irradiance[0] as f32,
                    irradiance[1] as f32,
                    irradiance[2] as f32,
                    0.0,
                ],
            },
            Light::Point {
                position,
                intensity,
            } => GpuLight {
                where_: [
                    position[0] as f32,
                    position[1] as f32,
                    position[2] as f32,
                    1.0,
                ],
                power: [
                    intensity[0] as f32,
                    intensity[1] as f32,
                    intensity[2] as f32,
                    0.0,
                ],
            },
            Light::Area { .. } => {
                return Err(unsupported(
                    "an area light: the GPU renderer draws directional and point lights",
                ))
            }
            other => {
                return Err(unsupported(format!(
                    "{other:?}: the GPU renderer draws directional and point lights"
                )))
            }
        });
    }
    if lights.len() > MAX_LIGHTS {
        return Err(unsupported(format!(
            "{} lights: at most {MAX_LIGHTS} fit in one uniform buffer",
            lights.len()
        )));
    }
    Ok(lights)
}

/// Appends object `oi`'s triangles (three vertices each, flat or mesh
/// normals) with material `gpu_index`; analytic spheres and planes are
/// refused.
fn push_triangles(
    oi: usize,
    shape: &Shape,
    gpu_index: u32,
    vertices: &mut Vec<Vertex>,
) -> Result<(), GpuError> {
    match shape {
        Shape::Mesh(mesh) => {
            let p = mesh.positions();
            for t in mesh.triangles() {
                let [a, b, c] = t.map(|i| p[i as usize]);
                let ng = normalize(cross(sub(b, a), sub(c, a)));
                for (corner, &i) in [a, b, c].into_iter().zip(t.iter()) {
                    let ns = match mesh.normals() {
                        Some(n) => n[i as usize],
                        None => ng,
                    };
                    vertices.push(Vertex {
                        position: f32x3(corner),
                        shading_normal: f32x3(ns),
                        geometric_normal: f32x3(ng),
                        material: gpu_index,
                    });
                }
            }
        }
        Shape::Quad { corner, u, v } => {
            let n = f32x3(normalize(cross(*u, *v)));
            let at = |a: f64, b: f64| {
                f32x3([0, 1, 2].map(|k| corner[k] + a * u[k] + b * v[k]))
            };
            for (a, b) in [(0.0, 0.0), (1.0, 0.0), (1.0, 1.0), (0.0, 0.0), (1.0, 1.0), (0.0, 1.0)] {
                vertices.push(Vertex {
                    position: at(a, b),
                    shading_normal: n,
                    geometric_normal: n,
                    material: gpu_index,
                });
            }
        }
        Shape::Sphere { .. } => {
            return Err(unsupported(format!(
                "object {oi} is an analytic sphere: the GPU renderer draws triangles (use shape = \"mesh-sphere\")"
            )))
        }
        Shape::Plane { .. } => {
            return Err(unsupported(format!(
                "object {oi} is an infinite plane: the GPU renderer draws triangles (use a quad)"
            )))
        }
        _ => {
            return Err(unsupported(format!(
                "object {oi}: the GPU renderer draws meshes and quads"
            )))
        }
    }
    Ok(())
}

fn f32x3(v: [f64; 3]) -> [f32; 3] {
    v.map(|x| x as f32)
}

impl GpuScene {
    /// Takes what the GPU draws from a prepared scene, or says what it
    /// cannot draw: the renderer rasterises triangles (meshes and quads),
    /// shades one sample per pixel centre with direct light from
    /// directional and point lights and no shadow rays, and evaluates
    /// Lambert and rational-fit materials (measured tables stay on the CPU).
    ///
    /// # Errors
    /// [`GpuError::Unsupported`] naming the first feature it cannot draw.
    pub fn from_scene(scene: &Scene) -> Result<Self, GpuError> {
        let s = &scene.integrator;
        if s.kind != IntegratorKind::Direct {
            return Err(unsupported(
                "integrator `path`: the GPU renderer computes direct lighting (kind = \"direct\")",
            ));
        }
        if s.spp != 1 {
            return Err(unsupported(format!(
                "spp = {}: the GPU renderer takes one sample through each pixel centre (spp = 1)",
                s.spp
            )));
        }
        if s.shadows {
            return Err(unsupported(
                "shadows = true: the GPU renderer traces no shadow rays (set shadows = false)",
            ));
        }
        if scene.environment.is_some() {
            return Err(unsupported(
                "an environment light: the GPU renderer draws directional and point lights",
            ));
        }
        let lights = gpu_lights(scene)?;

        // Materials in the scene's order; each must have a closed form.
        let mut materials = Vec::new();
        let mut material_names = Vec::new();
        let mut index = vec![None; scene.materials.len()];
        let mut vertices = Vec::new();
        for (oi, o) in scene.objects.iter().enumerate() {
            if o.emission.is_some() {
                return Err(unsupported(format!(
                    "object {oi} emits light: the GPU renderer has no area lights"
                )));
            }
            let Some(mi) = o.material else {
                return Err(unsupported(format!("object {oi} has no material")));
            };
            let m = &scene.materials[mi];
            let gpu_index = match index[mi] {
                Some(k) => k,
                None => {
                    let Some(form) = &m.closed_form else {
                        return Err(unsupported(format!(
                            "material `{}` ({}) has no closed form: the GPU evaluates Lambert and rational fits (fit a measured table with kind = \"fitted\")",
                            m.name, m.description
                        )));
                    };
                    materials.push(form.clone());
                    material_names.push(m.name.clone());
                    index[mi] = Some(materials.len() - 1);
                    materials.len() - 1
                }
            } as u32;
            push_triangles(oi, &o.shape, gpu_index, &mut vertices)?;
        }
        let c = &scene.camera;
        Ok(Self {
            vertices,
            lights,
            materials,
            material_names,
            camera: (c.origin(), c.forward(), c.right(), c.up(), c.tan_half_fov()),
            width: c.width(),
            height: c.height(),
        })
    }

    /// Near and far depths that hold every vertex in front of the camera.
    pub(crate) fn depth_range(&self) -> (f32, f32) {
        let (eye, forward, ..) = self.camera;
        let far = self
            .vertices
            .iter()
            .map(|v| dot(sub(v.position.map(f64::from), eye), forward))
            .fold(0.0f64, f64::max)
            .max(1e-6)
            * 1.01;
        ((far * 1e-5) as f32, far as f32)
    }

    /// Coefficients of the rational materials (all channels).
    pub fn coefficients(&self) -> usize {
        self.materials
            .iter()
            .map(|m| match m {
                ClosedForm::Fit(f) => f.fit().coefficients(),
                _ => 0,
            })
            .sum()
    }
}
