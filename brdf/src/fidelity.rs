//! How close a representation is to its table in BRDF space, over the whole
//! hemisphere: relative errors by band of the larger elevation, and the
//! largest value anywhere against the table's peak (an exploding fit must
//! show).

use crate::fitted::FittedBrdf;
use crate::geometry::{from_spherical, HalfDiff, Vec3};
use crate::Brdf;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

use crate::colour::luminance;

/// Relative errors over the direction pairs whose larger elevation falls in
/// one band.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BandErrors {
    /// Lower end of the band (degrees).
    pub from_deg: f64,
    /// Upper end of the band (degrees).
    pub to_deg: f64,
    /// Pairs in the band with a table value above the floor.
    pub pairs: usize,
    /// Median relative error.
    pub median: f64,
    /// 90th percentile.
    pub p90: f64,
    /// Largest.
    pub max: f64,
}

/// BRDF-space figures of a representation against its table.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct HemisphereErrors {
    /// Bands 0-70, 70-80 and 80-90 degrees of the larger elevation.
    pub bands: Vec<BandErrors>,
    /// Median relative error with both elevations below 80 degrees.
    pub median_below_80: f64,
    /// Largest value of the representation on a dense grid of the whole
    /// hemisphere over the table's largest value there, the worse channel.
    pub peak_ratio: f64,
}

/// Settings of [`hemisphere_errors`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HemisphereSettings {
    /// Random direction pairs (a quarter near the mirror direction).
    pub pairs: usize,
    /// Seed of the pairs.
    pub seed: u64,
    /// Dense grid for the peak check: `theta_h`, `theta_d`, `phi_d` bins.
    pub grid: [usize; 3],
    /// Pairs whose table luminance is below this fraction of the table's
    /// peak luminance are left out of the relative errors (a thousandth of
    /// the peak is invisible, and measured tables hold zeros and small
    /// negative values there).
    pub floor: f64,
}

impl Default for HemisphereSettings {
    /// 40,000 pairs, a 64 x 64 x 32 grid, a floor of 1e-3.
    fn default() -> Self {
        Self {
            pairs: 40_000,
            seed: 1,
            grid: [64, 64, 32],
            floor: 1e-3,
        }
    }
}

/// Direction pairs: uniform in solid angle over the hemisphere, every
/// fourth pair near the mirror direction (within about 3 degrees), where
/// specular peaks are.
pub fn validation_pairs(n: usize, seed: u64) -> Vec<(Vec3, Vec3)> {
    let mut state =
        crate::io::merl::SplitMix::new(seed.wrapping_mul(0x2545_F491_4F6C_DD1D) ^ 0x5851_F42D);
    let mut out = Vec::with_capacity(n);
    while out.len() < n {
        let mut dir = || {
            let z: f64 = state.uniform().max(1e-6);
            from_spherical(z.acos(), 2.0 * PI * state.uniform())
        };
        let wi = dir();
        let wo = if out.len() % 4 == 3 {
            let (t, p) = crate::geometry::to_spherical(wi);
            let jitter = 0.05 * (state.uniform() - 0.5);
            from_spherical(
                (t + jitter).clamp(0.0, PI / 2.0 - 1e-4),
                p + PI + 0.1 * (state.uniform() - 0.5),
            )
        } else {
            dir()
        };
        out.push((wi, wo));
    }
    out
}

fn percentile(sorted: &[f64], q: f64) -> f64 {
    if sorted.is_empty() {
        return 0.0;
    }
    let i = ((sorted.len() - 1) as f64 * q).round() as usize;
    sorted[i]
}

/// Largest value per channel on `pairs` with both elevations above
/// `cos_min` (NaN counts as infinite).
fn maxima(b: &dyn Brdf, pairs: &[(Vec3, Vec3)], cos_min: f64) -> [f64; 3] {
    pairs
        .par_iter()
        .filter(|(wi, wo)| wi[2].min(wo[2]) > cos_min)
        .map(|&(wi, wo)| b.eval(wi, wo))
        .reduce(
            || [0.0; 3],
            |a, v| [0, 1, 2].map(|c| a[c].max(if v[c].is_nan() { f64::INFINITY } else { v[c] })),
        )
}

/// The table's peak per channel on the grid's pairs: within 80 degrees of
/// the normal, since measured tables divide by a vanishing cosine at the
/// horizon.
fn table_peak(table: &dyn Brdf, pairs: &[(Vec3, Vec3)]) -> [f64; 3] {
    maxima(table, pairs, 80f64.to_radians().cos())
}

/// The worse channel's ratio of a candidate's largest values to the table's.
fn worst_ratio(candidate: [f64; 3], table: [f64; 3]) -> f64 {
    (0..3)
        .filter(|&c| table[c] > 0.0)
        .map(|c| candidate[c] / table[c])
        .fold(0.0, f64::max)
}

/// The peak check of [`hemisphere_errors`]: the candidate's largest value on
/// a dense `grid` of the whole hemisphere (cell centres of sqrt-warped
/// `theta_h`, `theta_d`, `phi_d`) over the table's, the worse channel, and
/// the table's peak.
pub fn peaks(table: &dyn Brdf, candidate: &dyn Brdf, grid: [usize; 3]) -> (f64, [f64; 3]) {
    let pairs = HalfDiff::cell_centres(grid);
    let table_peak = table_peak(table, &pairs);
    (
        worst_ratio(maxima(candidate, &pairs, 0.0), table_peak),
        table_peak,
    )
}

/// The peak check of a fit, with its ceiling and without.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct FitPeaks {
    /// The grid (`theta_h`, `theta_d`, `phi_d` cells).
    pub grid: [usize; 3],
    /// The fit's largest value over the table's peak, the worse channel.
    pub ratio: f64,
    /// The same for the fit's functions alone, without the ceiling.
    pub ratio_without_ceiling: f64,
}

/// [`peaks`] of a fit with its ceiling and without, evaluating the table
/// and the fit once each: the ceiling is a minimum per channel, so the
/// largest ceiled value is the ceiling's minimum with the largest value.
pub fn fit_peaks(table: &dyn Brdf, fit: &FittedBrdf, grid: [usize; 3]) -> FitPeaks {
    let pairs = HalfDiff::cell_centres(grid);
    let table_peak = table_peak(table, &pairs);
    let unclamped = FittedBrdf {
        ceiling: None,
        ..fit.clone()
    };
    let largest = maxima(&unclamped, &pairs, 0.0);
    let ceiled = match fit.ceiling {
        Some(c) => [0, 1, 2].map(|k| largest[k].min(c[k])),
        None => largest,
    };
    FitPeaks {
        grid,
        ratio: worst_ratio(ceiled, table_peak),
        ratio_without_ceiling: worst_ratio(largest, table_peak),
    }
}

impl std::fmt::Display for FitPeaks {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let [a, b, c] = self.grid;
        write!(
            f,
            "largest value on a {a} x {b} x {c} grid of the hemisphere: {:.3}x the table's peak (without the ceiling: {:.3}x)",
            self.ratio, self.ratio_without_ceiling
        )
    }
}

/// Relative luminance errors of `candidate` against `table` by band of the
/// larger elevation, and the peak check on a dense grid.
pub fn hemisphere_errors(
    table: &dyn Brdf,
    candidate: &dyn Brdf,
    settings: &HemisphereSettings,
) -> HemisphereErrors {
    let (peak_ratio, table_peak) = peaks(table, candidate, settings.grid);
    let pairs = validation_pairs(settings.pairs, settings.seed);
    let floor = settings.floor * luminance(table_peak);
    let rows: Vec<(f64, f64)> = pairs
        .par_iter()
        .filter_map(|&(wi, wo)| {
            let t = luminance(table.eval(wi, wo));
            if t.is_nan() || t <= floor {
                return None;
            }
            let f = luminance(candidate.eval(wi, wo));
            let elevation = wi[2].min(wo[2]).clamp(-1.0, 1.0).acos().to_degrees();
            let e = if f.is_finite() {
                (f / t - 1.0).abs()
            } else {
                f64::INFINITY
            };
            Some((elevation, e))
        })
        .collect();
    let band = |from: f64, to: f64| {
        let mut e: Vec<f64> = rows
            .iter()
            .filter(|(el, _)| *el >= from && *el < to)
            .map(|r| r.1)
            .collect();
        e.sort_by(f64::total_cmp);
        BandErrors {
            from_deg: from,
            to_deg: to,
            pairs: e.len(),
            median: percentile(&e, 0.5),
            p90: percentile(&e, 0.9),
            max: e.last().copied().unwrap_or(0.0),
        }
    };
    let mut below: Vec<f64> = rows.iter().filter(|r| r.0 < 80.0).map(|r| r.1).collect();
    below.sort_by(f64::total_cmp);
    HemisphereErrors {
        bands: vec![band(0.0, 70.0), band(70.0, 80.0), band(80.0, 90.1)],
        median_below_80: percentile(&below, 0.5),
        peak_ratio,
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BlinnPhong, Lambert};

    #[test]
    fn a_material_against_itself_has_no_error_and_a_unit_peak_ratio() {
        let m = BlinnPhong {
            kd: [0.2, 0.3, 0.4],
            ks: [0.5; 3],
            exponent: 50.0,
        };
        let s = HemisphereSettings {
            pairs: 4000,
            grid: [16, 16, 8],
            ..Default::default()
        };
        let e = hemisphere_errors(&m, &m, &s);
        assert_eq!(e.bands.len(), 3);
        assert!(e.bands.iter().all(|b| b.max == 0.0 && b.pairs > 0));
        assert!((e.peak_ratio - 1.0).abs() < 1e-12);
        // A diffuse stand-in misses the lobe: large errors, a small peak.
        let flat = Lambert {
            albedo: [0.2, 0.3, 0.4],
        };
        let e = hemisphere_errors(&m, &flat, &s);
        assert!(e.bands[0].p90 > 0.5 && e.peak_ratio < 0.5, "{e:?}");
    }
}
