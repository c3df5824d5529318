//! `ratfit demo`: the main job on built-in data with a known truth.

use anyhow::Result;
use brdf::{fit_brdf, BrdfFitSettings, CookTorranceGgx, MerlBrdf, TabulateOptions};
use rational_core::{fit, FitSettings, IntervalData};
use std::f64::consts::PI;
use std::path::Path;

/// CIEDE2000 drawn white in the demo's difference images.
const DIFFERENCE_FULL_SCALE: f64 = 5.0;

/// Blinn-Phong-like lobe over the half angle (radians), exponent `n`.
fn lobe(theta_h: f64, n: f64) -> f64 {
    0.05 / PI + (n + 8.0) / (8.0 * PI) * theta_h.cos().powf(n)
}

/// Schlick's Fresnel factor over the difference angle.
fn fresnel(theta_d: f64) -> f64 {
    0.04 + 0.96 * (1.0 - theta_d.cos()).powi(5)
}

/// The engine alone on steep 1-D and 2-D functions.
pub fn run_engine() -> Result<()> {
    println!(
        "ratfit demo: rational fits of steep specular-like functions, every fit verified in f64\n"
    );

    let n = 2000;
    let x: Vec<f64> = (0..n)
        .map(|i| 0.5 * PI * i as f64 / (n - 1) as f64)
        .collect();
    let v: Vec<f64> = x.iter().map(|&t| lobe(t, 300.0)).collect();
    let data = IntervalData::from_values_relative(1, x, v, 0.05)?;
    let settings = FitSettings::default().with_coeff_range(2, 30)?;
    println!(
        "1-D: Blinn-Phong lobe, exponent 300, theta_h in [0, pi/2], {n} samples, intervals +-5%"
    );
    let report = fit(&data, &settings)?;
    println!("{report}\n");

    let (nh, nd) = (90, 70);
    let mut pts = Vec::with_capacity(2 * nh * nd);
    let mut vals = Vec::with_capacity(nh * nd);
    for i in 0..nh {
        for j in 0..nd {
            // theta_h on the MERL sqrt warp, theta_d up to 78 degrees.
            let th = 0.5 * PI * (i as f64 / (nh - 1) as f64).powi(2);
            let td = 78f64.to_radians() * j as f64 / (nd - 1) as f64;
            pts.extend([th, td]);
            vals.push(0.05 / PI + (lobe(th, 120.0) - 0.05 / PI) * fresnel(td) / 0.04 * 0.25);
        }
    }
    let data2 = IntervalData::from_values_relative(2, pts, vals, 0.05)?;
    println!(
        "2-D: lobe(theta_h, exponent 120) x Schlick Fresnel(theta_d), {} samples, intervals +-5%",
        nh * nd
    );
    let report2 = fit(&data2, &FitSettings::default().with_coeff_range(2, 60)?)?;
    println!("{report2}");
    Ok(())
}

/// The main job on a built-in "measured" material.
pub fn run_brdf(out: &Path) -> Result<()> {
    let truth = CookTorranceGgx {
        kd: [0.03, 0.08, 0.25],
        f0: [0.04; 3],
        alpha: 0.12,
    };
    let options = TabulateOptions {
        noise: 0.01,
        seed: 2012,
        missing_above_theta_d_deg: Some(85.0),
    };
    println!(
        "ratfit demo: {} tabulated on the MERL grid (90 x 90 x 180 cells) with 1% noise, cells with theta_d > 85 deg missing\n",
        brdf::Brdf::name(&truth)
    );
    let measured = MerlBrdf::tabulate(&truth, options);
    let settings = BrdfFitSettings::default();
    let (fitted, report) = fit_brdf(&measured, &settings)?;
    println!("{report}");
    println!(
        "  representation: {} coefficients, {} bytes as f32 (the MERL table: {} bytes)",
        fitted.coefficients(),
        fitted.byte_size_f32(),
        brdf::merl::FILE_SIZE
    );
    // What a user judges: the fit's renders against the table's on the two
    // validation scenes of `ratfit bench fidelity`, side by side.
    let table: std::sync::Arc<dyn brdf::Brdf> = std::sync::Arc::new(measured);
    let validation = render_cpu::fidelity::ValidationSettings {
        size: 96,
        sky_spp: 32,
        ..Default::default()
    };
    let validator = render_cpu::fidelity::Validator::new(table, validation)?;
    let errors = validator.measure(std::sync::Arc::new(render_cpu::FitInDomain::new(fitted)))?;
    println!(
        "  render error against the table (mean CIEDE2000 over the sphere): lights {:.3}, sky {:.3} (the table against itself with another seed: {:.3}, {:.3})",
        errors.scenes[0].mean_de,
        errors.scenes[1].mean_de,
        validator.noise[0].mean_de,
        validator.noise[1].mean_de
    );
    std::fs::create_dir_all(out)?;
    for (k, scene) in render_cpu::fidelity::ValidationScene::ALL
        .iter()
        .enumerate()
    {
        let (w, h, rgb) = render_cpu::fidelity::side_by_side(
            &validator.references()[k],
            &errors.images[k],
            DIFFERENCE_FULL_SCALE,
        )?;
        let path = out.join(format!("demo-{}.png", scene.name()));
        render_cpu::write_png(&path, w, h, &rgb)?;
        println!(
            "  wrote {} (left: measured table; middle: rational fit; right: CIEDE2000, white at {DIFFERENCE_FULL_SCALE})",
            path.display()
        );
    }
    Ok(())
}
