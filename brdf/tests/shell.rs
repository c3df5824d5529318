//! The shell factor beyond an elevation cut: what it changes, what it
//! leaves, and the files that carry it.

use brdf::{
    fit_brdf, Brdf, BrdfFitSettings, ColourMode, CookTorranceGgx, FittedBrdf, Reduction,
    ReductionKind, ShellColour, ShellFactor, ShellLayout, ThetaDSpacing, DEFAULT_SHELL_BINS,
};
use std::f64::consts::{FRAC_PI_2, PI};

fn glossy() -> CookTorranceGgx {
    CookTorranceGgx {
        kd: [0.1, 0.2, 0.3],
        f0: [0.04; 3],
        alpha: 0.35,
    }
}

/// A 3-D fit of `glossy` over the whole hemisphere, evaluated within 70
/// degrees.
fn within_70() -> FittedBrdf {
    within_70_in(ColourMode::Rgb)
}

/// [`within_70`] with the functions of `mode`.
fn within_70_in(mode: ColourMode) -> FittedBrdf {
    let reduction = Reduction::default()
        .with_kind(ReductionKind::Full3d)
        .with_resolution(10, 10)
        .with_phi_resolution(8)
        .whole_hemisphere();
    let settings = BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_colour_mode(mode)
        .with_rel_tol(0.2)
        .unwrap();
    let (fitted, _) = fit_brdf(&glossy(), &settings).unwrap();
    fitted.evaluated_within(70.0).unwrap()
}

/// Reflected luminance `int Y cos_i cos_o` over pairs beyond 70 degrees,
/// on a midpoint grid unlike the one the factor is fitted on.
fn shell_energy(b: &dyn Brdf) -> f64 {
    shell_energy_rgb(b)[0]
}

/// [`shell_energy`] of the luminance, then of each RGB channel.
fn shell_energy_rgb(b: &dyn Brdf) -> [f64; 4] {
    let (n, m) = (61, 50);
    let cos_cut = 70f64.to_radians().cos();
    let dir = |t: f64, p: f64| [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()];
    let mut sum = [0.0; 4];
    for i in 0..n {
        let ti = (i as f64 + 0.5) / n as f64 * FRAC_PI_2;
        for o in 0..n {
            let to = (o as f64 + 0.5) / n as f64 * FRAC_PI_2;
            for p in 0..m {
                let (wi, wo) = (
                    dir(ti, 0.0),
                    dir(to, (p as f64 + 0.5) / m as f64 * 2.0 * PI),
                );
                if wi[2] >= cos_cut && wo[2] >= cos_cut {
                    continue;
                }
                let w = wi[2] * wo[2] * ti.sin() * to.sin();
                let v = b.eval(wi, wo);
                sum[0] += w * brdf::luminance(v);
                for c in 0..3 {
                    sum[c + 1] += w * v[c];
                }
            }
        }
    }
    sum
}

#[test]
// Within the cut the shell must change nothing, bit for bit.
#[allow(clippy::float_cmp)]
fn the_shell_factor_carries_the_tables_grazing_energy_and_nothing_else() {
    let table = glossy();
    let within = within_70();
    let shell = ShellFactor::fit(&table, &within, DEFAULT_SHELL_BINS).unwrap();
    assert_eq!(shell.factors.len(), 32);
    assert_eq!(shell.byte_size_f32(), 128);
    // Every factor is an f32 value, as the byte count says.
    assert!(shell.factors.iter().all(|&k| f64::from(k as f32) == k));
    let shelled = within.clone().with_shell(shell.clone()).unwrap();
    assert_eq!(shelled.byte_size_f32(), within.byte_size_f32() + 128);
    let (e_table, e_within, e_shelled) = (
        shell_energy(&table),
        shell_energy(&within),
        shell_energy(&shelled),
    );
    let (before, after) = (
        (e_within / e_table - 1.0).abs(),
        (e_shelled / e_table - 1.0).abs(),
    );
    eprintln!(
        "grazing energy: table {e_table:.5}, fit {e_within:.5}, with the shell {e_shelled:.5}"
    );
    // On this grid (not the factor's own) the clamped fit misses by about
    // 3%, the shell by about 0.6%.
    assert!(before > 0.02, "the clamped fit is already within {before}");
    assert!(after < before / 3.0, "{before} -> {after}");
    // Within the cut: the same values; beyond it, the fit's times the
    // factor of the pair's cell.
    let dir = |t: f64, p: f64| {
        let (t, p) = (t.to_radians(), p.to_radians());
        [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
    };
    for (a, b) in [((10.0, 0.0), (60.0, 170.0)), ((69.0, 0.0), (5.0, 90.0))] {
        let (wi, wo) = (dir(a.0, a.1), dir(b.0, b.1));
        assert_eq!(shelled.eval(wi, wo), within.eval(wi, wo));
        assert_eq!(shell.multipliers(wi, wo, within.mode), [1.0; 3]);
    }
    for (a, b) in [((80.0, 0.0), (80.0, 180.0)), ((85.0, 0.0), (30.0, 90.0))] {
        let (wi, wo) = (dir(a.0, a.1), dir(b.0, b.1));
        let [k, _, _] = shell.multipliers(wi, wo, within.mode);
        assert_ne!(k, 1.0);
        let (plain, scaled) = (within.eval(wi, wo), shelled.eval(wi, wo));
        for c in 0..3 {
            assert!((scaled[c] - k * plain[c]).abs() <= 1e-12 * scaled[c].abs().max(1e-12));
        }
    }
}

#[test]
fn a_factor_per_function_carries_each_channels_grazing_energy() {
    // The glossy material's body is blue and its specular part white, so
    // its colour changes towards grazing; the fits keep the colour at 70
    // degrees.
    let table = glossy();
    let layout = ShellLayout::luminance([4, 4]).cosine();
    for mode in [ColourMode::Rgb, ColourMode::LuminanceChroma] {
        let within = within_70_in(mode);
        let luminance = ShellFactor::fit_layout(&table, &within, layout).unwrap();
        let coloured = ShellFactor::fit_layout(&table, &within, layout.per_function()).unwrap();
        assert_eq!(coloured.factors.len(), 48);
        assert_eq!(coloured.byte_size_f32(), 192);
        assert_eq!(coloured.layout(), layout.per_function());
        assert_eq!(
            layout.per_function().byte_size_f32(),
            coloured.byte_size_f32()
        );
        let e_table = shell_energy_rgb(&table);
        let off = |shell: &ShellFactor| {
            let shelled = within.clone().with_shell(shell.clone()).unwrap();
            let e = shell_energy_rgb(&shelled);
            (1..4)
                .map(|c| (e[c] / e_table[c] - 1.0).abs())
                .fold(0.0, f64::max)
        };
        let (by_luminance, by_function) = (off(&luminance), off(&coloured));
        eprintln!("{mode:?}: worst channel's grazing energy off by {by_luminance:.4} with one factor, {by_function:.4} with one per function");
        assert!(
            by_function < by_luminance / 2.0,
            "{mode:?}: {by_luminance} -> {by_function}"
        );
    }
}

#[test]
fn the_render_checks_layouts_start_with_the_uniform_luminance_ones() {
    // `choose_evaluation_cut` measures these first at every cut.
    for (k, bins) in brdf::SHELL_BIN_CHOICES.iter().enumerate() {
        assert_eq!(brdf::SHELL_CHOICES[k], ShellLayout::luminance(*bins));
    }
    for layout in brdf::SHELL_CHOICES {
        let cells = layout.bins[0] * layout.bins[1];
        assert_eq!(
            layout.byte_size_f32(),
            4 * cells * layout.colour.factors_per_cell()
        );
    }
    let labels: Vec<String> = brdf::SHELL_CHOICES.iter().map(ShellLayout::label).collect();
    assert_eq!(
        labels,
        [
            "8x4",
            "4x4",
            "4x4 cos",
            "1x4 cos",
            "1x4 cos colour",
            "4x4 cos colour"
        ]
    );
}

#[test]
// Factors stored as f32 values are compared exactly.
#[allow(clippy::float_cmp)]
fn cosine_bins_are_finer_towards_grazing_theta_d() {
    let shell = ShellFactor {
        cut_deg: 70.0,
        n_theta_h: 1,
        n_theta_d: 4,
        spacing: ThetaDSpacing::Cosine,
        colour: ShellColour::Luminance,
        factors: vec![1.5, 2.0, 3.0, 4.0],
    };
    shell.validate().unwrap();
    let dir = |t: f64, p: f64| {
        let (t, p) = (t.to_radians(), p.to_radians());
        [t.sin() * p.cos(), t.sin() * p.sin(), t.cos()]
    };
    // A mirror pair at 75 degrees: theta_d = 75, 1 - cos 75 = 0.74 (the
    // third bin of four), where uniform bins give the fourth (75 / 90 =
    // 0.83).
    let (wi, wo) = (dir(75.0, 0.0), dir(75.0, 180.0));
    assert_eq!(shell.multipliers(wi, wo, ColourMode::Rgb), [3.0; 3]);
    assert_eq!(
        shell.multipliers(wi, wo, ColourMode::LuminanceChroma),
        [3.0, 1.0, 1.0]
    );
    let uniform = ShellFactor {
        spacing: ThetaDSpacing::Uniform,
        ..shell.clone()
    };
    assert_eq!(uniform.multipliers(wi, wo, ColourMode::Rgb), [4.0; 3]);
    // One factor per function is read as the cell's three.
    let coloured = ShellFactor {
        colour: ShellColour::PerFunction,
        factors: (0..12).map(f64::from).collect(),
        ..shell
    };
    coloured.validate().unwrap();
    assert_eq!(
        coloured.multipliers(wi, wo, ColourMode::LuminanceChroma),
        [6.0, 7.0, 8.0]
    );
}

#[test]
fn a_shell_needs_a_cut_and_valid_bins() {
    let table = glossy();
    let within = within_70();
    let whole = FittedBrdf {
        reduction: within.reduction.whole_hemisphere(),
        ..within.clone()
    };
    let e = ShellFactor::fit(&table, &whole, DEFAULT_SHELL_BINS).unwrap_err();
    assert!(e.to_string().contains("no elevation cut"), "{e}");
    for bins in [[0, 4], [8, 65]] {
        let e = ShellFactor::fit(&table, &within, bins).unwrap_err();
        assert!(e.to_string().contains("bins"), "{e}");
    }
    let shell = ShellFactor::fit(&table, &within, [2, 2]).unwrap();
    let e = whole.with_shell(shell.clone()).unwrap_err();
    assert!(
        e.to_string().contains("not the reduction's elevation cut"),
        "{e}"
    );
    let shelled = within.with_shell(shell).unwrap();
    let e = ShellFactor::fit(&table, &shelled, [2, 2]).unwrap_err();
    assert!(e.to_string().contains("has a shell factor already"), "{e}");
}

/// `glossy` with NaN beyond 80 degrees: a table no factor can be fitted to.
struct NanAtGrazing(CookTorranceGgx);

impl Brdf for NanAtGrazing {
    fn eval(&self, wi: brdf::Vec3, wo: brdf::Vec3) -> [f64; 3] {
        let cos80 = 80f64.to_radians().cos();
        if wi[2] < cos80 || wo[2] < cos80 {
            return [f64::NAN; 3];
        }
        self.0.eval(wi, wo)
    }

    fn name(&self) -> String {
        "NaN at grazing".into()
    }
}

#[test]
fn a_table_of_non_finite_values_is_named_not_turned_into_a_factor() {
    let e = ShellFactor::fit(&NanAtGrazing(glossy()), &within_70(), DEFAULT_SHELL_BINS)
        .unwrap_err()
        .to_string();
    assert!(
        e.contains("the table's integral over cell") && e.contains("NaN"),
        "{e}"
    );
}

#[test]
fn fit_files_with_a_shell_round_trip_and_edited_ones_are_named() {
    let table = glossy();
    let within = within_70();
    let shelled = within
        .clone()
        .with_shell(ShellFactor::fit(&table, &within, [3, 2]).unwrap())
        .unwrap();
    let json = serde_json::to_string(&shelled).unwrap();
    let back: FittedBrdf = serde_json::from_str(&json).unwrap();
    assert_eq!(back, shelled);
    let mut value: serde_json::Value = serde_json::from_str(&json).unwrap();
    // Files written before the layout choices read as uniform luminance
    // factors; a layout that asks for more factors than the file holds is
    // named.
    let mut old = value.clone();
    let shell = old["shell"].as_object_mut().unwrap();
    assert!(shell.remove("spacing").is_some() && shell.remove("colour").is_some());
    let back: FittedBrdf = serde_json::from_value(old).unwrap();
    assert_eq!(back, shelled);
    let mut per_function = value.clone();
    per_function["shell"]["colour"] = serde_json::json!("per_function");
    let e = serde_json::from_value::<FittedBrdf>(per_function).unwrap_err();
    assert!(
        e.to_string().contains("6 factors for 6 cells of 3 each"),
        "{e}"
    );
    let mut unknown = value.clone();
    unknown["shell"]["spacing"] = serde_json::json!("log");
    let e = serde_json::from_value::<FittedBrdf>(unknown).unwrap_err();
    assert!(e.to_string().contains("unknown variant"), "{e}");
    let edits: [(&str, serde_json::Value, &str); 5] = [
        (
            "factors",
            serde_json::json!([1.0, 2.0]),
            "2 factors for 6 cells",
        ),
        (
            "factors",
            serde_json::json!([1.0, 1.0, -1.0, 1.0, 1.0, 1.0]),
            "factor 2 is -1",
        ),
        ("n_theta_h", serde_json::json!(0), "0 theta_h bins"),
        ("cut_deg", serde_json::json!(95.0), "outside (0, 90)"),
        (
            "cut_deg",
            serde_json::json!(75.0),
            "not the reduction's elevation cut",
        ),
    ];
    for (field, edited, expected) in edits {
        let original = value["shell"][field].clone();
        value["shell"][field] = edited;
        let e = serde_json::from_value::<FittedBrdf>(value.clone()).unwrap_err();
        assert!(e.to_string().contains(expected), "{field}: {e}");
        value["shell"][field] = original;
    }
    // A file without a shell reads as before.
    let plain = serde_json::to_string(&within).unwrap();
    assert!(!plain.contains("shell"));
    assert_eq!(serde_json::from_str::<FittedBrdf>(&plain).unwrap(), within);
}
