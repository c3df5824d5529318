//! Invariances of the fit (proptest, seeded): scaling the values scales the
//! fit; permuting the samples or duplicating one changes nothing; an affine
//! change of the domain gives the same function.

use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use rational_core::{fit, FitReport, FitSettings, IntervalData, Selection};

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 32,
        rng_seed: RngSeed::Fixed(0x1A7E_2012),
        ..ProptestConfig::default()
    }
}

fn settings() -> FitSettings {
    FitSettings::default()
        .with_coeff_range(2, 12)
        .unwrap()
        .with_selection(Selection::Depth)
}

fn data(x: &[f64], f: impl Fn(f64) -> f64, t: f64) -> IntervalData {
    IntervalData::from_values_relative(1, x.to_vec(), x.iter().map(|&x| f(x)).collect(), t).unwrap()
}

fn same_fit(a: &FitReport, b: &FitReport, at: &[f64], scale: f64) -> Result<(), TestCaseError> {
    prop_assert_eq!((a.n_p, a.n_q), (b.n_p, b.n_q));
    prop_assert!(
        (a.depth / b.depth - 1.0).abs() < 1e-6,
        "depth {} vs {}",
        a.depth,
        b.depth
    );
    for &x in at {
        let (u, v) = (a.function.eval(&[x]), scale * b.function.eval(&[x]));
        prop_assert!(
            (u - v).abs() <= 1e-7 * u.abs().max(v.abs()),
            "at {}: {} vs {}",
            x,
            u,
            v
        );
    }
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn scaling_values_scales_the_fit(k in prop_oneof![Just(1e-9), Just(1e-3), Just(7.0), Just(1e6)], c in 1.0f64..20.0, t in 0.01f64..0.1) {
        let x: Vec<f64> = (0..300).map(|i| -1.0 + 2.0 * i as f64 / 299.0).collect();
        let f = |x: f64| 1.0 / (1.0 + c * x * x) + 0.2 * x;
        let a = fit(&data(&x, |x| k * (f(x) + 1.0), t), &settings()).unwrap();
        let b = fit(&data(&x, |x| f(x) + 1.0, t), &settings()).unwrap();
        same_fit(&a, &b, &[-0.9, -0.2, 0.4, 0.95], k)?;
    }

    #[test]
    fn permuting_or_duplicating_samples_changes_nothing(seed in 0u64..1000, dup in 0usize..200, c in 1.0f64..20.0) {
        let x: Vec<f64> = (0..200).map(|i| i as f64 / 199.0).collect();
        let f = |x: f64| (1.0 + c * x) / (1.0 + x * x);
        let base = fit(&data(&x, f, 0.02), &settings()).unwrap();
        // A deterministic permutation from the seed, plus one duplicate.
        let mut order: Vec<usize> = (0..200).collect();
        let mut g = ratfit_tests::SplitMix64::new(seed);
        for i in (1..200).rev() {
            order.swap(i, g.below(i + 1));
        }
        order.push(dup);
        let xp: Vec<f64> = order.iter().map(|&i| x[i]).collect();
        let other = fit(&data(&xp, f, 0.02), &settings()).unwrap();
        same_fit(&other, &base, &[0.1, 0.5, 0.77], 1.0)?;
    }

    #[test]
    fn affine_change_of_domain_gives_the_same_function(a in 0.01f64..100.0, b in -50.0f64..50.0, c in 1.0f64..20.0) {
        let x: Vec<f64> = (0..250).map(|i| i as f64 / 249.0).collect();
        let f = |x: f64| 1.0 / (1.0 + c * x * x) + 0.5;
        let base = fit(&data(&x, f, 0.02), &settings()).unwrap();
        let y: Vec<f64> = x.iter().map(|x| a * x + b).collect();
        let moved = fit(&data(&y, |y| f((y - b) / a), 0.02), &settings()).unwrap();
        prop_assert_eq!((moved.n_p, moved.n_q), (base.n_p, base.n_q));
        prop_assert!((moved.depth / base.depth - 1.0).abs() < 1e-5);
        for &t in &[0.05, 0.5, 0.93] {
            let (u, v) = (moved.function.eval(&[a * t + b]), base.function.eval(&[t]));
            prop_assert!((u - v).abs() <= 1e-6 * v.abs(), "{} vs {}", u, v);
        }
    }
}
