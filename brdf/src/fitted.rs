//! A fitted BRDF: the three rational functions, what they were fitted to,
//! and their evaluation.

use crate::colour::ColourMode;
use crate::geometry::{HalfDiff, Vec3};
use crate::lobe::Lobe;
use crate::reduce::Reduction;
use crate::shell::ShellFactor;
use crate::value_scale::ValueScale;
use crate::BrdfFitReport;
use crate::{Brdf, BrdfError};
use rational_core::RationalFunction;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

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
    /// What each function's value stands for: the value itself, or its
    /// logarithm ([`ValueScale`]).
    #[serde(default, skip_serializing_if = "ValueScale::is_linear")]
    pub scale: ValueScale,
    /// The analytic lobe each function multiplies (the lobe-times-rational
    /// representation), when there is one.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub lobe: Option<Lobe>,
    /// The largest RGB value any evaluation returns, when there is one:
    /// [`CEILING_OVER_PEAK`] times each channel's largest measured value
    /// within 80 degrees of the normal, or (plain intervals) a higher value
    /// measured beyond, or in RGB mode the cap check's cap where that is
    /// higher.
    /// Between samples nothing else bounds `p / q`: the cap check pushes the
    /// fit below its cap where a refit is feasible, and the ceiling holds
    /// where it is not, or between the check's grid points.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub ceiling: Option<[f64; 3]>,
    /// The tabulated factor beyond the elevation cut, when there is one
    /// ([`ShellFactor`]; its cut is the reduction's).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub shell: Option<ShellFactor>,
    /// Source material.
    pub name: String,
}

/// The ceiling of a fit's RGB values over the largest value measured
/// within 80 degrees of the normal in each channel: the fidelity target's
/// bound on the peak (a fit may exceed the table's peak between samples,
/// by its interval at the peak and then some, but not by more than this,
/// unless [`FittedBrdf::ceiling`] was raised).
pub const CEILING_OVER_PEAK: f64 = 2.0;

/// The serialised form of a [`FittedBrdf`], checked on the way in.
#[derive(Deserialize)]
struct FittedSpec {
    reduction: Reduction,
    channels: Vec<RationalFunction>,
    #[serde(default)]
    mode: ColourMode,
    #[serde(default)]
    scale: ValueScale,
    #[serde(default)]
    lobe: Option<Lobe>,
    #[serde(default)]
    ceiling: Option<[f64; 3]>,
    #[serde(default)]
    shell: Option<ShellFactor>,
    name: String,
}

impl TryFrom<FittedSpec> for FittedBrdf {
    type Error = BrdfError;
    fn try_from(s: FittedSpec) -> Result<Self, BrdfError> {
        let f = Self {
            reduction: s.reduction,
            channels: s.channels,
            mode: s.mode,
            scale: s.scale,
            lobe: s.lobe,
            ceiling: s.ceiling,
            shell: s.shell,
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
        if let Some(c) = self.ceiling {
            if !c.iter().all(|v| v.is_finite() && *v > 0.0) {
                return Err(bad(format!(
                    "ceiling {c:?}: three positive, finite values expected"
                )));
            }
        }
        if let Some(shell) = &self.shell {
            shell.validate()?;
            let cut = self.reduction.max_elevation_deg;
            if (shell.cut_deg - cut).abs() > 1e-9 {
                return Err(bad(format!(
                    "the shell factor's cut of {} degrees is not the reduction's elevation cut ({cut} degrees)",
                    shell.cut_deg
                )));
            }
        }
        Ok(())
    }

    /// The fit with `shell` applied beyond its elevation cut.
    ///
    /// # Errors
    /// As [`FittedBrdf::validate`]: the shell's cut must be the reduction's.
    pub fn with_shell(mut self, shell: ShellFactor) -> Result<Self, BrdfError> {
        self.shell = Some(shell);
        self.validate()?;
        Ok(self)
    }

    /// The same functions and bytes evaluated within `degrees` of the
    /// normal: directions beyond are moved onto the cut
    /// ([`crate::clamp_elevation`]), as for a fit made within it. `None`
    /// for a fit that already has a cut, or `degrees` outside `(0, 90)`.
    pub fn evaluated_within(&self, degrees: f64) -> Option<FittedBrdf> {
        if self.reduction.max_elevation_deg < 90.0 || !(degrees > 0.0 && degrees < 90.0) {
            return None;
        }
        let mut within = self.clone();
        within.reduction = within.reduction.with_max_elevation(degrees);
        Some(within)
    }

    /// RGB from the three functions' values: the colour mode's combination
    /// (negative values set to zero), then the ceiling.
    pub fn finish(&self, v: [f64; 3]) -> [f64; 3] {
        let rgb = self.mode.combine(v);
        match self.ceiling {
            Some(c) => [0, 1, 2].map(|k| rgb[k].min(c[k])),
            None => rgb,
        }
    }

    /// Fitting coordinates of a direction pair: `phi_d` folded by
    /// reciprocity, `theta_d` clamped to the fitted range (no extrapolation
    /// into the grazing cut).
    pub fn coordinates(&self, wi: Vec3, wo: Vec3) -> Vec<f64> {
        let [theta_h, theta_d, phi_d] = HalfDiff::isotropic_angles(wi, wo);
        let td = theta_d.min(self.reduction.max_theta_d_deg.to_radians());
        (self.reduction).point(theta_h, td, crate::geometry::fold_phi_d(phi_d))
    }

    /// Evaluates every channel in f64 and makes RGB by the colour mode;
    /// negative values (possible only between samples) are clamped to zero,
    /// and values above the ceiling to it. A fit with a lobe needs the
    /// directions: see [`Brdf::eval`].
    pub fn eval_coords(&self, x: &[f64]) -> [f64; 3] {
        self.finish(self.function_values(x))
    }

    /// The three functions' values at fitting coordinates `x`, on the
    /// linear scale (a log-scale function's `exp`), before any lobe.
    pub fn function_values(&self, x: &[f64]) -> [f64; 3] {
        let v = [0, 1, 2].map(|c| self.channels[c].eval(x));
        self.scale.values(self.mode, v)
    }

    /// The functions' values at a direction pair above the surface (the
    /// lobe's factors applied), before the colour mode makes RGB.
    fn functions_at(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        let v = self.function_values(&self.coordinates(wi, wo));
        match &self.lobe {
            Some(lobe) => {
                let f = lobe.factors(wi, wo, self.mode);
                [0, 1, 2].map(|c| v[c] * f[c])
            }
            None => v,
        }
    }

    /// The functions' values at a pair above the surface (the lobe's
    /// factors applied, before the colour mode makes RGB), the directions
    /// moved onto the reduction's elevation cut when it has one: the part
    /// of [`Brdf::eval`] that a shell factor does not change.
    pub fn functions_within_cut(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        let cut = self.reduction.max_elevation_deg;
        if cut < 90.0 {
            let (sin_cut, cos_cut) = cut.to_radians().sin_cos();
            return self.functions_at(
                crate::geometry::clamp_elevation(wi, cos_cut, sin_cut),
                crate::geometry::clamp_elevation(wo, cos_cut, sin_cut),
            );
        }
        self.functions_at(wi, wo)
    }

    /// [`Brdf::eval`] at a pair above the surface from `functions`, its
    /// [`FittedBrdf::functions_within_cut`], and `angles`, the pair's own
    /// `[theta_h, theta_d]` (called only where a shell factor reads them):
    /// the same value to the last bit, so that the evaluations of one fit
    /// under several shell factors share those parts.
    pub fn eval_from_parts(
        &self,
        wi: Vec3,
        wo: Vec3,
        functions: [f64; 3],
        angles: impl FnOnce() -> [f64; 2],
    ) -> [f64; 3] {
        let v = functions;
        self.finish(
            match (&self.shell, self.reduction.max_elevation_deg < 90.0) {
                (Some(shell), true) => {
                    let k = shell.multipliers_given(wi, wo, self.mode, angles);
                    [v[0] * k[0], v[1] * k[1], v[2] * k[2]]
                }
                _ => v,
            },
        )
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

    /// Bytes of all coefficients as f32, the lobe's seven parameters and
    /// the ceiling's three when there are.
    pub fn byte_size_f32(&self) -> usize {
        self.channels
            .iter()
            .map(RationalFunction::byte_size_f32)
            .sum::<usize>()
            + if self.lobe.is_some() { 28 } else { 0 }
            + if self.ceiling.is_some() { 12 } else { 0 }
            + self.shell.as_ref().map_or(0, ShellFactor::byte_size_f32)
    }
}

impl Brdf for FittedBrdf {
    /// The fit at `(wi, wo)`; beyond an elevation cut of the reduction,
    /// directions are moved to the cut ([`crate::clamp_elevation`]), where
    /// the fit was constrained, and the shell factor, when there is one,
    /// multiplies the value there.
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        let v = self.functions_within_cut(wi, wo);
        self.eval_from_parts(wi, wo, v, || {
            let [theta_h, theta_d, _] = HalfDiff::isotropic_angles(wi, wo);
            [theta_h, theta_d]
        })
    }

    fn name(&self) -> String {
        format!("rational fit of {}", self.name)
    }
}

impl FittedBrdf {
    /// This fit, as [`crate::fit_samples`] returned it with `report`, with every
    /// centred function at its split's point of largest margin
    /// ([`crate::ChannelReport::largest_margin`]; the others as they are): the
    /// same bytes and intervals, for a caller that chooses between the two
    /// by what the intervals do not see (its renders). `None` when no
    /// function has one.
    pub fn at_largest_margin(&self, report: &BrdfFitReport) -> Option<FittedBrdf> {
        if report.channels.len() != self.channels.len()
            || report.channels.iter().all(|c| c.largest_margin.is_none())
        {
            return None;
        }
        let channels = self
            .channels
            .iter()
            .zip(&report.channels)
            .map(|(f, c)| c.largest_margin.clone().unwrap_or_else(|| f.clone()))
            .collect();
        Some(FittedBrdf {
            channels,
            ..self.clone()
        })
    }
}
