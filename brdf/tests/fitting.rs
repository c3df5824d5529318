//! Fits of analytic materials with known truth: verified channels,
//! reciprocity, exact JSON round-trips, 2-D and 3-D reductions.

use brdf::{
    fit_brdf, from_spherical, BlinnPhong, Brdf, BrdfFitSettings, CookTorranceGgx, Coordinates,
    FittedBrdf, Reduction, ReductionKind, ValueScale,
};

fn settings(r: Reduction) -> BrdfFitSettings {
    BrdfFitSettings::default()
        .with_reduction(r)
        .with_rel_tol(0.05)
        .unwrap()
}

/// A blue GGX material, rough enough for small fits.
fn blue_ggx() -> CookTorranceGgx {
    CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.2,
    }
}

#[test]
fn two_d_fit_is_verified_reciprocal_and_round_trips() {
    let m = blue_ggx();
    let (fitted, report) =
        fit_brdf(&m, &settings(Reduction::default().with_resolution(40, 40))).unwrap();
    for c in &report.channels {
        assert!(c.verified, "{report}");
        assert!(c.max_rel <= 0.05 * (1.0 + 1e-9), "{report}");
    }
    // Reciprocity: swapping the directions changes nothing.
    for &(a, b, c, d) in &[
        (0.3, 0.2, 0.8, 2.0),
        (1.0, -1.0, 0.1, 0.5),
        (0.6, 0.0, 0.6, 3.1),
    ] {
        let (wi, wo) = (from_spherical(a, b), from_spherical(c, d));
        let (x, y) = (fitted.eval(wi, wo), fitted.eval(wo, wi));
        for k in 0..3 {
            assert!(
                (x[k] - y[k]).abs() <= 1e-12 * x[k].abs().max(1e-300),
                "{x:?} vs {y:?}"
            );
        }
    }
    let json = serde_json::to_string(&fitted).unwrap();
    let back: FittedBrdf = serde_json::from_str(&json).unwrap();
    assert_eq!(back, fitted);
}

#[test]
fn three_d_fit_covers_phi_d() {
    let m = BlinnPhong {
        kd: [0.2, 0.25, 0.3],
        ks: [0.3; 3],
        exponent: 15.0,
    };
    let r = Reduction::default()
        .with_kind(ReductionKind::Full3d)
        .with_resolution(16, 16)
        .with_phi_resolution(12);
    let (fitted, report) = fit_brdf(&m, &settings(r)).unwrap();
    assert!(
        report
            .channels
            .iter()
            .all(|c| c.verified && c.samples > 1000),
        "{report}"
    );
    assert_eq!(fitted.channels[0].dim(), 3);
    // Away from the samples (but inside the fitted range) the fit stays close.
    let (wi, wo) = (from_spherical(0.4, 0.3), from_spherical(0.7, 2.9));
    let (t, f) = (m.eval(wi, wo), fitted.eval(wi, wo));
    assert!((f[0] / t[0] - 1.0).abs() < 0.15, "{f:?} vs {t:?}");
}

#[test]
fn coordinates_and_spread_are_honoured() {
    let m = BlinnPhong {
        kd: [0.2; 3],
        ks: [0.4; 3],
        exponent: 10.0,
    };
    for coords in [
        Coordinates::Radians,
        Coordinates::Cosines,
        Coordinates::SqrtThetaH,
    ] {
        let r = Reduction::default()
            .with_resolution(20, 20)
            .with_coordinates(coords);
        let (_, report) = fit_brdf(&m, &settings(r)).unwrap();
        assert!(
            report.channels.iter().all(|c| c.verified),
            "{coords:?}: {report}"
        );
    }
    // The spread over phi_d holds the slice value and everything in between.
    let r = Reduction::default()
        .with_resolution(16, 16)
        .with_phi_resolution(8)
        .with_kind(ReductionKind::Spread2d);
    let samples = r.sample(&m);
    assert!(samples
        .rows
        .iter()
        .all(|s| (0..3).all(|c| s.lo[c] <= s.value[c] && s.value[c] <= s.hi[c])));
    let (_, report) = fit_brdf(&m, &settings(r)).unwrap();
    assert!(report.channels.iter().all(|c| c.verified));
}

#[test]
fn bad_settings_are_refused() {
    assert!(BrdfFitSettings::default().with_rel_tol(0.0).is_err());
    assert!(BrdfFitSettings::default().with_rel_tol(1.5).is_err());
    assert!(BrdfFitSettings::default().with_rel_tol(f64::NAN).is_err());
}

#[test]
fn channels_fitted_apart_assemble_into_the_joint_fit() {
    let m = blue_ggx();
    let s = settings(Reduction::default().with_resolution(24, 24))
        .with_colour_mode(brdf::ColourMode::LuminanceChroma);
    let samples = s.reduction().sample(&m);
    let (joint, joint_report) = brdf::fit_samples(&samples, "ggx", &s).unwrap();
    let parts: Vec<_> = (0..3)
        .map(|c| brdf::fit_samples_channel(&samples, c, &s).unwrap())
        .collect();
    let (apart, apart_report) = brdf::assemble_channels(&samples, "ggx", &s, parts).unwrap();
    assert_eq!(apart, joint);
    for (a, j) in apart_report.channels.iter().zip(&joint_report.channels) {
        assert_eq!((a.n_p, a.n_q, a.max_rel_all), (j.n_p, j.n_q, j.max_rel_all));
    }
    assert!(brdf::fit_samples_channel(&samples, 3, &s).is_err());
    let two: Vec<_> = (0..2)
        .map(|c| brdf::fit_samples_channel(&samples, c, &s).unwrap())
        .collect();
    let err = brdf::assemble_channels(&samples, "ggx", &s, two).unwrap_err();
    assert!(err.to_string().contains("2 channels"), "{err}");
}

/// GGX whose green channel is measured at zero, or a little below (noise
/// around a dark value), wherever `theta_d` exceeds 40 degrees.
struct DarkGreen(CookTorranceGgx);

impl Brdf for DarkGreen {
    fn eval(&self, wi: brdf::Vec3, wo: brdf::Vec3) -> [f64; 3] {
        let mut v = self.0.eval(wi, wo);
        let cos_d = (wi[0] * wo[0] + wi[1] * wo[1] + wi[2] * wo[2]).clamp(-1.0, 1.0);
        // theta_d is half the angle between the directions.
        if cos_d.acos() / 2.0 > 40f64.to_radians() {
            v[1] = if wi[0] > 0.0 { 0.0 } else { -1e-4 };
        }
        v
    }
    fn name(&self) -> String {
        "GGX with a dark green".into()
    }
}

#[test]
fn plain_intervals_bound_dark_cells_and_every_fit_stays_under_its_cap() {
    let m = DarkGreen(CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.3,
    });
    let r = Reduction::default().with_resolution(30, 30);
    let samples = r.sample(&m);
    let (data, used) = samples.channel(1, 0.05, 1e-2).unwrap();
    let dark: Vec<usize> = (0..used.len())
        .filter(|&k| samples.rows[used[k]].value[1] <= 0.0)
        .collect();
    assert!(dark.len() > 50, "{} dark cells", dark.len());
    // Every dark cell is fitted, within the channel's median of zero.
    let mut positive: Vec<f64> = samples
        .rows
        .iter()
        .filter(|r| !r.grazing && r.value[1] > 0.0)
        .map(|r| r.value[1])
        .collect();
    positive.sort_by(f64::total_cmp);
    let median = positive[positive.len() / 2];
    for &k in &dark {
        assert_eq!((data.lo()[k], data.hi()[k]), (-median, median));
    }
    // The floor does not matter to them.
    let (_, used_no_floor) = samples.channel(1, 0.05, 0.0).unwrap();
    assert_eq!(used_no_floor, used);

    let (fitted, report) = fit_brdf(&m, &settings(r)).unwrap();
    for c in &report.channels {
        let k = c.cap.expect("every fit is cap-checked");
        assert!(k.grid_points > 30 * 30, "{k:?}");
        assert!(k.held(), "{report}");
    }
    // The fit is no brighter than the median where the table is dark.
    let scale = report.channels[1].interval_scale;
    for &k in &dark {
        let x = data.point(k);
        let g = fitted.eval_coords(x)[1];
        assert!(g.abs() <= median * scale * (1.0 + 1e-9), "{g} at {x:?}");
    }
}

/// Fits `m` at `tol` with `memo`, counting the splits solved.
fn fit_counting(
    m: &dyn Brdf,
    base: &BrdfFitSettings,
    tol: f64,
    memo: Option<&brdf::NoFitMemo>,
) -> (FittedBrdf, usize) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let solved = Arc::new(AtomicUsize::new(0));
    let count = solved.clone();
    let mut s = base
        .clone()
        .with_rel_tol(tol)
        .unwrap()
        .with_channel_progress(Arc::new(move |_, _| {
            count.fetch_add(1, Ordering::Relaxed);
        }));
    if let Some(memo) = memo {
        s = s.with_no_fit_memo(memo.clone());
    }
    let (fitted, _) = fit_brdf(m, &s).unwrap();
    (fitted, solved.load(Ordering::Relaxed))
}

#[test]
fn proofs_of_no_fit_kept_between_fits_save_solves_and_change_no_fit() {
    let m = CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.3,
    };
    let engine = rational_core::FitSettings::default()
        .with_search(rational_core::Search::Staircase)
        .with_coeff_range(2, 16)
        .unwrap()
        .with_widening(2.0, 6)
        .unwrap();
    let base = BrdfFitSettings::default()
        .with_reduction(Reduction::default().with_resolution(24, 24))
        .with_baselines(false)
        .with_fit_settings(engine);
    let memo = brdf::NoFitMemo::new();
    fit_counting(&m, &base, 0.01, Some(&memo));
    assert!(!memo.is_empty(), "the 1% fits needed widening");
    // A tighter tolerance, as a search tries next: the same fit, fewer solves.
    let (plain, plain_solves) = fit_counting(&m, &base, 0.005, None);
    let (skipped, skipped_solves) = fit_counting(&m, &base, 0.005, Some(&memo));
    assert_eq!(skipped, plain);
    assert!(
        skipped_solves < plain_solves,
        "{skipped_solves} solves with the memo, {plain_solves} without"
    );
}

#[test]
fn the_functions_that_carry_light_get_the_floor_that_follows_the_tolerance() {
    let m = blue_ggx();
    let design = brdf::PerceptualBounds::default()
        .with_rel_tol(0.08)
        .unwrap();
    for mode in [brdf::ColourMode::LuminanceChroma, brdf::ColourMode::Rgb] {
        let s = settings(Reduction::default().with_resolution(24, 24))
            .with_colour_mode(mode)
            .with_design(design);
        let (_, report) = fit_brdf(&m, &s).unwrap();
        for (c, channel) in report.channels.iter().enumerate() {
            let used = channel.bounds.as_ref().unwrap().visibility;
            // Half a percent at 8% for the luminance and the RGB channels,
            // the fixed 2% for the chroma ratios.
            let want = if mode.carries_light(c) { 0.005 } else { 0.02 };
            assert!((used - want).abs() < 1e-15, "{mode} {c}: {used}");
        }
    }
}

/// A 24 x 24 reduction of a GGX material whose channel `unmeasured` has no
/// finite value (its fit fails before any solve), and staircase settings
/// with `widenings` whose progress counts channel `watched`'s splits and
/// sleeps 300 ms at its first, so that the failing channel's job surely runs
/// first on one of the pool's other threads.
fn one_channel_unmeasured(
    unmeasured: usize,
    watched: usize,
    widenings: usize,
) -> (
    brdf::Samples,
    BrdfFitSettings,
    std::sync::Arc<std::sync::atomic::AtomicUsize>,
) {
    use std::sync::atomic::{AtomicUsize, Ordering};
    use std::sync::Arc;
    let m = CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.3,
    };
    let reduction = Reduction::default().with_resolution(24, 24);
    let mut samples = reduction.sample(&m);
    for row in &mut samples.rows {
        let c = unmeasured;
        (row.value[c], row.lo[c], row.hi[c]) = (f64::NAN, f64::NAN, f64::NAN);
    }
    let engine = rational_core::FitSettings::default()
        .with_search(rational_core::Search::Staircase)
        .with_coeff_range(2, 40)
        .unwrap()
        .with_widening(2.0, widenings)
        .unwrap();
    let splits = Arc::new(AtomicUsize::new(0));
    let count = splits.clone();
    let settings = BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_baselines(false)
        .with_fit_settings(engine)
        .with_channel_progress(Arc::new(move |c, _| {
            if c == watched && count.fetch_add(1, Ordering::Relaxed) == 0 {
                std::thread::sleep(std::time::Duration::from_millis(300));
            }
        }));
    (samples, settings, splits)
}

/// A pool of three threads, one per function.
fn three_threads() -> rayon::ThreadPool {
    rayon::ThreadPoolBuilder::new()
        .num_threads(3)
        .build()
        .unwrap()
}

/// The first function in order that fails is the fit's error, so a failure
/// stops the functions after it: here red has no finite value (an error
/// before any solve) and blue's sweep, long on its own, ends after the
/// split it is solving when red fails.
#[test]
fn a_function_that_fails_stops_the_functions_after_it() {
    use std::sync::atomic::Ordering;
    let (samples, settings, blue_splits) = one_channel_unmeasured(0, 2, 0);
    let settings = settings.with_rel_tol(1e-4).unwrap();
    // Blue alone: every split of its sweep.
    let _ = brdf::fit_samples_channel(&samples, 2, &settings);
    let alone = blue_splits.swap(0, Ordering::Relaxed);
    assert!(alone > 20, "blue alone solved {alone} splits");
    let err = three_threads()
        .install(|| brdf::fit_samples(&samples, "red unmeasured", &settings))
        .unwrap_err();
    // Red's own error, as without the stop.
    match &err {
        brdf::BrdfError::Fit { channel, source } => {
            assert_eq!(*channel, 'r', "{err}");
            assert!(
                !matches!(source, rational_core::FitError::Cancelled { .. }),
                "{err}"
            );
        }
        other => panic!("expected red's fit error, got {other}"),
    }
    let stopped = blue_splits.load(Ordering::Relaxed);
    assert!(
        stopped <= 2 && stopped < alone,
        "blue solved {stopped} splits after red failed ({alone} alone)"
    );
}

/// A function that fails names the fit's error only where none before it
/// fails too, so the functions before it settle just that: here blue has
/// no finite value and red, whose sweep finds a fit in many splits on its
/// own, stops at its next split and proves it has a fit with the largest
/// budget's first split. The error is blue's, as fitting each function in
/// turn gives.
#[test]
fn the_functions_before_a_failed_one_settle_only_whether_they_fit() {
    use std::sync::atomic::Ordering;
    let (samples, settings, red_splits) = one_channel_unmeasured(2, 0, 1);
    let settings = (settings.with_cap_rounds(0).unwrap())
        .with_rel_tol(0.003)
        .unwrap();
    // Red alone: a fit, after every split of its sweep.
    brdf::fit_samples_channel(&samples, 0, &settings).unwrap();
    let alone = red_splits.swap(0, Ordering::Relaxed);
    assert!(alone > 10, "red alone solved {alone} splits");
    let err = three_threads()
        .install(|| brdf::fit_samples(&samples, "blue unmeasured", &settings))
        .unwrap_err();
    match &err {
        brdf::BrdfError::Fit { channel, .. } => assert_eq!(*channel, 'b', "{err}"),
        other => panic!("expected blue's fit error, got {other}"),
    }
    // Progress is reported by the searches, not by the settling splits.
    let settled = red_splits.load(Ordering::Relaxed);
    assert!(
        settled <= 1 && settled < alone,
        "red solved {settled} splits of its search after blue failed ({alone} alone)"
    );
}

#[test]
// The value is the same computation as `exp` of the function, bit for bit.
#[allow(clippy::float_cmp)]
fn a_fit_on_the_log_scale_holds_the_same_intervals_on_the_value() {
    // A sharp lobe: its values span orders of magnitude over theta_h.
    let m = CookTorranceGgx {
        kd: [0.02, 0.05, 0.1],
        f0: [0.04; 3],
        alpha: 0.08,
    };
    let r = Reduction::default().with_resolution(40, 40);
    let fit_on = |scale| fit_brdf(&m, &settings(r).with_value_scale(scale)).unwrap();
    let (log, report) = fit_on(ValueScale::Log);
    let (linear, linear_report) = fit_on(ValueScale::Linear);
    assert_eq!(
        (log.scale, linear.scale),
        (ValueScale::Log, ValueScale::Linear)
    );
    assert!(report.to_string().contains("log scale"), "{report}");
    for c in &report.channels {
        assert!(c.verified, "{report}");
        // Of the value, exp(p / q), against the table: the same bound as on
        // the linear scale.
        assert!(c.max_rel <= 0.05 * (1.0 + 1e-9), "{report}");
    }
    // At every sample above the noise floor the value is exp of the
    // function, within the 5% interval.
    let samples = r.sample(&m);
    let mut checked = 0;
    for row in samples.rows.iter().filter(|r| !r.grazing) {
        let v = log.eval_coords(&row.point);
        for c in 0..3 {
            let floor = report.channels[c].noise_floor_abs / 0.05;
            if row.value[c] > floor {
                let exact = log.channels[c].eval(&row.point).exp();
                assert_eq!(v[c], exact.min(log.ceiling.map_or(f64::MAX, |k| k[c])));
                assert!((v[c] / row.value[c] - 1.0).abs() <= 0.05 * (1.0 + 1e-9));
                checked += 1;
            }
        }
    }
    assert!(checked > 1000, "{checked}");
    // The log scale follows the lobe with fewer coefficients.
    assert!(
        log.coefficients() < linear.coefficients(),
        "log {} vs linear {} coefficients ({linear_report})",
        log.coefficients(),
        linear.coefficients()
    );
    // It is saved as such, and a linear fit's file has no `scale` field.
    let json = serde_json::to_string(&log).unwrap();
    assert!(json.contains("\"scale\":\"log\""), "{json}");
    assert_eq!(serde_json::from_str::<FittedBrdf>(&json).unwrap(), log);
    assert!(!serde_json::to_string(&linear)
        .unwrap()
        .contains("\"scale\""));
    let edited = json.replace("\"scale\":\"log\"", "\"scale\":\"exp\"");
    assert!(serde_json::from_str::<FittedBrdf>(&edited).is_err());
}

/// Blue only near the specular direction (exactly zero elsewhere), red and
/// green everywhere.
struct BlueHighlight;

impl Brdf for BlueHighlight {
    fn eval(&self, wi: [f64; 3], wo: [f64; 3]) -> [f64; 3] {
        let [theta_h, _, _] = brdf::HalfDiff::isotropic_angles(wi, wo);
        [0.2, 0.2, if theta_h < 0.05 { 0.5 } else { 0.0 }]
    }
    fn name(&self) -> String {
        "blue highlight".into()
    }
}

#[test]
fn a_log_scale_interval_with_no_positive_value_names_its_function_and_sample() {
    // Most of the blue channel is exactly zero, so its visibility floor
    // (a fraction of the median cosine-weighted value) is zero too, and a
    // zero cell's interval is [0, 0], which no exp(p / q) reaches.
    let s = settings(Reduction::default().with_resolution(12, 12))
        .with_design(brdf::PerceptualBounds::default())
        .with_value_scale(ValueScale::Log);
    let e = fit_brdf(&BlueHighlight, &s).unwrap_err().to_string();
    assert!(
        e.contains("log-scale intervals") && e.contains("function b, sample"),
        "{e}"
    );
    assert!(e.contains("holds no positive value"), "{e}");
}

#[test]
fn a_centred_fit_at_its_largest_margin_points_is_the_plain_fit() {
    let m = blue_ggx();
    let base = settings(Reduction::default().with_resolution(30, 30));
    let (plain, plain_report) = fit_brdf(&m, &base).unwrap();
    assert!(plain.at_largest_margin(&plain_report).is_none());
    let engine = base.fit_settings().clone().with_centred_fit(true);
    let (centred, report) = fit_brdf(&m, &base.clone().with_fit_settings(engine)).unwrap();
    assert!(report.channels.iter().any(|c| c.centred), "{report}");
    let other = centred
        .at_largest_margin(&report)
        .expect("centred functions");
    // The same splits and bytes; each function the plain sweep's point.
    assert_eq!(other.byte_size_f32(), centred.byte_size_f32());
    assert_eq!(other, plain);
    assert_ne!(centred, plain);
}
