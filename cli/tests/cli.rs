//! End-to-end tests of the `ratfit` binary.

mod common;

use common::blinn_phong_merl;
use std::path::PathBuf;
use std::process::Command;

fn ratfit() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ratfit"))
}

fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ratfit-cli-{}-{name}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

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

/// A MERL file written from an analytic material, in `dir`.
#[test]
fn fit_eval_export_and_plot_a_merl_file() {
    // A MERL file written from an analytic material stands in for a download.
    let dir = scratch("merl");
    let merl = blinn_phong_merl(&dir);
    let fit = dir.join("fit.json");
    let out = ratfit()
        .arg("fit")
        .arg(&merl)
        .args(["--format", "merl", "--resolution", "30,30"])
        .args(["--degree-weights", "1,2", "-o"])
        .arg(&fit)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    // The weighted order is in the report and travels with the fit.
    assert!(String::from_utf8_lossy(&out.stdout).contains("degree weights 1,2"));
    let json = std::fs::read_to_string(&fit).unwrap();
    assert!(json.contains("\"degree_weights\""), "{json}");
    // The peak check: printed, stored, and the ceiling never raises a value.
    assert!(String::from_utf8_lossy(&out.stdout).contains("x the table's peak"));
    let v: serde_json::Value = serde_json::from_str(&json).unwrap();
    let (ratio, without) = (
        v["peak"]["ratio"].as_f64().unwrap(),
        v["peak"]["ratio_without_ceiling"].as_f64().unwrap(),
    );
    assert!(
        ratio > 0.5 && ratio <= without && ratio <= 2.0,
        "{ratio} {without}"
    );
    assert_eq!(v["brdf"]["ceiling"].as_array().map(Vec::len), Some(3));
    let dirs = dir.join("dirs.csv");
    std::fs::write(
        &dirs,
        "theta_i,phi_i,theta_o,phi_o\n0.3,0.0,0.4,3.0\n0.5,1.0,0.2,2.0\n",
    )
    .unwrap();
    let out = ratfit()
        .arg("eval")
        .arg(&fit)
        .arg("--directions")
        .arg(&dirs)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let rows: Vec<Vec<f64>> = String::from_utf8_lossy(&out.stdout)
        .lines()
        .map(|l| l.split(',').map(|v| v.parse().unwrap()).collect())
        .collect();
    assert_eq!(rows.len(), 2);
    assert!(rows
        .iter()
        .all(|r| r.len() == 3 && r.iter().all(|v| *v > 0.0)));
    let out = ratfit()
        .arg("export")
        .arg(&fit)
        .args(["--to", "wgsl"])
        .output()
        .unwrap();
    assert!(String::from_utf8_lossy(&out.stdout).contains("fn ratfit_brdf("));
    // ALTA has no sqrt-warped parametrisation: the default fit is refused
    // with the way out named.
    let out = ratfit()
        .arg("export")
        .arg(&fit)
        .args(["--to", "alta"])
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("--coords radians"));
    let png = dir.join("slices.png");
    let out = ratfit()
        .arg("plot")
        .arg(&fit)
        .arg(&merl)
        .args(["--format", "merl", "-o"])
        .arg(&png)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    std::fs::remove_dir_all(dir).ok();
}

#[test]
fn cdf_fit_and_sampler_statistics_of_a_fitted_material() {
    let dir = scratch("cdf");
    let merl = dir.join("m.binary");
    brdf::MerlBrdf::tabulate(
        &brdf::BlinnPhong {
            kd: [0.2, 0.3, 0.4],
            ks: [0.4; 3],
            exponent: 30.0,
        },
        brdf::TabulateOptions::default(),
    )
    .write(&merl)
    .unwrap();
    let fit = dir.join("fit.json");
    let status = ratfit()
        .arg("fit")
        .arg(&merl)
        .args(["--format", "merl", "--resolution", "24,24", "-o"])
        .arg(&fit)
        .output()
        .unwrap();
    assert!(
        status.status.success(),
        "{}",
        String::from_utf8_lossy(&status.stderr)
    );
    let cdf = dir.join("cdf.json");
    let out = ratfit()
        .arg("cdf")
        .arg(&fit)
        .args(["--format", "fit", "--views", "6", "--cells", "24,24", "-o"])
        .arg(&cdf)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let report = String::from_utf8_lossy(&out.stdout);
    assert!(
        report.contains("theta") && report.contains("phi"),
        "{report}"
    );
    assert!(report.contains("coefficient bytes"), "{report}");

    let csv = dir.join("stats.csv");
    let out = ratfit()
        .arg("sample-stats")
        .arg(&cdf)
        .arg(&fit)
        .args(["--samples", "20000", "--views", "0,45", "--csv"])
        .arg(&csv)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let text = String::from_utf8_lossy(&out.stdout);
    for name in ["cosine", "tabulated", "rational"] {
        let rows = text
            .lines()
            .filter(|l| l.split_whitespace().nth(1) == Some(name))
            .count();
        assert_eq!(rows, 2, "{text}");
    }
    let rows = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(rows.lines().count(), 1 + 6, "{rows}");

    // A BRDF fit is not an inverse CDF: named, not a panic.
    let out = ratfit()
        .arg("sample-stats")
        .arg(&fit)
        .arg(&fit)
        .output()
        .unwrap();
    assert!(!out.status.success());
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(err.contains("not written by `ratfit cdf`"), "{err}");
}

#[test]
fn bench_fit_writes_checked_results_and_refuses_bad_instance_files() {
    let dir = scratch("bench");
    let instances = dir.join("instances.toml");
    std::fs::write(
        &instances,
        "[settings]\nrepetitions = 2\n\n[[instance]]\nname = \"runge\"\nrel_tol = [1e-2]\nsplits = [[3, 3], [6, 6]]\naaa = true\ndata = { kind = \"function\", function = \"runge\", samples = [300, 900] }\n",
    )
    .unwrap();
    let out_dir = dir.join("out");
    let out = ratfit()
        .args(["bench", "fit", "--backends", "native", "--instances"])
        .arg(&instances)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(out_dir.join("results.csv")).unwrap();
    // Two sizes x two splits on native, plus AAA at m = 3 and 6 per size.
    assert_eq!(csv.lines().count(), 1 + 4 + 4, "{csv}");
    assert!(csv.lines().skip(1).all(|l| l.contains(",true,")), "{csv}");
    let summary = std::fs::read_to_string(out_dir.join("summary.md")).unwrap();
    assert!(summary.contains("| runge |"), "{summary}");
    let png = std::fs::read(out_dir.join("error_vs_time.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"));
    let check = ratfit()
        .args(["bench", "check"])
        .arg(&out_dir)
        .output()
        .unwrap();
    // The run had only native; a build with other backends expects them too.
    let only_native = rational_core::Backend::available().len() == 1;
    assert_eq!(
        check.status.success(),
        only_native,
        "{}",
        String::from_utf8_lossy(&check.stderr)
    );

    // A tampered result (violated point marked verified) is caught.
    let tampered: String = csv
        .lines()
        .enumerate()
        .map(|(i, l)| {
            if i == 1 {
                let mut f: Vec<String> = l.split(',').map(str::to_string).collect();
                f[11] = "0.5".into();
                f.join(",")
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n");
    std::fs::write(out_dir.join("results.csv"), tampered + "\n").unwrap();
    let check = ratfit()
        .args(["bench", "check", "--backends", "native"])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(!check.status.success());
    assert!(String::from_utf8_lossy(&check.stderr).contains("violation"));

    std::fs::write(&instances, "[[instance]]\nname = \"x\"\nrel_tol = [1e-2]\nsplits = [[3, 3]]\ndata = { kind = \"function\", function = \"sinc\", samples = [10] }\n").unwrap();
    let out = ratfit()
        .args(["bench", "fit", "--instances"])
        .arg(&instances)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(String::from_utf8_lossy(&out.stderr).contains("unknown function `sinc`"));
}

#[test]
fn bench_rgl_fits_real_files_in_two_and_three_dimensions() {
    let dir = scratch("bench-rgl");
    let out = ratfit()
        .args(["bench", "rgl"])
        .arg(&dir)
        .arg("--out")
        .arg(dir.join("out"))
        .output()
        .unwrap();
    assert!(!out.status.success());
    assert!(
        String::from_utf8_lossy(&out.stderr).contains("no .bsdf file"),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );

    let data = common::data_dir();
    if !data.join("rgl").is_dir() {
        eprintln!("SKIPPED bench rgl on real files: no data folder (set RATFIT_DATA)");
        return;
    }
    let out_dir = dir.join("out");
    let out = ratfit()
        .args(["bench", "rgl"])
        .arg(data.join("rgl"))
        .args([
            "--only",
            "cm_military_green",
            "--dims",
            "2,3",
            "--resolution-3d",
            "12",
            "--max-coeffs",
            "60",
            "--out",
        ])
        .arg(&out_dir)
        .output()
        .unwrap();
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let csv = std::fs::read_to_string(out_dir.join("results.csv")).unwrap();
    let header: Vec<&str> = csv.lines().next().unwrap().split(',').collect();
    let col = |name: &str| header.iter().position(|h| *h == name).unwrap();
    let rows: Vec<Vec<&str>> = csv
        .lines()
        .skip(1)
        .map(|l| l.split(',').collect())
        .collect();
    assert_eq!(rows.len(), 6, "two fits of three channels: {csv}");
    for r in &rows {
        assert_eq!(r[col("outcome")], "fit", "{csv}");
        let coeffs: usize =
            r[col("n_p")].parse::<usize>().unwrap() + r[col("n_q")].parse::<usize>().unwrap();
        assert!((2..=60).contains(&coeffs), "{csv}");
        // Errors are printed to 5 decimals; the fit is verified against
        // the intervals it reports.
        let max_rel: f64 = r[col("max_rel")].parse().unwrap();
        let used: f64 = r[col("rel_tol_used")].parse().unwrap();
        assert!(max_rel <= used + 1e-5, "{csv}");
    }
    for d in ["2", "3"] {
        assert!(rows.iter().filter(|r| r[col("dims")] == d).count() == 3);
        let fit = out_dir.join(format!("fits/cm_military_green_rgb_{d}d.json"));
        assert!(fit.is_file(), "{}", fit.display());
    }
    let summary = std::fs::read_to_string(out_dir.join("summary.md")).unwrap();
    assert!(
        summary.lines().filter(|l| l.contains("military")).count() == 2,
        "{summary}"
    );
    let png = std::fs::read(out_dir.join("error_vs_time.png")).unwrap();
    assert!(png.starts_with(b"\x89PNG"));
}

/// `ratfit batch`: shards split the manifest, a rerun fits nothing, a
/// changed setting or a lost output is fitted again, bad manifests are
/// refused before anything is fitted.
#[test]
fn batch_resumes_shards_and_refuses_bad_manifests() {
    let data = common::data_dir();
    if !data.join("rgl").is_dir() {
        eprintln!("SKIPPED batch on real files: no data folder (set RATFIT_DATA)");
        return;
    }
    let dir = std::env::temp_dir().join(format!("ratfit-batch-{}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    let manifest = dir.join("m.toml");
    let write = |rel_tol: f64, extra: &str| {
        let text = format!(
            "[defaults]\nresolution = [16, 16]\nmax_coeffs = 30\nrel_tol = {rel_tol}\n\n\
             [[material]]\npath = \"{d}/rgl/cm_military_green_rgb.bsdf\"\n\n\
             [[material]]\nname = \"golden\"\npath = \"{d}/rgl/vch_golden_yellow_rgb.bsdf\"\nrel_tol = 0.2\n\n\
             [[material]]\npath = \"{d}/rgl/aurora_white_rgb.bsdf\"\nlobe = true\n{extra}",
            d = data.display()
        );
        std::fs::write(&manifest, text).unwrap();
    };
    let out = dir.join("out");
    let run = |extra: &[&str]| {
        let o = ratfit()
            .arg("batch")
            .arg(&manifest)
            .arg("--out")
            .arg(&out)
            .args(extra)
            .output()
            .unwrap();
        (
            o.status.success(),
            String::from_utf8_lossy(&o.stdout).into_owned() + &String::from_utf8_lossy(&o.stderr),
        )
    };
    write(0.15, "");
    let (ok, text) = run(&["--shard", "0/2"]);
    assert!(ok && text.contains("2 fitted, 0 skipped"), "{text}");
    let (ok, text) = run(&["--shard", "1/2"]);
    assert!(
        ok && text.contains("1 fitted") && text.contains("3 of 3 materials done"),
        "{text}"
    );
    let (ok, text) = run(&[]);
    assert!(ok && text.contains("0 fitted, 3 skipped"), "{text}");
    let summary = std::fs::read_to_string(out.join("summary.csv")).unwrap();
    assert_eq!(
        summary.lines().filter(|l| l.contains(",done,")).count(),
        3,
        "{summary}"
    );
    // Every output is a fit file that loads, with its key in its name.
    for line in summary.lines().skip(1) {
        let file = line.split(',').nth(4).unwrap();
        let key = line.split(',').nth(2).unwrap();
        assert!(file.contains(key), "{line}");
        let e = ratfit()
            .args(["export"])
            .arg(out.join(file))
            .args(["--to", "binary", "-o"])
            .arg(dir.join("x.bin"))
            .output()
            .unwrap();
        assert!(e.status.success(), "{}", String::from_utf8_lossy(&e.stderr));
    }
    // A changed default refits the two materials that use it.
    write(0.12, "");
    let (ok, text) = run(&[]);
    assert!(ok && text.contains("2 fitted, 1 skipped"), "{text}");
    // A lost output is fitted again, the others are skipped.
    let golden: Vec<PathBuf> = std::fs::read_dir(&out)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.to_string_lossy().contains("golden-"))
        .collect();
    assert_eq!(golden.len(), 1);
    std::fs::remove_file(&golden[0]).unwrap();
    let (ok, text) = run(&[]);
    assert!(ok && text.contains("1 fitted, 2 skipped"), "{text}");
    // Bad manifests and flags: named, nothing fitted.
    for (extra, expect) in [
        ("rel_tl = 0.1\n", "`rel_tl` is not a `ratfit fit` option"),
        ("rel_tol = \"x\"\n", "--rel-tol"),
        ("output = \"a.json\"\n", "set by the batch"),
        ("[[material]]\npath = \"nowhere.bsdf\"\n", "cannot read"),
    ] {
        write(0.12, extra);
        let (ok, text) = run(&[]);
        assert!(!ok && text.contains(expect), "{extra}: {text}");
    }
    write(0.12, "");
    for bad in ["2/2", "1", "x/3"] {
        let (ok, text) = run(&["--shard", bad]);
        assert!(!ok && text.contains("--shard"), "{bad}: {text}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

/// `--lobe` needs a table to fit the lobe to: other formats are refused
/// by name before anything is read.
#[test]
fn lobe_is_refused_for_scattered_and_alta_data() {
    for format in ["cornell", "alta"] {
        let out = ratfit()
            .args(["fit", "nowhere.txt", "--format", format, "--lobe", "-o"])
            .arg(std::env::temp_dir().join("ratfit-lobe-refused.json"))
            .output()
            .unwrap();
        assert!(!out.status.success());
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(err.contains("--lobe"), "{format}: {err}");
    }
}

/// Ctrl-C during a long `ratfit fit` stops the sweep within moments (the
/// native solver checks the flag at every active-set change), exits with
/// status 130, says so, and writes nothing.
#[cfg(unix)]
#[test]
fn ctrl_c_stops_a_long_fit_promptly_and_writes_nothing() {
    use std::time::{Duration, Instant};
    let data = common::data_dir();
    if !data.join("rgl").is_dir() {
        eprintln!("SKIPPED Ctrl-C on a real fit: no data folder (set RATFIT_DATA)");
        return;
    }
    let dir = scratch("interrupt");
    let output = dir.join("fit.json");
    // Minutes of work: 3-D, 10% intervals, up to 120 coefficients.
    let mut child = ratfit()
        .args(["fit", "--format", "rgl", "--dims", "3", "--rel-tol", "0.1"])
        .args(["--max-coeffs", "120", "--no-render-check", "-o"])
        .arg(&output)
        .arg(data.join("rgl/cm_military_green_rgb.bsdf"))
        .stderr(std::process::Stdio::piped())
        .stdout(std::process::Stdio::null())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_secs(3));
    let sent = Command::new("kill")
        .args(["-INT", &child.id().to_string()])
        .status()
        .unwrap();
    assert!(sent.success());
    let asked = Instant::now();
    let status = loop {
        if let Some(s) = child.try_wait().unwrap() {
            break s;
        }
        if asked.elapsed() > Duration::from_secs(30) {
            child.kill().ok();
            panic!("still running 30 s after Ctrl-C");
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let mut err = String::new();
    std::io::Read::read_to_string(child.stderr.as_mut().unwrap(), &mut err).unwrap();
    assert_eq!(status.code(), Some(130), "{err}");
    assert!(
        err.contains("interrupted") && err.contains("cancelled"),
        "{err}"
    );
    assert!(
        !output.exists(),
        "an interrupted fit wrote {}",
        output.display()
    );
    eprintln!(
        "stopped {:.2} s after Ctrl-C",
        asked.elapsed().as_secs_f64()
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn perceptual_fits_take_an_elevation_cut_only_when_asked() {
    let dir = scratch("perceptual-cut");
    let merl = blinn_phong_merl(&dir);
    for (cut, want) in [(None, 90.0), (Some("75"), 75.0)] {
        let fit = dir.join("fit.json");
        let mut cmd = ratfit();
        cmd.arg("fit")
            .arg(&merl)
            .args(["--format", "merl", "--perceptual", "--rel-tol", "0.2"])
            .args(["--dims", "3", "--resolution", "8,8,8", "--no-render-check"]);
        if let Some(c) = cut {
            cmd.args(["--max-elevation", c]);
        }
        let out = cmd.arg("-o").arg(&fit).output().unwrap();
        assert!(
            out.status.success(),
            "{}",
            String::from_utf8_lossy(&out.stderr)
        );
        let json: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&fit).unwrap()).unwrap();
        let got = json["brdf"]["reduction"]["max_elevation_deg"]
            .as_f64()
            .unwrap();
        assert!((got - want).abs() < 1e-12, "{cut:?}: {got}");
    }
}

#[test]
fn the_render_check_of_a_perceptual_fit_chooses_its_evaluation_cut() {
    let dir = scratch("perceptual-cut-choice");
    let merl = blinn_phong_merl(&dir);
    let fit = dir.join("fit.json");
    let out = ratfit()
        .arg("fit")
        .arg(&merl)
        .args(["--format", "merl", "--perceptual", "--rel-tol", "0.2"])
        .args(["--dims", "3", "--resolution", "8,8,8", "-o"])
        .arg(&fit)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    let line = stdout
        .lines()
        .find(|l| l.starts_with("evaluation cut chosen by the validation renders"))
        .unwrap_or_else(|| panic!("no cut choice in\n{stdout}"));
    // Seventeen evaluations measured, each with its bytes: none, then 80,
    // 75, 70 and 65 degrees without and with each uniform luminance shell
    // factor (8 x 4 and 4 x 4 cells), then the four other layouts at the
    // best of those cuts; three more for each lower cut (60, then 55)
    // tried while the lowest cut did best.
    let measured_at =
        |cut: &str| line.contains(&format!(", {cut} ")) || line.contains(&format!(", {cut}+shell"));
    let lower = ["60", "55"].iter().take_while(|c| measured_at(c)).count();
    assert!(!measured_at("55") || measured_at("60"), "{line}");
    assert_eq!(line.matches(" B)").count(), 17 + 3 * lower, "{line}");
    assert_eq!(line.matches("+shell ").count(), 12 + 2 * lower, "{line}");
    assert_eq!(line.matches("x4 cos").count(), 4, "{line}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fit).unwrap()).unwrap();
    let got = json["brdf"]["reduction"]["max_elevation_deg"]
        .as_f64()
        .unwrap();
    // The file holds the cut the line names.
    let shell = &json["brdf"]["shell"];
    let shell_bytes = shell["factors"].as_array().map(|f| 4 * f.len());
    let named = match shell_bytes {
        _ if got >= 90.0 => "none, the whole hemisphere".to_string(),
        Some(b) => {
            let mut cells = format!("{} x {} cells", shell["n_theta_h"], shell["n_theta_d"]);
            if shell["spacing"] == "cosine" {
                cells += ", theta_d bins uniform in cosine";
            }
            if shell["colour"] == "per_function" {
                cells += ", a factor per function";
            }
            format!("{got} degrees and a shell factor of {b} bytes ({cells})")
        }
        None => format!("{got} degrees"),
    };
    assert!(
        line.contains(&format!("renders: {named} (")),
        "{got}: {line}"
    );
    // The render check also gives the part of its error the luminance and
    // the colour each cause.
    assert!(stdout.contains("error by part (mean CIEDE2000, lights / sky)"));
    for part in ["luminance_mean_de", "colour_mean_de"] {
        let v = json["render"]["colour_split"][part].as_array().unwrap();
        assert!(v.len() == 2 && v.iter().all(|e| e.as_f64().unwrap() >= 0.0));
    }
    // The file records every evaluation measured and the choice: none,
    // four cuts without and with two shell factors, three more for each
    // lower cut, and four more layouts at the best of those cuts.
    assert_eq!(
        json["evaluation_cut"]["tried"].as_array().unwrap().len(),
        17 + 3 * lower
    );
    let chosen = json["evaluation_cut"]["chosen"].as_f64().unwrap_or(90.0);
    assert!((chosen - got).abs() < 1e-12, "{chosen} against {got}");
}

#[test]
fn a_target_fit_samples_the_shared_3d_grid_and_reports_what_it_reached() {
    let dir = scratch("target-grid");
    let merl = blinn_phong_merl(&dir);
    let fit = dir.join("fit.json");
    // A target no fit reaches within a one-second budget: one tolerance is
    // tried, on the grid `--target-de` chooses when `--resolution` is not
    // given: the default grid is measured first, and at a target of 0.001
    // the table on it renders far above the target, so the fits sample the
    // finer `theta_h` grid.
    let out = ratfit()
        .arg("fit")
        .arg(&merl)
        .args(["--format", "merl", "--target-de", "0.001", "--dims", "3"])
        .args(["--time-budget", "1", "-o"])
        .arg(&fit)
        .output()
        .unwrap();
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        out.status.success(),
        "{}",
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(stdout.contains("NOT reached"), "{stdout}");
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&fit).unwrap()).unwrap();
    let r = &json["brdf"]["reduction"];
    let bins = ["n_theta_h", "n_theta_d", "n_phi_d"].map(|k| r[k].as_u64().unwrap() as usize);
    let fine = render_cpu::fidelity::TARGET_FINE_GRID_3D;
    assert_eq!(bins, fine, "{r}");
    assert_eq!(json["target"]["reached"], false);
    let choice = &json["target"]["grid_choice"];
    assert_eq!(
        choice["base"]["bins"],
        serde_json::json!(render_cpu::fidelity::TARGET_GRID_3D)
    );
    assert_eq!(choice["fine"], serde_json::json!(fine));
    assert!(choice["base"]["worst_mean_de"].as_f64().unwrap() > 0.003);
    assert_eq!(
        json["target"]["grid_floor"]["bins"],
        serde_json::json!(fine)
    );
    assert!(stdout.contains("finer theta_h"), "{stdout}");
    std::fs::remove_dir_all(&dir).ok();
}
