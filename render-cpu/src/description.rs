//! The scene file (TOML): camera, film, integrator, materials, objects,
//! lights and environment. This module is the schema; [`crate::prepare`]
//! turns a description into a renderable [`crate::Scene`].
//!
//! ```toml
//! [camera]
//! from = [0.0, 0.0, 4.0]
//! to = [0.0, 0.0, 0.0]
//! fov_deg = 30.0
//! width = 256
//! height = 256
//!
//! [integrator]
//! kind = "direct"          # or "path"
//! spp = 16
//! sampler = "rational"     # BRDF sampling: cosine, tabulated or rational
//! pattern = "lattice"      # scrambled Sobol' points (default: independent)
//! jitter = true            # spread samples over the pixel (default)
//!
//! [materials.paint]
//! kind = "measured"
//! format = "rgl"
//! path = "$RATFIT_DATA/rgl/cm_military_green_rgb.bsdf"
//!
//! [materials.paint_fit]
//! kind = "fitted"
//! source = "paint"
//! rel_tol = 0.2
//!
//! [[objects]]
//! shape = "sphere"
//! center = [0.0, 0.0, 0.0]
//! radius = 1.0
//! material = "paint_fit"
//!
//! [environment]
//! kind = "sky"
//! zenith = [1.0, 1.0, 1.0]
//! horizon = [0.6, 0.7, 0.8]
//! ground = [0.1, 0.1, 0.1]
//! ```

use crate::error::{io, RenderError};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

fn default_up() -> [f64; 3] {
    [0.0, 1.0, 0.0]
}
fn default_fov() -> f64 {
    40.0
}
fn default_size() -> usize {
    256
}
fn one() -> f64 {
    1.0
}
fn default_spp() -> usize {
    16
}
fn default_depth() -> usize {
    5
}
fn default_triangles() -> usize {
    1000
}

/// The whole scene file.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct SceneDescription {
    /// The camera.
    pub camera: CameraDescription,
    /// Film settings.
    #[serde(default)]
    pub film: FilmDescription,
    /// How light is transported.
    pub integrator: IntegratorDescription,
    /// Materials by name; only those objects use are prepared.
    #[serde(default)]
    pub materials: BTreeMap<String, MaterialDescription>,
    /// Geometry.
    #[serde(default)]
    pub objects: Vec<ObjectDescription>,
    /// Lights other than the environment.
    #[serde(default)]
    pub lights: Vec<LightDescription>,
    /// Light from infinitely far away.
    pub environment: Option<EnvironmentDescription>,
}

/// A pinhole camera.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct CameraDescription {
    /// Eye position.
    pub from: [f64; 3],
    /// Point looked at.
    pub to: [f64; 3],
    /// Up direction (default +y).
    #[serde(default = "default_up")]
    pub up: [f64; 3],
    /// Vertical field of view in degrees (default 40).
    #[serde(default = "default_fov")]
    pub fov_deg: f64,
    /// Width in pixels (default 256).
    #[serde(default = "default_size")]
    pub width: usize,
    /// Height in pixels (default 256).
    #[serde(default = "default_size")]
    pub height: usize,
}

/// Film settings.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct FilmDescription {
    /// Multiplier applied before the sRGB curve in PNG output and before
    /// Lab conversion in comparisons (default 1).
    #[serde(default = "one")]
    pub exposure: f64,
}

impl Default for FilmDescription {
    fn default() -> Self {
        Self { exposure: 1.0 }
    }
}

/// The light-transport algorithm.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum IntegratorKind {
    /// Direct lighting: every directional and point light exactly (with
    /// shadow rays), one sample per area light, and the environment and
    /// emitters through BRDF sampling (plus light sampling with MIS).
    Direct,
    /// Path tracing: direct lighting at every bounce, continued by BRDF
    /// sampling, Russian roulette after three bounces.
    Path,
}

/// How the BRDF is importance-sampled.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "kebab-case")]
#[non_exhaustive]
pub enum SamplerKind {
    /// `cos(theta) / pi`, blind to the BRDF.
    Cosine,
    /// Tabulated inverse CDFs with a stored pdf.
    Tabulated,
    /// Fitted rational inverse CDFs, weight from the map's Jacobian.
    Rational,
}

impl std::str::FromStr for SamplerKind {
    type Err = RenderError;
    fn from_str(s: &str) -> Result<Self, RenderError> {
        match s {
            "cosine" => Ok(Self::Cosine),
            "tabulated" => Ok(Self::Tabulated),
            "rational" => Ok(Self::Rational),
            other => Err(crate::error::invalid(
                "sampler",
                format!("`{other}` (cosine, tabulated, rational)"),
            )),
        }
    }
}

impl SamplerKind {
    /// Name as in scene files.
    pub fn name(self) -> &'static str {
        match self {
            Self::Cosine => "cosine",
            Self::Tabulated => "tabulated",
            Self::Rational => "rational",
        }
    }
}

/// Where the random numbers of a pixel's samples come from.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Deserialize, Serialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum SamplePattern {
    /// Independent uniform numbers.
    #[default]
    Independent,
    /// A randomised rank-1 lattice per pair of dimensions: unbiased, and
    /// on smooth lighting far less noisy at the same samples per pixel.
    Lattice,
}

/// Integrator settings.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(deny_unknown_fields)]
pub struct IntegratorDescription {
    /// Direct lighting or path tracing.
    pub kind: IntegratorKind,
    /// Samples per pixel (default 16); with one, rays go through pixel
    /// centres.
    #[serde(default = "default_spp")]
    pub spp: usize,
    /// Seed of the per-pixel random streams (default 0).
    #[serde(default)]
    pub seed: u64,
    /// BRDF sampling strategy (default cosine).
    #[serde(default = "default_sampler")]
    pub sampler: SamplerKind,
    /// Also sample the environment and weigh both strategies by the balance
    /// heuristic (default false: BRDF sampling alone, as in the paper).
    #[serde(default)]
    pub mis: bool,
    /// Where each pixel's samples come from (default independent).
    #[serde(default)]
    pub pattern: SamplePattern,
    /// Spread a pixel's samples over its area (default true); false puts
    /// every sample through the pixel's centre, a point-sampled image whose
    /// only noise is that of the lighting integral.
    #[serde(default = "yes")]
    pub jitter: bool,
    /// Largest number of bounces of the path tracer (default 5).
    #[serde(default = "default_depth")]
    pub max_depth: usize,
    /// Shadow rays towards directional and point lights (default true;
    /// a lone convex object cannot shadow itself, so they can be skipped).
    #[serde(default = "yes")]
    pub shadows: bool,
}

fn yes() -> bool {
    true
}

fn default_sampler() -> SamplerKind {
    SamplerKind::Cosine
}

/// A material.
#[derive(Debug, Clone, Deserialize, Serialize, PartialEq)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
#[non_exhaustive]
pub enum MaterialDescription {
    /// Lambertian.
    Lambert {
        /// Albedo per channel.
        albedo: [f64; 3],
    },
    /// Normalised Blinn-Phong.
    BlinnPhong {
        /// Diffuse albedo.
        kd: [f64; 3],
        /// Specular scale.
        ks: [f64; 3],
        /// Exponent.
        exponent: f64,
    },
    /// Cook-Torrance with GGX and Schlick's Fresnel.
    Ggx {
        /// Diffuse albedo.
        kd: [f64; 3],
        /// Reflectance at normal incidence.
        f0: [f64; 3],
        /// GGX roughness.
        alpha: f64,
    },
    /// Ashikhmin-Shirley, isotropic.
    AshikhminShirley {
        /// Diffuse reflectance.
        rd: [f64; 3],
        /// Specular reflectance at normal incidence.
        rs: [f64; 3],
        /// Exponent.
        exponent: f64,
    },
    /// A measured table.
    Measured {
        /// `merl` or `rgl`.
        format: String,
        /// File path, relative to the scene file; `$RATFIT_DATA/` expands
        /// to the data directory.
        path: String,
    },
    /// A fit written by `ratfit fit`.
    Fit {
        /// File path, relative to the scene file.
        path: String,
    },
    /// A rational fit of another material of the scene, computed only when
    /// no cached fit exists.
    Fitted {
        /// The material fitted (by name).
        source: String,
        /// Relative interval half-width (default 0.05).
        #[serde(default = "default_rel_tol")]
        rel_tol: f64,
        /// 2 or 3 (default 2).
        #[serde(default = "default_dims")]
        dims: usize,
        /// Largest coefficient budget per channel (default 60; 120 with
        /// `target_de`, as `ratfit fit --target-de`, doubled once by the
        /// search where it rather than `max_bytes` stops it within twice
        /// the target, unless this is given).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_coeffs: Option<usize>,
        /// Instead of `rel_tol`: the smallest 3-D perceptual fit
        /// (luminance-chroma, 16^3 grid) whose validation renders reach
        /// this mean CIEDE2000 (see `render_cpu::fidelity::fit_to_target`;
        /// `dims` is then 3).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        target_de: Option<f64>,
        /// With `target_de`: the most bytes (f32) the fit may have; fits
        /// over it are tried, never kept. Default: no limit.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_bytes: Option<usize>,
        /// An elevation cut in degrees, in (0, 90]: only directions within
        /// it are fitted, and directions beyond it are evaluated at the
        /// cut. Default: 70 for fits at `rel_tol`; a `target_de` fit covers
        /// the whole hemisphere unless this is given.
        #[serde(default, skip_serializing_if = "Option::is_none")]
        max_elevation: Option<f64>,
        /// Fit the ratio of the source to a Cook-Torrance GGX lobe fitted
        /// first (lobe times rational; see `brdf::Lobe`). Default false.
        #[serde(default, skip_serializing_if = "std::ops::Not::not")]
        lobe: bool,
    },
}

fn default_rel_tol() -> f64 {
    0.05
}
fn default_dims() -> usize {
    2
}

/// An object: a shape and the material it uses.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "shape", rename_all = "kebab-case", deny_unknown_fields)]
#[non_exhaustive]
pub enum ObjectDescription {
    /// An analytic sphere.
    Sphere {
        /// Centre.
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// Material name.
        material: String,
    },
    /// An infinite plane.
    Plane {
        /// A point on it.
        point: [f64; 3],
        /// Its normal.
        normal: [f64; 3],
        /// Material name.
        material: String,
    },
    /// A parallelogram `corner + a u + b v`.
    Quad {
        /// One corner.
        corner: [f64; 3],
        /// First edge.
        u: [f64; 3],
        /// Second edge.
        v: [f64; 3],
        /// Material name.
        material: String,
    },
    /// A Wavefront OBJ mesh, scaled then translated.
    Mesh {
        /// File path, relative to the scene file.
        path: String,
        /// Uniform scale (default 1).
        #[serde(default = "one")]
        scale: f64,
        /// Translation (default none).
        #[serde(default)]
        translate: [f64; 3],
        /// Material name.
        material: String,
    },
    /// A triangulated UV sphere of about `triangles` triangles.
    MeshSphere {
        /// Centre.
        center: [f64; 3],
        /// Radius.
        radius: f64,
        /// About this many triangles (default 1000).
        #[serde(default = "default_triangles")]
        triangles: usize,
        /// Material name.
        material: String,
    },
    /// A torus around the y axis.
    Torus {
        /// Centre.
        center: [f64; 3],
        /// Radius of the ring.
        major: f64,
        /// Radius of the tube.
        minor: f64,
        /// About this many triangles (default 1000).
        #[serde(default = "default_triangles")]
        triangles: usize,
        /// Material name.
        material: String,
    },
}

impl ObjectDescription {
    /// The material's name.
    pub fn material(&self) -> &str {
        match self {
            Self::Sphere { material, .. }
            | Self::Plane { material, .. }
            | Self::Quad { material, .. }
            | Self::Mesh { material, .. }
            | Self::MeshSphere { material, .. }
            | Self::Torus { material, .. } => material,
        }
    }

    /// Uses another material.
    pub fn set_material(&mut self, name: &str) {
        match self {
            Self::Sphere { material, .. }
            | Self::Plane { material, .. }
            | Self::Quad { material, .. }
            | Self::Mesh { material, .. }
            | Self::MeshSphere { material, .. }
            | Self::Torus { material, .. } => *material = name.to_string(),
        }
    }
}

/// A light.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
#[non_exhaustive]
pub enum LightDescription {
    /// Parallel light.
    Directional {
        /// Towards the light.
        direction: [f64; 3],
        /// RGB irradiance on a surface facing it.
        irradiance: [f64; 3],
    },
    /// `count` directional lights spread evenly (a Fibonacci spiral) over
    /// the cone of `max_angle_deg` around `axis`, sharing `irradiance`.
    DirectionalSet {
        /// Number of lights.
        count: usize,
        /// Total RGB irradiance, split equally.
        irradiance: [f64; 3],
        /// Cone axis (default +y).
        #[serde(default = "default_up")]
        axis: [f64; 3],
        /// Cone half-angle in degrees (default 80).
        #[serde(default = "default_cone")]
        max_angle_deg: f64,
    },
    /// Isotropic point light.
    Point {
        /// Position.
        position: [f64; 3],
        /// RGB intensity.
        intensity: [f64; 3],
    },
    /// A one-sided emitting parallelogram (emits towards `u x v`).
    Area {
        /// One corner.
        corner: [f64; 3],
        /// First edge.
        u: [f64; 3],
        /// Second edge.
        v: [f64; 3],
        /// RGB radiance.
        radiance: [f64; 3],
    },
}

fn default_cone() -> f64 {
    80.0
}

/// The environment.
#[derive(Debug, Clone, Deserialize, Serialize)]
#[serde(tag = "kind", rename_all = "kebab-case", deny_unknown_fields)]
#[non_exhaustive]
pub enum EnvironmentDescription {
    /// Constant radiance (the white furnace).
    Uniform {
        /// RGB radiance.
        radiance: [f64; 3],
    },
    /// A procedural sky over +y.
    Sky {
        /// Radiance straight up.
        zenith: [f64; 3],
        /// Radiance at the horizon.
        horizon: [f64; 3],
        /// Radiance from below the horizon.
        ground: [f64; 3],
    },
    /// A latitude-longitude OpenEXR image.
    Image {
        /// File path, relative to the scene file.
        path: String,
        /// Radiance multiplier (default 1).
        #[serde(default = "one")]
        scale: f64,
    },
}

impl SceneDescription {
    /// Parses scene TOML; `origin` names it in errors.
    ///
    /// # Errors
    /// Invalid TOML, unknown keys, or missing required fields (the error
    /// gives the line and column).
    pub fn parse(text: &str, origin: &str) -> Result<Self, RenderError> {
        toml::from_str(text).map_err(|e| RenderError::Scene {
            path: origin.to_string(),
            reason: e.to_string(),
        })
    }

    /// Reads a scene file.
    ///
    /// # Errors
    /// As [`SceneDescription::parse`], or the file cannot be read.
    pub fn read(path: &Path) -> Result<Self, RenderError> {
        let text = std::fs::read_to_string(path).map_err(|e| io(path, e))?;
        Self::parse(&text, &path.display().to_string())
    }
}
