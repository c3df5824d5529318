//! Intervals designed from what a render sees, instead of one relative
//! tolerance everywhere.
//!
//! A render shows `f cos_l E`: an error `df` at a direction pair whose
//! cosine-weighted value `f cos_i cos_o` is a small fraction of the
//! material's peak cannot be seen, and near the horizon the measured value
//! itself is a small number divided by a vanishing cosine. So each cell gets
//! the widest of three half-widths:
//!
//! * perceptual: `rel_tol * v` (a lightness error of about `22 rel_tol`
//!   CIELAB units at mid grey);
//! * visibility: `visibility * median(f cos_i cos_o) / (cos_i cos_o)`, an
//!   absolute floor on the cosine-weighted value relative to the level most
//!   of a render shows (not the specular peak, which covers few pixels),
//!   loose towards grazing. For the functions that carry the light (the
//!   luminance of the luminance-chroma mode, each channel of an RGB fit)
//!   the floor follows the tolerance, at most `visibility`
//!   ([`PerceptualBounds::light_floor_per_tol`]): a fixed 2% would bind
//!   most dim cells of a fit at 8% and leave a dark body 20% off where the
//!   renders see it;
//! * noise: `noise_factor * sigma * v`, never tighter than the measurement's
//!   own scatter, with `sigma` estimated from the table ([`estimate_noise`]).
//!
//! Every cell of the hemisphere stays in the fit (none is cut), and upper
//! bounds never exceed `peak_cap` times the channel's peak, so the fitted
//! values are bounded where they are sampled; `brdf::fidelity` checks them on
//! a dense grid between samples. Beyond 70 degrees of elevation (where
//! measured tables divide small values by a vanishing cosine) the half-width
//! grows linearly to the whole value at 80 degrees; beyond 80 degrees a cell
//! only keeps the fit within `[0, peak_cap * peak]`.

use crate::reduce::Samples;
use crate::BrdfError;
use rational_core::IntervalData;
use serde::{Deserialize, Serialize};
use std::collections::HashMap;

/// Elevation (degrees) within which measured values are trusted for the
/// peak and the per-`theta_h` noise: beyond it measured tables divide small
/// values by a vanishing cosine.
pub const TRUSTED_ELEVATION_DEG: f64 = 70.0;

/// Width (degrees) of the elevation bands of the noise estimate.
const BAND_DEG: f64 = 10.0;

/// Settings of the perceptual interval design.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PerceptualBounds {
    /// Relative half-width where the reflected light is visible.
    pub rel_tol: f64,
    /// Absolute floor on `f cos_i cos_o`, as a fraction of its median over
    /// the trusted elevations.
    pub visibility: f64,
    /// For the function that carries the light, the floor is at most this
    /// multiple of `rel_tol` (and at most `visibility`), so that a tighter
    /// tolerance also tightens the dim cells: `1/16` gives the visibility
    /// floor of 2% at +-32% and 0.5% at +-8%. `None` (fit files written
    /// before it) keeps `visibility` for every function.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub light_floor_per_tol: Option<f64>,
    /// Half-widths are at least this many estimated noise deviations.
    pub noise_factor: f64,
    /// Upper bounds are at most this multiple of the channel's peak (and
    /// the dense cap check of `brdf::fitting` holds the fit below it).
    pub peak_cap: f64,
}

/// The default [`PerceptualBounds::light_floor_per_tol`]. Measured on the
/// RGL files with `--target-de 1 --max-bytes 1024`, it lowers the worse
/// scene's error on six of the eleven and raises it on one
/// (docs/results/fidelity-2026-12-05-light-floor.md).
pub const LIGHT_FLOOR_PER_TOL: f64 = 1.0 / 16.0;

/// The cap on a fitted value, as a multiple of the channel's largest upper
/// bound, that the dense cap check enforces on plain fits and that the
/// perceptual design uses by default.
pub const DEFAULT_PEAK_CAP: f64 = 1.5;

impl Default for PerceptualBounds {
    /// 4% where visible (about one CIEDE2000 unit at mid grey), a floor of
    /// 2% of the median cosine-weighted value (for the luminance and RGB
    /// channels, a sixteenth of the tolerance when that is less), two noise
    /// deviations, a cap of [`DEFAULT_PEAK_CAP`] times the peak.
    fn default() -> Self {
        Self {
            rel_tol: 0.04,
            visibility: 0.02,
            light_floor_per_tol: Some(LIGHT_FLOOR_PER_TOL),
            noise_factor: 2.0,
            peak_cap: DEFAULT_PEAK_CAP,
        }
    }
}

impl PerceptualBounds {
    /// The same design with another relative half-width.
    ///
    /// # Errors
    /// Not in `(0, 1)`.
    pub fn with_rel_tol(mut self, t: f64) -> Result<Self, BrdfError> {
        if !(t > 0.0 && t < 1.0) {
            return Err(BrdfError::Invalid {
                name: "relative tolerance",
                reason: format!("{t} is not in (0, 1)"),
            });
        }
        self.rel_tol = t;
        Ok(self)
    }

    /// The visibility floor of the function that carries the light:
    /// `min(visibility, light_floor_per_tol * rel_tol)`, or `visibility`
    /// without a proportional floor.
    pub fn light_floor(&self) -> f64 {
        self.light_floor_per_tol
            .map_or(self.visibility, |k| self.visibility.min(k * self.rel_tol))
    }

    /// The same design for the function that carries the light: its
    /// visibility floor is [`PerceptualBounds::light_floor`].
    pub fn for_light(mut self) -> Self {
        self.visibility = self.light_floor();
        self
    }

    /// Checks every field.
    ///
    /// # Errors
    /// A field out of range or not finite.
    pub fn validate(&self) -> Result<(), BrdfError> {
        let bad = |name: &'static str, v: f64| BrdfError::Invalid {
            name,
            reason: format!("{v} is out of range"),
        };
        if !(self.rel_tol > 0.0 && self.rel_tol < 1.0) {
            return Err(bad("relative tolerance", self.rel_tol));
        }
        if !(self.visibility >= 0.0 && self.visibility < 1.0) {
            return Err(bad("visibility floor", self.visibility));
        }
        if let Some(k) = self.light_floor_per_tol {
            if !(k >= 0.0 && k.is_finite()) {
                return Err(bad("light floor per tolerance", k));
            }
        }
        if !(self.noise_factor >= 0.0 && self.noise_factor.is_finite()) {
            return Err(bad("noise factor", self.noise_factor));
        }
        if !(self.peak_cap >= 1.0 && self.peak_cap.is_finite()) {
            return Err(bad("peak cap", self.peak_cap));
        }
        Ok(())
    }
}

/// The relative noise of one channel of a table, estimated from the data.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct NoiseEstimate {
    /// Over the whole table: relative standard deviation.
    pub global: f64,
    /// Per `theta_h` bin within the trusted elevations (the lobe's centre
    /// is noisier than its tail); the global figure where a bin has too few
    /// cells.
    pub by_theta_h: Vec<f64>,
    /// Per 10-degree band of the larger elevation, over every cell (tables
    /// are noisier towards grazing); the global figure where a band has too
    /// few cells.
    pub by_elevation: Vec<f64>,
}

impl NoiseEstimate {
    /// The estimate for a cell in `theta_h` bin `i` whose larger elevation
    /// is `elevation_deg`: the larger of its bin's and its band's.
    pub fn at(&self, i: usize, elevation_deg: f64) -> f64 {
        let band = ((elevation_deg / BAND_DEG).max(0.0) as usize)
            .min(self.by_elevation.len().saturating_sub(1));
        let h = self.by_theta_h.get(i).copied().unwrap_or(self.global);
        let e = self.by_elevation.get(band).copied().unwrap_or(self.global);
        h.max(e)
    }
}

/// Median absolute value over the normal's median absolute deviation and
/// the standard deviation of a second difference of iid noise (`sqrt 6`).
fn robust_sigma(mut d2: Vec<f64>) -> Option<f64> {
    if d2.len() < 8 {
        return None;
    }
    let mid = d2.len() / 2;
    let (_, m, _) = d2.select_nth_unstable_by(mid, f64::total_cmp);
    Some(*m / (0.674_49 * 6f64.sqrt()))
}

/// Estimates the multiplicative noise of channel `c` from second
/// differences of `ln v` along `theta_d` (the smoothest axis of a BRDF):
/// for `v = m (1 + sigma e)` with a smooth `m`, `ln v_(j-1) - 2 ln v_j +
/// ln v_(j+1)` has standard deviation `sqrt(6) sigma`. A robust median keeps
/// the curvature of the signal and outliers from dominating. Cells with an
/// elevation above 80 degrees or a non-positive value are left out; scattered
/// samples (no grid) give zero.
pub fn estimate_noise(samples: &Samples, c: usize) -> NoiseEstimate {
    let mut by_cell: HashMap<[u32; 3], (f64, f64)> = HashMap::with_capacity(samples.rows.len());
    let mut n_h = 0usize;
    for r in &samples.rows {
        if let Some(cell) = r.cell {
            let v = r.value[c];
            if v > 0.0 && v.is_finite() {
                by_cell.insert(cell, (v.ln(), max_elevation_deg(r.angles)));
                n_h = n_h.max(cell[0] as usize + 1);
            }
        }
    }
    let n_bands = (90.0 / BAND_DEG) as usize;
    let mut rows: Vec<Vec<f64>> = vec![Vec::new(); n_h];
    let mut bands: Vec<Vec<f64>> = vec![Vec::new(); n_bands];
    for (cell, &(l, elevation)) in &by_cell {
        let [i, j, k] = *cell;
        if j == 0 {
            continue;
        }
        if let (Some(a), Some(b)) = (by_cell.get(&[i, j - 1, k]), by_cell.get(&[i, j + 1, k])) {
            let d2 = (a.0 - 2.0 * l + b.0).abs();
            let worst = elevation.max(a.1).max(b.1);
            bands[((worst / BAND_DEG) as usize).min(n_bands - 1)].push(d2);
            if worst <= TRUSTED_ELEVATION_DEG {
                rows[i as usize].push(d2);
            }
        }
    }
    let global = robust_sigma(rows.iter().flatten().copied().collect()).unwrap_or(0.0);
    // A bin's estimate pools its neighbours (about 3 bins) for stability.
    let by_theta_h = (0..n_h)
        .map(|i| {
            let pooled: Vec<f64> = rows[i.saturating_sub(1)..(i + 2).min(n_h)]
                .iter()
                .flatten()
                .copied()
                .collect();
            robust_sigma(pooled).unwrap_or(global)
        })
        .collect();
    let by_elevation = bands
        .into_iter()
        .map(|b| robust_sigma(b).unwrap_or(global))
        .collect();
    NoiseEstimate {
        global,
        by_theta_h,
        by_elevation,
    }
}

/// The larger elevation (degrees) of a cell's two directions.
pub(crate) fn max_elevation_deg(angles: [f64; 3]) -> f64 {
    let (wi, wo) = crate::geometry::HalfDiff::pair_at(angles);
    wi[2].min(wo[2]).clamp(-1.0, 1.0).acos().to_degrees()
}

impl Samples {
    /// The colour most of a render shows, as linear sRGB: the median of
    /// each function (the samples hold `mode`'s functions) over the cells
    /// within the trusted elevations, combined. Black when there is none.
    pub fn typical_colour(&self, mode: crate::ColourMode) -> [f64; 3] {
        let median = |c: usize| {
            let mut v: Vec<f64> = self
                .rows
                .iter()
                .filter(|r| {
                    r.value[c].is_finite() && max_elevation_deg(r.angles) <= TRUSTED_ELEVATION_DEG
                })
                .map(|r| r.value[c])
                .collect();
            if v.is_empty() {
                return 0.0;
            }
            let mid = v.len() / 2;
            *v.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        mode.combine([median(0), median(1), median(2)])
    }
}

/// What the design used for one channel.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelBounds {
    /// Relative half-width where the light is visible (the design's, times
    /// the colour mode's perceptual factor for this function).
    #[serde(default)]
    pub rel_tol: f64,
    /// The visibility floor used, as a fraction of the median of
    /// `f cos_i cos_o` (0 in reports written before it was recorded).
    #[serde(default)]
    pub visibility: f64,
    /// Largest value over cells within 70 degrees of the normal.
    pub peak: f64,
    /// Median of `f cos_i cos_o` there.
    pub weighted_median: f64,
    /// The noise estimate (relative).
    pub noise: f64,
    /// Cells whose half-width is the perceptual one.
    pub perceptual_cells: usize,
    /// Cells whose half-width is the visibility floor or the loosening
    /// beyond the trusted elevations.
    pub floor_cells: usize,
    /// Cells whose half-width is the noise.
    pub noise_cells: usize,
}

impl Samples {
    /// Interval data of channel `c` under the perceptual design: every cell
    /// with a finite value (non-positive values get `[0, h]`), the rows
    /// used, and what the design used.
    ///
    /// # Errors
    /// No usable cell, invalid settings, or invalid values.
    pub fn channel_perceptual(
        &self,
        c: usize,
        bounds: &PerceptualBounds,
    ) -> Result<(IntervalData, Vec<usize>, ChannelBounds), BrdfError> {
        bounds.validate()?;
        let fit_err = |e| BrdfError::Fit {
            channel: ['r', 'g', 'b'][c],
            source: e,
        };
        let used: Vec<usize> = (0..self.rows.len())
            .filter(|&i| {
                let r = &self.rows[i];
                r.value[c].is_finite() && r.lo[c].is_finite() && r.hi[c].is_finite()
            })
            .collect();
        let trusted =
            |r: &crate::reduce::SampleRow| max_elevation_deg(r.angles) <= TRUSTED_ELEVATION_DEG;
        let mut peak = 0.0_f64;
        let mut weighted: Vec<f64> = Vec::new();
        for &i in &used {
            let r = &self.rows[i];
            if trusted(r) {
                peak = peak.max(r.hi[c]);
                weighted.push(r.value[c].max(0.0) * r.cos_weight);
            }
        }
        let mid = weighted.len() / 2;
        let weighted_median = if weighted.is_empty() {
            0.0
        } else {
            *weighted.select_nth_unstable_by(mid, f64::total_cmp).1
        };
        if peak.is_nan() || peak <= 0.0 {
            return Err(fit_err(rational_core::FitError::Empty));
        }
        let noise = estimate_noise(self, c);
        let cap = bounds.peak_cap * peak;
        let mut info = ChannelBounds {
            rel_tol: bounds.rel_tol,
            visibility: bounds.visibility,
            peak,
            weighted_median,
            noise: noise.global,
            perceptual_cells: 0,
            floor_cells: 0,
            noise_cells: 0,
        };
        let (mut lo, mut hi, mut values) = (
            Vec::with_capacity(used.len()),
            Vec::with_capacity(used.len()),
            Vec::with_capacity(used.len()),
        );
        for &i in &used {
            let r = &self.rows[i];
            // The measured interval, clamped into [0, peak]: values beyond
            // the peak only occur where a cosine vanishes.
            let (a, b) = (r.lo[c].clamp(0.0, peak), r.hi[c].clamp(0.0, peak));
            let v = r.value[c].clamp(0.0, peak);
            let sigma = r.cell.map_or(noise.global, |cell| {
                noise.at(cell[0] as usize, max_elevation_deg(r.angles))
            });
            let perceptual = bounds.rel_tol * v;
            let floor = bounds.visibility * weighted_median / r.cos_weight.max(1e-6);
            let scatter = bounds.noise_factor * sigma * v;
            // Beyond the trusted elevations the table divides by a vanishing
            // cosine: the half-width grows to the whole value by 80 degrees,
            // and beyond 80 only the cap bounds the fit.
            let elevation = max_elevation_deg(r.angles);
            let untrusted = ((elevation - TRUSTED_ELEVATION_DEG) / 10.0).max(0.0) * v;
            if elevation > TRUSTED_ELEVATION_DEG + 10.0 {
                info.floor_cells += 1;
                lo.push(0.0);
                hi.push(cap.max(b));
                values.push(v);
                continue;
            }
            let h = perceptual.max(floor).max(scatter).max(untrusted);
            if perceptual >= floor && perceptual >= scatter && perceptual >= untrusted {
                info.perceptual_cells += 1;
            } else if floor >= scatter || untrusted >= scatter {
                info.floor_cells += 1;
            } else {
                info.noise_cells += 1;
            }
            lo.push((a - h).max(0.0));
            hi.push((b + h).min(cap.max(b)));
            values.push(v);
        }
        let points = used
            .iter()
            .flat_map(|&i| self.rows[i].point.iter().copied())
            .collect();
        let data = IntervalData::new(self.dims, points, lo, hi)
            .and_then(|d| d.with_values(values))
            .map_err(fit_err)?;
        Ok((data, used, info))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BlinnPhong, MerlBrdf, Reduction, TabulateOptions};

    fn noisy_table(noise: f64) -> Samples {
        let truth = BlinnPhong {
            kd: [0.3, 0.2, 0.1],
            ks: [0.4, 0.4, 0.4],
            exponent: 40.0,
        };
        let table = MerlBrdf::tabulate(
            &truth,
            TabulateOptions {
                noise,
                seed: 7,
                missing_above_theta_d_deg: None,
            },
        );
        // The 2-D slice on the MERL grid: one table cell per sample.
        Reduction::default()
            .with_max_elevation(90.0)
            .with_max_theta_d(90.0)
            .sample(&table)
    }

    #[test]
    fn the_noise_estimate_recovers_known_added_noise() {
        for sigma in [0.01, 0.03, 0.1] {
            let samples = noisy_table(sigma);
            for c in 0..3 {
                let est = estimate_noise(&samples, c);
                assert!(
                    (est.global / sigma - 1.0).abs() < 0.25,
                    "sigma {sigma}, channel {c}: estimated {}",
                    est.global
                );
                // Bins pool few cells: within 60% of the truth.
                for (i, &s) in est.by_theta_h.iter().enumerate() {
                    assert!((s / sigma - 1.0).abs() < 0.6, "sigma {sigma} bin {i}: {s}");
                }
            }
        }
        // A noise-free table: the estimate is the signal's curvature alone,
        // far below the smallest noise above.
        let clean = estimate_noise(&noisy_table(0.0), 1);
        assert!(clean.global < 2e-3, "{}", clean.global);
    }

    #[test]
    fn perceptual_intervals_contain_the_data_and_stay_under_the_cap() {
        let samples = noisy_table(0.02);
        let bounds = PerceptualBounds::default();
        let (data, used, info) = samples.channel_perceptual(0, &bounds).unwrap();
        assert_eq!(used.len(), samples.rows.len(), "every cell is constrained");
        assert!(info.perceptual_cells > 0 && info.floor_cells > 0);
        assert!((info.noise - 0.02).abs() < 0.005, "{}", info.noise);
        for (k, &i) in used.iter().enumerate() {
            let v = samples.rows[i].value[0].clamp(0.0, info.peak);
            assert!(data.lo()[k] <= v && v <= data.hi()[k]);
            assert!(data.hi()[k] <= 1.5 * info.peak * (1.0 + 1e-12));
            assert!(data.lo()[k] >= 0.0);
            // Never tighter than the perceptual bound or two noise deviations.
            let h = 0.5 * (data.hi()[k] - data.lo()[k]);
            if data.lo()[k] > 0.0 && data.hi()[k] < 1.5 * info.peak {
                assert!(h >= 0.04 * v * (1.0 - 1e-12));
            }
        }
    }

    #[test]
    fn the_light_floor_follows_the_tolerance_up_to_the_visibility_floor() {
        let at = |t: f64| PerceptualBounds::default().with_rel_tol(t).unwrap();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-15;
        assert!(close(at(0.08).light_floor(), 0.005));
        assert!(close(at(0.32).light_floor(), 0.02));
        assert!(close(at(0.64).light_floor(), 0.02));
        let fixed = PerceptualBounds {
            light_floor_per_tol: None,
            ..at(0.08)
        };
        assert!(close(fixed.light_floor(), 0.02));
        assert_eq!(fixed.for_light(), fixed);
        // The floor used is reported, and binds fewer cells when lower.
        let samples = noisy_table(0.0);
        let (light_data, _, light) = samples
            .channel_perceptual(0, &at(0.08).for_light())
            .unwrap();
        let (ratio_data, _, ratio) = samples.channel_perceptual(0, &at(0.08)).unwrap();
        assert!(close(light.visibility, 0.005) && close(ratio.visibility, 0.02));
        assert!(light.floor_cells < ratio.floor_cells, "{light:?} {ratio:?}");
        for k in 0..light_data.len() {
            assert!(
                light_data.hi()[k] - light_data.lo()[k] <= ratio_data.hi()[k] - ratio_data.lo()[k]
            );
        }
        for bad in [-1.0, f64::NAN, f64::INFINITY] {
            let d = PerceptualBounds {
                light_floor_per_tol: Some(bad),
                ..at(0.08)
            };
            assert!(d.validate().is_err(), "{bad}");
        }
        // A design recorded before the proportional floor reads as without it.
        let old: PerceptualBounds = serde_json::from_str(
            r#"{"rel_tol":0.08,"visibility":0.02,"noise_factor":2.0,"peak_cap":1.5}"#,
        )
        .unwrap();
        assert_eq!(old.light_floor_per_tol, None);
    }

    #[test]
    fn the_typical_colour_is_the_diffuse_colour_and_sets_the_ratios_half_widths() {
        let kd = [0.3, 0.3, 0.28];
        let truth = crate::Lambert { albedo: kd };
        let samples = Reduction::default()
            .with_max_elevation(90.0)
            .with_max_theta_d(90.0)
            .sample(&truth);
        let mode = crate::ColourMode::LuminanceChroma;
        let typical = samples.in_colour_mode(mode).typical_colour(mode);
        for c in 0..3 {
            let want = kd[c] / std::f64::consts::PI;
            assert!((typical[c] / want - 1.0).abs() < 1e-9, "{typical:?}");
        }
        // A near grey: the ratios need tighter half-widths than the luminance.
        let f = mode.perceptual_factors(typical);
        assert!((f[0] - 1.0).abs() < f64::EPSILON, "{f:?}");
        assert!(f[1] < 0.7 && f[2] < 0.9, "{f:?}");
    }
}
