//! Bad input gets a named error; an impossible fit is reported as such;
//! widening recovers a fit when it is allowed.

use rational_core::{fit, Backend, FitError, FitSettings, Fitter, IntervalData, PoleControl};

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
