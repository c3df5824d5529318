//! The staircase search finds what the exhaustive sweep finds (the smallest
//! budget, its accepted splits and the chosen one) with fewer solves, and
//! keeps the sweep's outcomes: infeasible problems, widening, the smallest
//! budget allowed.

use rational_core::{fit, FitError, FitReport, FitSettings, IntervalData, Search};
use std::collections::BTreeSet;

mod common;
use common::{grid_1d, grid_2d};

/// Accepted splits at the chosen budget.
fn accepted_at_budget(r: &FitReport) -> BTreeSet<(usize, usize)> {
    let n = r.n_p + r.n_q;
    r.splits
        .iter()
        .filter(|s| s.accepted && s.n_p + s.n_q == n)
        .map(|s| (s.n_p, s.n_q))
        .collect()
}

fn both(name: &str, data: &IntervalData, settings: FitSettings) -> (FitReport, FitReport) {
    let all = fit(data, &settings.clone().with_search(Search::Exhaustive))
        .unwrap_or_else(|e| panic!("{name} exhaustive: {e}"));
    let stair = fit(data, &settings.with_search(Search::Staircase))
        .unwrap_or_else(|e| panic!("{name} staircase: {e}"));
    eprintln!(
        "{name}: N = {}, chosen ({}, {}); exhaustive {} splits in {:.3} s, staircase {} in {:.3} s",
        all.n_p + all.n_q,
        all.n_p,
        all.n_q,
        all.splits_tried,
        all.seconds,
        stair.splits_tried,
        stair.seconds
    );
    assert_eq!(
        accepted_at_budget(&stair),
        accepted_at_budget(&all),
        "{name}: accepted splits at the smallest budget"
    );
    assert_eq!(
        (stair.n_p, stair.n_q),
        (all.n_p, all.n_q),
        "{name}: chosen split"
    );
    assert!(stair.verification.satisfied, "{name}");
    assert_eq!(stair.search, Search::Staircase);
    (all, stair)
}

#[test]
fn staircase_finds_the_exhaustive_answer_with_fewer_solves() {
    let settings = FitSettings::default().with_coeff_range(2, 40).unwrap();
    let cases: Vec<(&str, IntervalData)> = vec![
        (
            "runge 1%",
            grid_1d(400, |x| 1.0 / (1.0 + 25.0 * (2.0 * x - 1.0).powi(2)), 0.01),
        ),
        (
            "oscillation 1e-3",
            grid_1d(300, |x| (9.0 * x).sin() + 1.5, 1e-3),
        ),
        (
            "faster oscillation 1e-4",
            grid_1d(500, |x| (25.0 * x).sin() + 1.5, 1e-4),
        ),
        (
            "lobe plus base",
            grid_1d(300, |x| 0.05 + 1.0 / (1e-3 + x * x), 0.05),
        ),
        (
            "2-d lobe 5%",
            grid_2d(30, |x, y| 0.1 + (1.0 + y) / (0.02 + x * x), 0.05),
        ),
        (
            "2-d smooth 1%",
            grid_2d(25, |x, y| (2.0 * x + y).cos() + 2.0 + x * y, 0.01),
        ),
    ];
    for (name, data) in &cases {
        let (all, stair) = both(name, data, settings.clone());
        // Below budget 8 the sweep solves at most 28 splits and the
        // staircase can need a few more; from budget 10 it must need fewer.
        if all.n_p + all.n_q >= 10 {
            assert!(
                stair.splits_tried < all.splits_tried,
                "{name}: staircase {} splits, exhaustive {}",
                stair.splits_tried,
                all.splits_tried
            );
        }
    }
}

#[test]
fn staircase_respects_the_smallest_budget() {
    let data = grid_1d(200, |x| 1.0 / (1.0 + 25.0 * (2.0 * x - 1.0).powi(2)), 0.01);
    let settings = FitSettings::default().with_coeff_range(7, 20).unwrap();
    let (all, _) = both("runge from 7", &data, settings);
    assert!(all.n_p + all.n_q >= 7);
    let stair = fit(
        &data,
        &FitSettings::default()
            .with_coeff_range(7, 20)
            .unwrap()
            .with_search(Search::Staircase),
    )
    .unwrap();
    assert!(stair
        .splits
        .iter()
        .all(|s| s.n_p + s.n_q >= 7 && s.n_p + s.n_q <= 20));
}

#[test]
fn staircase_reports_infeasible_problems_and_widens() {
    let conflicting = IntervalData::new(
        1,
        vec![0.0, 0.5, 0.5, 1.0],
        vec![1.0, 1.0, 3.0, 1.0],
        vec![1.1, 1.1, 3.1, 1.1],
    )
    .unwrap();
    let s = FitSettings::default()
        .with_coeff_range(2, 4)
        .unwrap()
        .with_search(Search::Staircase);
    match fit(&conflicting, &s) {
        Err(FitError::NoFeasibleFit { max_coeffs: 4, .. }) => {}
        other => panic!("expected NoFeasibleFit, got {other:?}"),
    }
    let tight = grid_1d(200, |x| (8.0 * x).sin() + 2.0, 1e-4);
    let strict = FitSettings::default()
        .with_coeff_range(2, 5)
        .unwrap()
        .with_search(Search::Staircase);
    assert!(fit(&tight, &strict).is_err());
    let report = fit(&tight, &strict.with_widening(10.0, 4).unwrap()).unwrap();
    assert!(report.widenings > 0);
    assert!(report.verification.satisfied);
}

#[test]
fn search_names_parse() {
    assert_eq!("staircase".parse::<Search>().unwrap(), Search::Staircase);
    assert_eq!("exhaustive".parse::<Search>().unwrap(), Search::Exhaustive);
    assert_eq!("probe".parse::<Search>().unwrap(), Search::Probe);
    assert!(matches!(
        "spiral".parse::<Search>(),
        Err(FitError::InvalidSetting { name: "search", .. })
    ));
}

#[test]
fn probing_doubles_then_bisects_the_budget_over_five_splits_each() {
    let settings = FitSettings::default().with_coeff_range(2, 40).unwrap();
    let data = grid_1d(300, |x| (9.0 * x).sin() + 1.5, 1e-3);
    let all = fit(&data, &settings.clone().with_search(Search::Exhaustive)).unwrap();
    let probe = fit(&data, &settings.with_search(Search::Probe)).unwrap();
    assert!(probe.verification.satisfied);
    assert_eq!(probe.search, Search::Probe);
    // The budgets probed: 2, 4, 8... up to the first feasible one, then a
    // bisection below it; at most five splits each, at the fractions.
    let mut budgets: Vec<usize> = probe.splits.iter().map(|s| s.n_p + s.n_q).collect();
    budgets.dedup();
    let doubling: Vec<usize> = budgets
        .iter()
        .copied()
        .take_while(|n| n.is_power_of_two())
        .collect();
    assert!(doubling.len() >= 2 && doubling[0] == 2, "{budgets:?}");
    for n in &budgets {
        let probed: Vec<usize> = probe
            .splits
            .iter()
            .filter(|s| s.n_p + s.n_q == *n)
            .map(|s| s.n_p)
            .collect();
        assert!(
            probed.len() <= rational_core::PROBE_FRACTIONS.len(),
            "{n}: {probed:?}"
        );
        for np in probed {
            assert!(rational_core::PROBE_FRACTIONS
                .iter()
                .any(|f| ((f * *n as f64).round() as usize).clamp(1, n - 1) == np));
        }
    }
    // The budget it returns is feasible and no smaller than the smallest;
    // the budget just below it was probed and refused.
    let n = probe.n_p + probe.n_q;
    assert!(n >= all.n_p + all.n_q, "{n} against {}", all.n_p + all.n_q);
    assert!(
        budgets.contains(&(n - 1)) || doubling.last() == Some(&n),
        "{budgets:?}"
    );
    assert!(probe.splits_tried < all.splits_tried);
}

#[test]
fn a_single_budget_keeps_the_best_conditioned_accepted_split_without_solving_them_all() {
    let cases: Vec<(&str, IntervalData)> = vec![
        (
            "runge 1%",
            grid_1d(400, |x| 1.0 / (1.0 + 25.0 * (2.0 * x - 1.0).powi(2)), 0.01),
        ),
        (
            "2-d lobe 5%",
            grid_2d(30, |x, y| 0.1 + (1.0 + y) / (0.02 + x * x), 0.05),
        ),
    ];
    for (name, data) in &cases {
        let smallest = fit(
            data,
            &FitSettings::default()
                .with_coeff_range(2, 40)
                .unwrap()
                .with_search(Search::Staircase),
        )
        .unwrap();
        // A few coefficients above the smallest budget: several splits hold.
        let n = smallest.n_p + smallest.n_q + 4;
        let fitter = rational_core::Fitter::new(data);
        let accepted: Vec<(f64, (usize, usize))> = (1..n)
            .filter_map(|n_q| {
                let s = fitter.split(n - n_q, n_q).ok()?;
                s.summary
                    .accepted
                    .then(|| (s.summary.condition_number.unwrap(), (n - n_q, n_q)))
            })
            .collect();
        assert!(accepted.len() >= 3, "{name}: {accepted:?}");
        let best = accepted
            .iter()
            .min_by(|a, b| a.0.total_cmp(&b.0))
            .unwrap()
            .1;
        for search in [Search::Staircase, Search::Exhaustive] {
            let settings = FitSettings::default()
                .with_coeff_range(n, n)
                .unwrap()
                .with_search(search);
            let r = fit(data, &settings).unwrap();
            assert_eq!((r.n_p, r.n_q), best, "{name} {search:?}");
            assert!(r.verification.satisfied);
            let solved_accepted = r.splits.iter().filter(|s| s.accepted).count();
            assert_eq!(solved_accepted, 1, "{name} {search:?}: stops at the first");
            assert!(r.splits_tried < n - 1 || accepted.len() == 1, "{name}");
        }
    }
}

/// The staircase's cases that need a budget of ten or more.
fn larger_cases() -> Vec<(&'static str, IntervalData)> {
    vec![
        (
            "faster oscillation 1e-4",
            grid_1d(500, |x| (25.0 * x).sin() + 1.5, 1e-4),
        ),
        (
            "2-d lobe 5%",
            grid_2d(30, |x, y| 0.1 + (1.0 + y) / (0.02 + x * x), 0.05),
        ),
    ]
}

#[test]
fn splits_known_infeasible_are_not_solved_again_and_change_nothing() {
    let settings = FitSettings::default()
        .with_coeff_range(2, 40)
        .unwrap()
        .with_search(Search::Staircase);
    for (name, data) in larger_cases() {
        let first = rational_core::Fitter::new(&data)
            .settings(settings.clone())
            .fit()
            .unwrap();
        let known = first.proved_infeasible();
        assert!(
            !known.is_empty(),
            "{name}: the walk proves some splits infeasible"
        );
        // The same data with every fifth interval halved: more rows' worth
        // of constraint, so what was infeasible stays infeasible.
        let (mut lo, mut hi) = (data.lo().to_vec(), data.hi().to_vec());
        for k in (0..data.len()).step_by(5) {
            let (c, h) = (0.5 * (lo[k] + hi[k]), 0.25 * (hi[k] - lo[k]));
            (lo[k], hi[k]) = (c - h, c + h);
        }
        let tighter = IntervalData::new(data.dim(), data.points().to_vec(), lo, hi).unwrap();
        let fitter = rational_core::Fitter::new(&tighter).settings(settings.clone());
        let plain = fitter.fit().unwrap();
        let informed = rational_core::Fitter::new(&tighter)
            .settings(settings.clone())
            .known_infeasible(&known)
            .fit()
            .unwrap();
        assert_eq!(
            (informed.n_p, informed.n_q),
            (plain.n_p, plain.n_q),
            "{name}"
        );
        assert_eq!(
            accepted_at_budget(&informed),
            accepted_at_budget(&plain),
            "{name}"
        );
        assert!(
            informed.splits_tried < plain.splits_tried,
            "{name}: fewer solves"
        );
        let known_up_to = |n_q: usize| {
            known
                .iter()
                .filter(|s| s.1 == n_q)
                .map(|s| s.0)
                .max()
                .unwrap_or(0)
        };
        assert!(
            informed.splits.iter().all(|s| s.n_p > known_up_to(s.n_q)),
            "{name}: a known split, or one below it, was solved"
        );
    }
}
