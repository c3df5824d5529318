//! The renderer's BRDF evaluation path against an independent renderer
//! (Mitsuba 3, `data/rgl/reference`): for each reference direction pair a
//! 1 x 1 render of a tilted plane, seen along `wo` and lit by a directional
//! light along `wi` of irradiance 1, must equal `f(wi, wo) cos(theta_i)`.

use ratfit_tests::data_dir;
use render_cpu::{prepare, render, Camera, Frame, Light, RenderOptions, SceneDescription};
use std::path::{Path, PathBuf};

fn spherical(theta: f64, phi: f64) -> [f64; 3] {
    [
        theta.sin() * phi.cos(),
        theta.sin() * phi.sin(),
        theta.cos(),
    ]
}

#[test]
fn renders_of_rgl_materials_agree_with_the_reference_renderer() {
    let Some(data) = data_dir() else {
        eprintln!("SKIPPED: no data directory (set RATFIT_DATA)");
        return;
    };
    let normal = {
        let n = [0.3f64, 1.0, 0.2];
        let l = (n[0] * n[0] + n[1] * n[1] + n[2] * n[2]).sqrt();
        n.map(|v| v / l)
    };
    let mut files: Vec<PathBuf> = std::fs::read_dir(data.join("rgl"))
        .unwrap()
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "bsdf"))
        .collect();
    files.sort();
    assert!(!files.is_empty(), "no RGL files in {}", data.display());
    for file in files {
        let stem = file.file_stem().unwrap().to_string_lossy().to_string();
        let text = format!(
            r#"
[camera]
from = [0.0, 2.0, 0.0]
to = [0.0, 0.0, 0.0]
up = [1.0, 0.0, 0.0]
width = 1
height = 1
[integrator]
kind = "direct"
spp = 1
[materials.m]
kind = "measured"
format = "rgl"
path = "{}"
[[objects]]
shape = "plane"
point = [0.0, 0.0, 0.0]
normal = {normal:?}
material = "m"
[[lights]]
kind = "directional"
direction = [0.0, 1.0, 0.0]
irradiance = [1.0, 1.0, 1.0]
"#,
            file.display()
        );
        let desc = SceneDescription::parse(&text, &stem).unwrap();
        let options = RenderOptions {
            no_cache: true,
            ..Default::default()
        };
        let (mut scene, _) = prepare(desc, Path::new("."), &stem, &options).unwrap();
        let frame = Frame::from_normal(normal);
        let csv = std::fs::read_to_string(data.join("rgl/reference").join(format!("{stem}.csv")))
            .unwrap();
        let rows: Vec<Vec<f64>> = csv
            .lines()
            .skip(1)
            .map(|l| l.split(',').map(|v| v.trim().parse().unwrap()).collect())
            .collect();
        let peak = rows
            .iter()
            .flat_map(|r| r[4..7].to_vec())
            .fold(0.0, f64::max);
        let mut errors = Vec::new();
        for r in &rows {
            if r[0] >= 80f64.to_radians() || r[2] >= 80f64.to_radians() {
                continue;
            }
            let (wi, wo) = (
                frame.to_world(spherical(r[0], r[1])),
                frame.to_world(spherical(r[2], r[3])),
            );
            let from = wo.map(|v| 2.0 * v);
            let up = if wo[0].abs() < 0.9 {
                [1.0, 0.0, 0.0]
            } else {
                [0.0, 0.0, 1.0]
            };
            scene.camera = Camera::new(from, [0.0; 3], up, 1.0, 1, 1);
            scene.lights = vec![Light::Directional {
                direction: wi,
                irradiance: [1.0; 3],
            }];
            let p = render(&scene, &|_, _| {}).image.at(0, 0);
            for c in 0..3 {
                let want = r[4 + c];
                if want > 1e-3 * peak {
                    let got = f64::from(p[c]) / r[0].cos();
                    errors.push((got - want).abs() / want);
                }
            }
        }
        errors.sort_by(f64::total_cmp);
        let median = errors[errors.len() / 2];
        let max = errors[errors.len() - 1];
        eprintln!(
            "{stem}: {} values, relative error median {median:.2e}, max {max:.2e}",
            errors.len()
        );
        assert!(errors.len() > 100, "{stem}: {} values", errors.len());
        assert!(
            median < 1e-5 && max < 2e-4,
            "{stem}: median {median:.2e}, max {max:.2e}"
        );
    }
}
