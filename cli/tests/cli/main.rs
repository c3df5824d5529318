//! End-to-end tests of the `ratfit` binary: here the engine's commands
//! (`fit-csv`, `eval`, `dump-qp`), bad input and the demos; the BRDF
//! commands in `brdf_commands.rs`, the benchmarks and `batch` in `bench.rs`
//! (one test binary, so one link).

mod bench;
mod brdf_commands;
#[path = "../common/mod.rs"]
mod common;

use common::{ratfit, scratch};
use std::path::PathBuf;

fn runge_csv(dir: &std::path::Path) -> PathBuf {
    let mut s = String::from("x,value\n");
    for i in 0..500 {
        let x = -1.0 + 2.0 * i as f64 / 499.0;
        s.push_str(&format!("{x},{}\n", 1.0 / (1.0 + 25.0 * x * x)));
    }
    let p = dir.join("runge.csv");
    std::fs::write(&p, s).unwrap();
    p
}

#[test]
fn fit_then_eval_reproduces_the_data_within_the_bound() {
    let dir = scratch("fit");
    let data = runge_csv(&dir);
    let fit = dir.join("fit.json");
    let out = ratfit()
        .args(["fit-csv"])
        .arg(&data)
        .args(["--rel-tol", "0.01", "-o"])
        .arg(&fit)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(report.contains("verified            yes"), "{report}");
    assert!(report.contains("n_p = 1, n_q = 3"), "{report}");

    let pts = dir.join("pts.csv");
    std::fs::write(&pts, "x\n-1\n0\n0.5\n").unwrap();
    let out = ratfit()
        .arg("eval")
        .arg(&fit)
        .arg("--points")
        .arg(&pts)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let vals: Vec<f64> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.parse().unwrap())
        .collect();
    for (x, v) in [-1.0f64, 0.0, 0.5].iter().zip(&vals) {
        let truth = 1.0 / (1.0 + 25.0 * x * x);
        assert!((v / truth - 1.0).abs() <= 0.01, "x = {x}: {v} vs {truth}");
    }
    std::fs::remove_dir_all(dir).ok();
}

/// The standard output of a run that must succeed (its standard error
/// is the failure message otherwise).
fn stdout_of_success(out: std::process::Output) -> String {
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    String::from_utf8_lossy(&out.stdout).into_owned()
}

/// `--centred` returns the least-squares point within the intervals, says
/// so, and is verified like the largest-margin point.
#[test]
fn fit_csv_centred_says_so_and_stays_verified() {
    let dir = scratch("centred");
    let data = runge_csv(&dir);
    let fit = dir.join("fit.json");
    let run = |extra: &[&str]| {
        let out = ratfit()
            .arg("fit-csv")
            .arg(&data)
            .args(["--rel-tol", "0.01", "--max-coeffs", "12", "-o"])
            .arg(&fit)
            .args(extra)
            .output()
            .unwrap();
        stdout_of_success(out)
    };
    let centred = run(&["--centred"]);
    assert!(centred.contains("verified            yes"), "{centred}");
    assert!(
        centred.contains("least squares within the intervals"),
        "{centred}"
    );
    let plain = run(&[]);
    assert!(!plain.contains("least squares within"), "{plain}");
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn dump_qp_writes_npy_files() {
    let dir = scratch("dump");
    let data = runge_csv(&dir);
    let out = ratfit()
        .arg("dump-qp")
        .arg(&data)
        .args(["--split", "2,3", "--out"])
        .arg(dir.join("qp"))
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let g = std::fs::read(dir.join("qp/G.npy")).unwrap();
    assert!(g.starts_with(b"\x93NUMPY"));
    let header_len = u16::from_le_bytes([g[8], g[9]]) as usize;
    assert_eq!(g.len(), 10 + header_len + 8 * 1000 * 5);
    assert_eq!((10 + header_len) % 16, 0, "the data start aligned");
    let header: String = std::str::from_utf8(&g[10..10 + header_len])
        .unwrap()
        .split_whitespace()
        .collect();
    assert!(header.contains("'descr':'<f8'"), "{header}");
    assert!(header.contains("'fortran_order':False"), "{header}");
    assert!(
        header.contains("'shape':(1000,5)") || header.contains("'shape':(1000,5,)"),
        "{header}"
    );
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn an_empty_sweep_names_the_flags_that_change_it() {
    let dir = scratch("empty-sweep");
    let data = dir.join("sine.csv");
    let mut s = String::from("x,value\n");
    for i in 0..200 {
        let x = i as f64 / 199.0;
        s.push_str(&format!("{x},{}\n", (20.0 * x).sin() + 2.0));
    }
    std::fs::write(&data, s).unwrap();
    let out = ratfit()
        .arg("fit-csv")
        .arg(&data)
        .args(["--rel-tol", "1e-6", "--max-coeffs", "6", "-o"])
        .arg(dir.join("f.json"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("15 splits tried")
            && err.contains("--max-coeffs")
            && err.contains("--rel-tol"),
        "{err}"
    );
}

#[test]
fn bad_input_gives_clear_errors() {
    let dir = scratch("bad");
    let bad = dir.join("bad.csv");
    std::fs::write(&bad, "x,v\n0,1\n0.5,abc\n").unwrap();
    let out = ratfit()
        .arg("fit-csv")
        .arg(&bad)
        .args(["-o"])
        .arg(dir.join("f.json"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(
        err.contains("line 3") && err.contains("not a number"),
        "{err}"
    );

    std::fs::write(&bad, "x,lo,hi\n0,2,1\n0.5,1,2\n1,1,2\n").unwrap();
    let out = ratfit()
        .arg("fit-csv")
        .arg(&bad)
        .args(["--intervals", "-o"])
        .arg(dir.join("f.json"))
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("lower bound 2 is above upper bound 1"));

    let out = ratfit()
        .arg("fit-csv")
        .arg(dir.join("missing.csv"))
        .args(["-o", "x.json"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("cannot read"));

    let out = ratfit()
        .arg("fit-csv")
        .arg(&bad)
        .args(["--backend", "gurobi", "-o", "x.json"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown backend"));

    // An unknown pole control is named, by both fitting commands.
    for cmd in ["fit-csv", "fit"] {
        let out = ratfit()
            .arg(cmd)
            .arg(&bad)
            .args(["--poles", "everywhere", "-o", "x.json"])
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            err.contains("unknown pole control `everywhere`"),
            "{cmd}: {err}"
        );
    }

    // Degree weights must be one per coordinate, each in 1..=16.
    let runge = runge_csv(&dir);
    for (weights, says) in [("1,2", "2 degree weights"), ("0", "weight 0")] {
        let out = ratfit()
            .arg("fit-csv")
            .arg(&runge)
            .args(["--rel-tol", "0.01", "--degree-weights", weights, "-o"])
            .arg(dir.join("f.json"))
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{weights}: {err}");
    }

    // Numeric flags are checked where they are read, whatever the format.
    let material = dir.join("material.bsdf");
    std::fs::write(&material, "not read").unwrap();
    for (format, flag, value, says) in [
        ("rgl", "--max-theta-d", "nan", "not finite"),
        ("rgl", "--max-elevation", "-5", "outside (0, 90]"),
        ("rgl", "--rel-tol", "5", "outside (0, 1)"),
        ("alta", "--rel-tol", "5", "outside (0, 1)"),
        ("alta", "--coords", "bogus", "unknown coordinates"),
        ("rgl", "--resolution", "100000,100000", "outside 1..=4096"),
        ("rgl", "--resolution", "24,24,24,24", "two or three"),
        ("rgl", "--max-coeffs", "1", "at least 2"),
        ("rgl", "--target-de", "0", "positive"),
        ("rgl", "--max-bytes", "4", "cannot hold"),
        ("rgl", "--max-bytes", "1024", "--target-de"),
        ("rgl", "--cap-rounds", "17", "outside 0..=16"),
        ("rgl", "--widen-factor", "0", "must be positive"),
        ("rgl", "--widen-factor", "1", "--widen-factor 1"),
    ] {
        let out = ratfit()
            .arg("fit")
            .arg(&material)
            .args(["--format", format, &format!("{flag}={value}"), "-o"])
            .arg(dir.join("f.json"))
            .output()
            .unwrap();
        assert!(!out.status.success(), "{flag} {value}");
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains(says), "{flag} {value}: {err}");
    }
    let out = ratfit()
        .args(["sample-stats", "a.json", "b.json", "--samples", "0"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stderr).contains("outside 1..="));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn missing_backend_is_named() {
    let out = ratfit().arg("backends").output().unwrap();
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    assert!(text.contains("native    compiled"));
    if text.contains("clarabel  not compiled") {
        let dir = scratch("nb");
        let data = runge_csv(&dir);
        let out = ratfit()
            .arg("fit-csv")
            .arg(&data)
            .args(["--backend", "clarabel", "-o"])
            .arg(dir.join("f.json"))
            .output()
            .unwrap();
        assert!(!out.status.success());
        assert!(String::from_utf8_lossy(&out.stderr).contains("not compiled"));
        std::fs::remove_dir_all(dir).ok();
    }
}

#[test]
fn engine_demo_runs_and_verifies() {
    let out = ratfit().args(["demo", "--engine"]).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.matches("verified            yes").count(), 2, "{text}");
}

#[test]
fn brdf_demo_fits_renders_and_exports() {
    let dir = scratch("demo");
    let out = ratfit().args(["demo", "--out"]).arg(&dir).output().unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    assert_eq!(text.matches("       yes ").count(), 3, "{text}");
    for scene in ["lights", "sky"] {
        let png = std::fs::read(dir.join(format!("demo-{scene}.png"))).unwrap();
        assert!(png.starts_with(b"\x89PNG"), "demo-{scene}.png");
    }
    std::fs::remove_dir_all(dir).ok();
}
