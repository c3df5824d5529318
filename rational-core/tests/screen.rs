//! Screening each split on a subsample changes the cost of a fit, never its
//! answer: the same splits are tried, refused and accepted, and the chosen
//! function is the one the full problems alone give.

use rational_core::{fit, FitError, FitReport, FitSettings, IntervalData, Screen, Search, Status};

mod common;
use common::{grid_1d, grid_2d};

/// `settings` screening every 8th sample from 1,000 samples.
fn screening(settings: &FitSettings) -> FitSettings {
    settings
        .clone()
        .with_screen(Screen {
            min_samples: 1_000,
            stride: 8,
        })
        .unwrap()
}

fn both(name: &str, data: &IntervalData, settings: FitSettings) -> (FitReport, FitReport) {
    let screened = screening(&settings);
    let plain = settings.with_screen(Screen::OFF).unwrap();
    let a = fit(data, &screened).unwrap_or_else(|e| panic!("{name} screened: {e}"));
    let b = fit(data, &plain).unwrap_or_else(|e| panic!("{name} plain: {e}"));
    (a, b)
}

fn same_answer(name: &str, screened: &FitReport, plain: &FitReport) {
    assert_eq!(
        (screened.n_p, screened.n_q),
        (plain.n_p, plain.n_q),
        "{name}: chosen split"
    );
    let outcome = |r: &FitReport| -> Vec<(usize, usize, bool, bool)> {
        r.splits
            .iter()
            .map(|s| (s.n_p, s.n_q, s.accepted, s.status == Status::Infeasible))
            .collect()
    };
    assert_eq!(
        outcome(screened),
        outcome(plain),
        "{name}: splits and outcomes"
    );
    let refused = screened
        .splits
        .iter()
        .filter(|s| s.note.contains("hence on all"))
        .count();
    assert!(refused > 0, "{name}: the subsample refused no split");
    // The optimum of each split is unique; the warm starts differ.
    let (fa, fb) = (&screened.function, &plain.function);
    let scale = fb
        .numerator()
        .iter()
        .chain(fb.denominator())
        .fold(0.0_f64, |m, v| m.max(v.abs()));
    for (x, y) in fa
        .numerator()
        .iter()
        .chain(fa.denominator())
        .zip(fb.numerator().iter().chain(fb.denominator()))
    {
        assert!((x - y).abs() <= 1e-7 * scale, "{name}: {x} against {y}");
    }
    assert!(screened.verification.satisfied, "{name}");
}

#[test]
fn screened_fits_give_the_plain_answer() {
    let runge = grid_1d(
        20_000,
        |x| 1.0 / (1.0 + 25.0 * (2.0 * x - 1.0).powi(2)),
        0.01,
    );
    let lobe = grid_2d(
        120,
        |x, y| 0.05 + 1.0 / (1.0 + 40.0 * ((x - 0.6).powi(2) + (y - 0.4).powi(2))),
        0.05,
    );
    for search in [Search::Staircase, Search::Exhaustive] {
        let settings = FitSettings::default()
            .with_coeff_range(2, 40)
            .unwrap()
            .with_search(search);
        let (a, b) = both("runge", &runge, settings.clone());
        same_answer(&format!("runge, {search:?}"), &a, &b);
        let (a, b) = both("lobe", &lobe, settings);
        same_answer(&format!("lobe, {search:?}"), &a, &b);
    }
}

#[test]
fn a_zero_stride_is_refused() {
    assert!(FitSettings::default()
        .with_screen(Screen {
            min_samples: 10,
            stride: 0,
        })
        .is_err());
}

/// Every split of a fit that must fail, and how many of them the subsample
/// refused.
fn refusals(data: &IntervalData, settings: FitSettings) -> (usize, usize) {
    match fit(data, &settings) {
        Err(FitError::NoFeasibleFit { splits, .. }) => {
            assert!(splits.iter().all(|s| !s.accepted));
            let refused = splits
                .iter()
                .filter(|s| s.note.contains("hence on all"))
                .count();
            (splits.len(), refused)
        }
        other => panic!("expected no feasible fit, got {other:?}"),
    }
}

#[test]
fn rows_found_binding_let_the_screen_refuse_what_its_stride_misses() {
    // A smooth line with a 50% step on three samples, none of them on the
    // stride: the subsample alone sees the line and accepts small splits,
    // the full problem sees the step and refuses every split. Once a full
    // solve has proved a split infeasible with the step's rows, the screen
    // holds them too and refuses the next splits itself.
    let n = 20_000;
    let x: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
    let v: Vec<f64> = (0..n)
        .map(|i| {
            (1.0 + x[i])
                * if (10_001..=10_003).contains(&i) {
                    1.5
                } else {
                    1.0
                }
        })
        .collect();
    let data = IntervalData::from_values_relative(1, x, v, 0.01).unwrap();
    for search in [Search::Staircase, Search::Exhaustive] {
        let settings = FitSettings::default()
            .with_coeff_range(2, 16)
            .unwrap()
            .with_widening(2.0, 0)
            .unwrap()
            .with_search(search);
        let (tried, refused) = refusals(&data, screening(&settings));
        let (tried_plain, _) = refusals(&data, settings.with_screen(Screen::OFF).unwrap());
        assert_eq!(tried, tried_plain, "{search:?}: the same splits");
        eprintln!("{search:?}: {refused} of {tried} splits refused by the screen");
        assert!(
            refused * 2 >= tried,
            "{search:?}: the screen refused only {refused} of {tried} splits"
        );
    }
}
