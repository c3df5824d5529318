//! Rational functions fitted inside interval data.
//!
//! Given samples `x_i` with intervals `[lo_i, hi_i]`, find `r = p / q` with
//! `lo_i <= r(x_i) <= hi_i` and `q(x_i) > 0` at every sample. With `p` and
//! `q` linear in their coefficients, each sample gives two linear
//! inequalities, and the most robust coefficient vector solves the convex
//! least-distance program P(n_p, n_q) (Salazar Celis, Cuyt and Verdonk 2007;
//! Pacanowski et al., "Rational BRDF", 2012). Its error bound is known a
//! priori: the fit lies inside every interval, which this crate checks in f64
//! for every fit it returns, whatever the solver reported.
//!
//! The crate knows nothing about reflectance: it offers multivariate bases
//! ([`Basis`]), interval data ([`IntervalData`]), [`RationalFunction`], one
//! way to fit ([`Fitter`]: the sweep over coefficient budgets, a single
//! split, or the program a split solves; [`fit`] is its shorthand), pole
//! control ([`PoleControl`]), caller-supplied rows and refinement
//! ([`ExtraConstraints`]: a check of each verified candidate that accepts
//! it, refuses it or adds rows for another solve, as the pole check does)
//! and verification.
//!
//! ```
//! use rational_core::{fit, FitSettings, IntervalData};
//!
//! // Runge's function within 1% at 200 points.
//! let x: Vec<f64> = (0..200).map(|i| -1.0 + 2.0 * i as f64 / 199.0).collect();
//! let v: Vec<f64> = x.iter().map(|x| 1.0 / (1.0 + 25.0 * x * x)).collect();
//! let data = IntervalData::from_values_relative(1, x, v, 0.01)?;
//! let report = fit(&data, &FitSettings::default())?;
//! assert!(report.verification.satisfied);
//! assert!(report.errors.max_relative <= 0.01);
//! assert_eq!(report.n_p + report.n_q, 4); // 1/(1 + 25 x^2) is (1, 3) in Chebyshev form
//! # Ok::<(), rational_core::FitError>(())
//! ```

/// The README's Rust example, compiled and run as a doctest.
#[cfg(doctest)]
#[doc = include_str!("../../README.md")]
pub struct ReadmeExample;

mod basis;
mod centre;
mod data;
mod error;
mod fit;
mod fitter;
pub mod poles;
mod power;
mod problem;
mod proof;
mod rational;
mod report;
mod screen;
mod settings;
mod sweep;
pub mod verify;

pub use basis::{
    graded_indices, weighted_graded_indices, Basis, BasisFamily, Domain, MAX_BASIS_LEN,
    MAX_DEGREE_WEIGHT, MAX_DIMENSION,
};
pub use data::IntervalData;
pub use error::FitError;
pub use fit::SplitFit;
pub use fitter::Fitter;
pub use poles::PoleControl;
pub use power::PowerForm;
pub use problem::{
    blocked_triangular_factor, condition_number, ExtraConstraints, NoExtraConstraints, Refinement,
    SharedDesign,
};
pub use proof::NoFitProof;
pub use qp_backends::{Backend, SolveOptions, Status};
pub use rational::RationalFunction;
pub use report::{FitReport, LargestMargin, PoleReport, SplitSummary};
pub use settings::{FitSettings, Progress, ProgressFn, Screen, Search, Selection, PROBE_FRACTIONS};
pub use sweep::fit;
pub use verify::{ErrorFigures, Verification};
