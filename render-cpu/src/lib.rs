//! CPU renders that show and measure BRDF representations.
//!
//! A user judges a BRDF representation by its renders. This crate reads a
//! scene (TOML: camera, spheres, planes, quads, OBJ and procedural meshes,
//! measured, fitted and analytic materials, directional, point, area and
//! environment lights), prepares only what the scene needs (a fit only when
//! a fitted material is used and no cached fit exists, inverse CDFs only
//! when the integrator samples the BRDF), renders it with direct lighting or
//! a path tracer (deterministic per seed, BRDF sampling by cosine, tabulated
//! or rational inverse CDFs), writes PNG and OpenEXR, and compares images in
//! CIELAB (CIE76, CIEDE2000).
//!
//! ```
//! use render_cpu::{prepare, render, RenderOptions, SceneDescription};
//!
//! let scene = SceneDescription::parse(r#"
//!     [camera]
//!     from = [0.0, 0.0, 4.0]
//!     to = [0.0, 0.0, 0.0]
//!     fov_deg = 40.0
//!     width = 16
//!     height = 16
//!     [integrator]
//!     kind = "direct"
//!     spp = 4
//!     [materials.white]
//!     kind = "lambert"
//!     albedo = [1.0, 1.0, 1.0]
//!     [[objects]]
//!     shape = "sphere"
//!     center = [0.0, 0.0, 0.0]
//!     radius = 1.0
//!     material = "white"
//!     [environment]
//!     kind = "uniform"
//!     radiance = [1.0, 1.0, 1.0]
//! "#, "furnace")?;
//! let options = RenderOptions { no_cache: true, ..Default::default() };
//! let (scene, _log) = prepare(scene, std::path::Path::new("."), "furnace", &options)?;
//! let out = render(&scene, &|_, _| {});
//! // White furnace: an albedo-1 Lambertian sphere in a uniform environment
//! // is as bright as the environment (cosine sampling is exact here).
//! let centre = out.image.at(8, 8);
//! assert!((centre[0] - 1.0).abs() < 1e-6);
//! # Ok::<(), render_cpu::RenderError>(())
//! ```

mod camera;
pub use brdf::lab as color;
pub mod compare;
pub mod description;
mod error;
pub mod fidelity;
mod geometry;
mod image;
mod integrator;
mod light;
mod linear;
pub mod math;
mod mesh;
mod prepare;
mod scene;

pub use brdf::write_atomic;
pub use camera::Camera;
pub use compare::{compare, false_colour, Comparison};
pub use description::{
    IntegratorKind, MaterialDescription, SamplePattern, SamplerKind, SceneDescription,
};
pub use error::RenderError;
pub use geometry::{Hit, Ray, Shape};
pub use image::{encode_png, srgb_encode, write_png, Image};
pub use integrator::{radiance, render, RenderOutput, RenderStats};
pub use light::{Environment, EnvironmentMap, Light};
pub use math::{Frame, Rng};
pub use mesh::TriangleMesh;
pub use prepare::{
    content_hash, prepare, prepare_file, resolve_path, spiral_directions, Action, LogEntry,
    PrepareLog, RenderOptions,
};
pub use scene::{
    ClosedForm, FitInDomain, IntegratorSettings, Object, PreparedMaterial, Scene, F32_TOLERANCE,
};
