//! Comparison backend: the interior-point conic solver Clarabel on the QP
//! `minimise 1/2 x^T I x` subject to `-G x + s = -h`, `s >= 0`.
//!
//! Rows are normalised first (the solution is unchanged), which keeps the
//! interior-point scaling sane on rows scaled by 1e-12 or 1e12.

use crate::problem::norm;
use crate::{Error, LdpProblem, LdpSolver, Solution, SolveOptions, Status};
use clarabel::algebra::CscMatrix;
use clarabel::solver::{DefaultSettings, DefaultSolver, IPSolver, SolverStatus, SupportedConeT};

/// Clarabel (interior point) on the LDP as a quadratic program.
#[derive(Debug, Clone, Copy, Default)]
pub struct ClarabelSolver;

impl LdpSolver for ClarabelSolver {
    fn name(&self) -> &'static str {
        "clarabel"
    }

    fn solve(&self, problem: &LdpProblem, options: &SolveOptions) -> Result<Solution, Error> {
        let (m, n) = (problem.rows(), problem.cols());
        let inv: Vec<f64> = problem
            .row_norms()
            .into_iter()
            .map(|v| if v > 0.0 { 1.0 / v } else { 1.0 })
            .collect();
        let p = CscMatrix::new(n, n, (0..=n).collect(), (0..n).collect(), vec![1.0; n]);
        let mut colptr = Vec::with_capacity(n + 1);
        let mut rowval = Vec::with_capacity(m * n);
        let mut nzval = Vec::with_capacity(m * n);
        colptr.push(0);
        // The dense matrix, built once when the rows are generated.
        let g = problem.g();
        for k in 0..n {
            for j in 0..m {
                let v = g[j * n + k];
                if v != 0.0 {
                    rowval.push(j);
                    nzval.push(-v * inv[j]);
                }
            }
            colptr.push(rowval.len());
        }
        let a = CscMatrix::new(m, n, colptr, rowval, nzval);
        let b: Vec<f64> = problem.h().iter().zip(&inv).map(|(h, s)| -h * s).collect();
        let cones = [SupportedConeT::NonnegativeConeT(m)];
        let settings = DefaultSettings::<f64> {
            verbose: false,
            max_iter: options
                .max_iterations
                .map_or(200, |v| v.min(u32::MAX as usize) as u32),
            ..DefaultSettings::default()
        };
        let mut solver =
            DefaultSolver::new(&p, &vec![0.0; n], &a, &b, &cones, settings).map_err(|e| {
                Error::BackendFailure {
                    backend: "clarabel",
                    message: e.to_string(),
                }
            })?;
        solver.solve();
        let status = match solver.solution.status {
            SolverStatus::Solved => Status::Solved,
            SolverStatus::AlmostSolved => Status::Inaccurate,
            SolverStatus::PrimalInfeasible | SolverStatus::AlmostPrimalInfeasible => {
                Status::Infeasible
            }
            SolverStatus::MaxIterations | SolverStatus::MaxTime => Status::IterationLimit,
            _ => Status::NumericalTrouble,
        };
        let x = solver.solution.x.clone();
        let x = if status == Status::Infeasible || norm(&x).is_nan() {
            vec![0.0; n]
        } else {
            x
        };
        let iterations = solver.solution.iterations as usize;
        Ok(Solution::measured(
            problem,
            status,
            x,
            iterations,
            Vec::new(),
            "clarabel",
        ))
    }
}
