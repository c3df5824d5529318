//! Scattered measurements: Cornell spectral samples and ALTA text data.
//! Both are lists of direction pairs with values, fitted directly in the
//! reduction's coordinates (no grid).

use crate::geometry::{from_spherical, HalfDiff, Vec3};
use crate::reduce::{Reduction, SampleRow, Samples};
use crate::BrdfError;
use std::path::Path;

/// Measured direction pairs with RGB values.
#[derive(Debug, Clone, PartialEq)]
pub struct ScatteredBrdf {
    /// Incident direction, outgoing direction, RGB value.
    pub samples: Vec<(Vec3, Vec3, [f64; 3])>,
    /// Source name.
    pub name: String,
}

/// CIE 1931 2-degree colour matching functions by the multi-lobe Gaussian
/// fit of Wyman, Sloan and Shirley (JCGT 2013), wavelength in nm.
pub fn cie_xyz(lambda: f64) -> [f64; 3] {
    let g = |mu: f64, s1: f64, s2: f64| {
        let s = if lambda < mu { s1 } else { s2 };
        (-0.5 * ((lambda - mu) / s).powi(2)).exp()
    };
    [
        1.056 * g(599.8, 37.9, 31.0) + 0.362 * g(442.0, 16.0, 26.7) - 0.065 * g(501.1, 20.4, 26.2),
        0.821 * g(568.8, 46.9, 40.5) + 0.286 * g(530.9, 16.3, 31.1),
        1.217 * g(437.0, 11.8, 36.0) + 0.681 * g(459.0, 26.0, 13.8),
    ]
}

/// Linear sRGB (Rec. 709 primaries, D65 white) of CIE XYZ.
pub fn xyz_to_linear_srgb(xyz: [f64; 3]) -> [f64; 3] {
    let [x, y, z] = xyz;
    [
        3.2406 * x - 1.5372 * y - 0.4986 * z,
        -0.9689 * x + 1.8758 * y + 0.0415 * z,
        0.0557 * x - 0.2040 * y + 1.0570 * z,
    ]
}

/// RGB of a reflectance spectrum sampled at `wavelengths` (nm): the
/// spectrum under the equal-energy illuminant, integrated against the CIE
/// 1931 matching functions by the trapezoidal rule, scaled so that a
/// constant spectrum 1 has luminance Y = 1, then converted to linear sRGB.
pub fn spectrum_to_rgb(wavelengths: &[f64], values: &[f64]) -> [f64; 3] {
    let mut xyz = [0.0; 3];
    let mut y_norm = 0.0;
    for k in 0..wavelengths.len() {
        let w = if wavelengths.len() == 1 {
            1.0
        } else {
            let left = if k > 0 {
                wavelengths[k] - wavelengths[k - 1]
            } else {
                0.0
            };
            let right = if k + 1 < wavelengths.len() {
                wavelengths[k + 1] - wavelengths[k]
            } else {
                0.0
            };
            0.5 * (left + right)
        };
        let cmf = cie_xyz(wavelengths[k]);
        for c in 0..3 {
            xyz[c] += w * cmf[c] * values[k];
        }
        y_norm += w * cmf[1];
    }
    xyz_to_linear_srgb(xyz.map(|v| v / y_norm))
}

fn numbers(line: &str) -> Option<Vec<f64>> {
    line.split_whitespace()
        .map(|t| t.parse::<f64>().ok())
        .collect()
}

impl ScatteredBrdf {
    /// Reads a Cornell spectral BRDF file: `# num wls`, the count, `# wls`,
    /// the wavelengths, then rows `theta_i phi_i theta_s phi_s` and one value
    /// per wavelength. Spectra become RGB by [`spectrum_to_rgb`].
    ///
    /// # Errors
    /// Unreadable file, missing wavelength header, rows of the wrong length,
    /// non-finite or negative values.
    pub fn read_cornell(path: &Path) -> Result<Self, BrdfError> {
        let text = std::fs::read_to_string(path).map_err(|e| BrdfError::io(path, e))?;
        let bad = |r: String| BrdfError::malformed(path, "Cornell BRDF", r);
        let mut lines = text
            .lines()
            .enumerate()
            .filter(|(_, l)| !l.trim().is_empty());
        let mut count = None;
        let mut wavelengths: Vec<f64> = Vec::new();
        let mut samples = Vec::new();
        let mut expect = "";
        for (no, line) in lines.by_ref() {
            let t = line.trim();
            if t.starts_with('#') {
                if t.contains("num wls") {
                    expect = "count";
                } else if t.trim_start_matches('#').trim() == "wls" {
                    expect = "wls";
                } else {
                    expect = "";
                }
                continue;
            }
            let v = numbers(t).ok_or_else(|| bad(format!("line {}: not numbers", no + 1)))?;
            match expect {
                "count" => {
                    let n = v
                        .first()
                        .copied()
                        .ok_or_else(|| bad("empty wavelength count".into()))?;
                    if v.len() != 1 || n.fract() != 0.0 || !(1.0..=10_000.0).contains(&n) {
                        return Err(bad(format!(
                            "line {}: wavelength count `{t}` is not one whole number in 1..=10000",
                            no + 1
                        )));
                    }
                    count = Some(n as usize);
                    expect = "";
                }
                "wls" if count.is_some_and(|n| wavelengths.len() < n) => {
                    wavelengths.extend(v);
                }
                _ => {
                    let n =
                        count.ok_or_else(|| bad("data before the `# num wls` header".into()))?;
                    if wavelengths.len() != n {
                        return Err(bad(format!(
                            "{} wavelengths listed, header says {n}",
                            wavelengths.len()
                        )));
                    }
                    // Checked once, at the first data row.
                    if let Some(w) = samples.is_empty().then_some(()).and(
                        wavelengths
                            .windows(2)
                            .find(|w| !(w[0].is_finite() && w[1] > w[0])),
                    ) {
                        return Err(bad(format!(
                            "wavelengths must increase: {} then {}",
                            w[0], w[1]
                        )));
                    }
                    if v.len() != 4 + n {
                        return Err(bad(format!(
                            "line {}: {} numbers, expected {}",
                            no + 1,
                            v.len(),
                            4 + n
                        )));
                    }
                    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                        return Err(bad(format!("line {}: non-finite value {x}", no + 1)));
                    }
                    if let Some(x) = v[4..].iter().find(|x| **x < 0.0) {
                        return Err(bad(format!("line {}: negative reflectance {x}", no + 1)));
                    }
                    let wi = from_spherical(v[0], v[1]);
                    let wo = from_spherical(v[2], v[3]);
                    samples.push((wi, wo, spectrum_to_rgb(&wavelengths, &v[4..])));
                }
            }
        }
        if samples.is_empty() {
            return Err(bad("no samples".into()));
        }
        let name = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        Ok(Self { samples, name })
    }

    /// Rows for fitting in the reduction's coordinates (`phi_d` folded; for a
    /// 2-D reduction `phi_d` is ignored, so every sample joins the 2-D data).
    pub fn samples(&self, reduction: &Reduction) -> Samples {
        let dims = reduction.dims();
        let rows = self
            .samples
            .iter()
            .filter(|(wi, wo, _)| wi[2] > 0.0 && wo[2] > 0.0)
            .map(|&(wi, wo, rgb)| {
                let hd = HalfDiff::from_directions(wi, wo);
                let pd = hd.folded_phi_d();
                SampleRow {
                    point: reduction.coordinates.map(hd.theta_h, hd.theta_d, pd, dims),
                    cell: None,
                    angles: [hd.theta_h, hd.theta_d, pd],
                    value: rgb,
                    lo: rgb,
                    hi: rgb,
                    cos_weight: wi[2] * wo[2],
                    grazing: hd.theta_d.to_degrees() > reduction.max_theta_d_deg,
                }
            })
            .collect();
        Samples { dims, rows }
    }
}

/// ALTA text data: `#DIM n m`, `#PARAM_IN`, `#PARAM_OUT`, optional `#VS`,
/// then rows of `n` inputs and `m` outputs (each output followed by its lower
/// and upper bound when `#VS 2` says so).
#[derive(Debug, Clone, PartialEq)]
pub struct AltaData {
    /// Input dimension.
    pub dim_in: usize,
    /// Output dimension.
    pub dim_out: usize,
    /// Input parametrisation name.
    pub param_in: String,
    /// Output quantity name.
    pub param_out: String,
    /// Rows: inputs then outputs.
    pub rows: Vec<Vec<f64>>,
    /// Per row and output, `(lo, hi)` when the file has vertical segments.
    pub intervals: Option<Vec<Vec<(f64, f64)>>>,
}

impl AltaData {
    /// Reads an ALTA data file (`.alta`, `.dat`).
    ///
    /// # Errors
    /// Unreadable file, missing `#DIM`, rows of the wrong length, non-finite
    /// values.
    pub fn read(path: &Path) -> Result<Self, BrdfError> {
        let text = std::fs::read_to_string(path).map_err(|e| BrdfError::io(path, e))?;
        let bad = |r: String| BrdfError::malformed(path, "ALTA data", r);
        let (mut dim, mut vs) = (None, 0usize);
        let (mut param_in, mut param_out) = (String::new(), String::new());
        let mut rows = Vec::new();
        let mut intervals = Vec::new();
        for (no, line) in text.lines().enumerate() {
            let t = line.trim();
            if t.is_empty() {
                continue;
            }
            if let Some(h) = t.strip_prefix('#') {
                let mut it = h.split_whitespace();
                match it.next() {
                    Some("DIM") => {
                        let v: Vec<usize> = it.filter_map(|x| x.parse().ok()).collect();
                        if v.len() != 2 || v[0] == 0 || v[1] == 0 {
                            return Err(bad(format!(
                                "line {}: `#DIM` needs two positive sizes",
                                no + 1
                            )));
                        }
                        dim = Some((v[0], v[1]));
                    }
                    Some("VS") => {
                        vs = match (it.next().map(str::parse::<u8>), it.next()) {
                            (Some(Ok(k @ (0 | 2))), None) => usize::from(k),
                            _ => {
                                return Err(bad(format!(
                                    "line {}: `#{h}`: `#VS` takes 0 or 2 (no interval, or lower and upper bounds)",
                                    no + 1
                                )))
                            }
                        }
                    }
                    Some("PARAM_IN") => param_in = it.collect::<Vec<_>>().join(" "),
                    Some("PARAM_OUT") => param_out = it.collect::<Vec<_>>().join(" "),
                    _ => {}
                }
                continue;
            }
            let (n, m) = dim.ok_or_else(|| bad("data before `#DIM`".into()))?;
            let v = numbers(t).ok_or_else(|| bad(format!("line {}: not numbers", no + 1)))?;
            let per_out = if vs == 2 { 3 } else { 1 };
            if v.len() != n + m * per_out {
                return Err(bad(format!(
                    "line {}: {} numbers, expected {}",
                    no + 1,
                    v.len(),
                    n + m * per_out
                )));
            }
            if let Some(x) = v.iter().find(|x| !x.is_finite()) {
                return Err(bad(format!("line {}: non-finite value {x}", no + 1)));
            }
            let mut row = v[..n].to_vec();
            let mut iv = Vec::new();
            for k in 0..m {
                row.push(v[n + k * per_out]);
                if vs == 2 {
                    let (value, lo, hi) = (
                        v[n + k * per_out],
                        v[n + k * per_out + 1],
                        v[n + k * per_out + 2],
                    );
                    if !(lo <= value && value <= hi) {
                        return Err(bad(format!(
                            "line {}: output {k} value {value} is outside its own interval [{lo}, {hi}]",
                            no + 1
                        )));
                    }
                    iv.push((lo, hi));
                }
            }
            rows.push(row);
            intervals.push(iv);
        }
        let (dim_in, dim_out) = dim.ok_or_else(|| bad("no `#DIM` header".into()))?;
        if rows.is_empty() {
            return Err(bad("no data rows".into()));
        }
        Ok(Self {
            dim_in,
            dim_out,
            param_in,
            param_out,
            rows,
            intervals: (vs == 2).then_some(intervals),
        })
    }

    /// Interval data for output `k` with relative tolerance `t` (or the
    /// file's own intervals when it has them).
    ///
    /// # Errors
    /// `k` out of range or invalid values.
    pub fn channel(&self, k: usize, t: f64) -> Result<rational_core::IntervalData, BrdfError> {
        if k >= self.dim_out {
            return Err(BrdfError::Invalid {
                name: "output",
                reason: format!("{k} of {} outputs", self.dim_out),
            });
        }
        let n = self.dim_in;
        let points = self.rows.iter().flat_map(|r| r[..n].to_vec()).collect();
        let values: Vec<f64> = self.rows.iter().map(|r| r[n + k]).collect();
        let wrap = |e| BrdfError::Fit {
            channel: ['r', 'g', 'b', 'a'][k.min(3)],
            source: e,
        };
        match &self.intervals {
            Some(iv) => rational_core::IntervalData::new(
                n,
                points,
                iv.iter().map(|r| r[k].0).collect(),
                iv.iter().map(|r| r[k].1).collect(),
            )
            .and_then(|d| d.with_values(values))
            .map_err(wrap),
            None => rational_core::IntervalData::from_values_relative(n, points, values, t)
                .map_err(wrap),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn equal_energy_spectrum_has_the_chromaticity_of_illuminant_e() {
        let wl: Vec<f64> = (0..31).map(|k| 400.0 + 10.0 * k as f64).collect();
        let rgb = spectrum_to_rgb(&wl, &[0.5; 31]);
        // Illuminant E has x = y = 1/3, so XYZ = (0.5, 0.5, 0.5); in linear
        // sRGB (D65 white) that is slightly pink.
        let want = xyz_to_linear_srgb([0.5; 3]);
        for c in 0..3 {
            assert!((rgb[c] - want[c]).abs() < 0.01, "{rgb:?} vs {want:?}");
        }
    }

    #[test]
    fn matching_functions_peak_where_expected() {
        assert!(cie_xyz(555.0)[1] > cie_xyz(500.0)[1] && cie_xyz(555.0)[1] > cie_xyz(650.0)[1]);
        assert!(cie_xyz(445.0)[2] > 1.5);
    }
}
