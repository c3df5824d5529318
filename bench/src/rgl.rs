//! `ratfit bench rgl`: every RGL `.bsdf` file of a folder fitted in 2-D and
//! 3-D with one set of settings, error next to cost per channel. Where the
//! requested intervals have no fit within the budget, the half-widths are
//! doubled (at most `--max-widenings` times) and the factor is reported;
//! where even that fails, the row says so. Writes `results.csv`,
//! `summary.md`, `error_vs_time.svg`/`.png` and each fit as JSON.

use super::instances::data_dir;
use super::summary::utc_date;
use crate::chart::{Figure, Panel};
use anyhow::{bail, Context, Result};
use brdf::{fit_brdf, BrdfFitReport, BrdfFitSettings, Reduction, ReductionKind, RglBrdf};
use clap::Args;
use rational_core::{FitSettings, Search};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `ratfit bench rgl`.
#[derive(Args)]
pub struct RglBenchArgs {
    /// Folder of RGL `.bsdf` files (default: `rgl` under `RATFIT_DATA` or
    /// `../shared/data`).
    dir: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "target/bench-rgl")]
    out: PathBuf,
    /// Fitting dimensions (comma-separated): 2 (the `phi_d = pi/2` slice),
    /// 3 (`theta_h, theta_d, phi_d`).
    #[arg(long, value_delimiter = ',', default_value = "2,3")]
    dims: Vec<usize>,
    /// Relative half-width of the intervals asked for.
    #[arg(long, default_value_t = 0.2)]
    rel_tol: f64,
    /// Largest coefficient budget per channel.
    #[arg(long, default_value_t = 120)]
    max_coeffs: usize,
    /// Doublings of every half-width allowed when the requested intervals
    /// have no fit within the budget.
    #[arg(long, default_value_t = 2)]
    max_widenings: usize,
    /// Bins per angle of the 3-D grid (`theta_h`, `theta_d`, `phi_d`).
    #[arg(long, default_value_t = 24)]
    resolution_3d: usize,
    /// Degree weights of `theta_h, theta_d, phi_d` in the basis order (2-D
    /// fits use the first two). Default: all 1.
    #[arg(long, value_delimiter = ',')]
    degree_weights: Vec<u16>,
    /// Only files whose name contains this.
    #[arg(long)]
    only: Option<String>,
}

/// One channel of one fit, or a fit that failed.
struct Row {
    material: String,
    dims: usize,
    channel: char,
    samples: usize,
    n_p: usize,
    n_q: usize,
    bytes: usize,
    interval_scale: f64,
    max_rel: f64,
    mean_rel: f64,
    rmse: f64,
    seconds: f64,
    polynomial_max_rel: f64,
    outcome: String,
}

fn rgl_files(dir: &Path, only: Option<&str>) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = std::fs::read_dir(dir)
        .with_context(|| format!("cannot read {}", dir.display()))?
        .filter_map(|e| e.ok().map(|e| e.path()))
        .filter(|p| p.extension().is_some_and(|x| x == "bsdf"))
        .filter(|p| {
            only.is_none_or(|o| {
                p.file_name()
                    .is_some_and(|n| n.to_string_lossy().contains(o))
            })
        })
        .collect();
    files.sort();
    if files.is_empty() {
        bail!("no .bsdf file in {}", dir.display());
    }
    Ok(files)
}

fn settings(args: &RglBenchArgs, dims: usize) -> Result<BrdfFitSettings> {
    let reduction = match dims {
        2 => Reduction::default(),
        3 => Reduction::default()
            .with_kind(ReductionKind::Full3d)
            .with_resolution(args.resolution_3d, args.resolution_3d)
            .with_phi_resolution(args.resolution_3d),
        d => bail!("--dims {d}: use 2 or 3"),
    };
    let mut fit = FitSettings::default()
        .with_coeff_range(2, args.max_coeffs)?
        .with_search(Search::Staircase);
    if !args.degree_weights.is_empty() {
        if args.degree_weights.len() < dims {
            bail!(
                "--degree-weights: {} weights for {dims}-D fits (give theta_h,theta_d,phi_d)",
                args.degree_weights.len()
            );
        }
        fit = fit.with_degree_weights(args.degree_weights[..dims].to_vec())?;
    }
    if args.max_widenings > 0 {
        fit = fit.with_widening(2.0, args.max_widenings)?;
    }
    Ok(BrdfFitSettings::default()
        .with_reduction(reduction)
        .with_rel_tol(args.rel_tol)?
        .with_fit_settings(fit))
}

fn rows_of(report: &BrdfFitReport, dims: usize) -> Vec<Row> {
    report
        .channels
        .iter()
        .map(|c| Row {
            material: report.material.clone(),
            dims,
            channel: c.channel,
            samples: c.samples,
            n_p: c.n_p,
            n_q: c.n_q,
            bytes: c.bytes_f32,
            interval_scale: c.interval_scale,
            max_rel: c.max_rel,
            mean_rel: c.mean_rel,
            rmse: c.rmse,
            seconds: c.seconds,
            polynomial_max_rel: c
                .baselines
                .iter()
                .find(|b| b.name.starts_with("polynomial"))
                .map_or(f64::NAN, |b| b.max_rel),
            outcome: if c.verified { "fit" } else { "NOT VERIFIED" }.into(),
        })
        .collect()
}

/// Runs `ratfit bench rgl`.
pub fn run(args: RglBenchArgs) -> Result<()> {
    let start = Instant::now();
    let dir = match &args.dir {
        Some(d) => d.clone(),
        None => data_dir()
            .map(|d| d.join("rgl"))
            .context("no data folder: give the folder or set RATFIT_DATA")?,
    };
    let files = rgl_files(&dir, args.only.as_deref())?;
    let fits_dir = args.out.join("fits");
    std::fs::create_dir_all(&fits_dir)
        .with_context(|| format!("cannot create {}", fits_dir.display()))?;
    let mut rows = Vec::new();
    for &dims in &args.dims {
        let settings = settings(&args, dims)?;
        for path in &files {
            let stem = path
                .file_stem()
                .map_or_else(String::new, |s| s.to_string_lossy().into_owned());
            let material = RglBrdf::read(path)?;
            let t = Instant::now();
            match fit_brdf(&material, &settings) {
                Ok((fitted, report)) => {
                    let new = rows_of(&report, dims);
                    for r in &new {
                        eprintln!(
                            "{stem} {dims}-D {}: ({}, {}) x{} max rel {:.3} mean {:.3} in {:.1} s",
                            r.channel,
                            r.n_p,
                            r.n_q,
                            r.interval_scale,
                            r.max_rel,
                            r.mean_rel,
                            r.seconds
                        );
                    }
                    rows.extend(new);
                    let json = fits_dir.join(format!("{stem}_{dims}d.json"));
                    crate::output::write(
                        &json,
                        serde_json::to_string(&brdf::FitFile::new(fitted).to_value())?,
                    )?;
                }
                Err(e) => {
                    eprintln!("{stem} {dims}-D: {e}");
                    rows.push(Row {
                        material: stem.clone(),
                        dims,
                        channel: '-',
                        samples: 0,
                        n_p: 0,
                        n_q: 0,
                        bytes: 0,
                        interval_scale: f64::NAN,
                        max_rel: f64::NAN,
                        mean_rel: f64::NAN,
                        rmse: f64::NAN,
                        seconds: t.elapsed().as_secs_f64(),
                        polynomial_max_rel: f64::NAN,
                        outcome: e.to_string().replace(',', ";"),
                    });
                }
            }
            // Written after every material, so a long run stopped early
            // keeps what it measured.
            write_outputs(&args, &dir, &rows, start.elapsed().as_secs_f64(), false)?;
        }
    }
    write_outputs(&args, &dir, &rows, start.elapsed().as_secs_f64(), true)?;
    let unverified = rows.iter().filter(|r| r.outcome == "NOT VERIFIED").count();
    if unverified > 0 {
        bail!("{unverified} channel fit(s) failed verification");
    }
    Ok(())
}

fn write_outputs(
    args: &RglBenchArgs,
    dir: &Path,
    rows: &[Row],
    total: f64,
    finished: bool,
) -> Result<()> {
    crate::output::write_csv(args.out.join("results.csv"), csv_rows(args, rows))?;
    let md = summary_md(args, dir, rows, total, finished);
    crate::output::write(args.out.join("summary.md"), &md)?;
    write_figure(args, rows)?;
    if finished {
        print!("{md}");
        eprintln!("wrote {}", args.out.display());
    }
    Ok(())
}

/// One row of `results.csv`: one channel fit.
#[derive(serde::Serialize)]
struct CsvRow<'a> {
    material: &'a str,
    dims: usize,
    channel: char,
    samples: usize,
    n_p: usize,
    n_q: usize,
    bytes_f32: usize,
    interval_scale: f64,
    rel_tol_used: f64,
    max_rel: f64,
    mean_rel: f64,
    rmse: f64,
    fit_s: f64,
    polynomial_max_rel: f64,
    outcome: &'a str,
}

/// The CSV rows, one per channel fit.
fn csv_rows<'a>(args: &'a RglBenchArgs, rows: &'a [Row]) -> impl Iterator<Item = CsvRow<'a>> {
    rows.iter().map(move |r| CsvRow {
        material: &r.material,
        dims: r.dims,
        channel: r.channel,
        samples: r.samples,
        n_p: r.n_p,
        n_q: r.n_q,
        bytes_f32: r.bytes,
        interval_scale: r.interval_scale,
        rel_tol_used: args.rel_tol * r.interval_scale,
        max_rel: r.max_rel,
        mean_rel: r.mean_rel,
        rmse: r.rmse,
        fit_s: r.seconds,
        polynomial_max_rel: r.polynomial_max_rel,
        outcome: &r.outcome,
    })
}

/// The Markdown summary: the run's settings, then one row per material and
/// dimension.
fn summary_md(args: &RglBenchArgs, dir: &Path, rows: &[Row], total: f64, finished: bool) -> String {
    let threads = rayon::current_num_threads();
    let mut md = format!(
        "# RGL materials, {}-D fits ({})\n\n`{}`: every file of `{}`. Intervals of {}% asked for (noise floor 1% of each channel's median), at most {} coefficients per channel, staircase search; where a channel has no fit, every half-width is doubled, at most {} times.{} `theta_d <= 78` degrees, elevations <= 70 degrees. Relative errors over samples above the noise floor; times are per channel (channels run in parallel on {threads} threads). {} {:.0} s.\n\n",
        args.dims.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(" and "),
        utc_date(),
        command_line(args),
        dir.display(),
        args.rel_tol * 100.0,
        args.max_coeffs,
        args.max_widenings,
        if args.dims.contains(&3) {
            format!(" 3-D on a {0}^3 grid.", args.resolution_3d)
        } else {
            String::new()
        },
        if finished { "Total" } else { "Unfinished run, so far" },
        total,
    );
    md += "| material | dims | coefficients r / g / b | bytes (f32) | intervals r / g / b | max rel error r / g / b | mean rel error r / g / b | fit time r / g / b (s) | polynomial, same size: max rel |\n|---|---|---|---|---|---|---|---|---|\n";
    let mut keys: Vec<(String, usize)> =
        rows.iter().map(|r| (r.material.clone(), r.dims)).collect();
    keys.dedup();
    for (material, dims) in &keys {
        let ch: Vec<&Row> = rows
            .iter()
            .filter(|r| &r.material == material && r.dims == *dims)
            .collect();
        if ch.len() == 1 && ch[0].channel == '-' {
            let _ = writeln!(
                md,
                "| {material} | {dims} | no fit: {} | | | | | {:.1} | |",
                ch[0].outcome, ch[0].seconds
            );
            continue;
        }
        let join =
            |f: &dyn Fn(&Row) -> String| ch.iter().map(|r| f(r)).collect::<Vec<_>>().join(" / ");
        let _ = writeln!(
            md,
            "| {material} | {dims} | {} | {} | {} | {} | {} | {} | {} |",
            join(&|r| (r.n_p + r.n_q).to_string()),
            ch.iter().map(|r| r.bytes).sum::<usize>(),
            join(&|r| format!("{:.0}%", 100.0 * args.rel_tol * r.interval_scale)),
            join(&|r| format!("{:.3}", r.max_rel)),
            join(&|r| format!("{:.3}", r.mean_rel)),
            join(&|r| format!("{:.1}", r.seconds)),
            join(&|r| format!("{:.2}", r.polynomial_max_rel)),
        );
    }
    md
}

/// Error against fit time: one panel per dimension, one series per
/// interval width used.
fn write_figure(args: &RglBenchArgs, rows: &[Row]) -> Result<()> {
    let scales = [1.0, 2.0, 4.0, 8.0];
    let legend = scales
        .iter()
        .map(|s| format!("{:.0}%", 100.0 * args.rel_tol * s))
        .collect();
    let panels = args
        .dims
        .iter()
        .map(|&d| Panel {
            title: format!("{d}-D fits, one point per channel"),
            points: rows
                .iter()
                .filter(|r| r.dims == d && r.channel != '-')
                .map(|r| {
                    let k = scales
                        .iter()
                        .position(|s| (s - r.interval_scale).abs() < 1e-9)
                        .unwrap_or(3);
                    (k, r.seconds, r.max_rel)
                })
                .collect(),
            front: Vec::new(),
        })
        .collect();
    let figure = Figure {
        title: "RGL materials: error against fit time".into(),
        x_label: "fit time (s)".into(),
        y_label: "max relative error".into(),
        legend,
        panels,
        columns: 2,
    };
    figure.write(&args.out, "error_vs_time")?;
    Ok(())
}

fn command_line(args: &RglBenchArgs) -> String {
    format!(
        "ratfit bench rgl --dims {} --rel-tol {} --max-coeffs {} --max-widenings {} --resolution-3d {}",
        args.dims.iter().map(|d| d.to_string()).collect::<Vec<_>>().join(","),
        args.rel_tol,
        args.max_coeffs,
        args.max_widenings,
        args.resolution_3d
    )
}
