//! [`Fitter`]: the one way to fit interval data, whether by the sweep over
//! coefficient budgets, at a single split, or to see the program a split
//! solves.

use crate::fit::{solve_split, split_problem, SplitFit};
use crate::problem::{ExtraConstraints, NoExtraConstraints};
use crate::sweep::{sweep, KnownInfeasible};
use crate::{FitError, FitReport, FitSettings, IntervalData, NoFitProof, Search};
use qp_backends::LdpProblem;

/// A fit of `data` being set up: settings (validated by their own
/// builders), the budget search, and caller-supplied constraint rows; then
/// [`Fitter::fit`] (the sweep), [`Fitter::split`] (one split) or
/// [`Fitter::problem`] (the program of one split, for other solvers).
///
/// ```
/// use rational_core::{Fitter, IntervalData, Search};
///
/// let x: Vec<f64> = (0..100).map(|i| i as f64 / 99.0).collect();
/// let v: Vec<f64> = x.iter().map(|x| 1.0 / (1.2 - x)).collect();
/// let data = IntervalData::from_values_relative(1, x, v, 0.001)?;
/// let fitter = Fitter::new(&data).search(Search::Staircase);
/// let report = fitter.fit()?;
/// assert!(report.verification.satisfied);
/// // The same data at the split the sweep chose, solved alone.
/// let single = fitter.split(report.n_p, report.n_q)?;
/// assert!(single.function.is_some());
/// # Ok::<(), rational_core::FitError>(())
/// ```
pub struct Fitter<'a> {
    data: &'a IntervalData,
    settings: FitSettings,
    extra: &'a dyn ExtraConstraints,
    known: KnownInfeasible,
    proofs: &'a [NoFitProof],
}

impl<'a> Fitter<'a> {
    /// A fit of `data` with the default settings and no extra constraints.
    pub fn new(data: &'a IntervalData) -> Self {
        Self {
            data,
            settings: FitSettings::default(),
            extra: &NoExtraConstraints,
            known: KnownInfeasible::default(),
            proofs: &[],
        }
    }

    /// These settings (basis, budgets, backend, poles, widening...).
    pub fn settings(mut self, settings: FitSettings) -> Self {
        self.settings = settings;
        self
    }

    /// How the sweep visits the splits (the settings' search otherwise).
    pub fn search(mut self, search: Search) -> Self {
        self.settings = self.settings.with_search(search);
        self
    }

    /// Linear rows added to every split's program (monotonicity of an
    /// inverse CDF, positivity on a grid...), and their check of each
    /// verified candidate ([`ExtraConstraints::refine`]: accept, refuse, or
    /// rows for another solve of the split).
    pub fn constraints(mut self, extra: &'a dyn ExtraConstraints) -> Self {
        self.extra = extra;
        self
    }

    /// Splits `(n_p, n_q)` already proved infeasible on some of these
    /// rows at these intervals or narrower ([`FitReport::proved_infeasible`]
    /// of a fit of the same data before rows were added): the staircase
    /// and the single-budget condition order do not solve them again, nor
    /// a split of the same `n_q` with a smaller `n_p` (nested bases).
    /// Wider intervals forget them: a widening can make them feasible.
    /// The sweep returns what it would without them, sooner.
    pub fn known_infeasible(mut self, splits: &[(usize, usize)]) -> Self {
        self.known = KnownInfeasible::new(splits);
        self
    }

    /// Interval data proved to have no fit ([`NoFitProof`], from sweeps
    /// with the same extra constraints as this one): the sweep solves
    /// nothing at a widening level whose data one of them covers, and
    /// returns what it would without them, sooner.
    pub fn no_fit_proofs(mut self, proofs: &'a [NoFitProof]) -> Self {
        self.proofs = proofs;
        self
    }

    /// The settings in use.
    pub fn current_settings(&self) -> &FitSettings {
        &self.settings
    }

    /// The sweep: for each budget from the smallest, its splits (every one,
    /// or the staircase's few); the first budget with an accepted split
    /// wins and the settings' criterion picks among its splits. Without one
    /// up to the largest budget, the intervals are widened (if the settings
    /// allow) and the sweep restarts. The returned fit is verified in f64.
    ///
    /// # Errors
    /// Invalid data or settings, too few samples, backend errors, or
    /// [`FitError::NoFeasibleFit`] with every split tried.
    pub fn fit(&self) -> Result<FitReport, FitError> {
        sweep(
            self.data,
            &self.settings,
            self.extra,
            &self.known,
            self.proofs,
        )
    }

    /// The single split P(n_p, n_q), accepted or not (no sweep, no
    /// widening), with the settings' basis, backend and pole control.
    ///
    /// # Errors
    /// Invalid data or settings, an empty side (`n_p` or `n_q` zero), fewer
    /// samples than `n_p + n_q`, backend errors.
    pub fn split(&self, n_p: usize, n_q: usize) -> Result<SplitFit, FitError> {
        solve_split(self.data, n_p, n_q, &self.settings, self.extra)
    }

    /// The program P(n_p, n_q) that [`Fitter::split`] solves first, extra
    /// rows included, for cross-checking with other solvers.
    ///
    /// # Errors
    /// As [`Fitter::split`].
    pub fn problem(&self, n_p: usize, n_q: usize) -> Result<LdpProblem, FitError> {
        split_problem(self.data, n_p, n_q, &self.settings, self.extra)
    }
}
