//! Fit a measured material (MERL `.binary` or RGL `.bsdf`) with three
//! rational functions under perceptual intervals over the whole hemisphere,
//! print the report, and compare the fit with the table at a few direction
//! pairs:
//!
//! ```sh
//! cargo run --release -p brdf --example fit_material -- FILE.bsdf
//! ```
//!
//! Without a file it fits a Blinn-Phong material tabulated on the MERL grid
//! with 2% noise (a stand-in for a measurement).

use brdf::{
    fit_brdf, from_spherical, BlinnPhong, Brdf, BrdfFitSettings, ColourMode, CompactBrdf,
    FittedBrdf, MerlBrdf, PerceptualBounds, Reduction, ReductionKind, RglBrdf, TabulateOptions,
};
use rational_core::{FitSettings, Search};
use std::error::Error;
use std::path::Path;

fn load(path: Option<&str>) -> Result<Box<dyn Brdf>, Box<dyn Error>> {
    Ok(match path {
        Some(p) if p.ends_with(".bsdf") => Box::new(RglBrdf::read(Path::new(p))?),
        Some(p) => Box::new(MerlBrdf::read(Path::new(p))?),
        None => {
            let truth = BlinnPhong {
                kd: [0.3, 0.2, 0.1],
                ks: [0.3, 0.3, 0.3],
                exponent: 30.0,
            };
            let noisy = TabulateOptions {
                noise: 0.02,
                seed: 1,
                missing_above_theta_d_deg: None,
            };
            Box::new(MerlBrdf::tabulate(&truth, noisy))
        }
    })
}

/// The 3-D `(theta_h, theta_d, phi_d)` grid at `resolution` bins per angle,
/// perceptual intervals at `rel_tol`, luminance and two chroma ratios.
fn fit_material(
    table: &dyn Brdf,
    resolution: usize,
    rel_tol: f64,
) -> Result<(FittedBrdf, brdf::BrdfFitReport), Box<dyn Error>> {
    let reduction = Reduction::default()
        .with_kind(ReductionKind::Full3d)
        .with_resolution(resolution, resolution)
        .with_phi_resolution(resolution)
        .whole_hemisphere();
    let engine = FitSettings::default()
        .with_coeff_range(2, 80)?
        .with_search(Search::Staircase)
        .with_widening(2.0, 4)?;
    let settings = BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_design(PerceptualBounds::default().with_rel_tol(rel_tol)?)
        .with_colour_mode(ColourMode::LuminanceChroma)
        .with_fit_settings(engine);
    Ok(fit_brdf(table, &settings)?)
}

fn main() -> Result<(), Box<dyn Error>> {
    let path = std::env::args().nth(1);
    let table = load(path.as_deref())?;
    let (fitted, report) = fit_material(table.as_ref(), 16, 0.1)?;
    println!("{report}");
    let compact = CompactBrdf::from_fitted(&fitted);
    println!(
        "{} bytes of coefficients; the binary format takes {} bytes",
        fitted.byte_size_f32(),
        compact.to_bytes().len()
    );
    for (theta_i, theta_o, phi_o) in [(0.0, 0.0, 0.0), (0.5, 0.5, 3.0), (1.0, 0.3, 2.0)] {
        let (wi, wo) = (from_spherical(theta_i, 0.0), from_spherical(theta_o, phi_o));
        let (t, f) = (table.eval(wi, wo), fitted.eval(wi, wo));
        println!("theta_i {theta_i}, theta_o {theta_o}, phi_o {phi_o}: table {t:.4?}, fit {f:.4?}");
    }
    Ok(())
}

#[test]
fn a_noisy_table_fits_within_its_intervals() {
    let table = load(None).unwrap();
    let (fitted, report) = fit_material(table.as_ref(), 10, 0.1).unwrap();
    assert!(report.channels.iter().all(|c| c.verified));
    let (wi, wo) = (
        from_spherical(0.3, 0.0),
        from_spherical(0.3, std::f64::consts::PI),
    );
    let (t, f) = (table.eval(wi, wo), fitted.eval(wi, wo));
    // Within the design's 10% plus the table's 2% noise, near the mirror.
    for c in 0..3 {
        assert!((f[c] / t[c] - 1.0).abs() < 0.25, "{t:?} {f:?}");
    }
}
