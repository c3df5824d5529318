//! A scene whose fitted material asks for a render error (`target_de`)
//! prepares and renders on a glossy measured material.

use ratfit_tests::data_dir;
use render_cpu::{prepare, render, RenderOptions, SceneDescription};
use std::path::Path;

/// A sphere of material `fit` under one directional light, `size` pixels
/// square, with the `[materials.*]` tables of `materials`.
fn sphere_scene(size: usize, materials: &str) -> SceneDescription {
    let text = format!(
        r#"
        [camera]
        from = [0.0, 0.0, 4.0]
        to = [0.0, 0.0, 0.0]
        fov_deg = 32.0
        width = {size}
        height = {size}
        [integrator]
        kind = "direct"
        spp = 1
        {materials}
        [[objects]]
        shape = "sphere"
        center = [0.0, 0.0, 0.0]
        radius = 1.0
        material = "fit"
        [[lights]]
        kind = "directional"
        direction = [0.5, 0.6, 0.8]
        irradiance = [5.0, 5.0, 5.0]
        "#
    );
    SceneDescription::parse(&text, "target").unwrap()
}

#[test]
fn a_target_de_scene_renders_a_glossy_rgl_file() {
    let Some(data) = data_dir() else {
        eprintln!("SKIPPED a_target_de_scene_renders_a_glossy_rgl_file: no data directory (set RATFIT_DATA)");
        return;
    };
    let path = data.join("rgl/vch_golden_yellow_rgb.bsdf");
    let scene = sphere_scene(
        32,
        &format!(
            r#"
        [materials.table]
        kind = "measured"
        format = "rgl"
        path = "{}"
        [materials.fit]
        kind = "fitted"
        source = "table"
        max_coeffs = 40
        target_de = 4.0
        max_bytes = 1024
        "#,
            path.display()
        ),
    );
    let options = RenderOptions {
        no_cache: true,
        ..Default::default()
    };
    let (scene, log) = prepare(scene, Path::new("."), "target", &options).unwrap();
    let line = log
        .entries
        .iter()
        .map(|e| e.why.clone())
        .find(|d| d.contains("target CIEDE2000"))
        .expect("the log states the target and what was reached");
    eprintln!("{line}");
    assert!(line.contains("of at most 1024"), "{line}");
    let out = render(&scene, &|_, _| {});
    let lit = out.image.pixels.iter().filter(|p| p[1] > 0.0).count();
    assert!(lit > 100, "{lit} lit pixels");
    assert!(out
        .image
        .pixels
        .iter()
        .all(|p| p.iter().all(|v| v.is_finite())));
}

/// `max_bytes` bounds a `target_de` fit: without one it is refused before
/// anything is fitted.
#[test]
fn a_byte_budget_without_a_target_is_refused() {
    let scene = sphere_scene(
        8,
        r#"
        [materials.plastic]
        kind = "blinn-phong"
        kd = [0.2, 0.3, 0.4]
        ks = [0.3, 0.3, 0.3]
        exponent = 20.0
        [materials.fit]
        kind = "fitted"
        source = "plastic"
        max_bytes = 512
        "#,
    );
    let options = RenderOptions {
        no_cache: true,
        ..Default::default()
    };
    let Err(err) = prepare(scene, Path::new("."), "budget", &options) else {
        panic!("max_bytes without target_de is refused");
    };
    let text = err.to_string();
    assert!(
        text.contains("max_bytes") && text.contains("target_de") && text.contains("fit"),
        "{text}"
    );
}
