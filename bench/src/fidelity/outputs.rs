//! What `bench fidelity` writes and checks: `results.csv`, `summary.md`,
//! the error-against-bytes chart and the images of each representation.

use super::{shell_row_suffix, FidelityArgs, Row};
use crate::chart::{pareto_front, Figure, Panel};
use crate::summary::utc_date;
use anyhow::Result;
use render_cpu::fidelity::ValidationScene;
use render_cpu::{false_colour, Image};
use std::fmt::Write as _;
use std::path::Path;
fn slug(s: &str) -> String {
    s.chars()
        .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
        .collect::<String>()
        .split('_')
        .filter(|p| !p.is_empty())
        .collect::<Vec<_>>()
        .join("_")
}

pub(super) fn write_images(
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

pub(super) fn write_outputs(
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
        } else if name.starts_with("table downsampled") {
            "table downsampled".into()
        } else if name.starts_with("table on") {
            "table on the 3-D fits' grid".into()
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
    best_within_budget(&mut md, rows, noise);
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

/// The bytes of the fidelity target (an RGB material).
const BUDGET_BYTES: usize = 1024;

/// The render target: mean CIEDE2000 on both scenes.
const TARGET_DE: f64 = 1.0;

/// The row of `material` with the lowest worse-scene mean CIEDE2000 within
/// `bytes` (the fewer bytes between equal errors).
fn best_within<'a>(rows: &'a [Row], material: &str, bytes: usize) -> Option<&'a Row> {
    rows.iter()
        .filter(|r| r.material == material && r.bytes <= bytes)
        .min_by(|a, b| {
            a.render
                .worst_mean()
                .total_cmp(&b.render.worst_mean())
                .then(a.bytes.cmp(&b.bytes))
        })
}

/// The headline: each material's best representation within
/// [`BUDGET_BYTES`] and how far its worse scene is from [`TARGET_DE`].
fn best_within_budget(md: &mut String, rows: &[Row], noise: &[(String, Vec<f64>)]) {
    let _ = writeln!(
        md,
        "\nBest within {BUDGET_BYTES} bytes (the lowest worse-scene mean CIEDE2000; target {TARGET_DE} on both scenes):\n\n\
         | material | representation | bytes | lights / sky | worse scene | rel <80 med | peak x |\n|---|---|---|---|---|---|---|"
    );
    for (m, _) in noise {
        let Some(r) = best_within(rows, m, BUDGET_BYTES) else {
            let _ = writeln!(md, "| {m} | none within {BUDGET_BYTES} B | | | | | |");
            continue;
        };
        let worst = r.render.worst_mean();
        let verdict = if worst <= TARGET_DE {
            "met".to_string()
        } else {
            format!("{:.1}x the target", worst / TARGET_DE)
        };
        let _ = writeln!(
            md,
            "| {m} | {} | {} | {:.3} / {:.3} | {worst:.3} ({verdict}) | {:.3} | {:.2} |",
            r.representation,
            r.bytes,
            r.render.scenes[0].mean_de,
            r.render.scenes[1].mean_de,
            r.hemisphere.median_below_80,
            r.hemisphere.peak_ratio
        );
    }
}

/// Checks a finished run: every file present, every figure finite, and,
/// with `target_bytes`, a target fit within it for every material.
pub(super) fn check(
    out: &Path,
    rows: &[Row],
    noise: &[(String, Vec<f64>)],
    target_bytes: Option<usize>,
) -> Vec<String> {
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
    let headline = format!("Best within {BUDGET_BYTES} bytes");
    match std::fs::read_to_string(out.join("summary.md")) {
        Ok(md) if md.contains(&headline) => {}
        Ok(_) => problems.push(format!("summary.md lacks the table \"{headline}\"")),
        Err(_) => {} // reported above as missing
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
        problems.extend(check_material(out, m, &reps, target_bytes));
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

/// The checks of one material's rows `reps`: every kind of representation
/// measured, each evaluation within a cut also with each shell factor, the
/// target fit (with `target_bytes`) within its budget, the table's images.
fn check_material(out: &Path, m: &str, reps: &[&Row], target_bytes: Option<usize>) -> Vec<String> {
    let mut problems = Vec::new();
    if !reps
        .iter()
        .any(|r| r.representation.starts_with("rational"))
    {
        problems.push(format!("{m}: no rational representation was measured"));
    }
    for (prefix, what) in [
        ("table downsampled", "no downsampled table was measured"),
        (
            "table on",
            "the table on the 3-D fits' grid was not measured",
        ),
    ] {
        if !reps.iter().any(|r| r.representation.starts_with(prefix)) {
            problems.push(format!("{m}: {what}"));
        }
    }
    // Every fit evaluated within a cut is also measured with each of its
    // shell factors, which cost bytes.
    for plain in reps.iter().filter(|r| {
        r.representation.contains("evaluated within")
            && !r.representation.contains(", shell factor")
    }) {
        for layout in brdf::SHELL_CHOICES {
            let name = format!(
                "{}, shell factor{}",
                plain.representation,
                shell_row_suffix(layout)
            );
            let factor_bytes = layout.byte_size_f32();
            match reps.iter().find(|r| r.representation == name) {
                Some(r) if r.bytes == plain.bytes + factor_bytes => {}
                Some(r) => problems.push(format!(
                    "{m}: {name} has {} bytes, not the fit's {} and {factor_bytes} for its factors",
                    r.bytes, plain.bytes,
                )),
                None => problems.push(format!("{m}: {name} was not measured")),
            }
        }
    }
    if let Some(max) = target_bytes {
        match reps
            .iter()
            .find(|r| r.representation.starts_with("rational target"))
        {
            Some(r) if r.bytes <= max => {}
            Some(r) => problems.push(format!(
                "{m}: the target fit has {} bytes, over its budget of {max}",
                r.bytes
            )),
            None => problems.push(format!("{m}: the target fit was not measured")),
        }
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
    problems
}
