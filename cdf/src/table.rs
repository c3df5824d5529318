//! Tabulated densities: for each view elevation of a grid, the distribution
//! of the light direction with density proportional to `Y(rho) cos(theta_l)`
//! (`Y` the luminance of the RGB value), piecewise constant on cells of
//! `(theta_l, phi_l)` with `phi_l` on `[0, pi]` (mirrored by isotropy).
//! The marginal over `phi` gives the `theta_l` CDF, each row the conditional
//! `phi_l` CDF. These tables are the ground truth the rational fits are fitted
//! to, and the tabulated sampler's stored pdf.

use crate::error::invalid;
use crate::CdfError;
use brdf::{from_spherical, Brdf};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// Rec. 709 luminance of linear RGB: the scalar density the samplers follow.
pub fn luminance(rgb: [f64; 3]) -> f64 {
    0.2126 * rgb[0] + 0.7152 * rgb[1] + 0.0722 * rgb[2]
}

/// Resolution of a [`CdfTable`]. Deserialisation checks every field as the
/// builders do, and the table's memory ([`TableSettings::validate`]).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "TableSpec")]
pub struct TableSettings {
    views: usize,
    theta_cells: usize,
    phi_cells: usize,
    max_view: f64,
    supersample: usize,
}

/// The serialised form of [`TableSettings`], checked on the way in.
#[derive(Deserialize)]
struct TableSpec {
    views: usize,
    theta_cells: usize,
    phi_cells: usize,
    max_view: f64,
    supersample: usize,
}

impl TryFrom<TableSpec> for TableSettings {
    type Error = CdfError;
    fn try_from(s: TableSpec) -> Result<Self, CdfError> {
        let t = TableSettings::default()
            .with_views(s.views)?
            .with_cells(s.theta_cells, s.phi_cells)?
            .with_max_view(s.max_view)?
            .with_supersample(s.supersample)?;
        t.validate()?;
        Ok(t)
    }
}

/// Largest table [`CdfTable::new`] builds, in bytes of its f64 arrays.
pub const MAX_TABLE_BYTES: usize = 4 << 30;

impl Default for TableSettings {
    /// 16 view elevations on `[0, 80 deg]`, 64 x 64 cells, 2 x 2 BRDF
    /// evaluations per cell.
    fn default() -> Self {
        Self {
            views: 16,
            theta_cells: 64,
            phi_cells: 64,
            max_view: 80f64.to_radians(),
            supersample: 2,
        }
    }
}

impl TableSettings {
    /// Number of view elevations, evenly spaced on `[0, max_view]`.
    ///
    /// # Errors
    /// Fewer than 2 or more than 4096.
    pub fn with_views(mut self, views: usize) -> Result<Self, CdfError> {
        if !(2..=4096).contains(&views) {
            return Err(invalid("views", format!("{views} is outside 2..=4096")));
        }
        self.views = views;
        Ok(self)
    }

    /// Cells in `theta_l` (on `[0, pi/2]`) and `phi_l` (on `[0, pi]`).
    ///
    /// # Errors
    /// Fewer than 4 or more than 8192 cells on either axis.
    pub fn with_cells(mut self, theta: usize, phi: usize) -> Result<Self, CdfError> {
        for (name, n) in [("theta cells", theta), ("phi cells", phi)] {
            if !(4..=8192).contains(&n) {
                return Err(invalid(name, format!("{n} is outside 4..=8192")));
            }
        }
        self.theta_cells = theta;
        self.phi_cells = phi;
        Ok(self)
    }

    /// Largest view elevation tabulated (radians); larger ones use the last.
    ///
    /// # Errors
    /// Not in `(0, pi/2)`.
    pub fn with_max_view(mut self, max_view: f64) -> Result<Self, CdfError> {
        if !(max_view > 0.0 && max_view < FRAC_PI_2) {
            return Err(invalid(
                "max view",
                format!("{max_view} rad is outside (0, pi/2)"),
            ));
        }
        self.max_view = max_view;
        Ok(self)
    }

    /// BRDF evaluations per cell and axis (midpoints of sub-cells).
    ///
    /// # Errors
    /// 0 or above 16.
    pub fn with_supersample(mut self, n: usize) -> Result<Self, CdfError> {
        if !(1..=16).contains(&n) {
            return Err(invalid("supersample", format!("{n} is outside 1..=16")));
        }
        self.supersample = n;
        Ok(self)
    }

    /// Bytes the table's f64 arrays will take.
    pub fn table_bytes(&self) -> usize {
        let (nt, np) = (self.theta_cells, self.phi_cells);
        8 * self.views * ((nt + 1) + nt * (np + 1) + nt * np)
    }

    /// Checks the combination: the table must fit in [`MAX_TABLE_BYTES`].
    ///
    /// # Errors
    /// A table above the ceiling, with its size.
    pub fn validate(&self) -> Result<(), CdfError> {
        let bytes = self.table_bytes();
        if bytes > MAX_TABLE_BYTES {
            return Err(invalid(
                "table size",
                format!(
                    "{} views x {} x {} cells need {:.1} GiB; the ceiling is {} GiB",
                    self.views,
                    self.theta_cells,
                    self.phi_cells,
                    bytes as f64 / f64::from(1u32 << 30),
                    MAX_TABLE_BYTES >> 30
                ),
            ));
        }
        Ok(())
    }

    /// Number of view elevations.
    pub fn views(&self) -> usize {
        self.views
    }

    /// Largest view elevation.
    pub fn max_view(&self) -> f64 {
        self.max_view
    }
}

/// The distribution at one view elevation.
#[derive(Debug, Clone)]
pub(crate) struct Slice {
    /// CDF of `theta_l` at the cell edges (`theta_cells + 1`, from 0 to 1).
    pub(crate) marginal: Vec<f64>,
    /// Per row, the CDF of `phi_l` at the cell edges (`phi_cells + 1`).
    pub(crate) conditional: Vec<f64>,
    /// Cell probabilities (sum 1).
    pub(crate) mass: Vec<f64>,
    /// `integral of Y(rho) cos dw` over the hemisphere (the luminance albedo).
    pub(crate) albedo: f64,
}

/// Tabulated light-direction distributions of one material at a grid of view
/// elevations.
#[derive(Debug, Clone)]
pub struct CdfTable {
    settings: TableSettings,
    material: String,
    slices: Vec<Slice>,
}

/// Index of the cell containing `u` in a CDF (edges from 0 to 1), skipping
/// empty cells, and the position inside it in `[0, 1]`.
pub(crate) fn invert_cdf(cdf: &[f64], u: f64) -> (usize, f64) {
    let cells = cdf.len() - 1;
    let j = cdf.partition_point(|&c| c <= u).clamp(1, cells) - 1;
    // u >= 1 may land on trailing empty cells: step back to the last cell with mass.
    let mut j = j;
    while j > 0 && cdf[j + 1] <= cdf[j] {
        j -= 1;
    }
    let w = cdf[j + 1] - cdf[j];
    let frac = if w > 0.0 {
        ((u - cdf[j]) / w).clamp(0.0, 1.0)
    } else {
        0.5
    };
    (j, frac)
}

fn normalised_cdf(mass: &[f64]) -> Vec<f64> {
    let total: f64 = mass.iter().sum();
    let mut cdf = Vec::with_capacity(mass.len() + 1);
    cdf.push(0.0);
    if total > 0.0 {
        let mut acc = 0.0;
        for m in mass {
            acc += m;
            cdf.push(acc / total);
        }
    } else {
        let n = mass.len() as f64;
        cdf.extend((1..=mass.len()).map(|k| k as f64 / n));
    }
    // Exact end point: rounding must not leave u = 1 outside.
    *cdf.last_mut().expect("at least one cell") = 1.0;
    cdf
}

impl CdfTable {
    /// Tabulates `material` (in parallel over cells).
    ///
    /// # Errors
    /// A table above [`MAX_TABLE_BYTES`], or a view elevation where the
    /// material reflects nothing or returns NaN.
    pub fn new(material: &dyn Brdf, settings: TableSettings) -> Result<Self, CdfError> {
        settings.validate()?;
        let slices = (0..settings.views)
            .map(|i| Self::slice(material, &settings, Self::view_of(&settings, i)))
            .collect::<Result<_, _>>()?;
        Ok(Self {
            settings,
            material: material.name(),
            slices,
        })
    }

    fn view_of(settings: &TableSettings, i: usize) -> f64 {
        settings.max_view * i as f64 / (settings.views - 1) as f64
    }

    fn slice(material: &dyn Brdf, s: &TableSettings, theta_v: f64) -> Result<Slice, CdfError> {
        let (nt, np, ss) = (s.theta_cells, s.phi_cells, s.supersample);
        let (dt, dp) = (FRAC_PI_2 / nt as f64, PI / np as f64);
        let wo = from_spherical(theta_v, 0.0);
        let raw: Vec<f64> = (0..nt * np)
            .into_par_iter()
            .map(|c| {
                let (j, k) = (c / np, c % np);
                let (ta, pa) = (j as f64 * dt, k as f64 * dp);
                // Exact integral of cos sin over the row; the BRDF averaged over sub-cells.
                let cos_sin = 0.5 * (((ta + dt).sin()).powi(2) - ta.sin().powi(2));
                let mut y = 0.0;
                for a in 0..ss {
                    for b in 0..ss {
                        let t = ta + (a as f64 + 0.5) * dt / ss as f64;
                        let p = pa + (b as f64 + 0.5) * dp / ss as f64;
                        y += luminance(material.eval(from_spherical(t, p), wo)).max(0.0);
                    }
                }
                y / (ss * ss) as f64 * cos_sin * dp
            })
            .collect();
        let total: f64 = raw.iter().sum();
        if !(total.is_finite() && total > 0.0) {
            return Err(CdfError::NoReflectance {
                material: material.name(),
                theta_v,
            });
        }
        let mass: Vec<f64> = raw.iter().map(|m| m / total).collect();
        let rows: Vec<f64> = mass.chunks(np).map(|r| r.iter().sum()).collect();
        let marginal = normalised_cdf(&rows);
        let conditional = mass.chunks(np).flat_map(normalised_cdf).collect();
        Ok(Slice {
            marginal,
            conditional,
            mass,
            // Two mirrored halves of the hemisphere.
            albedo: 2.0 * total,
        })
    }

    /// The resolution.
    pub fn settings(&self) -> &TableSettings {
        &self.settings
    }

    /// Name of the tabulated material.
    pub fn material(&self) -> &str {
        &self.material
    }

    /// The view elevations.
    pub fn views(&self) -> Vec<f64> {
        (0..self.settings.views)
            .map(|i| Self::view_of(&self.settings, i))
            .collect()
    }

    /// View elevation of slice `i`.
    pub fn view(&self, i: usize) -> f64 {
        Self::view_of(&self.settings, i)
    }

    /// Luminance albedo `integral Y(rho) cos dw` at slice `i` (midpoint rule).
    pub fn albedo(&self, i: usize) -> f64 {
        self.slices[i].albedo
    }

    /// The slice nearest to `theta_v` (clamped to the tabulated range).
    pub fn nearest_view(&self, theta_v: f64) -> usize {
        let step = self.settings.max_view / (self.settings.views - 1) as f64;
        ((theta_v / step).round().max(0.0) as usize).min(self.settings.views - 1)
    }

    /// The slices bracketing `theta_v` and the weight of the upper one.
    pub(crate) fn bracket_view(&self, theta_v: f64) -> (usize, usize, f64) {
        let step = self.settings.max_view / (self.settings.views - 1) as f64;
        let x = (theta_v / step).clamp(0.0, (self.settings.views - 1) as f64);
        let i = (x.floor() as usize).min(self.settings.views - 2);
        (i, i + 1, x - i as f64)
    }

    /// Cell counts `(theta, phi)`.
    pub fn cells(&self) -> (usize, usize) {
        (self.settings.theta_cells, self.settings.phi_cells)
    }

    /// Cell widths `(d theta, d phi)`.
    pub fn cell_size(&self) -> (f64, f64) {
        (
            FRAC_PI_2 / self.settings.theta_cells as f64,
            PI / self.settings.phi_cells as f64,
        )
    }

    /// Centre of row `j` in `theta_l`.
    pub fn row_theta(&self, j: usize) -> f64 {
        (j as f64 + 0.5) * self.cell_size().0
    }

    pub(crate) fn slice_ref(&self, i: usize) -> &Slice {
        &self.slices[i]
    }

    /// Inverse of the `theta_l` CDF of slice `i` at `mu` (piecewise linear).
    pub fn inverse_theta(&self, i: usize, mu: f64) -> f64 {
        let (j, f) = invert_cdf(&self.slices[i].marginal, mu.clamp(0.0, 1.0));
        (j as f64 + f) * self.cell_size().0
    }

    /// Inverse of the conditional `phi_l` CDF of row `j` of slice `i` at `tau`.
    pub fn inverse_phi(&self, i: usize, j: usize, tau: f64) -> f64 {
        let np = self.settings.phi_cells;
        let cdf = &self.slices[i].conditional[j * (np + 1)..(j + 1) * (np + 1)];
        let (k, f) = invert_cdf(cdf, tau.clamp(0.0, 1.0));
        (k as f64 + f) * self.cell_size().1
    }

    /// Probability of cell `(j, k)` in slice `i`.
    pub fn cell_mass(&self, i: usize, j: usize, k: usize) -> f64 {
        self.slices[i].mass[j * self.settings.phi_cells + k]
    }

    /// Stored bytes as f32: per slice the marginal CDF, the conditional CDFs
    /// and the cell pdf.
    pub fn byte_size_f32(&self) -> usize {
        let (nt, np) = self.cells();
        4 * self.settings.views * ((nt + 1) + nt * (np + 1) + nt * np)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use brdf::Lambert;

    #[test]
    fn lambert_marginal_is_sin_squared() {
        let m = Lambert { albedo: [0.5; 3] };
        let s = TableSettings::default()
            .with_views(2)
            .unwrap()
            .with_cells(32, 8)
            .unwrap();
        let t = CdfTable::new(&m, s).unwrap();
        for mu in [0.1f64, 0.25, 0.5, 0.9] {
            let want = mu.sqrt().asin();
            // Piecewise-linear inverse of an exact cell CDF: error below a cell.
            assert!((t.inverse_theta(1, mu) - want).abs() < t.cell_size().0);
            assert!((t.inverse_phi(0, 5, mu) - PI * mu).abs() < 1e-12);
        }
        assert!((t.albedo(0) - 0.5).abs() < 1e-12, "{}", t.albedo(0));
    }

    #[test]
    fn cdf_inversion_skips_empty_cells() {
        let cdf = [0.0, 0.5, 0.5, 1.0, 1.0];
        assert_eq!(invert_cdf(&cdf, 0.25), (0, 0.5));
        assert_eq!(invert_cdf(&cdf, 0.5).0, 2);
        assert_eq!(invert_cdf(&cdf, 1.0), (2, 1.0));
        assert_eq!(invert_cdf(&cdf, 0.0), (0, 0.0));
    }

    #[test]
    fn black_material_is_an_error() {
        let m = Lambert { albedo: [0.0; 3] };
        let e = CdfTable::new(&m, TableSettings::default().with_views(2).unwrap());
        assert!(matches!(e, Err(CdfError::NoReflectance { .. })));
    }
}
