//! `ratfit cdf` and `ratfit sample-stats`: rational inverse CDFs of a material
//! and the variance of the three samplers.

use crate::brdf_cmd::{load_material, read_json};
use anyhow::{bail, Context, Result};
use brdf::Brdf;
use cdf::{
    compare_samplers, fit_table, fit_table_to_variance, CdfFile, CdfFitSettings, CdfTable,
    CosineSampler, RationalSampler, Sampler, SamplerRow, TableSettings, TabulatedSampler,
};
use clap::Args;
use rational_core::FitSettings;
use serde::Serialize;
use std::path::{Path, PathBuf};

/// Options of `ratfit cdf`.
#[derive(Args)]
pub struct CdfArgs {
    /// The material: a measured file, or a fit written by `ratfit fit`.
    material: PathBuf,
    /// Its format: merl, rgl or fit.
    #[arg(long)]
    format: String,
    /// View elevations tabulated (evenly on [0, --max-view]).
    #[arg(long, default_value_t = 16)]
    views: usize,
    /// Largest view elevation fitted (degrees); beyond it the last is used
    /// (still unbiased, with more variance).
    #[arg(long, default_value_t = 80.0)]
    max_view: f64,
    /// Table cells as NT,NP (theta_l on [0, 90] degrees, phi_l on [0, 180]).
    #[arg(long, default_value = "64,64")]
    cells: String,
    /// Half-width of the fitting intervals in CDF space (doubled when no
    /// budget is feasible).
    #[arg(long, default_value_t = 0.05)]
    tol: f64,
    /// Largest coefficient budgets as THETA,PHI.
    #[arg(long, default_value = "64,120")]
    max_coeffs: String,
    /// Choose the tolerance by the variance it causes: halve `--tol` (at
    /// most four times) until the rational sampler's variance is within
    /// this factor of the tabulated sampler's (views 0, 30, 60, 75 degrees,
    /// 200,000 samples each); the report lists every tolerance tried. The
    /// default, 1.4, leaves room for the estimate's own noise below 1.5
    /// (glossy files' estimates differ by 5% to 10% between seeds).
    #[arg(long, default_value_t = 1.4, value_parser = crate::args::ratio)]
    max_variance_ratio: f64,
    /// Fit at `--tol` alone, without measuring the variance (faster; the
    /// variance may then exceed `--max-variance-ratio`).
    #[arg(long, conflicts_with = "max_variance_ratio")]
    fixed_tol: bool,
    /// Output (JSON: the inverse CDFs, the table settings and the report).
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
}

/// Options of `ratfit sample-stats`.
#[derive(Args)]
pub struct StatsArgs {
    /// Inverse CDFs written by `ratfit cdf`.
    cdf: PathBuf,
    /// The material the estimates integrate: a fit from `ratfit fit`, or a
    /// measured file with --format.
    material: PathBuf,
    /// Format of a measured material (merl or rgl).
    #[arg(long)]
    format: Option<String>,
    /// Samples per estimate.
    #[arg(long, default_value_t = 100_000, value_parser = crate::args::samples)]
    samples: usize,
    /// View elevations in degrees, comma-separated.
    #[arg(long, default_value = "0,30,60,80")]
    views: String,
    /// Seed of the uniform numbers.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Also write the rows as CSV.
    #[arg(long)]
    csv: Option<PathBuf>,
}

fn pair(s: &str, what: &str) -> Result<(usize, usize)> {
    s.split_once(',')
        .and_then(|(a, b)| Some((a.trim().parse().ok()?, b.trim().parse().ok()?)))
        .with_context(|| format!("{what} `{s}` is not A,B"))
}

/// A material from a measured file or a `ratfit fit` output.
pub fn material_from(path: &Path, format: Option<&str>) -> Result<Box<dyn Brdf>> {
    match format {
        Some("fit") | None => {
            let value = read_json(path)?;
            if !brdf::FitFile::is_fit_file(&value) {
                bail!(
                    "{} is not a BRDF fit; give --format merl or rgl for a measured file",
                    path.display()
                );
            }
            Ok(Box::new(brdf::FitFile::from_value(value, path)?.brdf))
        }
        Some(f) => load_material(path, f),
    }
}

pub fn run_cdf(args: CdfArgs) -> Result<()> {
    let material = material_from(&args.material, Some(&args.format))?;
    let (nt, np) = pair(&args.cells, "--cells")?;
    let (mt, mp) = pair(&args.max_coeffs, "--max-coeffs")?;
    let table_settings = TableSettings::default()
        .with_views(args.views)?
        .with_cells(nt, np)?
        .with_max_view(args.max_view.to_radians())?;
    let start = std::time::Instant::now();
    let table = CdfTable::new(material.as_ref(), table_settings)?;
    eprintln!(
        "tabulated {} views x {nt} x {np} cells in {:.2} s",
        args.views,
        start.elapsed().as_secs_f64()
    );
    let settings = CdfFitSettings::default()
        .with_tolerance(args.tol, 1e-3)?
        .with_max_coeffs(mt, mp)?
        .with_engine(FitSettings::default().with_cancel(crate::process::flag()));
    let (cdf, report) = match (!args.fixed_tol).then_some(args.max_variance_ratio) {
        None => fit_table(&table, &settings)?,
        Some(ratio) => {
            let (cdf, report, steps) = fit_table_to_variance(
                material.as_ref(),
                &table,
                &settings,
                ratio,
                cdf::VARIANCE_HALVINGS,
                cdf::VARIANCE_SAMPLES,
            )?;
            for s in &steps {
                if s.bytes == 0 {
                    println!(
                        "cdf tolerance {:<9} no fit within the budgets",
                        s.cdf_tolerance
                    );
                } else {
                    println!(
                        "cdf tolerance {:<9} {:>5} bytes, variance {:.2}x the tabulated sampler's",
                        s.cdf_tolerance, s.bytes, s.variance_ratio
                    );
                }
            }
            let kept = steps
                .iter()
                .find(|s| s.variance_ratio <= ratio)
                .or_else(|| {
                    steps
                        .iter()
                        .min_by(|a, b| a.variance_ratio.total_cmp(&b.variance_ratio))
                });
            if let Some(k) = kept {
                let verdict = if k.variance_ratio <= ratio {
                    format!("within the {ratio}x asked")
                } else {
                    format!("ABOVE the {ratio}x asked (the smallest reached)")
                };
                println!(
                    "kept tolerance {}: variance {:.2}x the tabulated sampler's, {verdict}",
                    k.cdf_tolerance, k.variance_ratio
                );
            }
            (cdf, report)
        }
    };
    println!("{report}");
    let file = CdfFile {
        cdf,
        table: table_settings,
        report: Some(report),
    };
    crate::output::write(&args.output, serde_json::to_string_pretty(&file)?)?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}

pub fn run_stats(args: StatsArgs) -> Result<()> {
    let file = CdfFile::read(&args.cdf)?;
    let material = material_from(&args.material, args.format.as_deref())?;
    let views: Vec<f64> = args
        .views
        .split(',')
        .map(|v| v.trim().parse::<f64>())
        .collect::<Result<_, _>>()
        .with_context(|| format!("--views `{}` is not a list of degrees", args.views))?;
    if let Some(v) = views.iter().find(|v| !(0.0..90.0).contains(*v)) {
        bail!("view elevation {v} is outside [0, 90) degrees");
    }
    let table = CdfTable::new(material.as_ref(), file.table)?;
    let tabulated = TabulatedSampler::new(table);
    let rational = RationalSampler::new(file.cdf);
    let samplers: [&dyn Sampler; 3] = [&CosineSampler, &tabulated, &rational];
    // One view at a time (its quadrature once, every sampler), so that long
    // runs (up to 1e10 samples) show where they are.
    let bar = crate::progress::count_bar("views");
    let mut rows = Vec::with_capacity(views.len() * samplers.len());
    for (k, &view) in views.iter().enumerate() {
        bar(k, views.len());
        rows.extend(compare_samplers(
            material.as_ref(),
            &samplers,
            &[view],
            args.samples,
            args.seed,
        ));
    }
    bar(views.len(), views.len());
    println!(
        "{}: {} samples per estimate; variance of one sample of rho cos / pdf per channel",
        material.name(),
        args.samples
    );
    print!("{}", cdf::stats::rows_text(&rows));
    if let Some(path) = args.csv {
        let name = material.name();
        crate::output::write_csv(&path, rows.iter().map(|r| CsvRow::of(&name, r)))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// One CSV row of `sample-stats --csv`.
#[derive(Serialize)]
struct CsvRow<'a> {
    material: &'a str,
    view_deg: f64,
    sampler: &'a str,
    bytes: usize,
    samples: usize,
    ns_per_sample: f64,
    mean_r: f64,
    mean_g: f64,
    mean_b: f64,
    var_r: f64,
    var_g: f64,
    var_b: f64,
    quad_r: f64,
    quad_g: f64,
    quad_b: f64,
}

impl<'a> CsvRow<'a> {
    fn of(material: &'a str, r: &'a SamplerRow) -> Self {
        let (e, q) = (&r.estimate, &r.reference.value);
        Self {
            material,
            view_deg: r.view_deg,
            sampler: &r.sampler,
            bytes: r.bytes,
            samples: e.samples,
            ns_per_sample: e.ns_per_sample,
            mean_r: e.mean[0],
            mean_g: e.mean[1],
            mean_b: e.mean[2],
            var_r: e.variance[0],
            var_g: e.variance[1],
            var_b: e.variance[2],
            quad_r: q[0],
            quad_g: q[1],
            quad_b: q[2],
        }
    }
}
