//! The full MERL grid in 3-D: RGL materials tabulated on 90 x 90 x 180
//! bins (739,892 samples per channel after the cuts), their three channels
//! fitted with budgets up to 120 coefficients by the staircase search,
//! widening by 2 where a channel has no fit, with the settings of `ratfit
//! fit FILE --format rgl --dims 3 --resolution 90,90,180 --rel-tol T
//! --max-coeffs 120 --search staircase`. For each material and tolerance it
//! records the splits, each channel's seconds (the three share the cores),
//! the wall time and the peak resident memory of the fit. Writes
//! `full_grid.csv` and `full_grid.svg` / `.png` (seconds per channel against
//! coefficients, log axes, one colour per tolerance).
//!
//! `cargo bench -p ratfit-bench --bench full_grid -- [--quick] [--out DIR]`
//! (`--quick`: cm_military_green at 40% on a 45 x 45 x 90 grid).

use anyhow::{Context, Result};
use brdf::{fit_brdf, BrdfFitSettings, Reduction, ReductionKind, RglBrdf};
use ratfit_bench::bench_target::TargetArgs;
use ratfit_bench::chart::{Figure, Panel};
use rational_core::{FitSettings, Search};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

const MATERIALS: [&str; 2] = ["cm_military_green_rgb", "aurora_white_rgb"];
const TOLERANCES: [f64; 2] = [0.2, 0.4];

/// One row of `full_grid.csv`: one channel of one fit.
#[derive(Serialize)]
struct Row<'a> {
    material: &'a str,
    rel_tol: f64,
    grid: String,
    samples: usize,
    channel: char,
    n_p: usize,
    n_q: usize,
    interval_scale: f64,
    verified: bool,
    max_rel: f64,
    channel_s: f64,
    wall_s: f64,
    peak_resident_bytes: Option<u64>,
}

/// Resets the peak resident memory of this process (Linux: 5 in
/// `/proc/self/clear_refs`); false where that is not possible.
fn reset_peak_memory() -> bool {
    std::fs::write("/proc/self/clear_refs", "5").is_ok()
}

/// Peak resident memory since the last reset (`VmHWM`), in bytes.
fn peak_memory() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmHWM:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}

fn settings(quick: bool, rel_tol: f64) -> Result<BrdfFitSettings> {
    let mut reduction = Reduction::default().with_kind(ReductionKind::Full3d);
    if quick {
        reduction = reduction.with_resolution(45, 45).with_phi_resolution(90);
    }
    let engine = FitSettings::default()
        .with_coeff_range(2, 120)?
        .with_search(Search::Staircase)
        .with_widening(2.0, 6)?;
    Ok(BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_rel_tol(rel_tol)?
        .with_fit_settings(engine))
}

fn main() -> Result<()> {
    let TargetArgs { quick, out, .. } = TargetArgs::from_env()?;
    let data = std::env::var_os("RATFIT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    let (materials, tolerances): (&[&str], &[f64]) = if quick {
        (&MATERIALS[..1], &TOLERANCES[1..])
    } else {
        (&MATERIALS, &TOLERANCES)
    };
    let csv_path = out.join("full_grid.csv");
    let mut csv = csv::Writer::from_path(&csv_path)
        .with_context(|| format!("cannot write {}", csv_path.display()))?;
    let mut panels = Vec::new();
    for &name in materials {
        let path = data.join("rgl").join(format!("{name}.bsdf"));
        let table = RglBrdf::read(&path)
            .with_context(|| format!("no RGL data at {} (set RATFIT_DATA)", path.display()))?;
        let mut panel = Panel {
            title: name.to_string(),
            ..Panel::default()
        };
        for (k, &rel_tol) in tolerances.iter().enumerate() {
            let settings = settings(quick, rel_tol)?;
            let reduction = settings.reduction();
            let grid = format!(
                "{}x{}x{}",
                reduction.n_theta_h, reduction.n_theta_d, reduction.n_phi_d
            );
            let measured = reset_peak_memory();
            let start = Instant::now();
            let (_, report) = fit_brdf(&table, &settings)?;
            let wall_s = start.elapsed().as_secs_f64();
            let peak = peak_memory().filter(|_| measured);
            for c in &report.channels {
                csv.serialize(Row {
                    material: name,
                    rel_tol,
                    grid: grid.clone(),
                    samples: c.samples,
                    channel: c.channel,
                    n_p: c.n_p,
                    n_q: c.n_q,
                    interval_scale: c.interval_scale,
                    verified: c.verified,
                    max_rel: c.max_rel,
                    channel_s: c.seconds,
                    wall_s,
                    peak_resident_bytes: peak,
                })?;
                panel
                    .points
                    .push((k, (c.n_p + c.n_q) as f64, c.seconds.max(1e-3)));
            }
            let split = |c: &brdf::ChannelReport| {
                format!(
                    "{} ({}, {}) x{} {:.1} s",
                    c.channel, c.n_p, c.n_q, c.interval_scale, c.seconds
                )
            };
            println!(
                "{name} {grid} at {:.0}%: {}; {wall_s:.1} s wall, peak {}",
                100.0 * rel_tol,
                report
                    .channels
                    .iter()
                    .map(split)
                    .collect::<Vec<_>>()
                    .join(", "),
                peak.map_or("not measured".into(), |b| format!(
                    "{:.2} GB",
                    b as f64 / 1e9
                )),
            );
        }
        panels.push(panel);
    }
    csv.flush()?;
    let figure = Figure {
        title: "Full MERL grid, 3-D: seconds per channel".into(),
        x_label: "coefficients of the channel's fit".into(),
        y_label: "seconds".into(),
        legend: tolerances
            .iter()
            .map(|t| format!("{:.0}% intervals", 100.0 * t))
            .collect(),
        columns: panels.len(),
        panels,
    };
    figure.write(&out, "full_grid")?;
    Ok(())
}
