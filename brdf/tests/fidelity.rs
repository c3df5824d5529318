//! Every representation stays bounded over the whole hemisphere, and the
//! perceptual design fits a noisy table without a cut.

use brdf::baseline::fit_ggx;
use brdf::fidelity::{hemisphere_errors, HemisphereSettings};
use brdf::{
    fit_brdf, BlinnPhong, Brdf, BrdfFitSettings, ColourMode, DownsampledTable, Lobe, MerlBrdf,
    PerceptualBounds, Reduction, ReductionKind, ShellFactor, TabulateOptions, ValueScale,
    DEFAULT_SHELL_BINS,
};
use rational_core::{FitSettings, Search};

#[test]
// The evaluation within a cut must be the same computation, bit for bit.
#[allow(clippy::float_cmp)]
fn every_representation_is_bounded_on_the_whole_hemisphere() {
    let truth = BlinnPhong {
        kd: [0.3, 0.2, 0.1],
        ks: [0.3, 0.3, 0.3],
        exponent: 30.0,
    };
    let table = MerlBrdf::tabulate(
        &truth,
        TabulateOptions {
            noise: 0.02,
            seed: 3,
            missing_above_theta_d_deg: None,
        },
    );
    let settings = BrdfFitSettings::default()
        .with_reduction(
            Reduction::default()
                .with_kind(ReductionKind::Full3d)
                .with_resolution(12, 12)
                .with_phi_resolution(12)
                .whole_hemisphere(),
        )
        .with_design(PerceptualBounds::default().with_rel_tol(0.1).unwrap())
        .with_fit_settings(
            FitSettings::default()
                .with_coeff_range(2, 80)
                .unwrap()
                .with_search(Search::Staircase)
                .with_widening(2.0, 4)
                .unwrap(),
        );
    let (fitted, report) = fit_brdf(&table, &settings).unwrap();
    assert!(report.channels.iter().all(|c| c.verified));
    // The dense cap check covers the whole domain, the extrapolation beyond
    // the outermost cells included, and ends below the cap.
    for c in &report.channels {
        let k = c.cap.unwrap();
        assert!(k.largest > 0.0 && k.held(), "{}: {k:?}", c.channel);
    }
    // Every cell of the grid up to the horizon was constrained.
    assert!((fitted.reduction.max_elevation_deg - 90.0).abs() < 1e-12);
    // Evaluated within 70 degrees: the same functions, directions beyond
    // the cut moved onto it; a fit with a cut has no other.
    let within = fitted.evaluated_within(70.0).unwrap();
    assert!(within.evaluated_within(60.0).is_none());
    assert!(fitted.evaluated_within(90.0).is_none() && fitted.evaluated_within(0.0).is_none());
    let direction = |theta: f64, phi: f64| {
        let (t, p) = (theta.to_radians(), phi.to_radians());
        [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
    };
    let (inside, grazing) = (direction(30.0, 10.0), direction(85.0, 200.0));
    assert_eq!(
        within.eval(inside, direction(50.0, 140.0)),
        fitted.eval(inside, direction(50.0, 140.0))
    );
    let (sin_cut, cos_cut) = 70f64.to_radians().sin_cos();
    let onto_cut = brdf::clamp_elevation(grazing, cos_cut, sin_cut);
    assert_eq!(within.eval(grazing, inside), fitted.eval(onto_cut, inside));
    assert_ne!(within.eval(grazing, inside), fitted.eval(grazing, inside));
    // Lobe times rational in luminance-chroma: the lobe grows to
    // 1 / (pi alpha^4) at grazing mirror pairs, which the ratio's cap
    // (the table's cap divided by the lobe) must undo.
    let lobe_settings = settings
        .clone()
        .with_colour_mode(ColourMode::LuminanceChroma)
        .with_lobe(Some(Lobe::fit(&table)));
    let (with_lobe, report) = fit_brdf(&table, &lobe_settings).unwrap();
    assert!(report.channels.iter().all(|c| c.verified));
    let luminance = report.channels[0].cap.unwrap();
    assert!(luminance.held(), "{luminance:?}");
    eprintln!("{report}");
    assert!(with_lobe.lobe.is_some());
    // The luminance on the log scale: exp(p / q) grows fast where p / q
    // overshoots between samples, which the cap check (on the value) and
    // the ceiling must hold.
    let log_settings = settings
        .clone()
        .with_colour_mode(ColourMode::LuminanceChroma)
        .with_value_scale(ValueScale::Log);
    let (log, report) = fit_brdf(&table, &log_settings).unwrap();
    assert!(report.channels.iter().all(|c| c.verified));
    assert!(report.channels[0].cap.unwrap().held(), "{report}");
    assert_eq!(log.scale, ValueScale::Log);
    let hemisphere = HemisphereSettings {
        pairs: 6000,
        grid: [48, 48, 24],
        ..Default::default()
    };
    let down = DownsampledTable::new(&table, DownsampledTable::bins_for_bytes(1024));
    let shelled = within
        .clone()
        .with_shell(ShellFactor::fit(&table, &within, DEFAULT_SHELL_BINS).unwrap())
        .unwrap();
    let reps: [(&str, &dyn Brdf); 5] = [
        ("rational", &fitted),
        ("lobe x rational", &with_lobe),
        ("rational on the log scale", &log),
        ("rational within 70 degrees x shell factor", &shelled),
        ("table", &down),
    ];
    for (name, rep) in reps {
        let e = hemisphere_errors(&table, rep, &hemisphere);
        assert!(
            e.peak_ratio.is_finite() && e.peak_ratio <= 2.0,
            "{name}: largest value {}x the table's peak",
            e.peak_ratio
        );
        if name != "table" {
            // Inside the trusted elevations the fit follows the table to
            // its intervals (10% plus the 2% noise).
            assert!(e.bands[0].median < 0.1, "{name}: {e:?}");
        }
    }
    // The analytic peer is not bounded: Cook-Torrance's 1 / (4 cos_i cos_o)
    // grows without limit towards grazing, which the benchmark reports.
    let ggx = fit_ggx(&table).model;
    let e = hemisphere_errors(&table, &ggx, &hemisphere);
    assert!(e.peak_ratio > 2.0, "{e:?}");
}

/// Lambert with the horizon blow-up of a measured table (a value divided by
/// a vanishing `cos_i cos_o`), to 30x the trusted values at the horizon.
struct GrazingBlowUp(brdf::Lambert);

impl Brdf for GrazingBlowUp {
    fn eval(&self, wi: brdf::Vec3, wo: brdf::Vec3) -> [f64; 3] {
        let boost = 1.0 + 0.01 / (wi[2] * wo[2]).max(3e-4);
        self.0.eval(wi, wo).map(|v| v * boost)
    }

    fn name(&self) -> String {
        "Lambert blowing up at the horizon".into()
    }
}

#[test]
fn untrusted_grazing_values_raise_the_ceiling_of_plain_intervals_only() {
    let table = GrazingBlowUp(brdf::Lambert {
        albedo: [0.6, 0.4, 0.2],
    });
    let reduction = Reduction::default()
        .with_kind(ReductionKind::Full3d)
        .with_resolution(8, 8)
        .with_phi_resolution(8)
        .whole_hemisphere();
    let fit = FitSettings::default()
        .with_coeff_range(2, 40)
        .unwrap()
        .with_search(Search::Staircase)
        .with_widening(2.0, 6)
        .unwrap();
    let plain = BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_rel_tol(0.5)
        .unwrap()
        .with_fit_settings(fit.clone());
    let perceptual = plain
        .clone()
        .with_design(PerceptualBounds::default().with_rel_tol(0.2).unwrap());
    // The table on the fits' grid: its largest value beyond 80 degrees is
    // far above twice its largest within.
    let samples = reduction.sample(&table);
    let cos_80 = 80f64.to_radians().cos();
    let (mut trusted, mut anywhere) = ([0.0f64; 3], [0.0f64; 3]);
    for r in &samples.rows {
        let (wi, wo) = brdf::HalfDiff::pair_at(r.angles);
        for c in 0..3 {
            anywhere[c] = anywhere[c].max(r.value[c]);
            if wi[2].min(wo[2]) > cos_80 {
                trusted[c] = trusted[c].max(r.value[c]);
            }
        }
    }
    assert!(
        (0..3).all(|c| anywhere[c] > 4.0 * trusted[c]),
        "{trusted:?} {anywhere:?}"
    );
    let (fitted, report) = fit_brdf(&table, &perceptual).unwrap();
    assert!(report.channels.iter().all(|c| c.verified));
    let ceiling = fitted.ceiling.unwrap();
    for c in 0..3 {
        let expected = brdf::CEILING_OVER_PEAK * trusted[c];
        assert!(
            (ceiling[c] - expected).abs() <= 1e-9 * expected,
            "{c}: {ceiling:?} {trusted:?}"
        );
    }
    // Plain intervals hold the grazing values from below: the ceiling
    // rises to them, so that a value inside its interval stays inside.
    let (fitted, _) = fit_brdf(&table, &plain).unwrap();
    let ceiling = fitted.ceiling.unwrap();
    assert!(
        (0..3).all(|c| ceiling[c] >= anywhere[c]),
        "{ceiling:?} {anywhere:?}"
    );
}
