//! Run-time selection among the compiled backends.

use crate::{Error, LdpProblem, LdpSolver, Solution, SolveOptions, Status};
use std::str::FromStr;

/// The solvers this crate knows. Only [`Backend::Native`] is always compiled;
/// the others need the cargo feature of the same name.
#[derive(
    Debug, Clone, Copy, PartialEq, Eq, Hash, Default, serde::Serialize, serde::Deserialize,
)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Backend {
    /// Dual active set (Goldfarb-Idnani) with constraint generation (the default).
    #[default]
    Native,
    /// Clarabel interior point (feature `clarabel`).
    Clarabel,
    /// OSQP ADMM (feature `osqp`).
    Osqp,
    /// good_lp + microlp on the LP form (feature `good_lp`).
    GoodLp,
}

impl Backend {
    /// Every backend, compiled or not.
    pub const ALL: [Backend; 4] = [
        Backend::Native,
        Backend::Clarabel,
        Backend::Osqp,
        Backend::GoodLp,
    ];

    /// The backend's name as accepted by [`FromStr`].
    pub fn name(self) -> &'static str {
        match self {
            Backend::Native => "native",
            Backend::Clarabel => "clarabel",
            Backend::Osqp => "osqp",
            Backend::GoodLp => "good_lp",
        }
    }

    /// Whether this build includes the backend.
    pub fn is_compiled(self) -> bool {
        match self {
            Backend::Native => true,
            Backend::Clarabel => cfg!(feature = "clarabel"),
            Backend::Osqp => cfg!(feature = "osqp"),
            Backend::GoodLp => cfg!(feature = "good_lp"),
        }
    }

    /// The backends compiled into this build.
    pub fn available() -> Vec<Backend> {
        Self::ALL.into_iter().filter(|b| b.is_compiled()).collect()
    }

    /// The solver object for this backend.
    ///
    /// # Errors
    /// [`Error::BackendNotCompiled`] when the feature is off.
    pub fn solver(self) -> Result<Box<dyn LdpSolver>, Error> {
        match self {
            Backend::Native => Ok(Box::new(crate::NativeSolver)),
            #[cfg(feature = "clarabel")]
            Backend::Clarabel => Ok(Box::new(crate::ClarabelSolver)),
            #[cfg(feature = "osqp")]
            Backend::Osqp => Ok(Box::new(crate::OsqpSolver)),
            #[cfg(feature = "good_lp")]
            Backend::GoodLp => Ok(Box::new(crate::GoodLpSolver)),
            #[allow(unreachable_patterns)]
            other => Err(Error::BackendNotCompiled(
                other.name(),
                Self::available()
                    .iter()
                    .map(|b| b.name())
                    .collect::<Vec<_>>()
                    .join(", "),
            )),
        }
    }

    /// Solves `problem` with this backend.
    ///
    /// # Errors
    /// As [`Backend::solver`] and [`LdpSolver::solve`].
    pub fn solve(self, problem: &LdpProblem, options: &SolveOptions) -> Result<Solution, Error> {
        let solver = self.solver()?;
        if options.cancelled() {
            let zero = vec![0.0; problem.cols()];
            return Ok(Solution::measured(
                problem,
                Status::Cancelled,
                zero,
                0,
                Vec::new(),
                self.name(),
            ));
        }
        solver.solve(problem, options)
    }
}

impl std::fmt::Display for Backend {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Backend {
    type Err = Error;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s.to_ascii_lowercase().replace('-', "_").as_str() {
            "native" | "goldfarb_idnani" => Ok(Backend::Native),
            "clarabel" => Ok(Backend::Clarabel),
            "osqp" => Ok(Backend::Osqp),
            "good_lp" | "goodlp" | "microlp" => Ok(Backend::GoodLp),
            _ => Err(Error::UnknownBackend(s.to_string())),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn names_round_trip() {
        for b in Backend::ALL {
            assert_eq!(b.name().parse::<Backend>(), Ok(b));
        }
        assert!(matches!(
            "cplex".parse::<Backend>(),
            Err(Error::UnknownBackend(_))
        ));
    }

    #[test]
    fn native_is_always_available() {
        assert!(Backend::available().contains(&Backend::Native));
        for b in Backend::ALL {
            assert_eq!(b.solver().is_ok(), b.is_compiled(), "{b}");
        }
    }
}
