//! One test body, run on every compiled backend (pbrt/Mitsuba style): known
//! optima, infeasibility, duplicate and near-parallel rows, extreme row
//! scales and tiny margins. A backend that cannot cope must say so through
//! its status or through our residual check, never by a silently wrong
//! "verified" point.

use qp_backends::tolerance::rounding_tolerance;
use qp_backends::{Backend, LdpProblem, Solution, SolveOptions, Status};

/// How close each backend is documented to get to the least-distance optimum
/// (relative error in x) on a problem of condition number `cond`. The native
/// solver is backward stable, so its forward error is rounding times `cond`;
/// the interior-point and ADMM backends stop at their own tolerances. `None`:
/// the backend solves the LP form, whose point is feasible but not least-norm.
fn optimum_accuracy(b: Backend, n: usize, cond: f64) -> Option<f64> {
    match b {
        Backend::Native => Some(rounding_tolerance(n) * cond),
        Backend::Clarabel => Some(1e-6 * cond),
        Backend::Osqp => Some(1e-3 * cond),
        Backend::GoodLp => None,
        other => panic!("{other}: its accuracy is not stated in this test"),
    }
}

/// Infeasibility must be reported as such; OSQP's ADMM may instead run out of
/// iterations, which still says "no solution" (never a verified point).
fn check_infeasible(name: &str, p: &LdpProblem) {
    for b in Backend::available() {
        let s = solve(b, p);
        assert!(
            !s.is_verified(),
            "{name}/{b}: verified point on an infeasible problem"
        );
        if b == Backend::Osqp && s.status == Status::IterationLimit {
            eprintln!(
                "{name}/{b}: stopped at the iteration limit instead of detecting infeasibility"
            );
            continue;
        }
        assert_eq!(s.status, Status::Infeasible, "{name}/{b}");
    }
}

fn solve(b: Backend, p: &LdpProblem) -> Solution {
    b.solve(p, &SolveOptions::default())
        .unwrap_or_else(|e| panic!("{b}: {e}"))
}

fn rel_err(x: &[f64], want: &[f64]) -> f64 {
    let d: f64 = x
        .iter()
        .zip(want)
        .map(|(a, b)| (a - b) * (a - b))
        .sum::<f64>()
        .sqrt();
    let n: f64 = want.iter().map(|a| a * a).sum::<f64>().sqrt();
    d / n.max(f64::MIN_POSITIVE)
}

/// The shared body for problems with a known least-distance optimum.
fn check_known_optimum(name: &str, p: &LdpProblem, want: &[f64], cond: f64) {
    for b in Backend::available() {
        let s = solve(b, p);
        let claimed = matches!(s.status, Status::Solved | Status::Inaccurate);
        if b == Backend::Native {
            assert!(
                s.is_verified(),
                "{name}/{b}: {:?} {:?}",
                s.status,
                s.residuals
            );
        }
        if s.claims_solved_but_violates() {
            // The verifier caught a bad point: acceptable only for ADMM.
            assert_eq!(
                b,
                Backend::Osqp,
                "{name}/{b}: solved but violates {:?}",
                s.residuals
            );
            eprintln!(
                "{name}/{b}: reported solved, verifier found violation {:.3e}",
                s.residuals.max_violation
            );
            continue;
        }
        if !claimed {
            assert_ne!(
                b,
                Backend::Native,
                "{name}: native failed with {:?}",
                s.status
            );
            eprintln!("{name}/{b}: gave up with status {}", s.status);
            continue;
        }
        match optimum_accuracy(b, p.cols(), cond) {
            Some(tol) if s.is_verified() => {
                let e = rel_err(&s.x, want);
                assert!(
                    e <= tol,
                    "{name}/{b}: relative error {e:.3e} > {tol:.0e}, x = {:?}",
                    s.x
                );
            }
            _ => assert!(s.is_verified(), "{name}/{b}: {:?}", s.residuals),
        }
    }
}

#[test]
fn axis_bounds() {
    let p = LdpProblem::from_rows(&[vec![1.0, 0.0], vec![0.0, 1.0]], vec![1.0, 2.0]).unwrap();
    check_known_optimum("axis_bounds", &p, &[1.0, 2.0], 1.0);
}

#[test]
fn single_halfspace_with_inactive_rows() {
    // x1 + x2 >= 2 gives (1, 1); x1 >= -5 and x2 >= -3 stay inactive.
    let p = LdpProblem::from_rows(
        &[
            vec![1.0, 1.0, 0.0],
            vec![1.0, 0.0, 0.0],
            vec![0.0, 1.0, 0.0],
        ],
        vec![2.0, -5.0, -3.0],
    )
    .unwrap();
    check_known_optimum("single_halfspace", &p, &[1.0, 1.0, 0.0], 1.0);
}

#[test]
fn constraint_that_must_be_dropped() {
    // Adding x1 + x2 >= 4 after x1 >= 1 makes x1 >= 1 inactive: optimum (2, 2).
    let p = LdpProblem::from_rows(&[vec![1.0, 0.0], vec![1.0, 1.0]], vec![1.5, 4.0]).unwrap();
    check_known_optimum("drop", &p, &[2.0, 2.0], 3.0);
}

#[test]
fn infeasible_pair_is_detected() {
    let p = LdpProblem::from_rows(
        &[vec![1.0, 0.0], vec![-1.0, 0.0], vec![0.0, 1.0]],
        vec![1.0, 1.0, 0.0],
    )
    .unwrap();
    check_infeasible("pair", &p);
}

#[test]
fn infeasible_cycle_is_detected() {
    // x1 >= 1, x2 >= 1, -x1 - x2 >= -1: infeasible, but every pair is feasible.
    let p = LdpProblem::from_rows(
        &[vec![1.0, 0.0], vec![0.0, 1.0], vec![-1.0, -1.0]],
        vec![1.0, 1.0, -1.0],
    )
    .unwrap();
    check_infeasible("cycle", &p);
}

#[test]
fn zero_row_with_positive_h_is_infeasible() {
    let p = LdpProblem::from_rows(&[vec![0.0, 0.0], vec![1.0, 0.0]], vec![1.0, 1.0]).unwrap();
    assert_eq!(solve(Backend::Native, &p).status, Status::Infeasible);
}

#[test]
fn duplicate_rows() {
    let rows = vec![
        vec![1.0, 0.0],
        vec![1.0, 0.0],
        vec![0.0, 1.0],
        vec![1.0, 0.0],
        vec![0.0, 1.0],
    ];
    let p = LdpProblem::from_rows(&rows, vec![1.0, 1.0, 2.0, 1.0, 2.0]).unwrap();
    check_known_optimum("duplicates", &p, &[1.0, 2.0], 1.0);
}

#[test]
fn near_parallel_rows() {
    let e = 1e-6;
    let p = LdpProblem::from_rows(&[vec![1.0, 0.0], vec![1.0, e]], vec![1.0, 1.0 + e]).unwrap();
    // Only the second row is active: x = h a / ||a||^2.
    let k = (1.0 + e) / (1.0 + e * e);
    check_known_optimum("near_parallel", &p, &[k, k * e], 1.0);
}

#[test]
fn rows_scaled_by_extreme_factors() {
    let p = LdpProblem::from_rows(&[vec![1e-12, 0.0], vec![0.0, 1e12]], vec![1e-12, 2e12]).unwrap();
    check_known_optimum("scaled_rows", &p, &[1.0, 2.0], 1.0);
}

/// A thin cone of depth `d` around the unit direction `axis` in `n`
/// dimensions: rows `d axis +- sqrt(1 - d^2) e_k` for directions `e_k`
/// orthogonal to the axis, `h = 1`. The optimum is `axis / d`.
fn thin_cone(n: usize, d: f64) -> (LdpProblem, Vec<f64>) {
    // axis = e_0 rotated a little so that no coordinate is special.
    let mut axis: Vec<f64> = (0..n).map(|k| 1.0 / (k as f64 + 2.0)).collect();
    let na = axis.iter().map(|v| v * v).sum::<f64>().sqrt();
    axis.iter_mut().for_each(|v| *v /= na);
    // Gram-Schmidt complement of the axis.
    let mut basis: Vec<Vec<f64>> = Vec::new();
    for k in 0..n {
        let mut e = vec![0.0; n];
        e[k] = 1.0;
        for b in std::iter::once(&axis).chain(basis.iter()) {
            let c: f64 = e.iter().zip(b).map(|(x, y)| x * y).sum();
            e.iter_mut().zip(b).for_each(|(x, y)| *x -= c * y);
        }
        let ne = e.iter().map(|v| v * v).sum::<f64>().sqrt();
        if ne > 1e-8 && basis.len() < n - 1 {
            basis.push(e.iter().map(|v| v / ne).collect());
        }
    }
    let s = (1.0 - d * d).sqrt();
    let mut rows = Vec::new();
    for b in &basis {
        for sign in [1.0, -1.0] {
            rows.push(
                axis.iter()
                    .zip(b)
                    .map(|(a, w)| d * a + sign * s * w)
                    .collect(),
            );
        }
    }
    let h = vec![1.0; rows.len()];
    let want = axis.iter().map(|a| a / d).collect();
    (LdpProblem::from_rows(&rows, h).unwrap(), want)
}

#[test]
fn tiny_margins_down_to_1e_minus_9() {
    for d in [1e-3, 1e-5, 1e-7, 1e-9] {
        for n in [2, 6, 22] {
            let (p, want) = thin_cone(n, d);
            let s = solve(Backend::Native, &p);
            assert!(
                s.is_verified(),
                "d={d:e} n={n}: {:?} {:?}",
                s.status,
                s.residuals
            );
            // Exact: the slack ratio is 1 to rounding and the depth is d.
            assert!(
                (s.residuals.min_slack_ratio - 1.0).abs() < 1e-6,
                "d={d:e} n={n}: {:?}",
                s.residuals
            );
            assert!(
                (s.residuals.depth / d - 1.0).abs() < 1e-6,
                "d={d:e} n={n}: {:?}",
                s.residuals
            );
            assert!(rel_err(&s.x, &want) < 1e-6, "d={d:e} n={n}");
            assert!(s.active_set.len() <= n);
        }
        let (p, want) = thin_cone(6, d);
        check_known_optimum(&format!("thin_cone_{d:e}"), &p, &want, 1.0 / d);
    }
}

#[test]
fn constraint_generation_matches_full_solve() {
    // Many rows tangent to a circle-like polytope in 3-D: x . n_j >= 1.
    let mut rows = Vec::new();
    for i in 0..40_000usize {
        let t = i as f64 * 0.618_033_988_75;
        let z = 0.5 + 0.5 * ((i as f64 + 0.5) / 40_000.0);
        let r = (1.0 - z * z).sqrt();
        rows.push(vec![
            r * (t * std::f64::consts::TAU).cos(),
            r * (t * std::f64::consts::TAU).sin(),
            z,
        ]);
    }
    let h = vec![1.0; rows.len()];
    let p = LdpProblem::from_rows(&rows, h).unwrap();
    let full = Backend::Native
        .solve(
            &p,
            &SolveOptions::default().with_working_set_threshold(usize::MAX),
        )
        .unwrap();
    let gen = Backend::Native
        .solve(&p, &SolveOptions::default().with_working_set_threshold(100))
        .unwrap();
    assert!(full.is_verified() && gen.is_verified());
    assert!(
        rel_err(&gen.x, &full.x) < 1e-10,
        "{:?} vs {:?}",
        gen.x,
        full.x
    );
    // Warm start from the active set reproduces it.
    let warm = Backend::Native
        .solve(
            &p,
            &SolveOptions::default()
                .with_working_set_threshold(100)
                .with_warm_start(gen.active_set.clone()),
        )
        .unwrap();
    assert!(rel_err(&warm.x, &full.x) < 1e-10);
    assert!(warm.iterations <= gen.iterations);
}

/// Solves the symmetric positive definite system `a y = b` (Cholesky).
fn spd_solve(mut a: Vec<Vec<f64>>, mut b: Vec<f64>) -> Vec<f64> {
    let q = b.len();
    for k in 0..q {
        a[k][k] = (a[k][k] - (0..k).map(|j| a[k][j] * a[k][j]).sum::<f64>()).sqrt();
        for i in k + 1..q {
            a[i][k] = (a[i][k] - (0..k).map(|j| a[i][j] * a[k][j]).sum::<f64>()) / a[k][k];
        }
    }
    for i in 0..q {
        b[i] = (b[i] - (0..i).map(|j| a[i][j] * b[j]).sum::<f64>()) / a[i][i];
    }
    for i in (0..q).rev() {
        b[i] = (b[i] - (i + 1..q).map(|j| a[j][i] * b[j]).sum::<f64>()) / a[i][i];
    }
    b
}

#[test]
fn large_working_sets_reach_the_kkt_point() {
    // 20,000 rows in 24 variables: working sets this large are priced
    // partially (only the rows closest to violation between full passes).
    // The answer must still be the optimum: x = G_A^T u with u >= 0 and the
    // active rows tight, computed here independently of the solver.
    let (m, n) = (20_000usize, 24usize);
    let mut state = 0x9e37_79b9_7f4a_7c15_u64;
    let mut next = move || {
        state ^= state << 13;
        state ^= state >> 7;
        state ^= state << 17;
        (state >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    };
    let rows: Vec<Vec<f64>> = (0..m)
        .map(|_| {
            let mut r: Vec<f64> = (0..n).map(|_| next()).collect();
            r[0] = 0.2 + r[0].abs(); // x = t e_0 is feasible for large t
            r
        })
        .collect();
    let h: Vec<f64> = (0..m).map(|_| 1.0 + next()).collect();
    let p = LdpProblem::from_rows(&rows, h.clone()).unwrap();
    for options in [
        SolveOptions::default().with_working_set_threshold(usize::MAX),
        SolveOptions::default(),
    ] {
        let s = Backend::Native.solve(&p, &options).unwrap();
        assert!(s.is_verified(), "{:?}", s.status);
        let a = &s.active_set;
        assert!(!a.is_empty() && a.len() <= n);
        let gram: Vec<Vec<f64>> = a
            .iter()
            .map(|&i| a.iter().map(|&j| dot(&rows[i], &rows[j])).collect())
            .collect();
        let u = spd_solve(gram, a.iter().map(|&i| h[i]).collect());
        assert!(u.iter().all(|&v| v > 0.0), "multipliers {u:?}");
        let kkt: Vec<f64> = (0..n)
            .map(|c| a.iter().zip(&u).map(|(&i, uk)| uk * rows[i][c]).sum())
            .collect();
        assert!(rel_err(&s.x, &kkt) < 1e-9, "{:?} vs {kkt:?}", s.x);
    }
}

fn dot(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| x * y).sum()
}

#[test]
fn unknown_and_missing_backends_are_errors() {
    assert!("gurobi".parse::<Backend>().is_err());
    for b in Backend::ALL {
        if !b.is_compiled() {
            let p = LdpProblem::from_rows(&[vec![1.0]], vec![1.0]).unwrap();
            let err = b.solve(&p, &SolveOptions::default()).unwrap_err();
            assert!(err.to_string().contains("not compiled"), "{err}");
        }
    }
}

/// A set cancel flag stops every backend with `Status::Cancelled` and no
/// verified point; the native solver also checks it inside its loop (called
/// here directly, past `Backend::solve`'s check before the start).
#[test]
fn a_set_cancel_flag_stops_every_backend() {
    use qp_backends::{CancelFlag, LdpSolver, NativeSolver};
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    // x1 >= 1, x2 >= 1: two active-set changes are needed.
    let p = LdpProblem::new(vec![1.0, 0.0, 0.0, 1.0], vec![1.0, 1.0], 2).unwrap();
    let flag = Arc::new(AtomicBool::new(true));
    let options = SolveOptions::default().with_cancel(CancelFlag::new(flag.clone()));
    for b in Backend::available() {
        let s = b.solve(&p, &options).unwrap();
        assert_eq!(s.status, Status::Cancelled, "{b}");
        assert!(!s.is_verified(), "{b}");
    }
    let s = NativeSolver.solve(&p, &options).unwrap();
    assert_eq!(s.status, Status::Cancelled);
    assert!(!s.is_verified());
    flag.store(false, std::sync::atomic::Ordering::Relaxed);
    let s = NativeSolver.solve(&p, &options).unwrap();
    assert_eq!(s.status, Status::Solved);
    assert!(rel_err(&s.x, &[1.0, 1.0]) < 1e-12);
}

/// An interval fit's rows generated from its design matrix: `lo_i <=
/// p(t_i) / q(t_i) <= hi_i` for `exp(t)` on [-1, 1] with monomials.
fn interval_problem(
    samples: usize,
    (n_p, n_q): (usize, usize),
    rel: f64,
    extra: &[Vec<f64>],
) -> LdpProblem {
    let width = n_p.max(n_q) + 1;
    let mut design = Vec::new();
    let (mut lo, mut hi) = (Vec::new(), Vec::new());
    for i in 0..samples {
        let t = -1.0 + 2.0 * i as f64 / (samples - 1) as f64;
        design.extend((0..width).map(|k| t.powi(k as i32)));
        lo.push(t.exp() * (1.0 - rel));
        hi.push(t.exp() * (1.0 + rel));
    }
    LdpProblem::from_intervals(design.into(), width, (n_p, n_q), lo, hi, extra).unwrap()
}

#[test]
fn generated_rows_solve_as_their_dense_matrix_on_every_backend() {
    let extra = vec![vec![0.0, 0.0, 0.0, 1.0, 0.5]];
    for (rel, feasible) in [(1e-2, true), (1e-6, false)] {
        let generated = interval_problem(400, (3, 2), rel, &extra);
        assert_eq!(generated.rows(), 801);
        let dense = LdpProblem::new(generated.g().into_owned(), generated.h().to_vec(), 5).unwrap();
        // The rows are unit rows, and G x agrees with the stored matrix.
        // (the extra row is used as given).
        let norms = generated.row_norms();
        for (j, n) in norms[..800].iter().enumerate() {
            assert!((n - 1.0).abs() < 1e-15, "row {j}: {n}");
        }
        assert!((norms[800] - 1.25f64.sqrt()).abs() < 1e-15);
        let x = [0.3, -1.0, 2.0, 0.5, -0.25];
        let (mut a, mut b) = (vec![0.0; 801], vec![0.0; 801]);
        generated.products(&x, &mut a);
        dense.products(&x, &mut b);
        assert!(a
            .iter()
            .zip(&b)
            .all(|(u, v)| (u - v).abs() <= 1e-14 * (1.0 + v.abs())));
        for backend in Backend::available() {
            let g = solve(backend, &generated);
            let d = solve(backend, &dense);
            if backend == Backend::Native {
                assert_eq!(g.status, d.status, "{backend} rel {rel}");
                assert_eq!(
                    g.is_verified(),
                    feasible,
                    "{backend} rel {rel}: {:?}",
                    g.residuals
                );
            }
            if !feasible {
                // Rounding-level differences may change an LP or ADMM
                // backend's status, never into a verified point.
                assert!(!g.is_verified() && !d.is_verified(), "{backend} rel {rel}");
            }
            if g.is_verified() && d.is_verified() && optimum_accuracy(backend, 5, 1.0).is_some() {
                let tol = if backend == Backend::Native {
                    1e-8
                } else {
                    1e-3
                };
                assert!(
                    rel_err(&g.x, &d.x) < tol,
                    "{backend}: {:?} vs {:?}",
                    g.x,
                    d.x
                );
            }
        }
    }
}

#[test]
fn interval_problems_refuse_bad_sizes_and_values() {
    let design: std::sync::Arc<[f64]> = vec![1.0, 0.5, 1.0, -0.5].into();
    let ok = |lo: f64| {
        LdpProblem::from_intervals(
            design.clone(),
            2,
            (1, 1),
            vec![lo, 1.0],
            vec![2.0, 2.0],
            &[],
        )
    };
    assert!(ok(0.5).is_ok());
    assert!(ok(f64::NAN).is_err());
    assert!(
        LdpProblem::from_intervals(design.clone(), 2, (3, 1), vec![1.0; 2], vec![2.0; 2], &[])
            .is_err()
    );
    assert!(
        LdpProblem::from_intervals(design.clone(), 2, (1, 0), vec![1.0; 2], vec![2.0; 2], &[])
            .is_err()
    );
    assert!(
        LdpProblem::from_intervals(design.clone(), 2, (1, 1), vec![1.0; 3], vec![2.0; 3], &[])
            .is_err()
    );
    assert!(LdpProblem::from_intervals(
        design,
        2,
        (1, 1),
        vec![1.0; 2],
        vec![2.0; 2],
        &[vec![1.0]]
    )
    .is_err());
}

#[test]
fn the_native_solver_returns_rows_that_prove_infeasibility() {
    // The cycle of `infeasible_cycle_is_detected` among feasible rows, with
    // a working set small enough to be generated: the rows returned must
    // be infeasible on their own (the proof a caller can keep), and all
    // three rows of the cycle are needed for that.
    let mut rows = vec![vec![1.0, 0.0], vec![0.0, 1.0], vec![-1.0, -1.0]];
    let mut h = vec![1.0, 1.0, -1.0];
    for k in 0..600 {
        let t = k as f64 * 0.01;
        rows.push(vec![t.cos(), t.sin()]);
        h.push(-10.0);
    }
    let p = LdpProblem::from_rows(&rows, h.clone()).unwrap();
    let options = SolveOptions::default().with_working_set_threshold(64);
    let s = Backend::Native.solve(&p, &options).unwrap();
    assert_eq!(s.status, Status::Infeasible);
    for j in 0..3 {
        assert!(s.active_set.contains(&j), "row {j} in {:?}", s.active_set);
    }
    let proof: Vec<Vec<f64>> = s.active_set.iter().map(|&j| rows[j].clone()).collect();
    let proof_h = s.active_set.iter().map(|&j| h[j]).collect();
    let q = LdpProblem::from_rows(&proof, proof_h).unwrap();
    assert_eq!(solve(Backend::Native, &q).status, Status::Infeasible);
}
