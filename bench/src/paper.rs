//! `ratfit bench paper`: the rendering experiments of the paper, on the
//! example scenes, with every figure next to what it cost. Writes images
//! and `experiments.md` to the output folder.

use anyhow::{Context, Result};
use clap::Args;
use render_cpu::{
    compare, false_colour, prepare_file, render, Action, PrepareLog, RenderOptions, RenderOutput,
    SamplerKind, Scene,
};
use std::fmt::Write as _;
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Options of `ratfit bench paper`.
#[derive(Args)]
pub struct PaperArgs {
    /// Output folder for images and experiments.md.
    #[arg(long, default_value = "target/bench-paper")]
    out: PathBuf,
    /// Folder of the example scenes.
    #[arg(long, default_value = "scenes")]
    scenes: PathBuf,
    /// Cache folder for fits and inverse CDFs (default: the usual cache).
    #[arg(long)]
    cache: Option<PathBuf>,
    /// Smaller images and fewer samples, for a quick check.
    #[arg(long)]
    quick: bool,
}

/// The real materials whose 2-D fits at 20% are feasible (see docs/guide/measured-brdfs.md).
const MATERIALS: [&str; 4] = [
    "aurora_white",
    "cm_military_green",
    "vch_golden_yellow",
    "vch_silk_blue",
];

struct Runner<'a> {
    args: &'a PaperArgs,
    md: String,
}

impl Runner<'_> {
    fn options(&self) -> RenderOptions {
        RenderOptions {
            cache_dir: self.args.cache.clone(),
            ..Default::default()
        }
    }

    /// The prepared scene and what preparing it cost: fits and inverse
    /// CDFs computed (with seconds) or read from the cache.
    fn scene(&self, name: &str, options: RenderOptions) -> Result<(Scene, String)> {
        let path = self.args.scenes.join(format!("{name}.toml"));
        let (scene, log) =
            prepare_file(&path, &options).with_context(|| format!("scene {}", path.display()))?;
        Ok((scene, work(&log)))
    }

    fn swap(&self, from: &str, to: &str) -> RenderOptions {
        RenderOptions {
            swaps: vec![(from.to_string(), to.to_string())],
            ..self.options()
        }
    }

    fn save(&self, out: &RenderOutput, scene: &Scene, name: &str) -> Result<()> {
        Ok(out
            .image
            .write(&self.args.out.join(format!("{name}.png")), scene.exposure)?)
    }

    fn sphere_experiment(&mut self) -> Result<()> {
        let res = if self.args.quick {
            (96, 96)
        } else {
            (256, 256)
        };
        self.md += "## Sphere under three directional lights: measured data against the fit\n\n";
        let _ = writeln!(self.md, "`scenes/sphere-lights.toml`, {}x{}, 4 spp; the fit is `--swap M=M_fit` (2-D, 20% intervals, at most 60 coefficients per channel). Mean CIELAB differences over the sphere's pixels (the paper: 1.52 for nickel).\n", res.0, res.1);
        self.md += "| material | fit bytes | table bytes | fit | render data / fit (s) | mean dE2000 | mean dE76 | p99 dE2000 | images |\n|---|---|---|---|---|---|---|---|---|\n";
        for m in MATERIALS {
            let mut data_opts = self.swap("cm_military_green", m);
            data_opts.resolution = Some(res);
            let mut fit_opts = self.swap("cm_military_green", &format!("{m}_fit"));
            fit_opts.resolution = Some(res);
            let (data_scene, _) = self.scene("sphere-lights", data_opts)?;
            let (fit_scene, prep) = self.scene("sphere-lights", fit_opts)?;
            let a = render(&data_scene, &|_, _| {});
            let b = render(&fit_scene, &|_, _| {});
            let (c, map) = compare(&a.image, &b.image, 1.0)?;
            self.save(&a, &data_scene, &format!("sphere-{m}-data"))?;
            self.save(&b, &fit_scene, &format!("sphere-{m}-fit"))?;
            render_cpu::write_png(
                &self.args.out.join(format!("sphere-{m}-diff.png")),
                res.0,
                res.1,
                &false_colour(&map, 10.0),
            )?;
            let _ = writeln!(
                self.md,
                "| {m} | {} | {} | {prep} | {:.2} / {:.2} | {:.3} | {:.3} | {:.2} | ![data](sphere-{m}-data.png) ![fit](sphere-{m}-fit.png) ![diff](sphere-{m}-diff.png) |",
                fit_scene.materials[0].brdf_bytes, data_scene.materials[0].brdf_bytes, a.stats.seconds, b.stats.seconds,
                c.covered_mean_de2000, c.covered_mean_de76, c.p99_de2000
            );
            eprintln!("sphere {m}: dE2000 {:.3}", c.covered_mean_de2000);
        }
        self.md += "\nDifference images: CIEDE2000, black 0 to white 10.\n\n";
        Ok(())
    }

    fn variance_experiment(&mut self) -> Result<()> {
        let (res, spp) = if self.args.quick {
            ((48, 48), 8)
        } else {
            ((128, 128), 32)
        };
        self.md += "## Environment lighting: variance of one sample per channel\n\n";
        let _ = writeln!(self.md, "`scenes/sphere-sky.toml` (the measured table under a sky, direct lighting, BRDF sampling only), {}x{}, {spp} spp, seed 1; variance of one sample averaged over the pixels (the paper, nickel: rational 0.0017 to 0.0156 against tabulated 0.002).\n", res.0, res.1);
        self.md += "| material | sampler | sampler bytes | inverse CDFs | render (s) | variance r | variance g | variance b |\n|---|---|---|---|---|---|---|---|\n";
        for m in MATERIALS {
            for sampler in [
                SamplerKind::Cosine,
                SamplerKind::Tabulated,
                SamplerKind::Rational,
            ] {
                let mut o = self.swap("cm_military_green", m);
                o.resolution = Some(res);
                o.spp = Some(spp);
                o.seed = Some(1);
                o.sampler = Some(sampler);
                let (scene, prep) = self.scene("sphere-sky", o)?;
                let out = render(&scene, &|_, _| {});
                if m == "cm_military_green" {
                    self.save(&out, &scene, &format!("sky-{}", sampler.name()))?;
                }
                let v = out.stats.sample_variance;
                let bytes = scene
                    .materials
                    .iter()
                    .find(|x| x.name == m)
                    .map_or(0, |x| x.sampler_bytes);
                let _ = writeln!(
                    self.md,
                    "| {m} | {} | {bytes} | {prep} | {:.2} | {:.3e} | {:.3e} | {:.3e} |",
                    sampler.name(),
                    out.stats.seconds,
                    v[0],
                    v[1],
                    v[2]
                );
                eprintln!("sky {m} {}: variance g {:.3e}", sampler.name(), v[1]);
            }
        }
        self.md += "\nThe variance includes the grey ground plane (a Lambertian sampled by the same strategy).\n\n";
        Ok(())
    }

    fn gi_experiment(&mut self) -> Result<()> {
        let (res, spp) = if self.args.quick {
            ((64, 64), 8)
        } else {
            ((256, 256), 256)
        };
        self.md += "## Global illumination: tabulated against rational representations\n\n";
        let _ = writeln!(self.md, "`scenes/cornell.toml`, path tracing with MIS, {}x{}, {spp} spp. Tabulated: the measured tables with tabulated inverse CDFs; rational: the 2-D fits (20%) with rational inverse CDFs. The noise floor is the difference between two tabulated renders with different seeds (the paper: 1.67 KB + 0.6 KB against 480 KB + 30 MB, mean CIELAB difference 0.77).\n", res.0, res.1);
        let base = |me: &Self, sampler, seed| {
            let mut o = me.options();
            o.resolution = Some(res);
            o.spp = Some(spp);
            o.sampler = Some(sampler);
            o.seed = Some(seed);
            o
        };
        let (tab_scene, tab_prep) = self.scene("cornell", base(self, SamplerKind::Tabulated, 1))?;
        let tab = render(&tab_scene, &|_, _| {});
        let (tab2_scene, _) = self.scene("cornell", base(self, SamplerKind::Tabulated, 2))?;
        let tab2 = render(&tab2_scene, &|_, _| {});
        let mut o = base(self, SamplerKind::Rational, 1);
        o.swaps = ["vch_golden_yellow", "cm_military_green"]
            .iter()
            .map(|m| (m.to_string(), format!("{m}_fit")))
            .collect();
        let (rat_scene, rat_prep) = self.scene("cornell", o)?;
        let rat = render(&rat_scene, &|_, _| {});
        self.save(&tab, &tab_scene, "cornell-tabulated")?;
        self.save(&rat, &rat_scene, "cornell-rational")?;
        let (c, map) = compare(&tab.image, &rat.image, 1.0)?;
        let (noise, _) = compare(&tab.image, &tab2.image, 1.0)?;
        render_cpu::write_png(
            &self.args.out.join("cornell-diff.png"),
            res.0,
            res.1,
            &false_colour(&map, 10.0),
        )?;
        let measured = |s: &Scene| -> (usize, usize) {
            s.materials
                .iter()
                .filter(|m| m.brdf_bytes > 0)
                .fold((0, 0), |(a, b), m| (a + m.brdf_bytes, b + m.sampler_bytes))
        };
        let (tb, ts) = measured(&tab_scene);
        let (rb, rs) = measured(&rat_scene);
        self.md += "| representation | BRDF bytes | sampler bytes | fits and CDFs | render (s) |\n|---|---|---|---|---|\n";
        let _ = writeln!(
            self.md,
            "| tabulated (2 measured materials) | {tb} | {ts} | {tab_prep} | {:.1} |",
            tab.stats.seconds
        );
        let _ = writeln!(
            self.md,
            "| rational (their fits) | {rb} | {rs} | {rat_prep} | {:.1} |",
            rat.stats.seconds
        );
        let _ = writeln!(
            self.md,
            "\nMean CIEDE2000 tabulated vs rational **{:.3}** (CIE76 {:.3}); noise floor, tabulated vs tabulated with another seed: {:.3} (CIE76 {:.3}).\n\n![tabulated](cornell-tabulated.png) ![rational](cornell-rational.png) ![difference](cornell-diff.png)\n",
            c.covered_mean_de2000, c.covered_mean_de76, noise.covered_mean_de2000, noise.covered_mean_de76
        );
        eprintln!(
            "cornell: dE2000 {:.3}, noise {:.3}",
            c.covered_mean_de2000, noise.covered_mean_de2000
        );
        Ok(())
    }

    fn fps_experiment(&mut self) -> Result<()> {
        let res = if self.args.quick {
            (256, 192)
        } else {
            (1024, 768)
        };
        self.md += "## 256 directional lights: frames per second on the CPU\n\n";
        let _ = writeln!(self.md, "`scenes/lights256.toml`: {}x{}, 256 directional lights, no shadow rays (one convex mesh), a UV sphere of about 1K triangles, 1 sample per pixel, {} threads (the paper: 110 / 70 / 19 fps on a GTX 580 for 126 / 140 / 238 coefficients).\n", res.0, res.1, rayon::current_num_threads());
        self.md +=
            "| material | coefficients | bytes | render (s) | frames/s |\n|---|---|---|---|---|\n";
        let mut rows = Vec::new();
        for m in MATERIALS {
            for name in [format!("{m}_fit"), m.to_string()] {
                let mut o = self.swap("cm_military_green_fit", &name);
                o.resolution = Some(res);
                let (scene, _) = self.scene("lights256", o)?;
                let out = render(&scene, &|_, _| {});
                let mat = &scene.materials[0];
                // A fit stores 4 bytes (f32) per coefficient.
                let coeffs = if name.ends_with("_fit") {
                    (mat.brdf_bytes / 4).to_string()
                } else {
                    "table".into()
                };
                rows.push(format!(
                    "| {name} | {coeffs} | {} | {:.3} | {:.2} |",
                    mat.brdf_bytes,
                    out.stats.seconds,
                    1.0 / out.stats.seconds
                ));
                if name == "cm_military_green_fit" {
                    self.save(&out, &scene, "lights256")?;
                }
                eprintln!("lights256 {name}: {:.3} s", out.stats.seconds);
            }
        }
        self.md += &rows.join("\n");
        self.md += "\n\n";
        Ok(())
    }
}

/// Fits and inverse CDFs of a preparation, summed by kind:
/// `fits 0.45 s`, `3 CDFs 2.10 s, 2 cached`...
fn work(log: &PrepareLog) -> String {
    // Which kind of work an entry is: a fit of a material, or inverse CDFs.
    let kind = |e: &render_cpu::LogEntry| {
        if e.what.contains("sampler") {
            Some("CDF")
        } else if e.what.starts_with("material") && e.why.contains("fit") {
            Some("fit")
        } else {
            None
        }
    };
    let mut parts = Vec::new();
    for k in ["fit", "CDF"] {
        let of_kind = || log.entries.iter().filter(|e| kind(e) == Some(k));
        let made: Vec<f64> = of_kind()
            .filter(|e| e.action == Action::Prepared)
            .map(|e| e.seconds)
            .collect();
        let cached = of_kind().filter(|e| e.action == Action::Cached).count();
        if !made.is_empty() {
            parts.push(format!(
                "{} {k}s {:.2} s",
                made.len(),
                made.iter().sum::<f64>()
            ));
        }
        if cached > 0 {
            parts.push(format!("{cached} {k}s cached"));
        }
    }
    if parts.is_empty() {
        "-".into()
    } else {
        parts.join(", ")
    }
}

/// Runs `ratfit bench paper`.
pub fn run(args: PaperArgs) -> Result<()> {
    let start = Instant::now();
    std::fs::create_dir_all(&args.out)
        .with_context(|| format!("cannot create {}", args.out.display()))?;
    let mut r = Runner {
        args: &args,
        md: String::new(),
    };
    r.md = format!(
        "# Rendering experiments\n\n`ratfit bench paper --out {}`{}, {}, {} threads.\n\n",
        args.out.display(),
        if args.quick { " --quick" } else { "" },
        super::summary::utc_date(),
        rayon::current_num_threads()
    );
    r.sphere_experiment()?;
    r.variance_experiment()?;
    r.gi_experiment()?;
    r.fps_experiment()?;
    let _ = writeln!(r.md, "Total {:.0} s.", start.elapsed().as_secs_f64());
    let path: &Path = &args.out.join("experiments.md");
    crate::output::write(path, &r.md)?;
    println!("{}", r.md);
    println!("wrote {}", path.display());
    Ok(())
}
