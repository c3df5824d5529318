//! `ratfit`: fit data with rational functions inside error bounds.

mod batch;
mod brdf_cmd;
mod cdf_cmd;
mod demo;
mod render_cmd;

use ratfit_bench::{args, numeric_csv, output, process, progress, slices};

use anyhow::{bail, Context, Result};
use clap::{Args, Parser, Subcommand};
use rational_core::{
    fit, Backend, BasisFamily, FitReport, FitSettings, Fitter, IntervalData, PoleControl,
    RationalFunction, Search, Selection,
};
use std::path::{Path, PathBuf};

#[derive(Parser)]
#[command(
    name = "ratfit",
    version,
    about = "Rational fits inside interval (error-bound) constraints"
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Fit CSV data (x_1..x_d, value; or x_1..x_d, lo, hi with --intervals).
    FitCsv {
        #[command(flatten)]
        data: DataArgs,
        #[command(flatten)]
        fit: FitArgs,
        /// Print the report as JSON instead of a table.
        #[arg(long)]
        json: bool,
        /// Where to write the fit (JSON).
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
    },
    /// Fit a measured BRDF (each RGB channel) and print the error report.
    Fit(brdf_cmd::FitArgs),
    /// Fit every material of a manifest (TOML) with its `ratfit fit`
    /// options: outputs keyed by content, skipped when present, written
    /// atomically; `--shard I/N` for job arrays; `summary.csv` at the end.
    Batch(batch::BatchArgs),
    /// Evaluate a fit: at points (CSV x_1..x_d, for `fit-csv` fits; one value
    /// per row) or at direction pairs (CSV theta_i,phi_i,theta_o,phi_o, for
    /// `fit` fits; r,g,b per row).
    Eval {
        /// A fit written by `fit-csv` or `fit`.
        fit: PathBuf,
        /// Points, one per row.
        #[arg(long, conflicts_with = "directions")]
        points: Option<PathBuf>,
        /// Direction pairs in radians (z is the normal), one per row.
        #[arg(long)]
        directions: Option<PathBuf>,
    },
    /// Export a BRDF fit: shader source (wgsl, glsl), an ALTA rational
    /// function file (alta; fits in radians) or the compact f32 binary.
    Export {
        /// A fit written by `ratfit fit`.
        fit: PathBuf,
        /// wgsl, glsl, alta or binary.
        #[arg(long)]
        to: String,
        /// Output file (default: standard output for shader source).
        #[arg(short = 'o', long = "output")]
        output: Option<PathBuf>,
    },
    /// Plot theta_h slices of the data and of a BRDF fit at several theta_d
    /// (log scale, slice phi_d = pi/2): dots are data, lines the fit.
    Plot {
        /// A fit written by `ratfit fit`.
        fit: PathBuf,
        /// The measured material the fit came from.
        material: PathBuf,
        /// Its format: merl or rgl.
        #[arg(long)]
        format: brdf::TableFormat,
        /// Channel: r, g or b.
        #[arg(long, default_value = "g", value_parser = ["r", "g", "b"])]
        channel: String,
        /// Output PNG.
        #[arg(short = 'o', long = "output")]
        output: PathBuf,
    },
    /// Write G and h of one P(n_p, n_q) instance as .npy files.
    DumpQp {
        #[command(flatten)]
        data: DataArgs,
        /// Basis family.
        #[arg(long, default_value = "chebyshev")]
        basis: BasisFamily,
        /// The split, as NP,NQ.
        #[arg(long)]
        split: String,
        /// Output folder.
        #[arg(long)]
        out: PathBuf,
    },
    /// Fit a built-in "measured" material (an analytic BRDF tabulated on the
    /// MERL grid with noise and missing grazing cells), print the report and
    /// write a sphere render: data on the left, fit on the right.
    Demo {
        /// Instead, fit steep specular-like 1-D and 2-D functions (the engine alone).
        #[arg(long)]
        engine: bool,
        /// Folder for the picture.
        #[arg(long, default_value = ".")]
        out: PathBuf,
    },
    /// Fit rational inverse CDFs of a material for importance sampling and
    /// print the fit report.
    Cdf(cdf_cmd::CdfArgs),
    /// Variance and cost of the cosine, tabulated and rational samplers:
    /// albedo estimates at equal sample count against quadrature.
    SampleStats(cdf_cmd::StatsArgs),
    /// Benchmarks: `ratfit bench fit [--quick] [--out DIR]` reports error
    /// against run time for every compiled backend.
    Bench(ratfit_bench::BenchArgs),
    /// Render a scene (TOML) to PNG and/or OpenEXR, preparing only the
    /// materials, fits and inverse CDFs the scene needs.
    Render(render_cmd::RenderArgs),
    /// Compare two linear images: mean and max CIELAB differences (CIE76,
    /// CIEDE2000), RMSE, and a false-colour difference image.
    Compare(render_cmd::CompareArgs),
    /// List the solver backends compiled into this build.
    Backends,
}

#[derive(Args)]
struct DataArgs {
    /// CSV file.
    data: PathBuf,
    /// Number of coordinates (default: columns minus 1, or minus 2 with --intervals).
    #[arg(long)]
    dims: Option<usize>,
    /// Columns after the coordinates are lo, hi instead of a value.
    #[arg(long)]
    intervals: bool,
    /// Relative half-width of the intervals around the values (default 0.01).
    #[arg(long, conflicts_with = "abs_tol", value_parser = args::relative_tolerance)]
    rel_tol: Option<f64>,
    /// Absolute half-width of the intervals around the values.
    #[arg(long, value_parser = args::positive)]
    abs_tol: Option<f64>,
}

#[derive(Args)]
struct FitArgs {
    /// Basis family: chebyshev, legendre or monomial.
    #[arg(long, default_value = "chebyshev")]
    basis: BasisFamily,
    /// Smallest coefficient budget n_p + n_q.
    #[arg(long, default_value_t = 2, value_parser = args::coefficients)]
    min_coeffs: usize,
    /// Largest coefficient budget n_p + n_q.
    #[arg(long, default_value_t = 40, value_parser = args::coefficients)]
    max_coeffs: usize,
    /// Solver backend (see `ratfit backends`).
    #[arg(long, default_value = "native")]
    backend: Backend,
    /// How to choose among feasible splits: condition or depth.
    #[arg(long, default_value = "condition")]
    selection: Selection,
    /// How to visit the splits: exhaustive (every split of every budget),
    /// staircase (the same smallest budget and splits in far fewer solves)
    /// or probe (five splits per budget, doubling then bisection: fewest
    /// solves, a small budget but not always the smallest).
    #[arg(long, default_value = "exhaustive")]
    search: Search,
    /// Poles between samples: none, grid (dense-grid check) or bernstein (certificate).
    #[arg(long, default_value = "grid")]
    poles: PoleControl,
    /// Widen the intervals by this factor when nothing is feasible...
    #[arg(long, default_value_t = 2.0, value_parser = args::positive)]
    widen: f64,
    /// ...at most this many times.
    #[arg(long, default_value_t = 0)]
    max_widenings: usize,
    /// Degree weights of the basis order, one per coordinate (`1,2`: a
    /// unit of degree in the second coordinate costs twice as much).
    #[arg(long, value_delimiter = ',')]
    degree_weights: Vec<u16>,
    /// Return the chosen split's least-squares fit within the intervals
    /// (residuals in half-widths, every constraint kept with a fifth of
    /// the largest margin) instead of its point of largest margin.
    #[arg(long)]
    centred: bool,
}

impl FitArgs {
    fn settings(&self) -> Result<FitSettings> {
        let mut s = FitSettings::default()
            .with_family(self.basis)
            .with_coeff_range(self.min_coeffs, self.max_coeffs)?
            .with_backend(self.backend)?
            .with_selection(self.selection)
            .with_search(self.search)
            .with_pole_control(self.poles)
            .with_centred_fit(self.centred)
            .with_cancel(process::flag());
        if self.max_widenings > 0 {
            s = s.with_widening(self.widen, self.max_widenings)?;
        }
        if !self.degree_weights.is_empty() {
            s = s.with_degree_weights(self.degree_weights.clone())?;
        }
        if let Some(bar) = progress::sweep_bar() {
            s = s.with_progress(bar);
        }
        Ok(s)
    }
}

impl DataArgs {
    fn load(&self) -> Result<IntervalData> {
        let rows = numeric_csv::read_numeric(&self.data)?;
        let width = rows[0].len();
        let extra = if self.intervals { 2 } else { 1 };
        let dims = self.dims.unwrap_or(width.saturating_sub(extra));
        if dims == 0 || dims + extra != width {
            bail!(
                "{}: {width} columns, but {dims} coordinates + {} need {}",
                self.data.display(),
                if self.intervals { "lo, hi" } else { "a value" },
                dims + extra
            );
        }
        let points: Vec<f64> = rows.iter().flat_map(|r| r[..dims].to_vec()).collect();
        let data = if self.intervals {
            if self.rel_tol.is_some() || self.abs_tol.is_some() {
                bail!("--rel-tol/--abs-tol do not apply to --intervals data");
            }
            IntervalData::new(
                dims,
                points,
                rows.iter().map(|r| r[dims]).collect(),
                rows.iter().map(|r| r[dims + 1]).collect(),
            )?
        } else {
            let values = rows.iter().map(|r| r[dims]).collect();
            match self.abs_tol {
                Some(a) => IntervalData::from_values_absolute(dims, points, values, a)?,
                None => IntervalData::from_values_relative(
                    dims,
                    points,
                    values,
                    self.rel_tol.unwrap_or(0.01),
                )?,
            }
        };
        Ok(data)
    }
}

fn load_function(value: &serde_json::Value, path: &Path) -> Result<RationalFunction> {
    let f = value
        .get("function")
        .cloned()
        .unwrap_or_else(|| value.clone());
    serde_json::from_value(f)
        .with_context(|| format!("{} does not hold a rational function", path.display()))
}

/// `ratfit eval`: a fit at points or at direction pairs.
fn run_eval(path: &Path, points: Option<PathBuf>, directions: Option<PathBuf>) -> Result<()> {
    let value = brdf_cmd::read_json(path)?;
    if brdf::FitFile::is_fit_file(&value) {
        let fitted = brdf::FitFile::from_value(value, path)?.brdf;
        let dirs = directions.context("a BRDF fit is evaluated at --directions")?;
        print!(
            "{}",
            brdf_cmd::eval_directions(&fitted, &numeric_csv::read_numeric(&dirs)?)?
        );
        return Ok(());
    }
    let f = load_function(&value, path)?;
    let points = points.context("a fit-csv fit is evaluated at --points")?;
    let rows = numeric_csv::read_numeric(&points)?;
    if rows[0].len() != f.dim() {
        bail!(
            "{}: {} columns, the fit takes {} coordinates",
            points.display(),
            rows[0].len(),
            f.dim()
        );
    }
    let mut out = String::with_capacity(rows.len() * 24);
    for r in &rows {
        out.push_str(&format!("{:e}\n", f.eval(r)));
    }
    print!("{out}");
    Ok(())
}

/// `ratfit export`: shader source, ALTA text or the compact binary.
fn run_export(path: &Path, to: &str, output: Option<PathBuf>) -> Result<()> {
    let fitted = brdf_cmd::read_fitted(path)?;
    let compact = brdf::CompactBrdf::from_fitted(&fitted);
    if matches!(to, "wgsl" | "glsl" | "binary") {
        if let Some(what) = compact.first_non_finite() {
            bail!(
                "{}: {what} is beyond the f32 range, so the f32 form ({to}) cannot hold this fit",
                path.display()
            );
        }
    }
    let bytes = match to {
        "wgsl" => brdf::shader::shader_source(&compact, brdf::shader::Language::Wgsl).into_bytes(),
        "glsl" => brdf::shader::shader_source(&compact, brdf::shader::Language::Glsl).into_bytes(),
        "binary" => compact.to_bytes(),
        "alta" => brdf::AltaRational::from_fitted(&fitted)
            .map_err(|e| {
                // The library names no flag; the way out, in `ratfit fit`'s.
                let hint = if fitted.lobe.is_some() {
                    " (`ratfit fit` without --lobe)"
                } else if fitted.shell.is_some() {
                    " (`ratfit fit --no-render-check`, or without --perceptual, keeps the fit without it)"
                } else if !fitted.mode.is_rgb() {
                    " (`ratfit fit --colour rgb`)"
                } else if fitted.reduction.coordinates != brdf::Coordinates::Radians {
                    " (`ratfit fit --coords radians`)"
                } else {
                    ""
                };
                anyhow::anyhow!("{}: {e}{hint}", path.display())
            })?
            .to_text(&format!("ratfit export {} --to alta", path.display()))
            .into_bytes(),
        other => bail!("unknown export `{other}` (wgsl, glsl, alta, binary)"),
    };
    match output {
        Some(o) => {
            crate::output::write(&o, &bytes)?;
            eprintln!("wrote {} ({} bytes)", o.display(), bytes.len());
        }
        None if to == "binary" => bail!("give -o FILE for binary output"),
        None => print!("{}", String::from_utf8_lossy(&bytes)),
    }
    Ok(())
}

/// `ratfit dump-qp`: G and h of one split as .npy files.
fn run_dump_qp(data: DataArgs, basis: BasisFamily, split: &str, out: &Path) -> Result<()> {
    let d = data.load()?;
    let (np, nq) = split
        .split_once(',')
        .and_then(|(a, b)| {
            Some((
                a.trim().parse::<usize>().ok()?,
                b.trim().parse::<usize>().ok()?,
            ))
        })
        .with_context(|| format!("--split `{split}` is not NP,NQ"))?;
    let settings = FitSettings::default()
        .with_family(basis)
        .with_pole_control(PoleControl::None)
        .with_value_scaling(false);
    let p = Fitter::new(&d).settings(settings).problem(np, nq)?;
    std::fs::create_dir_all(out).with_context(|| format!("cannot create {}", out.display()))?;
    output::write_npy(&out.join("G.npy"), &[p.rows(), p.cols()], &p.g())?;
    output::write_npy(&out.join("h.npy"), &[p.rows()], p.h())?;
    println!(
        "wrote {}/G.npy ({} x {}) and h.npy: minimise ||c||^2 s.t. G c >= h, c = (a[0..{np}], b[0..{nq}]), {basis} basis on the data's bounding box",
        out.display(),
        p.rows(),
        p.cols()
    );
    Ok(())
}

fn main() {
    process::exit_quietly_on_broken_pipe();
    process::install();
    let Err(e) = run(Cli::parse()) else {
        return;
    };
    progress::finish();
    if process::requested() {
        eprintln!(
            "interrupted: {}; the interrupted fit wrote nothing",
            output::chain_text(&e)
        );
        std::process::exit(process::EXIT_INTERRUPTED);
    }
    eprintln!("error: {}", output::chain_text(&e));
    if let Some(hint) = flag_hint(&e) {
        eprintln!("  ({hint})");
    }
    std::process::exit(1);
}

/// The library's "no feasible fit" names no flag; the CLI adds its own.
fn flag_hint(e: &anyhow::Error) -> Option<&'static str> {
    let empty_sweep = e.chain().any(|c| {
        matches!(
            c.downcast_ref::<rational_core::FitError>(),
            Some(rational_core::FitError::NoFeasibleFit { .. })
        )
    });
    empty_sweep.then_some("flags: --max-coeffs raises the budget, --rel-tol widens the intervals")
}

fn run(cli: Cli) -> Result<()> {
    match cli.command {
        Command::FitCsv {
            data,
            fit: args,
            json,
            output,
        } => {
            let d = data.load()?;
            let settings = args.settings()?;
            let report = fit(&d, &settings);
            progress::finish();
            let report: FitReport = report?;
            if json {
                println!("{}", serde_json::to_string_pretty(&report)?);
            } else {
                println!("{report}");
            }
            crate::output::write(&output, serde_json::to_string_pretty(&report)?)?;
            eprintln!("wrote {}", output.display());
        }
        Command::Fit(args) => brdf_cmd::run_fit(args)?,
        Command::Batch(args) => batch::run_batch(args)?,
        Command::Cdf(args) => cdf_cmd::run_cdf(args)?,
        Command::SampleStats(args) => cdf_cmd::run_stats(args)?,
        Command::Bench(args) => ratfit_bench::run_bench(args)?,
        Command::Render(args) => render_cmd::run_render(args)?,
        Command::Compare(args) => render_cmd::run_compare(args)?,
        Command::Eval {
            fit: path,
            points,
            directions,
        } => run_eval(&path, points, directions)?,
        Command::Export {
            fit: path,
            to,
            output,
        } => run_export(&path, &to, output)?,
        Command::Plot {
            fit: path,
            material,
            format,
            channel,
            output,
        } => {
            let fitted = brdf_cmd::read_fitted(&path)?;
            let data = format.read(&material)?;
            let c = "rgb"
                .find(channel.as_str())
                .expect("clap checks the channel");
            let degs = slices::theta_d_deg(&fitted);
            slices::draw(data.as_ref(), &fitted, c, &degs, &output)?;
            eprintln!(
                "wrote {} (theta_d = {degs:?} degrees; dots: data, lines: fit)",
                output.display()
            );
        }
        Command::DumpQp {
            data,
            basis,
            split,
            out,
        } => run_dump_qp(data, basis, &split, &out)?,
        Command::Demo { engine, out } => {
            if engine {
                demo::run_engine()?
            } else {
                demo::run_brdf(&out)?
            }
        }
        Command::Backends => {
            for b in Backend::ALL {
                println!(
                    "{:<9} {}",
                    b.name(),
                    if b.is_compiled() {
                        "compiled"
                    } else {
                        "not compiled (cargo feature)"
                    }
                );
            }
        }
    }
    Ok(())
}
