//! The f32 path, the compact binary format and the generated shaders.

use brdf::shader::{shader_source, shader_source_named, Language};
use brdf::{
    compact::to_f32, fit_brdf, from_spherical, BatchedFit, BlinnPhong, Brdf, BrdfFitSettings,
    ColourMode, CompactBrdf, CookTorranceGgx, Coordinates, FittedBrdf, Lobe, PhiCoordinate,
    Reduction, ReductionKind, ShellColour, ShellFactor, ShellLayout, ThetaDSpacing, ValueScale,
};

fn fits() -> Vec<FittedBrdf> {
    let m = CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.2,
    };
    let b = BlinnPhong {
        kd: [0.2; 3],
        ks: [0.3; 3],
        exponent: 12.0,
    };
    let mut out = Vec::new();
    for (coords, kind) in [
        (Coordinates::SqrtThetaH, ReductionKind::Slice2d),
        (Coordinates::Cosines, ReductionKind::Slice2d),
        (Coordinates::Radians, ReductionKind::Full3d),
    ] {
        let mut r = Reduction::default()
            .with_coordinates(coords)
            .with_kind(kind)
            .with_resolution(24, 24);
        if kind == ReductionKind::Full3d {
            r = r.with_resolution(12, 12).with_phi_resolution(10);
        }
        if coords == Coordinates::Cosines {
            // No elevation cut: every export must leave it out.
            r = r.whole_hemisphere();
        }
        let mut s = BrdfFitSettings::default().with_reduction(r);
        if kind == ReductionKind::Full3d {
            // A weighted degree order: every export must carry it.
            let fit = rational_core::FitSettings::default()
                .with_coeff_range(2, 60)
                .unwrap()
                .with_degree_weights(vec![1, 2, 2])
                .unwrap();
            s = s.with_fit_settings(fit);
        }
        let (f, _) = if kind == ReductionKind::Full3d {
            fit_brdf(&b, &s).unwrap()
        } else {
            fit_brdf(&m, &s).unwrap()
        };
        out.push(f);
    }
    // The luminance-chroma mode: every export and evaluator combines the
    // three functions the same way.
    let s = BrdfFitSettings::default()
        .with_reduction(Reduction::default().with_resolution(24, 24))
        .with_colour_mode(ColourMode::LuminanceChroma);
    let (f, _) = fit_brdf(&m, &s).unwrap();
    assert_eq!(f.mode, ColourMode::LuminanceChroma);
    out.push(f);
    // Lobe times rational, in both colour modes (and 3-D): every evaluator
    // multiplies by the same lobe.
    let lobe = Lobe::fit(&b);
    for (mode, kind) in [
        (ColourMode::Rgb, ReductionKind::Slice2d),
        (ColourMode::LuminanceChroma, ReductionKind::Full3d),
    ] {
        let r = Reduction::default()
            .with_kind(kind)
            .with_resolution(12, 12)
            .with_phi_resolution(8)
            .whole_hemisphere();
        let s = BrdfFitSettings::default()
            .with_reduction(r)
            .with_colour_mode(mode)
            .with_lobe(Some(lobe));
        let (f, _) = fit_brdf(&b, &s).unwrap();
        assert_eq!(f.lobe, Some(lobe));
        out.push(f);
    }
    // A tabulated factor beyond an elevation cut, on an RGB fit and on a
    // luminance-chroma fit with a lobe, in each layout: every evaluator
    // reads the unclamped pair, finds the same cell and multiplies the same
    // functions.
    let last = out.len() - 1;
    let layout = ShellLayout::luminance([6, 3]);
    for (k, table) in [(1, &m as &dyn Brdf), (last, &b as &dyn Brdf)] {
        for layout in [layout, layout.cosine(), layout.cosine().per_function()] {
            let within = out[k].evaluated_within(60.0).unwrap();
            let shell = ShellFactor::fit_layout(table, &within, layout).unwrap();
            out.push(within.with_shell(shell).unwrap());
        }
    }
    // Functions on the log scale, in both colour modes, every function or
    // the luminance alone (one with a lobe, one with a shell): every
    // evaluator and export takes the same `exp` of the same functions.
    for (mode, lobe, scale) in [
        (ColourMode::Rgb, None, ValueScale::Log),
        (
            ColourMode::LuminanceChroma,
            Some(lobe),
            ValueScale::LogLight,
        ),
        (ColourMode::LuminanceChroma, None, ValueScale::Log),
    ] {
        let s = BrdfFitSettings::default()
            .with_reduction(
                Reduction::default()
                    .with_resolution(24, 24)
                    .whole_hemisphere(),
            )
            .with_colour_mode(mode)
            .with_lobe(lobe)
            .with_value_scale(scale);
        let (f, _) = fit_brdf(&m, &s).unwrap();
        assert_eq!(f.scale, scale);
        out.push(f);
    }
    let log = out.len() - 1;
    let within = out[log].evaluated_within(60.0).unwrap();
    let shell = ShellFactor::fit_layout(&m, &within, layout.cosine()).unwrap();
    out.push(within.with_shell(shell).unwrap());
    // `cos phi_d` as the third coordinate: every evaluator, export and
    // shader maps `phi_d` the same way.
    let r = Reduction::default()
        .with_kind(ReductionKind::Full3d)
        .with_resolution(12, 12)
        .with_phi_resolution(8)
        .with_phi(PhiCoordinate::Cosine)
        .whole_hemisphere();
    let (f, _) = fit_brdf(&b, &BrdfFitSettings::default().with_reduction(r)).unwrap();
    assert_eq!(f.reduction.phi, PhiCoordinate::Cosine);
    out.push(f);
    out
}

/// Deterministic direction pairs over the hemisphere.
fn pairs(n: usize) -> Vec<([f64; 3], [f64; 3])> {
    (0..n)
        .map(|k| {
            let u = |s: f64| ((k as f64 + 0.5) * s).fract();
            (
                from_spherical(1.3 * u(0.618_034), std::f64::consts::TAU * u(0.754_878)),
                from_spherical(1.3 * u(0.569_840), std::f64::consts::TAU * u(0.851_249)),
            )
        })
        .collect()
}

/// Basis length and condition number of evaluating channel `ch`'s value
/// (`p / q`, or its `exp` on the log scale) at `x`: the factor by which rounding of the coordinates, recurrences
/// and sums grows in the value.
fn conditioning(f: &FittedBrdf, ch: usize, x: &[f64]) -> (usize, f64) {
    let r = &f.channels[ch];
    let n = r.basis().len();
    let mut phi = vec![0.0; n];
    r.basis().eval_into(x, &mut phi);
    let sum_abs = |c: &[f64]| -> f64 { c.iter().zip(&phi).map(|(a, b)| (a * b).abs()).sum() };
    let (p, q) = r.eval_parts(x);
    let kappa = sum_abs(r.numerator()) / p.abs().max(1e-300)
        + sum_abs(r.denominator()) / q.abs().max(1e-300);
    // On the log scale a relative error e in r is an error e |r| in
    // ln(value): the value's relative error grows by |r|.
    let gain = match f.scale.of(f.mode, ch) {
        ValueScale::Log => (p / q).abs().max(1.0),
        _ => 1.0,
    };
    (n, kappa * gain)
}

#[test]
fn f32_path_agrees_with_f64_within_evaluation_conditioning() {
    for f in fits() {
        let c = CompactBrdf::from_fitted(&f);
        // 2003 pairs: the batched path's last batch is short.
        let all = pairs(2003);
        let wi32: Vec<[f32; 3]> = all.iter().map(|p| to_f32(p.0)).collect();
        let wo32: Vec<[f32; 3]> = all.iter().map(|p| to_f32(p.1)).collect();
        let batched = c.eval_many_batched(&wi32, &wo32);
        for (i, &(wi, wo)) in all.iter().enumerate() {
            let exact = brdf::Brdf::eval(&f, wi, wo);
            let fast = c.eval(to_f32(wi), to_f32(wo));
            let x = f.coordinates(wi, wo);
            for ch in 0..3 {
                let (n, kappa) = conditioning(&f, ch, &x);
                let tol = 64.0 * f32::EPSILON as f64 * n as f64 * kappa * exact[ch].abs() + 1e-6;
                assert!(
                    (fast[ch] as f64 - exact[ch]).abs() <= tol,
                    "channel {ch}: f32 {} vs f64 {} (tolerance {tol:e})",
                    fast[ch],
                    exact[ch]
                );
                // The batched path (a polynomial atan2) within the same bound.
                assert!(
                    (batched[i][ch] as f64 - exact[ch]).abs() <= tol,
                    "channel {ch}: batched f32 {} vs f64 {} (tolerance {tol:e})",
                    batched[i][ch],
                    exact[ch]
                );
            }
        }
        // Below the horizon: zero, as pair by pair.
        let down = [[0.0, 0.6, -0.8], [0.0, 0.0, 1.0]];
        let mut out = [[1.0f32; 3]; 2];
        c.eval_batch(&down, &[[0.0, 0.0, 1.0]; 2], &mut out);
        let bits = |v: [f32; 3]| v.map(f32::to_bits);
        assert_eq!(bits(out[0]), [0; 3]);
        // At the normal every angle is 0 exactly on both paths.
        assert_eq!(bits(out[1]), bits(c.eval([0.0, 0.0, 1.0], [0.0, 0.0, 1.0])));
    }
}

#[test]
fn the_batched_f64_path_equals_the_fit_to_rounding() {
    for f in fits() {
        let batched = BatchedFit::new(f.clone());
        // 2003 pairs up to 86 degrees (beyond the cut of the fits that
        // have one), then two below the horizon: the last batch is short.
        let mut all: Vec<_> = pairs(2003)
            .into_iter()
            .map(|(a, b)| (a, brdf::rotate(b, [1.0, 0.0, 0.0], 0.2)))
            .filter(|p| p.1[2] > 0.0)
            .collect();
        all.extend([
            ([0.0, 0.6, -0.8], [0.0, 0.0, 1.0]),
            ([0.0, 0.0, 1.0], [0.0, 0.0, 1.0]),
        ]);
        let wi: Vec<[f64; 3]> = all.iter().map(|p| p.0).collect();
        let wo: Vec<[f64; 3]> = all.iter().map(|p| p.1).collect();
        let mut out = vec![[f64::NAN; 3]; all.len()];
        batched.eval_batch(&wi, &wo, &mut out);
        for (&(a, b), got) in all.iter().zip(&out) {
            let exact = brdf::Brdf::eval(&f, a, b);
            if a[2] <= 0.0 {
                assert_eq!(got.map(f64::to_bits), [0; 3]);
                continue;
            }
            let x = f.coordinates(a, b);
            for ch in 0..3 {
                let (n, kappa) = conditioning(&f, ch, &x);
                let tol = 64.0 * f64::EPSILON * n as f64 * kappa * exact[ch].abs() + 1e-14;
                assert!(
                    (got[ch] - exact[ch]).abs() <= tol,
                    "channel {ch} at {a:?}, {b:?}: batched {} vs {} (tolerance {tol:e})",
                    got[ch],
                    exact[ch]
                );
            }
        }
    }
}

#[test]
fn compact_binary_round_trips() {
    for f in fits() {
        let c = CompactBrdf::from_fitted(&f);
        let bytes = c.to_bytes();
        let back = CompactBrdf::from_bytes(&bytes).unwrap();
        assert_eq!(back, c);
        assert_eq!(back.to_bytes(), bytes);
        let cut = f.reduction.max_elevation_deg < 90.0;
        assert_eq!(c.has_elevation_cut(), cut);
        let lobe_end = if cut { 16 } else { 12 } + if f.lobe.is_some() { 28 } else { 0 };
        let shell_at = lobe_end + if f.ceiling.is_some() { 12 } else { 0 };
        let header = shell_at + f.shell.as_ref().map_or(0, |sh| 2 + sh.byte_size_f32());
        assert!(bytes.len() < header + 3 * (5 + 3 + 4 * (6 + 60)));
        // Every fit of measured or analytic data has a ceiling, above its peak.
        let ceiling = f.ceiling.expect("a ceiling");
        assert_eq!(back.ceiling, Some(ceiling.map(|v| v as f32)));
        let weighted = f.channels.iter().any(|r| r.basis().is_weighted());
        let chroma = f.mode == ColourMode::LuminanceChroma;
        assert_eq!(
            bytes[7],
            u8::from(weighted)
                | (u8::from(chroma) << 1)
                | (u8::from(cut) << 2)
                | (u8::from(f.lobe.is_some()) << 3)
                | (1 << 4)
                | (u8::from(f.shell.is_some()) << 5)
                | (u8::from(
                    f.shell
                        .as_ref()
                        .is_some_and(|sh| sh.spacing == ThetaDSpacing::Cosine)
                ) << 6)
                | (u8::from(
                    f.shell
                        .as_ref()
                        .is_some_and(|sh| sh.colour == ShellColour::PerFunction)
                ) << 7),
            "flags byte"
        );
        assert_eq!(
            bytes[4] & 0x20 != 0,
            f.reduction.phi == PhiCoordinate::Cosine,
            "bit 5 of the coordinates byte marks cos phi_d"
        );
        if let Some(sh) = &f.shell {
            assert_eq!(bytes[shell_at..shell_at + 2], [6, 3]);
            // A negative factor, a factor of an empty grid, a truncated
            // table and a shell without a cut are named.
            let mut bad = bytes.clone();
            bad[shell_at + 2..shell_at + 6].copy_from_slice(&(-1.0f32).to_le_bytes());
            let e = CompactBrdf::from_bytes(&bad).unwrap_err().to_string();
            assert!(e.contains("shell factor -1"), "{e}");
            let mut empty = bytes.clone();
            empty[shell_at] = 0;
            let e = CompactBrdf::from_bytes(&empty).unwrap_err().to_string();
            assert!(e.contains("shell factor bins 0 x 3"), "{e}");
            let mut short = bytes.clone();
            short.truncate(shell_at + 2 + sh.byte_size_f32() - 1);
            let e = CompactBrdf::from_bytes(&short).unwrap_err().to_string();
            assert!(e.contains("truncated shell factor"), "{e}");
            let mut uncut = bytes.clone();
            uncut[7] &= !4;
            let e = CompactBrdf::from_bytes(&uncut).unwrap_err().to_string();
            assert!(e.contains("shell factor without an elevation cut"), "{e}");
        } else {
            // The shell's layout bits without a shell are named.
            let mut stray = bytes.clone();
            stray[7] |= 64;
            let e = CompactBrdf::from_bytes(&stray).unwrap_err().to_string();
            assert!(e.contains("without a shell factor"), "{e}");
        }
        let mut negative = bytes.clone();
        negative[lobe_end + 4..lobe_end + 8].copy_from_slice(&(-1.0f32).to_le_bytes());
        let e = CompactBrdf::from_bytes(&negative).unwrap_err().to_string();
        assert!(e.contains("ceiling"), "{e}");
        let mut short = bytes.clone();
        short.truncate(lobe_end + 6);
        let e = CompactBrdf::from_bytes(&short).unwrap_err().to_string();
        assert!(e.contains("truncated ceiling"), "{e}");
        if f.lobe.is_some() {
            // The lobe's roughness is the last of its seven values.
            let at = lobe_end - 4;
            let mut rough = bytes.clone();
            rough[at..lobe_end].copy_from_slice(&0.0f32.to_le_bytes());
            let e = CompactBrdf::from_bytes(&rough).unwrap_err().to_string();
            assert!(e.contains("lobe") && e.contains("roughness"), "{e}");
            let mut short = bytes.clone();
            short.truncate(lobe_end - 2);
            let e = CompactBrdf::from_bytes(&short).unwrap_err().to_string();
            assert!(e.contains("truncated lobe"), "{e}");
            // ALTA's p / q cannot carry the lobe.
            let e = brdf::AltaRational::from_fitted(&f).unwrap_err().to_string();
            assert!(e.contains("lobe"), "{e}");
        }
        assert_eq!(back.mode, f.mode);
        if weighted {
            assert_eq!(back.channels[0].weights, vec![1, 2, 2]);
            // The first channel's weights follow its family, n_p and n_q.
            let mut zero = bytes.clone();
            zero[header + 5] = 0;
            let e = CompactBrdf::from_bytes(&zero).unwrap_err().to_string();
            assert!(e.contains("degree weight"), "{e}");
        }
        if cut {
            let mut wide = bytes.clone();
            wide[12..16].copy_from_slice(&2.0f32.to_le_bytes());
            let e = CompactBrdf::from_bytes(&wide).unwrap_err().to_string();
            assert!(e.contains("elevation cut"), "{e}");
        }
        let mut nan = bytes.clone();
        let last = nan.len() - 4;
        nan[last..].copy_from_slice(&f32::NAN.to_le_bytes());
        let e = CompactBrdf::from_bytes(&nan).unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
        let mut two = bytes.clone();
        two[6] = 2;
        let e = CompactBrdf::from_bytes(&two).unwrap_err().to_string();
        assert!(e.contains("channels"), "{e}");
        let mut cut = bytes.clone();
        cut.truncate(bytes.len() - 3);
        assert!(CompactBrdf::from_bytes(&cut).is_err());
        assert!(CompactBrdf::from_bytes(b"nope").is_err());
        let mut flags = bytes.clone();
        flags[7] = 0x80;
        let e = CompactBrdf::from_bytes(&flags).unwrap_err().to_string();
        assert!(e.contains("flags"), "{e}");
    }
}

/// Parses and validates WGSL with naga, panicking with the source on error.
fn valid_wgsl(wgsl: &str) -> naga::Module {
    let module = naga::front::wgsl::parse_str(wgsl)
        .unwrap_or_else(|e| panic!("{}\n{wgsl}", e.emit_to_string(wgsl)));
    naga::valid::Validator::new(
        naga::valid::ValidationFlags::all(),
        naga::valid::Capabilities::all(),
    )
    .validate(&module)
    .unwrap_or_else(|e| panic!("{e:?}\n{wgsl}"));
    module
}

#[test]
fn generated_wgsl_and_glsl_are_valid_shaders() {
    for f in fits() {
        let c = CompactBrdf::from_fitted(&f);
        let module = valid_wgsl(&shader_source(&c, Language::Wgsl));
        assert!(module
            .functions
            .iter()
            .any(|(_, f)| f.name.as_deref() == Some("ratfit_brdf")));
        // The elevation cut lives in the generated code, as in the f32 path.
        assert_eq!(
            module
                .functions
                .iter()
                .any(|(_, f)| f.name.as_deref() == Some("ratfit_to_cut")),
            c.has_elevation_cut()
        );
        assert_eq!(
            module
                .functions
                .iter()
                .any(|(_, f)| f.name.as_deref() == Some("ratfit_lobe")),
            c.lobe.is_some()
        );
        assert_eq!(
            module
                .functions
                .iter()
                .any(|(_, f)| f.name.as_deref() == Some("ratfit_shell")),
            c.shell.is_some()
        );

        let glsl = format!(
            "#version 450\n{}\nlayout(location = 0) out vec4 color;\nvoid main() {{ color = vec4(ratfit_brdf(vec3(0.0, 0.6, 0.8), vec3(0.0, -0.6, 0.8)), 1.0); }}\n",
            shader_source(&c, Language::Glsl)
        );
        let mut front = naga::front::glsl::Frontend::default();
        let module = front
            .parse(
                &naga::front::glsl::Options::from(naga::ShaderStage::Fragment),
                &glsl,
            )
            .unwrap_or_else(|e| panic!("{e:?}\n{glsl}"));
        naga::valid::Validator::new(
            naga::valid::ValidationFlags::all(),
            naga::valid::Capabilities::all(),
        )
        .validate(&module)
        .unwrap_or_else(|e| panic!("{e:?}\n{glsl}"));
    }
}

#[test]
fn named_shaders_of_several_fits_live_in_one_module() {
    let all = fits();
    let mut wgsl = String::new();
    for (k, f) in all.iter().enumerate() {
        let c = CompactBrdf::from_fitted(f);
        let one = shader_source_named(&c, Language::Wgsl, &format!("fit{k}")).unwrap();
        assert!(!one.contains("ratfit_") && !one.contains("RATFIT_"));
        wgsl += &one;
    }
    let module = valid_wgsl(&wgsl);
    for k in 0..all.len() {
        let name = format!("fit{k}_brdf");
        assert!(module
            .functions
            .iter()
            .any(|(_, f)| f.name.as_deref() == Some(name.as_str())));
    }
    let c = CompactBrdf::from_fitted(&all[0]);
    for bad in ["", "9lives", "a-b", "fit 1"] {
        let e = shader_source_named(&c, Language::Wgsl, bad).unwrap_err();
        assert!(e.to_string().contains("shader prefix"), "{e}");
    }
}

#[test]
fn alta_export_reads_back_and_evaluates_the_same() {
    let dir = std::env::temp_dir().join(format!("ratfit-alta-export-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    for f in fits() {
        let exported = brdf::AltaRational::from_fitted(&f);
        if f.shell.is_some() && f.lobe.is_none() {
            let e = exported.unwrap_err().to_string();
            assert!(e.contains("tabulated factor"), "{e}");
            continue;
        }
        if f.lobe.is_some() {
            let e = exported.unwrap_err().to_string();
            assert!(e.contains("lobe"), "{e}");
            continue;
        }
        if !f.mode.is_rgb() {
            let e = exported.unwrap_err().to_string();
            assert!(e.contains("luminance-chroma"), "{e}");
            continue;
        }
        if !f.scale.is_linear() {
            let e = exported.unwrap_err().to_string();
            assert!(e.contains("logarithms"), "{e}");
            continue;
        }
        if f.reduction.coordinates != Coordinates::Radians {
            let e = exported.unwrap_err().to_string();
            assert!(e.contains("radians"), "{e}");
            continue;
        }
        if f.reduction.phi != PhiCoordinate::Radians {
            let e = exported.unwrap_err().to_string();
            assert!(e.contains("cos phi_d"), "{e}");
            continue;
        }
        let alta = exported.unwrap();
        assert_eq!(alta.param_in, "RUSIN_TH_TD_PD");
        let path = dir.join("fit.brdf");
        std::fs::write(&path, alta.to_text("ratfit export --to alta")).unwrap();
        let back = brdf::AltaRational::read(&path).unwrap();
        assert_eq!(back.dim_in, 3);
        assert_eq!(back.channels.len(), 3);
        for (wi, wo) in pairs(500) {
            let x = f.coordinates(wi, wo);
            for c in 0..3 {
                let (ours, theirs) = (f.channels[c].eval(&x), back.channels[c].eval(&x));
                // Same coefficients, same Chebyshev recurrence, printed to
                // 17 significant digits: agreement to rounding of the sums.
                let tol = 1e-12 * ours.abs().max(1e-3);
                assert!((ours - theirs).abs() <= tol, "{ours} vs {theirs}");
            }
        }
    }
}

#[test]
fn the_ceiling_bounds_every_evaluation_path() {
    use rational_core::{Basis, BasisFamily, Domain, RationalFunction};
    // q = 1 - 0.999 T1(x0): near x0's upper end p / q reaches 1000.
    let domain = Domain::new(vec![0.0, 0.0], vec![1.0, 1.4]).unwrap();
    let basis = Basis::new(BasisFamily::Chebyshev, domain, 3).unwrap();
    let t1 = (0..3).find(|&j| basis.multi_index(j) == [1, 0]).unwrap();
    let mut q = vec![0.0; 3];
    q[0] = 1.0;
    q[t1] = -0.999;
    let channel = RationalFunction::new(basis, vec![1.0], q).unwrap();
    let ceiling = [1.5, 2.5, 4.0];
    let fit = FittedBrdf {
        reduction: Reduction::default().whole_hemisphere(),
        channels: vec![channel.clone(), channel.clone(), channel],
        mode: ColourMode::Rgb,
        scale: brdf::ValueScale::Linear,
        lobe: None,
        ceiling: Some(ceiling),
        shell: None,
        name: "pole".into(),
    };
    fit.validate().unwrap();
    let all = pairs(4001);
    let wi: Vec<[f64; 3]> = all.iter().map(|p| p.0).collect();
    let wo: Vec<[f64; 3]> = all.iter().map(|p| p.1).collect();
    let mut batched = vec![[0.0; 3]; all.len()];
    BatchedFit::new(fit.clone()).eval_batch(&wi, &wo, &mut batched);
    let compact = CompactBrdf::from_fitted(&fit);
    let wi32: Vec<[f32; 3]> = wi.iter().map(|&d| to_f32(d)).collect();
    let wo32: Vec<[f32; 3]> = wo.iter().map(|&d| to_f32(d)).collect();
    let lanes = compact.eval_many_batched(&wi32, &wo32);
    let mut held = [0usize; 3];
    for (i, &(a, b)) in all.iter().enumerate() {
        let f64_value = brdf::Brdf::eval(&fit, a, b);
        let f32_value = compact.eval(wi32[i], wo32[i]);
        for c in 0..3 {
            let values = [
                f64_value[c],
                batched[i][c],
                f64::from(f32_value[c]),
                f64::from(lanes[i][c]),
            ];
            assert!(
                values.iter().all(|&v| v <= ceiling[c] * (1.0 + 1e-7)),
                "channel {c} at pair {i}: {values:?} above {}",
                ceiling[c]
            );
            held[c] += usize::from(f64_value[c] >= ceiling[c]);
        }
    }
    // The functions exceed each ceiling somewhere, less often the higher it is.
    assert!(
        held[0] > held[1] && held[1] > held[2] && held[2] > 0,
        "{held:?}"
    );
    // The peak check of a fit, from one evaluation, equals the check of the
    // fit and of its functions alone.
    let table = CookTorranceGgx {
        kd: [0.05, 0.1, 0.3],
        f0: [0.04; 3],
        alpha: 0.2,
    };
    let grid = [24, 24, 12];
    let p = brdf::fidelity::fit_peaks(&table, &fit, grid);
    let unclamped = FittedBrdf {
        ceiling: None,
        ..fit.clone()
    };
    let with = brdf::fidelity::peaks(&table, &fit, grid).0;
    assert_eq!(p.ratio.to_bits(), with.to_bits());
    let without = brdf::fidelity::peaks(&table, &unclamped, grid).0;
    assert_eq!(p.ratio_without_ceiling.to_bits(), without.to_bits());
    assert!(p.ratio < p.ratio_without_ceiling, "{p:?}");
    // A fit file's ceiling is checked on load.
    let mut json = serde_json::to_value(&fit).unwrap();
    json["ceiling"] = serde_json::json!([1.0, -1.0, 1.0]);
    let e = serde_json::from_value::<FittedBrdf>(json)
        .unwrap_err()
        .to_string();
    assert!(e.contains("ceiling"), "{e}");
}

/// A fit whose f64 coefficients are finite but beyond f32 (1e308) is named
/// by `first_non_finite`, so the exports refuse it instead of writing `inf`
/// into a shader or a binary file that would not load.
#[test]
fn coefficients_beyond_f32_are_named_before_export() {
    let f = fits().remove(0);
    assert_eq!(CompactBrdf::from_fitted(&f).first_non_finite(), None);
    let mut json = serde_json::to_value(&f).unwrap();
    json["channels"][2]["numerator"][0] = serde_json::json!(1e308);
    let huge: FittedBrdf = serde_json::from_value(json).unwrap();
    let what = CompactBrdf::from_fitted(&huge).first_non_finite();
    assert_eq!(what.as_deref(), Some("channel b: numerator value 0"));
}
