use super::*;

fn naive(family: BasisFamily, k: usize, t: f64) -> f64 {
    match family {
        BasisFamily::Monomial => t.powi(k as i32),
        BasisFamily::Chebyshev => (k as f64 * t.acos()).cos(),
        BasisFamily::Legendre => {
            // Rodrigues-free explicit sum: P_k(t) = 2^-k sum C(k,i)^2 (t-1)^(k-i) (t+1)^i
            let mut s = 0.0;
            for i in 0..=k {
                let c = binom(k, i);
                s += c * c * (t - 1.0).powi((k - i) as i32) * (t + 1.0).powi(i as i32);
            }
            s / 2f64.powi(k as i32)
        }
    }
}

fn binom(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

#[test]
fn graded_order_in_two_variables() {
    let idx = graded_indices(2, 6);
    assert_eq!(
        idx,
        vec![
            vec![0, 0],
            vec![1, 0],
            vec![0, 1],
            vec![2, 0],
            vec![1, 1],
            vec![0, 2]
        ]
    );
    assert_eq!(graded_indices(3, 10).len(), 10);
}

#[test]
fn weighted_order_spends_degree_where_it_is_cheap() {
    // Weighted degrees 0, 1, 2, 2, 3, 3, 4, 4, 4 with weights (1, 2).
    assert_eq!(
        weighted_graded_indices(&[1, 2], 9),
        vec![
            vec![0, 0],
            vec![1, 0],
            vec![2, 0],
            vec![0, 1],
            vec![3, 0],
            vec![1, 1],
            vec![4, 0],
            vec![2, 1],
            vec![0, 2]
        ]
    );
    assert_eq!(
        weighted_graded_indices(&[1, 1, 1], 35),
        graded_indices(3, 35)
    );
    // Every prefix is a lower set: lowering any exponent gives an earlier index.
    let idx = weighted_graded_indices(&[1, 3, 2], 80);
    for (j, a) in idx.iter().enumerate() {
        for k in 0..3 {
            if a[k] > 0 {
                let mut b = a.clone();
                b[k] -= 1;
                let pos = idx.iter().position(|c| *c == b).expect("lower set");
                assert!(pos < j);
            }
        }
    }
    let mut sorted = idx.clone();
    sorted.sort();
    sorted.dedup();
    assert_eq!(sorted.len(), idx.len(), "no index twice");
}

#[test]
fn weighted_basis_round_trips_and_checks_its_weights() {
    let d = Domain::new(vec![0.0, -1.0], vec![1.0, 2.0]).unwrap();
    let b = Basis::weighted(BasisFamily::Chebyshev, d.clone(), 12, &[1, 3]).unwrap();
    assert!(b.is_weighted());
    assert_eq!(b.degree_in(0, 12), 6);
    assert_eq!(b.degree_in(1, 12), 2);
    let json = serde_json::to_string(&b).unwrap();
    assert!(json.contains("degree_weights"));
    let back: Basis = serde_json::from_str(&json).unwrap();
    assert_eq!(back, b);
    assert_eq!(b.with_len(5).unwrap().multi_index(4), b.multi_index(4));
    // Unweighted bases serialise as before weights existed.
    let plain = Basis::new(BasisFamily::Chebyshev, d.clone(), 6).unwrap();
    let json = serde_json::to_string(&plain).unwrap();
    assert!(!json.contains("degree_weights"), "{json}");
    assert_eq!(serde_json::from_str::<Basis>(&json).unwrap(), plain);
    for bad in [vec![1], vec![0, 1], vec![1, MAX_DEGREE_WEIGHT + 1]] {
        let err = Basis::weighted(BasisFamily::Chebyshev, d.clone(), 4, &bad).unwrap_err();
        assert!(err.to_string().contains("weight"), "{err}");
    }
}

#[test]
fn value_and_partial_agree_with_every_function_s_gradient() {
    for family in [
        BasisFamily::Monomial,
        BasisFamily::Chebyshev,
        BasisFamily::Legendre,
    ] {
        // 40 functions fit the small tables, 200 the large ones; 150 in
        // one coordinate and 5 coordinates take the heap; 1 and 4
        // coordinates the sums not unrolled.
        for (dim, len) in [
            (2usize, 40),
            (3, 40),
            (2, 200),
            (3, 200),
            (1, 150),
            (4, 60),
            (5, 60),
        ] {
            let domain = Domain {
                lower: vec![0.0; dim],
                upper: vec![2.0; dim],
            };
            let b = Basis::new(family, domain, len).unwrap();
            let a: Vec<f64> = (0..b.len())
                .map(|j| ((j * 7 % 11) as f64 - 5.0) / 3.0)
                .collect();
            let c: Vec<f64> = (0..b.len()).map(|j| 1.0 / (1.0 + j as f64)).collect();
            let x: Vec<f64> = (0..dim).map(|k| 0.3 + 0.4 * k as f64).collect();
            // The reference: every function's value and gradient.
            let mut values = vec![0.0; b.len()];
            let mut grad = vec![vec![0.0; b.len()]; dim];
            b.eval_with_gradient(&x, &mut values, &mut grad);
            let dot = |u: &[f64], v: &[f64]| u.iter().zip(v).map(|(p, q)| p * q).sum::<f64>();
            for k in 0..dim {
                let fast = b.combine_with_partial(&x, k, &a, &c);
                let slow = [
                    dot(&values, &a),
                    dot(&values, &c),
                    dot(&grad[k], &a),
                    dot(&grad[k], &c),
                ];
                for (u, v) in fast.iter().zip(&slow) {
                    assert!(
                        (u - v).abs() <= 1e-12 * (1.0 + v.abs()),
                        "{fast:?} {slow:?}"
                    );
                }
            }
        }
    }
}

#[test]
fn values_match_closed_forms() {
    for family in [
        BasisFamily::Monomial,
        BasisFamily::Chebyshev,
        BasisFamily::Legendre,
    ] {
        for &t in &[-1.0, -0.7, 0.0, 0.3, 0.99, 1.0] {
            let mut v = vec![0.0; 13];
            family.values(t, &mut v, None);
            for (k, vk) in v.iter().enumerate() {
                let want = naive(family, k, t);
                assert!(
                    (vk - want).abs() <= 1e-12 * want.abs().max(1.0),
                    "{family} k={k} t={t}"
                );
            }
        }
    }
}

#[test]
fn clenshaw_matches_sum() {
    let d = Domain::new(vec![-2.0], vec![3.0]).unwrap();
    let c: Vec<f64> = (0..9)
        .map(|k| ((k * 7 % 5) as f64 - 2.0) / (k as f64 + 1.0))
        .collect();
    for family in [
        BasisFamily::Monomial,
        BasisFamily::Chebyshev,
        BasisFamily::Legendre,
    ] {
        let b = Basis::new(family, d.clone(), 9).unwrap();
        for &x in &[-2.0, -1.1, 0.4, 2.9, 3.0] {
            let mut phi = vec![0.0; 9];
            b.eval_into(&[x], &mut phi);
            let sum: f64 = phi.iter().zip(&c).map(|(a, b)| a * b).sum();
            assert!((b.combine(&c, &[x]) - sum).abs() < 1e-12, "{family} x={x}");
        }
    }
}

#[test]
fn derivatives_match_finite_differences() {
    let d = Domain::new(vec![0.0, -1.0], vec![2.0, 5.0]).unwrap();
    for family in [
        BasisFamily::Monomial,
        BasisFamily::Chebyshev,
        BasisFamily::Legendre,
    ] {
        let b = Basis::new(family, d.clone(), 21).unwrap();
        let x = [0.7, 2.2];
        let mut v = vec![0.0; 21];
        let mut g = vec![vec![0.0; 21]; 2];
        b.eval_with_gradient(&x, &mut v, &mut g);
        for k in 0..2 {
            let h = 1e-6;
            let mut xp = x;
            let mut xm = x;
            xp[k] += h;
            xm[k] -= h;
            let (mut vp, mut vm) = (vec![0.0; 21], vec![0.0; 21]);
            b.eval_into(&xp, &mut vp);
            b.eval_into(&xm, &mut vm);
            for j in 0..21 {
                let fd = (vp[j] - vm[j]) / (2.0 * h);
                assert!(
                    (fd - g[k][j]).abs() < 1e-6 * fd.abs().max(1.0),
                    "{family} k={k} j={j}: {fd} vs {}",
                    g[k][j]
                );
            }
        }
    }
}

#[test]
fn power_coefficients_reproduce_values() {
    for family in [
        BasisFamily::Monomial,
        BasisFamily::Chebyshev,
        BasisFamily::Legendre,
    ] {
        let pc = family.power_coefficients(10);
        let mut v = vec![0.0; 11];
        family.values(0.37, &mut v, None);
        for k in 0..=10 {
            let s: f64 = pc[k]
                .iter()
                .enumerate()
                .map(|(j, c)| c * 0.37f64.powi(j as i32))
                .sum();
            assert!((s - v[k]).abs() < 1e-12, "{family} {k}");
        }
    }
}
