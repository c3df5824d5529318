//! What a BRDF fit reports: per channel, error next to cost.

use crate::baseline::BaselineReport;
use crate::cap::CapCheck;
use crate::design::{ChannelBounds, PerceptualBounds};
use crate::lobe::Lobe;
use crate::reduce::Reduction;
use crate::value_scale::ValueScale;
use rational_core::RationalFunction;
use serde::{Deserialize, Serialize};
use std::fmt;

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
    /// The function is its split's least-squares fit within the intervals,
    /// not the largest-margin point (`FitSettings::with_centred_fit`).
    #[serde(default)]
    pub centred: bool,
    /// When centred, the same split at its point of largest margin
    /// (verified, and as far within the cap check as the returned
    /// function), for [`crate::FittedBrdf::at_largest_margin`]. Not
    /// written: a report read back has none.
    #[serde(skip)]
    pub largest_margin: Option<RationalFunction>,
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

/// The report of [`crate::fit_brdf`].
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
    /// What the functions' values stand for ([`ValueScale`]).
    #[serde(default, skip_serializing_if = "ValueScale::is_linear")]
    pub scale: ValueScale,
    /// The fit's ceiling on its RGB values ([`crate::FittedBrdf::ceiling`]).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ceiling: Option<[f64; 3]>,
    /// Per channel.
    pub channels: Vec<ChannelReport>,
    /// Total wall time, sampling included.
    pub seconds: f64,
}

impl BrdfFitReport {
    /// The lines that say what the functions are beyond their intervals:
    /// the ceiling, the lobe, the scale and the basis order.
    fn write_representation(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if let Some(c) = self.ceiling {
            let raised = if self.design.is_some() {
                "raised to its cap where higher; measured values beyond 80 degrees are not trusted and do not raise it"
            } else {
                "raised to its cap or its largest value where higher"
            };
            writeln!(
                f,
                "  RGB values held at or below {:.4e}, {:.4e}, {:.4e}: {}x each channel's measured peak within 80 degrees ({raised})",
                c[0],
                c[1],
                c[2],
                crate::CEILING_OVER_PEAK
            )?;
        }
        if let Some(l) = &self.lobe {
            writeln!(
                f,
                "  lobe times rational: the functions fit the table divided by Cook-Torrance GGX (kd {:.4?}, f0 {:.4?}, alpha {:.4}); errors below are of the product",
                l.kd, l.f0, l.alpha
            )?;
        }
        if !self.scale.is_linear() {
            writeln!(
                f,
                "  log scale ({}): {} the logarithm of its value, exp(p / q), fitted to the logarithms of its intervals; errors below are of the value",
                self.scale,
                match self.scale {
                    ValueScale::LogLight => "each function that carries light (each channel, or the luminance; chroma ratios stay linear) is",
                    _ => "each function is",
                }
            )?;
        }
        if !self.degree_weights.is_empty() {
            let w: Vec<String> = self.degree_weights.iter().map(u16::to_string).collect();
            writeln!(f, "  basis order: degree weights {}", w.join(","))?;
        }
        Ok(())
    }
}

impl fmt::Display for BrdfFitReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let r = &self.reduction;
        writeln!(
            f,
            "{}: {}, theta_d <= {} deg, intervals +-{}% (noise floor {:e} of the median)",
            self.material,
            r.label(),
            r.max_theta_d_deg,
            self.rel_tol * 100.0,
            self.noise_floor
        )?;
        if let Some(d) = &self.design {
            writeln!(
                f,
                "  perceptual intervals: +-{}% where visible, floor {}% of the median of f cos_i cos_o (within 70 degrees){}, >= {} noise deviations, capped at {}x the peak; every cell of the hemisphere",
                d.rel_tol * 100.0,
                d.visibility * 100.0,
                match d.light_floor_per_tol {
                    Some(k) => format!(" ({:.3}% for the light: at most {k:.4} of the tolerance)", d.light_floor() * 100.0),
                    None => String::new(),
                },
                d.noise_factor,
                d.peak_cap
            )?;
            for c in &self.channels {
                if let Some(b) = &c.bounds {
                    writeln!(
                        f,
                        "  {}   +-{:.2}% where visible, floor {:.3}%, peak {:.4e}, noise {:.2}% (estimated), cells bound by perception / floor / noise: {} / {} / {}",
                        c.channel, b.rel_tol * 100.0, b.visibility * 100.0, b.peak, b.noise * 100.0, b.perceptual_cells, b.floor_cells, b.noise_cells,
                    )?;
                }
            }
        }
        for c in &self.channels {
            if let Some(k) = &c.cap {
                writeln!(f, "  {}   {k}", c.channel)?;
            }
        }
        self.write_representation(f)?;
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
        let centred: String = self
            .channels
            .iter()
            .filter(|c| c.centred)
            .map(|c| c.channel)
            .collect();
        if !centred.is_empty() {
            writeln!(
                f,
                "  least squares within the intervals (not the largest margin): {centred}"
            )?;
        }
        for c in self.channels.iter().filter(|c| c.interval_scale > 1.0) {
            writeln!(
                f,
                "  {}   no fit within the budget at the requested intervals; fitted with every interval widened x{} (on a log scale)",
                c.channel,
                scale_text(c.interval_scale)
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

/// A widening factor with at most three decimals and no trailing zeros
/// (`2`, `1.414`).
pub fn scale_text(scale: f64) -> String {
    let text = format!("{scale:.3}");
    text.trim_end_matches('0').trim_end_matches('.').to_string()
}
