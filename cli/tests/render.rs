//! End-to-end tests of `ratfit render`, `ratfit compare` and
//! `ratfit bench render`, and of the example scenes.

mod common;

use common::{ratfit, scratch};
use std::path::{Path, PathBuf};
use std::process::{Command, Output};

/// Runs and asserts success; returns stdout and stderr together.
fn run_ok(cmd: &mut Command) -> String {
    let out: Output = cmd.output().unwrap();
    let text = format!(
        "{}{}",
        String::from_utf8_lossy(&out.stdout),
        String::from_utf8_lossy(&out.stderr)
    );
    assert!(out.status.success(), "{text}");
    text
}

/// Runs and asserts failure; returns stderr.
fn run_err(cmd: &mut Command) -> String {
    let out = cmd.output().unwrap();
    assert!(!out.status.success(), "unexpected success");
    String::from_utf8_lossy(&out.stderr).into_owned()
}

const SCENE: &str = r#"
[camera]
from = [0.0, 0.5, 3.0]
to = [0.0, 0.0, 0.0]
width = 32
height = 24

[integrator]
kind = "path"
spp = 4
max_depth = 3

[materials.glossy]
kind = "ggx"
kd = [0.1, 0.2, 0.4]
f0 = [0.04, 0.04, 0.04]
alpha = 0.3

[materials.glossy_fit]
kind = "fitted"
source = "glossy"
rel_tol = 0.1

[materials.floor]
kind = "lambert"
albedo = [0.5, 0.5, 0.5]

[[objects]]
shape = "mesh"
path = "tri.obj"
material = "floor"

[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 0.8
material = "glossy"

[[lights]]
kind = "point"
position = [1.0, 2.0, 2.0]
intensity = [5.0, 5.0, 5.0]

[environment]
kind = "sky"
zenith = [0.5, 0.6, 0.9]
horizon = [0.9, 0.9, 0.9]
ground = [0.1, 0.1, 0.1]
"#;

fn write_scene(dir: &Path) -> PathBuf {
    std::fs::write(
        dir.join("tri.obj"),
        "v -5 -0.8 -5\nv 5 -0.8 -5\nv 0 -0.8 5\nf 1 3 2\n",
    )
    .unwrap();
    let p = dir.join("scene.toml");
    std::fs::write(&p, SCENE).unwrap();
    p
}

#[test]
fn render_writes_images_and_caches_fits_and_compare_measures_them() {
    let dir = scratch("render");
    let scene = write_scene(&dir);
    let cache = dir.join("cache");
    let (png, exr) = (dir.join("a.png"), dir.join("a.exr"));
    let text = run_ok(
        ratfit()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&png)
            .arg("-o")
            .arg(&exr)
            .arg("--cache")
            .arg(&cache),
    );
    assert!(
        text.contains("render:") && text.contains("phases: prepare"),
        "{text}"
    );
    assert!(text.contains("skipped  material glossy_fit"), "{text}");
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    // The fit is computed once, then read from the cache.
    let fit_exr = dir.join("fit.exr");
    let fit_run = |cmd: &mut Command| {
        run_ok(
            cmd.arg("render")
                .arg(&scene)
                .arg("-o")
                .arg(&fit_exr)
                .arg("--cache")
                .arg(&cache)
                .args(["--swap", "glossy=glossy_fit"]),
        )
    };
    let first = fit_run(&mut ratfit());
    assert!(
        first.contains("prepared material glossy_fit") && first.contains("fitted"),
        "{first}"
    );
    let second = fit_run(&mut ratfit());
    assert!(second.contains("cached   material glossy_fit"), "{second}");

    let same = run_ok(ratfit().arg("compare").arg(&exr).arg(&exr).arg("--json"));
    let v: serde_json::Value = serde_json::from_str(
        same.lines()
            .take_while(|l| !l.starts_with("wrote"))
            .collect::<Vec<_>>()
            .join("\n")
            .as_str(),
    )
    .unwrap();
    assert!(v["mean_de2000"].as_f64().unwrap().abs() < 1e-12, "{same}");
    let diff_png = dir.join("diff.png");
    let text = run_ok(
        ratfit()
            .arg("compare")
            .arg(&exr)
            .arg(&fit_exr)
            .arg("-o")
            .arg(&diff_png),
    );
    assert!(text.contains("CIEDE2000") && diff_png.exists(), "{text}");
    // Errors: a PNG is not linear, sizes must match, outputs need a known extension.
    assert!(run_err(ratfit().arg("compare").arg(&png).arg(&exr)).contains("OpenEXR"));
    let small = dir.join("small.exr");
    run_ok(
        ratfit()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(&small)
            .args(["--resolution", "8x8", "--no-cache"]),
    );
    assert!(run_err(ratfit().arg("compare").arg(&small).arg(&exr)).contains("sizes differ"));
    assert!(run_err(
        ratfit()
            .arg("render")
            .arg(&scene)
            .arg("-o")
            .arg(dir.join("a.jpg"))
    )
    .contains(".png or .exr"));
    assert!(run_err(
        ratfit()
            .arg("render")
            .arg(dir.join("none.toml"))
            .arg("-o")
            .arg(&png)
    )
    .contains("none.toml"));
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn bench_render_compares_samplers_against_a_reference() {
    let dir = scratch("bench");
    let scene = write_scene(&dir);
    let out = dir.join("out");
    let text = run_ok(
        ratfit()
            .args(["bench", "render"])
            .arg(&scene)
            .arg("--out")
            .arg(&out)
            .args([
                "--samplers",
                "cosine,tabulated",
                "--spp-list",
                "1,4",
                "--reference-spp",
                "32",
                "--resolution",
                "12x8",
                "--no-cache",
            ]),
    );
    assert!(text.contains("Equal time"), "{text}");
    let csv = std::fs::read_to_string(out.join("render.csv")).unwrap();
    assert_eq!(csv.lines().count(), 5, "{csv}");
    for line in csv.lines().skip(1) {
        let rmse: f64 = line.split(',').nth(4).unwrap().parse().unwrap();
        assert!(rmse.is_finite() && rmse > 0.0, "{line}");
    }
    for f in [
        "error_vs_time.svg",
        "error_vs_time.png",
        "summary.md",
        "reference.exr",
    ] {
        assert!(out.join(f).exists(), "{f}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn the_example_scenes_prepare_and_render() {
    let Some(data) = common::rgl_data("the example scenes, which use measured data") else {
        return;
    };
    let dir = scratch("examples");
    let scenes = PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../scenes");
    for name in ["sphere-lights", "sphere-sky", "lights256", "cornell"] {
        let text = run_ok(
            ratfit()
                .arg("render")
                .arg(scenes.join(format!("{name}.toml")))
                .arg("-o")
                .arg(dir.join(format!("{name}.png")))
                .args(["--resolution", "16x12", "--spp", "1"])
                .arg("--cache")
                .arg(dir.join("cache"))
                .env("RATFIT_DATA", &data),
        );
        assert!(text.contains("render:"), "{name}: {text}");
    }
    std::fs::remove_dir_all(&dir).ok();
}

const GPU_SCENE: &str = r#"
[camera]
from = [0.0, 0.5, 3.0]
to = [0.0, 0.0, 0.0]
width = 48
height = 36

[integrator]
kind = "direct"
spp = 1
shadows = false

[materials.glossy]
kind = "ggx"
kd = [0.1, 0.2, 0.4]
f0 = [0.04, 0.04, 0.04]
alpha = 0.3

[materials.glossy_fit]
kind = "fitted"
source = "glossy"
rel_tol = 0.2

[[objects]]
shape = "mesh-sphere"
center = [0.0, 0.0, 0.0]
radius = 0.8
triangles = 300
material = "glossy_fit"

[[lights]]
kind = "directional-set"
count = 16
irradiance = [2.0, 2.0, 2.0]
axis = [0.0, 0.5, 1.0]
max_angle_deg = 70.0
"#;

/// `--gpu` renders what the CPU renders (same scene, compared in Lab) in a
/// build with the `gpu` feature, and names the missing feature otherwise.
#[test]
fn render_on_the_gpu_matches_the_cpu_or_names_the_missing_feature() {
    let dir = scratch("gpu");
    let scene = dir.join("gpu.toml");
    std::fs::write(&scene, GPU_SCENE).unwrap();
    let mut gpu = ratfit();
    gpu.arg("render")
        .arg(&scene)
        .arg("--gpu")
        .arg("--no-cache")
        .arg("-o")
        .arg(dir.join("gpu.exr"));
    if !cfg!(feature = "gpu") {
        let e = run_err(&mut gpu);
        assert!(
            e.contains("without the GPU renderer") && e.contains("--features gpu"),
            "{e}"
        );
        return;
    }
    let out = gpu.output().unwrap();
    let text = String::from_utf8_lossy(&out.stderr).into_owned();
    if !out.status.success() && text.contains("no GPU adapter") {
        let required = std::env::var("RATFIT_REQUIRE_GPU").is_ok_and(|v| !v.is_empty() && v != "0");
        assert!(!required, "RATFIT_REQUIRE_GPU is set, but: {text}");
        use std::io::Write;
        let _ = writeln!(std::io::stderr(), "SKIPPED render --gpu: {text}");
        return;
    }
    assert!(out.status.success(), "{text}");
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("GPU: ") && stdout.contains("16 lights"),
        "{stdout}"
    );
    run_ok(
        ratfit()
            .arg("render")
            .arg(&scene)
            .arg("--no-cache")
            .arg("-o")
            .arg(dir.join("cpu.exr")),
    );
    let cmp = run_ok(
        ratfit()
            .arg("compare")
            .arg(dir.join("cpu.exr"))
            .arg(dir.join("gpu.exr"))
            .arg("--json"),
    );
    let start = cmp.find('{').unwrap();
    let end = cmp.rfind('}').unwrap();
    let v: serde_json::Value = serde_json::from_str(&cmp[start..=end]).unwrap();
    let mean = v["covered_mean_de2000"].as_f64().unwrap();
    assert!(mean < 0.05, "{cmp}");
}

/// A scene's `target_de` material and `ratfit fit --target-de` with the
/// same target, budgets and table return the same fit: both search on the
/// same validation renders with the same settings.
#[test]
fn a_scene_target_fit_is_the_fit_ratfit_fit_returns() {
    let dir = scratch("target-same");
    let merl = common::blinn_phong_merl(&dir);
    let fit = dir.join("fit.json");
    run_ok(
        ratfit()
            .arg("fit")
            .arg(&merl)
            .args(["--format", "merl", "--target-de", "3", "--max-bytes", "512"])
            .args(["--max-coeffs", "30", "-o"])
            .arg(&fit),
    );
    let scene = dir.join("target.toml");
    std::fs::write(
        &scene,
        format!(
            r#"
[camera]
from = [0.0, 0.0, 3.0]
to = [0.0, 0.0, 0.0]
width = 8
height = 8

[integrator]
kind = "direct"
spp = 1

[materials.table]
kind = "measured"
format = "merl"
path = "{}"

[materials.fit]
kind = "fitted"
source = "table"
target_de = 3.0
max_bytes = 512
max_coeffs = 30

[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "fit"

[[lights]]
kind = "directional"
direction = [0.5, 0.6, 0.8]
irradiance = [5.0, 5.0, 5.0]
"#,
            merl.display()
        ),
    )
    .unwrap();
    let cache = dir.join("cache");
    run_ok(
        ratfit()
            .arg("render")
            .arg(&scene)
            .arg("--cache")
            .arg(&cache)
            .arg("-o")
            .arg(dir.join("target.png")),
    );
    let cached: Vec<PathBuf> = std::fs::read_dir(&cache)
        .unwrap()
        .map(|e| e.unwrap().path())
        .filter(|p| p.file_name().unwrap().to_string_lossy().starts_with("fit-"))
        .collect();
    assert_eq!(cached.len(), 1, "{cached:?}");
    let read = |p: &Path| -> serde_json::Value {
        serde_json::from_str(&std::fs::read_to_string(p).unwrap()).unwrap()
    };
    let (from_scene, from_fit) = (read(&cached[0]), read(&fit));
    assert!(from_fit["target"]["bytes"].as_u64().unwrap() <= 512);
    assert_eq!(from_scene["payload"], from_fit["brdf"]);
    std::fs::remove_dir_all(dir).ok();
}
