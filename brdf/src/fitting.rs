//! Fitting the RGB channels of a BRDF and evaluating the fit.

use crate::cap::hold_below_cap;
use crate::colour::ColourMode;
use crate::design::{PerceptualBounds, DEFAULT_PEAK_CAP};
use crate::fit_report::{BrdfFitReport, ChannelReport};
use crate::fitted::{FittedBrdf, CEILING_OVER_PEAK};
use crate::geometry::HalfDiff;
use crate::lobe::Lobe;
use crate::no_fit::NoFitMemo;
use crate::reduce::{Reduction, Samples};
use crate::value_scale::ValueScale;
use crate::{Brdf, BrdfError};
use rational_core::{FitSettings, Fitter, IntervalData, Progress, RationalFunction, SharedDesign};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
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
    scale: ValueScale,
    lobe: Option<Lobe>,
    cap_rounds: usize,
    channel_progress: Option<ChannelProgress>,
    no_fit: Option<NoFitMemo>,
}

/// Callback receiving each channel's sweep progress: the channel (0, 1 or 2
/// of the colour mode) and the engine's [`Progress`]; called from worker
/// threads.
pub type ChannelProgressFn = Arc<dyn Fn(usize, Progress) + Send + Sync>;

/// A [`ChannelProgressFn`] that settings can hold and print.
#[derive(Clone)]
struct ChannelProgress(ChannelProgressFn);

impl std::fmt::Debug for ChannelProgress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("ChannelProgress")
    }
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
            scale: ValueScale::Linear,
            lobe: None,
            cap_rounds: 2,
            channel_progress: None,
            no_fit: None,
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

    /// Reports each channel's sweep as it goes (the channels run in
    /// parallel, so one callback sees all three).
    pub fn with_channel_progress(mut self, f: ChannelProgressFn) -> Self {
        self.channel_progress = Some(ChannelProgress(f));
        self
    }

    /// The callback of [`BrdfFitSettings::with_channel_progress`], if any
    /// (to chain another after it).
    pub fn channel_progress(&self) -> Option<ChannelProgressFn> {
        self.channel_progress.as_ref().map(|p| p.0.clone())
    }

    /// Shares proofs of no fit between the fits of one search
    /// ([`NoFitMemo`]): use one memo only for fits whose settings differ in
    /// their intervals (the tolerance) and coefficient budgets alone.
    pub fn with_no_fit_memo(mut self, memo: NoFitMemo) -> Self {
        self.no_fit = Some(memo);
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

    /// Fit each function on `scale` (default linear): on the log scale a
    /// function is the logarithm of its value and fits the logarithms of
    /// the intervals, the same bounds on the value ([`ValueScale`]).
    pub fn with_value_scale(mut self, scale: ValueScale) -> Self {
        self.scale = scale;
        self
    }

    /// What the functions' values stand for ([`ValueScale`]).
    pub fn value_scale(&self) -> ValueScale {
        self.scale
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

/// Samples `material`, fits each RGB channel (in parallel) with the sweep,
/// and reports error next to cost.
///
/// # Errors
/// Invalid settings, no positive samples, or no feasible fit for a channel:
/// the first function of the colour mode's order that fails, whose failure
/// stops the sweeps of the functions after it (their results would be
/// dropped) and turns those before it to settling only whether they have a
/// fit (`rational_core::FitSettings::with_existence_only`): the error is
/// the one a fit of each function in turn would give.
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
    let peaks = measured_peaks(samples);
    let derived = in_fitted_mode(samples, settings)?;
    let samples = derived.as_ref().unwrap_or(samples);
    // The channels are fitted at the same directions: one design serves all.
    let design = SharedDesign::new();
    // The first channel in order that fails is the fit's error, so a
    // failure stops the channels after it (at their next split): their
    // results would be dropped. Those before it need only settle whether
    // they fail too (and would be the error named), not find their fits.
    let flags = || -> Vec<Arc<AtomicBool>> { (0..3).map(|_| Arc::default()).collect() };
    let (stops, settles) = (flags(), flags());
    let results: Vec<Result<(RationalFunction, ChannelReport), BrdfError>> = (0..3)
        .into_par_iter()
        .map(|c| {
            let engine = settings
                .fit
                .clone()
                .with_cancel(stops[c].clone())
                .with_existence_only(settles[c].clone());
            let own = settings.clone().with_fit_settings(engine);
            let result = fit_channel(samples, c, &own, Some(&design));
            if result.as_ref().is_err_and(|e| !fit_exists(e)) {
                let set = |f: &Arc<AtomicBool>| f.store(true, Ordering::Relaxed);
                stops[c + 1..].iter().for_each(set);
                settles[..c].iter().for_each(set);
            }
            result
        })
        .collect();
    // A channel that settled only that it has a fit did so because one
    // after it failed: that failure (or an earlier one) is the error.
    let parts = results
        .into_iter()
        .filter(|r| !r.as_ref().is_err_and(fit_exists))
        .collect::<Result<Vec<_>, _>>()?;
    if parts.len() < 3 {
        return Err(BrdfError::Invalid {
            name: "channel fits",
            reason: "a channel stopped with no failing channel after it".into(),
        });
    }
    let (fitted, mut report) = assemble(samples, peaks, name, settings, parts);
    report.seconds = start.elapsed().as_secs_f64();
    Ok((fitted, report))
}

/// Whether `e` says only that a channel has a fit
/// (`rational_core::FitSettings::with_existence_only`).
fn fit_exists(e: &BrdfError) -> bool {
    matches!(
        e,
        BrdfError::Fit {
            source: rational_core::FitError::FitExists { .. },
            ..
        }
    )
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
    fit_channel(derived.as_ref().unwrap_or(samples), channel, settings, None)
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
    let (fitted, mut report) = assemble(
        derived.as_ref().unwrap_or(samples),
        measured_peaks(samples),
        name,
        settings,
        parts,
    );
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

/// The measured RGB peaks of each channel (values and the upper ends of
/// spread cells): within 80 degrees of the normal, where measured tables are
/// trusted (they divide by a vanishing cosine at the horizon), and
/// anywhere.
#[derive(Debug, Clone, Copy)]
struct Peaks {
    trusted: [f64; 3],
    anywhere: [f64; 3],
}

fn measured_peaks(samples: &Samples) -> Peaks {
    let cos_80 = 80f64.to_radians().cos();
    let mut p = Peaks {
        trusted: [0.0; 3],
        anywhere: [0.0; 3],
    };
    for r in &samples.rows {
        let (wi, wo) = HalfDiff::pair_at(r.angles);
        let trusted = wi[2].min(wo[2]) > cos_80;
        for c in 0..3 {
            for v in [r.value[c], r.hi[c]].into_iter().filter(|v| v.is_finite()) {
                p.anywhere[c] = p.anywhere[c].max(v);
                if trusted {
                    p.trusted[c] = p.trusted[c].max(v);
                }
            }
        }
    }
    p
}

/// The fit's ceiling: [`CEILING_OVER_PEAK`] times each channel's trusted
/// peak, raised, with plain intervals, to the largest measured value
/// anywhere (so that at a sample the ceiling only brings an overshooting
/// value nearer its measurement, and a value inside its interval stays
/// inside; perceptual intervals beyond 80 degrees start at zero, so a value
/// inside stays inside without it) and, in RGB mode, to the
/// channel's cap (so that it never holds a fit below the cap check's own
/// limit). None when a channel has no positive value.
fn ceiling(
    peaks: Peaks,
    settings: &BrdfFitSettings,
    reports: &[ChannelReport],
) -> Option<[f64; 3]> {
    if !peaks.anywhere.iter().all(|p| p.is_finite() && *p > 0.0) {
        return None;
    }
    Some([0, 1, 2].map(|c| {
        let cap = match settings.mode {
            ColourMode::Rgb => reports[c].cap.as_ref().map_or(0.0, |k| k.cap),
            _ => 0.0,
        };
        // Under the perceptual design a cell beyond 80 degrees has the
        // interval [0, cap]: a measured value there lies outside what the
        // fit is held to, and raising the ceiling to it only lets the
        // untrusted grazing values brighten the rim.
        let measured = match settings.design {
            Some(_) => peaks.trusted[c],
            None => peaks.anywhere[c],
        };
        (CEILING_OVER_PEAK * peaks.trusted[c])
            .max(measured)
            .max(cap)
    }))
}

/// The fit and its report from three fitted channels, with the errors over
/// every sample (`samples` in the settings' colour mode; `peaks` the
/// measured RGB peaks).
fn assemble(
    samples: &Samples,
    peaks: Peaks,
    name: &str,
    settings: &BrdfFitSettings,
    parts: Vec<(RationalFunction, ChannelReport)>,
) -> (FittedBrdf, BrdfFitReport) {
    let (channels, mut reports): (Vec<_>, Vec<_>) = parts.into_iter().unzip();
    let fitted = FittedBrdf {
        reduction: settings.reduction.as_fitted(),
        channels,
        mode: settings.mode,
        scale: settings.scale,
        lobe: settings.lobe,
        ceiling: ceiling(peaks, settings, &reports),
        shell: None,
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
            let x = r.point(th, td.min(r.max_theta_d_deg.to_radians()), pd);
            // Each function against its own data (luminance or a ratio in
            // the luminance-chroma mode).
            let lobe = settings
                .lobe
                .map_or(1.0, |l| l.factors_at(row.angles, settings.mode)[c]);
            let value = settings
                .scale
                .of(settings.mode, c)
                .value(fitted.channels[c].eval(&x));
            let e = ((value * lobe).max(0.0) / row.value[c] - 1.0).abs();
            max = max.max(e);
            sum += e;
            n += 1;
        }
        rep.max_rel_all = max;
        rep.mean_rel_all = if n > 0 { sum / n as f64 } else { 0.0 };
    }
    let report = BrdfFitReport {
        material: name.to_string(),
        reduction: settings.reduction.as_fitted(),
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
        scale: settings.scale,
        ceiling: fitted.ceiling,
        channels: reports,
        seconds: 0.0,
    };
    (fitted, report)
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

/// The sweep of `data`, skipping what `memo`'s proofs cover and adding what
/// it proves to them.
fn sweep_sharing_proofs(
    data: &IntervalData,
    engine: &FitSettings,
    memo: Option<&NoFitMemo>,
) -> Result<rational_core::FitReport, rational_core::FitError> {
    let proofs = memo.map(NoFitMemo::proofs).unwrap_or_default();
    let result = Fitter::new(data)
        .settings(engine.clone())
        .no_fit_proofs(&proofs)
        .fit();
    if let Some(memo) = memo {
        memo.record(data, engine, &result);
    }
    result
}

/// Channel `c`'s interval data under `s` (the perceptual design, its
/// half-width scaled for a chroma ratio, or plain relative intervals), the
/// sample rows used, and what the design used.
#[allow(clippy::type_complexity)]
fn channel_intervals(
    samples: &Samples,
    c: usize,
    s: &BrdfFitSettings,
) -> Result<
    (
        IntervalData,
        Vec<usize>,
        Option<crate::design::ChannelBounds>,
    ),
    BrdfError,
> {
    let channel = s.mode.names()[c];
    Ok(match &s.design {
        Some(design) => {
            // The chroma ratios get the half-width whose colour difference
            // matches the luminance's at the material's typical colour.
            let factor = s.mode.perceptual_factors(samples.typical_colour(s.mode))[c];
            let design = design.with_rel_tol(design.rel_tol * factor)?;
            let design = if s.mode.carries_light(c) {
                design.for_light()
            } else {
                design
            };
            let (d, u, b) = samples.channel_perceptual(c, &design)?;
            (d, u, Some(b))
        }
        None => {
            let (d, u) = samples
                .channel(c, s.rel_tol, s.noise_floor)
                .map_err(|e| BrdfError::Fit { channel, source: e })?;
            (d, u, None)
        }
    })
}

/// `data` on `scale` ([`ValueScale::data`]), an error naming the function.
fn on_scale(
    scale: ValueScale,
    data: &IntervalData,
    channel: char,
) -> Result<IntervalData, BrdfError> {
    scale.data(data).map_err(|e| match e {
        BrdfError::Invalid { name, reason } => BrdfError::Invalid {
            name,
            reason: format!("function {channel}, {reason}"),
        },
        other => other,
    })
}

fn fit_channel(
    samples: &Samples,
    c: usize,
    s: &BrdfFitSettings,
    design: Option<&SharedDesign>,
) -> Result<(RationalFunction, ChannelReport), BrdfError> {
    let channel = s.mode.names()[c];
    let (data, used, bounds) = channel_intervals(samples, c, s)?;
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
    // On the log scale the function fits the logarithms of the intervals.
    let scale = s.scale.of(s.mode, c);
    let data = on_scale(scale, &data, channel)?;
    let engine = match &s.channel_progress {
        Some(ChannelProgress(cb)) => {
            let cb = cb.clone();
            s.fit.clone().with_progress(Arc::new(move |p| cb(c, p)))
        }
        None => s.fit.clone(),
    };
    let engine = match design {
        Some(d) => engine.with_shared_design(d.clone()),
        None => engine,
    };
    let report = sweep_sharing_proofs(&data, &engine, s.no_fit.as_ref()).map_err(fit_err)?;
    let (report, cap_check) = if cap > 0.0 && cap.is_finite() {
        let (r, k) = hold_below_cap(report, &data, s, c, cap).map_err(fit_err)?;
        (r, Some(k))
    } else {
        (report, None)
    };
    let f = report.function.clone();
    let errors = SampleErrors::of(samples, c, &used, rel_tol, &measured_lo, |k| {
        scale.value(f.eval(data.point(k))) * factors[k]
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
        baselines: if s.baselines
            && s.design.is_none()
            && s.mode.is_rgb()
            && s.lobe.is_none()
            && s.scale.is_linear()
        {
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
