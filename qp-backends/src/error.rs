//! The crate's error type: bad input and unavailable backends.
//!
//! A problem that has no solution is *not* an error: it is reported as
//! [`crate::Status::Infeasible`] inside a [`crate::Solution`].

/// Everything that can go wrong before or around a solve.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum Error {
    /// The problem data are inconsistent or not finite.
    #[error("invalid problem: {0}")]
    InvalidProblem(String),
    /// A solver option is out of its valid range.
    #[error("invalid option `{name}`: {reason}")]
    InvalidOption {
        /// The option's name.
        name: &'static str,
        /// Why the value was refused.
        reason: String,
    },
    /// The backend exists but this build does not include it.
    #[error("backend `{0}` is not compiled in; rebuild with `--features {0}` (compiled: {1})")]
    BackendNotCompiled(&'static str, String),
    /// The backend name is not known at all.
    #[error("unknown backend `{0}`; known backends: native, clarabel, osqp, good_lp")]
    UnknownBackend(String),
    /// The external solver failed to set up or crashed (not an infeasibility).
    #[error("backend `{backend}` failed: {message}")]
    BackendFailure {
        /// Which backend.
        backend: &'static str,
        /// What it said.
        message: String,
    },
}
