//! Measured isotropic BRDFs in, compact verified rational BRDFs out.
//!
//! Measured reflectance tables are large (a MERL material is 35 MB). This
//! crate reads them (MERL binary, RGL `.bsdf`), provides analytic models
//! with known truth, reduces the isotropic BRDF to the 2-D
//! `rho(theta_h, theta_d)` of the paper or keeps the full 3-D
//! `(theta_h, theta_d, phi_d)` grid, and fits each RGB channel with a
//! rational function whose error bound holds at every sample (verified in
//! f64 by `rational-core`).
//!
//! ```
//! use brdf::{fit_brdf, BlinnPhong, Brdf, BrdfFitSettings, Reduction, from_spherical};
//!
//! let material = BlinnPhong { kd: [0.2, 0.3, 0.4], ks: [0.5; 3], exponent: 30.0 };
//! let settings = BrdfFitSettings::default()
//!     .with_reduction(Reduction::default().with_resolution(24, 24));
//! let (fitted, report) = fit_brdf(&material, &settings)?;
//! assert!(report.channels.iter().all(|c| c.verified));
//! let (wi, wo) = (from_spherical(0.3, 0.0), from_spherical(0.5, 3.0));
//! let (truth, fit) = (material.eval(wi, wo), fitted.eval(wi, wo));
//! assert!((fit[0] / truth[0] - 1.0).abs() < 0.1);
//! # Ok::<(), brdf::BrdfError>(())
//! ```

mod analytic;
pub mod baseline;
mod cap;
mod colour;
mod design;
mod downsample;
mod error;
pub mod export;
pub mod fidelity;
mod fit_report;
mod fit_settings;
mod fitted;
mod fitting;
mod geometry;
pub mod io;
pub mod lab;
mod lobe;
mod material;
mod no_fit;
mod reduce;
mod shell;
mod value_scale;

pub use analytic::{schlick, AshikhminShirley, BlinnPhong, CookTorranceGgx, Lambert};
pub use cap::CapCheck;
pub use colour::{luminance, ColourMode, LUMINANCE_WEIGHTS};
pub use compact::{CompactBrdf, CompactChannel};
pub use compact_batch::BatchedFit;
pub use design::{
    estimate_noise, ChannelBounds, NoiseEstimate, PerceptualBounds, DEFAULT_PEAK_CAP,
    LIGHT_FLOOR_PER_TOL,
};
pub use downsample::{DownsampledTable, SliceView};
pub use error::{write_atomic, BrdfError};
pub use export::alta::{AltaChannel, AltaRational};
pub use export::{compact, compact_batch, shader};
pub use fit_report::{scale_text, BrdfFitReport, ChannelReport};
pub use fit_settings::{BrdfFitSettings, ChannelProgressFn, MAX_CAP_ROUNDS};
pub use fitted::{FittedBrdf, CEILING_OVER_PEAK};
pub use fitting::{assemble_channels, fit_brdf, fit_samples, fit_samples_channel};
pub use geometry::{
    clamp_elevation, cross, dot, elevation, fold_phi_d, from_spherical, normalize, rotate,
    to_spherical, HalfDiff, Vec3,
};
pub use io::alta::AltaData;
pub use io::cornell::{cie_xyz, spectrum_to_rgb, xyz_to_linear_srgb, ScatteredBrdf};
pub use io::fit_file::FitFile;
pub use io::TableFormat;
pub use io::{merl, rgl};
pub use lobe::{Lobe, LobeF32, LOBE_ALPHA_RANGE};
pub use material::Brdf;
pub use merl::{MerlBrdf, TabulateOptions};
pub use no_fit::NoFitMemo;
pub use reduce::{Coordinates, PhiCoordinate, Reduction, ReductionKind, Samples, MAX_BINS};
pub use rgl::RglBrdf;
pub use shell::{
    ShellColour, ShellFactor, ShellLayout, ThetaDSpacing, DEFAULT_SHELL_BINS, MAX_SHELL_BINS,
    MAX_SHELL_FACTOR, SHELL_BIN_CHOICES, SHELL_CHOICES,
};
pub use value_scale::{ValueScale, LOG_EXPONENT_LIMIT, LOG_SPAN};
