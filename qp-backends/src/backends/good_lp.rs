//! Comparison backend: the LP form through good_lp and the pure-Rust
//! `microlp` simplex solver.
//!
//! With unit rows `n_j`, `b_j = h_j / ||G_j||`, it solves
//! `maximise t` subject to `n_j . y - b_j s >= t`, `-1 <= y <= 1`,
//! `0 <= s <= 1`, `t <= 1`: the largest margin in the infinity-norm ball of a
//! homogenised problem. `t > 0` means feasible, and `x = y / s` (or `y`
//! scaled up when `s = 0`) satisfies `G x >= h`. This is a feasible point of
//! largest margin, *not* the least-distance optimum: compare it with the
//! other backends on feasibility, depth and constraint satisfaction.

use crate::problem::dot;
use crate::{Error, LdpProblem, LdpSolver, Solution, SolveOptions, Status};
use good_lp::{
    variable, Expression, ProblemVariables, ResolutionError, Solution as _, SolverModel,
};

/// good_lp + microlp on the LP form.
#[derive(Debug, Clone, Copy, Default)]
pub struct GoodLpSolver;

impl LdpSolver for GoodLpSolver {
    fn name(&self) -> &'static str {
        "good_lp"
    }

    fn solve(&self, problem: &LdpProblem, _options: &SolveOptions) -> Result<Solution, Error> {
        let (m, n) = (problem.rows(), problem.cols());
        let norms = problem.row_norms();
        let infeasible = || {
            Solution::measured(
                problem,
                Status::Infeasible,
                vec![0.0; n],
                0,
                vec![],
                "good_lp",
            )
        };
        let mut vars = ProblemVariables::new();
        let y: Vec<_> = (0..n)
            .map(|_| vars.add(variable().min(-1.0).max(1.0)))
            .collect();
        let s = vars.add(variable().min(0.0).max(1.0));
        let t = vars.add(variable().max(1.0));
        let mut model = vars.maximise(t).using(good_lp::microlp);
        let g = problem.g();
        let row = |j: usize| &g[j * n..(j + 1) * n];
        for j in 0..m {
            if norms[j] == 0.0 {
                if problem.h()[j] > 0.0 {
                    return Ok(infeasible());
                }
                continue;
            }
            let inv = 1.0 / norms[j];
            let mut e = Expression::with_capacity(n + 2);
            for (k, yk) in y.iter().enumerate() {
                e.add_mul(row(j)[k] * inv, *yk);
            }
            e.add_mul(-problem.h()[j] * inv, s);
            e.add_mul(-1.0, t);
            model = model.with(e.geq(0.0));
        }
        let sol = match model.solve() {
            Ok(sol) => sol,
            Err(ResolutionError::Infeasible) => return Ok(infeasible()),
            Err(e) => {
                return Err(Error::BackendFailure {
                    backend: "good_lp",
                    message: e.to_string(),
                })
            }
        };
        let tv = sol.value(t);
        let sv = sol.value(s);
        let yv: Vec<f64> = y.iter().map(|v| sol.value(*v)).collect();
        if tv <= 0.0 {
            return Ok(infeasible());
        }
        let x: Vec<f64> = if sv > 1e-9 {
            yv.iter().map(|v| v / sv).collect()
        } else {
            // A recession direction: scale until every row with h > 0 holds.
            let k = (0..m)
                .filter(|&j| problem.h()[j] > 0.0)
                .map(|j| problem.h()[j] / dot(row(j), &yv))
                .fold(1.0_f64, f64::max);
            yv.iter().map(|v| v * k).collect()
        };
        Ok(Solution::measured(
            problem,
            Status::Solved,
            x,
            0,
            Vec::new(),
            "good_lp",
        ))
    }
}
