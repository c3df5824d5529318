//! `ratfit bench fidelity`: every representation of every material judged by
//! its renders. For each material: the table rendered on the two validation
//! scenes, then each representation (rational modes, Cook-Torrance GGX
//! fitted to the whole material, the table downsampled to the same bytes,
//! and the table kept at the 3-D fits' own grid, which shows what that
//! sampling alone loses) measured by mean and 99th-percentile CIEDE2000
//! over the object's pixels, BRDF-space relative error by elevation band
//! over the whole hemisphere, and the largest value anywhere against the
//! table's peak. Writes `results.csv`, `summary.md`, `de_vs_bytes.svg`/`.png`
//! (the Pareto front ringed) and table / representation / difference
//! images, then checks them.

use super::instances::data_dir;
use anyhow::{bail, Context, Result};
use brdf::fidelity::{hemisphere_errors, HemisphereErrors, HemisphereSettings};
use brdf::{Brdf, ColourMode, MerlBrdf, RglBrdf};
use clap::Args;
use render_cpu::fidelity::{RenderErrors, ValidationSettings, Validator};
use render_cpu::FitInDomain;
use std::path::{Path, PathBuf};
use std::sync::Arc;
use std::time::Instant;

mod outputs;
mod peers;
mod reps;

use outputs::{check, write_images, write_outputs};
use reps::{rational_reps, Plan, TargetPlan};

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
    /// Scales of the 3-D fits' functions that carry light (comma-separated:
    /// linear, log; see `ratfit fit --values`).
    #[arg(long, value_delimiter = ',', default_value = "linear,log")]
    values: Vec<brdf::ValueScale>,
    /// How `phi_d` enters the 3-D fits' coordinates (comma-separated:
    /// radians, cosine; see `ratfit fit --phi`).
    #[arg(long, value_delimiter = ',', default_value = "radians,cosine")]
    phi: Vec<brdf::PhiCoordinate>,
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
    /// Elevations (degrees, in [45, 90), comma-separated) at which each 3-D
    /// fit over the whole hemisphere is also measured evaluated within a
    /// cut, without fitting again: directions beyond it are moved onto it
    /// (`brdf::clamp_elevation`), so the silhouette shows the fit's value at
    /// the cut instead of its loosely bounded grazing cells.
    #[arg(long, value_delimiter = ',')]
    post_cuts: Vec<f64>,
    /// Also measure the fit `ratfit fit FILE --target-de D --max-bytes B`
    /// returns (chosen on its own validation renders, 96 x 96 with 256 sky
    /// samples, then measured here like every representation).
    #[arg(long, value_parser = crate::args::positive)]
    target_de: Option<f64>,
    /// The byte budget of the `--target-de` fit.
    #[arg(long, default_value_t = 1024, value_parser = crate::args::max_bytes)]
    max_bytes: usize,
    /// Seconds the `--target-de` fit may spend on fits and renders.
    #[arg(long, default_value_t = render_cpu::fidelity::TARGET_TIME_BUDGET_S, value_parser = crate::args::positive)]
    time_budget: f64,
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

/// What every candidate of one material is measured against.
struct Judge<'a> {
    material: &'a str,
    table: &'a dyn Brdf,
    shared: &'a Arc<dyn Brdf>,
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
    if let Some(c) = args.post_cuts.iter().find(|c| !(45.0..90.0).contains(*c)) {
        bail!("--post-cuts {c}: use elevations in [45, 90) degrees");
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
            shared: &table,
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
    let problems = check(
        &args.out,
        &rows,
        &noise,
        args.target_de.map(|_| args.max_bytes),
    );
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
        values: if args.quick {
            vec![brdf::ValueScale::Linear, brdf::ValueScale::Log]
        } else {
            args.values.clone()
        },
        phis: if args.quick {
            vec![brdf::PhiCoordinate::Radians, brdf::PhiCoordinate::Cosine]
        } else {
            args.phi.clone()
        },
        tols: if args.quick {
            vec![0.16]
        } else {
            args.tols.clone()
        },
        resolution_3d: if args.quick { 16 } else { args.resolution_3d },
        cut_3d: args.cut_3d,
        // The quick run measures one cut, with and without the shell
        // factor, so that every evaluation path of a cut fit is exercised.
        post_cuts: if args.quick && args.post_cuts.is_empty() {
            vec![70.0]
        } else {
            args.post_cuts.clone()
        },
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
        target: args.target_de.map(|de| TargetPlan {
            de,
            max_bytes: Some(args.max_bytes),
            seconds: args.time_budget,
        }),
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

/// A 3-D fit over the whole hemisphere evaluated within each elevation of
/// `cuts` (the same functions; only the evaluation's cut changes). Empty
/// for other fits.
fn post_cut_variants(fitted: &brdf::FittedBrdf, cuts: &[f64]) -> Vec<(f64, brdf::FittedBrdf)> {
    if fitted.reduction.kind != brdf::ReductionKind::Full3d {
        return Vec::new();
    }
    cuts.iter()
        .filter_map(|&degrees| Some((degrees, fitted.evaluated_within(degrees)?)))
        .collect()
}

/// The suffix of a shell factor's row after `, shell factor`: none for the
/// default layout, ` NH x ND` for other luminance factors on uniform bins,
/// then ` cos` for bins uniform in cosine and ` colour` for a factor per
/// function.
fn shell_row_suffix(layout: brdf::ShellLayout) -> String {
    if layout == brdf::ShellLayout::luminance(brdf::DEFAULT_SHELL_BINS) {
        return String::new();
    }
    let [nh, nd] = layout.bins;
    let mut out = format!(" {nh} x {nd}");
    if layout.spacing == brdf::ThetaDSpacing::Cosine {
        out += " cos";
    }
    if layout.colour == brdf::ShellColour::PerFunction {
        out += " colour";
    }
    out
}

/// The rows of `within` (a fit evaluated within an elevation cut) times its
/// shell factor beyond the cut ([`brdf::ShellFactor`], fitted to the table
/// here in each layout of [`brdf::SHELL_CHOICES`]; its time is added to
/// the fit's). The default layout's row is named `{name}, shell factor`,
/// the others' as [`shell_row_suffix`] says.
fn measure_with_shells(
    judge: &Judge,
    name: &str,
    within: brdf::FittedBrdf,
    fit_s: f64,
) -> Result<Vec<Row>> {
    let degrees = within.reduction.max_elevation_deg;
    let mut rows = Vec::new();
    for layout in brdf::SHELL_CHOICES {
        let start = Instant::now();
        let shelled = brdf::ShellFactor::fit_layout(judge.table, &within, layout)
            .and_then(|sh| within.clone().with_shell(sh))
            .with_context(|| {
                format!(
                    "{}: the shell factor beyond {degrees} degrees",
                    judge.table.name()
                )
            })?;
        let shell_s = start.elapsed().as_secs_f64();
        let suffix = shell_row_suffix(layout);
        rows.push(measure(
            judge,
            Candidate {
                name: format!("{name}, shell factor{suffix}"),
                bytes: shelled.byte_size_f32(),
                brdf: Arc::new(FitInDomain::new(shelled)),
                fit_s: fit_s + shell_s,
                note: format!(
                    "the row above times a factor beyond the cut on {} of theta_h x theta_d ({shell_s:.2} s)",
                    layout.describe()
                ),
            },
        )?);
    }
    Ok(rows)
}

/// Every representation of one material, measured.
fn measure_material(judge: &Judge) -> Result<Vec<Row>> {
    let mut material_rows = Vec::new();
    for attempt in rational_reps(judge.shared, judge.plan) {
        let (name, fit_s) = (attempt.name, attempt.fit_s);
        match attempt.result {
            Ok((fitted, note)) => {
                let bytes = fitted.byte_size_f32();
                let note = with_unclamped_peak(note, judge, &fitted);
                let (post_cut, own_cut) = if attempt.variants {
                    (
                        post_cut_variants(&fitted, &judge.plan.post_cuts),
                        (fitted.reduction.max_elevation_deg < 90.0).then(|| fitted.clone()),
                    )
                } else {
                    (Vec::new(), None)
                };
                let candidate: Arc<dyn Brdf> = Arc::new(FitInDomain::new(fitted));
                let row = measure(
                    judge,
                    Candidate {
                        name: name.clone(),
                        brdf: candidate,
                        bytes,
                        fit_s,
                        note,
                    },
                )?;
                material_rows.push(row);
                if let Some(cut_fit) = own_cut {
                    material_rows.extend(measure_with_shells(judge, &name, cut_fit, fit_s)?);
                }
                for (degrees, within) in post_cut {
                    let name = format!("{name} evaluated within {degrees}");
                    let row = measure(
                        judge,
                        Candidate {
                            name: name.clone(),
                            brdf: Arc::new(FitInDomain::new(within.clone())),
                            bytes,
                            fit_s,
                            note: format!(
                                "the fit above, directions beyond {degrees} degrees moved onto the cut"
                            ),
                        },
                    )?;
                    material_rows.push(row);
                    material_rows.extend(measure_with_shells(judge, &name, within, fit_s)?);
                }
            }
            Err(e) => println!("  {name:<46} no fit: {}", crate::output::chain_text(&e)),
        }
    }
    let rational_bytes: Vec<usize> = material_rows
        .iter()
        .filter(|r| r.representation.starts_with("rational"))
        .map(|r| r.bytes)
        .collect();
    material_rows.extend(peers::measure_peers(judge, &rational_bytes)?);
    Ok(material_rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    // Exact comparisons: the same functions evaluated at the same points.
    #[allow(clippy::float_cmp)]
    fn post_cuts_change_the_evaluation_only_and_only_of_whole_hemisphere_3d_fits() {
        let glossy = brdf::BlinnPhong {
            kd: [0.2, 0.4, 0.6],
            ks: [0.3, 0.3, 0.3],
            exponent: 4.0,
        };
        let reduction = brdf::Reduction::default()
            .with_kind(brdf::ReductionKind::Full3d)
            .with_resolution(6, 6)
            .with_phi_resolution(6)
            .whole_hemisphere();
        let settings = brdf::BrdfFitSettings::default()
            .with_reduction(reduction)
            .with_baselines(false);
        let (fitted, _) = brdf::fit_brdf(&glossy, &settings).unwrap();
        let variants = post_cut_variants(&fitted, &[70.0, 80.0]);
        assert_eq!(variants.len(), 2);
        let (degrees, within) = &variants[0];
        assert_eq!(*degrees, 70.0);
        assert_eq!(within.reduction.max_elevation_deg, 70.0);
        assert_eq!(within.channels, fitted.channels);
        let at = |deg: f64| {
            let t = deg.to_radians();
            [t.sin(), 0.0, t.cos()]
        };
        let view = at(10.0);
        // Within the cut the same values; beyond it, the value at the cut.
        assert_eq!(within.eval(at(60.0), view), fitted.eval(at(60.0), view));
        let (beyond, on_cut) = (within.eval(at(85.0), view), fitted.eval(at(70.0), view));
        for c in 0..3 {
            assert!(
                (beyond[c] - on_cut[c]).abs() <= 1e-12 * on_cut[c].abs(),
                "{c}"
            );
        }
        let unclamped = fitted.eval(at(85.0), view);
        assert!(
            (0..3).any(|c| (unclamped[c] - on_cut[c]).abs() > 1e-9),
            "the cut must matter here"
        );
        // A fit that already has a cut (or is 2-D) has no variants.
        assert!(post_cut_variants(&variants[1].1, &[70.0]).is_empty());
    }
}
