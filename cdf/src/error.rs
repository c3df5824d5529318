//! The crate's error type.

/// Bad input or settings, a material with no reflectance, or a fit that
/// could not be made monotone.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum CdfError {
    /// A setting is out of range.
    #[error("invalid setting `{name}`: {reason}")]
    InvalidSetting {
        /// Setting name.
        name: &'static str,
        /// Why it was refused.
        reason: String,
    },
    /// The material reflects nothing (or NaN) at some view angle.
    #[error(
        "material `{material}` has no finite positive reflectance at view angle {theta_v} rad"
    )]
    NoReflectance {
        /// Material name.
        material: String,
        /// View elevation.
        theta_v: f64,
    },
    /// The dense-grid check still found a negative derivative after the
    /// allowed refinement rounds.
    #[error("{function} is not monotone: derivative {min_derivative:.3e} at {at:?} after {rounds} refinement rounds")]
    NotMonotone {
        /// `"theta"` or `"phi"`.
        function: &'static str,
        /// Smallest derivative found.
        min_derivative: f64,
        /// Where (fit coordinates).
        at: Vec<f64>,
        /// Rounds of added constraints.
        rounds: usize,
    },
    /// No budget up to the maximum gave a monotone fit inside the intervals.
    #[error("no feasible {function} inverse CDF with at most {max_coeffs} coefficients at CDF tolerance {cdf_tolerance} (after doubling it {doublings} times); raise the budget or the tolerance")]
    Infeasible {
        /// `"theta"` or `"phi"`.
        function: &'static str,
        /// Largest budget tried.
        max_coeffs: usize,
        /// The last tolerance tried.
        cdf_tolerance: f64,
        /// Doublings of the tolerance.
        doublings: usize,
    },
    /// The fitting engine refused (infeasible within the budget, bad data).
    #[error(transparent)]
    Fit(#[from] rational_core::FitError),
    /// A stored inverse CDF is malformed.
    #[error("malformed inverse CDF: {0}")]
    Malformed(String),
    /// A file could not be read.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: std::path::PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// A stored file is not of its form.
    #[error("{path}: {reason}")]
    MalformedFile {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong.
        reason: String,
    },
}

pub(crate) fn invalid(name: &'static str, reason: impl Into<String>) -> CdfError {
    CdfError::InvalidSetting {
        name,
        reason: reason.into(),
    }
}
