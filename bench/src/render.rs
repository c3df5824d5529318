//! `ratfit bench render`: the BRDF samplers of one scene at equal sample
//! counts and at equal time, as error against a high-sample reference
//! against render time (CSV, figure, summary).

use crate::chart::{Figure, Panel};
use crate::scene_args::{parse_swap, OverrideArgs};
use anyhow::{bail, Context, Result};
use clap::Args;
use render_cpu::{compare, prepare_file, render, SamplerKind, Scene};
use std::fmt::Write as _;
use std::path::PathBuf;

/// Options of `ratfit bench render`.
#[derive(Args)]
pub struct RenderBenchArgs {
    /// The scene file.
    scene: PathBuf,
    /// Output folder.
    #[arg(long, default_value = "target/bench-render")]
    out: PathBuf,
    /// Samplers to compare.
    #[arg(
        long,
        value_delimiter = ',',
        default_value = "cosine,tabulated,rational"
    )]
    samplers: Vec<SamplerKind>,
    /// Samples per pixel of the compared renders.
    #[arg(long, value_delimiter = ',', default_value = "1,2,4,8,16,32")]
    spp_list: Vec<usize>,
    /// Samples per pixel of the reference.
    #[arg(long, default_value_t = 1024)]
    reference_spp: usize,
    /// Sampler of the reference.
    #[arg(long, default_value = "tabulated")]
    reference_sampler: SamplerKind,
    /// Objects using material A use material B in the rational sampler's
    /// renders only (A=B; repeatable): `--rational-swap T=T_fit` times the
    /// table with its tabulated sampler against its fit with rational ones.
    #[arg(long = "rational-swap")]
    rational_swaps: Vec<String>,
    #[command(flatten)]
    overrides: OverrideArgs,
}

/// One render of the study.
struct Row {
    sampler: SamplerKind,
    spp: usize,
    seconds: f64,
    rmse: f64,
    mean_de2000: f64,
    variance: [f64; 3],
    sampler_bytes: usize,
}

fn prepared(args: &RenderBenchArgs, sampler: SamplerKind) -> Result<Scene> {
    let mut options = args.overrides.options()?;
    options.sampler = Some(sampler);
    if sampler == SamplerKind::Rational {
        for s in &args.rational_swaps {
            options.swaps.push(parse_swap(s, "--rational-swap")?);
        }
    }
    let (scene, log) = prepare_file(&args.scene, &options)?;
    eprintln!("{} sampler:\n{log}", sampler.name());
    Ok(scene)
}

/// `log y` interpolated linearly in `log x` at `x`, from points sorted by x.
fn log_interpolate(points: &[(f64, f64)], x: f64) -> Option<f64> {
    points.windows(2).find_map(|w| {
        let ((x0, y0), (x1, y1)) = (w[0], w[1]);
        (x0 <= x && x <= x1 && x0 > 0.0 && y0 > 0.0 && y1 > 0.0).then(|| {
            let t = if x1 > x0 {
                (x / x0).ln() / (x1 / x0).ln()
            } else {
                0.0
            };
            (y0.ln() + t * (y1 / y0).ln()).exp()
        })
    })
}

/// Runs `ratfit bench render`.
pub fn run(args: RenderBenchArgs) -> Result<()> {
    if args.samplers.is_empty() || args.spp_list.contains(&0) || args.reference_spp == 0 {
        bail!("give at least one sampler and positive sample counts");
    }
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut reference_scene = prepared(&args, args.reference_sampler)?;
    reference_scene.integrator.spp = args.reference_spp;
    // A seed none of the compared renders uses.
    reference_scene.integrator.seed = 0x5eed_0000_0001;
    let reference = render(&reference_scene, &crate::scene_args::row_bar());
    reference.image.write_exr(&args.out.join("reference.exr"))?;
    println!(
        "reference: {} sampler, {} spp, {:.1} s",
        args.reference_sampler.name(),
        args.reference_spp,
        reference.stats.seconds
    );
    println!(
        "{:<10} {:>5} {:>9} {:>11} {:>9} {:>33}",
        "sampler", "spp", "seconds", "RMSE", "dE2000", "variance of one sample r / g / b"
    );
    let mut rows = Vec::new();
    for &sampler in &args.samplers {
        let mut scene = prepared(&args, sampler)?;
        let bytes = scene.materials.iter().map(|m| m.sampler_bytes).sum();
        for &spp in &args.spp_list {
            scene.integrator.spp = spp;
            scene.integrator.seed = 1;
            let out = render(&scene, &|_, _| {});
            let (c, _) = compare(&out.image, &reference.image, scene.exposure)?;
            let v = out.stats.sample_variance;
            println!(
                "{:<10} {:>5} {:>9.3} {:>11.4e} {:>9.4} {:>11.3e}/{:.3e}/{:.3e}",
                sampler.name(),
                spp,
                out.stats.seconds,
                c.rmse_all,
                c.covered_mean_de2000,
                v[0],
                v[1],
                v[2]
            );
            if spp == *args.spp_list.iter().max().unwrap_or(&spp) {
                out.image.write(
                    &args.out.join(format!("{}-{spp}spp.png", sampler.name())),
                    scene.exposure,
                )?;
            }
            rows.push(Row {
                sampler,
                spp,
                seconds: out.stats.seconds,
                rmse: c.rmse_all,
                mean_de2000: c.covered_mean_de2000,
                variance: v,
                sampler_bytes: bytes,
            });
        }
    }
    let scene_name = args
        .scene
        .file_stem()
        .map(|s| s.to_string_lossy().to_string())
        .unwrap_or_default();
    write_csv(&args, &scene_name, &rows)?;
    write_figure(&args, &scene_name, &rows)?;
    let md = summary(&args, &scene_name, &rows, reference.stats.seconds);
    crate::output::write(args.out.join("summary.md"), &md)?;
    println!("\n{md}");
    println!(
        "wrote {}/render.csv, error_vs_time.svg/.png, summary.md, reference.exr",
        args.out.display()
    );
    Ok(())
}

/// One row of `render.csv`: one sampler at one sample count.
#[derive(serde::Serialize)]
struct CsvRow<'a> {
    scene: &'a str,
    sampler: &'a str,
    spp: usize,
    seconds: f64,
    rmse: f64,
    mean_de2000: f64,
    var_r: f64,
    var_g: f64,
    var_b: f64,
    sampler_bytes: usize,
}

/// `render.csv`: one row per sampler and sample count.
fn write_csv(args: &RenderBenchArgs, scene_name: &str, rows: &[Row]) -> Result<()> {
    crate::output::write_csv(
        args.out.join("render.csv"),
        rows.iter().map(|r| CsvRow {
            scene: scene_name,
            sampler: r.sampler.name(),
            spp: r.spp,
            seconds: r.seconds,
            rmse: r.rmse,
            mean_de2000: r.mean_de2000,
            var_r: r.variance[0],
            var_g: r.variance[1],
            var_b: r.variance[2],
            sampler_bytes: r.sampler_bytes,
        }),
    )
}

/// `error_vs_time.svg/.png`: RMSE against time and against samples.
fn write_figure(args: &RenderBenchArgs, scene_name: &str, rows: &[Row]) -> Result<()> {
    let names: Vec<String> = args.samplers.iter().map(|s| s.name().to_string()).collect();
    let series = |f: &dyn Fn(&Row) -> (f64, f64)| -> Vec<(usize, f64, f64)> {
        rows.iter()
            .map(|r| {
                let k = args
                    .samplers
                    .iter()
                    .position(|s| *s == r.sampler)
                    .unwrap_or(0);
                let (x, y) = f(r);
                (k, x, y)
            })
            .collect()
    };
    let figure = Figure {
        title: format!(
            "{scene_name}: error against a {}-spp reference",
            args.reference_spp
        ),
        x_label: "render time (s) / samples per pixel".into(),
        y_label: "RMSE (linear)".into(),
        legend: names.clone(),
        panels: vec![
            Panel {
                title: "equal time: RMSE vs seconds".into(),
                points: series(&|r| (r.seconds, r.rmse)),
                front: Vec::new(),
            },
            Panel {
                title: "equal samples: RMSE vs spp".into(),
                points: series(&|r| (r.spp as f64, r.rmse)),
                front: Vec::new(),
            },
        ],
        columns: 2,
    };
    figure.write(&args.out, "error_vs_time")
}

/// `summary.md`: equal samples and equal time.
fn summary(
    args: &RenderBenchArgs,
    scene_name: &str,
    rows: &[Row],
    reference_seconds: f64,
) -> String {
    let names: Vec<String> = args.samplers.iter().map(|s| s.name().to_string()).collect();
    // Equal time: each sampler's RMSE interpolated at the longest time all reach.
    let curve = |s: SamplerKind| -> Vec<(f64, f64)> {
        let mut p: Vec<(f64, f64)> = rows
            .iter()
            .filter(|r| r.sampler == s)
            .map(|r| (r.seconds, r.rmse))
            .collect();
        p.sort_by(|a, b| a.0.total_cmp(&b.0));
        p
    };
    let common = args
        .samplers
        .iter()
        .filter_map(|&s| curve(s).last().map(|p| p.0))
        .fold(f64::INFINITY, f64::min);
    let mut md = format!(
        "# Samplers on `{scene_name}`\n\n{} ({} sampler, {} spp, {:.1} s) is the reference; errors are RMSE of linear values and the mean CIEDE2000 over non-black pixels. Seed 1 for every compared render.\n\n## Equal samples\n\n| spp |",
        "reference.exr", args.reference_sampler.name(), args.reference_spp, reference_seconds
    );
    if !args.rational_swaps.is_empty() {
        md.insert_str(
            md.find("\n\n## Equal samples").unwrap_or(md.len()),
            &format!(
                " The rational sampler's renders swap materials ({}): they time and measure the fits with their rational samplers against the tables with theirs.",
                args.rational_swaps.join(", ")
            ),
        );
    }
    for n in &names {
        let _ = write!(md, " {n} RMSE (s) |");
    }
    md.push_str("\n|---|");
    md.push_str(&"---|".repeat(names.len()));
    md.push('\n');
    for &spp in &args.spp_list {
        let _ = write!(md, "| {spp} |");
        for &s in &args.samplers {
            if let Some(r) = rows.iter().find(|r| r.sampler == s && r.spp == spp) {
                let _ = write!(md, " {:.3e} ({:.2}) |", r.rmse, r.seconds);
            }
        }
        md.push('\n');
    }
    let _ = write!(md, "\n## Equal time ({common:.3} s, log-log interpolation)\n\n| sampler | RMSE | sampler bytes | variance of one sample r / g / b at {} spp |\n|---|---|---|---|\n", args.spp_list.iter().max().unwrap_or(&1));
    for &s in &args.samplers {
        let at = log_interpolate(&curve(s), common)
            .or_else(|| curve(s).first().filter(|p| p.0 >= common).map(|p| p.1));
        let last = rows.iter().filter(|r| r.sampler == s).max_by_key(|r| r.spp);
        if let (Some(e), Some(r)) = (at, last) {
            let _ = writeln!(
                md,
                "| {} | {e:.3e} | {} | {:.3e} / {:.3e} / {:.3e} |",
                s.name(),
                r.sampler_bytes,
                r.variance[0],
                r.variance[1],
                r.variance[2]
            );
        }
    }
    md
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn log_interpolation_is_exact_on_power_laws() {
        let pts: Vec<(f64, f64)> = [1.0, 2.0, 8.0]
            .iter()
            .map(|&x: &f64| (x, 3.0 / x.sqrt()))
            .collect();
        let y = log_interpolate(&pts, 4.0).unwrap();
        assert!((y - 1.5).abs() < 1e-12, "{y}");
        assert!(log_interpolate(&pts, 9.0).is_none());
    }
}
