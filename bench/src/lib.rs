//! The benchmarks of ratfit, reached as `ratfit bench ...` or as the
//! `ratfit-bench` binary, and the command-line plumbing they share with
//! `ratfit`.
//!
//! * `bench fit`: error against run time for every compiled backend on the
//!   instances of `bench/fit.toml`, written as `results.csv`,
//!   `error_vs_time.png`/`.svg`, `time_vs_samples.svg` and `summary.md`;
//!   `bench check` re-checks a finished run's outputs. The backend
//!   comparison lives in the modules `run`, `instances`, `results` and
//!   `summary`, apart from the experiments.
//! * The experiments: `bench fidelity` (every representation judged by its
//!   renders), `bench render` (samplers at equal samples and time),
//!   `bench paper` (the paper's rendering experiments), `bench rgl` (every
//!   RGL file fitted) and `bench gpu` (frames per second on the GPU).
//! * Shared with `ratfit`: flag parsers ([`args`]), atomic output
//!   ([`output`], CSV and NumPy included), numeric CSV input
//!   ([`numeric_csv`]), progress bars ([`progress`]), Ctrl-C and broken
//!   pipes ([`process`]), scene overrides ([`scene_args`]) and the picture
//!   of `ratfit plot` ([`slices`]).
//! * For the benchmark targets `brdf_eval`, `sampling` and `full_grid` (`cargo bench -p
//!   ratfit-bench --bench NAME -- [--quick] [--out DIR]`): their flags
//!   ([`bench_target`]) and the log-log charts every benchmark draws
//!   ([`chart`], by `plotters`, with one palette and a built-in font).
//!
//! The arguments are clap's, so a program embeds them, as `ratfit bench`
//! does, and hands them to [`run_bench`]:
//!
//! ```
//! use clap::Parser;
//!
//! #[derive(Parser)]
//! struct Cli {
//!     #[command(flatten)]
//!     bench: ratfit_bench::BenchArgs,
//! }
//!
//! assert!(Cli::try_parse_from(["ratfit-bench", "check", "target/bench-quick"]).is_ok());
//! assert!(Cli::try_parse_from(["ratfit-bench", "no-such-benchmark"]).is_err());
//! ```

#![warn(missing_docs)]

mod aaa;
pub mod args;
pub mod bench_target;
pub mod chart;
mod fidelity;
mod gpu;
mod instances;
pub mod numeric_csv;
pub mod output;
mod paper;
pub mod process;
pub mod progress;
mod render;
mod results;
mod rgl;
mod run;
pub mod scene_args;
pub mod slices;
mod summary;

use anyhow::{bail, Context, Result};
use clap::{Args, Subcommand};
use instances::{data_dir, InstanceFile, DEFAULT_INSTANCES};
use rational_core::Backend;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `ratfit bench`.
#[derive(Args)]
pub struct BenchArgs {
    #[command(subcommand)]
    what: BenchWhat,
}

#[derive(Subcommand)]
enum BenchWhat {
    /// Fit every declared instance on every compiled backend over splits,
    /// tolerances and sizes; write results.csv, the error-against-time
    /// figure and summary.md, then check them.
    Fit(FitBenchArgs),
    /// Every representation of every material judged by its renders:
    /// CIEDE2000 on two validation scenes and BRDF-space error over the
    /// whole hemisphere, against bytes, next to a fitted analytic model and
    /// the table downsampled to the same bytes.
    Fidelity(fidelity::FidelityArgs),
    /// Compare the BRDF samplers of a scene at equal samples and equal
    /// time: error against a high-sample reference against render time.
    Render(render::RenderBenchArgs),
    /// The paper's rendering experiments on the example scenes: sphere data
    /// against fit, sampler variance, global illumination, frames per second.
    Paper(paper::PaperArgs),
    /// Every RGL `.bsdf` file fitted in 2-D and 3-D: coefficients, bytes,
    /// interval width used, errors and fit time per channel.
    Rgl(rgl::RglBenchArgs),
    /// Frames per second and evaluations per second of fitted materials on
    /// the GPU against the CPU (a build with `--features gpu`).
    Gpu(gpu::GpuBenchArgs),
    /// Check a finished run's outputs: files present, every backend timed,
    /// no point claimed solved yet violated without the verifier saying so.
    Check {
        /// The run's output folder.
        dir: PathBuf,
        /// Backends the run must have timed (default: every compiled one).
        #[arg(long, value_delimiter = ',')]
        backends: Option<Vec<Backend>>,
    },
}

#[derive(Args)]
struct FitBenchArgs {
    /// The quick subset (instances marked `quick`, at their quick sizes).
    #[arg(long)]
    quick: bool,
    /// Output folder.
    #[arg(long, default_value = "target/bench-fit")]
    out: PathBuf,
    /// Instance file (default: the repository's bench/fit.toml, built in).
    #[arg(long)]
    instances: Option<PathBuf>,
    /// Only these backends (comma-separated; default: every compiled one).
    #[arg(long, value_delimiter = ',')]
    backends: Option<Vec<Backend>>,
    /// Only instances whose name contains this.
    #[arg(long)]
    only: Option<String>,
    /// Override the file's time budget per run, in seconds.
    #[arg(long)]
    budget_s: Option<f64>,
}

/// Runs `ratfit bench`.
pub fn run_bench(args: BenchArgs) -> Result<()> {
    match args.what {
        BenchWhat::Fit(a) => run_fit(a),
        BenchWhat::Fidelity(a) => fidelity::run(a),
        BenchWhat::Render(a) => render::run(a),
        BenchWhat::Paper(a) => paper::run(a),
        BenchWhat::Gpu(a) => gpu::run(a),
        BenchWhat::Rgl(a) => rgl::run(a),
        BenchWhat::Check { dir, backends } => {
            let names: Vec<&str> = backends
                .unwrap_or_else(Backend::available)
                .iter()
                .map(|b| b.name())
                .collect();
            report_check(&dir, &names)
        }
    }
}

fn report_check(dir: &Path, backends: &[&str]) -> Result<()> {
    let problems = results::check(dir, backends)?;
    if problems.is_empty() {
        println!("check: {} is complete and consistent", dir.display());
        return Ok(());
    }
    for p in &problems {
        eprintln!("check: {p}");
    }
    bail!("{} problem(s) in {}", problems.len(), dir.display())
}

fn run_fit(a: FitBenchArgs) -> Result<()> {
    let start = Instant::now();
    let (text, origin) = match &a.instances {
        Some(p) => (
            std::fs::read_to_string(p).with_context(|| format!("cannot read {}", p.display()))?,
            p.display().to_string(),
        ),
        None => (DEFAULT_INSTANCES.to_string(), "bench/fit.toml".to_string()),
    };
    let mut file = InstanceFile::parse(&text, &origin)?;
    if let Some(b) = a.budget_s {
        if !(b > 0.0 && b.is_finite()) {
            bail!("--budget-s must be a positive number of seconds");
        }
        file.settings.budget_s = b;
        file.settings.quick_budget_s = b;
    }
    if let Some(only) = &a.only {
        file.instances.retain(|i| i.name.contains(only.as_str()));
        if file.instances.is_empty() {
            bail!("no instance name contains `{only}`");
        }
    }
    let backends = match &a.backends {
        Some(b) => {
            for x in b {
                if !x.is_compiled() {
                    bail!("backend {x} is not compiled in (enable its cargo feature)");
                }
            }
            b.clone()
        }
        None => Backend::available(),
    };
    let dir = data_dir();
    match &dir {
        Some(d) => println!("measured data: {}", d.display()),
        None => println!("measured data: not found (set RATFIT_DATA); instances on measured files will report an error"),
    }
    std::fs::create_dir_all(&a.out)
        .with_context(|| format!("cannot create {}", a.out.display()))?;
    let threads = rayon::current_num_threads();
    run::print_header();
    let rows = run::run(
        &file,
        &run::RunOptions {
            quick: a.quick,
            backends: backends.clone(),
            data_dir: dir.as_deref(),
        },
    );
    let info = summary::RunInfo {
        date: summary::utc_date(),
        commit: git_commit(),
        machine: cpu_model(),
        threads,
        command: std::iter::once("ratfit".to_string())
            .chain(std::env::args().skip(1))
            .collect::<Vec<_>>()
            .join(" "),
        wall_s: start.elapsed().as_secs_f64(),
        instances: file
            .instances
            .iter()
            .filter(|i| i.quick || !a.quick)
            .map(|i| (i.name.clone(), i.description.clone()))
            .collect(),
    };
    results::write_csv(&a.out.join("results.csv"), &rows, threads, &info.commit)?;
    let names: Vec<&str> = backends.iter().map(|b| b.name()).collect();
    let (err, time) = summary::figures(&rows, &names);
    err.write(&a.out, "error_vs_time")?;
    crate::output::write(a.out.join("time_vs_samples.svg"), time.svg()?)?;
    let md = summary::summary_md(&rows, &info);
    crate::output::write(a.out.join("summary.md"), &md)?;
    println!("\n{md}");
    println!(
        "wrote {0}/results.csv, error_vs_time.png, error_vs_time.svg, time_vs_samples.svg, summary.md ({1:.0} s)",
        a.out.display(),
        info.wall_s
    );
    report_check(&a.out, &names)
}

/// `git describe --always --dirty` of the current folder, or `unknown`.
fn git_commit() -> String {
    std::process::Command::new("git")
        .args(["describe", "--always", "--dirty"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "unknown".into())
}

/// The CPU model from `/proc/cpuinfo`, or the architecture.
fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|t| {
            t.lines()
                .find(|l| l.starts_with("model name"))
                .and_then(|l| l.split_once(':'))
                .map(|(_, v)| v.trim().to_string())
        })
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}
