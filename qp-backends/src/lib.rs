//! Least-distance programs behind one solver trait.
//!
//! Many fitting problems reduce to finding the shortest vector that satisfies
//! a large set of linear inequalities,
//!
//! ```text
//! minimise ||x||^2   subject to   G x >= h,
//! ```
//!
//! with `G` dense, up to millions of rows and a few hundred columns: stored,
//! or generated from the basis values of an interval fit
//! ([`LdpProblem::from_intervals`]) so that a problem of a million samples
//! costs no `rows x cols` copy. This
//! crate states that problem once ([`LdpProblem`]), defines one trait that
//! every solver implements ([`LdpSolver`]), and ships an exact active-set
//! solver ([`NativeSolver`], Goldfarb-Idnani with the identity Hessian and
//! constraint generation) plus comparison backends behind cargo features
//! (`clarabel`, `osqp`, `good_lp`).
//!
//! Infeasibility is a normal outcome ([`Status::Infeasible`]); errors
//! ([`Error`]) are for bad input and missing backends. Whatever a backend
//! reports, the residuals in a [`Solution`] are measured by this crate.
//!
//! ```
//! use qp_backends::{Backend, LdpProblem, SolveOptions, Status};
//!
//! // x1 >= 1 and x2 >= 2: the shortest such vector is (1, 2).
//! let problem = LdpProblem::from_rows(&[vec![1.0, 0.0], vec![0.0, 1.0]], vec![1.0, 2.0])?;
//! let solution = Backend::Native.solve(&problem, &SolveOptions::default())?;
//! assert_eq!(solution.status, Status::Solved);
//! assert!(solution.is_verified());
//! assert!((solution.x[0] - 1.0).abs() < 1e-12 && (solution.x[1] - 2.0).abs() < 1e-12);
//! # Ok::<(), qp_backends::Error>(())
//! ```

mod backend;
mod backends;
mod error;
mod options;
mod problem;
mod solution;
pub mod tolerance;

pub use backend::Backend;
#[cfg(feature = "clarabel")]
pub use backends::clarabel::ClarabelSolver;
#[cfg(feature = "good_lp")]
pub use backends::good_lp::GoodLpSolver;
pub use backends::native::NativeSolver;
#[cfg(feature = "osqp")]
pub use backends::osqp::OsqpSolver;
pub use error::Error;
pub use options::{CancelFlag, SolveOptions};
pub use problem::LdpProblem;
pub use solution::{Residuals, Solution, Status};

/// A solver for [`LdpProblem`]s. Implementations are stateless; settings
/// travel in [`SolveOptions`].
pub trait LdpSolver: Send + Sync {
    /// Short name, as accepted by [`Backend`]'s `FromStr`.
    fn name(&self) -> &'static str;

    /// Solves the problem. An infeasible problem is `Ok` with
    /// [`Status::Infeasible`].
    ///
    /// # Errors
    /// Only for failures that are not outcomes of the problem (a backend that
    /// cannot set up, invalid options).
    fn solve(&self, problem: &LdpProblem, options: &SolveOptions) -> Result<Solution, Error>;
}
