//! The honest peers of the rational representations: Cook-Torrance GGX
//! fitted to the whole material, the table downsampled to the same bytes
//! (and to 1 KB), and the table kept at the 3-D fits' own grid.

use super::{measure, Candidate, Judge, Row};
use anyhow::Result;
use brdf::DownsampledTable;
use std::sync::Arc;
use std::time::Instant;

/// The peers of one material, measured; `rational_bytes` are the bytes of
/// its rational representations, each a budget of a downsampled table.
pub(super) fn measure_peers(judge: &Judge, rational_bytes: &[usize]) -> Result<Vec<Row>> {
    let mut rows = Vec::new();
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
    rows.push(row);
    // The table downsampled to the bytes of each rational representation
    // and to 1 KB.
    let mut budgets: Vec<usize> = rational_bytes.iter().copied().chain([1024]).collect();
    budgets.sort_unstable();
    // Two budgets may give the same grid: measure each grid once.
    let mut grids: Vec<[usize; 3]> = budgets
        .into_iter()
        .map(DownsampledTable::bins_for_bytes)
        .collect();
    grids.sort_by_key(|b| (b[0] * b[1] * b[2], *b));
    grids.dedup();
    for bins in grids {
        rows.push(measure_table(judge, bins, |size| {
            (
                format!("table downsampled to {size} B"),
                format!("{}x{}x{} cells", bins[0], bins[1], bins[2]),
            )
        })?);
    }
    // The table kept at the 3-D fits' own grid (cell averages, interpolated
    // like the peer above): what the sampling alone loses, before any fit.
    let n = judge.plan.resolution_3d;
    rows.push(measure_table(judge, [n, n, n], |size| {
        (
            format!("table on the 3-D fits' grid ({size} B)"),
            format!("{n}x{n}x{n} cells: the resolution the 3-D fits sample"),
        )
    })?);
    Ok(rows)
}

/// The table averaged over a `bins` grid, measured; `describe` names the
/// row and its note from the grid's bytes.
fn measure_table(
    judge: &Judge,
    bins: [usize; 3],
    describe: impl FnOnce(usize) -> (String, String),
) -> Result<Row> {
    let start = Instant::now();
    let table = DownsampledTable::new(judge.table, bins);
    let bytes = table.byte_size_f32();
    let fit_s = start.elapsed().as_secs_f64();
    let (name, note) = describe(bytes);
    measure(
        judge,
        Candidate {
            name,
            brdf: Arc::new(table),
            bytes,
            fit_s,
            note,
        },
    )
}
