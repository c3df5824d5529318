//! Engine benchmark (medians of 5 runs after a warm-up; 3 runs when the
//! warm-up took over 0.2 s, 1 over 2 s): single P(n_p, n_q) fits of the 1-D Runge function and a
//! 2-D specular lobe (relative intervals of 1%) at 2,000 to 1,000,000
//! samples on every compiled backend, and the paper-like sweep of all 41
//! splits at 42 coefficients on about 7,000 2-D samples. Writes
//! `engine.csv` (error next to time for every run) to `--out`
//! (default `target/bench`).
//!
//! `cargo bench -p ratfit-cli --features all-backends --bench engine [-- --quick]`

use anyhow::{Context, Result};
use rational_core::{fit, fit_split, Backend, FitSettings, IntervalData, PoleControl, Selection};
use std::f64::consts::PI;
use std::io::Write;
use std::time::Instant;

fn runge(samples: usize) -> IntervalData {
    let x: Vec<f64> = (0..samples)
        .map(|i| -1.0 + 2.0 * i as f64 / (samples - 1) as f64)
        .collect();
    let v = x.iter().map(|x| 1.0 / (1.0 + 25.0 * x * x)).collect();
    IntervalData::from_values_relative(1, x, v, 0.01).expect("valid data")
}

/// A Blinn-Phong-like lobe in theta_h times a Schlick Fresnel term in
/// theta_d, on a grid of about `samples` points.
fn lobe2d(samples: usize) -> IntervalData {
    let side = (samples as f64).sqrt().round() as usize;
    let mut pts = Vec::with_capacity(2 * side * side);
    let mut vals = Vec::with_capacity(side * side);
    for i in 0..side {
        for j in 0..side {
            let th = 0.5 * PI * i as f64 / (side - 1) as f64;
            let td = 78f64.to_radians() * j as f64 / (side - 1) as f64;
            pts.extend([th, td]);
            let fresnel = 0.04 + 0.96 * (1.0 - td.cos()).powi(5);
            vals.push(0.02 + 3.0 * th.cos().powi(40) * fresnel / 0.04 * 0.2);
        }
    }
    IntervalData::from_values_relative(2, pts, vals, 0.01).expect("valid data")
}

fn median(v: &mut [f64]) -> f64 {
    v.sort_by(f64::total_cmp);
    let n = v.len();
    if n % 2 == 1 {
        v[n / 2]
    } else {
        0.5 * (v[n / 2 - 1] + v[n / 2])
    }
}

fn main() -> Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let quick = args.iter().any(|a| a == "--quick");
    let out = args
        .iter()
        .position(|a| a == "--out")
        .and_then(|i| args.get(i + 1))
        .map_or_else(
            || std::path::PathBuf::from("target/bench"),
            std::path::PathBuf::from,
        );
    std::fs::create_dir_all(&out).with_context(|| format!("cannot create {}", out.display()))?;
    let csv_path = out.join("engine.csv");
    let mut csv = std::fs::File::create(&csv_path)?;
    writeln!(csv, "instance,backend,samples,n_p,n_q,status,verified,depth,max_violation,max_rel_error,median_s,min_s,max_s,reps")?;
    let sizes: &[usize] = if quick {
        &[2_000, 20_000]
    } else {
        &[2_000, 20_000, 200_000, 1_000_000]
    };
    // A backend whose run at the next size is predicted to exceed this is
    // not run there.
    let budget_s = if quick { 8.0 } else { 60.0 };
    println!(
        "{:<10} {:<9} {:>9} {:>7} {:>9} {:>10} {:>10} {:>10}",
        "instance", "backend", "samples", "split", "status", "depth", "max rel", "median s"
    );
    type Maker = fn(usize) -> IntervalData;
    let instances: [(&str, Maker, (usize, usize)); 2] =
        [("runge1d", runge, (6, 6)), ("lobe2d", lobe2d, (26, 16))];
    let mut medians = std::collections::HashMap::new();
    for (name, make, (np, nq)) in instances {
        let mut predicted: std::collections::HashMap<Backend, f64> =
            std::collections::HashMap::new();
        for (si, &s) in sizes.iter().enumerate() {
            let data = make(s);
            for backend in Backend::available() {
                if let Some(&p) = predicted.get(&backend).filter(|&&p| p > budget_s) {
                    writeln!(
                        csv,
                        "{name},{backend},{},{np},{nq},skipped,,,,,,,,0",
                        data.len()
                    )?;
                    println!("{name:<10} {:<9} {:>9} {:>7} skipped: predicted {p:.0} s per run (budget {budget_s} s)", backend.name(), data.len(), format!("{np},{nq}"));
                    continue;
                }
                let settings = FitSettings::default()
                    .with_backend(backend)?
                    .with_pole_control(PoleControl::None);
                // Warm-up run; its time decides the repetitions (5, 3 or 1).
                let t = Instant::now();
                let mut last = fit_split(&data, np, nq, &settings)?;
                let warm = t.elapsed().as_secs_f64();
                let reps = if warm > 2.0 {
                    1
                } else if warm > 0.2 {
                    3
                } else {
                    5
                };
                let mut times = Vec::with_capacity(reps);
                for _ in 0..reps {
                    let t = Instant::now();
                    last = fit_split(&data, np, nq, &settings)?;
                    times.push(t.elapsed().as_secs_f64());
                }
                let (mn, mx) = (
                    times.iter().cloned().fold(f64::INFINITY, f64::min),
                    times.iter().cloned().fold(0.0, f64::max),
                );
                let med = median(&mut times);
                if let Some(&next) = sizes.get(si + 1) {
                    // Interior-point and simplex costs grow faster than
                    // linearly in practice: predict with exponent 1.5.
                    predicted.insert(backend, warm.max(mn) * (next as f64 / s as f64).powf(1.5));
                }
                let (viol, rel) = match (&last.verification, &last.function) {
                    (Some(v), Some(f)) => (
                        v.max_violation,
                        rational_core::verify::error_figures(f, &data).max_relative,
                    ),
                    (Some(v), None) => (v.max_violation, f64::NAN),
                    _ => (f64::NAN, f64::NAN),
                };
                let sm = &last.summary;
                writeln!(
                    csv,
                    "{name},{backend},{},{np},{nq},{},{},{:e},{:e},{:e},{med:e},{mn:e},{mx:e},{}",
                    data.len(),
                    sm.status,
                    sm.accepted,
                    sm.depth,
                    viol,
                    rel,
                    times.len()
                )?;
                println!(
                    "{name:<10} {:<9} {:>9} {:>7} {:>9} {:>10.3e} {:>10.3e} {:>10.4}",
                    backend.name(),
                    data.len(),
                    format!("{np},{nq}"),
                    if sm.accepted {
                        "verified".to_string()
                    } else {
                        sm.status.to_string()
                    },
                    sm.depth,
                    rel,
                    med
                );
                medians.insert((name, backend, data.len()), med);
            }
        }
    }
    // Ratios at 20,000 samples, same run.
    for name in ["runge1d", "lobe2d"] {
        let key = |b| {
            medians
                .get(&(name, b, if name == "runge1d" { 20_000 } else { 141 * 141 }))
                .copied()
        };
        if let Some(native) = key(Backend::Native) {
            for b in Backend::available()
                .into_iter()
                .filter(|b| *b != Backend::Native)
            {
                if let Some(t) = key(b) {
                    println!(
                        "{name} at ~20,000 samples: native is {:.1}x faster than {b}",
                        t / native
                    );
                }
            }
        }
    }
    // The paper-like sweep: all 41 splits at 42 coefficients, ~7,000 2-D samples.
    let data = lobe2d(7_000);
    let threads = rayon::current_num_threads();
    for (label, poles) in [
        ("sweep42", PoleControl::None),
        ("sweep42+grid", PoleControl::default()),
    ] {
        let settings = FitSettings::default()
            .with_coeff_range(42, 42)?
            .with_selection(Selection::ConditionNumber)
            .with_pole_control(poles);
        let reps = if quick { 1 } else { 3 };
        let mut times = Vec::new();
        let mut accepted = 0;
        let mut status = String::from("infeasible");
        for _ in 0..reps {
            let t = Instant::now();
            let r = fit(&data, &settings);
            times.push(t.elapsed().as_secs_f64());
            match r {
                Ok(rep) => {
                    accepted = rep.splits.iter().filter(|s| s.accepted).count();
                    status = format!("chosen ({},{}), {accepted}/41 feasible", rep.n_p, rep.n_q);
                }
                Err(e) => status = e.to_string(),
            }
        }
        let (mn, mx) = (
            times.iter().cloned().fold(f64::INFINITY, f64::min),
            times.iter().cloned().fold(0.0, f64::max),
        );
        let med = median(&mut times);
        writeln!(
            csv,
            "{label},native,{},41 splits,42,{accepted} feasible,,,,,{med:e},{mn:e},{mx:e},{reps}",
            data.len()
        )?;
        println!("{label}: {} samples, {threads} threads: {status}; median {med:.3} s (paper: 22 s on 8 threads)", data.len());
    }
    println!("wrote {}", csv_path.display());
    Ok(())
}
