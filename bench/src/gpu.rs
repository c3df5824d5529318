//! `ratfit bench gpu`: the frame-rate experiment on the GPU. For each
//! fitted material of a scene: frames per second on the GPU and on the CPU,
//! evaluations per second of the fit (GPU kernel and CPU f32), the GPU
//! image's difference from the CPU image of the same fit and from the CPU
//! image of the measured table (the representation error), with the
//! adapter's name.

#[cfg(not(feature = "gpu"))]
use anyhow::Result;
use clap::Args;
use std::path::PathBuf;

/// Options of `ratfit bench gpu`.
#[derive(Args)]
pub struct GpuBenchArgs {
    /// The scene (directional or point lights, triangles, fitted materials).
    #[arg(default_value = "scenes/lights256.toml")]
    scene: PathBuf,
    /// Output folder: results.csv, summary.md, frame_time.svg/png, images.
    #[arg(long, default_value = "target/bench-gpu")]
    out: PathBuf,
    /// Fitted materials to put on the scene's objects (comma-separated;
    /// default: every material of kind `fitted`).
    #[arg(long, value_delimiter = ',')]
    materials: Option<Vec<String>>,
    /// GPU frames timed per material (after one warm-up frame).
    #[arg(long, default_value_t = 16)]
    frames: usize,
    /// Direction pairs per evaluation-throughput batch (at most 2^20).
    #[arg(long, default_value_t = 1 << 20)]
    pairs: usize,
    /// Image size as WIDTHxHEIGHT (default: the scene's).
    #[arg(long)]
    resolution: Option<String>,
    /// Skip the CPU renders (no CPU frame time, no image differences).
    #[arg(long)]
    no_cpu: bool,
    /// Cache folder for fits (default: the usual cache).
    #[arg(long)]
    cache: Option<PathBuf>,
}

/// Runs `ratfit bench gpu`.
#[cfg(not(feature = "gpu"))]
pub fn run(_args: GpuBenchArgs) -> Result<()> {
    anyhow::bail!("{}", crate::scene_args::NO_GPU)
}

#[cfg(feature = "gpu")]
pub use imp::run;

#[cfg(feature = "gpu")]
mod imp {
    use super::GpuBenchArgs;
    use crate::chart::{Figure, Panel};
    use crate::scene_args::parse_resolution;
    use anyhow::{bail, Context, Result};
    use brdf::CompactBrdf;
    use rayon::prelude::*;
    use render_cpu::{
        compare, prepare_file, render, ClosedForm, MaterialDescription, RenderOptions,
        SceneDescription,
    };
    use std::fmt::Write as _;
    use std::time::Instant;
    use wgpu_eval::{agreement_tolerance, BatchEvaluator, GpuContext, GpuRenderer, GpuScene};

    /// Largest mean CIEDE2000 between GPU and CPU images of the same fit
    /// over covered pixels (silhouette pixels may differ between
    /// rasterisation and ray casting; measured 0.005 to 0.03).
    const MAX_MEAN_DE: f64 = 0.1;

    struct Row {
        material: String,
        coefficients: usize,
        bytes: usize,
        gpu_setup_s: f64,
        gpu_frame_s: f64,
        cpu_frame_s: f64,
        table_frame_s: f64,
        gpu_evals_resident: f64,
        gpu_evals_transfer: f64,
        cpu_evals: f64,
        kernel_worst: f64,
        /// The f32 form's largest relative difference from the f64 fit
        /// (`FitInDomain::f32_error`).
        f32_error: f64,
        de_vs_cpu: f64,
        de_max_vs_cpu: f64,
        de_vs_table: f64,
    }

    /// One row of `results.csv`: one material's frame rates, throughputs
    /// and agreements.
    #[derive(serde::Serialize)]
    struct CsvRow<'a> {
        material: &'a str,
        coefficients: usize,
        bytes: usize,
        gpu_setup_s: f64,
        gpu_frame_s: f64,
        gpu_fps: f64,
        cpu_frame_s: f64,
        cpu_fps: f64,
        table_frame_s: f64,
        gpu_over_cpu: f64,
        gpu_evals_per_s: f64,
        gpu_evals_per_s_with_transfer: f64,
        cpu_f32_evals_per_s: f64,
        kernel_error_of_tolerance: f64,
        f32_error_vs_f64: f64,
        mean_de2000_gpu_vs_cpu: f64,
        max_de2000_gpu_vs_cpu: f64,
        mean_de2000_vs_table: f64,
    }

    impl<'a> CsvRow<'a> {
        fn of(r: &'a Row) -> Self {
            Self {
                material: &r.material,
                coefficients: r.coefficients,
                bytes: r.bytes,
                gpu_setup_s: r.gpu_setup_s,
                gpu_frame_s: r.gpu_frame_s,
                gpu_fps: 1.0 / r.gpu_frame_s,
                cpu_frame_s: r.cpu_frame_s,
                cpu_fps: 1.0 / r.cpu_frame_s,
                table_frame_s: r.table_frame_s,
                gpu_over_cpu: r.cpu_frame_s / r.gpu_frame_s,
                gpu_evals_per_s: r.gpu_evals_resident,
                gpu_evals_per_s_with_transfer: r.gpu_evals_transfer,
                cpu_f32_evals_per_s: r.cpu_evals,
                kernel_error_of_tolerance: r.kernel_worst,
                f32_error_vs_f64: r.f32_error,
                mean_de2000_gpu_vs_cpu: r.de_vs_cpu,
                max_de2000_gpu_vs_cpu: r.de_max_vs_cpu,
                mean_de2000_vs_table: r.de_vs_table,
            }
        }
    }

    /// Direction pairs inside the fits' sampled elevations (70 degrees):
    /// a fixed, seeded set of unit vectors of the upper hemisphere.
    fn pairs(n: usize, max_elevation: f64) -> Vec<([f32; 3], [f32; 3])> {
        let mut rng = render_cpu::Rng::new(2012, 0);
        let cut = max_elevation.cos();
        let dir = |rng: &mut render_cpu::Rng| {
            let [a, b] = rng.pair();
            let z = cut + (1.0 - cut) * a;
            let r = (1.0 - z * z).max(0.0).sqrt();
            let phi = 2.0 * std::f64::consts::PI * b;
            [(r * phi.cos()) as f32, (r * phi.sin()) as f32, z as f32]
        };
        (0..n).map(|_| (dir(&mut rng), dir(&mut rng))).collect()
    }

    /// Measures one material on the scene's first object: GPU and CPU frame
    /// times, evaluation throughput, agreement; returns its row, the GPU
    /// image and the scene's exposure.
    fn measure(
        args: &GpuBenchArgs,
        desc: &SceneDescription,
        ctx: &GpuContext,
        object_material: &str,
        resolution: Option<(usize, usize)>,
        name: &str,
    ) -> Result<(Row, render_cpu::Image, f64)> {
        let options = |to: &str| RenderOptions {
            swaps: vec![(object_material.to_string(), to.to_string())],
            resolution,
            cache_dir: args.cache.clone(),
            ..Default::default()
        };
        let (scene, _) = prepare_file(&args.scene, &options(name))
            .with_context(|| format!("scene {} with {name}", args.scene.display()))?;
        let gpu_scene = GpuScene::from_scene(&scene)?;
        let Some(ClosedForm::Fit(fit)) = gpu_scene.materials.first().cloned() else {
            bail!("material `{name}` is not a rational fit");
        };
        let compact: &CompactBrdf = fit.compact();

        let t = Instant::now();
        let renderer = GpuRenderer::new(ctx, &gpu_scene)?;
        let image = renderer.render()?;
        let gpu_setup_s = t.elapsed().as_secs_f64();
        let timing = renderer.time_frames(args.frames)?;
        eprintln!(
            "{name}: GPU {:.4} s/frame ({:.1} fps), first frame {:.2} s",
            timing.seconds_per_frame,
            1.0 / timing.seconds_per_frame,
            timing.first_frame_seconds
        );

        // Evaluation throughput, kernel against the CPU f32 path.
        let p = pairs(args.pairs.clamp(1, 1 << 20), fit.max_elevation());
        let kernel = BatchEvaluator::new(ctx, compact)?;
        let resident = kernel.time_resident(&p, 8)?;
        let t = Instant::now();
        let values = kernel.eval(&p)?;
        let transfer = t.elapsed().as_secs_f64();
        let t = Instant::now();
        let cpu_values: Vec<[f32; 3]> = p
            .par_iter()
            .map(|(wi, wo)| compact.eval(*wi, *wo))
            .collect();
        let cpu_eval_s = t.elapsed().as_secs_f64();
        let kernel_worst = kernel_disagreement(&values, &cpu_values);

        let (mut cpu_frame_s, mut table_frame_s) = (f64::NAN, f64::NAN);
        let (mut de_vs_cpu, mut de_max_vs_cpu, mut de_vs_table) = (f64::NAN, f64::NAN, f64::NAN);
        if !args.no_cpu {
            let cpu = render(&scene, &|_, _| {});
            cpu_frame_s = cpu.stats.seconds;
            let (c, _) = compare(&cpu.image, &image, scene.exposure)?;
            de_vs_cpu = c.covered_mean_de2000;
            de_max_vs_cpu = c.max_de2000;
            if let Some(MaterialDescription::Fitted { source, .. }) = desc.materials.get(name) {
                let (table_scene, _) = prepare_file(&args.scene, &options(source))?;
                let table = render(&table_scene, &|_, _| {});
                table_frame_s = table.stats.seconds;
                de_vs_table = compare(&table.image, &image, scene.exposure)?
                    .0
                    .covered_mean_de2000;
            }
            eprintln!(
                "{name}: CPU {cpu_frame_s:.3} s/frame; GPU vs CPU mean dE2000 {de_vs_cpu:.4} (max {de_max_vs_cpu:.3}); vs the table {de_vs_table:.3}"
            );
        }
        let row = Row {
            material: name.to_string(),
            coefficients: fit.fit().coefficients(),
            bytes: fit.fit().byte_size_f32(),
            gpu_setup_s,
            gpu_frame_s: timing.seconds_per_frame,
            cpu_frame_s,
            table_frame_s,
            gpu_evals_resident: p.len() as f64 / resident,
            gpu_evals_transfer: p.len() as f64 / transfer,
            cpu_evals: p.len() as f64 / cpu_eval_s,
            kernel_worst,
            f32_error: fit.f32_error(),
            de_vs_cpu,
            de_max_vs_cpu,
            de_vs_table,
        };
        Ok((row, image, scene.exposure))
    }

    /// The largest disagreement between the GPU kernel's values and the
    /// CPU f32 path's, in units of their agreement tolerance (infinite for
    /// a non-finite GPU value).
    fn kernel_disagreement(values: &[[f32; 3]], cpu_values: &[[f32; 3]]) -> f64 {
        let peak = cpu_values
            .iter()
            .flatten()
            .fold(0.0f32, |m, v| m.max(v.abs()));
        values
            .iter()
            .zip(cpu_values)
            .flat_map(|(g, c)| (0..3).map(move |k| (g[k], c[k])))
            .map(|(g, c)| {
                let e = ((g - c).abs() / agreement_tolerance(c, peak)) as f64;
                // A non-finite GPU value is the worst disagreement.
                if e.is_finite() {
                    e
                } else {
                    f64::INFINITY
                }
            })
            .fold(0.0, f64::max)
    }

    /// `frame_time.svg/.png`: frame time against coefficients, error
    /// against frame time.
    fn write_figure(
        args: &GpuBenchArgs,
        rows: &[Row],
        adapter: &str,
        threads: usize,
    ) -> Result<()> {
        let series = |f: &dyn Fn(&Row) -> (f64, f64), k: usize| -> Vec<(usize, f64, f64)> {
            rows.iter().map(|r| (k, f(r).0, f(r).1)).collect()
        };
        let mut time = series(&|r| (r.coefficients as f64, r.gpu_frame_s), 0);
        time.extend(series(&|r| (r.coefficients as f64, r.cpu_frame_s), 1));
        let mut error = series(&|r| (r.gpu_frame_s, r.de_vs_table), 0);
        error.extend(series(&|r| (r.cpu_frame_s, r.de_vs_table), 1));
        let figure = Figure {
            title: format!("{}: {adapter}", args.scene.display()),
            x_label: "coefficients / seconds per frame".into(),
            y_label: "seconds per frame / mean dE2000 against the table".into(),
            legend: vec!["GPU".into(), format!("CPU ({threads} threads)")],
            panels: vec![
                Panel {
                    title: "frame time vs coefficients".into(),
                    points: time,
                    front: Vec::new(),
                },
                Panel {
                    title: "error vs frame time".into(),
                    points: error,
                    front: Vec::new(),
                },
            ],
            columns: 2,
        };
        figure.write(&args.out, "frame_time")
    }

    /// Runs `ratfit bench gpu`.
    pub fn run(args: GpuBenchArgs) -> Result<()> {
        let start = Instant::now();
        std::fs::create_dir_all(&args.out)?;
        let desc = SceneDescription::read(&args.scene)?;
        let Some(object_material) = desc.objects.first().map(|o| o.material().to_string()) else {
            bail!("{}: the scene has no objects", args.scene.display());
        };
        let materials: Vec<String> = match &args.materials {
            Some(m) => m.clone(),
            None => desc
                .materials
                .iter()
                .filter(|(_, m)| matches!(m, MaterialDescription::Fitted { .. }))
                .map(|(n, _)| n.clone())
                .collect(),
        };
        if materials.is_empty() {
            bail!("{}: no fitted materials to measure", args.scene.display());
        }
        let ctx = GpuContext::new()?;
        let adapter = ctx.adapter_name();
        eprintln!("adapter: {adapter}");
        let resolution = args
            .resolution
            .as_deref()
            .map(parse_resolution)
            .transpose()?;
        let threads = rayon::current_num_threads();
        let mut rows = Vec::new();
        let mut first_image = None;
        for name in &materials {
            let (row, image, exposure) =
                measure(&args, &desc, &ctx, &object_material, resolution, name)?;
            if first_image.is_none() {
                image.write(&args.out.join("gpu.png"), exposure)?;
                first_image = Some(name.clone());
            }
            rows.push(row);
        }
        rows.sort_by_key(|r| r.coefficients);

        crate::output::write_csv(args.out.join("results.csv"), rows.iter().map(CsvRow::of))?;

        let (w, h) = resolution.unwrap_or((desc.camera.width, desc.camera.height));
        let mut md = format!(
            "# GPU frame rate: {}\n\nAdapter: **{adapter}**. {w}x{h} pixels; CPU figures on {threads} threads. GPU frame time is the median of batches of up to 8 frames after a warm-up frame ({} frames). Evaluation throughput over {} direction pairs inside the fits' sampled elevations: the kernel with the pairs already on the device, then with upload and read-back, and the CPU f32 path. \"dE\" is the mean CIEDE2000 over covered pixels. \"f32 vs f64\": the f32 form's largest relative difference from the f64 fit; above {:.0e} the CPU renders the fit in f64, and the kernel's agreement with the CPU f32 path is reported, not required (both are f32 evaluations of a form that keeps too few digits).\n\n",
            args.scene.display(),
            args.frames,
            args.pairs.clamp(1, 1 << 20),
            render_cpu::F32_TOLERANCE,
        );
        md += "| material | coefficients | GPU ms/frame | GPU fps | CPU s/frame | GPU/CPU speed | GPU evals/s | with transfer | CPU f32 evals/s | kernel error / tolerance | f32 vs f64 | dE GPU vs CPU (max) | dE vs table (table CPU s) |\n|---|---|---|---|---|---|---|---|---|---|---|---|---|\n";
        for r in &rows {
            let _ = writeln!(
                md,
                "| {} | {} | {:.2} | {:.1} | {:.3} | {:.1}x | {:.3e} | {:.3e} | {:.3e} | {:.3} | {:.1e} | {:.4} ({:.3}) | {:.3} ({:.2}) |",
                r.material, r.coefficients, 1e3 * r.gpu_frame_s, 1.0 / r.gpu_frame_s, r.cpu_frame_s,
                r.cpu_frame_s / r.gpu_frame_s, r.gpu_evals_resident, r.gpu_evals_transfer, r.cpu_evals,
                r.kernel_worst, r.f32_error, r.de_vs_cpu, r.de_max_vs_cpu, r.de_vs_table, r.table_frame_s
            );
        }
        let _ = writeln!(
            md,
            "\nThe paper: 110 / 70 / 19 fps on a GTX 580 for 126 / 140 / 238 coefficients. Image: `gpu.png` ({}). Total {:.1} s.",
            first_image.unwrap_or_default(),
            start.elapsed().as_secs_f64()
        );
        crate::output::write(args.out.join("summary.md"), &md)?;

        write_figure(&args, &rows, &adapter, threads)?;
        print!("{md}");
        eprintln!("wrote {}", args.out.display());
        // The run checks itself: the kernel within the stated tolerance of
        // the CPU f32 path (for fits whose f32 form keeps its digits: two
        // f32 evaluations of one that does not differ by its rounding), the
        // image within a small Lab difference.
        let mut problems = Vec::new();
        for r in &rows {
            let f32_reliable = r.f32_error <= render_cpu::F32_TOLERANCE;
            if f32_reliable && (r.kernel_worst.is_nan() || r.kernel_worst > 1.0) {
                problems.push(format!(
                    "{}: kernel error {:.3} of the tolerance",
                    r.material, r.kernel_worst
                ));
            }
            if r.de_vs_cpu > MAX_MEAN_DE {
                problems.push(format!(
                    "{}: mean dE2000 {:.4} between the GPU and CPU images (limit {MAX_MEAN_DE})",
                    r.material, r.de_vs_cpu
                ));
            }
        }
        if !problems.is_empty() {
            bail!("{}", problems.join("; "));
        }
        Ok(())
    }
}
