//! Tests of [`super::choose_evaluation_cut`] and what it measures.

use super::*;
use crate::fidelity::ValidationSettings;

/// A glossy material, its 3-D fit over the whole hemisphere on a
/// coarse grid, and small validation renders of it.
fn glossy_fit() -> (brdf::BlinnPhong, FittedBrdf, Validator) {
    let glossy = brdf::BlinnPhong {
        kd: [0.2, 0.3, 0.4],
        ks: [0.4, 0.4, 0.4],
        exponent: 8.0,
    };
    let reduction = brdf::Reduction::default()
        .with_kind(brdf::ReductionKind::Full3d)
        .with_resolution(6, 6)
        .with_phi_resolution(6)
        .whole_hemisphere();
    let settings = brdf::BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_baselines(false);
    let (fitted, _) = brdf::fit_brdf(&glossy, &settings).unwrap();
    let validator = Validator::new(
        Arc::new(glossy),
        ValidationSettings {
            size: 24,
            sky_spp: 4,
            ..RENDER_CHECK
        },
    )
    .unwrap();
    (glossy, fitted, validator)
}

/// Reusing the uncut fit's values inside a cut renders every variant
/// (each cut, with and without a shell factor, on both evaluation
/// paths) exactly as rendering it whole does.
#[test]
fn variants_inside_their_cut_reuse_the_uncut_values_to_the_last_bit() {
    let (glossy, fitted, validator) = glossy_fit();
    let mut reused = 0;
    for uses_f32 in [false, true] {
        let on_path = |fit: &FittedBrdf| -> Arc<dyn Brdf> {
            Arc::new(crate::FitInDomain::on_path(fit.clone(), uses_f32))
        };
        let base = validator.sample_values(&on_path(&fitted));
        for degrees in EVALUATION_CUTS {
            let plain = fitted.evaluated_within(degrees).unwrap();
            let shell = ShellFactor::fit(&glossy, &plain, [4, 4]).unwrap();
            let shelled = plain.clone().with_shell(shell).unwrap();
            let cos_inside = (degrees - INSIDE_MARGIN_DEG).to_radians().cos();
            let inside =
                move |wi: brdf::Vec3, wo: brdf::Vec3| wi[2] >= cos_inside && wo[2] >= cos_inside;
            for variant in [plain, shelled] {
                let whole = validator.measure(on_path(&variant)).unwrap();
                let fast = validator
                    .measure_reusing(on_path(&variant), &base, &inside)
                    .unwrap();
                assert_eq!(whole.images.len(), fast.images.len());
                for (a, b) in whole.images.iter().zip(&fast.images) {
                    assert!(a.pixels == b.pixels, "cut {degrees}, f32 {uses_f32}");
                }
                reused += 1;
            }
        }
    }
    assert_eq!(reused, 2 * 2 * EVALUATION_CUTS.len());
    // In f64, the fit's parts beyond each cut, taken once, give every
    // variant there (each shell layout) the render's values too.
    let base = validator.sample_values(&on_path_f64(&fitted));
    let mut shared = 0;
    for degrees in EVALUATION_CUTS {
        let plain = fitted.evaluated_within(degrees).unwrap();
        let cos_inside = (degrees - INSIDE_MARGIN_DEG).to_radians().cos();
        let inside =
            move |wi: brdf::Vec3, wo: brdf::Vec3| wi[2] >= cos_inside && wo[2] >= cos_inside;
        let parts = FitParts::new(&validator, &plain, &inside);
        let shelled = SHELL_CHOICES.iter().map(|&layout| {
            let shell = ShellFactor::fit_layout(&glossy, &plain, layout).unwrap();
            plain.clone().with_shell(shell).unwrap()
        });
        for variant in std::iter::once(plain.clone()).chain(shelled) {
            let whole = validator.measure(on_path_f64(&variant)).unwrap();
            let fast = validator
                .measure_with_parts(on_path_f64(&variant), &variant, &base, &inside, &parts)
                .unwrap();
            for (a, b) in whole.images.iter().zip(&fast.images) {
                let bits = |i: &crate::image::Image| {
                    i.pixels
                        .iter()
                        .flat_map(|p| p.map(f32::to_bits))
                        .collect::<Vec<_>>()
                };
                assert!(bits(a) == bits(b), "cut {degrees}");
            }
            shared += 1;
        }
    }
    assert_eq!(shared, EVALUATION_CUTS.len() * (1 + SHELL_CHOICES.len()));
    // The uncut fit differs beyond a cut: reusing its values
    // everywhere would render another image.
    let base = validator.sample_values(&on_path_f64(&fitted));
    let cut = on_path_f64(&fitted.evaluated_within(65.0).unwrap());
    let everywhere = |_: brdf::Vec3, _: brdf::Vec3| true;
    let wrong = validator
        .measure_reusing(cut.clone(), &base, &everywhere)
        .unwrap();
    let right = validator.measure(cut).unwrap();
    assert!(wrong.images[1].pixels != right.images[1].pixels);
}

/// A lower cut is tried only while the lowest cut measured gives the
/// best evaluation, the fit as given included, and only down to the
/// last of the lower cuts.
#[test]
fn lower_cuts_follow_while_the_lowest_cut_does_best() {
    let t = |cut: Option<f64>, de: f64| CutTried {
        cut,
        shell: false,
        shell_layout: None,
        bytes: 100,
        worst_mean_de: de,
    };
    let standard = [t(None, 3.0), t(Some(80.0), 2.5), t(Some(65.0), 2.0)];
    let bits = |c: Option<f64>| c.map(f64::to_bits);
    assert_eq!(
        bits(next_lower_cut(&standard, Some(65.0))),
        bits(Some(LOWER_CUTS[0]))
    );
    // A higher cut, or the whole hemisphere, does best: no lower cut.
    let higher = [t(None, 3.0), t(Some(70.0), 1.5), t(Some(65.0), 2.0)];
    assert!(next_lower_cut(&higher, Some(65.0)).is_none());
    let whole = [t(None, 1.0), t(Some(65.0), 2.0)];
    assert!(next_lower_cut(&whole, Some(65.0)).is_none());
    // Equal errors: the first measured (the higher cut) is the best.
    let tie = [t(None, 3.0), t(Some(70.0), 2.0), t(Some(65.0), 2.0)];
    assert!(next_lower_cut(&tie, Some(65.0)).is_none());
    // Each lower cut in turn, then none below the last.
    let mut more = standard.to_vec();
    more.push(t(Some(LOWER_CUTS[0]), 1.0));
    assert_eq!(
        bits(next_lower_cut(&more, Some(LOWER_CUTS[0]))),
        bits(Some(LOWER_CUTS[1]))
    );
    let last = LOWER_CUTS[LOWER_CUTS.len() - 1];
    more.push(t(Some(last), 0.5));
    assert!(next_lower_cut(&more, Some(last)).is_none());
    assert!(next_lower_cut(&more, None).is_none());
}

fn on_path_f64(fit: &FittedBrdf) -> Arc<dyn Brdf> {
    Arc::new(crate::FitInDomain::on_path(fit.clone(), false))
}

/// The glossy fit's errors and its evaluation cut chosen with no target
/// and no byte budget.
fn whole_hemisphere_choice() -> (
    brdf::BlinnPhong,
    FittedBrdf,
    Validator,
    RenderErrors,
    CutChoice,
) {
    let (glossy, fitted, validator) = glossy_fit();
    let errors = validator
        .measure(Arc::new(crate::FitInDomain::new(fitted.clone())))
        .unwrap();
    let choice = choose_evaluation_cut(
        &validator,
        &glossy,
        fitted.clone(),
        errors.clone(),
        None,
        None,
    )
    .unwrap();
    (glossy, fitted, validator, errors, choice)
}

#[test]
fn the_cut_chosen_is_the_best_of_those_measured_and_cut_fits_are_kept() {
    let (_, fitted, _, errors, choice) = whole_hemisphere_choice();
    let whole = errors.worst_mean();
    // None and every cut measured, without and with each shell factor
    // on uniform luminance bins, and the other layouts at the best of
    // those cuts; the chosen one has the lowest error.
    let (first, more) = (
        SHELL_BIN_CHOICES.len(),
        SHELL_CHOICES.len() - SHELL_BIN_CHOICES.len(),
    );
    // The standard cuts, then the lower ones in turn while the lowest
    // did best.
    let mut measured_cuts: Vec<f64> = Vec::new();
    for c in choice.tried.iter().filter_map(|t| t.cut) {
        if !measured_cuts.iter().any(|m| m.to_bits() == c.to_bits()) {
            measured_cuts.push(c);
        }
    }
    let standard = EVALUATION_CUTS.len();
    let lower = &measured_cuts[standard..];
    let bits = |v: &[f64]| v.iter().map(|c| c.to_bits()).collect::<Vec<_>>();
    assert_eq!(bits(&measured_cuts[..standard]), bits(&EVALUATION_CUTS));
    assert_eq!(bits(lower), bits(&LOWER_CUTS[..lower.len()]));
    let cuts = measured_cuts.len();
    assert_eq!(choice.tried.len(), 1 + (1 + first) * cuts + more);
    assert_eq!(choice.shell, choice.fitted.shell.is_some());
    assert_eq!(
        choice.tried.iter().filter(|t| t.shell).count(),
        first * cuts + more
    );
    let stage_one = &choice.tried[1..1 + (1 + first) * cuts];
    let best_cut = stage_one
        .iter()
        .min_by(|a, b| a.worst_mean_de.total_cmp(&b.worst_mean_de))
        .unwrap()
        .cut;
    for t in &choice.tried[1 + (1 + first) * cuts..] {
        assert_eq!(t.cut, best_cut);
        assert!(!SHELL_BIN_CHOICES
            .iter()
            .any(|&bins| t.shell_layout == Some(ShellLayout::luminance(bins))));
    }
    for t in &choice.tried {
        let shell_bytes = t.shell_layout.map_or(0, |l| l.byte_size_f32());
        assert_eq!(t.bytes, fitted.byte_size_f32() + shell_bytes);
    }
    assert!((choice.tried[0].worst_mean_de - whole).abs() < 1e-12);
    let lowest = choice
        .tried
        .iter()
        .map(|t| t.worst_mean_de)
        .fold(f64::INFINITY, f64::min);
    assert!((choice.errors.worst_mean() - lowest).abs() < 1e-12);
    let cut_in_file = choice.fitted.reduction.max_elevation_deg;
    assert!((cut_in_file - choice.cut.unwrap_or(90.0)).abs() < 1e-12);
    assert_eq!(choice.fitted.channels, fitted.channels);
}

/// A target every evaluation reaches takes the fewest bytes, one none
/// reaches the lowest error, and a byte budget no shell factor fits in
/// keeps the fit without one.
#[test]
fn targets_and_byte_budgets_choose_among_the_evaluations() {
    let (glossy, fitted, validator, errors, choice) = whole_hemisphere_choice();
    let lowest = choice
        .tried
        .iter()
        .map(|t| t.worst_mean_de)
        .fold(f64::INFINITY, f64::min);
    let reached = choose_evaluation_cut(
        &validator,
        &glossy,
        fitted.clone(),
        errors.clone(),
        Some(1e9),
        None,
    )
    .unwrap();
    assert_eq!(
        reached.fitted.byte_size_f32(),
        fitted.byte_size_f32(),
        "{}",
        reached.describe()
    );
    assert!(!reached.shell);
    let missed = choose_evaluation_cut(
        &validator,
        &glossy,
        fitted.clone(),
        errors.clone(),
        Some(1e-9),
        None,
    )
    .unwrap();
    assert!((missed.errors.worst_mean() - lowest).abs() < 1e-12);
    let budget = fitted.byte_size_f32();
    let small = choose_evaluation_cut(
        &validator,
        &glossy,
        fitted.clone(),
        errors.clone(),
        None,
        Some(budget),
    )
    .unwrap();
    assert!(!small.shell && small.fitted.byte_size_f32() == budget);
    let plain_lowest = choice
        .tried
        .iter()
        .filter(|t| !t.shell)
        .map(|t| t.worst_mean_de)
        .fold(f64::INFINITY, f64::min);
    assert!((small.errors.worst_mean() - plain_lowest).abs() < 1e-12);
}

/// A fit that already has a cut keeps it, with or without the shell.
#[test]
fn a_fit_with_its_own_cut_keeps_it() {
    let (glossy, fitted, validator) = glossy_fit();
    let mut within = fitted;
    within.reduction = within.reduction.with_max_elevation(75.0);
    let errors = validator
        .measure(Arc::new(crate::FitInDomain::new(within.clone())))
        .unwrap();
    let kept = choose_evaluation_cut(
        &validator,
        &glossy,
        within.clone(),
        errors.clone(),
        None,
        None,
    )
    .unwrap();
    // Every layout at its own cut.
    assert_eq!(kept.tried.len(), 1 + SHELL_CHOICES.len());
    // Under a byte budget 48 bytes above the fit, the layouts that
    // would pass it are not measured, and the choice is the best of
    // the full measurement within the budget.
    let budget = within.byte_size_f32() + 48;
    let budgeted = choose_evaluation_cut(
        &validator,
        &glossy,
        within.clone(),
        errors,
        None,
        Some(budget),
    )
    .unwrap();
    let fits = |t: &&CutTried| t.bytes <= budget;
    let affordable: Vec<&CutTried> = kept.tried.iter().filter(fits).collect();
    assert_eq!(
        affordable.len(),
        3,
        "the fit, 1 x 4 cos and 1 x 4 cos colour"
    );
    assert_eq!(budgeted.tried.len(), affordable.len());
    assert!(budgeted.tried.iter().all(|t| t.bytes <= budget));
    let best = affordable
        .iter()
        .map(|t| t.worst_mean_de)
        .fold(f64::INFINITY, f64::min);
    assert!((budgeted.errors.worst_mean() - best).abs() < 1e-12);
    for t in &kept.tried[1..] {
        assert_eq!((t.cut, t.shell), (Some(75.0), true));
    }
    assert_eq!(kept.fitted.reduction, within.reduction);
    if kept.shell {
        assert_eq!(kept.cut, Some(75.0));
        let bytes = kept.fitted.shell.as_ref().unwrap().byte_size_f32();
        assert!(kept
            .describe()
            .contains(&format!("75 degrees and a shell factor of {bytes} bytes")));
    } else {
        assert_eq!(kept.cut, None);
        assert!(kept.describe().contains("the fit's own cut of 75 degrees"));
    }
    // With its shell it is measured as it is.
    let shelled = within
        .clone()
        .with_shell(ShellFactor::fit(&glossy, &within, brdf::DEFAULT_SHELL_BINS).unwrap())
        .unwrap();
    let errors = validator
        .measure(Arc::new(crate::FitInDomain::new(shelled.clone())))
        .unwrap();
    let kept = choose_evaluation_cut(&validator, &glossy, shelled, errors, None, None).unwrap();
    assert_eq!((kept.cut, kept.shell, kept.tried.len()), (None, true, 1));
    assert!(kept
        .describe()
        .contains("own cut of 75 degrees and its shell factor"));
}

fn tried(worst_mean_de: f64, bytes: usize) -> CutTried {
    CutTried {
        cut: Some(70.0),
        shell: true,
        shell_layout: Some(ShellLayout::luminance([4, 4])),
        bytes,
        worst_mean_de,
    }
}

#[test]
fn a_target_prefers_the_smallest_evaluation_that_reaches_it() {
    let list = [
        tried(1.4, 960),
        tried(1.1, 1088),
        tried(0.97, 1024),
        tried(0.95, 1088),
    ];
    // Without a target, or one none reaches: the lowest error.
    assert_eq!(preferred(&list, None, None), 3);
    assert_eq!(preferred(&list, Some(0.5), None), 3);
    // The smallest that reaches it; the lower error between equal sizes.
    assert_eq!(preferred(&list, Some(1.0), None), 2);
    assert_eq!(preferred(&list, Some(1.2), None), 2);
    assert_eq!(preferred(&list, Some(1.5), None), 0);
    // Equal errors: the fewer bytes.
    assert_eq!(
        preferred(&[tried(1.0, 1088), tried(1.0, 1024)], None, None),
        1
    );
    // A byte budget leaves out what passes it, unless everything does.
    assert_eq!(preferred(&list, None, Some(1024)), 2);
    assert_eq!(preferred(&list, Some(0.5), Some(1000)), 0);
    assert_eq!(preferred(&list, Some(1.0), Some(1000)), 0);
    assert_eq!(preferred(&list, None, Some(900)), 3);
}
