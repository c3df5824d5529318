//! Fits of analytic materials with known truth: verified channels,
//! reciprocity, exact JSON round-trips, 2-D and 3-D reductions.

use brdf::{
    fit_brdf, from_spherical, BlinnPhong, Brdf, BrdfFitSettings, CookTorranceGgx, Coordinates,
    FittedBrdf, Reduction, ReductionKind,
};

fn settings(r: Reduction) -> BrdfFitSettings {
    BrdfFitSettings::default()
        .with_reduction(r)
        .with_rel_tol(0.05)
        .unwrap()
}

#[test]
fn two_d_fit_is_verified_reciprocal_and_round_trips() {
    let m = CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.2,
    };
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
    let m = CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.2,
    };
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
