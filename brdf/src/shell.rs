//! The grazing shell: a tabulated factor on a fit evaluated within an
//! elevation cut.
//!
//! A fit evaluated within a cut shows, beyond it, its value at the cut
//! ([`crate::clamp_elevation`]). The measured table does not stay there:
//! at grazing it brightens towards the specular direction (Fresnel) and
//! darkens elsewhere, and that is what a render's silhouette shows. The
//! shell factor stores, on a small `theta_h x theta_d` grid, the ratio of
//! the table's reflected luminance to the clamped fit's over the directions
//! beyond the cut, weighted by the projected solid angle (a render
//! integrates `f cos_i cos_o`), so the corrected fit carries the table's
//! energy beyond the cut, cell by cell. Within the cut nothing changes.
//! Half-angle cells follow the specular direction, which a factor of the
//! two elevations averages away.

use crate::colour::{luminance, ColourMode};
use crate::geometry::{HalfDiff, Vec3};
use crate::{Brdf, BrdfError};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::{FRAC_PI_2, PI};

/// Largest number of bins on either axis of a shell factor.
pub const MAX_SHELL_BINS: usize = 64;

/// Largest factor a shell cell may hold: beyond it a file is taken as
/// corrupt (measured ratios stay within a few hundred).
pub const MAX_SHELL_FACTOR: f64 = 1e6;

/// The bins [`ShellFactor::fit`] uses unless told: 8 `theta_h` (the MERL
/// square-root warp) by 4 `theta_d`, 128 bytes as f32.
pub const DEFAULT_SHELL_BINS: [usize; 2] = [8, 4];

/// The bins the render checks try beyond a cut, largest first: the default
/// 8 x 4 (128 bytes) and 4 x 4 (64 bytes), which keeps most of its gain
/// and fits fits that the larger one would push past a byte budget.
pub const SHELL_BIN_CHOICES: [[usize; 2]; 2] = [DEFAULT_SHELL_BINS, [4, 4]];

/// Steps of the quadrature [`ShellFactor::fit`] integrates with: midpoints
/// per cell along `theta_h` and along `theta_d`, and of `phi_d` over the
/// circle.
const QUADRATURE: (usize, usize) = (8, 48);

/// A factor of the luminance beyond an elevation cut, on a
/// `theta_h x theta_d` grid (see the module documentation). Deserialisation
/// checks it ([`ShellFactor::validate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ShellSpec")]
pub struct ShellFactor {
    /// The elevation cut in degrees: pairs with both directions within it
    /// are left as they are.
    pub cut_deg: f64,
    /// Bins of `sqrt(theta_h / (pi / 2))` (the MERL warp, fine near the
    /// specular direction).
    pub n_theta_h: usize,
    /// Bins of `theta_d` over `[0, pi / 2]`.
    pub n_theta_d: usize,
    /// One factor per cell, `theta_h` major, each an f32 value; cells no
    /// grazing pair reaches hold 1.
    pub factors: Vec<f64>,
}

#[derive(Deserialize)]
struct ShellSpec {
    cut_deg: f64,
    n_theta_h: usize,
    n_theta_d: usize,
    factors: Vec<f64>,
}

impl TryFrom<ShellSpec> for ShellFactor {
    type Error = BrdfError;
    fn try_from(s: ShellSpec) -> Result<Self, BrdfError> {
        let f = Self {
            cut_deg: s.cut_deg,
            n_theta_h: s.n_theta_h,
            n_theta_d: s.n_theta_d,
            factors: s.factors,
        };
        f.validate()?;
        Ok(f)
    }
}

/// The cell of Rusinkiewicz angles on a `bins` grid.
pub(crate) fn shell_cell(theta_h: f64, theta_d: f64, bins: [usize; 2]) -> usize {
    let h = ((theta_h.max(0.0) / FRAC_PI_2).sqrt() * bins[0] as f64) as usize;
    let d = (theta_d.max(0.0) / FRAC_PI_2 * bins[1] as f64) as usize;
    h.min(bins[0] - 1) * bins[1] + d.min(bins[1] - 1)
}

impl ShellFactor {
    /// Fits the factor of `within` (a fit evaluated within its elevation
    /// cut, without a shell) to `table` on a `bins = [theta_h, theta_d]`
    /// grid: per cell, the table's luminance integrated against the
    /// projected solid angle over the pairs beyond the cut, over the fit's.
    ///
    /// # Errors
    /// `within` has no elevation cut or has a shell already, `bins` outside
    /// `1..=MAX_SHELL_BINS`, or a cell whose table or fit luminance
    /// integral is not finite (named).
    pub fn fit(
        table: &dyn Brdf,
        within: &crate::FittedBrdf,
        bins: [usize; 2],
    ) -> Result<Self, BrdfError> {
        let cut_deg = within.reduction.max_elevation_deg;
        let bad = |reason: String| BrdfError::Invalid {
            name: "shell factor",
            reason,
        };
        if cut_deg >= 90.0 {
            return Err(bad("the fit has no elevation cut to correct beyond".into()));
        }
        if within.shell.is_some() {
            return Err(bad("the fit has a shell factor already".into()));
        }
        if bins.iter().any(|&n| n == 0 || n > MAX_SHELL_BINS) {
            return Err(bad(format!("bins {bins:?}: each in 1..={MAX_SHELL_BINS}")));
        }
        let cells = bins[0] * bins[1];
        let cos_cut = cut_deg.to_radians().cos();
        let (sub, azimuths) = QUADRATURE;
        // Midpoints of each cell in the warped `u = sqrt(theta_h / (pi/2))`
        // and in `theta_d`, and of `phi_d` over the circle, so that every
        // cell is integrated, the narrow ones at the specular direction
        // included. A pair's measure is `4 cos_d dw_h dw_d`, with
        // `dtheta_h = pi u du`; the constants cancel in the ratio.
        let sums: Vec<(f64, f64)> = (0..cells)
            .into_par_iter()
            .map(|cell| {
                let (ch, cd) = (cell / bins[1], cell % bins[1]);
                let (mut t_sum, mut f_sum) = (0.0, 0.0);
                for a in 0..sub {
                    let u = (ch as f64 + (a as f64 + 0.5) / sub as f64) / bins[0] as f64;
                    let theta_h = u * u * FRAC_PI_2;
                    for b in 0..sub {
                        let theta_d = (cd as f64 + (b as f64 + 0.5) / sub as f64) / bins[1] as f64
                            * FRAC_PI_2;
                        for p in 0..azimuths {
                            let phi_d = (p as f64 + 0.5) / azimuths as f64 * 2.0 * PI;
                            let (wi, wo) = HalfDiff {
                                theta_h,
                                phi_h: 0.0,
                                theta_d,
                                phi_d,
                            }
                            .to_directions();
                            if wi[2] <= 0.0
                                || wo[2] <= 0.0
                                || (wi[2] >= cos_cut && wo[2] >= cos_cut)
                            {
                                continue;
                            }
                            let weight =
                                wi[2] * wo[2] * theta_d.cos() * theta_h.sin() * theta_d.sin() * u;
                            t_sum += weight * luminance(table.eval(wi, wo));
                            f_sum += weight * luminance(within.eval(wi, wo));
                        }
                    }
                }
                (t_sum, f_sum)
            })
            .collect();
        // A non-finite integral would otherwise become a factor of 0, 1 or
        // the largest allowed without a word: name the cell instead.
        if let Some((cell, &(t, f))) = sums
            .iter()
            .enumerate()
            .find(|(_, (t, f))| !(t.is_finite() && f.is_finite()))
        {
            let whose = if t.is_finite() {
                "the fit's"
            } else {
                "the table's"
            };
            return Err(bad(format!(
                "{whose} luminance integral over cell {cell} ({} x {} cells) beyond the cut is {}",
                bins[0],
                bins[1],
                if t.is_finite() { f } else { t }
            )));
        }
        let factors = sums
            .iter()
            .map(|&(t, f)| {
                let k = if f > 0.0 { (t / f).max(0.0) } else { 1.0 };
                f64::from(k.min(MAX_SHELL_FACTOR) as f32)
            })
            .collect();
        let shell = Self {
            cut_deg,
            n_theta_h: bins[0],
            n_theta_d: bins[1],
            factors,
        };
        shell.validate()?;
        Ok(shell)
    }

    /// Checks what evaluation indexes by: a cut in `(0, 90)`, bins in
    /// `1..=MAX_SHELL_BINS`, one factor per cell, each finite and in
    /// `[0, MAX_SHELL_FACTOR]`.
    ///
    /// # Errors
    /// The first invariant broken, named.
    pub fn validate(&self) -> Result<(), BrdfError> {
        let bad = |reason: String| BrdfError::Invalid {
            name: "shell factor",
            reason,
        };
        if !(self.cut_deg > 0.0 && self.cut_deg < 90.0) {
            return Err(bad(format!(
                "cut {} degrees is outside (0, 90)",
                self.cut_deg
            )));
        }
        for (what, n) in [("theta_h", self.n_theta_h), ("theta_d", self.n_theta_d)] {
            if n == 0 || n > MAX_SHELL_BINS {
                return Err(bad(format!("{n} {what} bins (1..={MAX_SHELL_BINS})")));
            }
        }
        let cells = self.n_theta_h * self.n_theta_d;
        if self.factors.len() != cells {
            return Err(bad(format!(
                "{} factors for {cells} cells",
                self.factors.len()
            )));
        }
        if let Some(k) = self
            .factors
            .iter()
            .position(|v| !(v.is_finite() && (0.0..=MAX_SHELL_FACTOR).contains(v)))
        {
            return Err(bad(format!(
                "factor {k} is {}, outside [0, {MAX_SHELL_FACTOR:e}]",
                self.factors[k]
            )));
        }
        Ok(())
    }

    /// Bytes of the factors as f32.
    pub fn byte_size_f32(&self) -> usize {
        4 * self.factors.len()
    }

    /// The factor at a pair: 1 when both directions are within the cut.
    pub fn factor(&self, wi: Vec3, wo: Vec3) -> f64 {
        let cos_cut = self.cut_deg.to_radians().cos();
        if wi[2] >= cos_cut && wo[2] >= cos_cut {
            return 1.0;
        }
        let hd = HalfDiff::from_directions(wi, wo);
        self.factors[shell_cell(hd.theta_h, hd.theta_d, [self.n_theta_h, self.n_theta_d])]
    }

    /// What the factor multiplies among the three functions: all three in
    /// RGB, the luminance alone in luminance-chroma.
    pub fn factors_for(k: f64, mode: ColourMode) -> [f64; 3] {
        match mode {
            ColourMode::Rgb => [k; 3],
            ColourMode::LuminanceChroma => [k, 1.0, 1.0],
        }
    }
}
