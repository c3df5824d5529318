//! `ratfit bench fidelity`: every representation of every material judged by
//! its renders. For each material: the table rendered on the two validation
//! scenes, then each representation (rational modes, Cook-Torrance GGX
//! fitted to the whole material, the table downsampled to the same bytes)
//! measured by mean and 99th-percentile CIEDE2000 over the object's pixels,
//! BRDF-space relative error by elevation band over the whole hemisphere,
//! and the largest value anywhere against the table's peak. Writes
//! `results.csv`, `summary.md`, `de_vs_bytes.svg`/`.png` (the Pareto front
//! ringed) and table / representation / difference images, then checks them.

use super::instances::data_dir;
use super::summary::utc_date;
use crate::chart::{pareto_front, Figure, Panel};
use anyhow::{bail, Context, Result};
use brdf::fidelity::{hemisphere_errors, HemisphereErrors, HemisphereSettings};
use brdf::{Brdf, ColourMode, DownsampledTable, MerlBrdf, RglBrdf};
use clap::Args;
use render_cpu::fidelity::{RenderErrors, ValidationScene, ValidationSettings, Validator};
use render_cpu::{false_colour, FitInDomain, Image};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

/// Options of `ratfit bench fidelity`.
#[derive(Args)]
pub struct FidelityArgs {
    /// Folder of materials (`.bsdf` RGL, `.binary` MERL), or one file;
    /// default: `rgl` under `RATFIT_DATA` or `../shared/data`.
    path: Option<PathBuf>,
    /// Output folder.
    #[arg(long, default_value = "target/bench-fidelity")]
    out: PathBuf,
    /// A few materials at small size (under three minutes): 2 RGL files,
    /// 64 x 64 renders, the 2-D fit at 20% and the 3-D luminance-chroma
    /// fits at 16% on a 16^3 grid, with and without the GGX lobe, with at
    /// most 60 coefficients per function.
    #[arg(long)]
    quick: bool,
    /// Skip the 2-D perceptual fit, the slowest representation on glossy
    /// materials (up to about 45 minutes on 2 cores).
    #[arg(long)]
    no_perceptual_2d: bool,
    /// Only materials whose file name contains this.
    #[arg(long)]
    only: Option<String>,
    /// Relative half-widths of the perceptual 3-D fits (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "0.08,0.16")]
    tols: Vec<f64>,
    /// Colour modes of the 3-D fits (comma-separated: rgb,
    /// luminance-chroma).
    #[arg(long, value_delimiter = ',', default_value = "rgb,luminance-chroma")]
    colour: Vec<ColourMode>,
    /// Lobes of the 3-D fits (comma-separated): none (the table itself) and
    /// ggx (the ratio of the table to a fitted Cook-Torrance GGX lobe; see
    /// `ratfit fit --lobe`).
    #[arg(long, value_delimiter = ',', default_value = "none,ggx")]
    lobe: Vec<LobeChoice>,
    /// Bins per angle of the 3-D grid.
    #[arg(long, default_value_t = 24)]
    resolution_3d: usize,
    /// An elevation cut (degrees, in [45, 90)) for the 3-D fits: cells with
    /// either direction further from the normal are not fitted, and every
    /// evaluation moves such directions onto the cut (`brdf::clamp_elevation`,
    /// as for the 2-D slice). Default: none, the whole hemisphere, its
    /// grazing cells loosely bounded.
    #[arg(long)]
    cut_3d: Option<f64>,
    /// Largest coefficient budget per channel.
    #[arg(long, default_value_t = 120)]
    max_coeffs: usize,
    /// Validation render size (pixels per side).
    #[arg(long, default_value_t = 96)]
    size: usize,
    /// Samples per pixel of the sky scene (scrambled Sobol' points at the
    /// pixel centres: 1024 brings two renders of a table within about 0.1
    /// to 0.25 CIEDE2000 of each other).
    #[arg(long, default_value_t = 1024)]
    sky_spp: usize,
}

/// What the rational functions of a 3-D fit multiply.
#[derive(Clone, Copy, PartialEq, Eq, clap::ValueEnum)]
enum LobeChoice {
    /// Nothing: the functions fit the table.
    None,
    /// A Cook-Torrance GGX lobe fitted to the table first.
    Ggx,
}

/// One representation of one material.
struct Row {
    material: String,
    representation: String,
    bytes: usize,
    fit_s: f64,
    render: RenderErrors,
    hemisphere: HemisphereErrors,
    note: String,
}

fn materials(path: &Path, only: Option<&str>, quick: bool) -> Result<Vec<PathBuf>> {
    let mut files: Vec<PathBuf> = if path.is_file() {
        vec![path.to_path_buf()]
    } else {
        std::fs::read_dir(path)
            .with_context(|| format!("cannot read {}", path.display()))?
            .filter_map(|e| e.ok().map(|e| e.path()))
            .filter(|p| p.extension().is_some_and(|x| x == "bsdf" || x == "binary"))
            .collect()
    };
    files.retain(|p| {
        only.is_none_or(|o| {
            p.file_name()
                .is_some_and(|n| n.to_string_lossy().contains(o))
        })
    });
    files.sort();
    if quick {
        // One matte and one glossy file when both are there.
        let pick: Vec<PathBuf> = ["cm_military_green", "vch_golden_yellow"]
            .iter()
            .filter_map(|n| {
                files
                    .iter()
                    .find(|p| p.to_string_lossy().contains(n))
                    .cloned()
            })
            .collect();
        files = if pick.is_empty() {
            files.into_iter().take(2).collect()
        } else {
            pick
        };
    }
    if files.is_empty() {
        bail!("no material files (.bsdf, .binary) in {}", path.display());
    }
    Ok(files)
}

fn load(path: &Path) -> Result<Arc<dyn Brdf>> {
    Ok(match path.extension().and_then(|e| e.to_str()) {
        Some("binary") => Arc::new(MerlBrdf::read(path)?),
        _ => Arc::new(RglBrdf::read(path)?),
    })
}

/// Settings of the representations measured.
struct Plan {
    perceptual_2d: bool,
    modes: Vec<ColourMode>,
    lobes: Vec<LobeChoice>,
    tols: Vec<f64>,
    resolution_3d: usize,
    cut_3d: Option<f64>,
    max_coeffs: usize,
    hemisphere: HemisphereSettings,
}

/// A representation's name, its fit and description (or why it failed),
/// and the fit time.
type Attempt = (String, Result<(brdf::FittedBrdf, String)>, f64);

fn rational_reps(table: &dyn Brdf, plan: &Plan) -> Vec<Attempt> {
    let mut out = Vec::new();
    // Today's former default for scenes: the 2-D slice at 20% inside the cuts.
    let start = Instant::now();
    let r = rational_mode::fit_plain_2d(table, 0.2, plan.max_coeffs);
    out.push((
        "rational 2-D 20%".to_string(),
        r,
        start.elapsed().as_secs_f64(),
    ));
    if plan.perceptual_2d {
        let start = Instant::now();
        let t = plan.tols.iter().copied().fold(0.0, f64::max).min(0.08);
        let grid = rational_mode::Grid {
            dims: 2,
            resolution: 90,
            cut: None,
        };
        let r =
            rational_mode::fit_perceptual(table, grid, t, plan.max_coeffs, ColourMode::Rgb, None);
        out.push((
            format!("rational 2-D perceptual {}%", t * 100.0),
            r,
            start.elapsed().as_secs_f64(),
        ));
    }
    // The lobe is fitted once; its time counts in every fit that uses it.
    let lobe = plan.lobes.contains(&LobeChoice::Ggx).then(|| {
        let start = Instant::now();
        (brdf::Lobe::fit(table), start.elapsed().as_secs_f64())
    });
    for &t in &plan.tols {
        for &mode in &plan.modes {
            for &choice in &plan.lobes {
                let start = Instant::now();
                let (with, lobe_s) = match (choice, &lobe) {
                    (LobeChoice::Ggx, Some((l, s))) => (Some(*l), *s),
                    _ => (None, 0.0),
                };
                let grid = rational_mode::Grid {
                    dims: 3,
                    resolution: plan.resolution_3d,
                    cut: plan.cut_3d,
                };
                let r = rational_mode::fit_perceptual(table, grid, t, plan.max_coeffs, mode, with);
                let what = mode.to_string();
                let lobe_name = if with.is_some() { " x GGX lobe" } else { "" };
                let cut = plan.cut_3d.map_or(String::new(), |c| format!(" cut {c}"));
                out.push((
                    format!("rational 3-D {what}{lobe_name} {}%{cut}", t * 100.0),
                    r,
                    start.elapsed().as_secs_f64() + lobe_s,
                ));
            }
        }
    }
    out
}

/// The rational modes the benchmark fits, by name.
mod rational_mode {
    use anyhow::Result;
    use brdf::{
        fit_brdf, Brdf, BrdfFitSettings, ColourMode, FittedBrdf, PerceptualBounds, Reduction,
        ReductionKind,
    };
    use rational_core::{FitSettings, Search};

    /// The staircase search; perceptual intervals widen by sqrt 2 up to
    /// 16 times (as `ratfit fit --perceptual`), plain ones by 2.
    fn engine(max_coeffs: usize, perceptual: bool) -> Result<FitSettings> {
        let (factor, times) = if perceptual {
            (std::f64::consts::SQRT_2, 8)
        } else {
            (2.0, 4)
        };
        Ok(FitSettings::default()
            .with_coeff_range(2, max_coeffs)?
            .with_search(Search::Staircase)
            .with_widening(factor, times)?)
    }

    fn describe(fitted: &FittedBrdf, report: &brdf::BrdfFitReport) -> String {
        let widened: Vec<String> = report
            .channels
            .iter()
            .filter(|c| c.interval_scale > 1.0)
            .map(|c| format!("{} x{}", c.channel, brdf::scale_text(c.interval_scale)))
            .collect();
        let splits: Vec<String> = report
            .channels
            .iter()
            .map(|c| format!("({},{})", c.n_p, c.n_q))
            .collect();
        let verified = report.channels.iter().all(|c| c.verified);
        // The dense cap check's largest value over the cap left, per function.
        let caps: Vec<String> = report
            .channels
            .iter()
            .filter_map(|c| c.cap.map(|k| (c.channel, k)))
            .map(|(ch, k)| {
                if k.non_finite > 0 {
                    format!("{ch} {:.2} ({} not finite)", k.largest, k.non_finite)
                } else {
                    format!("{ch} {:.2}", k.largest)
                }
            })
            .collect();
        format!(
            "splits {}; {}{}",
            splits.join(" "),
            if verified { "verified" } else { "NOT verified" },
            if widened.is_empty() {
                String::new()
            } else {
                format!("; widened {}", widened.join(" "))
            }
        ) + &format!("; {} coefficients", fitted.coefficients())
            + &if caps.is_empty() {
                String::new()
            } else {
                format!("; over the cap x {}", caps.join(" "))
            }
    }

    /// The 2-D `phi_d = pi/2` slice with plain relative intervals inside the
    /// 78-degree grazing and 70-degree elevation cuts.
    pub fn fit_plain_2d(
        table: &dyn Brdf,
        rel_tol: f64,
        max_coeffs: usize,
    ) -> Result<(FittedBrdf, String)> {
        let settings = BrdfFitSettings::default()
            .with_rel_tol(rel_tol)?
            .with_baselines(false)
            .with_fit_settings(engine(max_coeffs, false)?);
        let (f, r) = fit_brdf(table, &settings)?;
        let d = describe(&f, &r);
        Ok((f, d))
    }

    /// Where a perceptual fit samples its table.
    #[derive(Clone, Copy)]
    pub struct Grid {
        /// 2 (the `phi_d = pi/2` slice) or 3.
        pub dims: usize,
        /// Bins per angle.
        pub resolution: usize,
        /// An elevation cut in degrees; `None`: the whole hemisphere.
        pub cut: Option<f64>,
    }

    /// The 2-D slice or the full `(theta_h, theta_d, phi_d)` grid over the
    /// whole hemisphere (or within the grid's elevation cut) with
    /// perceptual intervals.
    pub fn fit_perceptual(
        table: &dyn Brdf,
        grid: Grid,
        rel_tol: f64,
        max_coeffs: usize,
        mode: ColourMode,
        lobe: Option<brdf::Lobe>,
    ) -> Result<(FittedBrdf, String)> {
        let Grid {
            dims,
            resolution,
            cut,
        } = grid;
        let kind = if dims == 3 {
            ReductionKind::Full3d
        } else {
            ReductionKind::Slice2d
        };
        let reduction = Reduction::default()
            .with_kind(kind)
            .with_resolution(resolution, resolution)
            .with_phi_resolution(resolution)
            .whole_hemisphere();
        let reduction = match cut {
            Some(degrees) => reduction.with_max_elevation(degrees),
            None => reduction,
        };
        let settings = BrdfFitSettings::default()
            .with_reduction(reduction)
            .with_design(PerceptualBounds::default().with_rel_tol(rel_tol)?)
            .with_colour_mode(mode)
            .with_lobe(lobe)
            .with_baselines(false)
            .with_fit_settings(engine(max_coeffs, true)?);
        let (f, r) = fit_brdf(table, &settings)?;
        let d = describe(&f, &r);
        Ok((f, d))
    }
}

/// What every candidate of one material is measured against.
struct Judge<'a> {
    material: &'a str,
    table: &'a dyn Brdf,
    validator: &'a Validator,
    plan: &'a Plan,
}

/// One representation to measure.
struct Candidate {
    name: String,
    brdf: Arc<dyn Brdf>,
    bytes: usize,
    fit_s: f64,
    note: String,
}

fn measure(judge: &Judge, c: Candidate) -> Result<Row> {
    let Candidate {
        name,
        brdf: candidate,
        bytes,
        fit_s,
        note,
    } = c;
    let (material, table, validator, plan) =
        (judge.material, judge.table, judge.validator, judge.plan);
    let render = validator.measure(candidate.clone())?;
    let hemisphere = hemisphere_errors(table, candidate.as_ref(), &plan.hemisphere);
    let non_finite: usize = render.scenes.iter().map(|s| s.non_finite_pixels).sum();
    let note = if non_finite > 0 {
        format!("{note}; {non_finite} non-finite pixels (counted as white)")
    } else {
        note
    };
    let row = Row {
        material: material.to_string(),
        representation: name,
        bytes,
        fit_s,
        render,
        hemisphere,
        note,
    };
    println!(
        "  {:<46} {:>6} B  fit {:>7.2} s  dE lights {:>6.3} (p99 {:>6.2}, silhouette {:>6.2})  sky {:>6.3} (p99 {:>6.2}, silhouette {:>6.2})  median rel <80 {:>6.3}  peak x{:<6.2} {}",
        row.representation,
        row.bytes,
        row.fit_s,
        row.render.scenes[0].mean_de,
        row.render.scenes[0].p99_de,
        row.render.scenes[0].silhouette_mean_de,
        row.render.scenes[1].mean_de,
        row.render.scenes[1].p99_de,
        row.render.scenes[1].silhouette_mean_de,
        row.hemisphere.median_below_80,
        row.hemisphere.peak_ratio,
        row.note
    );
    Ok(row)
}

fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .split('_')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("_")
}

fn write_images(
    out: &Path,
    material: &str,
    rep: &str,
    reference: &[Image],
    row: &Row,
) -> Result<()> {
    for (k, scene) in ValidationScene::ALL.iter().enumerate() {
        let base = format!("{}-{}", slug(material), scene.name());
        let table_png = out.join(format!("{base}-table.png"));
        if !table_png.exists() {
            reference[k].write(&table_png, 1.0)?;
        }
        let img = &row.render.images[k];
        img.write(&out.join(format!("{base}-{}.png", slug(rep))), 1.0)?;
        let (_, map) = render_cpu::compare(&reference[k], img, 1.0)?;
        let rgb = false_colour(&map, 5.0);
        render_cpu::write_png(
            &out.join(format!("{base}-{}-diff.png", slug(rep))),
            img.width,
            img.height,
            &rgb,
        )?;
    }
    Ok(())
}

/// Runs `ratfit bench fidelity`.
pub fn run(args: FidelityArgs) -> Result<()> {
    let start = Instant::now();
    for &t in &args.tols {
        if !(t > 0.0 && t < 1.0) {
            bail!("--tols: {t} is not in (0, 1)");
        }
    }
    if !(2..=90).contains(&args.resolution_3d) {
        bail!("--resolution-3d {}: use 2 to 90 bins", args.resolution_3d);
    }
    if let Some(c) = args.cut_3d {
        if !(45.0..90.0).contains(&c) {
            bail!("--cut-3d {c}: use an elevation in [45, 90) degrees");
        }
    }
    if !(8..=1024).contains(&args.size) || !(1..=4096).contains(&args.sky_spp) {
        bail!("--size must be in 8..=1024 and --sky-spp in 1..=4096");
    }
    if args.colour.is_empty() {
        bail!("--colour needs at least one mode (rgb, luminance-chroma)");
    }
    let path = match &args.path {
        Some(p) => p.clone(),
        None => data_dir()
            .map(|d| d.join("rgl"))
            .context("no material folder given and no data directory found (set RATFIT_DATA)")?,
    };
    let files = materials(&path, args.only.as_deref(), args.quick)?;
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let (settings, plan) = settings_and_plan(&args);
    let mut rows: Vec<Row> = Vec::new();
    let mut noise: Vec<(String, Vec<f64>)> = Vec::new();
    for file in &files {
        let material = file
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let t0 = Instant::now();
        let table = load(file)?;
        let validator = Validator::new(table.clone(), settings)?;
        let floor: Vec<f64> = validator.noise.iter().map(|n| n.mean_de).collect();
        println!(
            "{material}: table rendered in {:.1} s; table against itself (another seed): dE lights {:.3}, sky {:.3}",
            t0.elapsed().as_secs_f64(),
            floor[0],
            floor[1]
        );
        noise.push((material.clone(), floor));
        let judge = Judge {
            material: &material,
            table: table.as_ref(),
            validator: &validator,
            plan: &plan,
        };
        let material_rows = measure_material(&judge)?;
        for row in &material_rows {
            write_images(
                &args.out,
                &material,
                &row.representation,
                validator.references(),
                row,
            )?;
        }
        rows.extend(material_rows);
        write_outputs(&args, &rows, &noise, start.elapsed().as_secs_f64())?;
    }
    let problems = check(&args.out, &rows, &noise);
    if !problems.is_empty() {
        for p in &problems {
            eprintln!("check: {p}");
        }
        bail!("{} problem(s) in {}", problems.len(), args.out.display());
    }
    println!(
        "check: {} is complete ({} rows); wrote {} in {:.1} s",
        args.out.display(),
        rows.len(),
        args.out.display(),
        start.elapsed().as_secs_f64()
    );
    Ok(())
}

/// The validation renders and the representations of a run.
fn settings_and_plan(args: &FidelityArgs) -> (ValidationSettings, Plan) {
    let settings = if args.quick {
        ValidationSettings {
            size: 64,
            lights_spp: 1,
            sky_spp: 32,
            seed: 1,
        }
    } else {
        ValidationSettings {
            size: args.size,
            sky_spp: args.sky_spp,
            ..Default::default()
        }
    };
    let plan = Plan {
        perceptual_2d: !args.quick && !args.no_perceptual_2d,
        modes: if args.quick {
            vec![ColourMode::LuminanceChroma]
        } else {
            args.colour.clone()
        },
        lobes: if args.quick {
            vec![LobeChoice::None, LobeChoice::Ggx]
        } else {
            args.lobe.clone()
        },
        tols: if args.quick {
            vec![0.16]
        } else {
            args.tols.clone()
        },
        resolution_3d: if args.quick { 16 } else { args.resolution_3d },
        cut_3d: args.cut_3d,
        max_coeffs: if args.quick {
            args.max_coeffs.min(60)
        } else {
            args.max_coeffs
        },
        hemisphere: if args.quick {
            HemisphereSettings {
                pairs: 10_000,
                grid: [32, 32, 16],
                ..Default::default()
            }
        } else {
            HemisphereSettings::default()
        },
    };
    (settings, plan)
}

/// The note of a fit with a ceiling that binds on the peak check's grid,
/// with the peak ratio the functions reach without it: the ceiling bounds
/// what is rendered, and the note keeps the fit's own excess in sight.
fn with_unclamped_peak(note: String, judge: &Judge, fitted: &brdf::FittedBrdf) -> String {
    if fitted.ceiling.is_none() {
        return note;
    }
    let p = brdf::fidelity::fit_peaks(judge.table, fitted, judge.plan.hemisphere.grid);
    let (with, without) = (p.ratio, p.ratio_without_ceiling);
    if without > with * (1.0 + 1e-9) {
        format!("{note}; the ceiling holds: peak x{without:.2} without it")
    } else {
        note
    }
}

/// Every representation of one material, measured.
fn measure_material(judge: &Judge) -> Result<Vec<Row>> {
    let mut material_rows = Vec::new();
    for (name, result, fit_s) in rational_reps(judge.table, judge.plan) {
        match result {
            Ok((fitted, note)) => {
                let bytes = fitted.byte_size_f32();
                let note = with_unclamped_peak(note, judge, &fitted);
                let candidate: Arc<dyn Brdf> = Arc::new(FitInDomain::new(fitted));
                let row = measure(
                    judge,
                    Candidate {
                        name,
                        brdf: candidate,
                        bytes,
                        fit_s,
                        note,
                    },
                )?;
                material_rows.push(row);
            }
            Err(e) => println!("  {name:<46} no fit: {}", crate::output::chain_text(&e)),
        }
    }
    // The analytic peer.
    let ggx = brdf::baseline::fit_ggx(judge.table);
    let note = format!(
        "kd {:.3?} f0 {:.3?} alpha {:.4}",
        ggx.model.kd, ggx.model.f0, ggx.model.alpha
    );
    let row = measure(
        judge,
        Candidate {
            name: "Cook-Torrance GGX (LM, log)".into(),
            brdf: Arc::new(ggx.model),
            bytes: 28,
            fit_s: ggx.seconds,
            note,
        },
    )?;
    material_rows.push(row);
    // The table downsampled to the bytes of each rational representation
    // and to 1 KB.
    let mut budgets: Vec<usize> = material_rows
        .iter()
        .filter(|r| r.representation.starts_with("rational"))
        .map(|r| r.bytes)
        .chain([1024])
        .collect();
    budgets.sort_unstable();
    // Two budgets may give the same grid: measure each grid once.
    let mut grids: Vec<[usize; 3]> = budgets
        .into_iter()
        .map(DownsampledTable::bins_for_bytes)
        .collect();
    grids.sort_by_key(|b| (b[0] * b[1] * b[2], *b));
    grids.dedup();
    for bins in grids {
        let t1 = Instant::now();
        let down = DownsampledTable::new(judge.table, bins);
        let size = down.byte_size_f32();
        let row = measure(
            judge,
            Candidate {
                name: format!("table downsampled to {size} B"),
                brdf: Arc::new(down),
                bytes: size,
                fit_s: t1.elapsed().as_secs_f64(),
                note: format!("{}x{}x{} cells", bins[0], bins[1], bins[2]),
            },
        )?;
        material_rows.push(row);
    }
    Ok(material_rows)
}

/// One row of `results.csv`: the figures of one representation of one
/// material.
#[derive(serde::Serialize, serde::Deserialize)]
struct CsvRow {
    material: String,
    representation: String,
    bytes: usize,
    fit_s: f64,
    lights_mean_de: f64,
    lights_p99_de: f64,
    sky_mean_de: f64,
    sky_p99_de: f64,
    lights_silhouette_de: f64,
    sky_silhouette_de: f64,
    median_rel_0_70: f64,
    p90_rel_0_70: f64,
    max_rel_0_70: f64,
    median_rel_70_80: f64,
    p90_rel_70_80: f64,
    max_rel_70_80: f64,
    median_rel_80_90: f64,
    p90_rel_80_90: f64,
    max_rel_80_90: f64,
    median_rel_below_80: f64,
    peak_ratio: f64,
    note: String,
}

impl CsvRow {
    fn of(r: &Row) -> Self {
        let b = &r.hemisphere.bands;
        let (lights, sky) = (&r.render.scenes[0], &r.render.scenes[1]);
        Self {
            material: r.material.clone(),
            representation: r.representation.clone(),
            bytes: r.bytes,
            fit_s: r.fit_s,
            lights_mean_de: lights.mean_de,
            lights_p99_de: lights.p99_de,
            sky_mean_de: sky.mean_de,
            sky_p99_de: sky.p99_de,
            lights_silhouette_de: lights.silhouette_mean_de,
            sky_silhouette_de: sky.silhouette_mean_de,
            median_rel_0_70: b[0].median,
            p90_rel_0_70: b[0].p90,
            max_rel_0_70: b[0].max,
            median_rel_70_80: b[1].median,
            p90_rel_70_80: b[1].p90,
            max_rel_70_80: b[1].max,
            median_rel_80_90: b[2].median,
            p90_rel_80_90: b[2].p90,
            max_rel_80_90: b[2].max,
            median_rel_below_80: r.hemisphere.median_below_80,
            peak_ratio: r.hemisphere.peak_ratio,
            note: r.note.clone(),
        }
    }
}

fn write_outputs(
    args: &FidelityArgs,
    rows: &[Row],
    noise: &[(String, Vec<f64>)],
    wall_s: f64,
) -> Result<()> {
    crate::output::write_csv(args.out.join("results.csv"), rows.iter().map(CsvRow::of))?;
    crate::output::write(
        args.out.join("summary.md"),
        summary(args, rows, noise, wall_s),
    )?;
    // Mean CIEDE2000 (the worse scene) against bytes, one panel per material.
    let mut legend: Vec<String> = Vec::new();
    let series = |name: &str| -> String {
        if name.starts_with("rational") {
            name.to_string()
        } else if name.starts_with("table") {
            "table downsampled".into()
        } else {
            name.to_string()
        }
    };
    for r in rows {
        let s = series(&r.representation);
        if !legend.contains(&s) {
            legend.push(s);
        }
    }
    let mut panels: Vec<Panel> = Vec::new();
    for (material, _) in noise {
        let pts: Vec<(usize, f64, f64)> = rows
            .iter()
            .filter(|r| &r.material == material)
            .map(|r| {
                let k = legend
                    .iter()
                    .position(|l| *l == series(&r.representation))
                    .unwrap_or(0);
                (k, r.bytes as f64, r.render.worst_mean())
            })
            .collect();
        let front = pareto_front(&pts.iter().map(|p| (p.1, p.2)).collect::<Vec<_>>());
        panels.push(Panel {
            title: material.clone(),
            points: pts,
            front,
        });
    }
    let figure = Figure {
        title: "Render error against bytes (worse of the two validation scenes)".into(),
        x_label: "bytes (f32)".into(),
        y_label: "mean CIEDE2000".into(),
        legend,
        panels,
        columns: 3,
    };
    figure.write(&args.out, "de_vs_bytes")?;
    Ok(())
}

fn summary(args: &FidelityArgs, rows: &[Row], noise: &[(String, Vec<f64>)], wall_s: f64) -> String {
    let mut md = String::new();
    let _ = writeln!(md, "# Fidelity: render error against bytes\n");
    let _ = writeln!(
        md,
        "{}; `ratfit bench fidelity{}`; {} threads; {:.0} s in all.\n",
        utc_date(),
        if args.quick { " --quick" } else { "" },
        rayon::current_num_threads(),
        wall_s
    );
    let _ = writeln!(
        md,
        "Mean and 99th-percentile CIEDE2000 over the sphere's pixels (those whose centre sees \
         the sphere, not black in both images; before 2026-12-03 the sky's figures also counted \
         the sky and ground around it, equal in both, and were about 1.6x lower) against the \
         table's render (lights: three directional lights; sky: sky and ground, MIS); \
         `*_silhouette_de` in `results.csv`: the mean over the pixels that view the sphere more \
         than 70 degrees from its normal. Relative error: luminance, \
         over random direction pairs of the whole hemisphere with a table value above 1e-3 of its \
         peak, by band of the larger elevation. Peak: the largest value on a dense grid of the \
         hemisphere over the table's.\n"
    );
    let _ = writeln!(
        md,
        "| material | table vs itself (lights / sky) |\n|---|---|"
    );
    for (m, n) in noise {
        let _ = writeln!(md, "| {m} | {:.3} / {:.3} |", n[0], n[1]);
    }
    let _ = writeln!(
        md,
        "\n| material | representation | bytes | fit s | dE lights (p99) | dE sky (p99) | rel 0-70 med / p90 | rel 70-80 med | rel 80-90 med | rel <80 med | peak x | note |\n|---|---|---|---|---|---|---|---|---|---|---|---|"
    );
    for r in rows {
        let b = &r.hemisphere.bands;
        let _ = writeln!(
            md,
            "| {} | {} | {} | {:.2} | {:.3} ({:.2}) | {:.3} ({:.2}) | {:.3} / {:.3} | {:.3} | {:.3} | {:.3} | {:.2} | {} |",
            r.material,
            r.representation,
            r.bytes,
            r.fit_s,
            r.render.scenes[0].mean_de,
            r.render.scenes[0].p99_de,
            r.render.scenes[1].mean_de,
            r.render.scenes[1].p99_de,
            b[0].median,
            b[0].p90,
            b[1].median,
            b[2].median,
            r.hemisphere.median_below_80,
            r.hemisphere.peak_ratio,
            r.note
        );
    }
    md
}

/// Checks a finished run: every file present, every figure finite.
fn check(out: &Path, rows: &[Row], noise: &[(String, Vec<f64>)]) -> Vec<String> {
    let mut problems = Vec::new();
    for f in [
        "results.csv",
        "summary.md",
        "de_vs_bytes.svg",
        "de_vs_bytes.png",
    ] {
        if !out.join(f).is_file() {
            problems.push(format!("{f} is missing"));
        }
    }
    // Read back with the writer's own schema: a row with a missing, extra
    // or unparsable field is an error.
    match csv::Reader::from_path(out.join("results.csv")) {
        Ok(mut reader) => {
            let read: Result<Vec<CsvRow>, _> = reader.deserialize().collect();
            match read {
                Ok(read) if read.len() != rows.len() => problems.push(format!(
                    "results.csv has {} rows, expected {}",
                    read.len(),
                    rows.len()
                )),
                Ok(_) => {}
                Err(e) => problems.push(format!("results.csv: {e}")),
            }
        }
        Err(e) => problems.push(format!("results.csv: {e}")),
    }
    for (m, _) in noise {
        let reps: Vec<&Row> = rows.iter().filter(|r| &r.material == m).collect();
        if !reps
            .iter()
            .any(|r| r.representation.starts_with("rational"))
        {
            problems.push(format!("{m}: no rational representation was measured"));
        }
        if !reps.iter().any(|r| r.representation.starts_with("table")) {
            problems.push(format!("{m}: no downsampled table was measured"));
        }
        for scene in ValidationScene::ALL {
            if !out
                .join(format!("{}-{}-table.png", slug(m), scene.name()))
                .is_file()
            {
                problems.push(format!(
                    "{m}: the table's {} image is missing",
                    scene.name()
                ));
            }
        }
    }
    for r in rows {
        let figures = [
            r.render.scenes[0].mean_de,
            r.render.scenes[1].mean_de,
            r.hemisphere.median_below_80,
            r.hemisphere.peak_ratio,
        ];
        if figures.iter().any(|v| !v.is_finite() || *v < 0.0) {
            problems.push(format!(
                "{} / {}: a figure is not finite",
                r.material, r.representation
            ));
        }
        if r.representation.starts_with("rational") && r.note.contains("NOT verified") {
            problems.push(format!(
                "{} / {}: a fit is not verified",
                r.material, r.representation
            ));
        }
    }
    problems
}
