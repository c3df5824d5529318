//! `ratfit fit` and `ratfit eval --directions`: measured BRDFs to rational fits.

use anyhow::{bail, Context, Result};
use brdf::{
    fit_brdf, fit_samples, AltaData, Brdf, BrdfFitSettings, Coordinates, FittedBrdf, Reduction,
    ReductionKind, ScatteredBrdf,
};
use clap::Args;
use rational_core::{Backend, FitSettings, PoleControl, Search};
use std::path::{Path, PathBuf};

/// Options of `ratfit fit`.
#[derive(Args, Clone)]
pub struct FitArgs {
    /// The measured material file.
    material: PathBuf,
    /// File format: merl, rgl, cornell (scattered spectral samples) or alta
    /// (ALTA text data, fitted in the file's own parametrisation).
    #[arg(long)]
    format: String,
    /// 2 (rho(theta_h, theta_d)) or 3 (theta_h, theta_d, phi_d). Default:
    /// 2, and with `--target-de` the slice and the 3-D grid (the slice
    /// first when the table seen through it reaches the target).
    #[arg(long)]
    dims: Option<usize>,
    /// 2-D only: use the spread over phi_d as the interval instead of the phi_d = pi/2 slice.
    #[arg(long)]
    spread: bool,
    /// Fitting coordinates: sqrt (MERL warp of theta_h), radians or cosines.
    #[arg(long, default_value = "sqrt")]
    coords: String,
    /// Relative half-width of the intervals, in (0, 1).
    #[arg(long, default_value_t = 0.05, value_parser = crate::args::relative_tolerance)]
    rel_tol: f64,
    /// Smallest half-width as a fraction of each channel's median value (noise floor).
    #[arg(long, default_value_t = 1e-2, value_parser = crate::args::fraction)]
    noise_floor: f64,
    /// Largest coefficient budget per channel (default 60, and 120 with
    /// `--target-de`, which, unless this is given, doubles it once for the
    /// best search where it rather than `--max-bytes` stopped that search
    /// within twice the target).
    #[arg(long, value_parser = crate::args::coefficients)]
    max_coeffs: Option<usize>,
    /// Samples with theta_d above this (degrees, in (0, 90]) are not fitted.
    #[arg(long, default_value_t = 78.0, value_parser = crate::args::angle_deg)]
    max_theta_d: f64,
    /// Cells with either direction further than this from the normal
    /// (degrees, in (0, 90]) are not sampled, and evaluation moves such
    /// directions onto the cut. Default: 70 with plain intervals; the whole
    /// hemisphere with `--perceptual` and `--target-de` unless given (a cut
    /// of 70 or 75 lowers the render error of some 3-D fits at the
    /// silhouette: docs/guide/fidelity.md).
    #[arg(long, value_parser = crate::args::angle_deg)]
    max_elevation: Option<f64>,
    /// Grid resolution as `NH,ND[,NP]` (theta_h, theta_d, phi_d bins, each
    /// in 2..=4096).
    #[arg(long, value_parser = crate::args::bins)]
    resolution: Option<crate::args::Bins>,
    /// Solver backend.
    #[arg(long, default_value = "native")]
    backend: Backend,
    /// Poles between samples: none, grid or bernstein.
    #[arg(long, default_value = "grid")]
    poles: PoleControl,
    /// How to visit the splits: exhaustive (every split of every budget, the
    /// paper's sweep), staircase (the same smallest budget and splits in
    /// about N log N solves instead of N^2/2; see `rational_core::Search`)
    /// or probe (doubling and bisection of the budget over five splits each,
    /// about 5 log N solves, a small budget but not always the smallest).
    /// Default: staircase (on the eleven RGL files of the test data it
    /// returns the exhaustive sweep's fits, coefficient for coefficient, two
    /// to eight times sooner).
    #[arg(long)]
    search: Option<Search>,
    /// When no budget is feasible, widen every interval half-width by
    /// `--widen-factor` and fit again, at most this many times (the report
    /// names the factor used); 0 asks for the exact intervals or no fit.
    #[arg(long, default_value_t = 6)]
    max_widenings: usize,
    /// Return each function's least-squares fit within its intervals (each
    /// residual in units of its half-width, every constraint kept with a
    /// fifth of the largest margin) instead of the point of largest
    /// margin, whose error swings from bound to bound like a minimax
    /// fit's. Always on with `--target-de`.
    #[arg(long)]
    centred: bool,
    /// The factor of each widening (above 1). Default: 2 for plain
    /// intervals; sqrt 2 with `--perceptual` and `--target-de`, whose
    /// intervals are what the renders show, so the fit stays nearer them
    /// (each widening that still finds nothing costs one more search).
    #[arg(long, value_parser = crate::args::positive)]
    widen_factor: Option<f64>,
    /// Fit to a perceptual budget instead of fixed intervals: the smallest
    /// perceptual fit (whole hemisphere) whose validation renders (a sphere
    /// under three directional lights and under a sky) reach this mean
    /// CIEDE2000 against the table; the 2-D slice and 3-D (grid from
    /// `--resolution`, else 16^3, or 24 x 16 x 8 where the table on 16^3
    /// renders above 3 times the target) unless `--dims` fixes one, the slice
    /// first only when the table seen through it reaches the target;
    /// luminance-chroma, and RGB on the first reduction too when the
    /// chroma ratios limit it, unless `--colour` fixes one. MERL and RGL
    /// files only.
    #[arg(long, conflicts_with_all = ["perceptual", "spread"], value_parser = crate::args::positive)]
    target_de: Option<f64>,
    /// Seconds `--target-de` may spend on fits and renders before it
    /// returns the best fit so far: no fit starts past it once one within
    /// the byte budget is in hand (the last one started may run past it),
    /// and the report names the searches left out.
    #[arg(long, default_value_t = render_cpu::fidelity::TARGET_TIME_BUDGET_S, value_parser = crate::args::positive)]
    time_budget: f64,
    /// With `--target-de`: the most bytes (f32, a shell factor included)
    /// the fit returned may have. Fits over it are tried and listed, never
    /// returned; a tolerance whose fit passes it is followed by looser ones.
    /// Default: no limit (the target decides the size).
    #[arg(long, requires = "target_de", value_parser = crate::args::max_bytes)]
    max_bytes: Option<usize>,
    /// Degree weights of the basis order, one per fitting coordinate
    /// (`theta_h,theta_d[,phi_d]`): `1,2` spends twice the degree on
    /// `theta_h` as on `theta_d` for the same budget. Default: all 1.
    #[arg(long, value_delimiter = ',')]
    degree_weights: Vec<u16>,
    /// Perceptual intervals (`brdf::PerceptualBounds`): `--rel-tol` where
    /// the reflected light is visible, an absolute floor on `f cos_i cos_o`
    /// elsewhere, never tighter than the table's estimated noise, and every
    /// cell of the hemisphere constrained (no grazing cut, and no elevation
    /// cut unless `--max-elevation` gives one).
    #[arg(long)]
    perceptual: bool,
    /// At most this many refits that add the points where the fit exceeds
    /// 1.5x the channel's largest upper bound (its peak) on a dense grid of
    /// the whole domain it is evaluated on (0: check and report only). The
    /// report gives the largest excess left. MERL, RGL and Cornell fits.
    #[arg(long, default_value_t = 2, value_parser = crate::args::cap_rounds)]
    cap_rounds: usize,
    /// What the three fitted functions are: rgb (one per channel) or
    /// luminance-chroma (the luminance, then r/Y and b/Y). Default: rgb,
    /// and luminance-chroma with `--target-de` (fewer bytes for the same
    /// render error on the materials measured; docs/results/fidelity.md).
    #[arg(long)]
    colour: Option<brdf::ColourMode>,
    /// What each fitted function is: the value (linear), its natural
    /// logarithm (log: the value is `exp(p / q)`, positive everywhere, and
    /// a lobe spanning orders of magnitude is a smooth bump), or the
    /// logarithm for the functions that carry light alone (log-light: the
    /// channels, or the luminance; chroma ratios linear). The intervals
    /// bound the value the same way on every scale. Default: linear; with
    /// `--target-de`, the whole hemisphere's fits on the log scale and the
    /// searches after them linear (the validation renders choose), which
    /// giving `--values` replaces by that scale in every search.
    #[arg(long)]
    values: Option<brdf::ValueScale>,
    /// How `phi_d` enters a 3-D fit's coordinates: in radians, or as its
    /// cosine (an isotropic BRDF folded by mirror symmetry is a smooth
    /// function of `cos phi_d`, which often needs fewer coefficients).
    /// Default: radians; cosine with `--target-de`.
    #[arg(long)]
    phi: Option<brdf::PhiCoordinate>,
    /// Lobe times rational: fit a Cook-Torrance GGX lobe to the table
    /// first (several starts, log error), then fit the ratio of the table
    /// to the lobe, which is smooth where the lobe has the right shape
    /// (28 bytes more). MERL and RGL files only.
    #[arg(long)]
    lobe: bool,
    /// Print the report as JSON.
    #[arg(long)]
    json: bool,
    /// Skip the render check: by default a fit of a MERL or RGL table is
    /// rendered beside the table on the two validation scenes (64 x 64
    /// pixels, a few seconds) and the report states the CIEDE2000 reached;
    /// with `--perceptual` it also chooses the evaluation cut (80, 75, 70
    /// or 65 degrees, then 60 and 55 while the lowest does best, or the
    /// fit's own) and whether a shell factor carries
    /// the table's luminance or colour beyond it (16 to 192 bytes, in the
    /// layouts of `brdf::SHELL_CHOICES`);
    /// with `--target-de`, the fewest bytes that reach the target.
    #[arg(long)]
    no_render_check: bool,
    /// Output fit (JSON).
    #[arg(short = 'o', long = "output")]
    output: PathBuf,
}

/// Loads a material file by format name (merl, rgl).
pub fn load_material(path: &Path, format: &str) -> Result<Box<dyn Brdf>> {
    Ok(format.parse::<brdf::TableFormat>()?.read(path)?)
}

fn reduction(args: &FitArgs) -> Result<Reduction> {
    let kind = match (args.dims.unwrap_or(2), args.spread) {
        (2, false) => ReductionKind::Slice2d,
        (2, true) => ReductionKind::Spread2d,
        (3, false) => ReductionKind::Full3d,
        (3, true) => bail!("--spread applies to 2-D fits only"),
        (d, _) => bail!("--dims {d}: use 2 or 3"),
    };
    let coords = match args.coords.as_str() {
        "sqrt" => Coordinates::SqrtThetaH,
        "radians" => Coordinates::Radians,
        "cosines" => Coordinates::Cosines,
        c => bail!("unknown coordinates `{c}` (sqrt, radians, cosines)"),
    };
    let mut r = Reduction::default()
        .with_kind(kind)
        .with_coordinates(coords)
        .with_max_theta_d(args.max_theta_d);
    if let Some(degrees) = args.max_elevation {
        r = r.with_max_elevation(degrees);
    }
    if let Some(phi) = args.phi {
        r = r.with_phi(phi);
    }
    if kind == ReductionKind::Full3d {
        // The full MERL grid is 1.46 M cells per channel; default to a 45^3 subgrid.
        r = r.with_resolution(45, 45).with_phi_resolution(45);
    }
    if let Some(crate::args::Bins(v)) = &args.resolution {
        r = r.with_resolution(v[0], v[1]);
        if let Some(&p) = v.get(2) {
            r = r.with_phi_resolution(p);
        }
    }
    Ok(r)
}

/// Runs `ratfit fit`.
pub fn run_fit(args: FitArgs) -> Result<()> {
    let out = fit_to_json(&args)?;
    crate::output::write(&args.output, serde_json::to_string_pretty(&out)?)?;
    eprintln!("wrote {}", args.output.display());
    Ok(())
}

/// The `ratfit fit` output file's content for `args` (the report is
/// printed on the way); `args.output` is not written.
pub fn fit_to_json(args: &FitArgs) -> Result<serde_json::Value> {
    let fit_settings = engine_settings(args)?;
    // Every flag is checked whatever the format, even those ALTA data
    // (fitted in the file's own parametrisation) do not use.
    let checked_reduction = reduction(args)?;
    if args.lobe && args.format != "merl" && args.format != "rgl" {
        bail!("--lobe fits the lobe to a table: use --format merl or rgl");
    }
    if args.format == "alta" {
        return run_fit_alta(args, &fit_settings);
    }
    if let Some(target) = args.target_de {
        return run_fit_target(args, fit_settings, target);
    }
    let mut settings = BrdfFitSettings::default()
        .with_reduction(checked_reduction)
        .with_rel_tol(args.rel_tol)?
        .with_noise_floor(args.noise_floor)?
        .with_colour_mode(args.colour.unwrap_or_default())
        .with_value_scale(args.values.unwrap_or_default())
        .with_cap_rounds(args.cap_rounds)?
        .with_fit_settings(fit_settings);
    if let Some(bar) = crate::progress::channel_bar(args.colour.unwrap_or_default().names()) {
        settings = settings.with_channel_progress(bar);
    }
    if args.perceptual {
        let whole = within_cut(settings.reduction().whole_hemisphere(), args);
        settings = settings
            .with_reduction(whole)
            .with_design(brdf::PerceptualBounds::default().with_rel_tol(args.rel_tol)?);
    }
    let mut cut_choice: Option<(String, serde_json::Value)> = None;
    let (fitted, report, render) = if args.format == "cornell" {
        let data = ScatteredBrdf::read_cornell(&args.material)?;
        let samples = data.samples(settings.reduction());
        let (f, r) = fit_samples(&samples, &format!("Cornell {}", data.name), &settings)?;
        (f, r, None)
    } else {
        let material: std::sync::Arc<dyn Brdf> =
            load_material(&args.material, &args.format)?.into();
        if args.lobe {
            settings = settings.with_lobe(Some(brdf::Lobe::fit(material.as_ref())));
        }
        let (mut f, r) = fit_brdf(material.as_ref(), &settings)?;
        crate::progress::finish();
        let render = if args.no_render_check {
            None
        } else if args.perceptual {
            // A perceptual fit covers the whole hemisphere unless given a
            // cut: the render check also chooses the cut it is evaluated
            // within, and whether a shell factor multiplies it beyond.
            let choice = render_cpu::fidelity::render_check_choosing_cut(material.clone(), f)?;
            f = choice.fitted.clone();
            cut_choice = Some((
                choice.describe(),
                serde_json::json!({ "chosen": choice.cut, "shell": choice.shell, "tried": choice.tried }),
            ));
            Some((peak_check(material.as_ref(), &f), choice.errors))
        } else {
            Some((
                peak_check(material.as_ref(), &f),
                render_cpu::fidelity::render_check(material, &f)?,
            ))
        };
        (f, r, render)
    };
    crate::progress::finish();
    let (peak, render) = render.unzip();
    print_fit_report(
        args.json,
        &report,
        cut_choice.as_ref().map(|(line, _)| line.as_str()),
        peak.as_ref().zip(render.as_ref()),
    )?;
    let mut out =
        serde_json::json!({ "brdf": fitted, "report": report, "render": render, "peak": peak });
    if let Some((_, chosen)) = cut_choice {
        out["evaluation_cut"] = chosen;
    }
    Ok(out)
}

/// The engine's settings from `ratfit fit`'s flags: the coefficient
/// budget (larger for a target search), backend, poles, search, degree
/// weights and widening.
fn engine_settings(args: &FitArgs) -> Result<FitSettings> {
    let mut fit_settings = FitSettings::default()
        .with_coeff_range(
            2,
            args.max_coeffs.unwrap_or(if args.target_de.is_some() {
                render_cpu::fidelity::TARGET_MAX_COEFFS
            } else {
                60
            }),
        )?
        .with_backend(args.backend)?
        .with_pole_control(args.poles)
        .with_search(args.search.unwrap_or(Search::Staircase))
        .with_centred_fit(args.centred)
        .with_cancel(crate::process::flag());
    if !args.degree_weights.is_empty() {
        fit_settings = fit_settings.with_degree_weights(args.degree_weights.clone())?;
    }
    if args.max_widenings > 0 {
        let perceptual = args.perceptual || args.target_de.is_some();
        let factor = args.widen_factor.unwrap_or(if perceptual {
            std::f64::consts::SQRT_2
        } else {
            2.0
        });
        fit_settings = fit_settings
            .with_widening(factor, args.max_widenings)
            .with_context(|| format!("--widen-factor {factor}"))?;
    }
    Ok(fit_settings)
}

/// Prints a plain fit's report (as JSON with `json`), the evaluation cut
/// chosen, and the render and peak checks.
fn print_fit_report(
    json: bool,
    report: &brdf::BrdfFitReport,
    cut_line: Option<&str>,
    checks: Option<(
        &brdf::fidelity::FitPeaks,
        &render_cpu::fidelity::RenderErrors,
    )>,
) -> Result<()> {
    if json {
        println!("{}", serde_json::to_string_pretty(report)?);
        return Ok(());
    }
    println!("{report}");
    if let Some(line) = cut_line {
        println!("{line}");
    }
    if let Some((p, r)) = checks {
        println!("{}", describe_render(r));
        if let Some(split) = &r.colour_split {
            println!("{}", split.describe("the fit"));
        }
        println!("{p}");
    }
    Ok(())
}

/// The peak check of `ratfit bench fidelity` on a fit, on its grid.
fn peak_check(table: &dyn Brdf, fitted: &FittedBrdf) -> brdf::fidelity::FitPeaks {
    let grid = brdf::fidelity::HemisphereSettings::default().grid;
    brdf::fidelity::fit_peaks(table, fitted, grid)
}

/// A whole-hemisphere reduction with the elevation cut `--max-elevation`
/// gives, if any.
fn within_cut(whole: Reduction, args: &FitArgs) -> Reduction {
    match args.max_elevation {
        Some(degrees) => whole.with_max_elevation(degrees),
        None => whole,
    }
}

fn describe_render(r: &render_cpu::fidelity::RenderErrors) -> String {
    format!(
        "render error against the table (mean CIEDE2000, 64 x 64; --no-render-check skips): \
         lights {:.2} (p99 {:.1}, silhouette {:.1}), sky {:.2} (p99 {:.1}, silhouette {:.1})",
        r.scenes[0].mean_de,
        r.scenes[0].p99_de,
        r.scenes[0].silhouette_mean_de,
        r.scenes[1].mean_de,
        r.scenes[1].p99_de,
        r.scenes[1].silhouette_mean_de
    )
}

/// `--target-de`: the smallest perceptual fit reaching a render error.
fn run_fit_target(
    args: &FitArgs,
    fit_settings: FitSettings,
    target: f64,
) -> Result<serde_json::Value> {
    if !(target > 0.0 && target.is_finite()) {
        bail!("--target-de {target}: give a positive CIEDE2000 value");
    }
    if !(args.time_budget > 0.0 && args.time_budget.is_finite()) {
        bail!(
            "--time-budget {}: give a positive number of seconds",
            args.time_budget
        );
    }
    if args.format != "merl" && args.format != "rgl" {
        bail!("--target-de renders the table: use --format merl or rgl");
    }
    // The 3-D grid (or, with `--dims 2`, the slice alone) over the whole
    // hemisphere; in the automatic mode the slice is tried too.
    let slice_only = args.dims == Some(2);
    let mut reduction = reduction(args)?
        .with_kind(if slice_only {
            ReductionKind::Slice2d
        } else {
            ReductionKind::Full3d
        })
        .whole_hemisphere()
        .with_phi(args.phi.unwrap_or(render_cpu::fidelity::TARGET_PHI));
    reduction = within_cut(reduction, args);
    if args.resolution.is_none() {
        reduction = render_cpu::fidelity::on_target_grid(reduction);
    }
    let material: std::sync::Arc<dyn Brdf> = load_material(&args.material, &args.format)?.into();
    let colour = args.colour.unwrap_or(brdf::ColourMode::LuminanceChroma);
    let mut settings = render_cpu::fidelity::target_settings(fit_settings)
        .with_reduction(reduction)
        .with_colour_mode(colour)
        .with_lobe(args.lobe.then(|| brdf::Lobe::fit(material.as_ref())))
        .with_cap_rounds(args.cap_rounds)?;
    if let Some(scale) = args.values {
        settings = settings.with_value_scale(scale);
    }
    // The functions are numbered when the search may change colour mode.
    let labels = match args.colour {
        Some(c) => c.names(),
        None => ['1', '2', '3'],
    };
    if let Some(bar) = crate::progress::channel_bar(labels) {
        settings = settings.with_channel_progress(bar);
    }
    let mode = match args.dims {
        None => render_cpu::fidelity::TargetReduction::Auto,
        Some(_) => render_cpu::fidelity::TargetReduction::Fixed,
    };
    let colour_choice = match args.colour {
        None => render_cpu::fidelity::TargetColour::Auto,
        Some(_) => render_cpu::fidelity::TargetColour::Fixed,
    };
    let choices = render_cpu::fidelity::TargetChoices {
        reduction: mode,
        colour: colour_choice,
        scale: match args.values {
            None => render_cpu::fidelity::TargetScale::Auto,
            Some(_) => render_cpu::fidelity::TargetScale::Fixed,
        },
        grid: match args.resolution {
            None => render_cpu::fidelity::TargetGrid::Auto,
            Some(_) => render_cpu::fidelity::TargetGrid::Fixed,
        },
        coefficients: render_cpu::fidelity::TargetCoefficients::unless_named(args.max_coeffs),
    };
    let fitted = render_cpu::fidelity::fit_to_target(
        material.clone(),
        target,
        &settings,
        choices,
        render_cpu::fidelity::ValidationSettings::default(),
        render_cpu::fidelity::TargetBudget::seconds(args.time_budget).with_bytes(args.max_bytes),
    );
    crate::progress::finish();
    let (fitted, target_report) = fitted?;
    println!(
        "{}: {} coefficients, {} bytes (f32), {}-D perceptual fit {}",
        fitted.name,
        fitted.coefficients(),
        fitted.byte_size_f32(),
        fitted.reduction.dims(),
        target_report
            .fitted_within
            .map_or("over the whole hemisphere".to_string(), |c| format!(
                "within {c} degrees of the normal"
            ))
    );
    println!("{target_report}");
    let peak = peak_check(material.as_ref(), &fitted);
    println!("{peak}");
    Ok(serde_json::json!({ "brdf": fitted, "target": target_report, "peak": peak }))
}

/// ALTA text data: each output fitted in the file's own parametrisation.
fn run_fit_alta(args: &FitArgs, settings: &FitSettings) -> Result<serde_json::Value> {
    let data = AltaData::read(&args.material)?;
    println!(
        "{}: {} samples, {} inputs ({}), {} outputs ({})",
        args.material.display(),
        data.rows.len(),
        data.dim_in,
        data.param_in,
        data.dim_out,
        data.param_out
    );
    let mut settings = settings.clone();
    if let Some(bar) = crate::progress::sweep_bar() {
        settings = settings.with_progress(bar);
    }
    let mut functions = Vec::new();
    let mut reports = Vec::new();
    for k in 0..data.dim_out {
        let d = data.channel(k, args.rel_tol)?;
        let r = rational_core::fit(&d, &settings).with_context(|| format!("output {k}"))?;
        crate::progress::finish();
        println!("output {k}:\n{r}");
        functions.push(r.function.clone());
        reports.push(r);
    }
    Ok(
        serde_json::json!({ "alta_param_in": data.param_in, "functions": functions, "reports": reports }),
    )
}

/// Reads a JSON file.
pub fn read_json(path: &Path) -> Result<serde_json::Value> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    serde_json::from_str(&text).with_context(|| format!("{} is not JSON", path.display()))
}

/// Reads a fitted BRDF file written by `ratfit fit`.
pub fn read_fitted(path: &Path) -> Result<FittedBrdf> {
    Ok(brdf::FitFile::read(path)?.brdf)
}

/// `r,g,b` per row of `theta_i,phi_i,theta_o,phi_o`.
pub fn eval_directions(fitted: &FittedBrdf, rows: &[Vec<f64>]) -> Result<String> {
    if rows[0].len() != 4 {
        bail!(
            "--directions needs 4 columns theta_i,phi_i,theta_o,phi_o; found {}",
            rows[0].len()
        );
    }
    let mut out = String::with_capacity(rows.len() * 40);
    for r in rows {
        let v = fitted.eval(
            brdf::from_spherical(r[0], r[1]),
            brdf::from_spherical(r[2], r[3]),
        );
        out.push_str(&format!("{:e},{:e},{:e}\n", v[0], v[1], v[2]));
    }
    Ok(out)
}
