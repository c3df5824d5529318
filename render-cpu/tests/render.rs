//! Furnace and analytic scenes with known answers, on every sampler; scene
//! preparation (only what is needed, the fit cache, errors); determinism.

use render_cpu::{
    prepare, render, Action, Camera, RenderError, RenderOptions, SamplerKind, Scene,
    SceneDescription, Shape,
};
use std::path::{Path, PathBuf};

const SAMPLERS: [SamplerKind; 3] = [
    SamplerKind::Cosine,
    SamplerKind::Tabulated,
    SamplerKind::Rational,
];

fn temp_dir(tag: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!("ratfit-render-{tag}-{}", std::process::id()));
    std::fs::create_dir_all(&d).unwrap();
    d
}

fn sphere_scene(material: &str, lights: &str, integrator: &str) -> String {
    format!(
        r#"
[camera]
from = [0.0, 0.0, 3.0]
to = [0.0, 0.0, 0.0]
fov_deg = 45.0
width = 24
height = 24

[integrator]
{integrator}

[materials.m]
{material}

[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "m"

{lights}
"#
    )
}

fn prepared(text: &str, options: &RenderOptions) -> Result<Scene, RenderError> {
    let desc = SceneDescription::parse(text, "test scene")?;
    prepare(desc, Path::new("."), "test scene", options).map(|(s, _)| s)
}

fn options(sampler: SamplerKind, mis: bool) -> RenderOptions {
    RenderOptions {
        sampler: Some(sampler),
        mis: Some(mis),
        no_cache: true,
        ..Default::default()
    }
}

/// Sphere normal seen through pixel `(x, y)` (pixel centre), if any.
fn normal_at(camera: &Camera, x: usize, y: usize) -> Option<[f64; 3]> {
    let shape = Shape::Sphere {
        center: [0.0; 3],
        radius: 1.0,
    };
    shape
        .intersect(&camera.ray(x as f64 + 0.5, y as f64 + 0.5))
        .map(|h| h.shading_normal)
}

/// Checks the sphere pixels against `truth(normal)`: the mean error over
/// all pixel samples must be within `z` standard errors (estimated from the
/// same samples; pixels are independent). Returns the mean error.
fn check_against(scene: &Scene, z: f64, truth: impl Fn([f64; 3]) -> [f64; 3]) -> f64 {
    // One pixel-centre sample per render: the truth is per normal.
    let mut s = scene.clone();
    let spp = s.integrator.spp;
    s.integrator.spp = 1;
    let mut errors = Vec::new();
    for k in 0..spp {
        s.integrator.seed = 1000 + k as u64;
        let out = render(&s, &|_, _| {});
        for y in 0..out.image.height {
            for x in 0..out.image.width {
                if let Some(n) = normal_at(&s.camera, x, y) {
                    let p = out.image.at(x, y);
                    let t = truth(n);
                    errors.push((0..3).map(|c| f64::from(p[c]) - t[c]).sum::<f64>() / 3.0);
                }
            }
        }
    }
    let n = errors.len() as f64;
    let mean = errors.iter().sum::<f64>() / n;
    let var = errors.iter().map(|e| (e - mean).powi(2)).sum::<f64>() / (n - 1.0);
    let se = (var / n).sqrt();
    assert!(
        mean.abs() <= z * se + 1e-6,
        "mean error {mean:.3e} > {z} x standard error {se:.3e}"
    );
    mean
}

#[test]
fn white_furnace_renders_one_for_every_sampler_and_integrator() {
    for sampler in SAMPLERS {
        for integrator in ["kind = \"direct\"\nspp = 32", "kind = \"path\"\nspp = 32"] {
            for mis in [false, true] {
                let text = sphere_scene(
                    "kind = \"lambert\"\nalbedo = [1.0, 1.0, 1.0]",
                    "[environment]\nkind = \"uniform\"\nradiance = [1.0, 1.0, 1.0]",
                    integrator,
                );
                let scene = prepared(&text, &options(sampler, mis)).unwrap();
                let err = check_against(&scene, 5.0, |_| [1.0; 3]);
                eprintln!(
                    "furnace {:?} {integrator:?} mis={mis}: mean error {err:.2e}",
                    sampler
                );
                if sampler == SamplerKind::Cosine && !mis {
                    // rho cos / pdf = 1 for every sample: exact.
                    assert!(err.abs() < 1e-6, "{err}");
                }
            }
        }
    }
}

#[test]
fn lambertian_sphere_under_a_directional_light_is_exact() {
    let l = [0.3f64, 0.5, 0.81];
    let n = (l[0] * l[0] + l[1] * l[1] + l[2] * l[2]).sqrt();
    let l = l.map(|v| v / n);
    let text = sphere_scene(
        "kind = \"lambert\"\nalbedo = [0.2, 0.5, 0.8]",
        &format!(
            "[[lights]]\nkind = \"directional\"\ndirection = {l:?}\nirradiance = [2.0, 2.0, 2.0]"
        ),
        "kind = \"direct\"\nspp = 1",
    );
    for sampler in SAMPLERS {
        let scene = prepared(&text, &options(sampler, false)).unwrap();
        let out = render(&scene, &|_, _| {});
        let mut checked = 0;
        for y in 0..24 {
            for x in 0..24 {
                let p = out.image.at(x, y);
                let Some(nrm) = normal_at(&scene.camera, x, y) else {
                    assert!(p.iter().all(|v| *v == 0.0), "background");
                    continue;
                };
                let cos = (nrm[0] * l[0] + nrm[1] * l[1] + nrm[2] * l[2]).max(0.0);
                for (c, a) in [0.2, 0.5, 0.8].iter().enumerate() {
                    let want = a / std::f64::consts::PI * 2.0 * cos;
                    assert!(
                        (f64::from(p[c]) - want).abs() < 1e-6 * (1.0 + want),
                        "{x},{y}: {p:?} vs {want}"
                    );
                }
                checked += 1;
            }
        }
        assert!(checked > 200, "{checked}");
    }
}

#[test]
fn lambertian_sphere_under_a_hemisphere_sky_matches_the_closed_form() {
    // Irradiance from a uniform upper hemisphere (radiance 1) on a surface
    // with normal n is pi (1 + n_y) / 2, so the radiance is a (1 + n_y) / 2.
    let albedo = [0.9, 0.6, 0.3];
    for sampler in SAMPLERS {
        for mis in [false, true] {
            let text = sphere_scene(
                "kind = \"lambert\"\nalbedo = [0.9, 0.6, 0.3]",
                "[environment]\nkind = \"sky\"\nzenith = [1.0, 1.0, 1.0]\nhorizon = [1.0, 1.0, 1.0]\nground = [0.0, 0.0, 0.0]",
                "kind = \"direct\"\nspp = 16",
            );
            let scene = prepared(&text, &options(sampler, mis)).unwrap();
            let err = check_against(&scene, 5.0, |n| albedo.map(|a| a * (1.0 + n[1]) / 2.0));
            eprintln!("sky {sampler:?} mis={mis}: mean error {err:.2e}");
        }
    }
}

#[test]
fn glossy_furnace_matches_the_albedo_for_every_sampler() {
    // A non-Lambertian material in a uniform environment: each pixel is the
    // directional albedo at its view angle; the estimate of the mean over
    // the image must agree between samplers (all unbiased) within noise.
    let text = sphere_scene(
        "kind = \"blinn-phong\"\nkd = [0.3, 0.3, 0.3]\nks = [0.4, 0.4, 0.4]\nexponent = 40.0",
        "[environment]\nkind = \"uniform\"\nradiance = [1.0, 1.0, 1.0]",
        "kind = \"direct\"\nspp = 64",
    );
    let mut means = Vec::new();
    for sampler in SAMPLERS {
        let scene = prepared(&text, &options(sampler, false)).unwrap();
        let out = render(&scene, &|_, _| {});
        let (mut sum, mut var, mut n) = (0.0, 0.0, 0.0);
        for y in 0..24 {
            for x in 0..24 {
                if normal_at(&scene.camera, x, y).is_some() {
                    sum += f64::from(out.image.at(x, y)[1]);
                    n += 1.0;
                }
            }
        }
        var += out.stats.sample_variance[1] * (24.0 * 24.0) / n;
        let se = (var / (n * 64.0)).sqrt();
        eprintln!(
            "glossy furnace {sampler:?}: mean {:.5} +- {se:.1e}, variance {:.3e}",
            sum / n,
            out.stats.sample_variance[1]
        );
        means.push((sum / n, se));
    }
    for w in means.windows(2) {
        let d = (w[0].0 - w[1].0).abs();
        assert!(
            d < 5.0 * (w[0].1.powi(2) + w[1].1.powi(2)).sqrt() + 1e-9,
            "{means:?}"
        );
    }
    // Importance sampling must beat cosine sampling on a glossy lobe.
    assert!(
        means[1].1 < means[0].1 && means[2].1 < means[0].1,
        "{means:?}"
    );
}

#[test]
fn sobol_pattern_agrees_with_independent_samples_with_far_less_noise() {
    // A glossy sphere under the sky, every sample through the pixel centre:
    // across seeds, each pixel's estimates must agree between the two
    // patterns (both unbiased) and vary far less with the scrambled points.
    let scene_with = |pattern: &str| {
        let text = sphere_scene(
            "kind = \"ggx\"\nkd = [0.2, 0.2, 0.2]\nf0 = [0.04, 0.04, 0.04]\nalpha = 0.3",
            "[environment]\nkind = \"sky\"\nzenith = [0.9, 1.0, 1.3]\nhorizon = [1.6, 1.5, 1.3]\nground = [0.2, 0.18, 0.15]",
            &format!("kind = \"direct\"\nspp = 32\njitter = false\npattern = \"{pattern}\""),
        );
        prepared(&text, &options(SamplerKind::Tabulated, true)).unwrap()
    };
    let seeds = 12;
    let per_pixel = |scene: &Scene| {
        let mut s = scene.clone();
        let renders: Vec<_> = (0..seeds)
            .map(|k| {
                s.integrator.seed = 50 + k;
                render(&s, &|_, _| {}).image
            })
            .collect();
        let mut stats = Vec::new();
        for y in 0..24 {
            for x in 0..24 {
                if normal_at(&s.camera, x, y).is_some() {
                    let v: Vec<f64> = renders.iter().map(|r| f64::from(r.at(x, y)[1])).collect();
                    let mean = v.iter().sum::<f64>() / v.len() as f64;
                    let var =
                        v.iter().map(|a| (a - mean).powi(2)).sum::<f64>() / (v.len() - 1) as f64;
                    stats.push((mean, var));
                }
            }
        }
        stats
    };
    let independent = per_pixel(&scene_with("independent"));

    let sobol = per_pixel(&scene_with("lattice"));
    let (mut var_independent, mut var_sobol, mut diff, mut diff_var) = (0.0, 0.0, 0.0, 0.0);
    for ((mi, vi), (ms, vs)) in independent.iter().zip(&sobol) {
        var_independent += vi;
        var_sobol += vs;
        diff += mi - ms;
        diff_var += (vi + vs) / seeds as f64;
    }
    assert!(
        diff.abs() < 5.0 * diff_var.sqrt(),
        "summed difference of the means {diff:.3e} against its standard error {:.3e}",
        diff_var.sqrt()
    );
    assert!(
        var_sobol < var_independent / 4.0,
        "variance with scrambled Sobol' points {var_sobol:.3e}, independent {var_independent:.3e}"
    );
}

#[test]
fn renders_are_deterministic_per_seed() {
    let text = sphere_scene(
        "kind = \"ggx\"\nkd = [0.1, 0.2, 0.3]\nf0 = [0.04, 0.04, 0.04]\nalpha = 0.2",
        "[environment]\nkind = \"sky\"\nzenith = [1.0, 1.0, 1.0]\nhorizon = [0.5, 0.6, 0.7]\nground = [0.1, 0.1, 0.1]",
        "kind = \"path\"\nspp = 4\nseed = 3",
    );
    let scene = prepared(&text, &options(SamplerKind::Cosine, true)).unwrap();
    let a = render(&scene, &|_, _| {});
    let b = render(&scene, &|_, _| {});
    assert_eq!(a.image, b.image);
    let mut other = scene.clone();
    other.integrator.seed = 4;
    assert_ne!(render(&other, &|_, _| {}).image, a.image);
}

#[test]
fn only_what_the_scene_uses_is_prepared_and_fits_are_cached() {
    let cache = temp_dir("cache");
    let text = r#"
[camera]
from = [0.0, 0.0, 3.0]
to = [0.0, 0.0, 0.0]
width = 8
height = 8
[integrator]
kind = "direct"
spp = 1
sampler = "rational"
[materials.unused]
kind = "measured"
format = "merl"
path = "does/not/exist.binary"
[materials.truth]
kind = "blinn-phong"
kd = [0.2, 0.3, 0.4]
ks = [0.5, 0.5, 0.5]
exponent = 20.0
[materials.fit]
kind = "fitted"
source = "truth"
rel_tol = 0.1
[[objects]]
shape = "sphere"
center = [0.0, 0.0, 0.0]
radius = 1.0
material = "fit"
[[lights]]
kind = "directional"
direction = [0.0, 0.0, 1.0]
irradiance = [1.0, 1.0, 1.0]
"#;
    let opts = RenderOptions {
        cache_dir: Some(cache.clone()),
        ..Default::default()
    };
    let desc = SceneDescription::parse(text, "t").unwrap();
    let (_, log) = prepare(desc.clone(), Path::new("."), "t", &opts).unwrap();
    eprintln!("first:\n{log}");
    assert_eq!(log.find(Action::Skipped, "material unused").len(), 1);
    assert_eq!(log.find(Action::Prepared, "material fit").len(), 1);
    assert_eq!(
        log.find(Action::Prepared, "material truth").len(),
        1,
        "the source is built for the fit"
    );
    // Only directional lights under direct lighting: no inverse CDFs.
    assert_eq!(
        log.find(Action::Skipped, "rational sampler for fit").len(),
        1
    );
    let (_, log) = prepare(desc.clone(), Path::new("."), "t", &opts).unwrap();
    eprintln!("second:\n{log}");
    assert_eq!(log.find(Action::Cached, "material fit").len(), 1);
    assert!(
        log.find(Action::Prepared, "material truth").is_empty(),
        "cached fit: source not built"
    );
    // Other settings, another key: fitted again.
    let changed =
        SceneDescription::parse(&text.replace("rel_tol = 0.1", "rel_tol = 0.2"), "t").unwrap();
    let (_, log) = prepare(changed, Path::new("."), "t", &opts).unwrap();
    assert_eq!(log.find(Action::Prepared, "material fit").len(), 1);
    // The lobe-times-rational form is another key too, and its fit carries
    // the lobe into the renderer's f32 form.
    let lobe = SceneDescription::parse(
        &text.replace("rel_tol = 0.1", "rel_tol = 0.1\nlobe = true"),
        "t",
    )
    .unwrap();
    let (scene, log) = prepare(lobe.clone(), Path::new("."), "t", &opts).unwrap();
    assert_eq!(log.find(Action::Prepared, "material fit").len(), 1, "{log}");
    match &scene.materials[0].closed_form {
        Some(render_cpu::ClosedForm::Fit(f)) => {
            assert!(f.fit().lobe.is_some() && f.compact().lobe.is_some());
        }
        _ => panic!("the fitted material has no closed form"),
    }
    let (_, log) = prepare(lobe, Path::new("."), "t", &opts).unwrap();
    assert_eq!(log.find(Action::Cached, "material fit").len(), 1, "{log}");
    // An elevation cut is another key, and the fit carries it.
    let with_cut = |degrees: &str| {
        SceneDescription::parse(
            &text.replace(
                "rel_tol = 0.1",
                &format!("rel_tol = 0.1\nmax_elevation = {degrees}"),
            ),
            "t",
        )
        .unwrap()
    };
    let (scene, log) = prepare(with_cut("75.0"), Path::new("."), "t", &opts).unwrap();
    assert_eq!(log.find(Action::Prepared, "material fit").len(), 1, "{log}");
    match &scene.materials[0].closed_form {
        Some(render_cpu::ClosedForm::Fit(f)) => {
            assert!((f.fit().reduction.max_elevation_deg - 75.0).abs() < 1e-12);
        }
        _ => panic!("the fitted material has no closed form"),
    }
    let err = match prepare(with_cut("95.0"), Path::new("."), "t", &opts) {
        Ok(_) => panic!("a cut beyond the horizon is refused"),
        Err(e) => e.to_string(),
    };
    assert!(
        err.contains("fit") && err.contains("max_elevation"),
        "{err}"
    );
    // With an environment the BRDF is sampled: inverse CDFs are fitted, then cached.
    let with_env =
        format!("{text}\n[environment]\nkind = \"uniform\"\nradiance = [1.0, 1.0, 1.0]\n");
    let d = SceneDescription::parse(&with_env, "t").unwrap();
    let (scene, log) = prepare(d.clone(), Path::new("."), "t", &opts).unwrap();
    assert_eq!(
        log.find(Action::Prepared, "rational sampler for fit").len(),
        1,
        "{log}"
    );
    assert!(scene.materials[0].sampler_bytes > 0);
    let (_, log) = prepare(d, Path::new("."), "t", &opts).unwrap();
    assert_eq!(
        log.find(Action::Cached, "rational sampler for fit").len(),
        1,
        "{log}"
    );
    std::fs::remove_dir_all(&cache).ok();
}

#[test]
fn bad_scenes_give_named_errors() {
    let good = sphere_scene(
        "kind = \"lambert\"\nalbedo = [1.0, 1.0, 1.0]",
        "[environment]\nkind = \"uniform\"\nradiance = [1.0, 1.0, 1.0]",
        "kind = \"direct\"",
    );
    assert!(prepared(&good, &options(SamplerKind::Cosine, false)).is_ok());
    for (from, to, what) in [
        ("radius = 1.0", "radius = -1.0", "radius"),
        ("material = \"m\"", "material = \"nope\"", "nope"),
        (
            "kind = \"direct\"",
            "kind = \"bidirectional\"",
            "bidirectional",
        ),
        (
            "albedo = [1.0, 1.0, 1.0]",
            "albedo = [1.0, nan, 1.0]",
            "albedo",
        ),
        (
            "albedo = [1.0, 1.0, 1.0]",
            "albedo = [1e308, 0.5, 0.5]",
            "must lie in [0, 1]",
        ),
        (
            "radiance = [1.0, 1.0, 1.0]",
            "radiance = [1e300, 1.0, 1.0]",
            "at most 1e12",
        ),
        ("width = 24", "width = 0", "resolution"),
        (
            "kind = \"direct\"",
            "kind = \"direct\"\nspp = 1000000000000",
            "integrator.spp",
        ),
        (
            "kind = \"direct\"",
            "kind = \"direct\"\npattern = \"halton\"",
            "halton",
        ),
        ("radius = 1.0", "radius = 1.0\ncolour = 3", "colour"),
        (
            "kind = \"uniform\"\nradiance = [1.0, 1.0, 1.0]",
            "kind = \"uniform\"",
            "radiance",
        ),
        (
            "[environment]\nkind = \"uniform\"\nradiance = [1.0, 1.0, 1.0]",
            "",
            "no light",
        ),
        (
            "kind = \"lambert\"\nalbedo = [1.0, 1.0, 1.0]",
            "kind = \"measured\"\nformat = \"rgl\"\npath = \"missing.bsdf\"",
            "missing.bsdf",
        ),
        (
            "kind = \"lambert\"\nalbedo = [1.0, 1.0, 1.0]",
            "kind = \"measured\"\nformat = \"png\"\npath = \"Cargo.toml\"",
            "unknown format",
        ),
        (
            "shape = \"sphere\"\ncenter = [0.0, 0.0, 0.0]\nradius = 1.0",
            "shape = \"mesh\"\npath = \"missing.obj\"",
            "missing.obj",
        ),
    ] {
        let text = good.replace(from, to);
        assert_ne!(text, good, "{from}");
        let err = prepared(&text, &options(SamplerKind::Cosine, false))
            .unwrap_err()
            .to_string();
        assert!(err.contains(what), "{to}: {err}");
    }
    let cycle = good.replace(
        "kind = \"lambert\"\nalbedo = [1.0, 1.0, 1.0]",
        "kind = \"fitted\"\nsource = \"n\"\n[materials.n]\nkind = \"fitted\"\nsource = \"m\"",
    );
    let err = prepared(&cycle, &options(SamplerKind::Cosine, false))
        .unwrap_err()
        .to_string();
    assert!(err.contains("cycle"), "{err}");
    let up = good.replace("fov_deg = 45.0", "fov_deg = 45.0\nup = [0.0, 0.0, -2.0]");
    let err = prepared(&up, &options(SamplerKind::Cosine, false))
        .unwrap_err()
        .to_string();
    assert!(err.contains("parallel"), "{err}");
    let swap = RenderOptions {
        swaps: vec![("m".into(), "other".into())],
        ..options(SamplerKind::Cosine, false)
    };
    assert!(prepared(&good, &swap)
        .unwrap_err()
        .to_string()
        .contains("other"));
}

#[test]
fn an_exr_environment_map_lights_the_furnace() {
    // A latitude-longitude OpenEXR image of radiance 1 everywhere except a
    // bright patch: the furnace (no patch) renders to 1 with MIS on and the
    // map importance-sampled; the patch brightens only pixels facing it.
    let dir = temp_dir("envmap");
    let (w, h) = (32, 16);
    let flat = render_cpu::Image::new(w, h, vec![[1.0; 3]; w * h]);
    flat.write_exr(&dir.join("flat.exr")).unwrap();
    let text = sphere_scene(
        "kind = \"lambert\"\nalbedo = [1.0, 1.0, 1.0]",
        "[environment]\nkind = \"image\"\npath = \"flat.exr\"\nscale = 1.0",
        "kind = \"direct\"\nspp = 16",
    );
    for sampler in SAMPLERS {
        let desc = SceneDescription::parse(&text, "env").unwrap();
        let (scene, log) = prepare(desc, &dir, "env", &options(sampler, true)).unwrap();
        assert_eq!(log.find(Action::Prepared, "environment").len(), 1, "{log}");
        let err = check_against(&scene, 5.0, |_| [1.0; 3]);
        eprintln!("EXR furnace {sampler:?}: mean error {err:.2e}");
    }
    let missing = sphere_scene(
        "kind = \"lambert\"\nalbedo = [1.0, 1.0, 1.0]",
        "[environment]\nkind = \"image\"\npath = \"none.exr\"",
        "kind = \"direct\"",
    );
    let desc = SceneDescription::parse(&missing, "env").unwrap();
    let err = prepare(desc, &dir, "env", &options(SamplerKind::Cosine, true))
        .unwrap_err()
        .to_string();
    assert!(err.contains("none.exr"), "{err}");
    let mut pixels = vec![[1.0f32; 3]; w * h];
    pixels[5] = [1.0, -0.5, 1.0];
    render_cpu::Image::new(w, h, pixels)
        .write_exr(&dir.join("negative.exr"))
        .unwrap();
    let desc =
        SceneDescription::parse(&missing.replace("none.exr", "negative.exr"), "env").unwrap();
    let err = prepare(desc, &dir, "env", &options(SamplerKind::Cosine, true))
        .unwrap_err()
        .to_string();
    assert!(
        err.contains("negative radiance") && err.contains("(5, 0)"),
        "{err}"
    );
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn many_lights_evaluate_a_fit_as_one_light_at_a_time_does() {
    // The shading loop hands a fit all its lights at once (the batched f32
    // path); the values are those of one evaluation per light.
    use brdf::Brdf;
    let truth = brdf::CookTorranceGgx {
        kd: [0.1, 0.2, 0.3],
        f0: [0.04; 3],
        alpha: 0.25,
    };
    let settings = brdf::BrdfFitSettings::default()
        .with_reduction(brdf::Reduction::default().with_resolution(20, 20));
    let (fit, _) = brdf::fit_brdf(&truth, &settings).unwrap();
    let f = render_cpu::FitInDomain::new(fit);
    assert!(f.uses_f32(), "f32 differs by {}", f.f32_error());
    let wo = brdf::from_spherical(0.7, 0.3);
    // 130 directions: two full blocks and a short one; a few below the horizon.
    let wi: Vec<[f64; 3]> = (0..130)
        .map(|k| brdf::from_spherical(1.65 * (k as f64 + 0.5) / 130.0, 0.37 * k as f64))
        .collect();
    let mut out = vec![[0.0; 3]; wi.len()];
    f.eval_incident(&wi, wo, &mut out);
    for (w, got) in wi.iter().zip(&out) {
        let one = f.eval(*w, wo);
        for c in 0..3 {
            assert!(
                (got[c] - one[c]).abs() <= 1e-5 * one[c].abs() + 1e-7,
                "at {w:?}: batched {got:?}, one at a time {one:?}"
            );
        }
    }
}

#[test]
fn a_fit_whose_f32_form_loses_its_digits_is_evaluated_in_f64() {
    use brdf::Brdf;
    use rational_core::{Basis, BasisFamily, Domain, RationalFunction};
    // q = 1 - (1 - 1e-9) T1(x0) on a box whose x0 ends at the 70-degree cut:
    // at the cut q is 1e-9 in f64, and rounding in f32 (1 - 1e-9 is 1)
    // leaves only the error of the coordinates.
    let cut = (70.0_f64 / 90.0).sqrt();
    let domain = Domain::new(vec![0.0, 0.0], vec![cut, 1.4]).unwrap();
    let basis = Basis::new(BasisFamily::Chebyshev, domain, 3).unwrap();
    let t1 = (0..3).find(|&j| basis.multi_index(j) == [1, 0]).unwrap();
    let mut q = vec![0.0; 3];
    q[0] = 1.0;
    q[t1] = -(1.0 - 1e-9);
    let channel = RationalFunction::new(basis.clone(), vec![1e-9], q).unwrap();
    let fit = brdf::FittedBrdf {
        reduction: brdf::Reduction::default(),
        channels: vec![channel.clone(), channel.clone(), channel],
        mode: brdf::ColourMode::Rgb,
        scale: brdf::ValueScale::Linear,
        lobe: None,
        ceiling: None,
        shell: None,
        name: "nearly cancelling".into(),
    };
    fit.validate().unwrap();
    let f = render_cpu::FitInDomain::new(fit.clone());
    assert!(!f.uses_f32(), "f32 differs by {}", f.f32_error());
    // Both directions at the cut, mirror pair: theta_h at the box's end.
    let w = brdf::from_spherical(70f64.to_radians(), 0.0);
    let v = f.eval(w, w);
    assert!(v[0].is_finite() && (v[0] - fit.eval(w, w)[0]).abs() <= 1e-12 * v[0]);
    // The f32 form is nowhere near it there.
    let compact = f.compact().eval(w.map(|v| v as f32), w.map(|v| v as f32));
    let off = (f64::from(compact[0]) / v[0] - 1.0).abs();
    assert!(off.is_nan() || off > 0.5, "{compact:?} against {v:?}");
    let mut out = [[0.0; 3]];
    f.eval_incident(&[w], w, &mut out);
    assert!(
        (0..3).all(|c| (out[0][c] - v[c]).abs() <= 1e-12 * v[c]),
        "{out:?}"
    );
}
