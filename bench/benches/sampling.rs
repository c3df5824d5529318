//! Importance sampling of the real RGL materials: for each, fit the rational
//! inverse CDFs (default settings), then estimate the directional albedo
//! with the cosine, tabulated and rational samplers at equal sample count
//! and seed. Writes `sampling.csv` (variance per channel, time per sample,
//! bytes, fit time) and `sampling.svg` / `.png` (relative variance against
//! time per sample, log axes, one colour per sampler), and prints per
//! material the variance ratios rational / tabulated and cosine / rational.
//!
//! `cargo bench -p ratfit-bench --bench sampling -- [--quick] [--out DIR]`
//! (a relative DIR is taken from `bench/`, where cargo runs benchmarks).

use anyhow::{Context, Result};
use brdf::{Brdf, RglBrdf};
use cdf::{
    compare_samplers, fit_table_to_variance, relative_variance, CdfFitSettings, CdfTable,
    CosineSampler, RationalSampler, Sampler, TableSettings, TabulatedSampler,
};
use ratfit_bench::bench_target::TargetArgs;
use ratfit_bench::chart::{Figure, Panel};
use serde::Serialize;
use std::path::PathBuf;

/// The estimates' seed: not the fitter's (2012), so that the tolerance
/// chosen on its estimates is judged on other samples.
const SEED: u64 = 1;

const SAMPLERS: [&str; 3] = ["cosine", "tabulated", "rational"];

/// One row of `sampling.csv`.
#[derive(Serialize)]
struct Row<'a> {
    material: &'a str,
    view_deg: f64,
    sampler: &'a str,
    bytes: usize,
    samples: usize,
    ns_per_sample: f64,
    var_r: f64,
    var_g: f64,
    var_b: f64,
    relative_variance: f64,
    quad_g: f64,
    mean_g: f64,
    fit_seconds: f64,
    coefficients: usize,
}

fn main() -> Result<()> {
    let TargetArgs { quick, out, .. } = TargetArgs::from_env()?;
    let data = std::env::var_os("RATFIT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"))
        .join("rgl");
    let mut files: Vec<PathBuf> = std::fs::read_dir(&data)
        .with_context(|| format!("no RGL data at {} (set RATFIT_DATA)", data.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|e| e == "bsdf"))
        .collect();
    files.sort();
    if quick {
        files.truncate(2);
    }
    let samples = if quick { 50_000 } else { 400_000 };
    let views = [0.0, 30.0, 60.0, 75.0];
    let csv_path = out.join("sampling.csv");
    let mut csv = csv::Writer::from_path(&csv_path)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let mut panel = Panel {
        title: format!("{} RGL files, {} views", files.len(), views.len()),
        ..Panel::default()
    };
    println!(
        "{:<28} {:>6} {:>8} {:>10} {:>13} {:>12} {:>12}",
        "material", "bytes", "fit s", "coeffs", "tol theta/phi", "rat/tab var", "cos/rat var"
    );
    for path in &files {
        let material = RglBrdf::read(path)?;
        let table = CdfTable::new(&material, TableSettings::default())?;
        // As `ratfit cdf` by default: the tolerance chosen by the variance
        // it causes (at most 1.4x the table's by the fitter's own
        // estimates, whose seed is not the one below).
        let start = std::time::Instant::now();
        let fitted = fit_table_to_variance(
            &material,
            &table,
            &CdfFitSettings::default(),
            1.4,
            cdf::VARIANCE_HALVINGS,
            cdf::VARIANCE_SAMPLES,
        );
        let fit_seconds = start.elapsed().as_secs_f64();
        let (cdf, report) = match fitted {
            Ok((cdf, report, _steps)) => (cdf, report),
            Err(e) => {
                println!("{:<28} no fit: {e}", material.name());
                continue;
            }
        };
        let coeffs = cdf.theta.coefficients() + cdf.phi.coefficients();
        let tabulated = TabulatedSampler::new(table);
        let rational = RationalSampler::new(cdf);
        let samplers: [&dyn Sampler; 3] = [&CosineSampler, &tabulated, &rational];
        let rows = compare_samplers(&material as &dyn Brdf, &samplers, &views, samples, SEED);
        let mut sums = [0.0f64; 3];
        for r in &rows {
            let rel = relative_variance(r);
            let k = SAMPLERS.iter().position(|s| *s == r.sampler).unwrap_or(0);
            sums[k] += rel.ln();
            panel.points.push((k, r.estimate.ns_per_sample, rel));
            let e = &r.estimate;
            csv.serialize(Row {
                material: &material.name(),
                view_deg: r.view_deg,
                sampler: &r.sampler,
                bytes: r.bytes,
                samples: e.samples,
                ns_per_sample: e.ns_per_sample,
                var_r: e.variance[0],
                var_g: e.variance[1],
                var_b: e.variance[2],
                relative_variance: rel,
                quad_g: r.reference.value[1],
                mean_g: e.mean[1],
                fit_seconds,
                coefficients: coeffs,
            })?;
        }
        // Geometric means over the views.
        let n = views.len() as f64;
        println!(
            "{:<28} {:>6} {:>8.2} {:>10} {:>6.4}/{:<6.4} {:>12.2} {:>12.1}",
            material.name().trim_start_matches("RGL "),
            report.bytes,
            fit_seconds,
            coeffs,
            report.theta.cdf_tolerance,
            report.phi.cdf_tolerance,
            ((sums[2] - sums[1]) / n).exp(),
            ((sums[0] - sums[2]) / n).exp()
        );
    }
    csv.flush()?;
    let figure = Figure {
        title: "Importance sampling".into(),
        x_label: "ns per sample (sample + eval)".into(),
        y_label: "variance / albedo^2".into(),
        legend: SAMPLERS.iter().map(|s| s.to_string()).collect(),
        panels: vec![panel],
        columns: 1,
    };
    figure.write(&out, "sampling")?;
    println!(
        "{samples} samples per estimate at views {views:?} degrees; ratios are geometric means over the views of the relative variance; wrote {}/sampling.csv, sampling.svg and sampling.png",
        out.display()
    );
    Ok(())
}
