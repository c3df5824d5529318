//! Mutated files, every reader: truncations and flipped bytes of real and
//! written files must give an error or a material that evaluates to finite
//! values, never a panic. A deterministic generator keeps failures
//! reproducible; each case names its mutation.

use brdf::{
    fit_brdf, AltaData, AltaRational, BlinnPhong, Brdf, BrdfFitSettings, CompactBrdf, FittedBrdf,
    Reduction, RglBrdf, ScatteredBrdf,
};
mod common;

use common::{data_dir, tensor_field};
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::path::{Path, PathBuf};

/// The mutation generator.
type Gen = ratfit_tests::SplitMix64;

/// `count` mutations of `bytes`: truncations, flipped bits, bytes set to
/// 0x00 / 0xff, and (for text) digits and separators replaced. Positions
/// favour the first 4 KB, where the headers are.
fn mutations(bytes: &[u8], count: usize, seed: u64) -> Vec<(String, Vec<u8>)> {
    let mut g = Gen::new(seed);
    let mut out = Vec::with_capacity(count);
    for _ in 0..count {
        let mut b = bytes.to_vec();
        let span = if g.below(4) == 0 {
            b.len()
        } else {
            b.len().min(4096)
        };
        let at = g.below(span);
        let what = match g.below(5) {
            0 => {
                b.truncate(at);
                format!("truncated at {at}")
            }
            1 => {
                let bit = g.below(8);
                b[at] ^= 1 << bit;
                format!("bit {bit} of byte {at} flipped")
            }
            2 => {
                b[at] = 0xff;
                format!("byte {at} set to 0xff")
            }
            3 => {
                b[at] = 0;
                format!("byte {at} set to 0")
            }
            _ => {
                let c = b"-9e.,x \n#"[g.below(9)];
                b[at] = c;
                format!("byte {at} set to {:?}", char::from(c))
            }
        };
        out.push((what, b));
    }
    out
}

/// Loads with `load`; a loaded material must evaluate to finite,
/// non-negative values on a few direction pairs.
fn check<B: Brdf>(name: &str, cases: Vec<(String, Vec<u8>)>, load: impl Fn(&[u8]) -> Option<B>) {
    let pairs = [
        ((0.3, 0.1), (0.5, 2.0)),
        ((1.2, 0.0), (1.3, 3.0)),
        ((0.0, 0.0), (0.0, 0.0)),
        ((1.55, 1.0), (0.2, -2.0)),
    ];
    for (what, bytes) in cases {
        let result = catch_unwind(AssertUnwindSafe(|| {
            if let Some(m) = load(&bytes) {
                for ((ti, pi), (to, po)) in pairs {
                    let v = m.eval(brdf::from_spherical(ti, pi), brdf::from_spherical(to, po));
                    assert!(
                        v.iter().all(|x| x.is_finite()),
                        "{name}, {what}: loaded, then evaluated to {v:?}"
                    );
                }
            }
        }));
        if let Err(e) = result {
            let msg = e
                .downcast_ref::<String>()
                .cloned()
                .or_else(|| e.downcast_ref::<&str>().map(|s| s.to_string()))
                .unwrap_or_default();
            panic!("{name}, {what}: panicked: {msg}");
        }
    }
}

fn scratch() -> PathBuf {
    let d = std::env::temp_dir().join(format!("ratfit-mutations-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// A path-based reader through a temporary file.
fn via_file<T>(
    dir: &Path,
    ext: &str,
    bytes: &[u8],
    read: impl Fn(&Path) -> Option<T>,
) -> Option<T> {
    let p = dir.join(format!("mutated.{ext}"));
    std::fs::write(&p, bytes).unwrap();
    read(&p)
}

#[test]
fn mutated_rgl_files_never_panic() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED mutated_rgl_files_never_panic: no data directory (set RATFIT_DATA)");
        return;
    };
    let path = dir.join("rgl/cm_military_green_rgb.bsdf");
    let good = std::fs::read(&path).unwrap();
    check("rgl", mutations(&good, 300, 1), |b| {
        RglBrdf::from_bytes(b, &path, "mutated".into()).ok()
    });
}

#[test]
fn rgl_fields_set_to_extreme_values_never_panic_or_evaluate_to_nan() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED rgl_fields_set_to_extreme_values: no data directory (set RATFIT_DATA)");
        return;
    };
    let path = dir.join("rgl/cm_military_green_rgb.bsdf");
    let good = std::fs::read(&path).unwrap();
    let mut cases = Vec::new();
    let mut g = Gen::new(7);
    for field in ["theta_i", "phi_i", "ndf", "sigma", "vndf", "rgb"] {
        let (offset, width, n) = tensor_field(&good, field);
        for value in [f64::NAN, f64::INFINITY, -1.0, 1e30, 0.0] {
            let k = g.below(n);
            let mut b = good.clone();
            let at = offset + k * width;
            match width {
                4 => b[at..at + 4].copy_from_slice(&(value as f32).to_le_bytes()),
                8 => b[at..at + 8].copy_from_slice(&value.to_le_bytes()),
                _ => continue,
            }
            cases.push((format!("{field}[{k}] = {value}"), b));
        }
    }
    check("rgl fields", cases, |b| {
        RglBrdf::from_bytes(b, &path, "mutated".into()).ok()
    });
}

#[test]
fn mutated_text_files_never_panic() {
    let Some(dir) = data_dir() else {
        eprintln!("SKIPPED mutated_text_files_never_panic: no data directory (set RATFIT_DATA)");
        return;
    };
    let tmp = scratch();
    let cornell = std::fs::read(dir.join("cornell/acryl_blue.brdf")).unwrap();
    let mut cases = mutations(&cornell[..cornell.len().min(20_000)], 150, 2);
    cases.truncate(150);
    check("cornell", cases, |b| {
        via_file(&tmp, "brdf", b, |p| ScatteredBrdf::read_cornell(p).ok())
            .map(|s| s.samples(&Reduction::default()))
            .map(|_| brdf::Lambert { albedo: [0.5; 3] })
    });
    for file in ["alta/pink-felt-1d.alta", "alta/retro-3M-jaune.dat"] {
        let text = std::fs::read(dir.join(file)).unwrap();
        let cases = mutations(&text[..text.len().min(20_000)], 150, 3);
        for (what, b) in cases {
            let r = catch_unwind(AssertUnwindSafe(|| {
                if let Some(d) = via_file(&tmp, "alta", &b, |p| AltaData::read(p).ok()) {
                    for k in 0..d.dim_out {
                        let _ = d.channel(k, 0.05);
                    }
                }
            }));
            assert!(r.is_ok(), "{file}, {what}: panicked");
        }
    }
    let rational = std::fs::read(dir.join("alta/rational-example-01.brdf")).unwrap();
    for (what, b) in mutations(&rational, 200, 4) {
        let r = catch_unwind(AssertUnwindSafe(|| {
            if let Some(f) = via_file(&tmp, "brdf", &b, |p| AltaRational::read(p).ok()) {
                for c in &f.channels {
                    let mid: Vec<f64> =
                        (0..f.dim_in).map(|k| 0.5 * (c.min[k] + c.max[k])).collect();
                    let _ = c.eval(&mid);
                }
            }
        }));
        assert!(r.is_ok(), "alta rational, {what}: panicked");
    }
    std::fs::remove_dir_all(&tmp).ok();
}

/// A small fit, with or without the analytic lobe (whose parameters the
/// mutations then reach too).
fn small_fit(lobe: bool) -> FittedBrdf {
    let m = BlinnPhong {
        kd: [0.2; 3],
        ks: [0.3; 3],
        exponent: 12.0,
    };
    let s = BrdfFitSettings::default()
        .with_reduction(Reduction::default().with_resolution(16, 16))
        .with_lobe(lobe.then(|| brdf::Lobe::fit(&m)))
        .with_baselines(false);
    fit_brdf(&m, &s).unwrap().0
}

#[test]
fn mutated_fit_files_never_panic() {
    for lobe in [false, true] {
        let fit = small_fit(lobe);
        let json = serde_json::to_vec(&fit).unwrap();
        check("fit JSON", mutations(&json, 400, 5), |b| {
            serde_json::from_slice::<FittedBrdf>(b).ok()
        });
        let binary = CompactBrdf::from_fitted(&fit).to_bytes();
        check("compact binary", mutations(&binary, 400, 6), |b| {
            CompactBrdf::from_bytes(b).ok()
        });
    }
}
