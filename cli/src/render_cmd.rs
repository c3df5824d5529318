//! `ratfit render` and `ratfit compare`.

use anyhow::{bail, Result};
use clap::Args;
use ratfit_bench::scene_args::{row_bar, OverrideArgs, NO_GPU};
use render_cpu::{
    compare, false_colour, prepare_file, render, Image, RenderOptions, RenderOutput, Scene,
};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `ratfit render`.
#[derive(Args)]
pub struct RenderArgs {
    /// The scene file (TOML).
    scene: PathBuf,
    /// Output images: .png (tone-mapped) and/or .exr (linear); repeatable.
    #[arg(short = 'o', long = "output", required = true)]
    outputs: Vec<PathBuf>,
    #[command(flatten)]
    overrides: OverrideArgs,
    /// Print the figures as JSON on standard output.
    #[arg(long)]
    json: bool,
    /// Render on the GPU (a build with `--features gpu`): direct light from
    /// directional and point lights through each pixel centre, no shadow
    /// rays, Lambert and fitted materials, triangles.
    #[arg(long)]
    gpu: bool,
}

/// Prepares a scene file, printing the log to standard error.
pub fn prepare_logged(scene: &Path, options: &RenderOptions) -> Result<(Scene, f64)> {
    let start = Instant::now();
    let (scene, log) = prepare_file(scene, options)?;
    let t = start.elapsed().as_secs_f64();
    eprintln!("prepared in {t:.2} s:\n{log}");
    Ok((scene, t))
}

/// Figures of a render for people.
pub fn describe(scene: &Scene, out: &RenderOutput) -> String {
    let s = &out.stats;
    let i = &scene.integrator;
    let (brdf_bytes, sampler_bytes) = scene.material_bytes();
    let mut text = format!(
        "{}x{} pixels, {} spp, {:?} integrator, {} sampler{}\n",
        scene.camera.width(),
        scene.camera.height(),
        s.spp,
        i.kind,
        i.sampler.name(),
        if i.mis { " + MIS" } else { "" }
    );
    text += &format!(
        "render: {:.3} s ({:.3e} samples/s, {:.2} frames/s)\n",
        s.seconds,
        (s.pixels * s.spp) as f64 / s.seconds,
        1.0 / s.seconds
    );
    text += &format!(
        "variance of one sample (mean over pixels): r {:.4e}  g {:.4e}  b {:.4e}\n",
        s.sample_variance[0], s.sample_variance[1], s.sample_variance[2]
    );
    text += &format!(
        "materials: {brdf_bytes} bytes of reflectance, {sampler_bytes} bytes of samplers\n"
    );
    for m in &scene.materials {
        text += &format!(
            "  {}: {} ({} bytes), sampler {} ({} bytes)\n",
            m.name,
            m.description,
            m.brdf_bytes,
            m.sampler.name(),
            m.sampler_bytes
        );
    }
    text
}

/// Runs `ratfit render`.
pub fn run_render(args: RenderArgs) -> Result<()> {
    let options = args.overrides.options()?;
    for o in &args.outputs {
        let ext = o.extension().and_then(|e| e.to_str()).unwrap_or("");
        if !matches!(ext, "png" | "exr") {
            bail!("{}: the output must end in .png or .exr", o.display());
        }
    }
    if args.gpu && !cfg!(feature = "gpu") {
        bail!("--gpu: {NO_GPU}");
    }
    let (scene, prepare_s) = prepare_logged(&args.scene, &options)?;
    if args.gpu {
        return render_on_gpu(&args, &scene, prepare_s);
    }
    let out = render(&scene, &row_bar());
    let start = Instant::now();
    for o in &args.outputs {
        out.image.write(o, scene.exposure)?;
        eprintln!("wrote {}", o.display());
    }
    let write_s = start.elapsed().as_secs_f64();
    if args.json {
        let v = serde_json::json!({
            "prepare_seconds": prepare_s,
            "render": out.stats,
            "write_seconds": write_s,
            "material_bytes": scene.material_bytes(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        print!("{}", describe(&scene, &out));
        println!(
            "phases: prepare {prepare_s:.2} s, render {:.2} s, write {write_s:.2} s",
            out.stats.seconds
        );
    }
    Ok(())
}

#[cfg(not(feature = "gpu"))]
fn render_on_gpu(_args: &RenderArgs, _scene: &Scene, _prepare_s: f64) -> Result<()> {
    bail!("--gpu: {NO_GPU}")
}

/// `ratfit render --gpu`: one frame on the GPU, written like a CPU render.
#[cfg(feature = "gpu")]
fn render_on_gpu(args: &RenderArgs, scene: &Scene, prepare_s: f64) -> Result<()> {
    let gpu_scene = wgpu_eval::GpuScene::from_scene(scene)?;
    let ctx = wgpu_eval::GpuContext::new()?;
    let start = Instant::now();
    let renderer = wgpu_eval::GpuRenderer::new(&ctx, &gpu_scene)?;
    let image = renderer.render()?;
    let first_s = start.elapsed().as_secs_f64();
    let timing = renderer.time_frames(4)?;
    for o in &args.outputs {
        image.write(o, scene.exposure)?;
        eprintln!("wrote {}", o.display());
    }
    let adapter = ctx.adapter_name();
    if args.json {
        let v = serde_json::json!({
            "adapter": adapter,
            "prepare_seconds": prepare_s,
            "first_frame_seconds": first_s,
            "seconds_per_frame": timing.seconds_per_frame,
            "frames_timed": timing.frames,
            "lights": gpu_scene.lights.len(),
            "triangles": gpu_scene.vertices.len() / 3,
            "coefficients": gpu_scene.coefficients(),
            "material_bytes": scene.material_bytes(),
        });
        println!("{}", serde_json::to_string_pretty(&v)?);
    } else {
        println!(
            "GPU: {adapter}\n{}x{} pixels, {} triangles, {} lights, {} coefficients\nfirst frame (shader compilation, upload, read-back) {first_s:.3} s; then {:.4} s per frame ({:.1} frames/s, median of {} frames)\nphases: prepare {prepare_s:.2} s",
            gpu_scene.width,
            gpu_scene.height,
            gpu_scene.vertices.len() / 3,
            gpu_scene.lights.len(),
            gpu_scene.coefficients(),
            timing.seconds_per_frame,
            1.0 / timing.seconds_per_frame,
            timing.frames
        );
    }
    Ok(())
}

/// Options of `ratfit compare`.
#[derive(Args)]
pub struct CompareArgs {
    /// First image (.exr, linear).
    a: PathBuf,
    /// Second image (.exr, linear).
    b: PathBuf,
    /// False-colour map of the per-pixel CIEDE2000 difference (PNG).
    #[arg(short = 'o', long = "output")]
    output: Option<PathBuf>,
    /// Multiplier applied to both images before the Lab conversion (white
    /// is linear 1 after it).
    #[arg(long, default_value_t = 1.0)]
    exposure: f64,
    /// CIEDE2000 difference drawn white in the map.
    #[arg(long, default_value_t = 10.0)]
    full_scale: f64,
    /// Print the figures as JSON.
    #[arg(long)]
    json: bool,
}

/// Runs `ratfit compare`.
pub fn run_compare(args: CompareArgs) -> Result<()> {
    let a = Image::read_exr(&args.a)?;
    let b = Image::read_exr(&args.b)?;
    for (path, image) in [(&args.a, &a), (&args.b, &b)] {
        if let Some(i) = image.pixels.iter().position(|p| p.iter().any(|&v| v < 0.0)) {
            bail!(
                "{}: pixel ({}, {}) is {:?}; radiance cannot be negative",
                path.display(),
                i % image.width,
                i / image.width,
                image.pixels[i]
            );
        }
    }
    if !(args.exposure.is_finite() && args.exposure > 0.0) {
        bail!("--exposure {} must be positive", args.exposure);
    }
    let (c, map) = compare(&a, &b, args.exposure)?;
    if args.json {
        println!("{}", serde_json::to_string_pretty(&c)?);
    } else {
        println!("{} vs {}", args.a.display(), args.b.display());
        println!("{c}");
    }
    if let Some(o) = &args.output {
        if !(args.full_scale.is_finite() && args.full_scale > 0.0) {
            bail!("--full-scale {} must be positive", args.full_scale);
        }
        render_cpu::write_png(o, a.width, a.height, &false_colour(&map, args.full_scale))?;
        eprintln!(
            "wrote {} (CIEDE2000, black 0 to white {})",
            o.display(),
            args.full_scale
        );
    }
    Ok(())
}
