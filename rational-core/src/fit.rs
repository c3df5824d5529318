//! Solving one split P(n_p, n_q) and the sweep over coefficient budgets.

use crate::poles::{bernstein_margin, bernstein_rows, grid_check, grid_size};
use crate::problem::{
    build_problem_in, condition_number, DesignMatrix, ExtraConstraints, NoExtraConstraints,
    Refinement, SharedDesign,
};
use crate::report::{FitReport, PoleReport, SplitSummary};
use crate::screen::{data_row, Screened, Subsample};
use crate::verify::{error_figures, verify, verify_with, Verification};
use crate::{
    Basis, FitError, FitSettings, IntervalData, NoFitProof, PoleControl, Progress,
    RationalFunction, Search, Selection,
};
use qp_backends::{CancelFlag, LdpProblem, Status};
use rayon::prelude::*;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::time::Instant;

/// Dense-grid rounds before a split with poles between samples is rejected.
const MAX_POLE_ROUNDS: usize = 6;

/// Basis functions evaluated at the samples before any split asks for more.
const INITIAL_DESIGN_WIDTH: usize = 16;

/// One solved split, accepted or not.
#[derive(Debug, Clone)]
pub struct SplitFit {
    /// Summary figures (status, depth, time, ...).
    pub summary: SplitSummary,
    /// The fitted function when accepted.
    pub function: Option<RationalFunction>,
    /// Our own check of the point, whenever the backend claimed one
    /// (accepted or not).
    pub verification: Option<Verification>,
    /// Pole figures of the accepted function.
    pub poles: PoleReport,
}

/// Everything the splits of a sweep share.
struct Prepared<'a> {
    basis: Basis,
    /// Basis values at the samples, as many functions as the widest split
    /// so far needed (grown by doubling): a search whose answer is small
    /// never evaluates, nor stores, the whole basis. The settings' shared
    /// design when it holds these points and basis, else this fit's own.
    shared: Option<SharedDesign>,
    own: SharedDesign,
    /// The subsample each split is solved on first, for large data.
    screen: Option<Subsample>,
    data: &'a IntervalData,
    settings: &'a FitSettings,
    extra: &'a dyn ExtraConstraints,
    /// Bounds are divided by this in P(n_p, n_q); the numerator is scaled back.
    scale: f64,
    /// Splits started, reported when the sweep is cancelled.
    solved: AtomicUsize,
    /// Stopped by [`FitSettings::with_existence_only`]'s flag.
    interrupted: AtomicBool,
    /// A sweep that may be stopped to settle whether a fit exists (not a
    /// single split, nor a sweep settling it already).
    may_settle: AtomicBool,
    /// A split was accepted: a staircase sweep returns a fit of the level
    /// it was accepted at, if not of one before (the widest level's
    /// largest budget counts too).
    accepted_one: AtomicBool,
}

impl<'a> Prepared<'a> {
    fn new(
        data: &'a IntervalData,
        settings: &'a FitSettings,
        extra: &'a dyn ExtraConstraints,
        len: usize,
    ) -> Result<Self, FitError> {
        let domain = match &settings.domain {
            Some(d) if d.dim() != data.dim() => {
                return Err(FitError::DimensionMismatch(format!(
                    "domain of dimension {} for data of dimension {}",
                    d.dim(),
                    data.dim()
                )))
            }
            Some(d) => d.clone(),
            None => data.bounding_box(),
        };
        let basis = match &settings.degree_weights {
            Some(w) => Basis::weighted(settings.family, domain, len, w)?,
            None => Basis::new(settings.family, domain, len)?,
        };
        let scale = if settings.value_scaling {
            data.value_scale()
        } else {
            1.0
        };
        Ok(Self {
            basis,
            shared: settings.shared_design.clone(),
            own: SharedDesign::new(),
            screen: if settings.screen.applies(data.len()) {
                Some(Subsample::of(data, settings.screen.stride)?)
            } else {
                None
            },
            data,
            settings,
            extra,
            scale,
            solved: AtomicUsize::new(0),
            interrupted: AtomicBool::new(false),
            may_settle: AtomicBool::new(false),
            accepted_one: AtomicBool::new(false),
        })
    }

    /// The rows added to P(n_p, n_q) before any pole rows.
    fn base_rows(&self, n_p: usize, n_q: usize) -> Vec<Vec<f64>> {
        let mut rows = self.extra.rows(&self.basis, n_p, n_q);
        if let PoleControl::Bernstein { elevation } = self.settings.pole_control {
            for t in bernstein_rows(&self.basis, n_q, elevation) {
                let mut r = vec![0.0; n_p];
                r.extend(t);
                rows.push(r);
            }
        }
        rows
    }

    /// P(n_p, n_q) on `data` (the prepared points, possibly widened bounds).
    fn problem(
        &self,
        data: &IntervalData,
        n_p: usize,
        n_q: usize,
        rows: &[Vec<f64>],
    ) -> Result<LdpProblem, FitError> {
        debug_assert_eq!(data.len(), self.data.len());
        let design = self.design_of_width(n_p.max(n_q))?;
        build_problem_in(&design, data, n_p, n_q, rows, self.scale)
    }

    /// The design matrix with at least `width` functions (a shared handle).
    fn design_of_width(&self, width: usize) -> Result<DesignMatrix, FitError> {
        let width = width.max(INITIAL_DESIGN_WIDTH).min(self.basis.len());
        if let Some(shared) = &self.shared {
            if let Some(design) = shared.of_width(&self.basis, self.data, width)? {
                return Ok(design);
            }
        }
        Ok(self
            .own
            .of_width(&self.basis, self.data, width)?
            .expect("a fit's own design holds its points and basis"))
    }

    /// [`verify`] of a candidate on the prepared points, with the basis
    /// values read from the design matrix (the same numbers, not evaluated
    /// again).
    fn verify(
        &self,
        f: &RationalFunction,
        data: &IntervalData,
        rows: &[Vec<f64>],
    ) -> Result<Verification, FitError> {
        let (n_p, n_q) = f.split();
        let design = self.design_of_width(n_p.max(n_q))?;
        Ok(verify_with(f, data, rows, |i, phi| {
            phi.copy_from_slice(&design.row(i)[..phi.len()]);
        }))
    }

    /// The rational function of a solution vector `(a, b)` (numerator
    /// rescaled from the value-scaled problem), unit-normalised.
    fn candidate(
        &self,
        split_basis: &Basis,
        x: &[f64],
        n_p: usize,
    ) -> Result<RationalFunction, FitError> {
        Ok(RationalFunction::new(
            split_basis.clone(),
            x[..n_p].iter().map(|a| a * self.scale).collect(),
            x[n_p..].to_vec(),
        )?
        .normalised())
    }

    /// Counts a split about to be solved, or stops the sweep when one of
    /// its cancel flags is set.
    fn start_split(&self) -> Result<(), FitError> {
        if self.settings.cancelled() {
            return Err(FitError::Cancelled {
                splits_tried: self.solved.load(Ordering::Relaxed),
            });
        }
        if self.may_settle.load(Ordering::Relaxed) && self.settings.existence_only() {
            // Caught by `sweep`, which settles whether a fit exists.
            self.interrupted.store(true, Ordering::Relaxed);
            return Err(FitError::Cancelled {
                splits_tried: self.solved.load(Ordering::Relaxed),
            });
        }
        self.solved.fetch_add(1, Ordering::Relaxed);
        Ok(())
    }

    /// Solves P(n_p, n_q) with its pole rounds. `active` is a warm start on
    /// entry (the active data rows of a neighbouring split; a hint that
    /// saves iterations and changes no optimum) and holds this split's
    /// active data rows on return.
    fn solve(
        &self,
        data: &IntervalData,
        n_p: usize,
        n_q: usize,
        want_condition: bool,
        active: &mut Vec<usize>,
    ) -> Result<SplitFit, FitError> {
        self.start_split()?;
        let start = Instant::now();
        let mut rows = self.base_rows(n_p, n_q);
        let split_basis = self.basis.with_len(n_p.max(n_q))?;
        let mut summary = SplitSummary::pending(n_p, n_q);
        let mut poles = PoleReport {
            control: self.settings.pole_control,
            grid_min_q: None,
            certified: None,
        };
        let mut warm = std::mem::take(active);
        if self.refused_by_screen(data, (n_p, n_q), &rows, &mut warm, &mut summary, active)? {
            summary.seconds = start.elapsed().as_secs_f64();
            return Ok(SplitFit {
                summary,
                function: None,
                verification: None,
                poles,
            });
        }
        // Each exit of the loop names the outcome; the timing and the result
        // are assembled once below.
        let (function, verification) = loop {
            let problem = self.problem(data, n_p, n_q, &rows)?;
            let mut options = self.settings.solve_options.clone().with_warm_start(warm);
            if !self.settings.cancel.is_empty() {
                options = options.with_cancel(CancelFlag::any(self.settings.cancel.clone()));
            }
            let sol = self.settings.backend.solve(&problem, &options)?;
            let data_rows = 2 * data.len();
            active.clear();
            active.extend(sol.active_set.iter().copied().filter(|&j| j < data_rows));
            if let Some(sub) = &self.screen {
                sub.remember(active, data);
            }
            if sol.status == Status::Cancelled {
                return Err(FitError::Cancelled {
                    splits_tried: self.solved.load(Ordering::Relaxed),
                });
            }
            summary.status = sol.status;
            summary.iterations += sol.iterations;
            summary.depth = sol.residuals.depth;
            // P(n_p, n_q) is homogeneous: any point with every row strictly
            // positive (depth > 0) is a valid fit after rescaling, even if a
            // backend stopped at G c >= 1 - 1e-9 instead of G c >= 1.
            let claimed = matches!(sol.status, Status::Solved | Status::Inaccurate);
            let usable =
                claimed && sol.residuals.depth > 0.0 && sol.x.iter().all(|v| v.is_finite());
            if !usable {
                // A point the backend claims but that is not strictly inside
                // is still measured by our verifier, so callers see why.
                let measured = claimed
                    .then(|| self.candidate(&split_basis, &sol.x, n_p).ok())
                    .flatten()
                    .map(|f| verify(&f, data, &rows));
                summary.note = if claimed {
                    format!(
                        "backend reported {}; verifier found violation {:.2e}",
                        sol.status,
                        measured.map_or(sol.residuals.max_violation, |v| v.max_violation)
                    )
                } else {
                    sol.status.to_string()
                };
                break (None, measured);
            }
            warm = sol.active_set.clone();
            let f = self.candidate(&split_basis, &sol.x, n_p)?;
            let ver = self.verify(&f, data, &rows)?;
            if !ver.satisfied {
                summary.note = format!(
                    "verification failed at {} (violation {:.2e})",
                    ver.worst, ver.max_violation
                );
                break (None, Some(ver));
            }
            match self.refine(&f, &ver, data, &mut summary, &mut poles) {
                Refinement::AddRows(more) => {
                    rows.extend(more);
                    continue;
                }
                Refinement::Reject { reason } => {
                    summary.note = reason;
                    break (None, Some(ver));
                }
                _ => {}
            }
            summary.accepted = true;
            self.accepted_one.store(true, Ordering::Relaxed);
            if want_condition {
                summary.condition_number = Some(self.condition_before_poles(
                    &problem,
                    data,
                    (n_p, n_q),
                    summary.pole_rounds,
                )?);
            }
            break (Some(f), Some(ver));
        };
        summary.seconds = start.elapsed().as_secs_f64();
        Ok(SplitFit {
            summary,
            function,
            verification,
            poles,
        })
    }

    /// The condition number [`Selection::ConditionNumber`] compares: of
    /// the split's rows before any pole rows (every split is judged on the
    /// same rows), so of `problem` itself when no pole rounds added rows.
    fn condition_before_poles(
        &self,
        problem: &LdpProblem,
        data: &IntervalData,
        (n_p, n_q): (usize, usize),
        pole_rounds: usize,
    ) -> Result<f64, FitError> {
        if pole_rounds == 0 {
            return Ok(condition_number(problem));
        }
        let base = self.problem(data, n_p, n_q, &self.base_rows(n_p, n_q))?;
        Ok(condition_number(&base))
    }

    /// The condition number of every accepted split of `candidates` that
    /// has none yet (the searches leave it to the candidates of the budget
    /// they return: a blocked QR of all the split's rows, as costly as a
    /// solve on large data), copied to its summary in `summaries`.
    fn condition_numbers(
        &self,
        data: &IntervalData,
        candidates: &mut [SplitFit],
        summaries: &mut [SplitSummary],
    ) -> Result<(), FitError> {
        for fit in candidates.iter_mut().filter(|f| f.summary.accepted) {
            if fit.summary.condition_number.is_some() {
                continue;
            }
            let (n_p, n_q) = (fit.summary.n_p, fit.summary.n_q);
            let problem = self.problem(data, n_p, n_q, &self.base_rows(n_p, n_q))?;
            let k = condition_number(&problem);
            fit.summary.condition_number = Some(k);
            if let Some(s) = summaries
                .iter_mut()
                .rev()
                .find(|s| s.accepted && (s.n_p, s.n_q) == (n_p, n_q))
            {
                s.condition_number = Some(k);
            }
        }
        Ok(())
    }

    /// Whether the subsample (when there is one) refuses the split: then
    /// `summary` says so and `active` holds the subsample's active data
    /// rows; otherwise `warm` becomes the subsample's active rows (the
    /// optimum of this split on fewer rows starts the full problem nearer
    /// its own than a neighbouring split's does).
    fn refused_by_screen(
        &self,
        data: &IntervalData,
        split: (usize, usize),
        rows: &[Vec<f64>],
        warm: &mut Vec<usize>,
        summary: &mut SplitSummary,
        active: &mut Vec<usize>,
    ) -> Result<bool, FitError> {
        let Some(sub) = &self.screen else {
            return Ok(false);
        };
        match self.screen_split(sub, data, split, rows, warm)? {
            Screened::Infeasible { iterations, rows } => {
                summary.status = Status::Infeasible;
                summary.iterations = iterations;
                summary.note = format!("infeasible on one sample in {}, hence on all", sub.stride);
                active.extend(rows.into_iter().filter(|&j| j < 2 * data.len()));
                Ok(true)
            }
            Screened::Open { iterations, rows } => {
                summary.iterations = iterations;
                if !rows.is_empty() {
                    *warm = rows;
                }
                Ok(false)
            }
        }
    }

    /// P(n_p, n_q) on the subsample with `data`'s bounds and the binding
    /// rows, started from the rows of `warm` it holds; its verdict and
    /// active rows, as rows of the full problem.
    fn screen_split(
        &self,
        sub: &Subsample,
        data: &IntervalData,
        (n_p, n_q): (usize, usize),
        rows: &[Vec<f64>],
        warm: &[usize],
    ) -> Result<Screened, FitError> {
        let sub_data = sub.bounds_of(data)?;
        let width = n_p.max(n_q).max(INITIAL_DESIGN_WIDTH).min(self.basis.len());
        let design = sub
            .design
            .of_width(&self.basis, &sub.points, width)?
            .expect("a subsample's design holds its points and basis");
        let numbering = sub.numbering(data.len(), rows.len());
        let split_basis = self.basis.with_len(n_p.max(n_q))?;
        let mut added = rows.to_vec();
        added.extend(
            numbering
                .binding
                .iter()
                .map(|&j| data_row(&split_basis, data, j, n_p, n_q)),
        );
        let problem = build_problem_in(&design, &sub_data, n_p, n_q, &added, self.scale)?;
        let hint = warm.iter().filter_map(|&j| numbering.to_sub(j)).collect();
        let mut options = self.settings.solve_options.clone().with_warm_start(hint);
        if !self.settings.cancel.is_empty() {
            options = options.with_cancel(CancelFlag::any(self.settings.cancel.clone()));
        }
        let sol = self.settings.backend.solve(&problem, &options)?;
        let rows = sol
            .active_set
            .iter()
            .map(|&r| numbering.to_full(r))
            .collect();
        Ok(match sol.status {
            Status::Cancelled => {
                return Err(FitError::Cancelled {
                    splits_tried: self.solved.load(Ordering::Relaxed),
                })
            }
            Status::Infeasible => Screened::Infeasible {
                iterations: sol.iterations,
                rows,
            },
            Status::Solved | Status::Inaccurate => Screened::Open {
                iterations: sol.iterations,
                rows,
            },
            _ => Screened::Open {
                iterations: sol.iterations,
                rows: Vec::new(),
            },
        })
    }

    /// The refinement of a verified candidate: the pole check first, then
    /// the caller's [`ExtraConstraints::refine`]; each accepts, refuses or
    /// adds rows for another solve of the split (counted in `summary`).
    fn refine(
        &self,
        f: &RationalFunction,
        ver: &Verification,
        data: &IntervalData,
        summary: &mut SplitSummary,
        poles: &mut PoleReport,
    ) -> Refinement {
        let split = (summary.n_p, summary.n_q);
        match self.check_poles(f, ver, data, split, summary.pole_rounds, poles) {
            Refinement::Accept => {}
            Refinement::AddRows(more) => {
                summary.pole_rounds += 1;
                return Refinement::AddRows(more);
            }
            other => return other,
        }
        let refinement = self.extra.refine(f, summary.refine_rounds);
        if matches!(refinement, Refinement::AddRows(_)) {
            summary.refine_rounds += 1;
        }
        refinement
    }

    /// The settings' pole control on a verified candidate: accept it,
    /// reject it, or solve again with rows `q > 0` at the grid points where
    /// `q <= 0` (after `rounds` such rounds).
    fn check_poles(
        &self,
        f: &RationalFunction,
        ver: &Verification,
        data: &IntervalData,
        (n_p, n_q): (usize, usize),
        rounds: usize,
        poles: &mut PoleReport,
    ) -> Refinement {
        match self.settings.pole_control {
            PoleControl::None => Refinement::Accept,
            PoleControl::Bernstein { elevation } => {
                let m = bernstein_margin(f.basis(), f.denominator(), elevation);
                poles.certified = Some(m > 0.0);
                if m > 0.0 {
                    Refinement::Accept
                } else {
                    Refinement::Reject {
                        reason: "Bernstein certificate failed".into(),
                    }
                }
            }
            PoleControl::DenseGrid { points_per_dim } => {
                let g = grid_size(data.len(), data.dim(), points_per_dim);
                let (min, bad) = grid_check(f.basis(), f.denominator(), g, 4 * n_q + 8);
                // min_q / min_q_ratio is the largest q at the samples.
                poles.grid_min_q = Some(min / ver.min_q.max(f64::MIN_POSITIVE) * ver.min_q_ratio);
                if bad.is_empty() {
                    return Refinement::Accept;
                }
                if rounds >= MAX_POLE_ROUNDS {
                    return Refinement::Reject {
                        reason: format!(
                            "q <= 0 at {} grid points after {MAX_POLE_ROUNDS} rounds",
                            bad.len()
                        ),
                    };
                }
                let mut phi = vec![0.0; f.basis().len()];
                let rows = bad
                    .iter()
                    .map(|x| {
                        f.basis().eval_into(x, &mut phi);
                        let mut r = vec![0.0; n_p];
                        r.extend_from_slice(&phi[..n_q]);
                        r
                    })
                    .collect();
                Refinement::AddRows(rows)
            }
        }
    }
}

fn check_sizes(data: &IntervalData, settings: &FitSettings) -> Result<usize, FitError> {
    if data.len() < settings.min_coeffs {
        return Err(FitError::TooFewSamples {
            samples: data.len(),
            coeffs: settings.min_coeffs,
        });
    }
    Ok(settings.max_coeffs.min(data.len()))
}

/// At least as many samples as the split has coefficients.
fn check_split(data: &IntervalData, n_p: usize, n_q: usize) -> Result<(), FitError> {
    if data.len() < n_p + n_q {
        return Err(FitError::TooFewSamples {
            samples: data.len(),
            coeffs: n_p + n_q,
        });
    }
    Ok(())
}

/// [`crate::Fitter::split`].
pub(crate) fn solve_split(
    data: &IntervalData,
    n_p: usize,
    n_q: usize,
    settings: &FitSettings,
    extra: &dyn ExtraConstraints,
) -> Result<SplitFit, FitError> {
    check_split(data, n_p, n_q)?;
    if n_p == 0 || n_q == 0 {
        return Err(FitError::InvalidSetting {
            name: "split",
            reason: "n_p and n_q must be at least 1".into(),
        });
    }
    let prep = Prepared::new(data, settings, extra, n_p.max(n_q))?;
    prep.solve(data, n_p, n_q, true, &mut Vec::new())
}

/// [`crate::Fitter::problem`].
pub(crate) fn split_problem(
    data: &IntervalData,
    n_p: usize,
    n_q: usize,
    settings: &FitSettings,
    extra: &dyn ExtraConstraints,
) -> Result<LdpProblem, FitError> {
    check_split(data, n_p, n_q)?;
    let prep = Prepared::new(data, settings, extra, n_p.max(n_q).max(1))?;
    let rows = prep.base_rows(n_p, n_q);
    prep.problem(data, n_p, n_q, &rows)
}

/// Fits `data` by the sweep with `settings`: shorthand for
/// `Fitter::new(data).settings(settings.clone()).fit()` ([`crate::Fitter`]
/// adds extra constraints, a single split and the program of a split).
///
/// # Errors
/// As [`crate::Fitter::fit`].
pub fn fit(data: &IntervalData, settings: &FitSettings) -> Result<FitReport, FitError> {
    sweep(
        data,
        settings,
        &NoExtraConstraints,
        &KnownInfeasible::default(),
        &[],
    )
}

/// Splits known infeasible before a sweep starts
/// ([`crate::Fitter::known_infeasible`]): for each `n_q`, the largest `n_p`
/// proved infeasible, so every smaller `n_p` is too (nested bases: a
/// numerator of fewer coefficients is one of more with zeros).
#[derive(Debug, Clone, Default)]
pub(crate) struct KnownInfeasible {
    up_to: Vec<usize>,
}

impl KnownInfeasible {
    pub(crate) fn new(splits: &[(usize, usize)]) -> Self {
        let mut up_to = Vec::new();
        for &(n_p, n_q) in splits {
            if up_to.len() <= n_q {
                up_to.resize(n_q + 1, 0);
            }
            up_to[n_q] = up_to[n_q].max(n_p);
        }
        Self { up_to }
    }

    /// The largest `n_p` known infeasible with `n_q` (0: none).
    fn up_to(&self, n_q: usize) -> usize {
        self.up_to.get(n_q).copied().unwrap_or(0)
    }
}

/// [`crate::Fitter::fit`].
pub(crate) fn sweep(
    data: &IntervalData,
    settings: &FitSettings,
    extra: &dyn ExtraConstraints,
    known: &KnownInfeasible,
    proofs: &[NoFitProof],
) -> Result<FitReport, FitError> {
    let start = Instant::now();
    let max_n = check_sizes(data, settings)?;
    let prep = Prepared::new(data, settings, extra, (max_n - 1).max(1))?;
    prep.may_settle.store(true, Ordering::Relaxed);
    let sweep = Sweep {
        prep: &prep,
        data,
        max_n,
        known,
        proofs,
        start,
    };
    let mut summaries = Vec::new();
    match sweep.levels(&mut summaries) {
        Err(FitError::Cancelled { .. }) if prep.interrupted.load(Ordering::Relaxed) => {
            sweep.settle(summaries)
        }
        other => other,
    }
}

/// One sweep's data, settings and what is known before it.
struct Sweep<'a, 'p> {
    prep: &'a Prepared<'p>,
    data: &'a IntervalData,
    max_n: usize,
    known: &'a KnownInfeasible,
    proofs: &'a [NoFitProof],
    start: Instant,
}

impl Sweep<'_, '_> {
    /// The data widened to the settings' widest level, as the levels of
    /// [`Sweep::levels`] reach it (the same widenings in the same order).
    fn widest(&self) -> IntervalData {
        let settings = self.prep.settings;
        let mut widest = self.data.clone();
        for _ in 0..settings.max_widenings {
            widest = widest.widened(settings.widen_factor);
        }
        widest
    }

    fn no_fit(&self, splits: Vec<SplitSummary>) -> FitError {
        FitError::NoFeasibleFit {
            splits,
            max_coeffs: self.max_n,
            widenings: self.prep.settings.max_widenings,
            factor: self.prep.settings.widen_factor,
        }
    }

    fn covered(&self, data: &IntervalData) -> bool {
        self.proofs
            .iter()
            .any(|p| p.covers(data, self.prep.settings))
    }

    /// The settings' search at each widening level in turn, until one has
    /// a fit.
    fn levels(&self, summaries: &mut Vec<SplitSummary>) -> Result<FitReport, FitError> {
        let (prep, settings, max_n) = (self.prep, self.prep.settings, self.max_n);
        let want_condition = settings.selection == Selection::ConditionNumber;
        let mut current = self.data.clone();
        let nothing_known = KnownInfeasible::default();
        for widenings in 0..=settings.max_widenings {
            // A screen's binding rows depend on every solve before, so with
            // one this check could change the fit returned.
            if widenings == 1 && settings.search != Search::Probe && prep.screen.is_none() {
                // The exact intervals have no fit: before a search at each
                // wider level, the widest level's largest budget.
                let widest = self.widest();
                if !self.covered(&widest) {
                    match largest_budget(prep, &widest, (max_n, true), summaries)? {
                        Tops::Refused => return Err(self.no_fit(std::mem::take(summaries))),
                        Tops::Fit | Tops::Open => {}
                    }
                }
            }
            if self.covered(&current) {
                // Proved to have no fit: nothing to solve at this width.
                if widenings < settings.max_widenings {
                    current = current.widened(settings.widen_factor);
                }
                continue;
            }
            let single_budget = settings.min_coeffs == max_n;
            // What was proved at the given intervals says nothing of wider ones.
            let known = if widenings == 0 {
                self.known
            } else {
                &nothing_known
            };
            let first = summaries.len();
            let searched = match settings.search {
                Search::Exhaustive | Search::Staircase if want_condition && single_budget => {
                    by_condition(prep, &current, max_n, known, summaries)
                }
                Search::Exhaustive => exhaustive(prep, &current, max_n, summaries),
                Search::Staircase => staircase(prep, &current, max_n, known, summaries),
                Search::Probe => probing(prep, &current, max_n, summaries),
            };
            // Tagged even where the search stopped part way.
            for s in &mut summaries[first..] {
                s.widenings = widenings;
            }
            let mut candidates = searched?;
            if want_condition {
                prep.condition_numbers(&current, &mut candidates, &mut summaries[first..])?;
            }
            if let Some(best) = select(candidates, settings.selection) {
                let function = best.function.expect("accepted splits carry a function");
                let errors = error_figures(&function, &current);
                return Ok(FitReport {
                    n_p: best.summary.n_p,
                    n_q: best.summary.n_q,
                    depth: best.summary.depth,
                    condition_number: best.summary.condition_number,
                    errors,
                    verification: best.verification.expect("accepted splits are verified"),
                    poles: best.poles,
                    seconds: self.start.elapsed().as_secs_f64(),
                    samples: self.data.len(),
                    splits_tried: summaries.len(),
                    widenings,
                    interval_scale: settings.widen_factor.powi(widenings as i32),
                    backend: settings.backend.name().to_string(),
                    selection: settings.selection,
                    search: settings.search,
                    splits: std::mem::take(summaries),
                    function,
                });
            }
            if widenings < settings.max_widenings {
                current = current.widened(settings.widen_factor);
            }
        }
        Err(self.no_fit(std::mem::take(summaries)))
    }

    /// [`FitSettings::with_existence_only`]: whether the sweep would return
    /// a fit, from the widest level's largest budget; where that proves
    /// neither, the sweep from the start with the flag ignored.
    fn settle(&self, mut summaries: Vec<SplitSummary>) -> Result<FitReport, FitError> {
        let prep = self.prep;
        prep.may_settle.store(false, Ordering::Relaxed);
        let exists = || FitError::FitExists {
            splits_tried: prep.solved.load(Ordering::Relaxed),
        };
        if prep.accepted_one.load(Ordering::Relaxed) {
            return Err(exists());
        }
        let widest = self.widest();
        if self.covered(&widest) {
            return Err(self.no_fit(summaries));
        }
        match largest_budget(prep, &widest, (self.max_n, false), &mut summaries)? {
            Tops::Refused => Err(self.no_fit(summaries)),
            Tops::Fit => Err(exists()),
            // Every level's splits solved again, each from its own start.
            Tops::Open => self.levels(&mut Vec::new()),
        }
    }
}

/// What the largest budget's splits at the widest level say
/// ([`largest_budget`]).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Tops {
    /// Every split refused with a certificate of infeasibility.
    Refused,
    /// One was accepted.
    Fit,
    /// One was refused without a certificate.
    Open,
}

/// The splits `(max_n - n_q, n_q)` of the largest budget at the widest
/// widening level (`data`), for `n_q = 1, 2, ...` in turn until one is not
/// refused with a certificate of infeasibility; their summaries are
/// appended to `summaries`, at that level. Without `until_open`, on past
/// such a split until one is accepted (a fit is what settling asks for).
/// Every split of every budget up
/// to `max_n` is nested in one of them (a basis of fewer coefficients is
/// one of more with zeros), so [`Tops::Refused`] proves that `data` has no
/// fit, nor has any level of narrower intervals. A staircase walk of the
/// largest budget solves the same splits from the same start, so
/// [`Tops::Fit`] means that a staircase sweep would return a fit.
///
/// A sweep whose exact intervals have no fit asks this before searching
/// the levels between: where the widest level has no fit either, one walk
/// of the largest budget's splits proves it for every level, instead of a
/// search of every budget at each. Otherwise the sweep goes on as it would
/// have, and each level's search solves its own splits from its own start
/// (the fit returned does not depend on this check), at the cost of the
/// splits solved here: one, where the largest budget's first split fits.
fn largest_budget(
    prep: &Prepared<'_>,
    data: &IntervalData,
    (max_n, until_open): (usize, bool),
    summaries: &mut Vec<SplitSummary>,
) -> Result<Tops, FitError> {
    let mut active = Vec::new();
    let level = prep.settings.max_widenings;
    let mut verdict = if max_n > 1 { Tops::Refused } else { Tops::Open };
    for n_q in 1..max_n {
        let mut f = prep.solve(data, max_n - n_q, n_q, false, &mut active)?;
        f.summary.widenings = level;
        let (refused, accepted) = (f.summary.proved_infeasible(), f.summary.accepted);
        summaries.push(f.summary);
        if accepted {
            return Ok(Tops::Fit);
        }
        if !refused {
            verdict = Tops::Open;
            if until_open {
                break;
            }
        }
    }
    Ok(verdict)
}

/// The settings' criterion among accepted splits of one budget.
fn select(candidates: Vec<SplitFit>, selection: Selection) -> Option<SplitFit> {
    candidates
        .into_iter()
        .filter(|f| f.summary.accepted)
        .min_by(|a, b| match selection {
            Selection::ConditionNumber => {
                let key = |f: &SplitFit| {
                    f.summary
                        .condition_number
                        .filter(|v| !v.is_nan())
                        .unwrap_or(f64::INFINITY)
                };
                key(a).total_cmp(&key(b))
            }
            Selection::Depth => b.summary.depth.total_cmp(&a.summary.depth),
        })
}

/// Every split of each budget from the smallest up, a budget's splits in
/// parallel; returns the splits of the first budget with an accepted one
/// (empty when none up to `max_n` is).
fn exhaustive(
    prep: &Prepared<'_>,
    data: &IntervalData,
    max_n: usize,
    summaries: &mut Vec<SplitSummary>,
) -> Result<Vec<SplitFit>, FitError> {
    for n in prep.settings.min_coeffs..=max_n {
        let nps: Vec<usize> = (1..n).collect();
        let fits = solve_budget(prep, data, n, &nps, summaries)?;
        if fits.iter().any(|f| f.summary.accepted) {
            return Ok(fits);
        }
    }
    Ok(Vec::new())
}

/// The splits `(n_p, n - n_p)` of budget `n` for each `n_p` of `nps`, in
/// parallel, each from scratch, reporting progress; their summaries are
/// appended to `summaries`.
fn solve_budget(
    prep: &Prepared<'_>,
    data: &IntervalData,
    n: usize,
    nps: &[usize],
    summaries: &mut Vec<SplitSummary>,
) -> Result<Vec<SplitFit>, FitError> {
    let done = AtomicUsize::new(0);
    let fits: Vec<SplitFit> = nps
        .par_iter()
        .map(|&np| {
            let r = prep.solve(data, np, n - np, false, &mut Vec::new());
            let k = done.fetch_add(1, Ordering::Relaxed) + 1;
            if let Some(cb) = &prep.settings.progress {
                cb(Progress {
                    budget: n,
                    done: k,
                    total: nps.len(),
                });
            }
            r
        })
        .collect::<Result<_, _>>()?;
    summaries.extend(fits.iter().map(|f| f.summary.clone()));
    Ok(fits)
}

/// The splits of the single budget `n` in increasing condition number
/// (computed in parallel, a blocked QR each, on the rows before any pole
/// rows as [`Selection::ConditionNumber`] defines it), solved one after
/// another until one is accepted: the split that the selection would
/// choose among all the accepted ones, without solving every feasible
/// split to its optimum (ties go to the smaller `n_q`, as in the searches'
/// order).
fn by_condition(
    prep: &Prepared<'_>,
    data: &IntervalData,
    n: usize,
    known: &KnownInfeasible,
    summaries: &mut Vec<SplitSummary>,
) -> Result<Vec<SplitFit>, FitError> {
    let mut order: Vec<(f64, usize)> = (1..n)
        .into_par_iter()
        .filter(|&n_q| n - n_q > known.up_to(n_q))
        .map(|n_q| {
            let n_p = n - n_q;
            let problem = prep.problem(data, n_p, n_q, &prep.base_rows(n_p, n_q))?;
            Ok((condition_number(&problem), n_q))
        })
        .collect::<Result<_, FitError>>()?;
    // NaN (a failed factorisation) last, as the selection ranks it.
    let rank = |k: f64| if k.is_nan() { f64::INFINITY } else { k };
    order.sort_by(|a, b| rank(a.0).total_cmp(&rank(b.0)));
    let mut active = Vec::new();
    for (done, &(k, n_q)) in order.iter().enumerate() {
        let mut f = prep.solve(data, n - n_q, n_q, false, &mut active)?;
        if f.summary.accepted {
            // The selection's figure, already computed for the order.
            f.summary.condition_number = Some(k);
        }
        summaries.push(f.summary.clone());
        if let Some(cb) = &prep.settings.progress {
            cb(Progress {
                budget: n,
                done: done + 1,
                total: order.len(),
            });
        }
        if f.summary.accepted {
            return Ok(vec![f]);
        }
    }
    Ok(Vec::new())
}

/// The probe splits of budget `n` ([`crate::PROBE_FRACTIONS`]).
fn probe(
    prep: &Prepared<'_>,
    data: &IntervalData,
    n: usize,
    summaries: &mut Vec<SplitSummary>,
) -> Result<Vec<SplitFit>, FitError> {
    let mut nps: Vec<usize> = crate::PROBE_FRACTIONS
        .iter()
        .map(|f| ((f * n as f64).round() as usize).clamp(1, n - 1))
        .collect();
    nps.dedup();
    solve_budget(prep, data, n, &nps, summaries)
}

/// [`Search::Probe`]: budgets doubling from the smallest up to `max_n`, then
/// bisected between the last infeasible and the first feasible one.
/// Returns the probe splits of the smallest feasible budget found (empty
/// when none is).
fn probing(
    prep: &Prepared<'_>,
    data: &IntervalData,
    max_n: usize,
    summaries: &mut Vec<SplitSummary>,
) -> Result<Vec<SplitFit>, FitError> {
    let accepted = |fits: &[SplitFit]| fits.iter().any(|f| f.summary.accepted);
    let mut n = prep.settings.min_coeffs;
    let mut infeasible = n - 1;
    let (mut feasible, mut found) = loop {
        let fits = probe(prep, data, n, summaries)?;
        if accepted(&fits) {
            break (n, fits);
        }
        infeasible = n;
        if n >= max_n {
            return Ok(Vec::new());
        }
        n = (2 * n).min(max_n);
    };
    while feasible - infeasible > 1 {
        let mid = infeasible + (feasible - infeasible) / 2;
        let fits = probe(prep, data, mid, summaries)?;
        if accepted(&fits) {
            (feasible, found) = (mid, fits);
        } else {
            infeasible = mid;
        }
    }
    Ok(found)
}

/// The staircase search ([`Search::Staircase`]) under budget limits that
/// double from `max(2 min, 8)` up to `max_n`, so small answers cost small
/// solves; a limit that finds nothing proves every split within it
/// infeasible. Returns the accepted splits of the smallest budget found.
fn staircase(
    prep: &Prepared<'_>,
    data: &IntervalData,
    max_n: usize,
    known: &KnownInfeasible,
    summaries: &mut Vec<SplitSummary>,
) -> Result<Vec<SplitFit>, FitError> {
    let mut limit = (2 * prep.settings.min_coeffs).max(8).min(max_n);
    let mut infeasible_up_to = 0;
    loop {
        let found = staircase_within(prep, data, limit, infeasible_up_to, known, summaries)?;
        if !found.is_empty() || limit == max_n {
            return Ok(found);
        }
        infeasible_up_to = limit;
        limit = (2 * limit).min(max_n);
    }
}

/// One staircase walk over the splits with `n_p + n_q <= limit`, knowing
/// those with `n_p + n_q <= infeasible_up_to` infeasible, and those of
/// `known`: for `n_q = 1, 2,
/// ...` the smallest accepted `n_p` by bisection, below both the previous
/// column's (nested bases) and the best budget so far.
fn staircase_within(
    prep: &Prepared<'_>,
    data: &IntervalData,
    limit: usize,
    infeasible_up_to: usize,
    known: &KnownInfeasible,
    summaries: &mut Vec<SplitSummary>,
) -> Result<Vec<SplitFit>, FitError> {
    let settings = prep.settings;
    let mut best_budget = limit;
    let mut best: Vec<SplitFit> = Vec::new();
    // Smallest accepted n_p of the last column that had one.
    let mut p_bound = limit - 1;
    // Each split starts from the active set of the one solved before it:
    // the walk moves one column or one bisection step at a time.
    let mut active = Vec::new();
    let mut solve = |np: usize, nq: usize| -> Result<SplitFit, FitError> {
        let f = prep.solve(data, np, nq, false, &mut active)?;
        summaries.push(f.summary.clone());
        if let Some(cb) = &settings.progress {
            cb(Progress {
                budget: np + nq,
                done: nq,
                total: limit - 1,
            });
        }
        Ok(f)
    };
    for nq in 1..limit {
        if nq >= best_budget {
            break;
        }
        let hi = p_bound.min(best_budget - nq);
        let lo = settings
            .min_coeffs
            .max(infeasible_up_to + 1)
            .saturating_sub(nq)
            .max(known.up_to(nq) + 1);
        if hi < lo {
            continue;
        }
        let top = solve(hi, nq)?;
        if !top.summary.accepted {
            continue;
        }
        // Invariant: `found` is accepted at n_p = b; below `a` none is.
        let (mut a, mut b, mut found) = (lo, hi, top);
        while a < b {
            let mid = a + (b - a) / 2;
            let f = solve(mid, nq)?;
            if f.summary.accepted {
                b = mid;
                found = f;
            } else {
                a = mid + 1;
            }
        }
        p_bound = b;
        let budget = b + nq;
        if best.is_empty() || budget < best_budget {
            best_budget = budget;
            best = vec![found];
        } else if budget == best_budget {
            best.push(found);
        }
    }
    Ok(best)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::BasisFamily;

    #[test]
    fn verifying_from_the_design_matches_evaluating_the_basis() {
        let n = 400;
        let points: Vec<f64> = (0..n)
            .flat_map(|i| {
                let t = i as f64 / n as f64;
                [t, (7.0 * t).fract(), (13.0 * t).fract()]
            })
            .collect();
        let value = |i: usize| 1.0 + points[3 * i] * points[3 * i + 1] + 0.5 * points[3 * i + 2];
        let lo = (0..n).map(|i| 0.97 * value(i)).collect();
        let hi = (0..n).map(|i| 1.03 * value(i)).collect();
        let data = IntervalData::new(3, points.clone(), lo, hi).unwrap();
        let basis = Basis::new(BasisFamily::Chebyshev, data.bounding_box(), 20).unwrap();
        let design = DesignMatrix::new(&basis, &data);
        let f = RationalFunction::new(
            basis.with_len(10).unwrap(),
            (0..10).map(|k| 1.0 / (1.0 + k as f64)).collect(),
            (0..6)
                .map(|k| if k == 0 { 1.0 } else { 0.05 / k as f64 })
                .collect(),
        )
        .unwrap();
        let extra = vec![vec![0.5; 16]];
        let direct = verify(&f, &data, &extra);
        let from_design = verify_with(&f, &data, &extra, |i, phi| {
            phi.copy_from_slice(&design.row(i)[..phi.len()]);
        });
        assert_eq!(direct, from_design);
    }
}
