//! Fits that share one design (the channels of a material) give exactly the
//! answers of fits that evaluate their own, run concurrently, and a fit of
//! other points handed the same handle is not misled by it.

use rational_core::{fit, FitReport, FitSettings, IntervalData, Search, SharedDesign};
use std::thread;

mod common;
use common::grid_2d;

/// Three "channels": one set of points, three different functions.
fn channels() -> Vec<IntervalData> {
    let lobes = [3.0, 6.0, 12.0];
    lobes
        .iter()
        .map(|&k| {
            grid_2d(
                30,
                |x, y| 0.1 + 1.0 / (1.0 + k * ((x - 0.5).powi(2) + (y - 0.3).powi(2))),
                0.05,
            )
        })
        .collect()
}

fn settings() -> FitSettings {
    FitSettings::default()
        .with_coeff_range(2, 40)
        .unwrap()
        .with_search(Search::Staircase)
}

fn same_answer(a: &FitReport, b: &FitReport, what: &str) {
    assert_eq!((a.n_p, a.n_q), (b.n_p, b.n_q), "{what}: split");
    assert_eq!(a.function.numerator(), b.function.numerator(), "{what}");
    assert_eq!(a.function.denominator(), b.function.denominator(), "{what}");
    assert_eq!(a.splits_tried, b.splits_tried, "{what}: splits tried");
}

#[test]
fn channels_sharing_a_design_fit_as_they_do_alone() {
    let data = channels();
    let alone: Vec<FitReport> = data.iter().map(|d| fit(d, &settings()).unwrap()).collect();
    let design = SharedDesign::new();
    let shared: Vec<FitReport> = thread::scope(|s| {
        let handles: Vec<_> = data
            .iter()
            .map(|d| {
                let settings = settings().with_shared_design(design.clone());
                s.spawn(move || fit(d, &settings).unwrap())
            })
            .collect();
        handles.into_iter().map(|h| h.join().unwrap()).collect()
    });
    for (c, (a, b)) in alone.iter().zip(&shared).enumerate() {
        same_answer(a, b, &format!("channel {c}"));
    }
    // Budgets differ between the channels, so the design grew while shared.
    let widest = shared.iter().map(|r| r.n_p.max(r.n_q)).max().unwrap();
    let narrowest = shared.iter().map(|r| r.n_p.max(r.n_q)).min().unwrap();
    assert!(
        widest > narrowest,
        "the channels should need different widths"
    );
}

#[test]
fn a_handle_claimed_by_other_points_is_not_used() {
    let data = channels();
    let design = SharedDesign::new();
    fit(&data[0], &settings().with_shared_design(design.clone())).unwrap();
    // The same samples in reverse order: the bounding box, hence the basis,
    // is the same, but row i of the handle's design is not sample i.
    let reversed =
        |v: &[f64], dim: usize| -> Vec<f64> { v.chunks(dim).rev().flatten().copied().collect() };
    let moved = IntervalData::new(
        2,
        reversed(data[1].points(), 2),
        reversed(data[1].lo(), 1),
        reversed(data[1].hi(), 1),
    )
    .unwrap();
    let alone = fit(&moved, &settings()).unwrap();
    let handed = fit(&moved, &settings().with_shared_design(design)).unwrap();
    same_answer(&alone, &handed, "other points");
}
