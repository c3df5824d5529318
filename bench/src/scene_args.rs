//! Flags shared by `ratfit render` and `ratfit bench render`: scene
//! overrides, the image size, and the row progress bar.

use anyhow::{Context, Result};
use clap::Args;
use render_cpu::{RenderOptions, SamplerKind};
use std::path::PathBuf;

/// Scene overrides shared by `render` and `bench render`.
#[derive(Args, Clone)]
pub struct OverrideArgs {
    /// Image size as WIDTHxHEIGHT.
    #[arg(long)]
    pub resolution: Option<String>,
    /// Samples per pixel (1..=2^20).
    #[arg(long, value_parser = crate::args::spp)]
    pub spp: Option<usize>,
    /// Seed of the random streams.
    #[arg(long)]
    pub seed: Option<u64>,
    /// BRDF sampling: cosine, tabulated or rational.
    #[arg(long)]
    pub sampler: Option<SamplerKind>,
    /// Multiple importance sampling: true or false.
    #[arg(long)]
    pub mis: Option<bool>,
    /// Objects using material A use material B instead (A=B; repeatable).
    #[arg(long = "swap")]
    pub swaps: Vec<String>,
    /// Cache folder for fits and inverse CDFs (default: $RATFIT_CACHE,
    /// $XDG_CACHE_HOME/ratfit or ~/.cache/ratfit).
    #[arg(long)]
    pub cache: Option<PathBuf>,
    /// Neither read nor write cached fits.
    #[arg(long)]
    pub no_cache: bool,
}

impl OverrideArgs {
    /// The library's options.
    pub fn options(&self) -> Result<RenderOptions> {
        let resolution = self
            .resolution
            .as_deref()
            .map(parse_resolution)
            .transpose()?;
        let swaps = self
            .swaps
            .iter()
            .map(|s| parse_swap(s, "--swap"))
            .collect::<Result<_>>()?;
        Ok(RenderOptions {
            resolution,
            spp: self.spp,
            seed: self.seed,
            sampler: self.sampler,
            mis: self.mis,
            swaps,
            cache_dir: self.cache.clone(),
            no_cache: self.no_cache,
        })
    }
}

/// Parses a swap `A=B` given to `flag`.
pub fn parse_swap(s: &str, flag: &str) -> Result<(String, String)> {
    s.split_once('=')
        .map(|(a, b)| (a.to_string(), b.to_string()))
        .with_context(|| format!("{flag} `{s}` is not A=B"))
}

/// Parses WIDTHxHEIGHT.
pub fn parse_resolution(r: &str) -> Result<(usize, usize)> {
    let (w, h) = r
        .split_once('x')
        .with_context(|| format!("--resolution `{r}` is not WIDTHxHEIGHT"))?;
    Ok((
        w.trim()
            .parse()
            .with_context(|| format!("width in `{r}`"))?,
        h.trim()
            .parse()
            .with_context(|| format!("height in `{r}`"))?,
    ))
}

/// What `--gpu` says in a build without the GPU renderer.
pub const NO_GPU: &str = "this ratfit was built without the GPU renderer; rebuild with `cargo build --release -p ratfit-cli --features gpu`";

/// A progress bar over image rows on standard error (terminals only).
pub fn row_bar() -> impl Fn(usize, usize) + Sync {
    let bar = crate::progress::count_bar("render rows");
    move |done: usize, total: usize| {
        if done % 8 == 0 || done == total {
            bar(done, total);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn swaps_are_a_equals_b_and_errors_name_the_flag() {
        assert_eq!(
            parse_swap("table=table_fit", "--swap").unwrap(),
            ("table".to_string(), "table_fit".to_string())
        );
        let e = parse_swap("table", "--rational-swap").unwrap_err();
        assert!(e.to_string().contains("--rational-swap `table` is not A=B"));
    }
}
