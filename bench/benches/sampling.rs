//! Importance sampling of the real RGL materials: for each, fit the rational
//! inverse CDFs (default settings), then estimate the directional albedo
//! with the cosine, tabulated and rational samplers at equal sample count
//! and seed. Writes `sampling.csv` (variance per channel, time per sample,
//! bytes, fit time) and `sampling.svg` (relative variance against time per
//! sample, log axes, one colour per sampler), and prints per material the
//! variance ratios rational / tabulated and cosine / rational.
//!
//! `cargo bench -p ratfit-bench --bench sampling -- [--quick] [--out DIR]`
//! (a relative DIR is taken from `cli/`, where cargo runs benchmarks).

use anyhow::{Context, Result};
use brdf::{Brdf, RglBrdf};
use cdf::{
    compare_samplers, fit_table_to_variance, relative_variance, CdfFitSettings, CdfTable,
    CosineSampler, RationalSampler, Sampler, TableSettings, TabulatedSampler,
};
use std::fmt::Write as _;
use std::path::PathBuf;

/// The estimates' seed: not the fitter's (2012), so that the tolerance
/// chosen on its estimates is judged on other samples.
const SEED: u64 = 1;

const SAMPLERS: [(&str, &str); 3] = [
    ("cosine", "#d62728"),
    ("tabulated", "#1f77b4"),
    ("rational", "#2ca02c"),
];

fn svg(points: &[(String, f64, f64)]) -> String {
    let (w, h, m) = (720.0, 480.0, 70.0);
    let lx: Vec<f64> = points.iter().map(|p| p.1.log10()).collect();
    let ly: Vec<f64> = points.iter().map(|p| p.2.log10()).collect();
    let (x0, x1) = (
        lx.iter().cloned().fold(f64::INFINITY, f64::min).floor(),
        lx.iter().cloned().fold(f64::NEG_INFINITY, f64::max).ceil(),
    );
    let (y0, y1) = (
        ly.iter().cloned().fold(f64::INFINITY, f64::min).floor(),
        ly.iter().cloned().fold(f64::NEG_INFINITY, f64::max).ceil(),
    );
    let (x1, y1) = (x1.max(x0 + 1.0), y1.max(y0 + 1.0));
    let px = |v: f64| m + (v - x0) / (x1 - x0) * (w - 2.0 * m);
    let py = |v: f64| h - m - (v - y0) / (y1 - y0) * (h - 2.0 * m);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n"
    );
    let _ = writeln!(
        s,
        "<rect x=\"{m}\" y=\"{m}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>",
        w - 2.0 * m,
        h - 2.0 * m
    );
    for e in (x0 as i32)..=(x1 as i32) {
        let x = px(e as f64);
        let _ = writeln!(s, "<line x1=\"{x}\" y1=\"{}\" x2=\"{x}\" y2=\"{m}\" stroke=\"#ddd\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">1e{e}</text>", h - m, h - m + 16.0);
    }
    for e in (y0 as i32)..=(y1 as i32) {
        let y = py(e as f64);
        let _ = writeln!(s, "<line x1=\"{m}\" y1=\"{y}\" x2=\"{}\" y2=\"{y}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">1e{e}</text>", w - m, m - 6.0, y + 4.0);
    }
    let _ = writeln!(s, "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">time per sample (ns, sampling + BRDF evaluation)</text>", w / 2.0, h - 20.0);
    let _ = writeln!(s, "<text x=\"18\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 18 {})\">variance / albedo^2 (one sample, mean over RGB)</text>", h / 2.0, h / 2.0);
    for (i, (name, colour)) in SAMPLERS.iter().enumerate() {
        for (p, (x, y)) in points.iter().zip(lx.iter().zip(&ly)) {
            if p.0 == *name {
                let _ = writeln!(s, "<circle cx=\"{:.1}\" cy=\"{:.1}\" r=\"3.5\" fill=\"{colour}\" fill-opacity=\"0.7\"/>", px(*x), py(*y));
            }
        }
        let ly = m + 18.0 * (i as f64 + 1.0);
        let _ = writeln!(s, "<circle cx=\"{}\" cy=\"{ly}\" r=\"4\" fill=\"{colour}\"/><text x=\"{}\" y=\"{}\">{name}</text>", w - m - 90.0, w - m - 80.0, ly + 4.0);
    }
    s.push_str("</svg>\n");
    s
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map_or_else(|| PathBuf::from("target/bench"), PathBuf::from);
    std::fs::create_dir_all(&out)?;
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
    let mut csv = String::from("material,view_deg,sampler,bytes,samples,ns_per_sample,var_r,var_g,var_b,relative_variance,quad_g,mean_g,fit_seconds,coefficients\n");
    let mut points = Vec::new();
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
            let k = SAMPLERS.iter().position(|s| s.0 == r.sampler).unwrap_or(0);
            sums[k] += rel.ln();
            points.push((r.sampler.clone(), r.estimate.ns_per_sample, rel));
            let e = &r.estimate;
            let _ = writeln!(
                csv,
                "{},{},{},{},{},{:.1},{:e},{:e},{:e},{:e},{:e},{:e},{:.3},{}",
                material.name(),
                r.view_deg,
                r.sampler,
                r.bytes,
                e.samples,
                e.ns_per_sample,
                e.variance[0],
                e.variance[1],
                e.variance[2],
                rel,
                r.reference.value[1],
                e.mean[1],
                fit_seconds,
                coeffs
            );
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
    std::fs::write(out.join("sampling.csv"), csv)?;
    std::fs::write(out.join("sampling.svg"), svg(&points))?;
    println!(
        "{samples} samples per estimate at views {views:?} degrees; ratios are geometric means over the views of the relative variance; wrote {}/sampling.csv and sampling.svg",
        out.display()
    );
    Ok(())
}
