//! Throughput of evaluating a fitted BRDF (the f32 compact path pair by
//! pair and in batches of 8 lanes, the f64 path pair by pair and in
//! batches; all cores) against looking
//! up the tabulated MERL grid, on the same one million direction pairs (a
//! hundred thousand with `--quick`), same run. Writes `brdf_eval.csv` and
//! `brdf_eval.svg` / `.png` (evaluations per second against bytes, log
//! axes, one colour per path).
//!
//! `cargo bench -p ratfit-bench --bench brdf_eval -- [--quick] [--out DIR]`

use anyhow::{Context, Result};
use brdf::{
    compact::to_f32, fit_brdf, from_spherical, BatchedFit, Brdf, BrdfFitSettings, CompactBrdf,
    CookTorranceGgx, MerlBrdf, TabulateOptions,
};
use ratfit_bench::bench_target::TargetArgs;
use ratfit_bench::chart::{Figure, Panel};
use rayon::prelude::*;
use serde::Serialize;
use std::time::Instant;

/// One row of `brdf_eval.csv`.
#[derive(Serialize)]
struct Row<'a> {
    path: &'a str,
    pairs: usize,
    median_s: f64,
    evals_per_s: f64,
    coefficients: usize,
    bytes: usize,
}

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<()> {
    let TargetArgs { quick, out, .. } = TargetArgs::from_env()?;
    let truth = CookTorranceGgx {
        kd: [0.03, 0.08, 0.25],
        f0: [0.04; 3],
        alpha: 0.12,
    };
    let table = MerlBrdf::tabulate(
        &truth,
        TabulateOptions {
            noise: 0.01,
            seed: 2012,
            missing_above_theta_d_deg: Some(85.0),
        },
    );
    let (fitted, report) = fit_brdf(&table, &BrdfFitSettings::default().with_baselines(false))?;
    let compact = CompactBrdf::from_fitted(&fitted);
    let n = if quick { 100_000 } else { 1_000_000 };
    let pairs: Vec<_> = (0..n)
        .map(|k| {
            let u = |s: f64| ((k as f64 + 0.5) * s).fract();
            (
                from_spherical(1.5 * u(0.618_034), std::f64::consts::TAU * u(0.754_878)),
                from_spherical(1.5 * u(0.569_840), std::f64::consts::TAU * u(0.851_249)),
            )
        })
        .collect();
    let wi32: Vec<[f32; 3]> = pairs.iter().map(|p| to_f32(p.0)).collect();
    let wo32: Vec<[f32; 3]> = pairs.iter().map(|p| to_f32(p.1)).collect();
    let reps = 5;
    let mut rows = Vec::new();
    let mut time = |name: &str, f: &dyn Fn() -> f64| {
        let _ = f();
        let t: Vec<f64> = (0..reps)
            .map(|_| {
                let s = Instant::now();
                std::hint::black_box(f());
                s.elapsed().as_secs_f64()
            })
            .collect();
        let m = median(t);
        println!(
            "{name:<34} {:>8.1} M evaluations/s (median of {reps}, {n} pairs, {} threads)",
            n as f64 / m / 1e6,
            rayon::current_num_threads()
        );
        rows.push((name.to_string(), m));
    };
    time("rational fit, f32 compact", &|| {
        compact
            .eval_many(&wi32, &wo32)
            .iter()
            .map(|v| v[0] as f64)
            .sum()
    });
    time("rational fit, f32 batched (8 lanes)", &|| {
        compact
            .eval_many_batched(&wi32, &wo32)
            .iter()
            .map(|v| v[0] as f64)
            .sum()
    });
    time("rational fit, f64", &|| {
        pairs.par_iter().map(|&(a, b)| fitted.eval(a, b)[0]).sum()
    });
    let batched64 = BatchedFit::new(fitted.clone());
    let wi64: Vec<[f64; 3]> = pairs.iter().map(|p| p.0).collect();
    let wo64: Vec<[f64; 3]> = pairs.iter().map(|p| p.1).collect();
    time("rational fit, f64 batched (8 lanes)", &|| {
        let mut out = vec![[0.0; 3]; n];
        out.par_chunks_mut(1024)
            .zip(wi64.par_chunks(1024).zip(wo64.par_chunks(1024)))
            .for_each(|(o, (a, b))| batched64.eval_batch(a, b, o));
        out.iter().map(|v| v[0]).sum()
    });
    time("MERL table lookup, f64", &|| {
        pairs.par_iter().map(|&(a, b)| table.eval(a, b)[0]).sum()
    });
    let csv_path = out.join("brdf_eval.csv");
    let mut csv = csv::Writer::from_path(&csv_path)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let mut panel = Panel {
        title: format!("{n} pairs, {} threads", rayon::current_num_threads()),
        ..Panel::default()
    };
    for (k, (name, m)) in rows.iter().enumerate() {
        let (coefficients, bytes) = if name.starts_with("MERL") {
            (0, brdf::merl::FILE_SIZE)
        } else {
            (fitted.coefficients(), fitted.byte_size_f32())
        };
        csv.serialize(Row {
            path: name,
            pairs: n,
            median_s: *m,
            evals_per_s: n as f64 / m,
            coefficients,
            bytes,
        })?;
        panel.points.push((k, bytes as f64, n as f64 / m));
    }
    csv.flush()?;
    let figure = Figure {
        title: "Fitted BRDF against table lookup".into(),
        x_label: "bytes of the representation".into(),
        y_label: "evaluations per second (median)".into(),
        // The paths in the order timed above.
        legend: ["f32", "f32 x8", "f64", "f64 x8", "MERL lookup"]
            .map(String::from)
            .to_vec(),
        panels: vec![panel],
        columns: 1,
    };
    figure.write(&out, "brdf_eval")?;
    println!(
        "fit: {} coefficients, {} bytes; max rel error per channel {:?}",
        fitted.coefficients(),
        fitted.byte_size_f32(),
        report
            .channels
            .iter()
            .map(|c| c.max_rel)
            .collect::<Vec<_>>()
    );
    let (fit32, batched, fit64, batched64, lookup) =
        (rows[0].1, rows[1].1, rows[2].1, rows[3].1, rows[4].1);
    println!(
        "ratio: f32 rational fit is {:.2}x the speed of the MERL lookup pair by pair, {:.2}x batched",
        lookup / fit32,
        lookup / batched
    );
    println!(
        "ratio: the f64 fit batched is {:.2}x the speed of the f64 fit pair by pair",
        fit64 / batched64
    );
    Ok(())
}
