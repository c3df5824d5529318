//! MERL binary BRDFs (Matusik et al. 2003): a 90 x 90 x 180 grid over
//! `(theta_h, theta_d, phi_d)`, three little-endian int32 dimensions, then
//! `3 x 90 x 90 x 180` little-endian f64 values stored channel-planar (R,
//! G, B) and divided by the channel scales `1/1500, 1.15/1500, 1.66/1500`.
//! Negative stored values mark missing cells.

use crate::geometry::{HalfDiff, Vec3};
use crate::{Brdf, BrdfError};
use std::f64::consts::PI;
use std::path::Path;

/// Resolution in `theta_h`.
pub const RES_THETA_H: usize = 90;
/// Resolution in `theta_d`.
pub const RES_THETA_D: usize = 90;
/// Resolution in `phi_d` (over `[0, pi)`).
pub const RES_PHI_D: usize = 180;
/// Cells per channel.
pub const CELLS: usize = RES_THETA_H * RES_THETA_D * RES_PHI_D;
/// Size of a MERL file in bytes.
pub const FILE_SIZE: usize = 12 + 3 * CELLS * 8;
/// Channel scales applied to the stored values.
pub const SCALE: [f64; 3] = [1.0 / 1500.0, 1.15 / 1500.0, 1.66 / 1500.0];

/// `theta_h` bin: `floor(90 sqrt(theta_h / (pi/2)))`, clamped to the grid.
pub fn theta_h_index(theta_h: f64) -> usize {
    if theta_h <= 0.0 {
        return 0;
    }
    let v = (theta_h / (PI / 2.0) * (RES_THETA_H * RES_THETA_H) as f64).sqrt();
    (v as usize).min(RES_THETA_H - 1)
}

/// `theta_d` bin: `floor(theta_d / (pi/2) * 90)`, clamped.
pub fn theta_d_index(theta_d: f64) -> usize {
    let v = theta_d / (PI / 2.0) * RES_THETA_D as f64;
    if v <= 0.0 {
        0
    } else {
        (v as usize).min(RES_THETA_D - 1)
    }
}

/// `phi_d` bin after folding into `[0, pi)` by reciprocity:
/// `floor(phi_d / pi * 180)`, clamped.
pub fn phi_d_index(phi_d: f64) -> usize {
    let p = if phi_d < 0.0 { phi_d + PI } else { phi_d };
    let v = p / PI * RES_PHI_D as f64;
    if v <= 0.0 {
        0
    } else {
        (v as usize).min(RES_PHI_D - 1)
    }
}

/// Linear index `phi_d + 180 (theta_d + 90 theta_h)`.
pub fn cell_index(i_h: usize, i_d: usize, i_p: usize) -> usize {
    i_p + RES_PHI_D * (i_d + RES_THETA_D * i_h)
}

/// Centre of a cell, in the warped coordinates the bins are uniform in:
/// `theta_h = ((i + 1/2) / 90)^2 pi/2`, `theta_d = (j + 1/2)/90 pi/2`,
/// `phi_d = (k + 1/2)/180 pi`. Every centre maps back to its own cell.
pub fn cell_center(i_h: usize, i_d: usize, i_p: usize) -> (f64, f64, f64) {
    let u = (i_h as f64 + 0.5) / RES_THETA_H as f64;
    (
        u * u * PI / 2.0,
        (i_d as f64 + 0.5) / RES_THETA_D as f64 * PI / 2.0,
        (i_p as f64 + 0.5) / RES_PHI_D as f64 * PI,
    )
}

/// A MERL-grid BRDF with missing cells.
#[derive(Debug, Clone, PartialEq)]
pub struct MerlBrdf {
    /// Physical values, channel-planar; `NaN` marks a missing cell.
    values: Vec<f64>,
    name: String,
}

/// Options for [`MerlBrdf::tabulate`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TabulateOptions {
    /// Relative standard deviation of multiplicative measurement noise.
    pub noise: f64,
    /// Seed of the noise.
    pub seed: u64,
    /// Cells with `theta_d` above this (degrees) are missing, like the
    /// grazing cells of real measurements.
    pub missing_above_theta_d_deg: Option<f64>,
}

impl Default for TabulateOptions {
    fn default() -> Self {
        Self {
            noise: 0.0,
            seed: 1,
            missing_above_theta_d_deg: None,
        }
    }
}

/// Measurement-like noise from a seeded SplitMix64.
pub(crate) struct SplitMix(rand_xoshiro::SplitMix64);

impl SplitMix {
    pub(crate) fn new(seed: u64) -> Self {
        Self(rand_core::SeedableRng::seed_from_u64(seed))
    }

    pub(crate) fn next_u64(&mut self) -> u64 {
        rand_core::Rng::next_u64(&mut self.0)
    }

    pub(crate) fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Standard normal by Box-Muller.
    pub(crate) fn normal(&mut self) -> f64 {
        let u1 = self.uniform().max(1e-300);
        let u2 = self.uniform();
        (-2.0 * u1.ln()).sqrt() * (2.0 * PI * u2).cos()
    }
}

impl MerlBrdf {
    /// Reads a MERL binary file.
    ///
    /// # Errors
    /// Unreadable file, wrong size (a truncated download), wrong dimensions,
    /// non-finite values.
    pub fn read(path: &Path) -> Result<Self, BrdfError> {
        let (bytes, name) = crate::error::read_named(path)?;
        Self::from_bytes(&bytes, path, name)
    }

    /// Parses the bytes of a MERL file (`path` is only used in messages).
    ///
    /// # Errors
    /// As [`MerlBrdf::read`].
    pub fn from_bytes(bytes: &[u8], path: &Path, name: String) -> Result<Self, BrdfError> {
        if bytes.len() < 12 {
            return Err(BrdfError::malformed(
                path,
                "MERL",
                format!("{} bytes, too short for the header", bytes.len()),
            ));
        }
        let dims: Vec<i32> = (0..3)
            .map(|k| i32::from_le_bytes(bytes[4 * k..4 * k + 4].try_into().expect("4 bytes")))
            .collect();
        if dims != [RES_THETA_H as i32, RES_THETA_D as i32, RES_PHI_D as i32] {
            return Err(BrdfError::malformed(
                path,
                "MERL",
                format!("dimensions {dims:?}, expected [90, 90, 180]"),
            ));
        }
        if bytes.len() != FILE_SIZE {
            return Err(BrdfError::malformed(
                path,
                "MERL",
                format!(
                    "{} bytes, expected {FILE_SIZE} (truncated or not a MERL file)",
                    bytes.len()
                ),
            ));
        }
        let mut values = Vec::with_capacity(3 * CELLS);
        for (k, chunk) in bytes[12..].chunks_exact(8).enumerate() {
            let v = f64::from_le_bytes(chunk.try_into().expect("8 bytes"));
            if !v.is_finite() {
                return Err(BrdfError::malformed(
                    path,
                    "MERL",
                    format!("value {k} is not finite ({v})"),
                ));
            }
            values.push(if v < 0.0 {
                f64::NAN
            } else {
                v * SCALE[k / CELLS]
            });
        }
        Ok(Self { values, name })
    }

    /// The file bytes (missing cells written as -1).
    pub fn to_bytes(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(FILE_SIZE);
        for d in [RES_THETA_H, RES_THETA_D, RES_PHI_D] {
            out.extend_from_slice(&(d as i32).to_le_bytes());
        }
        for (k, v) in self.values.iter().enumerate() {
            let stored = if v.is_nan() {
                -1.0
            } else {
                v / SCALE[k / CELLS]
            };
            out.extend_from_slice(&stored.to_le_bytes());
        }
        out
    }

    /// Writes a MERL binary file atomically ([`crate::write_atomic`]).
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write(&self, path: &Path) -> Result<(), BrdfError> {
        let bytes = self.to_bytes();
        crate::write_atomic(path, |tmp| std::fs::write(tmp, &bytes))
            .map_err(|e| BrdfError::io(path, e))
    }

    /// Tabulates any BRDF at the cell centres, with optional noise and
    /// missing grazing cells.
    pub fn tabulate(material: &dyn Brdf, options: TabulateOptions) -> Self {
        use rayon::prelude::*;
        let mut values = vec![f64::NAN; 3 * CELLS];
        let rows: Vec<(usize, [f64; 3])> = (0..CELLS)
            .into_par_iter()
            .map(|idx| {
                let i_p = idx % RES_PHI_D;
                let i_d = (idx / RES_PHI_D) % RES_THETA_D;
                let i_h = idx / (RES_PHI_D * RES_THETA_D);
                let (th, td, pd) = cell_center(i_h, i_d, i_p);
                let (wi, wo) = HalfDiff {
                    theta_h: th,
                    phi_h: 0.0,
                    theta_d: td,
                    phi_d: pd,
                }
                .to_directions();
                let missing = options
                    .missing_above_theta_d_deg
                    .is_some_and(|m| td.to_degrees() > m);
                if missing || wi[2] <= 0.0 || wo[2] <= 0.0 {
                    (idx, [f64::NAN; 3])
                } else {
                    (idx, material.eval(wi, wo))
                }
            })
            .collect();
        let mut rng = SplitMix::new(options.seed);
        for (idx, v) in rows {
            for c in 0..3 {
                let noisy = if options.noise > 0.0 {
                    v[c] * (1.0 + options.noise * rng.normal()).max(0.0)
                } else {
                    v[c]
                };
                values[c * CELLS + idx] = noisy;
            }
        }
        Self {
            values,
            name: material.name(),
        }
    }

    /// Value of a cell per channel (`None` when missing).
    pub fn cell(&self, i_h: usize, i_d: usize, i_p: usize) -> [Option<f64>; 3] {
        let idx = cell_index(i_h, i_d, i_p);
        [0, 1, 2].map(|c| {
            let v = self.values[c * CELLS + idx];
            (!v.is_nan()).then_some(v)
        })
    }

    /// Number of cells with all three channels present.
    pub fn valid_cells(&self) -> usize {
        (0..CELLS)
            .filter(|&i| (0..3).all(|c| !self.values[c * CELLS + i].is_nan()))
            .count()
    }

    /// The cell of a direction pair (nearest-cell lookup, as in MERL's code).
    pub fn lookup_index(wi: Vec3, wo: Vec3) -> usize {
        let hd = HalfDiff::from_directions(wi, wo);
        cell_index(
            theta_h_index(hd.theta_h),
            theta_d_index(hd.theta_d),
            phi_d_index(hd.phi_d),
        )
    }
}

impl Brdf for MerlBrdf {
    /// Nearest-cell lookup; missing cells read as zero.
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        let idx = Self::lookup_index(wi, wo);
        [0, 1, 2].map(|c| {
            let v = self.values[c * CELLS + idx];
            if v.is_nan() {
                0.0
            } else {
                v
            }
        })
    }

    fn name(&self) -> String {
        format!("MERL {}", self.name)
    }
}

/// A line of the checksum list: material name, size and SHA-256.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct KnownFile {
    /// Material name.
    pub material: String,
    /// Size in bytes.
    pub size: u64,
    /// Lower-case hex SHA-256.
    pub sha256: String,
}

/// Parses `MERL_CHECKSUMS.tsv` (header row, then material, size, sha256, ...).
///
/// # Errors
/// Unreadable or malformed list.
pub fn read_checksums(path: &Path) -> Result<Vec<KnownFile>, BrdfError> {
    let text = std::fs::read_to_string(path).map_err(|e| BrdfError::io(path, e))?;
    text.lines()
        .skip(1)
        .filter(|l| !l.trim().is_empty())
        .enumerate()
        .map(|(i, l)| {
            let f: Vec<&str> = l.split('\t').collect();
            if f.len() < 3 {
                return Err(BrdfError::malformed(
                    path,
                    "checksum list",
                    format!("line {}: {} fields", i + 2, f.len()),
                ));
            }
            let size = f[1].parse().map_err(|_| {
                BrdfError::malformed(
                    path,
                    "checksum list",
                    format!("line {}: size `{}`", i + 2, f[1]),
                )
            })?;
            Ok(KnownFile {
                material: f[0].to_string(),
                size,
                sha256: f[2].to_ascii_lowercase(),
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn hand_computed_indices() {
        // theta_h: sqrt warp. 1 degree: floor(90 sqrt(1/90)) = floor(9.4868) = 9.
        assert_eq!(theta_h_index(1f64.to_radians()), 9);
        assert_eq!(theta_h_index(0.0), 0);
        assert_eq!(theta_h_index(-0.1), 0);
        assert_eq!(theta_h_index(PI / 2.0), 89);
        // Bin edges: ((i/90)^2 pi/2) starts bin i (nudged inside).
        for i in [1usize, 10, 45, 89] {
            let edge = (i as f64 / 90.0).powi(2) * PI / 2.0;
            assert_eq!(theta_h_index(edge * (1.0 + 1e-12)), i);
            assert_eq!(theta_h_index(edge * (1.0 - 1e-9)), i - 1);
        }
        assert_eq!(theta_d_index(45f64.to_radians()), 45);
        assert_eq!(theta_d_index(PI / 2.0), 89);
        // phi_d folds by reciprocity: -pi/2 is pi/2.
        assert_eq!(phi_d_index(-PI / 2.0), 90);
        assert_eq!(phi_d_index(PI / 2.0), 90);
        assert_eq!(phi_d_index(PI), 179);
        assert_eq!(phi_d_index(0.0), 0);
        assert_eq!(cell_index(1, 2, 3), 3 + 180 * (2 + 90));
    }

    #[test]
    fn centres_map_to_their_cells() {
        for i_h in [0, 1, 44, 89] {
            for i_d in [0, 30, 89] {
                for i_p in [0, 90, 179] {
                    let (th, td, pd) = cell_center(i_h, i_d, i_p);
                    assert_eq!(
                        (theta_h_index(th), theta_d_index(td), phi_d_index(pd)),
                        (i_h, i_d, i_p)
                    );
                }
            }
        }
    }
}
