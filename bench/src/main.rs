//! `ratfit-bench`: the benchmarks without the rest of `ratfit` (the same
//! commands as `ratfit bench ...`).

use anyhow::Result;
use clap::Parser;

/// The benchmarks of ratfit: fit, fidelity, render, paper, rgl, gpu, check.
#[derive(Parser)]
#[command(name = "ratfit-bench", version)]
struct Cli {
    #[command(flatten)]
    bench: ratfit_bench::BenchArgs,
}

fn main() {
    ratfit_bench::process::exit_quietly_on_broken_pipe();
    ratfit_bench::process::install();
    if let Err(e) = run() {
        eprintln!("error: {}", ratfit_bench::output::chain_text(&e));
        std::process::exit(1);
    }
}

fn run() -> Result<()> {
    ratfit_bench::run_bench(Cli::parse().bench)
}
