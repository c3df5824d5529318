//! Rational inverse CDFs for importance sampling isotropic BRDFs, and the
//! estimator that needs no stored pdf.
//!
//! Renderers sample light directions in proportion to `rho * cos(theta_l)`.
//! Tabulated inverse CDFs do that well but cost megabytes per material. This
//! crate tabulates the distributions ([`CdfTable`], also the baseline
//! [`TabulatedSampler`]), fits compact rational inverse CDFs to them
//! ([`fit_table`]) that are correct by construction (boundary values built
//! into the model, monotone by linear constraints checked on a denser grid,
//! symmetric in the two elevations through a symmetric basis), and samples
//! with weight `alpha = d theta/d mu * d phi/d tau * sin(theta_l)` taken from
//! the fitted functions' own derivatives ([`RationalSampler`]).
//!
//! ```
//! use brdf::{from_spherical, BlinnPhong};
//! use cdf::{estimate_albedo, fit_table, albedo_quadrature, CdfFitSettings, CdfTable,
//!           RationalSampler, TableSettings};
//!
//! let material = BlinnPhong { kd: [0.3; 3], ks: [0.2; 3], exponent: 10.0 };
//! let table = CdfTable::new(&material, TableSettings::default().with_views(6)?.with_cells(24, 24)?)?;
//! let settings = CdfFitSettings::default().with_samples(12, 8, 6, 1)?;
//! let (fitted, report) = fit_table(&table, &settings)?;
//! assert!(report.theta.min_derivative >= 0.0 && report.phi.min_derivative >= 0.0);
//!
//! // The estimator is unbiased whatever the fit's accuracy.
//! let sampler = RationalSampler::new(fitted);
//! let wo = from_spherical(0.5, 0.0);
//! let estimate = estimate_albedo(&material, &sampler, wo, 50_000, 1);
//! let truth = albedo_quadrature(&material, wo, 32);
//! assert!((estimate.mean[0] - truth.value[0]).abs() < 5.0 * estimate.std_error[0]);
//! # Ok::<(), cdf::CdfError>(())
//! ```

mod error;
mod file;
mod fit;
mod mis;
mod model;
mod monotone;
mod report;
mod sampler;
mod settings;
pub mod stats;
mod table;
mod variance;

pub use error::CdfError;
pub use file::CdfFile;
pub use fit::fit_table;
pub use model::{Component, InverseCdf, KnownPart, RationalCdf};
pub use report::{CdfFitReport, ComponentReport};
pub use sampler::{
    weighted_sample, CosineSampler, DirectionSample, RationalSampler, Sampler, TabulatedSampler,
};
pub use settings::CdfFitSettings;
pub use stats::{
    albedo_quadrature, chi_square, compare_samplers, estimate_albedo, relative_variance,
    AlbedoEstimate, ChiSquare, Quadrature, SamplerRow,
};
pub use table::{luminance, CdfTable, TableSettings, MAX_TABLE_BYTES};
pub use variance::{
    fit_table_to_variance, variance_ratio, VarianceStep, VARIANCE_HALVINGS, VARIANCE_SAMPLES,
    VARIANCE_VIEWS_DEG,
};
