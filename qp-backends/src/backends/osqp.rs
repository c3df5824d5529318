//! Comparison backend: OSQP (ADMM) on `minimise 1/2 x^T I x` subject to
//! `h <= G x <= +inf`. ADMM stops at modest accuracy, so OSQP may report
//! "solved" on points that violate rows; our residual check flags those.

use crate::{Error, LdpProblem, LdpSolver, Solution, SolveOptions, Status};
use osqp::{CscMatrix, Problem, Settings};
use std::borrow::Cow;

/// OSQP 0.6 (ADMM, C library built with cmake).
#[derive(Debug, Clone, Copy, Default)]
pub struct OsqpSolver;

impl LdpSolver for OsqpSolver {
    fn name(&self) -> &'static str {
        "osqp"
    }

    fn solve(&self, problem: &LdpProblem, options: &SolveOptions) -> Result<Solution, Error> {
        let (m, n) = (problem.rows(), problem.cols());
        let inv: Vec<f64> = problem
            .row_norms()
            .into_iter()
            .map(|v| if v > 0.0 { 1.0 / v } else { 1.0 })
            .collect();
        let p = CscMatrix {
            nrows: n,
            ncols: n,
            indptr: Cow::Owned((0..=n).collect()),
            indices: Cow::Owned((0..n).collect()),
            data: Cow::Owned(vec![1.0; n]),
        };
        let mut indptr = vec![0];
        let mut indices = Vec::with_capacity(m * n);
        let mut data = Vec::with_capacity(m * n);
        // The dense matrix, built once when the rows are generated.
        let g = problem.g();
        for k in 0..n {
            for j in 0..m {
                let v = g[j * n + k];
                if v != 0.0 {
                    indices.push(j);
                    data.push(v * inv[j]);
                }
            }
            indptr.push(indices.len());
        }
        let a = CscMatrix {
            nrows: m,
            ncols: n,
            indptr: Cow::Owned(indptr),
            indices: Cow::Owned(indices),
            data: Cow::Owned(data),
        };
        let l: Vec<f64> = problem.h().iter().zip(&inv).map(|(h, s)| h * s).collect();
        let u = vec![f64::INFINITY; m];
        let max_iter = options
            .max_iterations
            .map_or(20_000, |v| v.min(u32::MAX as usize) as u32);
        // A fixed rho-adaptation interval: OSQP's default derives it from the
        // measured setup time, which makes results vary from run to run.
        let settings = Settings::default()
            .verbose(false)
            .max_iter(max_iter)
            .polish(true)
            .adaptive_rho_interval(Some(25));
        let mut prob = Problem::new(p, &vec![0.0; n], a, &l, &u, &settings).map_err(|e| {
            Error::BackendFailure {
                backend: "osqp",
                message: format!("{e:?}"),
            }
        })?;
        let result = prob.solve();
        let iterations = result.iter() as usize;
        let (status, x) = match result {
            osqp::Status::Solved(s) => (Status::Solved, s.x().to_vec()),
            osqp::Status::SolvedInaccurate(s) => (Status::Inaccurate, s.x().to_vec()),
            osqp::Status::MaxIterationsReached(s) | osqp::Status::TimeLimitReached(s) => {
                (Status::IterationLimit, s.x().to_vec())
            }
            osqp::Status::PrimalInfeasible(_) | osqp::Status::PrimalInfeasibleInaccurate(_) => {
                (Status::Infeasible, vec![0.0; n])
            }
            _ => (Status::NumericalTrouble, vec![0.0; n]),
        };
        Ok(Solution::measured(
            problem,
            status,
            x,
            iterations,
            Vec::new(),
            "osqp",
        ))
    }
}
