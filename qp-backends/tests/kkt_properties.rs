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
