//! Tests of `ratfit bench fit`, `ratfit bench rgl` and `ratfit batch`.

use crate::common::{self, ratfit, scratch};
use std::path::PathBuf;

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

    let Some(data) = common::rgl_data("bench rgl on real files") else {
        return;
    };
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
    let Some(data) = common::rgl_data("batch on real files") else {
        return;
    };
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
