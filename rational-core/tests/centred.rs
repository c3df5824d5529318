//! The centred fit ([`FitSettings::with_centred_fit`]): within every
//! interval, and nearer the data than the largest-margin point.

use rational_core::{FitSettings, Fitter, IntervalData, Search};

/// Root mean square of `(r - v) / half-width` and the largest
/// `|r - v| / half-width` over the samples.
fn errors_in_half_widths(data: &IntervalData, fit: &rational_core::RationalFunction) -> (f64, f64) {
    let (mut sum, mut max) = (0.0, 0.0_f64);
    for i in 0..data.len() {
        let half = 0.5 * (data.hi()[i] - data.lo()[i]);
        let centre = 0.5 * (data.hi()[i] + data.lo()[i]);
        let e = (fit.eval(data.point(i)) - centre) / half;
        sum += e * e;
        max = max.max(e.abs());
    }
    ((sum / data.len() as f64).sqrt(), max)
}

fn fit_both(data: &IntervalData, settings: FitSettings) -> [(f64, f64); 2] {
    [false, true].map(|on| {
        let report = Fitter::new(data)
            .settings(settings.clone().with_centred_fit(on))
            .fit()
            .expect("a fit");
        assert!(report.verification.satisfied);
        assert_eq!(report.centred, on, "the report names the point returned");
        errors_in_half_widths(data, &report.function)
    })
}

/// A peak on a slope at `n` points of [0, 1], within 5%.
fn peak_at(n: usize) -> IntervalData {
    let x: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
    let v: Vec<f64> = x
        .iter()
        .map(|x| 1.0 / (0.05 + (x - 0.3) * (x - 0.3)) + 2.0 * x)
        .collect();
    IntervalData::from_values_relative(1, x, v, 0.05).unwrap()
}

#[test]
fn centred_fits_stay_within_and_nearer_the_centres() {
    // A peak and a smooth 2-D product, each at a fixed budget.
    let peak = peak_at(400);
    let mut points = Vec::new();
    let mut values = Vec::new();
    for i in 0..30 {
        for j in 0..30 {
            let (a, b) = (i as f64 / 29.0, j as f64 / 29.0);
            points.extend([a, b]);
            values.push((1.0 + a * a).exp() / (1.2 + a * b - 0.5 * b));
        }
    }
    let surface = IntervalData::from_values_relative(2, points, values, 0.02).unwrap();
    for (name, data) in [("peak", &peak), ("surface", &surface)] {
        let settings = FitSettings::default()
            .with_search(Search::Staircase)
            .with_coeff_range(2, 40)
            .unwrap();
        let [margin, centred] = fit_both(data, settings);
        println!(
            "{name}: largest margin rms {:.3} max {:.3}; centred rms {:.3} max {:.3}",
            margin.0, margin.1, centred.0, centred.1
        );
        assert!(centred.1 <= 1.0 + 1e-9, "{name}: outside an interval");
        assert!(centred.0 < margin.0, "{name}: not nearer the centres");
    }
}

#[test]
fn a_centred_fit_keeps_its_largest_margin_point_as_the_plain_fit_returns_it() {
    let data = peak_at(300);
    let settings = FitSettings::default()
        .with_search(Search::Staircase)
        .with_coeff_range(2, 40)
        .unwrap();
    let plain = Fitter::new(&data).settings(settings.clone()).fit().unwrap();
    assert!(plain.largest_margin.is_none() && plain.at_largest_margin().is_none());
    let centred = Fitter::new(&data)
        .settings(settings.with_centred_fit(true))
        .fit()
        .unwrap();
    assert!(centred.centred);
    let other = centred.at_largest_margin().expect("a centred fit keeps it");
    // The same split and point as the plain sweep's, checked like it.
    assert_eq!((other.n_p, other.n_q), (plain.n_p, plain.n_q));
    assert!(!other.centred && other.largest_margin.is_none());
    assert!(other.verification.satisfied);
    assert!(other.splits.iter().all(|s| !s.centred));
    let (a, b) = (other.function.numerator(), plain.function.numerator());
    assert_eq!(a, b, "the largest-margin point is the plain fit's");
    let bits = |r: &rational_core::FitReport| r.errors.max_relative.to_bits();
    assert_eq!(bits(&other), bits(&plain));
    assert_ne!(centred.function.numerator(), plain.function.numerator());
}
