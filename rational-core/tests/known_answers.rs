//! The known answers of DESIGN.md section 2, computed independently
//! (Goldfarb-Idnani on P(n_p, n_q), Chebyshev basis in graded order, each
//! coordinate mapped to [-1, 1] by the data's range, intervals
//! `[v (1 - t), v (1 + t)]`): the smallest budget with a feasible split, the
//! feasible splits there and their depths (given to two digits). A sweep that
//! reports a larger budget has a solver or tolerance bug. Both searches
//! must find exactly the listed splits.

use ratfit_tests::data_dir;
use rational_core::{fit, FitSettings, IntervalData, PoleControl, Search, Selection};

/// Reads whitespace-separated numeric rows of an ALTA text file.
fn read_alta(path: &std::path::Path) -> Vec<Vec<f64>> {
    std::fs::read_to_string(path)
        .unwrap_or_else(|e| panic!("{}: {e}", path.display()))
        .lines()
        .filter(|l| !l.trim_start().starts_with('#') && !l.trim().is_empty())
        .map(|l| {
            l.split_whitespace()
                .map(|v| v.parse().expect("numeric ALTA row"))
                .collect()
        })
        .collect()
}

fn settings() -> FitSettings {
    // The reference used the paper's formulation: no pole check between
    // samples, no scaling of the values.
    FitSettings::default()
        .with_pole_control(PoleControl::None)
        .with_value_scaling(false)
        .with_selection(Selection::Depth)
        .with_coeff_range(2, 14)
        .unwrap()
}

/// Checks, for both searches, the minimal budget, and that exactly the
/// listed splits are feasible there with the listed depths (2 significant
/// digits).
fn check(name: &str, data: &IntervalData, smallest: usize, feasible: &[(usize, usize, f64)]) {
    for search in [Search::Exhaustive, Search::Staircase] {
        check_search(name, data, smallest, feasible, search);
    }
}

fn check_search(
    name: &str,
    data: &IntervalData,
    smallest: usize,
    feasible: &[(usize, usize, f64)],
    search: Search,
) {
    let name = &format!("{name} ({search:?})");
    let report =
        fit(data, &settings().with_search(search)).unwrap_or_else(|e| panic!("{name}: {e}"));
    assert_eq!(report.n_p + report.n_q, smallest, "{name}: smallest budget");
    assert!(report.verification.satisfied, "{name}");
    assert!(
        report.errors.max_relative <= 0.02 * (1.0 + 1e-9),
        "{name}: {:?}",
        report.errors
    );
    let at_budget: Vec<_> = report
        .splits
        .iter()
        .filter(|s| s.n_p + s.n_q == smallest && s.accepted)
        .collect();
    if !feasible.is_empty() {
        assert_eq!(
            at_budget.len(),
            feasible.len(),
            "{name}: feasible splits {at_budget:?}"
        );
        for &(np, nq, depth) in feasible {
            let s = at_budget
                .iter()
                .find(|s| s.n_p == np && s.n_q == nq)
                .unwrap_or_else(|| panic!("{name}: ({np},{nq}) not feasible"));
            let rel = (s.depth / depth - 1.0).abs();
            assert!(
                rel < 0.05,
                "{name} ({np},{nq}): depth {:.3e}, reference {depth:.1e}",
                s.depth
            );
        }
    }
    eprintln!(
        "{name}: N = {smallest}, chosen ({}, {}), depth {:.3e}, {} splits, {:.3} s",
        report.n_p, report.n_q, report.depth, report.splits_tried, report.seconds
    );
}

#[test]
fn runge_2000_points_one_percent() {
    let x: Vec<f64> = (0..2000).map(|i| -1.0 + 2.0 * i as f64 / 1999.0).collect();
    let v: Vec<f64> = x.iter().map(|x| 1.0 / (1.0 + 25.0 * x * x)).collect();
    let data = IntervalData::from_values_relative(1, x, v, 0.01).unwrap();
    check("runge", &data, 4, &[(1, 3, 3.2e-4)]);
}

#[test]
fn pink_felt_slice_two_percent() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED pink_felt_slice_two_percent: no data directory (set RATFIT_DATA)");
        return;
    };
    let rows = read_alta(&dir.join("alta/pink-felt-1d.alta"));
    let x: Vec<f64> = rows.iter().map(|r| r[0]).collect();
    let channel = |c: usize| -> IntervalData {
        let v = rows.iter().map(|r| r[c]).collect();
        IntervalData::from_values_relative(1, x.clone(), v, 0.02).unwrap()
    };
    check(
        "pink-felt red",
        &channel(1),
        7,
        &[(3, 4, 2.0e-5), (4, 3, 1.8e-5)],
    );
    check("pink-felt green", &channel(2), 8, &[]);
    check(
        "pink-felt blue",
        &channel(3),
        10,
        &[(1, 9, 6.3e-4), (9, 1, 1.3e-4)],
    );
}
