//! Throughput of evaluating a fitted BRDF (the f32 compact path pair by
//! pair and in batches of 8 lanes, the f64 path pair by pair and in
//! batches; all cores) against looking
//! up the tabulated MERL grid, on the same one million direction pairs, same
//! run. Writes `brdf_eval.csv`.
//!
//! `cargo bench -p ratfit-bench --bench brdf_eval [-- --out DIR]`

use anyhow::Result;
use brdf::{
    compact::to_f32, fit_brdf, from_spherical, BatchedFit, Brdf, BrdfFitSettings, CompactBrdf,
    CookTorranceGgx, MerlBrdf, TabulateOptions,
};
use rayon::prelude::*;
use std::io::Write;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map_or_else(
            || std::path::PathBuf::from("target/bench"),
            std::path::PathBuf::from,
        );
    std::fs::create_dir_all(&out)?;
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
    let n = 1_000_000;
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
    let mut csv = std::fs::File::create(out.join("brdf_eval.csv"))?;
    writeln!(csv, "path,pairs,median_s,evals_per_s,coefficients,bytes")?;
    for (name, m) in &rows {
        let (coef, bytes) = if name.starts_with("MERL") {
            (0, brdf::merl::FILE_SIZE)
        } else {
            (fitted.coefficients(), fitted.byte_size_f32())
        };
        writeln!(csv, "{name},{n},{m:e},{:e},{coef},{bytes}", n as f64 / m)?;
    }
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
