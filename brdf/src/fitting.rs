//! Fitting the RGB channels of a BRDF and evaluating the fit. The
//! settings are in `fit_settings.rs`.

use crate::cap::hold_below_cap;
use crate::colour::ColourMode;
use crate::design::DEFAULT_PEAK_CAP;
use crate::fit_report::{BrdfFitReport, ChannelReport};
use crate::fit_settings::{BrdfFitSettings, ChannelProgress};
use crate::fitted::{FittedBrdf, CEILING_OVER_PEAK};
use crate::geometry::HalfDiff;
use crate::no_fit::NoFitMemo;
use crate::reduce::Samples;
use crate::value_scale::ValueScale;
use crate::{Brdf, BrdfError};
use rational_core::{FitSettings, Fitter, IntervalData, RationalFunction, SharedDesign};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Instant;

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

/// Fits already sampled data (a grid from [`crate::Reduction::sample`] or scattered
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

/// The engine of channel `c`: the settings' own, with the channel's
/// progress callback and the design the channels share, if any.
fn channel_engine(
    s: &BrdfFitSettings,
    c: usize,
    design: Option<&SharedDesign>,
) -> rational_core::FitSettings {
    let engine = match &s.channel_progress {
        Some(ChannelProgress(cb)) => {
            let cb = cb.clone();
            s.fit.clone().with_progress(Arc::new(move |p| cb(c, p)))
        }
        None => s.fit.clone(),
    };
    match design {
        Some(d) => engine.with_shared_design(d.clone()),
        None => engine,
    }
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
    let engine = channel_engine(s, c, design);
    let report = sweep_sharing_proofs(&data, &engine, s.no_fit.as_ref()).map_err(fit_err)?;
    let (report, cap_check) = if cap > 0.0 && cap.is_finite() {
        let (r, k) = hold_below_cap(report, &data, s, c, cap).map_err(fit_err)?;
        (r, Some(k))
    } else {
        (report, None)
    };
    let largest_margin =
        crate::cap::largest_margin_as_capped(&report, &data, s, c, cap_check.as_ref());
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
        centred: report.centred,
        largest_margin,
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
