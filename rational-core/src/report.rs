//! What a fit reports: the chosen split, its verified figures and what the
//! sweep cost.

use crate::verify::{ErrorFigures, Verification};
use crate::{PoleControl, RationalFunction, Search, Selection};
use qp_backends::Status;
use serde::{Deserialize, Serialize};
use std::fmt;

/// One split of a sweep.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SplitSummary {
    /// Numerator coefficients.
    pub n_p: usize,
    /// Denominator coefficients.
    pub n_q: usize,
    /// Backend status of the last solve.
    pub status: Status,
    /// Verified and pole-checked.
    pub accepted: bool,
    /// Why it was not accepted (empty when accepted).
    pub note: String,
    /// Depth of the solution (0 when none).
    pub depth: f64,
    /// Condition number of `G`: under condition selection, of the accepted
    /// splits a sweep chose among (the smallest budget's) and of every
    /// accepted [`crate::Fitter::split`]; `None` otherwise.
    pub condition_number: Option<f64>,
    /// Wall time of this split.
    pub seconds: f64,
    /// Backend iterations, summed over re-solves.
    pub iterations: usize,
    /// Dense-grid re-solves.
    pub pole_rounds: usize,
    /// Re-solves with rows from [`crate::ExtraConstraints::refine`].
    #[serde(default)]
    pub refine_rounds: usize,
    /// Interval widenings in force when it was solved (the sweep's count).
    #[serde(default)]
    pub widenings: usize,
    /// The accepted function is the split's least-squares fit within its
    /// intervals ([`crate::FitSettings::with_centred_fit`]), not its point
    /// of largest margin (whose depth `depth` still is).
    #[serde(default)]
    pub centred: bool,
}

impl SplitSummary {
    /// A split not solved yet: infeasible until a solve says otherwise.
    pub(crate) fn pending(n_p: usize, n_q: usize) -> Self {
        Self {
            n_p,
            n_q,
            status: Status::Infeasible,
            accepted: false,
            note: String::new(),
            depth: 0.0,
            condition_number: None,
            seconds: 0.0,
            iterations: 0,
            pole_rounds: 0,
            refine_rounds: 0,
            widenings: 0,
            centred: false,
        }
    }

    /// Proved infeasible by the backend on the data's own rows (no pole or
    /// refinement rows were added): every program with these rows and more,
    /// at these intervals or narrower, is infeasible too.
    pub fn proved_infeasible(&self) -> bool {
        self.status == Status::Infeasible && self.pole_rounds == 0 && self.refine_rounds == 0
    }
}

/// Pole figures of a fit.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoleReport {
    /// The control in force.
    pub control: PoleControl,
    /// Smallest `q` on the dense grid over the largest `|q|` at the samples.
    pub grid_min_q: Option<f64>,
    /// Bernstein certificate: `q > 0` on the whole domain box.
    pub certified: Option<bool>,
}

/// The result of [`crate::fit`].
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct FitReport {
    /// The fitted function.
    pub function: RationalFunction,
    /// Chosen numerator size.
    pub n_p: usize,
    /// Chosen denominator size.
    pub n_q: usize,
    /// Depth of the chosen solution.
    pub depth: f64,
    /// Condition number of its constraint matrix (condition selection).
    pub condition_number: Option<f64>,
    /// Errors against the measured values.
    pub errors: ErrorFigures,
    /// Our own f64 check against every constraint.
    pub verification: Verification,
    /// Pole figures.
    pub poles: PoleReport,
    /// Wall time of the whole sweep.
    pub seconds: f64,
    /// Samples fitted.
    pub samples: usize,
    /// Splits solved.
    pub splits_tried: usize,
    /// Interval widenings applied.
    pub widenings: usize,
    /// Factor applied to every half-width (`widen_factor ^ widenings`).
    pub interval_scale: f64,
    /// Backend name.
    pub backend: String,
    /// Selection criterion.
    pub selection: Selection,
    /// How the splits were visited.
    #[serde(default)]
    pub search: Search,
    /// The function is the chosen split's least-squares fit within its
    /// intervals, not its point of largest margin
    /// ([`crate::FitSettings::with_centred_fit`]).
    #[serde(default)]
    pub centred: bool,
    /// When [`Self::centred`], the same split's point of largest margin,
    /// verified like the returned function: an alternative for a caller
    /// that judges the two by what the intervals do not see (a render).
    /// Not written: a fit read back has none.
    #[serde(skip)]
    pub largest_margin: Option<Box<LargestMargin>>,
    /// Every split solved, in order.
    pub splits: Vec<SplitSummary>,
}

/// A centred fit's split at its point of largest margin
/// ([`FitReport::largest_margin`]).
#[derive(Debug, Clone)]
pub struct LargestMargin {
    /// The function at that point.
    pub function: RationalFunction,
    /// Its errors against the measured values.
    pub errors: ErrorFigures,
    /// Its f64 check against every constraint.
    pub verification: Verification,
    /// Its pole figures.
    pub poles: PoleReport,
}

impl FitReport {
    /// The splits `(n_p, n_q)` this sweep proved infeasible
    /// ([`SplitSummary::proved_infeasible`]) at the intervals of the fit
    /// it returned (the widening it was accepted at): what
    /// [`crate::Fitter::known_infeasible`] takes for a refit of the same
    /// data with rows added.
    pub fn proved_infeasible(&self) -> Vec<(usize, usize)> {
        self.splits
            .iter()
            .filter(|s| s.widenings == self.widenings && s.proved_infeasible())
            .map(|s| (s.n_p, s.n_q))
            .collect()
    }

    /// This report with its function at the split's point of largest
    /// margin ([`Self::largest_margin`]), or `None` when it has none.
    pub fn at_largest_margin(&self) -> Option<FitReport> {
        let m = self.largest_margin.as_deref()?;
        let mut splits = self.splits.clone();
        for s in &mut splits {
            s.centred = false;
        }
        Some(FitReport {
            function: m.function.clone(),
            errors: m.errors,
            verification: m.verification,
            poles: m.poles,
            centred: false,
            largest_margin: None,
            splits,
            backend: self.backend.clone(),
            ..*self
        })
    }
}

impl fmt::Display for FitReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let v = &self.verification;
        writeln!(
            f,
            "rational fit: n_p = {}, n_q = {} ({} coefficients, {} bytes as f32)",
            self.n_p,
            self.n_q,
            self.n_p + self.n_q,
            self.function.byte_size_f32()
        )?;
        let basis = self.function.basis();
        if basis.is_weighted() {
            let w: Vec<String> = basis.weights().iter().map(u16::to_string).collect();
            writeln!(f, "  degree weights      {}", w.join(","))?;
        }
        writeln!(f, "  samples             {}", self.samples)?;
        writeln!(
            f,
            "  verified            {} (max violation {:.2e}, min q/max q {:.3e})",
            if v.satisfied { "yes" } else { "NO" },
            v.max_violation,
            v.min_q_ratio
        )?;
        writeln!(f, "  depth               {:.3e}", self.depth)?;
        if self.centred {
            writeln!(
                f,
                "  point               least squares within the intervals (the depth is the largest margin's)"
            )?;
        }
        match self.condition_number {
            Some(k) => writeln!(f, "  condition number    {k:.3e}")?,
            None => writeln!(f, "  condition number    not computed (selection by depth)")?,
        }
        writeln!(f, "  max relative error  {:.4e}", self.errors.max_relative)?;
        writeln!(f, "  mean relative error {:.4e}", self.errors.mean_relative)?;
        writeln!(f, "  RMSE                {:.4e}", self.errors.rmse)?;
        match (self.poles.certified, self.poles.grid_min_q) {
            (Some(c), _) => writeln!(
                f,
                "  poles               Bernstein certificate {}",
                if c {
                    "holds: q > 0 on the box"
                } else {
                    "FAILED"
                }
            )?,
            (None, Some(g)) => writeln!(
                f,
                "  poles               none on the dense grid (min q/max q {g:.3e})"
            )?,
            _ => writeln!(f, "  poles               not checked between samples")?,
        }
        if self.widenings > 0 {
            writeln!(
                f,
                "  intervals widened   {} times (x{}, on a log scale where of one sign)",
                self.widenings, self.interval_scale
            )?;
        }
        write!(
            f,
            "  splits tried        {} ({} backend, {} search), wall time {:.3} s",
            self.splits_tried,
            self.backend,
            match self.search {
                Search::Exhaustive => "exhaustive",
                Search::Staircase => "staircase",
                Search::Probe => "probe",
            },
            self.seconds
        )
    }
}
