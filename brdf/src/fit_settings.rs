//! The settings of a BRDF fit: the reduction, the intervals (relative or
//! perceptual), the colour mode and value scale, the engine's settings and
//! the dense cap check's refits.

use crate::colour::ColourMode;
use crate::design::PerceptualBounds;
use crate::lobe::Lobe;
use crate::no_fit::NoFitMemo;
use crate::reduce::Reduction;
use crate::value_scale::ValueScale;
use crate::BrdfError;
use rational_core::{FitSettings, Progress};
use std::sync::Arc;

/// Settings of [`crate::fit_brdf`].
#[derive(Debug, Clone)]
pub struct BrdfFitSettings {
    pub(crate) reduction: Reduction,
    pub(crate) rel_tol: f64,
    pub(crate) noise_floor: f64,
    pub(crate) fit: FitSettings,
    pub(crate) baselines: bool,
    pub(crate) design: Option<PerceptualBounds>,
    pub(crate) mode: ColourMode,
    pub(crate) scale: ValueScale,
    pub(crate) lobe: Option<Lobe>,
    pub(crate) cap_rounds: usize,
    pub(crate) channel_progress: Option<ChannelProgress>,
    pub(crate) no_fit: Option<NoFitMemo>,
}

/// Callback receiving each channel's sweep progress: the channel (0, 1 or 2
/// of the colour mode) and the engine's [`Progress`]; called from worker
/// threads.
pub type ChannelProgressFn = Arc<dyn Fn(usize, Progress) + Send + Sync>;

/// A [`ChannelProgressFn`] that settings can hold and print.
#[derive(Clone)]
pub(crate) struct ChannelProgress(pub(crate) ChannelProgressFn);

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
    /// perceptual design's `peak_cap`, else [`crate::design::DEFAULT_PEAK_CAP`], times the
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
