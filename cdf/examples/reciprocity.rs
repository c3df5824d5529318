//! How far a measured table is from reciprocal, as the azimuth map sees it:
//! for every pair of tabulated view elevations `(a, b)`, the conditional
//! azimuth CDF at `(theta_v, theta_l) = (a, b)` against the one at `(b, a)`
//! (the nearest `theta_l` row), at 15 quantiles. A fit symmetric in the two
//! elevations can meet both only where their CDF-space intervals of
//! half-width `delta` overlap; the example counts the disjoint ones.
//!
//! `cargo run --release -p cdf --example reciprocity -- FILE.bsdf`

use brdf::{Brdf, RglBrdf};
use cdf::{CdfTable, TableSettings};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let path = std::env::args()
        .nth(1)
        .ok_or("usage: reciprocity FILE.bsdf (an RGL file)")?;
    let material = RglBrdf::read(std::path::Path::new(&path))?;
    let table = CdfTable::new(&material, TableSettings::default())?;
    let views = table.settings().views();
    let rows = table.cells().0;
    let row_of =
        |theta: f64| ((theta / table.cell_size().0 - 0.5).round().max(0.0) as usize).min(rows - 1);
    for delta in [0.025, 0.05, 0.1] {
        let (mut pairs, mut disjoint, mut widest) = (0, 0, 0.0_f64);
        for i in 0..views {
            for k in (0..views).filter(|&k| k != i) {
                let (a, b) = (table.view(i), table.view(k));
                let (j, j_swapped) = (row_of(b), row_of(a));
                for q in 1..16 {
                    let tau = f64::from(q) / 16.0;
                    let (lo, hi) = ((tau - delta).max(0.0), (tau + delta).min(1.0));
                    let ab = (table.inverse_phi(i, j, lo), table.inverse_phi(i, j, hi));
                    let ba = (
                        table.inverse_phi(k, j_swapped, lo),
                        table.inverse_phi(k, j_swapped, hi),
                    );
                    pairs += 1;
                    let gap = (ab.0 - ba.1).max(ba.0 - ab.1);
                    if gap > 0.0 {
                        disjoint += 1;
                        widest = widest.max(gap);
                    }
                }
            }
        }
        println!(
            "{}: delta {delta}: {disjoint} of {pairs} swapped pairs disjoint (widest gap {widest:.3} rad)",
            material.name()
        );
    }
    Ok(())
}
