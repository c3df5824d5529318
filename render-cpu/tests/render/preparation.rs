//! Scene preparation: only what the scene uses is prepared, fits are
//! cached, and bad scenes give named errors.

use super::{options, prepared, sphere_scene, temp_dir};
use render_cpu::{prepare, Action, RenderOptions, SamplerKind, SceneDescription};
use std::path::Path;

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
