//! Bad input gets a named error; an impossible fit is reported as such;
//! widening recovers a fit when it is allowed.

use rational_core::{
    fit, Backend, FitError, FitSettings, Fitter, IntervalData, PoleControl, Search,
};

fn line(n: usize) -> Vec<f64> {
    (0..n).map(|i| i as f64 / (n - 1).max(1) as f64).collect()
}

#[test]
fn too_few_samples_is_named() {
    let d = IntervalData::from_values_relative(1, vec![0.5], vec![1.0], 0.1).unwrap();
    assert!(matches!(
        fit(&d, &FitSettings::default()),
        Err(FitError::TooFewSamples {
            samples: 1,
            coeffs: 2
        })
    ));
    let d = IntervalData::from_values_relative(1, line(5), vec![1.0; 5], 0.1).unwrap();
    assert!(matches!(
        Fitter::new(&d).split(4, 3),
        Err(FitError::TooFewSamples {
            samples: 5,
            coeffs: 7
        })
    ));
}

#[test]
fn conflicting_duplicates_are_infeasible() {
    // The same point with disjoint intervals: no function passes both.
    let d = IntervalData::new(
        1,
        vec![0.0, 0.5, 0.5, 1.0],
        vec![1.0, 1.0, 3.0, 1.0],
        vec![1.1, 1.1, 3.1, 1.1],
    )
    .unwrap();
    let s = FitSettings::default().with_coeff_range(2, 4).unwrap();
    match fit(&d, &s) {
        Err(FitError::NoFeasibleFit {
            max_coeffs: 4,
            splits,
            ..
        }) => {
            // Budgets 2, 3 and 4: 1 + 2 + 3 splits, none accepted, each with
            // its reason.
            assert_eq!(splits.len(), 6);
            assert!(splits.iter().all(|s| !s.accepted));
        }
        other => panic!("expected NoFeasibleFit, got {other:?}"),
    }
}

#[test]
fn a_set_cancel_flag_stops_the_sweep() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let x = line(200);
    let v: Vec<f64> = x.iter().map(|x| (8.0 * x).sin() + 2.0).collect();
    let d = IntervalData::from_values_relative(1, x, v, 1e-6).unwrap();
    let flag = Arc::new(AtomicBool::new(false));
    let s = FitSettings::default().with_cancel(flag.clone());
    // Unset, the flag changes nothing.
    let small = IntervalData::from_values_relative(1, line(50), vec![1.0; 50], 0.1).unwrap();
    assert!(fit(&small, &s).is_ok());
    flag.store(true, Ordering::Relaxed);
    match fit(&d, &s) {
        Err(e @ FitError::Cancelled { splits_tried: 0 }) => {
            assert!(e.to_string().contains("cancelled"), "{e}");
        }
        other => panic!("expected Cancelled, got {other:?}"),
    }
}

#[test]
fn any_of_several_cancel_flags_stops_the_sweep() {
    use std::sync::atomic::{AtomicBool, Ordering};
    use std::sync::Arc;
    let x = line(200);
    let v: Vec<f64> = x.iter().map(|x| (8.0 * x).sin() + 2.0).collect();
    let d = IntervalData::from_values_relative(1, x, v, 1e-6).unwrap();
    let (interrupt, own) = (
        Arc::new(AtomicBool::new(false)),
        Arc::new(AtomicBool::new(false)),
    );
    let s = FitSettings::default()
        .with_cancel(interrupt.clone())
        .with_cancel(own.clone());
    let small = IntervalData::from_values_relative(1, line(50), vec![1.0; 50], 0.1).unwrap();
    assert!(fit(&small, &s).is_ok());
    // The second flag alone stops it: adding a flag keeps the first.
    own.store(true, Ordering::Relaxed);
    assert!(matches!(
        fit(&d, &s),
        Err(FitError::Cancelled { splits_tried: 0 })
    ));
    own.store(false, Ordering::Relaxed);
    interrupt.store(true, Ordering::Relaxed);
    assert!(matches!(
        fit(&d, &s),
        Err(FitError::Cancelled { splits_tried: 0 })
    ));
}

#[test]
fn zero_width_intervals_have_no_strict_solution() {
    // P(n, m) asks for a positive margin; a zero-width interval has none.
    let x = line(20);
    let v: Vec<f64> = x.iter().map(|x| 1.0 + x).collect();
    let d = IntervalData::new(1, x, v.clone(), v).unwrap();
    let s = FitSettings::default().with_coeff_range(2, 6).unwrap();
    assert!(matches!(fit(&d, &s), Err(FitError::NoFeasibleFit { .. })));
}

#[test]
fn widening_recovers_a_fit_and_says_so() {
    let x = line(200);
    let v: Vec<f64> = x.iter().map(|x| (8.0 * x).sin() + 2.0).collect();
    let d = IntervalData::from_values_relative(1, x, v, 1e-4).unwrap();
    let strict = FitSettings::default().with_coeff_range(2, 5).unwrap();
    assert!(fit(&d, &strict).is_err());
    let report = fit(&d, &strict.with_widening(10.0, 4).unwrap()).unwrap();
    assert!(report.widenings > 0);
    assert!(report.verification.satisfied);
    assert!((report.interval_scale - 10f64.powi(report.widenings as i32)).abs() < 1e-9);
}

#[test]
fn widening_keeps_intervals_of_one_sign_away_from_zero() {
    let x = line(5);
    let d = IntervalData::new(
        1,
        x,
        vec![0.95, -1.05, -1.0, 2.0, 0.0],
        vec![1.05, -0.95, 1.0, 2.0, 3.0],
    )
    .unwrap();
    let w = d.widened(8.0);
    let log_half = |lo: f64, hi: f64| 0.5 * (hi / lo).ln().abs();
    for i in 0..2 {
        assert!(
            w.lo()[i] * d.lo()[i] > 0.0 && w.hi()[i] * d.hi()[i] > 0.0,
            "{i}: sign kept"
        );
        let ratio = log_half(w.lo()[i], w.hi()[i]) / log_half(d.lo()[i], d.hi()[i]);
        assert!((ratio - 8.0).abs() < 1e-9, "{i}: log half-width x{ratio}");
        assert!(
            (w.lo()[i] * w.hi()[i] - d.lo()[i] * d.hi()[i]).abs() < 1e-12,
            "{i}: geometric centre"
        );
    }
    // Across zero: the half-width about the centre; a point stays a point.
    assert_eq!((w.lo()[2], w.hi()[2]), (-8.0, 8.0));
    assert_eq!((w.lo()[3], w.hi()[3]), (2.0, 2.0));
    // Zero at one end stays there: non-negative data stay non-negative.
    assert_eq!((w.lo()[4], w.hi()[4]), (0.0, 24.0));
}

#[test]
fn invalid_settings_are_refused() {
    assert!(FitSettings::default().with_coeff_range(1, 5).is_err());
    assert!(FitSettings::default().with_coeff_range(6, 5).is_err());
    assert!(FitSettings::default().with_widening(1.0, 3).is_err());
    assert!(FitSettings::default().with_widening(f64::NAN, 3).is_err());
    for b in Backend::ALL {
        assert_eq!(
            FitSettings::default().with_backend(b).is_ok(),
            b.is_compiled()
        );
    }
}

#[test]
fn dense_grid_removes_a_pole_between_samples() {
    // Data of 1/(x - 0.5) sampled away from the pole, positive branch only
    // near the samples: a naive fit may put a sign change of q between them.
    let x: Vec<f64> = (0..40)
        .map(|i| {
            if i < 20 {
                i as f64 * 0.02
            } else {
                0.62 + (i - 20) as f64 * 0.02
            }
        })
        .collect();
    let v: Vec<f64> = x.iter().map(|x| 1.0 + 0.2 * x).collect();
    let d = IntervalData::from_values_relative(1, x, v, 0.01).unwrap();
    for poles in [
        PoleControl::DenseGrid {
            points_per_dim: 2001,
        },
        PoleControl::Bernstein { elevation: 3 },
    ] {
        let r = fit(
            &d,
            &FitSettings::default()
                .with_pole_control(poles)
                .with_coeff_range(2, 8)
                .unwrap(),
        )
        .unwrap();
        for i in 0..=2000 {
            let t = 0.98 * i as f64 / 2000.0;
            assert!(
                r.function.eval_parts(&[t]).1 > 0.0,
                "{poles:?}: q <= 0 at {t}"
            );
        }
    }
}

#[test]
fn a_report_round_trips_through_json() {
    // What `ratfit fit-csv` writes must read back: no extra rows leave the
    // margin infinite, which JSON writes as null.
    let x = line(100);
    let v: Vec<f64> = x.iter().map(|x| 1.0 / (1.0 + 25.0 * x * x)).collect();
    let d = IntervalData::from_values_relative(1, x, v, 0.01).unwrap();
    let report = fit(&d, &FitSettings::default()).unwrap();
    assert!(report.verification.extra_min_margin.is_infinite());
    let json = serde_json::to_string(&report).unwrap();
    let back: rational_core::FitReport = serde_json::from_str(&json).unwrap();
    assert_eq!(back.function, report.function);
    assert_eq!(back.verification, report.verification);
    assert_eq!(back.splits, report.splits);
}

/// `sin(8 x) + 2` at 200 points within `rel_tol`: budgets up to 8 fit it
/// from 1% (widened twice from 0.25%), not at 0.4% (widened twice from
/// 0.1%).
fn wave(rel_tol: f64) -> IntervalData {
    let x = line(200);
    let v: Vec<f64> = x.iter().map(|x| (8.0 * x).sin() + 2.0).collect();
    IntervalData::from_values_relative(1, x, v, rel_tol).unwrap()
}

fn up_to_8(search: Search, widenings: usize) -> FitSettings {
    FitSettings::default()
        .with_search(search)
        .with_coeff_range(2, 8)
        .unwrap()
        .with_widening(2.0, widenings)
        .unwrap()
}

#[test]
fn no_fit_at_the_widest_level_is_proved_by_its_largest_budget_alone() {
    for search in [Search::Exhaustive, Search::Staircase] {
        let d = wave(1e-3);
        let Err(FitError::NoFeasibleFit {
            splits,
            widenings: 2,
            ..
        }) = fit(&d, &up_to_8(search, 2))
        else {
            panic!("{search:?}: a fit within 8 coefficients at 0.4%");
        };
        // The exact intervals searched, the level between never solved,
        // and the widest level's seven splits of budget 8, each refused
        // with a certificate.
        assert!(splits.iter().any(|s| s.widenings == 0));
        assert!(splits.iter().all(|s| s.widenings != 1), "{search:?}");
        let widest: Vec<_> = splits.iter().filter(|s| s.widenings == 2).collect();
        let tops: Vec<_> = (1..8).map(|n_q| (8 - n_q, n_q)).collect();
        assert_eq!(
            widest.iter().map(|s| (s.n_p, s.n_q)).collect::<Vec<_>>(),
            tops
        );
        assert!(widest.iter().all(|s| s.proved_infeasible()));
        // Each level on its own has no fit either.
        let mut level = d;
        for _ in 0..=2 {
            assert!(matches!(
                fit(&level, &up_to_8(search, 0)),
                Err(FitError::NoFeasibleFit { .. })
            ));
            level = level.widened(2.0);
        }
    }
}

#[test]
fn the_widest_levels_check_changes_no_fit_returned() {
    for search in [Search::Exhaustive, Search::Staircase] {
        for (rel_tol, level) in [(0.01, 1), (0.003, 2)] {
            let d = wave(rel_tol);
            let checked_at_2 = fit(&d, &up_to_8(search, 2)).unwrap();
            assert_eq!(checked_at_2.widenings, level, "{search:?} {rel_tol}");
            // The check's solves are reported, at the level they were made.
            assert!(checked_at_2.splits.iter().any(|s| s.widenings == 2));
            // Checked at a wider level, each level's search is the same.
            let checked_at_3 = fit(&d, &up_to_8(search, 3)).unwrap();
            assert!(checked_at_3.splits.iter().any(|s| s.widenings == 3));
            let (a, b) = (&checked_at_2.function, &checked_at_3.function);
            assert_eq!(checked_at_2.widenings, checked_at_3.widenings);
            assert_eq!(a.numerator(), b.numerator(), "{search:?} {rel_tol}");
            assert_eq!(a.denominator(), b.denominator());
        }
    }
}

#[test]
fn an_existence_only_sweep_settles_without_finding_the_fit() {
    use std::sync::atomic::AtomicBool;
    use std::sync::Arc;
    let settle = |s: FitSettings| s.with_existence_only(Arc::new(AtomicBool::new(true)));
    let staircase = up_to_8(Search::Staircase, 2);
    // A fit at the first widening: the widest level's first split of the
    // largest budget says so, and nothing else is solved.
    let d = wave(0.01);
    assert!(fit(&d, &staircase).is_ok());
    assert!(matches!(
        fit(&d, &settle(staircase.clone())),
        Err(FitError::FitExists { splits_tried: 1 })
    ));
    // No fit: the widest level's largest budget proves it, as the sweep
    // without the flag finds.
    let d = wave(1e-3);
    assert!(matches!(
        fit(&d, &staircase),
        Err(FitError::NoFeasibleFit { .. })
    ));
    let Err(FitError::NoFeasibleFit { splits, .. }) = fit(&d, &settle(staircase)) else {
        panic!("a fit within 8 coefficients at 0.4%");
    };
    assert_eq!(splits.len(), 7);
    assert!(splits
        .iter()
        .all(|s| s.widenings == 2 && s.proved_infeasible()));
    // The other searches fit as usual, and so is a single split.
    let exhaustive = up_to_8(Search::Exhaustive, 2);
    assert!(fit(&wave(0.01), &settle(exhaustive)).is_ok());
    let split = Fitter::new(&wave(0.01))
        .settings(settle(up_to_8(Search::Staircase, 2)))
        .split(7, 1)
        .unwrap();
    assert!(split.summary.status != rational_core::Status::Cancelled);
}
