//! Cornell's spectral BRDF measurements: scattered direction pairs with
//! spectra, converted to RGB and fitted directly in the reduction's
//! coordinates (no grid); the spectral conversion they need.

use super::numbers;
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
        Self::parse_cornell(&text, path)
    }

    /// Parses the text of a Cornell BRDF file; `path` names it in errors.
    ///
    /// # Errors
    /// As [`ScatteredBrdf::read_cornell`], but for the file's own reading.
    pub fn parse_cornell(text: &str, path: &Path) -> Result<Self, BrdfError> {
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
                    point: reduction.point(hd.theta_h, hd.theta_d, pd),
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
