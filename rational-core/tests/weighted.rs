//! The weighted graded order: on data that vary much faster along one
//! coordinate, weights that make the slow coordinate's degree expensive find
//! a verified fit with fewer coefficients; both searches agree on it; weights
//! that do not match the data are an error, not a panic.

use rational_core::{fit, FitError, FitSettings, IntervalData, Search};

mod common;
use common::grid_2d;

/// `(2 + sin(6x)) (1 + y / 5)` on an `n x n` grid of the unit square, 0.1%
/// relative intervals: degree is needed in `x`, hardly any in `y`.
fn anisotropic(n: usize) -> IntervalData {
    grid_2d(n, |x, y| (2.0 + (6.0 * x).sin()) * (1.0 + y / 5.0), 1e-3)
}

fn settings() -> FitSettings {
    FitSettings::default().with_coeff_range(2, 60).unwrap()
}

#[test]
fn weights_find_smaller_fits_of_anisotropic_data() {
    let data = anisotropic(21);
    let plain = fit(&data, &settings().with_search(Search::Staircase)).expect("plain fit");
    let weighted_settings = settings().with_degree_weights(vec![1, 4]).unwrap();
    let weighted = fit(
        &data,
        &weighted_settings.clone().with_search(Search::Staircase),
    )
    .expect("weighted fit");
    let exhaustive = fit(&data, &weighted_settings).expect("weighted exhaustive fit");
    let budget = |r: &rational_core::FitReport| r.n_p + r.n_q;
    eprintln!(
        "plain: {} coefficients; weights (1,4): {} (staircase), {} (exhaustive)",
        budget(&plain),
        budget(&weighted),
        budget(&exhaustive)
    );
    for r in [&plain, &weighted, &exhaustive] {
        assert!(r.verification.satisfied, "{r}");
    }
    assert!(weighted.function.basis().is_weighted());
    assert_eq!(weighted.function.basis().weights(), &[1, 4]);
    assert_eq!(budget(&weighted), budget(&exhaustive));
    assert_eq!(
        (weighted.n_p, weighted.n_q),
        (exhaustive.n_p, exhaustive.n_q)
    );
    assert!(
        budget(&weighted) < budget(&plain),
        "weights (1,4) should need fewer coefficients than the total-degree order"
    );
    // The report says which order was used; the fit reads back from JSON.
    assert!(weighted.to_string().contains("degree weights      1,4"));
    let json = serde_json::to_string(&weighted.function).unwrap();
    let back: rational_core::RationalFunction = serde_json::from_str(&json).unwrap();
    assert_eq!(back, weighted.function);
}

#[test]
fn weights_that_do_not_fit_the_data_are_errors() {
    let data = anisotropic(5);
    let err = fit(
        &data,
        &settings().with_degree_weights(vec![1, 2, 3]).unwrap(),
    )
    .unwrap_err();
    assert!(matches!(err, FitError::DimensionMismatch(_)), "{err}");
    assert!(err.to_string().contains("3 degree weights"), "{err}");
    for bad in [vec![], vec![0, 1], vec![1, 17]] {
        let err = settings().with_degree_weights(bad.clone()).unwrap_err();
        assert!(err.to_string().contains("weight"), "{bad:?}: {err}");
    }
}
