//! The flags of the benchmark targets: `cargo bench -p ratfit-bench --bench
//! NAME -- [--quick] [--out DIR]`.

use anyhow::{Context, Result};
use clap::Parser;
use std::path::PathBuf;

/// Flags of a benchmark target.
#[derive(Parser, Debug)]
pub struct TargetArgs {
    /// A small run (fewer materials, samples or pairs) for CI and a first
    /// look.
    #[arg(long)]
    pub quick: bool,
    /// Output folder for the CSV and the charts; a relative path is taken
    /// from `bench/`, where cargo runs benchmarks.
    #[arg(long, default_value = "target/bench")]
    pub out: PathBuf,
    /// Passed by `cargo bench` to every target; nothing to do.
    #[arg(long, hide = true)]
    bench: bool,
}

impl TargetArgs {
    /// The flags of this process, with the output folder created.
    ///
    /// # Errors
    /// The folder cannot be created (clap exits on unknown flags itself).
    pub fn from_env() -> Result<Self> {
        let args = Self::parse();
        std::fs::create_dir_all(&args.out)
            .with_context(|| format!("cannot create {}", args.out.display()))?;
        Ok(args)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cargo_bench_flag_is_accepted_and_unknown_flags_are_not() {
        let a =
            TargetArgs::try_parse_from(["sampling", "--bench", "--quick", "--out", "x"]).unwrap();
        assert!(a.quick);
        assert_eq!(a.out, PathBuf::from("x"));
        let d = TargetArgs::try_parse_from(["sampling"]).unwrap();
        assert!(!d.quick && d.out == std::path::Path::new("target/bench"));
        assert!(TargetArgs::try_parse_from(["sampling", "--oot", "x"]).is_err());
    }
}
