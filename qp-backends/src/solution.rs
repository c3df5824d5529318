//! What a solve returns: the backend's status, the point, and residuals
//! measured by our own code.

use crate::problem::norm;
use crate::tolerance::rounding_tolerance;
use crate::LdpProblem;

/// How a backend's solve ended. Infeasibility is an outcome, not an error.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
#[non_exhaustive]
pub enum Status {
    /// The backend claims an optimal (or, for LP-form backends, feasible) point.
    Solved,
    /// The backend stopped close to optimal but outside its own tolerances.
    Inaccurate,
    /// No point satisfies the constraints.
    Infeasible,
    /// The iteration limit was reached first.
    IterationLimit,
    /// The backend lost accuracy (degenerate or ill-conditioned data).
    NumericalTrouble,
    /// The caller's cancel flag stopped the solve before it ended.
    Cancelled,
}

impl std::fmt::Display for Status {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let s = match self {
            Status::Solved => "solved",
            Status::Inaccurate => "inaccurate",
            Status::Infeasible => "infeasible",
            Status::IterationLimit => "iteration-limit",
            Status::NumericalTrouble => "numerical-trouble",
            Status::Cancelled => "cancelled",
        };
        f.write_str(s)
    }
}

/// Constraint residuals of a point, measured in f64 by this crate whatever
/// the backend reported.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Residuals {
    /// Largest violation, as a distance to the half-space:
    /// `max_j max(0, h_j - G_j x) / ||G_j||`.
    pub max_violation: f64,
    /// Smallest `G_j x / h_j` over rows with `h_j > 0` (1 means tight, below 1
    /// violated); `+inf` when no row has `h_j > 0`.
    pub min_slack_ratio: f64,
    /// Smallest normalised margin `G_j x / (||G_j|| ||x||)`: the depth of `x`
    /// in the constraint cone (meaningful for homogeneous problems).
    pub depth: f64,
    /// `||x||`.
    pub norm_x: f64,
    /// Index of the worst row.
    pub worst_row: usize,
    /// Whether every row holds to the rounding tolerance
    /// `h_j - G_j x <= tol * (|h_j| + ||G_j|| ||x||)`.
    pub satisfied: bool,
}

impl Residuals {
    /// Measures `x` against every row of `problem`.
    pub fn measure(problem: &LdpProblem, x: &[f64]) -> Self {
        let tol = rounding_tolerance(problem.cols());
        let norm_x = norm(x);
        let mut r = Residuals {
            max_violation: 0.0,
            min_slack_ratio: f64::INFINITY,
            depth: f64::INFINITY,
            norm_x,
            worst_row: 0,
            satisfied: x.iter().all(|v| v.is_finite()),
        };
        let mut worst = f64::NEG_INFINITY;
        if x.len() != problem.cols() {
            r.satisfied = false;
            r.max_violation = f64::INFINITY;
            return r;
        }
        let mut products = vec![0.0; problem.rows()];
        problem.products(x, &mut products);
        let norms = problem.row_norms();
        for j in 0..problem.rows() {
            let gx = products[j];
            let h = problem.h()[j];
            let nrm = norms[j];
            if nrm == 0.0 {
                if h > 0.0 {
                    r.satisfied = false;
                    r.max_violation = f64::INFINITY;
                    r.worst_row = j;
                }
                continue;
            }
            let violation = (h - gx) / nrm;
            if violation > worst {
                worst = violation;
                r.worst_row = j;
            }
            r.max_violation = r.max_violation.max(violation);
            if h > 0.0 {
                r.min_slack_ratio = r.min_slack_ratio.min(gx / h);
            }
            if norm_x > 0.0 {
                r.depth = r.depth.min(gx / (nrm * norm_x));
            }
            if h - gx > tol * (h.abs() + nrm * norm_x) {
                r.satisfied = false;
            }
        }
        if norm_x == 0.0 {
            r.depth = 0.0;
        }
        r
    }
}

/// The result of one solve.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct Solution {
    /// What the backend reported.
    pub status: Status,
    /// The point (empty when the backend produced none).
    pub x: Vec<f64>,
    /// Residuals measured by this crate on every row.
    pub residuals: Residuals,
    /// Iterations the backend used (active-set changes for the native solver).
    pub iterations: usize,
    /// Rows active at the solution (native backend), for warm starts; for
    /// an infeasible problem, the active rows and the row found
    /// incompatible with them (rows that already prove infeasibility).
    pub active_set: Vec<usize>,
    /// Backend name.
    pub backend: &'static str,
}

impl Solution {
    /// Builds a solution and measures its residuals on `problem`.
    pub fn measured(
        problem: &LdpProblem,
        status: Status,
        x: Vec<f64>,
        iterations: usize,
        active_set: Vec<usize>,
        backend: &'static str,
    ) -> Self {
        let x = if x.len() == problem.cols() {
            x
        } else {
            vec![0.0; problem.cols()]
        };
        let residuals = Residuals::measure(problem, &x);
        Self {
            status,
            x,
            residuals,
            iterations,
            active_set,
            backend,
        }
    }

    /// `true` when the backend reported success *and* our own check confirms
    /// that every constraint holds.
    pub fn is_verified(&self) -> bool {
        matches!(self.status, Status::Solved | Status::Inaccurate) && self.residuals.satisfied
    }

    /// `true` when the backend claimed success but the point violates rows.
    pub fn claims_solved_but_violates(&self) -> bool {
        matches!(self.status, Status::Solved) && !self.residuals.satisfied
    }
}
