//! Importance-sample a material with fitted rational inverse CDFs: tabulate
//! its distributions, fit the two inverse CDFs, then estimate the
//! directional albedo at a few views with the rational sampler, the
//! tabulated one and cosine sampling, next to quadrature, with each
//! estimator's variance, time per sample and bytes:
//!
//! ```sh
//! cargo run --release -p cdf --example sample_with_cdf -- FILE.bsdf
//! ```
//!
//! Without a file it samples a Blinn-Phong material.

use brdf::{from_spherical, BlinnPhong, Brdf, RglBrdf};
use cdf::{
    albedo_quadrature, estimate_albedo, fit_table, CdfFitSettings, CdfTable, CosineSampler,
    RationalSampler, Sampler, TableSettings, TabulatedSampler,
};
use std::error::Error;

/// The tabulated and rational samplers of `material`.
fn samplers(
    material: &dyn Brdf,
    table_settings: TableSettings,
    fit_settings: &CdfFitSettings,
) -> Result<(TabulatedSampler, RationalSampler), Box<dyn Error>> {
    let table = CdfTable::new(material, table_settings)?;
    let (fitted, report) = fit_table(&table, fit_settings)?;
    println!("{report}");
    Ok((TabulatedSampler::new(table), RationalSampler::new(fitted)))
}

fn main() -> Result<(), Box<dyn Error>> {
    let material: Box<dyn Brdf> = match std::env::args().nth(1) {
        Some(path) => Box::new(RglBrdf::read(std::path::Path::new(&path))?),
        None => Box::new(BlinnPhong {
            kd: [0.3; 3],
            ks: [0.2; 3],
            exponent: 10.0,
        }),
    };
    let (tabulated, rational) = samplers(
        material.as_ref(),
        TableSettings::default(),
        &CdfFitSettings::default(),
    )?;
    let all: [&dyn Sampler; 3] = [&CosineSampler, &tabulated, &rational];
    for view_deg in [0.0_f64, 30.0, 60.0] {
        let wo = from_spherical(view_deg.to_radians(), 0.0);
        let truth = albedo_quadrature(material.as_ref(), wo, 64);
        println!(
            "view {view_deg} degrees: quadrature (green) {:.5}",
            truth.value[1]
        );
        for s in all {
            let e = estimate_albedo(material.as_ref(), s, wo, 100_000, 7);
            println!(
                "  {:<10} {:.5} +- {:.5}, variance {:.3e}, {:.0} ns per sample, {} bytes",
                s.name(),
                e.mean[1],
                e.std_error[1],
                e.variance[1],
                e.ns_per_sample,
                s.byte_size()
            );
        }
    }
    Ok(())
}

#[test]
fn the_rational_estimate_agrees_with_quadrature() {
    let material = BlinnPhong {
        kd: [0.3; 3],
        ks: [0.2; 3],
        exponent: 10.0,
    };
    let table = TableSettings::default()
        .with_views(6)
        .and_then(|t| t.with_cells(24, 24))
        .unwrap();
    let fit = CdfFitSettings::default().with_samples(12, 8, 6, 1).unwrap();
    let (_, rational) = samplers(&material, table, &fit).unwrap();
    let wo = from_spherical(0.5, 0.0);
    let e = estimate_albedo(&material, &rational, wo, 50_000, 1);
    let truth = albedo_quadrature(&material, wo, 32);
    for c in 0..3 {
        assert!(
            (e.mean[c] - truth.value[c]).abs() < 5.0 * e.std_error[c],
            "{e:?}"
        );
    }
}
