//! Readers against real data and hand-made files: RGL files agree with an
//! independent renderer; MERL files round-trip exactly; malformed files get
//! clear errors.

use brdf::merl::{self, MerlBrdf, TabulateOptions};
use brdf::{from_spherical, BlinnPhong, Brdf, CookTorranceGgx, RglBrdf};
mod common;

use common::{data_dir, tensor_field};
use std::path::{Path, PathBuf};

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ratfit-brdf-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// Relative error of our RGL evaluation against Mitsuba's values, per file:
/// the median over all pairs, and the largest over pairs away from grazing
/// angles (both elevations below 80 degrees) and away from tiny values
/// (below 1e-3 of the file's peak, where float cancellation dominates).
#[test]
fn rgl_files_agree_with_the_reference_renderer() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED rgl_files_agree_with_the_reference_renderer: no data directory (set RATFIT_DATA)");
        return;
    };
    let mut files: Vec<_> = std::fs::read_dir(dir.join("rgl"))
        .unwrap()
        .flatten()
        .map(|e| e.path())
        .collect();
    files.retain(|p| p.extension().is_some_and(|e| e == "bsdf"));
    files.sort();
    assert!(!files.is_empty());
    for path in files {
        let stem = path.file_stem().unwrap().to_string_lossy().to_string();
        let reference = dir.join("rgl/reference").join(format!("{stem}.csv"));
        if !reference.exists() {
            eprintln!("{stem}: no reference values, skipped");
            continue;
        }
        let m = RglBrdf::read(&path).unwrap();
        let text = std::fs::read_to_string(&reference).unwrap();
        let rows: Vec<Vec<f64>> = text
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
            .collect();
        let peak = rows
            .iter()
            .flat_map(|r| r[4..7].iter().copied())
            .fold(0.0_f64, f64::max);
        let mut errs = Vec::new();
        let mut worst = 0.0_f64;
        for r in &rows {
            let wi = from_spherical(r[0], r[1]);
            let wo = from_spherical(r[2], r[3]);
            let v = m.eval(wi, wo);
            for c in 0..3 {
                let want = r[4 + c];
                if want.abs() < 1e-3 * peak {
                    continue;
                }
                let e = (v[c] - want).abs() / want.abs();
                errs.push(e);
                if r[0] < 80f64.to_radians() && r[2] < 80f64.to_radians() {
                    worst = worst.max(e);
                }
            }
        }
        errs.sort_by(f64::total_cmp);
        let median = errs[errs.len() / 2];
        eprintln!("{stem}: {} values, median relative error {median:.2e}, max away from grazing {worst:.2e}", errs.len());
        assert!(median < 1e-5, "{stem}: median relative error {median:.2e}");
        assert!(worst < 2e-4, "{stem}: max relative error {worst:.2e}");
    }
}

#[test]
fn merl_files_round_trip_exactly() {
    let dir = scratch("merl");
    let m = MerlBrdf::tabulate(
        &CookTorranceGgx {
            kd: [0.1, 0.2, 0.3],
            f0: [0.04; 3],
            alpha: 0.2,
        },
        TabulateOptions {
            noise: 0.01,
            seed: 7,
            missing_above_theta_d_deg: Some(85.0),
        },
    );
    let p = dir.join("a.binary");
    m.write(&p).unwrap();
    assert_eq!(
        std::fs::metadata(&p).unwrap().len() as usize,
        merl::FILE_SIZE
    );
    let back = MerlBrdf::read(&p).unwrap();
    // Exact up to the channel scale's own rounding (value / s * s).
    for (i_h, i_d, i_p) in [(0, 0, 0), (10, 20, 30), (89, 84, 179), (45, 89, 90)] {
        let (a, b) = (m.cell(i_h, i_d, i_p), back.cell(i_h, i_d, i_p));
        for c in 0..3 {
            match (a[c], b[c]) {
                (Some(x), Some(y)) => assert!((x - y).abs() <= 4.0 * f64::EPSILON * x.abs()),
                (None, None) => {}
                other => panic!("cell ({i_h},{i_d},{i_p}) channel {c}: {other:?}"),
            }
        }
    }
    assert!(
        back.cell(45, 89, 90)[0].is_none(),
        "grazing cells stay missing"
    );
    // Writing the read file reproduces the bytes.
    assert_eq!(std::fs::read(&p).unwrap(), back.to_bytes());
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn merl_lookup_reproduces_the_tabulated_material() {
    let mat = BlinnPhong {
        kd: [0.2, 0.3, 0.4],
        ks: [0.4; 3],
        exponent: 20.0,
    };
    let m = MerlBrdf::tabulate(&mat, TabulateOptions::default());
    // At a cell centre the lookup returns the value tabulated there.
    let (th, td, pd) = merl::cell_center(30, 40, 50);
    let (wi, wo) = brdf::HalfDiff {
        theta_h: th,
        phi_h: 0.7,
        theta_d: td,
        phi_d: pd,
    }
    .to_directions();
    let (a, b) = (m.eval(wi, wo), mat.eval(wi, wo));
    for c in 0..3 {
        assert!((a[c] / b[c] - 1.0).abs() < 1e-9, "{a:?} vs {b:?}");
    }
}

#[test]
fn malformed_files_give_clear_errors() {
    let dir = scratch("bad");
    let p = dir.join("short.binary");
    let mut bytes = MerlBrdf::tabulate(
        &brdf::Lambert { albedo: [0.5; 3] },
        TabulateOptions::default(),
    )
    .to_bytes();
    bytes.truncate(1000);
    std::fs::write(&p, &bytes).unwrap();
    let e = MerlBrdf::read(&p).unwrap_err().to_string();
    assert!(e.contains("truncated") && e.contains("34992012"), "{e}");
    bytes[0] = 7;
    std::fs::write(&p, &bytes).unwrap();
    assert!(MerlBrdf::read(&p)
        .unwrap_err()
        .to_string()
        .contains("dimensions"));
    let mut nan = MerlBrdf::tabulate(
        &brdf::Lambert { albedo: [0.5; 3] },
        TabulateOptions::default(),
    )
    .to_bytes();
    nan[100..108].copy_from_slice(&f64::NAN.to_le_bytes());
    std::fs::write(&p, &nan).unwrap();
    assert!(MerlBrdf::read(&p)
        .unwrap_err()
        .to_string()
        .contains("not finite"));
    assert!(MerlBrdf::read(Path::new("/nonexistent/x.binary")).is_err());
    let q = dir.join("x.bsdf");
    std::fs::write(&q, b"tensor_file\0\x01\x00\x00\x00\x00\x00").unwrap();
    assert!(RglBrdf::read(&q)
        .unwrap_err()
        .to_string()
        .contains("no `theta_i` field"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn merl_checksum_list_parses() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED merl_checksum_list_parses: no data directory");
        return;
    };
    let list = merl::read_checksums(&dir.join("merl/MERL_CHECKSUMS.tsv")).unwrap();
    assert_eq!(list.len(), 100);
    assert!(list
        .iter()
        .all(|k| k.size as usize == merl::FILE_SIZE && k.sha256.len() == 64));
}

#[test]
fn alta_rational_function_loads_and_evaluates() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED alta_rational_function_loads_and_evaluates: no data directory");
        return;
    };
    let f = brdf::AltaRational::read(&dir.join("alta/rational-example-01.brdf")).unwrap();
    assert_eq!(f.dim_in, 2);
    assert_eq!(f.param_in, "STARK_2D");
    assert_eq!(f.channels.len(), 3);
    for c in &f.channels {
        assert_eq!((c.numerator.len(), c.denominator.len()), (100, 50));
    }
    // Gold metallic paint: positive and finite inside its domain.
    for &x in &[[0.1, 0.2], [0.5, 0.5], [0.9, 0.3]] {
        for c in &f.channels {
            let v = c.eval(&x);
            assert!(v.is_finite() && v > 0.0, "{x:?}: {v}");
        }
    }
    // Malformed: a truncated file is refused with its reason.
    let text = std::fs::read_to_string(dir.join("alta/rational-example-01.brdf")).unwrap();
    let cut: String = text.lines().take(120).collect::<Vec<_>>().join("\n");
    let d = scratch("alta");
    std::fs::write(d.join("cut.brdf"), cut).unwrap();
    let e = brdf::AltaRational::read(&d.join("cut.brdf"))
        .unwrap_err()
        .to_string();
    assert!(e.contains("coefficients"), "{e}");
    std::fs::remove_dir_all(d).ok();
}

#[test]
fn alta_and_cornell_data_load() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED alta_and_cornell_data_load: no data directory");
        return;
    };
    let a = brdf::AltaData::read(&dir.join("alta/pink-felt-1d.alta")).unwrap();
    assert_eq!((a.dim_in, a.dim_out, a.rows.len()), (1, 3, 90));
    let r = brdf::AltaData::read(&dir.join("alta/retro-3M-jaune.dat")).unwrap();
    assert_eq!((r.dim_in, r.dim_out), (3, 1));
    assert!(r.rows.len() > 7000);
    for name in ["acryl_blue", "cayman", "garnet_red"] {
        let c =
            brdf::ScatteredBrdf::read_cornell(&dir.join(format!("cornell/{name}.brdf"))).unwrap();
        assert!(c.samples.len() > 1000, "{name}");
        // Spectral to RGB keeps luminance non-negative for reflectance spectra.
        assert!(c
            .samples
            .iter()
            .all(|s| 0.2126 * s.2[0] + 0.7152 * s.2[1] + 0.0722 * s.2[2] >= -1e-12));
    }
}

/// Directional albedo `int f(l, v) cos(theta_l) dl` by a midpoint rule in
/// `(cos theta_l, phi_l)`.
fn albedo(b: &dyn Brdf, view_deg: f64) -> [f64; 3] {
    let v = brdf::from_spherical(view_deg.to_radians(), 0.0);
    let (nm, np) = (400usize, 400usize);
    let mut sum = [0.0; 3];
    for i in 0..nm {
        let mu = (i as f64 + 0.5) / nm as f64;
        for j in 0..np {
            let phi = (j as f64 + 0.5) / np as f64 * std::f64::consts::TAU;
            let f = b.eval(brdf::from_spherical(mu.acos(), phi), v);
            for c in 0..3 {
                sum[c] += f[c] * mu;
            }
        }
    }
    sum.map(|s| s * std::f64::consts::TAU / (nm * np) as f64)
}

#[test]
fn rgl_albedo_matches_the_independent_renderer_under_each_convention() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED rgl_albedo_matches_the_independent_renderer_under_each_convention: no data directory (set RATFIT_DATA)");
        return;
    };
    let path = dir.join("rgl/cm_military_green_rgb.bsdf");
    let light_first = RglBrdf::read(&path).unwrap();
    let view_first = RglBrdf::read(&path).unwrap().with_view_as_incident(true);
    // Green-channel directional albedo at view elevations 0, 30, 60 degrees
    // from Mitsuba 3.9.1 (`measured`, cosine-weighted estimates of its
    // `eval`): with the view as `wo` (the light in the table's incident
    // slot, this crate's default) and with the view as `si.wi` (its path
    // tracer's convention).
    let mitsuba_light_first = [0.0695, 0.0859, 0.1371];
    let mitsuba_view_first = [0.0837, 0.0832, 0.1361];
    for (k, view) in [0.0, 30.0, 60.0].into_iter().enumerate() {
        let a = albedo(&light_first, view)[1];
        let b = albedo(&view_first, view)[1];
        eprintln!(
            "view {view}: light first {a:.4} (Mitsuba {}), view first {b:.4} (Mitsuba {})",
            mitsuba_light_first[k], mitsuba_view_first[k]
        );
        assert!(
            (a / mitsuba_light_first[k] - 1.0).abs() < 0.025,
            "{view}: {a}"
        );
        assert!(
            (b / mitsuba_view_first[k] - 1.0).abs() < 0.025,
            "{view}: {b}"
        );
    }
}

#[test]
fn rgl_axes_are_checked_and_corrupt_names_are_quoted_short() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED rgl_axes_are_checked: no data directory (set RATFIT_DATA)");
        return;
    };
    let path = dir.join("rgl/aurora_white_rgb.bsdf");
    let good = std::fs::read(&path).unwrap();
    let (offset, width, _) = tensor_field(&good, "theta_i");
    let write = |bytes: &mut Vec<u8>, k: usize, v: f64| {
        let at = offset + k * width;
        if width == 4 {
            bytes[at..at + 4].copy_from_slice(&(v as f32).to_le_bytes());
        } else {
            bytes[at..at + 8].copy_from_slice(&v.to_le_bytes());
        }
    };
    for (value, says) in [
        (f64::NAN, "non-finite"),
        (f64::INFINITY, "non-finite"),
        (-1.0, "not increasing"),
        (3.0, "not increasing"),
    ] {
        let mut bytes = good.clone();
        write(&mut bytes, 1, value);
        let e = RglBrdf::from_bytes(&bytes, &path, "edited".into())
            .unwrap_err()
            .to_string();
        assert!(e.contains("theta_i") && e.contains(says), "{value}: {e}");
    }
    // A field name of 5,000 raw bytes (with an unsupported element type,
    // so the message quotes it) is quoted as a short, escaped prefix.
    let mut bytes = good[..14].to_vec();
    bytes.extend_from_slice(&1u32.to_le_bytes());
    bytes.extend_from_slice(&5000u16.to_le_bytes());
    bytes.extend(std::iter::repeat_n(0xffu8, 5000));
    bytes.extend_from_slice(&0u16.to_le_bytes());
    bytes.push(99);
    bytes.extend_from_slice(&0u64.to_le_bytes());
    let e = RglBrdf::from_bytes(&bytes, &path, "edited".into())
        .unwrap_err()
        .to_string();
    assert!(e.contains("element type 99"), "{e}");
    assert!(e.len() < 400, "{} bytes: {e}", e.len());
}

#[test]
fn cornell_headers_are_checked() {
    let dir = scratch("cornell-headers");
    let body = "0.1 0.0 0.2 3.1 0.5 0.6 0.7\n";
    for (header, says) in [
        ("# num wls\n31.9\n# wls\n400 500 600\n", "whole number"),
        ("# num wls\n3\n# wls\n400 400 600\n", "must increase"),
        ("# num wls\n3\n# wls\n600 500 400\n", "must increase"),
    ] {
        let p = dir.join("bad.brdf");
        std::fs::write(&p, format!("{header}{body}")).unwrap();
        let e = brdf::ScatteredBrdf::read_cornell(&p)
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{header}: {e}");
    }
    let p = dir.join("good.brdf");
    std::fs::write(&p, format!("# num wls\n3\n# wls\n400 500 600\n{body}")).unwrap();
    assert!(brdf::ScatteredBrdf::read_cornell(&p).is_ok());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn alta_vertical_segments_are_checked() {
    let dir = scratch("alta-vs");
    let p = dir.join("bad.alta");
    for (text, says) in [
        (
            "#DIM 1 1\n#VS 2\n0.5 1.0 1.2 1.5\n",
            "outside its own interval",
        ),
        ("#DIM 1 1\n#VS two\n0.5 1.0\n", "#VS"),
        ("#DIM 1 1\n#VS 3\n0.5 1.0\n", "#VS"),
    ] {
        std::fs::write(&p, text).unwrap();
        let e = brdf::AltaData::read(&p).unwrap_err().to_string();
        assert!(e.contains(says), "{text}: {e}");
    }
    std::fs::write(&p, "#DIM 1 1\n#VS 2\n0.5 1.0 0.9 1.1\n").unwrap();
    assert!(brdf::AltaData::read(&p).is_ok());
    std::fs::remove_dir_all(&dir).ok();
}

/// Inputs the fuzzer (`fuzz/run.sh`) found, one per class: each now gets a
/// named error or a finite value.
#[test]
fn fuzzer_findings_are_named_errors_or_finite() {
    let path = Path::new("found.txt");
    // ALTA data: `#DIM` sizes bounded before a row is sized by them, once,
    // before the data.
    for (text, says) in [
        ("#DIM 18446744073709551615 1\n0.5 1.0\n", "#DIM"),
        ("#DIM 1 100000\n0.5 1.0\n", "outputs"),
        (
            "#DIM 1 3\n0.9 0.1 0.08 0.06\n#DIM 2 3\n0.5 0.5 1 2 3\n",
            "second `#DIM`",
        ),
        (
            "#DIM 1 1\n0.5 1.0\n#VS 2\n0.5 1.0 0.9 1.1\n",
            "after the data rows",
        ),
    ] {
        let e = brdf::AltaData::parse(text, path).unwrap_err().to_string();
        assert!(e.contains(says), "{text:?}: {e}");
    }
    // ALTA rational functions: an input count past the limit, counts whose
    // sum overflows, and a denominator that is identically zero.
    let header = "#ALTA FUNC HEADER\n#DIM 1 1\n#PARAM_IN COS_TH\n#ALTA HEADER END\n#FUNC rational_function\n#MIN 0.0\n#MAX 1.0\n";
    for (text, says) in [
        (
            "#DIM 0018446744073709551615 1\n#NP 1\n#NQ 1\n0\t0\t1.0\n".to_string(),
            "#DIM",
        ),
        (
            format!("{header}#NP 18446744073709551615\n#NQ 1\n0\t1.0\n"),
            "coefficients",
        ),
        (
            format!("{header}#NP 1\n#NQ 2\n0\t1.0\n0\t0.0\n1\t0.0\n"),
            "identically zero",
        ),
    ] {
        let e = brdf::AltaRational::parse(&text, path)
            .unwrap_err()
            .to_string();
        assert!(e.contains(says), "{text:?}: {e}");
    }
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED the RGL part of fuzzer_findings: no data directory (set RATFIT_DATA)");
        return;
    };
    let rgl = dir.join("rgl/cm_military_green_rgb.bsdf");
    let good = std::fs::read(&rgl).unwrap();
    // VNDF rows without mass where the half vector sits (rows run along
    // theta_m at fixed phi_m; at normal incidence phi_m maps to the middle
    // rows, 63 and 64 of 128): the warp has nothing to invert there; the
    // value stays finite.
    let (offset, width, _) = tensor_field(&good, "vndf");
    assert_eq!(width, 4);
    let mut bytes = good.clone();
    for k in 63 * 128..65 * 128 {
        let at = offset + 4 * k;
        bytes[at..at + 4].copy_from_slice(&0f32.to_le_bytes());
    }
    let m = RglBrdf::from_bytes(&bytes, &rgl, "edited".into()).unwrap();
    let n = [0.0, 0.0, 1.0];
    let v = m.eval(n, n);
    assert!(v.iter().all(|x| x.is_finite()), "{v:?}");
    // A projected area of zero would divide the NDF by zero.
    let (offset, _, _) = tensor_field(&good, "sigma");
    let mut bytes = good.clone();
    bytes[offset..offset + 4].copy_from_slice(&0f32.to_le_bytes());
    let e = RglBrdf::from_bytes(&bytes, &rgl, "edited".into())
        .unwrap_err()
        .to_string();
    assert!(e.contains("sigma"), "{e}");
}
