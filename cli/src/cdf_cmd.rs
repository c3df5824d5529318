//! `ratfit cdf` and `ratfit sample-stats`: rational inverse CDFs of a material
//! and the variance of the three samplers.

use crate::brdf_cmd::{load_fitted, load_material, read_json};
use anyhow::{bail, Context, Result};
use brdf::Brdf;
use cdf::{
    compare_samplers, fit_table, fit_table_to_variance, CdfFitReport, CdfFitSettings, CdfTable,
    CosineSampler, RationalCdf, RationalSampler, Sampler, SamplerRow, TableSettings,
    TabulatedSampler,
};
use clap::Args;
use rational_core::FitSettings;
use serde::{Deserialize, Serialize};
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

/// What `ratfit cdf` writes.
#[derive(Serialize, Deserialize)]
pub struct CdfFile {
    /// The fitted inverse CDFs.
    pub cdf: RationalCdf,
    /// The table they were fitted to (rebuilt for the tabulated sampler).
    pub table: TableSettings,
    /// The fit report.
    #[serde(skip_deserializing)]
    pub report: Option<CdfFitReport>,
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
            match load_fitted(&value, path) {
                Some(f) => Ok(Box::new(f?)),
                None => bail!(
                    "{} is not a BRDF fit; give --format merl or rgl for a measured file",
                    path.display()
                ),
            }
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
        .with_engine(FitSettings::default().with_cancel(crate::interrupt::flag()));
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

pub fn read_cdf(path: &Path) -> Result<CdfFile> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    // Deserialisation checks the inverse CDFs and the table settings.
    serde_json::from_str(&text).with_context(|| {
        format!(
            "{} is not written by `ratfit cdf`, or fails its checks",
            path.display()
        )
    })
}

/// Rows of `sample-stats` as text.
pub fn format_rows(rows: &[SamplerRow]) -> String {
    let mut s = format!(
        "{:>5} {:<10} {:>10} {:>8} {:>11} {:>11} {:>11} {:>10} {:>10}\n",
        "view", "sampler", "bytes", "ns/smp", "var R", "var G", "var B", "mean G", "quad G"
    );
    for r in rows {
        let e = &r.estimate;
        s.push_str(&format!(
            "{:>5.0} {:<10} {:>10} {:>8.0} {:>11.3e} {:>11.3e} {:>11.3e} {:>10.5} {:>10.5}\n",
            r.view_deg,
            r.sampler,
            r.bytes,
            e.ns_per_sample,
            e.variance[0],
            e.variance[1],
            e.variance[2],
            e.mean[1],
            r.reference.value[1]
        ));
    }
    s
}

pub fn run_stats(args: StatsArgs) -> Result<()> {
    let file = read_cdf(&args.cdf)?;
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
    print!("{}", format_rows(&rows));
    if let Some(path) = args.csv {
        crate::output::write(&path, csv_rows(&material.name(), &rows))?;
        eprintln!("wrote {}", path.display());
    }
    Ok(())
}

/// CSV of comparison rows (one header line).
pub fn csv_rows(material: &str, rows: &[SamplerRow]) -> String {
    let mut s = String::from(
        "material,view_deg,sampler,bytes,samples,ns_per_sample,mean_r,mean_g,mean_b,var_r,var_g,var_b,quad_r,quad_g,quad_b\n",
    );
    for r in rows {
        let e = &r.estimate;
        s.push_str(&format!(
            "{material},{},{},{},{},{:.1},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e},{:e}\n",
            r.view_deg,
            r.sampler,
            r.bytes,
            e.samples,
            e.ns_per_sample,
            e.mean[0],
            e.mean[1],
            e.mean[2],
            e.variance[0],
            e.variance[1],
            e.variance[2],
            r.reference.value[0],
            r.reference.value[1],
            r.reference.value[2]
        ));
    }
    s
}
