//! Property tests of the native solver: on random feasible problems its
//! point satisfies every row and the KKT conditions (x is a non-negative
//! combination of the active rows); warm starts change nothing.

use proptest::prelude::*;
use qp_backends::{Backend, LdpProblem, SolveOptions, Status};

fn kkt_multipliers(p: &LdpProblem, active: &[usize], x: &[f64]) -> (Vec<f64>, f64) {
    // Least squares N_A u = x by normal equations on a tiny system.
    let q = active.len();
    let n = p.cols();
    let mut a = vec![0.0; q * q];
    let mut b = vec![0.0; q];
    for i in 0..q {
        for j in 0..q {
            a[i * q + j] = (0..n)
                .map(|k| p.row(active[i])[k] * p.row(active[j])[k])
                .sum();
        }
        b[i] = (0..n).map(|k| p.row(active[i])[k] * x[k]).sum();
    }
    // Gaussian elimination with partial pivoting.
    for c in 0..q {
        let piv = (c..q)
            .max_by(|&i, &j| a[i * q + c].abs().total_cmp(&a[j * q + c].abs()))
            .unwrap();
        for k in 0..q {
            a.swap(c * q + k, piv * q + k);
        }
        b.swap(c, piv);
        for r in c + 1..q {
            let f = a[r * q + c] / a[c * q + c];
            for k in c..q {
                a[r * q + k] -= f * a[c * q + k];
            }
            b[r] -= f * b[c];
        }
    }
    let mut u = vec![0.0; q];
    for c in (0..q).rev() {
        let s: f64 = (c + 1..q).map(|k| a[c * q + k] * u[k]).sum();
        u[c] = (b[c] - s) / a[c * q + c];
    }
    let mut res = x.to_vec();
    for (i, &j) in active.iter().enumerate() {
        for k in 0..n {
            res[k] -= u[i] * p.row(j)[k];
        }
    }
    let rn = res.iter().map(|v| v * v).sum::<f64>().sqrt();
    let xn = x.iter().map(|v| v * v).sum::<f64>().sqrt();
    (u, rn / xn.max(1e-300))
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    #[test]
    fn random_feasible_problems_are_solved_exactly(
        n in 1usize..8,
        m in 1usize..60,
        seed in proptest::collection::vec(-1.0f64..1.0, 600),
        x0 in proptest::collection::vec(-3.0f64..3.0, 8),
    ) {
        let g: Vec<f64> = seed[..m * n].to_vec();
        let h: Vec<f64> = (0..m).map(|j| {
            let gx: f64 = (0..n).map(|k| g[j * n + k] * x0[k]).sum();
            gx - 0.1 * (1.0 + seed[(j + 7) % 600].abs())
        }).collect();
        let p = LdpProblem::new(g, h, n).unwrap();
        let s = Backend::Native.solve(&p, &SolveOptions::default()).unwrap();
        prop_assert_eq!(s.status, Status::Solved);
        prop_assert!(s.is_verified(), "{:?}", s.residuals);
        prop_assert!(s.active_set.len() <= n);
        let xn: f64 = s.x.iter().map(|v| v * v).sum::<f64>().sqrt();
        let x0n: f64 = x0[..n].iter().map(|v| v * v).sum::<f64>().sqrt();
        prop_assert!(xn <= x0n * (1.0 + 1e-12) + 1e-12, "not shorter than a feasible point");
        if !s.active_set.is_empty() {
            let (u, res) = kkt_multipliers(&p, &s.active_set, &s.x);
            prop_assert!(res < 1e-9, "x not in the span of active rows: {}", res);
            prop_assert!(u.iter().all(|&v| v > -1e-9), "negative multiplier {:?}", u);
        }
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 64, ..ProptestConfig::default() })]

    /// The dual method started from any rows (a neighbour's active set, a
    /// wrong guess, rows with negative multipliers) reaches the cold start's
    /// optimum, or its verdict of infeasibility.
    #[test]
    fn any_warm_start_reaches_the_cold_optimum(
        n in 1usize..8,
        m in 1usize..60,
        seed in proptest::collection::vec(-1.0f64..1.0, 600),
        x0 in proptest::collection::vec(-3.0f64..3.0, 8),
        feasible in any::<bool>(),
        warm in proptest::collection::vec(0usize..80, 0..12),
    ) {
        let g: Vec<f64> = seed[..m * n].to_vec();
        let h: Vec<f64> = (0..m).map(|j| {
            let gx: f64 = (0..n).map(|k| g[j * n + k] * x0[k]).sum();
            // Without the margin's sign flip some problems are infeasible.
            let margin = 0.1 * (1.0 + seed[(j + 7) % 600].abs());
            if feasible { gx - margin } else { seed[(j + 11) % 600].abs() + margin }
        }).collect();
        let p = LdpProblem::new(g, h, n).unwrap();
        let cold = Backend::Native.solve(&p, &SolveOptions::default()).unwrap();
        let hot = Backend::Native
            .solve(&p, &SolveOptions::default().with_warm_start(warm))
            .unwrap();
        prop_assert_eq!(cold.status, hot.status);
        if cold.status == Status::Solved {
            prop_assert!(hot.is_verified(), "{:?}", hot.residuals);
            let scale = cold.x.iter().map(|v| v * v).sum::<f64>().sqrt().max(1.0);
            let diff = cold.x.iter().zip(&hot.x).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt();
            prop_assert!(diff <= 1e-9 * scale, "cold {:?} warm {:?}", cold.x, hot.x);
        }
    }
}

/// Started from its own optimal active set the native solver needs no
/// further active-set change on a problem without constraint generation.
#[test]
fn the_optimal_active_set_is_a_fixed_point() {
    let n = 6;
    let rows: Vec<Vec<f64>> = (0..40)
        .map(|j| {
            (0..n)
                .map(|k| ((j * 7 + k * 3) as f64 * 0.37).sin() + if k == j % n { 2.0 } else { 0.0 })
                .collect()
        })
        .collect();
    let p = LdpProblem::from_rows(&rows, vec![1.0; rows.len()]).unwrap();
    let cold = Backend::Native.solve(&p, &SolveOptions::default()).unwrap();
    assert_eq!(cold.status, Status::Solved);
    assert!(cold.iterations > 0);
    let hot = Backend::Native
        .solve(
            &p,
            &SolveOptions::default().with_warm_start(cold.active_set.clone()),
        )
        .unwrap();
    assert_eq!(hot.status, Status::Solved);
    assert_eq!(hot.iterations, 0, "active set {:?}", cold.active_set);
    let diff: f64 = cold
        .x
        .iter()
        .zip(&hot.x)
        .map(|(a, b)| (a - b).abs())
        .fold(0.0, f64::max);
    assert!(diff < 1e-12, "{:?} vs {:?}", cold.x, hot.x);
}
