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
//!
//! Two choices make the factor follow a render's silhouette more closely
//! ([`ShellLayout`]). Bins uniform in `1 - cos theta_d`
//! ([`ThetaDSpacing::Cosine`]) put three of four `theta_d` bins above 41
//! degrees, where a grazing view's mirror direction lies and Fresnel
//! brightens it; uniform bins give the range above 67.5 degrees one. And
//! one factor per fitted function ([`ShellColour::PerFunction`]) also
//! carries the grazing colour, which turns towards the light's as the
//! specular part grows. On six RGL files' target fits, 4 x 4 cosine bins
//! lower the sky scene's error on five against 4 x 4 uniform ones, and a
//! factor per function on those bins lowers it further on five
//! (docs/results/fidelity-2026-12-05-shell-layouts.md).

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

/// The bins of [`SHELL_CHOICES`] with uniform `theta_d` bins and one
/// luminance factor: the default 8 x 4 (128 bytes) and 4 x 4 (64 bytes),
/// which keeps most of its gain and fits fits that the larger one would
/// push past a byte budget.
pub const SHELL_BIN_CHOICES: [[usize; 2]; 2] = [DEFAULT_SHELL_BINS, [4, 4]];

/// How the `theta_d` bins of a shell factor are spaced.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ThetaDSpacing {
    /// Uniform in `theta_d` over `[0, pi / 2]` (files written before the
    /// choice existed).
    #[default]
    Uniform,
    /// Uniform in `1 - cos theta_d`: finer towards grazing `theta_d`, where
    /// the pairs beyond a cut near the specular direction lie.
    Cosine,
}

/// What each cell of a shell factor multiplies.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum ShellColour {
    /// One factor: the luminance (every channel of an RGB fit, the
    /// luminance of a luminance-chroma one), so the colour at the cut is
    /// kept (files written before the choice existed).
    #[default]
    Luminance,
    /// One factor per fitted function (`r, g, b`, or `Y, r / Y, b / Y`),
    /// which matches the table's energy in each RGB channel: three times
    /// the bytes.
    PerFunction,
}

impl ShellColour {
    /// Factors stored per cell.
    pub fn factors_per_cell(self) -> usize {
        match self {
            ShellColour::Luminance => 1,
            ShellColour::PerFunction => 3,
        }
    }
}

/// The cells of a shell factor: bins, their spacing, and what they
/// multiply.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
pub struct ShellLayout {
    /// `theta_h` (square-root warp) and `theta_d` bins.
    pub bins: [usize; 2],
    /// Spacing of the `theta_d` bins.
    pub spacing: ThetaDSpacing,
    /// What each cell multiplies.
    pub colour: ShellColour,
}

impl ShellLayout {
    /// Uniform `theta_d` bins and one luminance factor per cell.
    pub const fn luminance(bins: [usize; 2]) -> Self {
        Self {
            bins,
            spacing: ThetaDSpacing::Uniform,
            colour: ShellColour::Luminance,
        }
    }

    /// The same layout with `theta_d` bins uniform in `1 - cos theta_d`.
    pub const fn cosine(mut self) -> Self {
        self.spacing = ThetaDSpacing::Cosine;
        self
    }

    /// The same layout with one factor per fitted function.
    pub const fn per_function(mut self) -> Self {
        self.colour = ShellColour::PerFunction;
        self
    }

    /// Bytes of its factors as f32.
    pub fn byte_size_f32(&self) -> usize {
        4 * self.bins[0] * self.bins[1] * self.colour.factors_per_cell()
    }

    /// Its cells in words: `4 x 4 cells`, `1 x 4 cells, theta_d bins
    /// uniform in cosine, a factor per function`.
    pub fn describe(&self) -> String {
        let [nh, nd] = self.bins;
        let mut out = format!("{nh} x {nd} cells");
        if self.spacing == ThetaDSpacing::Cosine {
            out += ", theta_d bins uniform in cosine";
        }
        if self.colour == ShellColour::PerFunction {
            out += ", a factor per function";
        }
        out
    }

    /// Short name for reports: `8x4`, `4x4 cos`, `4x4 cos colour`.
    pub fn label(&self) -> String {
        let [nh, nd] = self.bins;
        let spacing = match self.spacing {
            ThetaDSpacing::Uniform => "",
            ThetaDSpacing::Cosine => " cos",
        };
        let colour = match self.colour {
            ShellColour::Luminance => "",
            ShellColour::PerFunction => " colour",
        };
        format!("{nh}x{nd}{spacing}{colour}")
    }
}

/// The layouts the render checks try beyond a cut: the luminance factors
/// of [`SHELL_BIN_CHOICES`] (128 and 64 bytes); luminance factors on
/// `theta_d` bins uniform in `1 - cos theta_d`, 4 x 4 (64 bytes) and 1 x 4
/// (16 bytes, which fits beside a fit a few bytes under a budget); and one
/// factor per function on the same bins, 1 x 4 (48 bytes) and 4 x 4 (192
/// bytes). The render checks measure each and keep what the renders
/// prefer within the byte budget; on the 11 RGL files' target searches one
/// of the four added layouts is kept on six
/// (docs/results/fidelity-2026-12-05-shell-layouts.md).
pub const SHELL_CHOICES: [ShellLayout; 6] = [
    ShellLayout::luminance(DEFAULT_SHELL_BINS),
    ShellLayout::luminance([4, 4]),
    ShellLayout::luminance([4, 4]).cosine(),
    ShellLayout::luminance([1, 4]).cosine(),
    ShellLayout::luminance([1, 4]).cosine().per_function(),
    ShellLayout::luminance([4, 4]).cosine().per_function(),
];

/// Steps of the quadrature [`ShellFactor::fit`] integrates with: midpoints
/// per cell along `theta_h` and along `theta_d`, and of `phi_d` over the
/// circle.
const QUADRATURE: (usize, usize) = (8, 48);

/// A factor of the luminance (or of each fitted function) beyond an
/// elevation cut, on a `theta_h x theta_d` grid (see the module
/// documentation). Deserialisation checks it ([`ShellFactor::validate`]).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "ShellSpec")]
pub struct ShellFactor {
    /// The elevation cut in degrees: pairs with both directions within it
    /// are left as they are.
    pub cut_deg: f64,
    /// Bins of `sqrt(theta_h / (pi / 2))` (the MERL warp, fine near the
    /// specular direction).
    pub n_theta_h: usize,
    /// Bins of `theta_d` over `[0, pi / 2]`, spaced as `spacing` says.
    pub n_theta_d: usize,
    /// Spacing of the `theta_d` bins.
    #[serde(default)]
    pub spacing: ThetaDSpacing,
    /// What each cell multiplies.
    #[serde(default)]
    pub colour: ShellColour,
    /// [`ShellColour::factors_per_cell`] factors per cell, cells `theta_h`
    /// major, each an f32 value; cells no grazing pair reaches hold 1.
    pub factors: Vec<f64>,
}

#[derive(Deserialize)]
struct ShellSpec {
    cut_deg: f64,
    n_theta_h: usize,
    n_theta_d: usize,
    #[serde(default)]
    spacing: ThetaDSpacing,
    #[serde(default)]
    colour: ShellColour,
    factors: Vec<f64>,
}

impl TryFrom<ShellSpec> for ShellFactor {
    type Error = BrdfError;
    fn try_from(s: ShellSpec) -> Result<Self, BrdfError> {
        let f = Self {
            cut_deg: s.cut_deg,
            n_theta_h: s.n_theta_h,
            n_theta_d: s.n_theta_d,
            spacing: s.spacing,
            colour: s.colour,
            factors: s.factors,
        };
        f.validate()?;
        Ok(f)
    }
}

/// The cell of Rusinkiewicz angles on a `bins` grid spaced as `spacing`.
pub(crate) fn shell_cell(
    theta_h: f64,
    theta_d: f64,
    bins: [usize; 2],
    spacing: ThetaDSpacing,
) -> usize {
    let h = ((theta_h.max(0.0) / FRAC_PI_2).sqrt() * bins[0] as f64) as usize;
    let d = match spacing {
        ThetaDSpacing::Uniform => theta_d.max(0.0) / FRAC_PI_2,
        ThetaDSpacing::Cosine => 1.0 - theta_d.clamp(0.0, FRAC_PI_2).cos(),
    };
    let d = (d * bins[1] as f64) as usize;
    h.min(bins[0] - 1) * bins[1] + d.min(bins[1] - 1)
}

/// Integrals of the table's and the fit's values over one cell: the
/// luminance, then each RGB channel.
#[derive(Clone, Copy, Default)]
struct CellSums {
    table: [f64; 4],
    fit: [f64; 4],
}

impl CellSums {
    fn add(&mut self, weight: f64, table: [f64; 3], fit: [f64; 3]) {
        for (sums, v) in [(&mut self.table, table), (&mut self.fit, fit)] {
            sums[0] += weight * luminance(v);
            for c in 0..3 {
                sums[c + 1] += weight * v[c];
            }
        }
    }

    /// The factors of the cell: the luminance's ratio, or one per function
    /// of `mode` so that each RGB channel's integral matches the table's.
    fn factors(&self, colour: ShellColour, mode: ColourMode) -> Vec<f64> {
        let ratio = |k: usize| {
            let (t, f) = (self.table[k], self.fit[k]);
            if f > 0.0 {
                (t / f).max(0.0)
            } else {
                1.0
            }
        };
        let y = ratio(0);
        let factors = match (colour, mode) {
            (ShellColour::Luminance, _) => vec![y],
            (ShellColour::PerFunction, ColourMode::Rgb) => vec![ratio(1), ratio(2), ratio(3)],
            // `r = Y (r / Y)`: the ratio's factor is the red channel's over
            // the luminance's.
            (ShellColour::PerFunction, ColourMode::LuminanceChroma) => {
                let of_ratio = |k: usize| if y > 0.0 { ratio(k) / y } else { 1.0 };
                vec![y, of_ratio(1), of_ratio(3)]
            }
        };
        factors
            .into_iter()
            .map(|k| f64::from(k.min(MAX_SHELL_FACTOR) as f32))
            .collect()
    }
}

impl ShellFactor {
    /// Fits the factor of `within` (a fit evaluated within its elevation
    /// cut, without a shell) to `table` on a `bins = [theta_h, theta_d]`
    /// grid with uniform `theta_d` bins: per cell, the table's luminance
    /// integrated against the projected solid angle over the pairs beyond
    /// the cut, over the fit's. [`ShellFactor::fit_layout`] with
    /// [`ShellLayout::luminance`].
    ///
    /// # Errors
    /// As [`ShellFactor::fit_layout`].
    pub fn fit(
        table: &dyn Brdf,
        within: &crate::FittedBrdf,
        bins: [usize; 2],
    ) -> Result<Self, BrdfError> {
        Self::fit_layout(table, within, ShellLayout::luminance(bins))
    }

    /// Fits the factor of `within` (a fit evaluated within its elevation
    /// cut, without a shell) to `table` on `layout`'s cells: per cell, the
    /// table's luminance (or each RGB channel) integrated against the
    /// projected solid angle over the pairs beyond the cut, over the fit's.
    ///
    /// # Errors
    /// `within` has no elevation cut or has a shell already, bins outside
    /// `1..=MAX_SHELL_BINS`, or a cell whose table or fit integral is not
    /// finite (named).
    pub fn fit_layout(
        table: &dyn Brdf,
        within: &crate::FittedBrdf,
        layout: ShellLayout,
    ) -> Result<Self, BrdfError> {
        let cut_deg = within.reduction.max_elevation_deg;
        let bins = layout.bins;
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
        let sums: Vec<CellSums> = (0..cells)
            .into_par_iter()
            .map(|cell| cell_sums(table, within, layout, cell, cos_cut))
            .collect();
        // A non-finite integral would otherwise become a factor of 0, 1 or
        // the largest allowed without a word: name the cell instead.
        let finite = |v: &[f64; 4]| v.iter().all(|x| x.is_finite());
        if let Some((cell, s)) = sums
            .iter()
            .enumerate()
            .find(|(_, s)| !(finite(&s.table) && finite(&s.fit)))
        {
            let (whose, v) = if finite(&s.table) {
                ("the fit's", s.fit)
            } else {
                ("the table's", s.table)
            };
            let value = v.iter().copied().find(|x| !x.is_finite()).unwrap_or(v[0]);
            return Err(bad(format!(
                "{whose} integral over cell {cell} ({} x {} cells) beyond the cut is {value}",
                bins[0], bins[1],
            )));
        }
        let factors = sums
            .iter()
            .flat_map(|s| s.factors(layout.colour, within.mode))
            .collect();
        let shell = Self {
            cut_deg,
            n_theta_h: bins[0],
            n_theta_d: bins[1],
            spacing: layout.spacing,
            colour: layout.colour,
            factors,
        };
        shell.validate()?;
        Ok(shell)
    }

    /// Its cells: bins, spacing and what they multiply.
    pub fn layout(&self) -> ShellLayout {
        ShellLayout {
            bins: [self.n_theta_h, self.n_theta_d],
            spacing: self.spacing,
            colour: self.colour,
        }
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
        let per_cell = self.colour.factors_per_cell();
        if self.factors.len() != cells * per_cell {
            return Err(bad(format!(
                "{} factors for {cells} cells of {per_cell} each",
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

    /// The multipliers of `mode`'s three functions at a pair: 1 when both
    /// directions are within the cut.
    pub fn multipliers(&self, wi: Vec3, wo: Vec3, mode: ColourMode) -> [f64; 3] {
        self.multipliers_given(wi, wo, mode, || {
            let [theta_h, theta_d, _] = HalfDiff::isotropic_angles(wi, wo);
            [theta_h, theta_d]
        })
    }

    /// [`ShellFactor::multipliers`] with the pair's `[theta_h, theta_d]`
    /// from `angles` (called only beyond the cut): evaluations of one pair
    /// under several shell factors compute its angles once.
    pub fn multipliers_given(
        &self,
        wi: Vec3,
        wo: Vec3,
        mode: ColourMode,
        angles: impl FnOnce() -> [f64; 2],
    ) -> [f64; 3] {
        let cos_cut = self.cut_deg.to_radians().cos();
        if wi[2] >= cos_cut && wo[2] >= cos_cut {
            return [1.0; 3];
        }
        let [theta_h, theta_d] = angles();
        let cell = shell_cell(
            theta_h,
            theta_d,
            [self.n_theta_h, self.n_theta_d],
            self.spacing,
        );
        match self.colour {
            ShellColour::Luminance => Self::factors_for(self.factors[cell], mode),
            ShellColour::PerFunction => {
                let k = &self.factors[3 * cell..3 * cell + 3];
                [k[0], k[1], k[2]]
            }
        }
    }

    /// What a luminance factor multiplies among the three functions: all
    /// three in RGB, the luminance alone in luminance-chroma.
    pub fn factors_for(k: f64, mode: ColourMode) -> [f64; 3] {
        match mode {
            ColourMode::Rgb => [k; 3],
            ColourMode::LuminanceChroma => [k, 1.0, 1.0],
        }
    }
}
/// The integrals of the table and of the fit `within` over the pairs of
/// shell cell `cell` of `layout` beyond the cut (`cos_cut`).
fn cell_sums(
    table: &dyn Brdf,
    within: &crate::FittedBrdf,
    layout: ShellLayout,
    cell: usize,
    cos_cut: f64,
) -> CellSums {
    let bins = layout.bins;
    let (sub, azimuths) = QUADRATURE;
    // Midpoints of each cell in the warped `u = sqrt(theta_h / (pi/2))`
    // and in the `theta_d` spacing's variable, and of `phi_d` over the
    // circle, so that every cell is integrated, the narrow ones at the
    // specular direction included. A pair's measure is
    // `4 cos_d dw_h dw_d`, with `dtheta_h = pi u du` and `sin theta_d
    // dtheta_d` (uniform) or `d(1 - cos theta_d)` (cosine); the
    // constants cancel in the ratio.
    let (ch, cd) = (cell / bins[1], cell % bins[1]);
    let mut sums = CellSums::default();
    for a in 0..sub {
        let u = (ch as f64 + (a as f64 + 0.5) / sub as f64) / bins[0] as f64;
        let theta_h = u * u * FRAC_PI_2;
        for b in 0..sub {
            let v = (cd as f64 + (b as f64 + 0.5) / sub as f64) / bins[1] as f64;
            let (theta_d, d_measure) = match layout.spacing {
                ThetaDSpacing::Uniform => {
                    let t = v * FRAC_PI_2;
                    (t, t.sin())
                }
                ThetaDSpacing::Cosine => ((1.0 - v).acos(), 1.0),
            };
            for p in 0..azimuths {
                let phi_d = (p as f64 + 0.5) / azimuths as f64 * 2.0 * PI;
                let (wi, wo) = HalfDiff {
                    theta_h,
                    phi_h: 0.0,
                    theta_d,
                    phi_d,
                }
                .to_directions();
                if wi[2] <= 0.0 || wo[2] <= 0.0 || (wi[2] >= cos_cut && wo[2] >= cos_cut) {
                    continue;
                }
                let weight = wi[2] * wo[2] * theta_d.cos() * theta_h.sin() * d_measure * u;
                sums.add(weight, table.eval(wi, wo), within.eval(wi, wo));
            }
        }
    }
    sums
}
