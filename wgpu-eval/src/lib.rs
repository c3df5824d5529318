//! Fitted rational BRDFs on the GPU.
//!
//! A fit of a measured BRDF is a few hundred bytes of coefficients; on the
//! GPU it becomes straight-line shader code. This crate compiles fits
//! (through `brdf`'s WGSL export, coefficients as literals, so that no
//! coefficient is read from a storage buffer) into
//! - a compute kernel that evaluates a fit at many direction pairs
//!   ([`BatchEvaluator`]), and
//! - a renderer for render-cpu scenes lit by directional and point lights
//!   ([`GpuScene`], [`GpuRenderer`]): the paper's frame-rate experiment, a
//!   mesh shaded at every pixel by hundreds of lights.
//!
//! wgpu picks the adapter: a GPU, or Mesa's software Vulkan (lavapipe) on
//! machines without one. The results agree with the CPU f32 path
//! ([`brdf::CompactBrdf::eval`]) within [`agreement_tolerance`].
//!
//! ```
//! # fn main() -> Result<(), Box<dyn std::error::Error>> {
//! use brdf::{fit_brdf, BrdfFitSettings, CompactBrdf, Lambert};
//! use wgpu_eval::{BatchEvaluator, GpuContext, GpuError};
//!
//! let (fit, _report) = fit_brdf(&Lambert { albedo: [0.5, 0.3, 0.2] }, &BrdfFitSettings::default())?;
//! let compact = CompactBrdf::from_fitted(&fit);
//! let ctx = match GpuContext::new() {
//!     Ok(ctx) => ctx,
//!     Err(GpuError::NoAdapter(why)) => {
//!         eprintln!("SKIPPED: {why}");
//!         return Ok(());
//!     }
//!     Err(e) => return Err(e.into()),
//! };
//! let kernel = BatchEvaluator::new(&ctx, &compact)?;
//! let (wi, wo) = ([0.0, 0.6, 0.8], [0.0, -0.6, 0.8]);
//! let gpu = kernel.eval(&[(wi, wo)])?;
//! let cpu = compact.eval(wi, wo);
//! for c in 0..3 {
//!     assert!((gpu[0][c] - cpu[c]).abs() <= wgpu_eval::agreement_tolerance(cpu[c], cpu[c]));
//! }
//! # Ok(())
//! # }
//! ```

mod batch;
mod context;
mod error;
mod raster;
mod scene;
pub mod wgsl;

pub use batch::{BatchEvaluator, DirectionPair};
pub use context::GpuContext;
pub use error::GpuError;
pub use raster::{FrameTiming, GpuRenderer};
pub use scene::{GpuLight, GpuScene, Vertex, MAX_LIGHTS};

/// Renders a prepared render-cpu scene on the GPU: one frame, read back.
///
/// # Errors
/// [`GpuError::Unsupported`] for what the GPU renderer does not draw (see
/// [`GpuScene::from_scene`]), [`GpuError::Gpu`] for a device error.
pub fn render_scene(
    ctx: &GpuContext,
    scene: &render_cpu::Scene,
) -> Result<render_cpu::Image, GpuError> {
    let gpu = GpuScene::from_scene(scene)?;
    GpuRenderer::new(ctx, &gpu)?.render()
}

/// How far a GPU value may be from the CPU f32 value `cpu` of the same
/// generated code, for a function whose largest value is `peak`: 2^-10
/// relative to `cpu`, plus 2^-16 of `peak`.
///
/// The two paths run the same operations in the same order, but GPUs fuse
/// multiply-adds and Vulkan lets `sin`, `cos`, `asin` and `atan2` (in the
/// Rusinkiewicz coordinates) be some ulps off; a rational function's
/// relative sensitivity to its coordinates amplifies that near a narrow
/// peak, and cancellation in `p` or `q` shows as an absolute error on small
/// values.
pub fn agreement_tolerance(cpu: f32, peak: f32) -> f32 {
    cpu.abs() * 2f32.powi(-10) + peak.abs() * 2f32.powi(-16)
}
