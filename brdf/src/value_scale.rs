//! The scale a fit's functions are fitted on: the values themselves, or
//! their logarithms.
//!
//! A measured lobe spans orders of magnitude within a few degrees, which a
//! ratio of polynomials follows only with many coefficients; its logarithm
//! is a smooth bump (a Gaussian or Beckmann lobe is a low-degree function
//! of `theta_h` in log scale). On the log scale a function `r` stands for
//! `exp(r)`, and an interval `[lo, hi]` with `lo > 0` becomes
//! `[ln lo, ln hi]`: `exp` is increasing, so `exp(r)` lies in the
//! measured interval exactly where `r` lies in the logarithmic one, and
//! the verification of `r` is the verification of the fit.
//!
//! The log scale applies to every function ([`ValueScale::Log`]) or to
//! those that carry the light alone (each RGB channel, or the luminance;
//! [`ValueScale::LogLight`]): chroma ratios that vary slowly about a
//! constant gain nothing from it, and `exp` turns a small overshoot between
//! samples of a loosely bounded ratio into a large factor on the colour,
//! while the ratios of a coloured highlight span a range as the
//! luminance does.

use crate::colour::ColourMode;
use crate::BrdfError;
use rational_core::IntervalData;
use serde::{Deserialize, Serialize};

/// On the log scale, how far below an interval's upper end its lower end
/// may lie, as a factor: an interval whose lower end is at or below zero
/// (or below `hi / LOG_SPAN`) gets the lower end `hi / LOG_SPAN`, so the
/// interval is never looser than the one measured, and the value it allows
/// at its bottom, a millionth of the top, is black in any render.
pub const LOG_SPAN: f64 = 1e6;

/// The largest exponent a log-scale function's value is taken at:
/// `exp(80)` (5.5e34) is finite in f32, far above any reflectance (the
/// fit's ceiling then holds the RGB value), and keeps an exploding
/// function between samples from making an infinite luminance, whose
/// product with a zero chroma ratio would be NaN.
pub const LOG_EXPONENT_LIMIT: f64 = 80.0;

/// What a fitted function's value stands for.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum ValueScale {
    /// The function is the value (luminance, ratio or channel).
    #[default]
    Linear,
    /// Every function is its value's natural logarithm: the value is
    /// `exp(r)`, positive everywhere.
    Log,
    /// The functions that carry the light (each RGB channel, or the
    /// luminance) are on the log scale, the chroma ratios linear.
    LogLight,
}

impl ValueScale {
    /// Whether this is [`ValueScale::Linear`] (serialisation skips the
    /// default, so linear fit files are as before).
    pub fn is_linear(&self) -> bool {
        *self == ValueScale::Linear
    }

    /// What a description of a fit adds for its scale: `" log"` or
    /// `" log-light"`, nothing for linear (the scale a fit has unless it
    /// says otherwise).
    pub fn suffix(self) -> String {
        if self.is_linear() {
            String::new()
        } else {
            format!(" {self}")
        }
    }

    /// The scale of function `c` of a fit in colour `mode`: linear or
    /// log.
    pub fn of(self, mode: ColourMode, c: usize) -> ValueScale {
        match self {
            ValueScale::LogLight if mode.carries_light(c) => ValueScale::Log,
            ValueScale::LogLight => ValueScale::Linear,
            other => other,
        }
    }

    /// The value a function's output `r` stands for on this scale.
    pub fn value(self, r: f64) -> f64 {
        match self {
            ValueScale::Linear => r,
            ValueScale::Log | ValueScale::LogLight => r.min(LOG_EXPONENT_LIMIT).exp(),
        }
    }

    /// [`ValueScale::value`] in f32, as the shaders compute it.
    pub fn value_f32(self, r: f32) -> f32 {
        match self {
            ValueScale::Linear => r,
            ValueScale::Log | ValueScale::LogLight => r.min(LOG_EXPONENT_LIMIT as f32).exp(),
        }
    }

    /// The values of a fit's three functions in colour `mode`
    /// ([`ValueScale::of`] each).
    pub fn values(self, mode: ColourMode, v: [f64; 3]) -> [f64; 3] {
        [0, 1, 2].map(|c| self.of(mode, c).value(v[c]))
    }

    /// [`ValueScale::values`] in f32.
    pub fn values_f32(self, mode: ColourMode, v: [f32; 3]) -> [f32; 3] {
        [0, 1, 2].map(|c| self.of(mode, c).value_f32(v[c]))
    }

    /// The interval on this scale whose values lie in `[lo, hi]`: on the
    /// log scale `[ln max(lo, hi / LOG_SPAN), ln hi]`. `None` where no
    /// positive value lies in the interval (`hi <= 0`), which the log
    /// scale cannot represent.
    pub fn interval(self, lo: f64, hi: f64) -> Option<(f64, f64)> {
        match self {
            ValueScale::Linear => Some((lo, hi)),
            _ if hi > 0.0 => {
                let floor = hi / LOG_SPAN;
                Some((lo.max(floor).ln(), hi.ln()))
            }
            _ => None,
        }
    }

    /// `data` on this scale ([`ValueScale::interval`] of every interval,
    /// each value moved into its interval and mapped alike).
    ///
    /// # Errors
    /// On the log scale, an interval with no positive value (named by its
    /// index and bounds).
    pub fn data(self, data: &IntervalData) -> Result<IntervalData, BrdfError> {
        let bad = |reason: String| BrdfError::Invalid {
            name: "log-scale intervals",
            reason,
        };
        if self.is_linear() {
            return Ok(data.clone());
        }
        let n = data.len();
        let (mut lo, mut hi, mut values) = (
            Vec::with_capacity(n),
            Vec::with_capacity(n),
            Vec::with_capacity(n),
        );
        for i in 0..n {
            let (l, h) = (data.lo()[i], data.hi()[i]);
            let (a, b) = self.interval(l, h).ok_or_else(|| {
                bad(format!(
                    "sample {i}: the interval [{l:e}, {h:e}] holds no positive value, \
                     which a fit on the log scale cannot reach"
                ))
            })?;
            let v = data.value(i);
            let v = if v > 0.0 { v.ln() } else { a };
            lo.push(a);
            hi.push(b);
            values.push(v.clamp(a, b));
        }
        IntervalData::new(data.dim(), data.points().to_vec(), lo, hi)
            .and_then(|d| d.with_values(values))
            .map_err(|e| bad(e.to_string()))
    }
}

impl std::fmt::Display for ValueScale {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            ValueScale::Linear => "linear",
            ValueScale::Log => "log",
            ValueScale::LogLight => "log-light",
        })
    }
}

impl std::str::FromStr for ValueScale {
    type Err = BrdfError;
    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "linear" => Ok(ValueScale::Linear),
            "log" => Ok(ValueScale::Log),
            "log-light" | "log_light" => Ok(ValueScale::LogLight),
            other => Err(BrdfError::Invalid {
                name: "value scale",
                reason: format!("unknown scale `{other}` (linear, log, log-light)"),
            }),
        }
    }
}

#[cfg(test)]
// The values are the same computations as the expected ones, bit for bit.
#[allow(clippy::float_cmp)]
mod tests {
    use super::*;

    #[test]
    fn a_log_interval_holds_exactly_the_values_of_the_measured_one() {
        let s = ValueScale::Log;
        let (a, b) = s.interval(0.5, 2.0).unwrap();
        assert_eq!((a, b), (0.5f64.ln(), 2.0f64.ln()));
        // Inside maps inside, outside outside, at both ends.
        for (v, inside) in [(0.49, false), (0.51, true), (1.99, true), (2.01, false)] {
            let r = f64::ln(v);
            assert_eq!(r >= a && r <= b, inside, "{v}");
            assert!((s.value(r) - v).abs() < 1e-15);
        }
        // A lower end at or below zero becomes a millionth of the top: never
        // looser than the measured interval.
        let (a, b) = s.interval(-1.0, 3.0).unwrap();
        assert!((s.value(a) - 3e-6).abs() < 1e-18 && s.value(a) > -1.0);
        assert!((s.value(b) - 3.0).abs() < 1e-14);
        assert_eq!(s.interval(-1.0, 0.0), None);
        assert_eq!(ValueScale::Linear.interval(-1.0, 0.0), Some((-1.0, 0.0)));
        // An exploding function stays finite in both precisions.
        assert!(s.value(1e6).is_finite() && s.value_f32(1e6).is_finite());
        assert_eq!(s.value(1e6), LOG_EXPONENT_LIMIT.exp());
    }

    #[test]
    fn log_light_takes_the_functions_that_carry_light_and_leaves_ratios_linear() {
        let lc = ColourMode::LuminanceChroma;
        let v = ValueScale::LogLight.values(lc, [0.0, 0.5, 2.0]);
        assert_eq!(v, [1.0, 0.5, 2.0]);
        assert_eq!(
            ValueScale::LogLight.values_f32(lc, [0.0, 0.5, 2.0]),
            [1.0, 0.5, 2.0]
        );
        let all = [1.0, 0.5f64.exp(), 2f64.exp()];
        assert_eq!(ValueScale::Log.values(lc, [0.0, 0.5, 2.0]), all);
        for scale in [ValueScale::Log, ValueScale::LogLight] {
            let v = scale.values(ColourMode::Rgb, [0.0, 1.0, -1.0]);
            assert_eq!(v, [1.0, 1f64.exp(), (-1f64).exp()]);
            assert_eq!(scale.to_string().parse::<ValueScale>().unwrap(), scale);
        }
        assert_eq!(
            ValueScale::Linear.values(ColourMode::Rgb, [0.0, 1.0, -1.0]),
            [0.0, 1.0, -1.0]
        );
        let e = "exp".parse::<ValueScale>().unwrap_err().to_string();
        assert!(e.contains("exp") && e.contains("log-light"), "{e}");
    }

    #[test]
    fn a_description_names_every_scale_but_linear() {
        assert_eq!(ValueScale::Linear.suffix(), "");
        assert_eq!(ValueScale::Log.suffix(), " log");
        assert_eq!(ValueScale::LogLight.suffix(), " log-light");
    }

    #[test]
    fn data_on_the_log_scale_keep_points_and_name_an_interval_without_positive_values() {
        let d = IntervalData::new(1, vec![0.0, 1.0], vec![0.9, -0.1], vec![1.1, 0.2])
            .unwrap()
            .with_values(vec![1.0, -0.05])
            .unwrap();
        let l = ValueScale::Log.data(&d).unwrap();
        assert_eq!(l.points(), d.points());
        assert_eq!(l.lo()[0], 0.9f64.ln());
        assert_eq!(l.hi()[1], 0.2f64.ln());
        assert_eq!(l.value(0), 0.0);
        // A non-positive value sits at its interval's lower end.
        assert_eq!(l.value(1), l.lo()[1]);
        let bad = IntervalData::new(1, vec![0.0], vec![-1.0], vec![0.0]).unwrap();
        let e = ValueScale::Log.data(&bad).unwrap_err().to_string();
        assert!(e.contains("sample 0") && e.contains("positive"), "{e}");
        assert_eq!(ValueScale::Linear.data(&d).unwrap(), d);
    }
}
