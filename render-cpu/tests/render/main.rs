//! Furnace and analytic scenes with known answers, on every sampler, and
//! determinism; scene preparation (only what is needed, the fit cache,
//! errors) in `preparation.rs`.

mod preparation;

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
