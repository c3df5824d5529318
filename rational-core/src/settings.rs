//! Fit settings: `Default` plus validated `with_*` methods.

use crate::{BasisFamily, Domain, FitError, PoleControl, SharedDesign};
use qp_backends::{Backend, SolveOptions};
use serde::{Deserialize, Serialize};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// How the sweep picks among the feasible splits of one budget.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Selection {
    /// Lowest 2-norm condition number of the normalised constraint matrix
    /// `G` (the paper's criterion), of the data's rows and any extra rows,
    /// before the rows the pole check adds: every split is judged on the
    /// same rows.
    #[default]
    ConditionNumber,
    /// Largest depth (smallest normalised margin of `G c`, over `||c||`):
    /// the most robust fit. Skips the condition-number computation.
    Depth,
}

impl std::str::FromStr for Selection {
    type Err = FitError;
    fn from_str(s: &str) -> Result<Self, FitError> {
        match s {
            "condition" | "condition_number" | "cond" => Ok(Self::ConditionNumber),
            "depth" => Ok(Self::Depth),
            _ => Err(FitError::InvalidSetting {
                name: "selection",
                reason: format!("unknown `{s}` (condition, depth)"),
            }),
        }
    }
}

/// How the sweep visits the splits `(n_p, n_q)`.
///
/// A single budget (equal smallest and largest coefficient counts) under
/// [`Selection::ConditionNumber`] is searched alike by `Exhaustive` and
/// `Staircase`: its splits in increasing condition number, the first
/// accepted kept, which is the split the selection would choose among
/// every accepted one, without solving each to its optimum.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize, Default)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Search {
    /// Every split of every budget from the smallest up, the budget's splits
    /// in parallel (the paper's sweep): about `N^2 / 2` solves up to budget
    /// `N`.
    #[default]
    Exhaustive,
    /// The staircase of the feasible set. Adding a basis function never
    /// removes a solution (the graded bases are nested), so the smallest
    /// feasible `n_p` does not grow with `n_q`; walking `n_q` up with a
    /// bisection on `n_p` below the best budget so far finds every feasible
    /// split of the smallest budget, the splits the exhaustive sweep
    /// chooses among, in about `N log N` solves at most. Splits rejected
    /// for poles or failed verification count as infeasible, so where such
    /// a rejection breaks the nesting the staircase may stop at a larger
    /// budget than the exhaustive sweep.
    Staircase,
    /// Budgets doubling from the smallest, then bisected below the first
    /// feasible one, each budget judged by five splits (`n_p` at 20, 35,
    /// 50, 65 and 80% of it, [`PROBE_FRACTIONS`]) solved in parallel, each
    /// from scratch: about `5 log2 N` solves. It assumes that a budget with
    /// a feasible probe has feasible larger ones and may miss a budget whose
    /// only feasible splits lie between the probes, so it returns a small
    /// budget, not always the smallest. The inverse CDFs are fitted with it.
    Probe,
}

/// Where [`Search::Probe`] puts `n_p` within a budget.
pub const PROBE_FRACTIONS: [f64; 5] = [0.2, 0.35, 0.5, 0.65, 0.8];

impl std::str::FromStr for Search {
    type Err = FitError;
    fn from_str(s: &str) -> Result<Self, FitError> {
        match s {
            "exhaustive" | "all" => Ok(Self::Exhaustive),
            "staircase" => Ok(Self::Staircase),
            "probe" => Ok(Self::Probe),
            _ => Err(FitError::InvalidSetting {
                name: "search",
                reason: format!("unknown `{s}` (exhaustive, staircase, probe)"),
            }),
        }
    }
}

/// Progress of a sweep: `done` of `total` splits of `budget` coefficients
/// (a staircase search reports the split's budget and its solves so far
/// against its bound on the number of solves).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Coefficient budget being swept.
    pub budget: usize,
    /// Splits finished at this budget.
    pub done: usize,
    /// Splits at this budget.
    pub total: usize,
}

/// Callback receiving [`Progress`] events.
pub type ProgressFn = Arc<dyn Fn(Progress) + Send + Sync>;

/// Settings of [`crate::fit`].
#[derive(Clone)]
pub struct FitSettings {
    pub(crate) family: BasisFamily,
    pub(crate) degree_weights: Option<Vec<u16>>,
    pub(crate) domain: Option<Domain>,
    pub(crate) min_coeffs: usize,
    pub(crate) max_coeffs: usize,
    pub(crate) selection: Selection,
    pub(crate) search: Search,
    pub(crate) backend: Backend,
    pub(crate) solve_options: SolveOptions,
    pub(crate) widen_factor: f64,
    pub(crate) max_widenings: usize,
    pub(crate) pole_control: PoleControl,
    pub(crate) value_scaling: bool,
    pub(crate) centred: bool,
    pub(crate) progress: Option<ProgressFn>,
    pub(crate) cancel: Vec<Arc<AtomicBool>>,
    pub(crate) existence_only: Option<Arc<AtomicBool>>,
    pub(crate) shared_design: Option<SharedDesign>,
    pub(crate) screen: Screen,
}

/// Solving each split first on every `stride`-th sample, for data of at
/// least `min_samples`: a split infeasible there is infeasible on all
/// samples (its constraints are a subset of the full problem's), so the
/// full problem is built only for splits the subsample cannot refuse, and
/// those start from the subsample's active set. The answer is the one the
/// full problems alone give; only the cost changes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Screen {
    /// Smallest number of samples screened.
    pub min_samples: usize,
    /// One sample in `stride` is kept (1: no screening).
    pub stride: usize,
}

impl Default for Screen {
    /// Every 8th sample of data of 100,000 samples or more (the full MERL
    /// grid's 739,892 are screened on 92,487).
    fn default() -> Self {
        Self {
            min_samples: 100_000,
            stride: 8,
        }
    }
}

impl Screen {
    /// No screening.
    pub const OFF: Self = Self {
        min_samples: usize::MAX,
        stride: 1,
    };

    /// Whether data of `len` samples are screened.
    pub(crate) fn applies(&self, len: usize) -> bool {
        self.stride > 1 && len >= self.min_samples.max(2 * self.stride)
    }
}

impl std::fmt::Debug for FitSettings {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("FitSettings")
            .field("family", &self.family)
            .field("degree_weights", &self.degree_weights)
            .field("domain", &self.domain)
            .field("min_coeffs", &self.min_coeffs)
            .field("max_coeffs", &self.max_coeffs)
            .field("selection", &self.selection)
            .field("search", &self.search)
            .field("backend", &self.backend)
            .field("widen_factor", &self.widen_factor)
            .field("max_widenings", &self.max_widenings)
            .field("pole_control", &self.pole_control)
            .field("value_scaling", &self.value_scaling)
            .field("centred", &self.centred)
            .field("cancel_flags", &self.cancel.len())
            .field("existence_only", &self.existence_only.is_some())
            .field("shared_design", &self.shared_design.is_some())
            .field("screen", &self.screen)
            .finish_non_exhaustive()
    }
}

impl Default for FitSettings {
    /// Chebyshev basis on the data's bounding box, budgets 2 to 40,
    /// condition-number selection, exhaustive search, native backend, dense-grid pole check,
    /// no widening.
    fn default() -> Self {
        Self {
            family: BasisFamily::Chebyshev,
            degree_weights: None,
            domain: None,
            min_coeffs: 2,
            max_coeffs: 40,
            selection: Selection::ConditionNumber,
            search: Search::Exhaustive,
            backend: Backend::Native,
            solve_options: SolveOptions::default(),
            widen_factor: 2.0,
            max_widenings: 0,
            pole_control: PoleControl::default(),
            value_scaling: true,
            centred: false,
            progress: None,
            cancel: Vec::new(),
            existence_only: None,
            shared_design: None,
            screen: Screen::default(),
        }
    }
}

fn invalid(name: &'static str, reason: impl Into<String>) -> FitError {
    FitError::InvalidSetting {
        name,
        reason: reason.into(),
    }
}

impl FitSettings {
    /// Basis family.
    pub fn with_family(mut self, family: BasisFamily) -> Self {
        self.family = family;
        self
    }

    /// Degree weights of a weighted graded order (one per coordinate, each
    /// in `1..=`[`crate::MAX_DEGREE_WEIGHT`]): a unit of degree in coordinate
    /// `k` costs `weights[k]`, so `[1, 2]` reaches twice the degree in the
    /// first coordinate as in the second for the same budget. Default: all 1,
    /// the total-degree order. Their count is checked against the data's
    /// dimension when fitting.
    ///
    /// # Errors
    /// No weights, or a weight outside `1..=MAX_DEGREE_WEIGHT`.
    pub fn with_degree_weights(mut self, weights: Vec<u16>) -> Result<Self, FitError> {
        if weights.is_empty() {
            return Err(invalid("degree weights", "give one weight per coordinate"));
        }
        crate::basis::check_weights(&weights, weights.len())?;
        self.degree_weights = Some(weights);
        Ok(self)
    }

    /// Domain box mapped to `[-1, 1]^d` (default: the data's bounding box).
    pub fn with_domain(mut self, domain: Domain) -> Self {
        self.domain = Some(domain);
        self
    }

    /// Smallest and largest total coefficient budgets `N = n_p + n_q`.
    ///
    /// # Errors
    /// `min < 2` or `min > max`.
    pub fn with_coeff_range(mut self, min: usize, max: usize) -> Result<Self, FitError> {
        if min < 2 {
            return Err(invalid(
                "min_coeffs",
                "a rational function needs at least 2 coefficients",
            ));
        }
        if min > max {
            return Err(invalid(
                "max_coeffs",
                format!("{max} is below min_coeffs {min}"),
            ));
        }
        self.min_coeffs = min;
        self.max_coeffs = max;
        Ok(self)
    }

    /// Selection criterion among feasible splits.
    pub fn with_selection(mut self, selection: Selection) -> Self {
        self.selection = selection;
        self
    }

    /// How the splits are visited.
    pub fn with_search(mut self, search: Search) -> Self {
        self.search = search;
        self
    }

    /// Solver backend.
    ///
    /// # Errors
    /// The backend is not compiled into this build.
    pub fn with_backend(mut self, backend: Backend) -> Result<Self, FitError> {
        backend.solver()?;
        self.backend = backend;
        Ok(self)
    }

    /// Options passed to the backend.
    pub fn with_solve_options(mut self, options: SolveOptions) -> Self {
        self.solve_options = options;
        self
    }

    /// When no budget up to the maximum is feasible, widen every interval by
    /// `factor` and sweep again, at most `times` times: intervals of one
    /// sign on a log scale (zero never enters), others about their centre
    /// ([`crate::IntervalData::widened`]).
    ///
    /// When the exact intervals have no fit, the widest level's largest
    /// budget is solved first, split by split: if every split is refused
    /// with a certificate of infeasibility, no level has a fit and the
    /// sweep ends there, without searching the levels between. Otherwise
    /// the levels are searched as they would be without it (the fit
    /// returned is the same; the splits solved are reported at the widest
    /// level). Not with [`crate::Search::Probe`], nor on screened data
    /// ([`crate::Screen`]).
    ///
    /// # Errors
    /// `factor <= 1` or not finite.
    pub fn with_widening(mut self, factor: f64, times: usize) -> Result<Self, FitError> {
        if !(factor.is_finite() && factor > 1.0) {
            return Err(invalid(
                "widen_factor",
                format!("{factor} must be finite and above 1"),
            ));
        }
        self.widen_factor = factor;
        self.max_widenings = times;
        Ok(self)
    }

    /// Pole control.
    pub fn with_pole_control(mut self, pole_control: PoleControl) -> Self {
        self.pole_control = pole_control;
        self
    }

    /// Divide the bounds by their largest magnitude before building
    /// P(n_p, n_q) (default on). The least-norm objective of the
    /// paper's formulation depends on the data's units: without scaling,
    /// values near 1e-9 give depths near 1e-11 and may change the chosen
    /// split. Off reproduces the paper's formulation exactly.
    pub fn with_value_scaling(mut self, on: bool) -> Self {
        self.value_scaling = on;
        self
    }

    /// Return the chosen split's least-squares fit within its intervals
    /// instead of its point of largest margin (default off, the paper's
    /// point; the split is chosen as without it). The largest-margin point's error swings between the bounds
    /// like a minimax fit's; the centred fit is the one closest to the
    /// intervals' centres (each residual in units of its half-width) among
    /// the coefficients that keep every constraint with a fifth of that
    /// margin. It is verified and pole-checked like any point; where it
    /// fails either, or the program is too large to store densely (about
    /// 130 MB), the largest-margin point stays.
    pub fn with_centred_fit(mut self, on: bool) -> Self {
        self.centred = on;
        self
    }

    /// The subsample each split is solved on first ([`Screen`]; default:
    /// every 8th sample from 100,000 samples; [`Screen::OFF`] to solve
    /// every split on all samples at once).
    ///
    /// # Errors
    /// A stride of zero.
    pub fn with_screen(mut self, screen: Screen) -> Result<Self, FitError> {
        if screen.stride == 0 {
            return Err(invalid("screen stride", "0 must be at least 1"));
        }
        self.screen = screen;
        Ok(self)
    }

    /// Basis values shared with other fits of the same points (the channels
    /// of a material): each fit given a clone of one handle reads the
    /// design the first one evaluated, when its points and basis are the
    /// same, instead of evaluating and storing its own.
    pub fn with_shared_design(mut self, design: SharedDesign) -> Self {
        self.shared_design = Some(design);
        self
    }

    /// Progress callback (called from worker threads).
    pub fn with_progress(mut self, f: ProgressFn) -> Self {
        self.progress = Some(f);
        self
    }

    /// Adds a flag that stops the sweep: once any of the settings' flags is
    /// set, no further split is solved and the fit returns
    /// [`FitError::Cancelled`]; splits being solved stop at their next
    /// active-set change (native backend) or when they end. Lets a caller
    /// interrupt a long fit (Ctrl-C in an interactive session, a deadline in
    /// a server) and a library stop fits whose result is no longer needed,
    /// each with its own flag.
    pub fn with_cancel(mut self, flag: Arc<AtomicBool>) -> Self {
        self.cancel.push(flag);
        self
    }

    /// A flag that turns the sweep from finding the smallest fit to
    /// settling whether any exists: once it is set, a staircase sweep
    /// ([`Search::Staircase`]) stops at its next split and solves the
    /// widest widening level's largest budget, split by split
    /// ([`FitSettings::with_widening`]). A split accepted there means the
    /// sweep would have returned a fit ([`FitError::FitExists`]); every
    /// split refused with a certificate means it would have returned
    /// [`FitError::NoFeasibleFit`], which it does; otherwise the sweep
    /// starts again as if the flag were not set. For a caller that needs
    /// one function's outcome only where another's has failed (the error
    /// named is the first in order), not its fit. Other searches ignore it.
    pub fn with_existence_only(mut self, flag: Arc<AtomicBool>) -> Self {
        self.existence_only = Some(flag);
        self
    }

    /// Whether the flag of [`FitSettings::with_existence_only`] is set.
    pub(crate) fn existence_only(&self) -> bool {
        self.search == Search::Staircase
            && self
                .existence_only
                .as_ref()
                .is_some_and(|f| f.load(Ordering::Relaxed))
    }

    /// Whether one of the cancel flags ([`FitSettings::with_cancel`]) is set.
    pub(crate) fn cancelled(&self) -> bool {
        self.cancel.iter().any(|f| f.load(Ordering::Relaxed))
    }

    /// The smallest and largest total coefficient budgets searched.
    pub fn coeff_range(&self) -> (usize, usize) {
        (self.min_coeffs, self.max_coeffs)
    }

    /// The backend in use.
    pub fn backend(&self) -> Backend {
        self.backend
    }
}
