//! Fitting the RGB channels of a BRDF and evaluating the fit.

use crate::baseline::BaselineReport;
use crate::colour::ColourMode;
use crate::design::{ChannelBounds, PerceptualBounds, DEFAULT_PEAK_CAP};
use crate::geometry::{HalfDiff, Vec3};
use crate::lobe::Lobe;
use crate::reduce::{Reduction, Samples, HORIZON_INSET_RAD};
use crate::{Brdf, BrdfError};
use rational_core::{fit, FitSettings, IntervalData, RationalFunction};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::fmt;
use std::time::Instant;

/// Settings of [`fit_brdf`].
#[derive(Debug, Clone)]
pub struct BrdfFitSettings {
    reduction: Reduction,
    rel_tol: f64,
    noise_floor: f64,
    fit: FitSettings,
    baselines: bool,
    design: Option<PerceptualBounds>,
    mode: ColourMode,
    lobe: Option<Lobe>,
    cap_rounds: usize,
}

/// Most refits [`BrdfFitSettings::with_cap_rounds`] may ask for.
pub const MAX_CAP_ROUNDS: usize = 16;

impl Default for BrdfFitSettings {
    /// The 2-D slice on the MERL grid, relative intervals of 5% with a noise
    /// floor of 1% of the channel's median value, budgets up to 60
    /// coefficients per channel, at most two refits of the dense cap check,
    /// rational-core's other defaults.
    fn default() -> Self {
        Self {
            reduction: Reduction::default(),
            rel_tol: 0.05,
            noise_floor: 1e-2,
            baselines: true,
            design: None,
            mode: ColourMode::Rgb,
            lobe: None,
            cap_rounds: 2,
            fit: FitSettings::default()
                .with_coeff_range(2, 60)
                .expect("valid range"),
        }
    }
}

impl BrdfFitSettings {
    /// Sampling and coordinates.
    pub fn with_reduction(mut self, r: Reduction) -> Self {
        self.reduction = r;
        self
    }

    /// Relative half-width of the intervals.
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

    /// Smallest interval half-width, as a fraction of the channel's median
    /// value: a measurement's noise floor. Relative intervals alone ask the
    /// fit to follow noise at a millionth of the peak (real tables have such
    /// tails).
    ///
    /// # Errors
    /// Negative, not finite, or 1 and above.
    pub fn with_noise_floor(mut self, floor: f64) -> Result<Self, BrdfError> {
        if !(0.0..1.0).contains(&floor) {
            return Err(BrdfError::Invalid {
                name: "noise floor",
                reason: format!("{floor} is not in [0, 1)"),
            });
        }
        self.noise_floor = floor;
        Ok(self)
    }

    /// Also fit the baselines (a polynomial with as many coefficients, and
    /// Cook-Torrance by Levenberg-Marquardt) on the same samples. Default on.
    pub fn with_baselines(mut self, on: bool) -> Self {
        self.baselines = on;
        self
    }

    /// The engine's settings (basis, budgets, backend, pole control).
    pub fn with_fit_settings(mut self, s: FitSettings) -> Self {
        self.fit = s;
        self
    }

    /// Intervals from the perceptual design ([`PerceptualBounds`]) instead
    /// of plain relative ones; the reduction should then cover the whole
    /// hemisphere ([`Reduction::whole_hemisphere`]), since the design
    /// constrains every cell it is given.
    pub fn with_design(mut self, design: PerceptualBounds) -> Self {
        self.design = Some(design);
        self
    }

    /// What the three fitted functions are (default RGB).
    pub fn with_colour_mode(mut self, mode: ColourMode) -> Self {
        self.mode = mode;
        self
    }

    /// Fit the ratio of the data to `lobe` instead of the data (the
    /// lobe-times-rational representation; see [`Lobe`]): the intervals are
    /// the same, divided by the lobe, so the bound on the product holds.
    pub fn with_lobe(mut self, lobe: Option<Lobe>) -> Self {
        self.lobe = lobe;
        self
    }

    /// At most `rounds` refits of the dense cap check: every fit is
    /// evaluated on a grid of the whole domain it is evaluated on, twice as
    /// dense as the data, and the points where it exceeds its cap (the
    /// perceptual design's `peak_cap`, else [`DEFAULT_PEAK_CAP`], times the
    /// channel's largest upper bound) are added as `[0, cap]` constraints
    /// before fitting again. 0 checks and reports without refitting.
    ///
    /// # Errors
    /// Above [`MAX_CAP_ROUNDS`].
    pub fn with_cap_rounds(mut self, rounds: usize) -> Result<Self, BrdfError> {
        if rounds > MAX_CAP_ROUNDS {
            return Err(BrdfError::Invalid {
                name: "cap rounds",
                reason: format!("{rounds} is above {MAX_CAP_ROUNDS}"),
            });
        }
        self.cap_rounds = rounds;
        Ok(self)
    }

    /// Refits the dense cap check may make.
    pub fn cap_rounds(&self) -> usize {
        self.cap_rounds
    }

    /// The analytic lobe the functions multiply, when in use.
    pub fn lobe(&self) -> Option<&Lobe> {
        self.lobe.as_ref()
    }

    /// The colour mode.
    pub fn colour_mode(&self) -> ColourMode {
        self.mode
    }

    /// The perceptual design, when in use.
    pub fn design(&self) -> Option<&PerceptualBounds> {
        self.design.as_ref()
    }

    /// The engine's settings.
    pub fn fit_settings(&self) -> &FitSettings {
        &self.fit
    }

    /// The reduction in use.
    pub fn reduction(&self) -> &Reduction {
        &self.reduction
    }
}

/// A fitted isotropic BRDF: one rational function per RGB channel over the
/// reduction's coordinates. Deserialisation checks it
/// ([`FittedBrdf::validate`]): a fit file is input like any other.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(try_from = "FittedSpec")]
pub struct FittedBrdf {
    /// What the functions were fitted to.
    pub reduction: Reduction,
    /// Red, green and blue, or what `mode` says.
    pub channels: Vec<RationalFunction>,
    /// What the three functions are (RGB unless stated).
    #[serde(default, skip_serializing_if = "ColourMode::is_rgb")]
    pub mode: ColourMode,
    /// The analytic lobe each function multiplies (the lobe-times-rational
    /// representation), when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lobe: Option<Lobe>,
    /// Source material.
    pub name: String,
}

/// The serialised form of a [`FittedBrdf`], checked on the way in.
#[derive(Deserialize)]
struct FittedSpec {
    reduction: Reduction,
    channels: Vec<RationalFunction>,
    #[serde(default)]
    mode: ColourMode,
    #[serde(default)]
    lobe: Option<Lobe>,
    name: String,
}

impl TryFrom<FittedSpec> for FittedBrdf {
    type Error = BrdfError;
    fn try_from(s: FittedSpec) -> Result<Self, BrdfError> {
        let f = Self {
            reduction: s.reduction,
            channels: s.channels,
            mode: s.mode,
            lobe: s.lobe,
            name: s.name,
        };
        f.validate()?;
        Ok(f)
    }
}

impl FittedBrdf {
    /// Checks every invariant the evaluators index by: three channels, each
    /// a function of the reduction's coordinates, and a valid reduction
    /// (each function's coefficients were checked when it was built).
    ///
    /// # Errors
    /// The first invariant broken, named.
    pub fn validate(&self) -> Result<(), BrdfError> {
        let bad = |reason: String| BrdfError::Invalid {
            name: "fitted BRDF",
            reason,
        };
        self.reduction.validate()?;
        if self.channels.len() != 3 {
            return Err(bad(format!(
                "{} channels (three functions expected: {})",
                self.channels.len(),
                match self.mode {
                    ColourMode::Rgb => "red, green, blue",
                    ColourMode::LuminanceChroma => "luminance, r/Y, b/Y",
                }
            )));
        }
        let dims = self.reduction.dims();
        for (k, c) in self.channels.iter().enumerate() {
            if c.basis().dim() != dims {
                return Err(bad(format!(
                    "channel {k} is a function of {} coordinates; the {:?} reduction has {dims}",
                    c.basis().dim(),
                    self.reduction.kind
                )));
            }
        }
        Ok(())
    }

    /// Fitting coordinates of a direction pair: `phi_d` folded by
    /// reciprocity, `theta_d` clamped to the fitted range (no extrapolation
    /// into the grazing cut).
    pub fn coordinates(&self, wi: Vec3, wo: Vec3) -> Vec<f64> {
        let hd = HalfDiff::from_directions(wi, wo);
        let td = hd.theta_d.min(self.reduction.max_theta_d_deg.to_radians());
        self.reduction
            .coordinates
            .map(hd.theta_h, td, hd.folded_phi_d(), self.reduction.dims())
    }

    /// Evaluates every channel in f64 and makes RGB by the colour mode;
    /// negative values (possible only between samples) are clamped to zero.
    /// A fit with a lobe needs the directions: see [`Brdf::eval`].
    pub fn eval_coords(&self, x: &[f64]) -> [f64; 3] {
        self.mode
            .combine([0, 1, 2].map(|c| self.channels[c].eval(x)))
    }

    /// The functions' values at a direction pair above the surface (the
    /// lobe's factors applied), before the colour mode makes RGB.
    fn functions_at(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        let x = self.coordinates(wi, wo);
        let v = [0, 1, 2].map(|c| self.channels[c].eval(&x));
        match &self.lobe {
            Some(lobe) => {
                let f = lobe.factors(wi, wo, self.mode);
                [0, 1, 2].map(|c| v[c] * f[c])
            }
            None => v,
        }
    }

    /// Evaluates the fit at many direction pairs in parallel.
    pub fn eval_many(&self, pairs: &[(Vec3, Vec3)]) -> Vec<[f64; 3]> {
        pairs
            .par_iter()
            .map(|&(wi, wo)| self.eval(wi, wo))
            .collect()
    }

    /// Total coefficients over the channels.
    pub fn coefficients(&self) -> usize {
        self.channels
            .iter()
            .map(|f| f.split().0 + f.split().1)
            .sum()
    }

    /// Bytes of all coefficients as f32, and the lobe's seven parameters
    /// when there is one.
    pub fn byte_size_f32(&self) -> usize {
        self.channels
            .iter()
            .map(RationalFunction::byte_size_f32)
            .sum::<usize>()
            + if self.lobe.is_some() { 28 } else { 0 }
    }
}

impl Brdf for FittedBrdf {
    /// The fit at `(wi, wo)`; beyond an elevation cut of the reduction,
    /// directions are moved to the cut ([`crate::clamp_elevation`]), where
    /// the fit was constrained.
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        let cut = self.reduction.max_elevation_deg;
        if cut < 90.0 {
            let (sin_cut, cos_cut) = cut.to_radians().sin_cos();
            let (wi, wo) = (
                crate::geometry::clamp_elevation(wi, cos_cut, sin_cut),
                crate::geometry::clamp_elevation(wo, cos_cut, sin_cut),
            );
            return self.mode.combine(self.functions_at(wi, wo));
        }
        self.mode.combine(self.functions_at(wi, wo))
    }

    fn name(&self) -> String {
        format!("rational fit of {}", self.name)
    }
}

/// Figures of one channel's fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ChannelReport {
    /// `r`, `g` or `b`.
    pub channel: char,
    /// Numerator coefficients.
    pub n_p: usize,
    /// Denominator coefficients.
    pub n_q: usize,
    /// Coefficient bytes as f32.
    pub bytes_f32: usize,
    /// Verified inside every interval in f64.
    pub verified: bool,
    /// Depth of the chosen P(n_p, n_q) solution.
    pub depth: f64,
    /// Samples fitted.
    pub samples: usize,
    /// Fitted samples above the noise floor (relative intervals).
    pub samples_above_floor: usize,
    /// The noise floor in the channel's units.
    pub noise_floor_abs: f64,
    /// Max relative error on the fitted samples above the noise floor.
    pub max_rel: f64,
    /// Mean relative error on the fitted samples above the noise floor.
    pub mean_rel: f64,
    /// Max relative error on every valid sample, grazing ones included
    /// (evaluated with `theta_d` clamped to the fitted range).
    pub max_rel_all: f64,
    /// Mean relative error on every valid sample.
    pub mean_rel_all: f64,
    /// RMSE on the fitted samples.
    pub rmse: f64,
    /// RMSE weighted by `cos theta_i cos theta_o` (normalised weights).
    pub cos_rmse: f64,
    /// Fit time (the sweep) in seconds.
    pub seconds: f64,
    /// Factor applied to every interval half-width when the requested ones
    /// had no fit within the budget (1 when none was needed; see
    /// `FitSettings::with_widening`).
    #[serde(default = "unit_scale")]
    pub interval_scale: f64,
    /// What the perceptual design used (when in use).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub bounds: Option<ChannelBounds>,
    /// What the dense cap check found (absent from files written before
    /// every fit had one).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub cap: Option<CapCheck>,
    /// Baselines on the same samples (when enabled).
    pub baselines: Vec<BaselineReport>,
}

fn unit_scale() -> f64 {
    1.0
}

/// What the dense cap check found for one function: between the samples
/// nothing bounds `p / q`, so the fit is evaluated on a grid of its whole
/// evaluation domain.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct CapCheck {
    /// The cap on the fitted value (of the product, with a lobe) in the
    /// function's units.
    pub cap: f64,
    /// Grid points the check evaluated.
    pub grid_points: usize,
    /// Points where a fit exceeded the cap, added as `[0, cap]`
    /// constraints before fitting again.
    pub points: usize,
    /// Refits made.
    pub refits: usize,
    /// Largest ratio of the final fit to the cap over the grid's finite
    /// values (at most about 1.01 when the check succeeded).
    pub largest: f64,
    /// Grid points where the final fit is not finite (a pole).
    pub non_finite: usize,
}

impl CapCheck {
    /// The final fit stays within 1% of its cap on the whole grid.
    pub fn held(&self) -> bool {
        self.non_finite == 0 && self.largest <= 1.01
    }
}

/// The report of [`fit_brdf`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BrdfFitReport {
    /// Source material.
    pub material: String,
    /// Sampling used.
    pub reduction: Reduction,
    /// Relative half-width of the intervals.
    pub rel_tol: f64,
    /// Smallest half-width as a fraction of each channel's median value.
    pub noise_floor: f64,
    /// The perceptual design, when it chose the intervals (then `rel_tol`
    /// is its relative half-width where the light is visible).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub design: Option<PerceptualBounds>,
    /// Degree weights of the basis order (empty: the total-degree order).
    #[serde(default, skip_serializing_if = "Vec::is_empty")]
    pub degree_weights: Vec<u16>,
    /// The lobe the functions multiply, when in use.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lobe: Option<Lobe>,
    /// Per channel.
    pub channels: Vec<ChannelReport>,
    /// Total wall time, sampling included.
    pub seconds: f64,
}

impl fmt::Display for BrdfFitReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.reduction;
        writeln!(
            f,
            "{}: {:?} in {:?} coordinates, theta_d <= {} deg, intervals +-{}% (noise floor {:e} of the median)",
            self.material,
            r.kind,
            r.coordinates,
            r.max_theta_d_deg,
            self.rel_tol * 100.0,
            self.noise_floor
        )?;
        if let Some(d) = &self.design {
            writeln!(
                f,
                "  perceptual intervals: +-{}% where visible, floor {}% of the peak of f cos_i cos_o, >= {} noise deviations, capped at {}x the peak; every cell of the hemisphere",
                d.rel_tol * 100.0,
                d.visibility * 100.0,
                d.noise_factor,
                d.peak_cap
            )?;
            for c in &self.channels {
                if let Some(b) = &c.bounds {
                    writeln!(
                        f,
                        "  {}   peak {:.4e}, noise {:.2}% (estimated), cells bound by perception / floor / noise: {} / {} / {}",
                        c.channel, b.peak, b.noise * 100.0, b.perceptual_cells, b.floor_cells, b.noise_cells,
                    )?;
                }
            }
        }
        for c in &self.channels {
            if let Some(k) = &c.cap {
                writeln!(
                    f,
                    "  {}   cap check on {} points of the evaluation domain: cap {:.4e}, {} points added in {} refits, largest value {:.2}x the cap{}{}",
                    c.channel,
                    k.grid_points,
                    k.cap,
                    k.points,
                    k.refits,
                    k.largest,
                    if k.non_finite > 0 {
                        format!(", NOT FINITE at {} points", k.non_finite)
                    } else {
                        String::new()
                    },
                    if k.held() { "" } else { " (ABOVE the cap)" }
                )?;
            }
        }
        if let Some(l) = &self.lobe {
            writeln!(
                f,
                "  lobe times rational: the functions fit the table divided by Cook-Torrance GGX (kd {:.4?}, f0 {:.4?}, alpha {:.4}); errors below are of the product",
                l.kd, l.f0, l.alpha
            )?;
        }
        if !self.degree_weights.is_empty() {
            let w: Vec<String> = self.degree_weights.iter().map(u16::to_string).collect();
            writeln!(f, "  basis order: degree weights {}", w.join(","))?;
        }
        writeln!(
            f,
            "  ch  n_p n_q  bytes  samples (>floor)  verified   max rel  mean rel  max rel*  mean rel*      RMSE   cos-RMSE    time s"
        )?;
        for c in &self.channels {
            writeln!(
                f,
                "  {}   {:>3} {:>3} {:>6} {:>7} ({:>7})  {:>8} {:>9.3e} {:>9.3e} {:>9.3e} {:>10.3e} {:>9.3e} {:>10.3e} {:>9.3}",
                c.channel,
                c.n_p,
                c.n_q,
                c.bytes_f32,
                c.samples,
                c.samples_above_floor,
                if c.verified { "yes" } else { "NO" },
                c.max_rel,
                c.mean_rel,
                c.max_rel_all,
                c.mean_rel_all,
                c.rmse,
                c.cos_rmse,
                c.seconds
            )?;
        }
        for c in self.channels.iter().filter(|c| c.interval_scale > 1.0) {
            writeln!(
                f,
                "  {}   no fit within the budget at the requested intervals; fitted with every interval widened x{} (on a log scale)",
                c.channel, c.interval_scale
            )?;
        }
        for c in &self.channels {
            for b in &c.baselines {
                writeln!(
                    f,
                    "  {}   baseline {:<58} max rel {:>9.3e}  mean rel {:>9.3e}  {:>7.3} s",
                    c.channel, b.name, b.max_rel, b.mean_rel, b.seconds
                )?;
            }
        }
        write!(
            f,
            "  relative errors over samples above the noise floor; * also grazing ones (theta_d clamped to the cut)\n  total wall time {:.3} s",
            self.seconds
        )
    }
}

/// Samples `material`, fits each RGB channel (in parallel) with the sweep,
/// and reports error next to cost.
///
/// # Errors
/// Invalid settings, no positive samples, or no feasible fit for a channel.
pub fn fit_brdf(
    material: &dyn Brdf,
    settings: &BrdfFitSettings,
) -> Result<(FittedBrdf, BrdfFitReport), BrdfError> {
    let start = Instant::now();
    let samples = settings.reduction.sample(material);
    let (fitted, mut report) = fit_samples(&samples, &material.name(), settings)?;
    report.seconds = start.elapsed().as_secs_f64();
    Ok((fitted, report))
}

/// Fits already sampled data (a grid from [`Reduction::sample`] or scattered
/// measurements) in the reduction of `settings`.
///
/// # Errors
/// As [`fit_brdf`].
pub fn fit_samples(
    samples: &Samples,
    name: &str,
    settings: &BrdfFitSettings,
) -> Result<(FittedBrdf, BrdfFitReport), BrdfError> {
    let start = Instant::now();
    let derived = in_fitted_mode(samples, settings)?;
    let samples = derived.as_ref().unwrap_or(samples);
    let results: Vec<Result<(RationalFunction, ChannelReport), BrdfError>> = (0..3)
        .into_par_iter()
        .map(|c| fit_channel(samples, c, settings))
        .collect();
    let parts = results.into_iter().collect::<Result<Vec<_>, _>>()?;
    let (fitted, mut report) = assemble(samples, name, settings, parts);
    report.seconds = start.elapsed().as_secs_f64();
    Ok((fitted, report))
}

/// Fits one of the three functions of [`fit_samples`] (`channel` 0, 1 or 2
/// of the settings' colour mode) alone, so that the channels of a material
/// can run as separate tasks of a distributed engine;
/// [`assemble_channels`] joins them.
///
/// # Errors
/// As [`fit_brdf`], or a channel outside 0..3.
pub fn fit_samples_channel(
    samples: &Samples,
    channel: usize,
    settings: &BrdfFitSettings,
) -> Result<(RationalFunction, ChannelReport), BrdfError> {
    if channel > 2 {
        return Err(BrdfError::Invalid {
            name: "channel",
            reason: format!("{channel} is not 0, 1 or 2"),
        });
    }
    let derived = in_fitted_mode(samples, settings)?;
    fit_channel(derived.as_ref().unwrap_or(samples), channel, settings)
}

/// Joins three channels fitted by [`fit_samples_channel`] with the same
/// samples and settings into the fit and report [`fit_samples`] returns.
///
/// # Errors
/// Not three channels, or functions that do not take the reduction's
/// coordinates.
pub fn assemble_channels(
    samples: &Samples,
    name: &str,
    settings: &BrdfFitSettings,
    parts: Vec<(RationalFunction, ChannelReport)>,
) -> Result<(FittedBrdf, BrdfFitReport), BrdfError> {
    let derived = in_fitted_mode(samples, settings)?;
    if parts.len() != 3 {
        return Err(BrdfError::Invalid {
            name: "channels",
            reason: format!("{} channels given, a material has 3", parts.len()),
        });
    }
    if let Some((f, _)) = parts.iter().find(|(f, _)| f.dim() != samples.dims) {
        return Err(BrdfError::Invalid {
            name: "channels",
            reason: format!("a {}-D function for {}-D samples", f.dim(), samples.dims),
        });
    }
    let seconds = parts.iter().map(|(_, r)| r.seconds).fold(0.0, f64::max);
    let (fitted, mut report) = assemble(derived.as_ref().unwrap_or(samples), name, settings, parts);
    report.seconds = seconds;
    Ok((fitted, report))
}

/// The samples in the settings' colour mode (`None`: they are already), after
/// checking their dimension against the reduction's.
fn in_fitted_mode(
    samples: &Samples,
    settings: &BrdfFitSettings,
) -> Result<Option<Samples>, BrdfError> {
    if samples.dims != settings.reduction.dims() {
        return Err(BrdfError::Invalid {
            name: "samples",
            reason: format!(
                "{}-D samples for a {}-D reduction",
                samples.dims,
                settings.reduction.dims()
            ),
        });
    }
    Ok((!settings.mode.is_rgb()).then(|| samples.in_colour_mode(settings.mode)))
}

/// The fit and its report from three fitted channels, with the errors over
/// every sample (`samples` in the settings' colour mode).
fn assemble(
    samples: &Samples,
    name: &str,
    settings: &BrdfFitSettings,
    parts: Vec<(RationalFunction, ChannelReport)>,
) -> (FittedBrdf, BrdfFitReport) {
    let (channels, mut reports): (Vec<_>, Vec<_>) = parts.into_iter().unzip();
    let fitted = FittedBrdf {
        reduction: settings.reduction,
        channels,
        mode: settings.mode,
        lobe: settings.lobe,
        name: name.to_string(),
    };
    // Errors over every valid sample above the floor, grazing ones included.
    for (c, rep) in reports.iter_mut().enumerate() {
        let (mut max, mut sum, mut n) = (0.0_f64, 0.0, 0usize);
        let floor = rep.noise_floor_abs / settings.design.map_or(settings.rel_tol, |d| d.rel_tol);
        for row in samples
            .rows
            .iter()
            .filter(|r| r.value[c] > floor && r.value[c].is_finite())
        {
            let r = &settings.reduction;
            let [th, td, pd] = row.angles;
            let x = r
                .coordinates
                .map(th, td.min(r.max_theta_d_deg.to_radians()), pd, r.dims());
            // Each function against its own data (luminance or a ratio in
            // the luminance-chroma mode).
            let lobe = settings
                .lobe
                .map_or(1.0, |l| l.factors_at(row.angles, settings.mode)[c]);
            let e = ((fitted.channels[c].eval(&x) * lobe).max(0.0) / row.value[c] - 1.0).abs();
            max = max.max(e);
            sum += e;
            n += 1;
        }
        rep.max_rel_all = max;
        rep.mean_rel_all = if n > 0 { sum / n as f64 } else { 0.0 };
    }
    let report = BrdfFitReport {
        material: name.to_string(),
        reduction: settings.reduction,
        rel_tol: settings.design.map_or(settings.rel_tol, |d| d.rel_tol),
        noise_floor: settings.noise_floor,
        design: settings.design,
        degree_weights: fitted
            .channels
            .first()
            .map(|r| r.basis())
            .filter(|b| b.is_weighted())
            .map(|b| b.weights().to_vec())
            .unwrap_or_default(),
        lobe: settings.lobe,
        channels: reports,
        seconds: 0.0,
    };
    (fitted, report)
}

/// Most points one round of the cap check adds (the largest excesses).
const CAP_POINTS_PER_ROUND: usize = 400;

/// Most points of the cap check's grid: 512 per axis in 2-D, 64 in 3-D.
const CAP_GRID_MAX_POINTS: usize = 1 << 18;

/// The dense grid of the cap check: the reduction's whole evaluation domain
/// ([`Reduction::domain`], corners and faces included, so the
/// extrapolation beyond the outermost cells is covered), twice as dense as
/// the data along each coordinate (at least 4 points, at most
/// [`CAP_GRID_MAX_POINTS`] in all), only points whose two directions are
/// above the horizon and, when the reduction has an elevation cut (where
/// evaluation clamps directions), within it. The `phi_d = pi / 2` slice
/// holds both directions nearest the normal, so in 2-D these are exactly the
/// coordinates that evaluation reaches. Each line of constant `theta_h`
/// (and `phi_d`) also gets the point where the cut or the horizon ends it:
/// the last grid point inside stops up to a step short, and fits rise
/// steepest at that edge.
fn cap_grid(data: &IntervalData, reduction: &Reduction) -> Vec<Vec<f64>> {
    let dim = data.dim();
    let (lower, upper) = reduction.domain();
    let most_per_axis = (CAP_GRID_MAX_POINTS as f64).powf(1.0 / dim as f64).floor() as usize;
    // Distinct coordinate values per axis give the data's resolution.
    let per_axis: Vec<usize> = (0..dim)
        .map(|k| {
            let mut v: Vec<f64> = data.points().chunks_exact(dim).map(|p| p[k]).collect();
            v.sort_by(f64::total_cmp);
            v.dedup();
            (2 * v.len()).clamp(4, most_per_axis.max(4))
        })
        .collect();
    // A hair below the cut's cosine: points on the cut itself stay.
    let min_cos = if reduction.max_elevation_deg < 90.0 {
        reduction.max_elevation_deg.to_radians().cos() - 1e-9
    } else {
        0.0
    };
    let total: usize = per_axis.iter().product();
    let mut grid = Vec::with_capacity(total);
    for idx in 0..total {
        let mut rest = idx;
        let x: Vec<f64> = (0..dim)
            .map(|k| {
                let n = per_axis[k];
                let t = (rest % n) as f64 / (n - 1) as f64;
                rest /= n;
                lower[k] + t * (upper[k] - lower[k])
            })
            .collect();
        let [theta_h, theta_d, phi_d] = reduction.coordinates.angles(&x);
        let (wi, wo) = HalfDiff {
            theta_h,
            phi_h: 0.0,
            theta_d,
            phi_d,
        }
        .to_directions();
        if wi[2] > 0.0 && wo[2] > 0.0 && wi[2].min(wo[2]) >= min_cos {
            grid.push(x);
        }
    }
    grid.extend(boundary_points(reduction, &lower, &upper, &per_axis));
    grid
}

/// The points where the elevation cut (or, without one, the inset horizon)
/// ends each line of constant `theta_h` and `phi_d` of the cap grid: the
/// smaller elevation of the pair, `cos theta_h cos theta_d - sin theta_h
/// sin theta_d |cos phi_d|`, equals the cut's cosine there.
fn boundary_points(
    reduction: &Reduction,
    lower: &[f64],
    upper: &[f64],
    per_axis: &[usize],
) -> Vec<Vec<f64>> {
    let dim = per_axis.len();
    let horizon = std::f64::consts::FRAC_PI_2 - HORIZON_INSET_RAD;
    let edge = reduction.max_elevation_deg.to_radians().min(horizon);
    let theta_d_max = reduction.max_theta_d_deg.to_radians().min(horizon);
    let n_phi = if dim == 3 { per_axis[2] } else { 1 };
    let at =
        |k: usize, i: usize| lower[k] + i as f64 / (per_axis[k] - 1) as f64 * (upper[k] - lower[k]);
    let mut out = Vec::new();
    for i in 0..per_axis[0] {
        for j in 0..n_phi {
            let mut x = vec![at(0, i), lower[1]];
            if dim == 3 {
                x.push(at(2, j));
            }
            let [theta_h, _, phi_d] = reduction.coordinates.angles(&x);
            // a cos(theta_d) - b sin(theta_d) = r cos(theta_d + atan2(b, a)).
            let (a, b) = (theta_h.cos(), theta_h.sin() * phi_d.cos().abs());
            let r = a.hypot(b);
            if edge.cos() >= r {
                continue; // the whole line is beyond the edge
            }
            let theta_d = (edge.cos() / r).acos() - b.atan2(a);
            if theta_d > 0.0 && theta_d < theta_d_max {
                out.push(reduction.coordinates.map(theta_h, theta_d, phi_d, dim));
            }
        }
    }
    out
}

/// One scan of the cap check's grid.
struct CapScan {
    /// The points to add (flattened), the largest excesses first.
    points: Vec<f64>,
    /// The cap at each point to add.
    caps: Vec<f64>,
    /// Largest ratio of `f` to its cap over the finite values.
    largest: f64,
    /// Grid points where `f` is not finite.
    non_finite: usize,
}

/// The points of `grid` where `f` exceeds `cap_at` by more than 1% or is
/// not finite (the largest [`CAP_POINTS_PER_ROUND`] excesses relative to
/// the cap, non-finite ones first), each with its cap.
fn points_above_cap(
    grid: &[Vec<f64>],
    f: &RationalFunction,
    cap_at: &dyn Fn(&[f64]) -> f64,
) -> CapScan {
    let mut found: Vec<(f64, f64, &[f64])> = Vec::new();
    let (mut largest, mut non_finite) = (0.0_f64, 0usize);
    for x in grid {
        let v = f.eval(x);
        let cap = cap_at(x);
        let excess = if v.is_finite() {
            largest = largest.max(v / cap);
            v / cap
        } else {
            non_finite += 1;
            f64::INFINITY
        };
        if excess > 1.01 {
            found.push((excess, cap, x));
        }
    }
    found.sort_by(|a, b| b.0.total_cmp(&a.0));
    found.truncate(CAP_POINTS_PER_ROUND);
    CapScan {
        caps: found.iter().map(|p| p.1).collect(),
        points: found.iter().flat_map(|p| p.2.iter().copied()).collect(),
        largest,
        non_finite,
    }
}

/// `data` with `points` added as `[0, cap]` constraints, one cap each.
fn with_cap_points(
    data: &IntervalData,
    points: Vec<f64>,
    caps: &[f64],
) -> Result<IntervalData, rational_core::FitError> {
    let mut all = data.points().to_vec();
    all.extend(points);
    let mut lo = data.lo().to_vec();
    let mut hi = data.hi().to_vec();
    let mut values: Vec<f64> = (0..data.len()).map(|i| data.value(i)).collect();
    lo.extend(std::iter::repeat_n(0.0, caps.len()));
    hi.extend_from_slice(caps);
    values.extend(caps.iter().map(|c| 0.5 * c));
    IntervalData::new(data.dim(), all, lo, hi)?.with_values(values)
}

/// `data` with every interval and value divided by its point's factor.
fn divided_by(
    data: &IntervalData,
    factors: &[f64],
) -> Result<IntervalData, rational_core::FitError> {
    let lo = data.lo().iter().zip(factors).map(|(v, f)| v / f).collect();
    let hi = data.hi().iter().zip(factors).map(|(v, f)| v / f).collect();
    let values = (0..data.len())
        .map(|i| data.value(i) / factors[i])
        .collect();
    IntervalData::new(data.dim(), data.points().to_vec(), lo, hi)?.with_values(values)
}

/// Errors of a channel's fit (times its lobe) on the samples it was fitted to.
struct SampleErrors {
    above_floor: usize,
    floor_abs: f64,
    max_rel: f64,
    mean_rel: f64,
    rmse: f64,
    cos_rmse: f64,
}

impl SampleErrors {
    /// `fitted(k)` is the fit's value at the `k`-th used sample;
    /// `measured_lo` the lower ends of the measured intervals.
    fn of(
        samples: &Samples,
        c: usize,
        used: &[usize],
        rel_tol: f64,
        measured_lo: &[f64],
        fitted: impl Fn(usize) -> f64,
    ) -> Self {
        let (mut wsum, mut wsq, mut sq) = (0.0_f64, 0.0_f64, 0.0_f64);
        // Relative errors over the samples whose interval is relative
        // (above the noise floor); below it the bound is absolute.
        let (mut max_rel, mut sum_rel, mut n_rel) = (0.0_f64, 0.0, 0usize);
        let mut floor_abs = 0.0_f64;
        for (k, &i) in used.iter().enumerate() {
            let row = &samples.rows[i];
            let v = row.value[c];
            let e = fitted(k) - v;
            sq += e * e;
            wsum += row.cos_weight;
            wsq += row.cos_weight * e * e;
            let relative_bound = rel_tol * row.lo[c].min(v);
            if v <= 0.0 || v - measured_lo[k] > relative_bound * (1.0 + 1e-12) {
                floor_abs = floor_abs.max(v - measured_lo[k]);
            } else {
                max_rel = max_rel.max((e / v).abs());
                sum_rel += (e / v).abs();
                n_rel += 1;
            }
        }
        Self {
            above_floor: n_rel,
            floor_abs,
            max_rel,
            mean_rel: if n_rel > 0 {
                sum_rel / n_rel as f64
            } else {
                0.0
            },
            // Of the product with the lobe (the engine's RMSE is of the ratio).
            rmse: (sq / used.len().max(1) as f64).sqrt(),
            cos_rmse: if wsum > 0.0 { (wsq / wsum).sqrt() } else { 0.0 },
        }
    }
}

fn fit_channel(
    samples: &Samples,
    c: usize,
    s: &BrdfFitSettings,
) -> Result<(RationalFunction, ChannelReport), BrdfError> {
    let channel = s.mode.names()[c];
    let (data, used, bounds) = match &s.design {
        Some(design) => {
            let (d, u, b) = samples.channel_perceptual(c, design)?;
            (d, u, Some(b))
        }
        None => {
            let (d, u) = samples
                .channel(c, s.rel_tol, s.noise_floor)
                .map_err(|e| BrdfError::Fit { channel, source: e })?;
            (d, u, None)
        }
    };
    let rel_tol = s.design.map_or(s.rel_tol, |d| d.rel_tol);
    let fit_err = |e| BrdfError::Fit { channel, source: e };
    // With a lobe the functions fit data / lobe in the intervals divided by it.
    let factors: Vec<f64> = match &s.lobe {
        Some(lobe) => used
            .iter()
            .map(|&i| lobe.factors_at(samples.rows[i].angles, s.mode)[c])
            .collect(),
        None => vec![1.0; used.len()],
    };
    let measured_lo = data.lo().to_vec();
    // The cap: the design's multiple of its peak, else DEFAULT_PEAK_CAP
    // times the largest upper bound (the peak and its interval).
    let cap = match (&s.design, &bounds) {
        (Some(design), Some(b)) => design.peak_cap * b.peak,
        _ => DEFAULT_PEAK_CAP * data.hi().iter().fold(0.0_f64, |m, &v| m.max(v)),
    };
    let data = if s.lobe.is_some() {
        divided_by(&data, &factors).map_err(fit_err)?
    } else {
        data
    };
    let report = fit(&data, &s.fit).map_err(fit_err)?;
    let (report, cap_check) = if cap > 0.0 && cap.is_finite() {
        let (r, k) = hold_below_cap(report, &data, s, c, cap).map_err(fit_err)?;
        (r, Some(k))
    } else {
        (report, None)
    };
    let f = report.function.clone();
    let errors = SampleErrors::of(samples, c, &used, rel_tol, &measured_lo, |k| {
        f.eval(data.point(k)) * factors[k]
    });
    let rep = ChannelReport {
        channel,
        n_p: report.n_p,
        n_q: report.n_q,
        bytes_f32: f.byte_size_f32(),
        verified: report.verification.satisfied,
        depth: report.depth,
        samples: data.len(),
        samples_above_floor: errors.above_floor,
        noise_floor_abs: errors.floor_abs,
        max_rel: errors.max_rel,
        mean_rel: errors.mean_rel,
        max_rel_all: 0.0,
        mean_rel_all: 0.0,
        rmse: errors.rmse,
        cos_rmse: errors.cos_rmse,
        seconds: report.seconds,
        interval_scale: report.interval_scale,
        bounds,
        cap: cap_check,
        // The baselines divide by the value: plain relative intervals only
        // (the fidelity benchmark compares the analytic peer by its renders).
        baselines: if s.baselines && s.design.is_none() && s.mode.is_rgb() && s.lobe.is_none() {
            vec![
                crate::baseline::polynomial(
                    &data,
                    f.basis().family(),
                    f.basis().weights(),
                    report.n_p + report.n_q,
                ),
                crate::baseline::cook_torrance(samples, &used, c),
            ]
        } else {
            Vec::new()
        },
    };
    Ok((f, rep))
}

/// The dense cap check ([`BrdfFitSettings::with_cap_rounds`]): between the
/// samples nothing bounds `p / q`, so the fit is evaluated on a grid of its
/// whole evaluation domain twice as dense as the data; the points above
/// `cap` (divided by the lobe, with one) are added to `data` as `[0, cap]`
/// and the data fitted again, at most `cap_rounds` times. When the first fit
/// needed wider intervals, the refits keep the data at that width and widen
/// nothing more (widening the cap points would lift the cap). A refit with
/// no feasible fit within the budget keeps the fit before it (the check
/// then reports the excess).
fn hold_below_cap(
    mut report: rational_core::FitReport,
    data: &IntervalData,
    s: &BrdfFitSettings,
    c: usize,
    cap: f64,
) -> Result<(rational_core::FitReport, CapCheck), rational_core::FitError> {
    let coordinates = s.reduction.coordinates;
    let cap_at = |x: &[f64]| match &s.lobe {
        Some(lobe) => cap / lobe.factors_at(coordinates.angles(x), s.mode)[c],
        None => cap,
    };
    let grid = cap_grid(data, &s.reduction);
    let mut check = CapCheck {
        cap,
        grid_points: grid.len(),
        points: 0,
        refits: 0,
        largest: 0.0,
        non_finite: 0,
    };
    // The intervals the first fit was accepted at.
    let scale = report.interval_scale;
    let accepted = (scale > 1.0).then(|| data.widened(scale));
    let mut augmented: Option<IntervalData> = None;
    loop {
        let scan = points_above_cap(&grid, &report.function, &cap_at);
        check.largest = scan.largest;
        check.non_finite = scan.non_finite;
        if scan.caps.is_empty() || check.refits == s.cap_rounds {
            break;
        }
        let so_far = augmented.as_ref().or(accepted.as_ref()).unwrap_or(data);
        let more = with_cap_points(so_far, scan.points, &scan.caps)?;
        // The added constraints only shrink the feasible set: the smallest
        // budget cannot fall, so the search starts at this one.
        let budget = report.n_p + report.n_q;
        let (_, max_coeffs) = s.fit.coeff_range();
        let warm = s
            .fit
            .clone()
            .with_coeff_range(budget.min(max_coeffs), max_coeffs)?
            .with_widening(2.0, 0)?;
        match fit(&more, &warm) {
            Ok(r) => {
                report = r;
                report.interval_scale = scale;
            }
            Err(rational_core::FitError::NoFeasibleFit { .. }) => break,
            Err(e) => return Err(e),
        }
        check.points += scan.caps.len();
        check.refits += 1;
        augmented = Some(more);
    }
    Ok((report, check))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::reduce::{ReductionKind, HORIZON_INSET_RAD};
    use std::f64::consts::PI;

    #[test]
    fn the_cap_grid_reaches_the_horizon_beyond_the_outermost_cells() {
        let reduction = Reduction::default()
            .with_kind(ReductionKind::Full3d)
            .with_resolution(8, 8)
            .with_phi_resolution(8)
            .whole_hemisphere();
        let lambert = crate::Lambert {
            albedo: [0.5, 0.5, 0.5],
        };
        let samples = reduction.sample(&lambert);
        let (data, _) = samples.channel(0, 0.1, 1e-2).unwrap();
        let grid = cap_grid(&data, &reduction);
        let angles: Vec<[f64; 3]> = grid
            .iter()
            .map(|x| reduction.coordinates.angles(x))
            .collect();
        // The cells' centres stop half a bin short of each end; the grid
        // goes to the ends (theta_d to the inset horizon, phi_d to 0 and pi).
        let max_theta_d = angles.iter().map(|a| a[1]).fold(0.0, f64::max);
        assert!((max_theta_d - (PI / 2.0 - HORIZON_INSET_RAD)).abs() < 1e-12);
        assert!(angles.iter().any(|a| a[0] == 0.0 && a[2] == 0.0));
        assert!(angles.iter().any(|a| (a[2] - PI).abs() < 1e-12));
        // Only pairs above the horizon.
        for a in &angles {
            let (wi, wo) = HalfDiff {
                theta_h: a[0],
                phi_h: 0.0,
                theta_d: a[1],
                phi_d: a[2],
            }
            .to_directions();
            assert!(wi[2] > 0.0 && wo[2] > 0.0, "{a:?}");
        }
        // 16 points per axis (twice the data's 8), less those below the horizon.
        assert!(grid.len() < 16 * 16 * 16 && grid.len() > 16 * 16 * 16 / 3);
    }

    #[test]
    fn the_cap_grid_of_a_cut_slice_stays_within_the_cut_and_reaches_it() {
        let reduction = Reduction::default().with_resolution(20, 20);
        let samples = reduction.sample(&crate::Lambert {
            albedo: [0.5, 0.5, 0.5],
        });
        let (data, _) = samples.channel(0, 0.1, 1e-2).unwrap();
        let grid = cap_grid(&data, &reduction);
        let cut = reduction.max_elevation_deg;
        let elevations: Vec<f64> = grid
            .iter()
            .map(|x| crate::design::max_elevation_deg(reduction.coordinates.angles(x)))
            .collect();
        assert!(
            elevations.iter().all(|&e| e <= cut + 1e-6),
            "beyond the cut"
        );
        // Every line of theta_h below the cut ends on it: 40 lines (twice
        // the data's 20), less those at or beyond 70 degrees.
        let on_cut = elevations
            .iter()
            .filter(|&&e| (e - cut).abs() < 1e-6)
            .count();
        assert!(on_cut >= 30, "{on_cut} points on the cut");
    }

    #[test]
    fn points_above_cap_keep_the_largest_excesses_and_report_the_largest_ratio() {
        // p(x) = 5 + 5 T1(x / 5 - 1) = x on [0, 10], q = 1.
        let domain = rational_core::Domain::new(vec![0.0], vec![10.0]).unwrap();
        let basis =
            rational_core::Basis::new(rational_core::BasisFamily::Chebyshev, domain, 2).unwrap();
        let f = RationalFunction::new(basis, vec![5.0, 5.0], vec![1.0]).unwrap();
        let grid: Vec<Vec<f64>> = (0..10).map(|i| vec![i as f64]).collect();
        let scan = points_above_cap(&grid, &f, &|_| 4.0);
        // f(x) = x exceeds 4.04 at x = 5..9; the largest ratio is 9 / 4.
        assert_eq!(scan.points, vec![9.0, 8.0, 7.0, 6.0, 5.0]);
        assert_eq!(scan.caps, vec![4.0; 5]);
        assert!((scan.largest - 2.25).abs() < 1e-12);
        assert_eq!(scan.non_finite, 0);
    }
}
