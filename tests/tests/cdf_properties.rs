//! Properties of the rational inverse CDFs over random materials (proptest,
//! seeded): the boundary values hold exactly, the maps are symmetric in the
//! two elevations bit for bit, monotone on a grid never used as a constraint,
//! and the pdf-free estimator is unbiased (within 4 standard errors of
//! quadrature).

use brdf::{from_spherical, BlinnPhong, Brdf, CookTorranceGgx};
use cdf::{
    albedo_quadrature, estimate_albedo, fit_table, CdfFitSettings, CdfTable, RationalCdf,
    RationalSampler, TableSettings,
};
use proptest::prelude::*;
use proptest::test_runner::RngSeed;
use std::f64::consts::{FRAC_PI_2, PI};

fn config() -> ProptestConfig {
    ProptestConfig {
        cases: 12,
        rng_seed: RngSeed::Fixed(0xCDF_2012),
        ..ProptestConfig::default()
    }
}

fn fitted(material: &dyn Brdf) -> RationalCdf {
    let table = CdfTable::new(
        material,
        TableSettings::default()
            .with_views(6)
            .unwrap()
            .with_cells(24, 24)
            .unwrap(),
    )
    .unwrap();
    let settings = CdfFitSettings::default().with_samples(12, 8, 8, 1).unwrap();
    fit_table(&table, &settings).unwrap().0
}

fn midpoints(n: usize, a: f64, b: f64) -> impl Iterator<Item = f64> {
    (0..n).map(move |k| a + (b - a) * (k as f64 + 0.5) / n as f64)
}

fn check(material: &dyn Brdf, view: f64) -> Result<(), TestCaseError> {
    let cdf = fitted(material);
    for tv in midpoints(9, 0.0, cdf.max_view) {
        prop_assert_eq!(cdf.theta.eval(&[tv, 0.0]).to_bits(), 0f64.to_bits());
        prop_assert_eq!(cdf.theta.eval(&[tv, 1.0]).to_bits(), FRAC_PI_2.to_bits());
        for tl in midpoints(9, 0.0, FRAC_PI_2) {
            prop_assert_eq!(cdf.phi.eval(&[tv, tl, 1.0]).to_bits(), PI.to_bits());
            prop_assert_eq!(cdf.phi.eval(&[tv, tl, 0.0]).to_bits(), 0f64.to_bits());
            for tau in midpoints(5, 0.0, 1.0) {
                let (a, b) = (cdf.phi.eval(&[tv, tl, tau]), cdf.phi.eval(&[tl, tv, tau]));
                prop_assert_eq!(a.to_bits(), b.to_bits());
            }
        }
        for mu in midpoints(48, 0.0, 1.0) {
            let d = cdf.theta.eval_with_derivative(&[tv, mu]).1;
            prop_assert!(d > 0.0, "d theta / d mu = {} at ({}, {})", d, tv, mu);
        }
        for tl in midpoints(32, 0.0, FRAC_PI_2) {
            for tau in midpoints(32, 0.0, 1.0) {
                let d = cdf.phi.eval_with_derivative(&[tv, tl, tau]).1;
                prop_assert!(
                    d > 0.0,
                    "d phi / d tau = {} at ({}, {}, {})",
                    d,
                    tv,
                    tl,
                    tau
                );
            }
        }
    }
    let wo = from_spherical(view, 0.0);
    let truth = albedo_quadrature(material, wo, 48);
    let e = estimate_albedo(material, &RationalSampler::new(cdf), wo, 200_000, 3);
    for c in 0..3 {
        let sigma = (e.std_error[c].powi(2) + truth.error[c].powi(2)).sqrt();
        let z = (e.mean[c] - truth.value[c]) / sigma;
        prop_assert!(z.abs() < 4.0, "channel {}: z = {}", c, z);
    }
    Ok(())
}

proptest! {
    #![proptest_config(config())]

    #[test]
    fn blinn_phong_inverse_cdfs_are_correct_by_construction(
        kd in 0.02f64..0.5, ks in 0.05f64..0.5, exponent in 1.0f64..80.0, view in 0.0f64..1.3,
    ) {
        check(&BlinnPhong { kd: [kd, 0.8 * kd, 0.6 * kd], ks: [ks; 3], exponent }, view)?;
    }

    #[test]
    fn ggx_inverse_cdfs_are_correct_by_construction(
        kd in 0.0f64..0.5, f0 in 0.04f64..1.0, alpha in 0.15f64..0.9, view in 0.0f64..1.3,
    ) {
        check(&CookTorranceGgx { kd: [kd; 3], f0: [f0, 0.9 * f0, 0.7 * f0], alpha }, view)?;
    }
}
