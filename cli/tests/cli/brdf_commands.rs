//! Tests of the `ratfit` binary's BRDF commands: `fit`, `eval`,
//! `export`, `plot` and `cdf` on a MERL file, perceptual and target fits,
//! and Ctrl-C during a fit.

use crate::common::{self, blinn_phong_merl, ratfit, scratch};
use std::process::Command;

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
    let Some(data) = common::rgl_data("Ctrl-C on a real fit") else {
        return;
    };
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
    let stdout = crate::stdout_of_success(out);
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

/// chm_light_blue's perceptual fit within 65 degrees: the centred points of
/// all three functions dip below `q > 0` on the pole check's grid, so each
/// is centred only once it is solved again with those rows.
#[test]
fn a_centred_point_that_needs_pole_rows_is_solved_again_with_them() {
    let Some(data) = common::rgl_data("centred pole rows on a real fit") else {
        return;
    };
    let dir = scratch("centred-pole-rows");
    let out = ratfit()
        .arg("fit")
        .arg(data.join("rgl/chm_light_blue_rgb.bsdf"))
        .args(["--format", "rgl", "--dims", "3", "--resolution", "24,16,8"])
        .args(["--phi", "cosine", "--max-elevation", "65", "--perceptual"])
        .args([
            "--rel-tol",
            "0.32",
            "--colour",
            "luminance-chroma",
            "--centred",
        ])
        .args([
            "--max-coeffs",
            "120",
            "--search",
            "staircase",
            "--max-widenings",
            "2",
        ])
        .args([
            "--widen-factor",
            "1.4142135623730951",
            "--no-render-check",
            "-o",
        ])
        .arg(dir.join("fit.json"))
        .output()
        .unwrap();
    let stdout = crate::stdout_of_success(out);
    assert!(
        stdout.contains("least squares within the intervals (not the largest margin): Yrb"),
        "{stdout}"
    );
    std::fs::remove_dir_all(&dir).ok();
}
