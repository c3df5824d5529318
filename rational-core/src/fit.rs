//! Solving one split P(n_p, n_q): its program, screening, verification
//! and pole control. The sweep over coefficient budgets is in `sweep.rs`.

use crate::poles::{bernstein_margin, bernstein_rows, grid_check, grid_size};
use crate::problem::{
    build_problem_in, condition_number, DesignMatrix, ExtraConstraints, Refinement, SharedDesign,
};
use crate::report::{LargestMargin, PoleReport, SplitSummary};
use crate::screen::{data_row, Screened, Subsample};
use crate::verify::{verify, verify_with, Verification};
use crate::{Basis, FitError, FitSettings, IntervalData, PoleControl, RationalFunction};
use qp_backends::{CancelFlag, LdpProblem, Solution, Status};
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
    /// Where the split stands with centring
    /// ([`FitSettings::with_centred_fit`]).
    pub(crate) centring: Centring,
}

/// A split's centring ([`FitSettings::with_centred_fit`]).
#[derive(Debug, Clone, Default)]
pub(crate) enum Centring {
    /// Not asked for, not accepted, or tried and kept as it was.
    #[default]
    None,
    /// The accepted largest-margin point, kept for centring once the
    /// sweep has chosen.
    Pending(MarginPoint),
    /// Centred: the largest-margin point it replaced.
    Replaced(Box<LargestMargin>),
}

/// A split's accepted solution of P(n_p, n_q) and the rows of that
/// program (pole rows included).
#[derive(Debug, Clone)]
pub(crate) struct MarginPoint {
    pub(crate) x: Vec<f64>,
    pub(crate) rows: Vec<Vec<f64>>,
}

/// Everything the splits of a sweep share.
pub(crate) struct Prepared<'a> {
    pub(crate) basis: Basis,
    /// Basis values at the samples, as many functions as the widest split
    /// so far needed (grown by doubling): a search whose answer is small
    /// never evaluates, nor stores, the whole basis. The settings' shared
    /// design when it holds these points and basis, else this fit's own.
    shared: Option<SharedDesign>,
    own: SharedDesign,
    /// The subsample each split is solved on first, for large data.
    pub(crate) screen: Option<Subsample>,
    data: &'a IntervalData,
    pub(crate) settings: &'a FitSettings,
    extra: &'a dyn ExtraConstraints,
    /// Bounds are divided by this in P(n_p, n_q); the numerator is scaled back.
    pub(crate) scale: f64,
    /// Splits started, reported when the sweep is cancelled.
    pub(crate) solved: AtomicUsize,
    /// Stopped by [`FitSettings::with_existence_only`]'s flag.
    pub(crate) interrupted: AtomicBool,
    /// A sweep that may be stopped to settle whether a fit exists (not a
    /// single split, nor a sweep settling it already).
    pub(crate) may_settle: AtomicBool,
    /// A split was accepted: a staircase sweep returns a fit of the level
    /// it was accepted at, if not of one before (the widest level's
    /// largest budget counts too).
    pub(crate) accepted_one: AtomicBool,
}

impl<'a> Prepared<'a> {
    pub(crate) fn new(
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
    pub(crate) fn base_rows(&self, n_p: usize, n_q: usize) -> Vec<Vec<f64>> {
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
    pub(crate) fn problem(
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
    pub(crate) fn design_of_width(&self, width: usize) -> Result<DesignMatrix, FitError> {
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
    pub(crate) fn verify(
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
    pub(crate) fn candidate(
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

    /// Solves the program of a split from the warm start, recording the
    /// data rows of its active set in `active` (and in the screen's memory).
    fn solve_program(
        &self,
        problem: &LdpProblem,
        warm: Vec<usize>,
        data: &IntervalData,
        active: &mut Vec<usize>,
    ) -> Result<Solution, FitError> {
        let mut options = self.settings.solve_options.clone().with_warm_start(warm);
        if !self.settings.cancel.is_empty() {
            options = options.with_cancel(CancelFlag::any(self.settings.cancel.clone()));
        }
        let sol = self.settings.backend.solve(problem, &options)?;
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
        Ok(sol)
    }

    /// Solves P(n_p, n_q) with its pole rounds. `active` is a warm start on
    /// entry (the active data rows of a neighbouring split; a hint that
    /// saves iterations and changes no optimum) and holds this split's
    /// active data rows on return.
    pub(crate) fn solve(
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
                centring: Centring::None,
            });
        }
        // Each exit of the loop names the outcome; the timing and the result
        // are assembled once below.
        let mut centring = Centring::None;
        let (function, verification) = loop {
            let problem = self.problem(data, n_p, n_q, &rows)?;
            let sol = self.solve_program(&problem, warm, data, active)?;
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
                let measured = claimed
                    .then(|| self.candidate(&split_basis, &sol.x, n_p).ok())
                    .flatten()
                    .map(|f| verify(&f, data, &rows));
                summary.note = unusable_note(&sol, claimed, measured.as_ref());
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
            if self.settings.centred {
                centring = Centring::Pending(MarginPoint {
                    x: sol.x.clone(),
                    rows: rows.clone(),
                });
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
            centring,
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
    pub(crate) fn condition_numbers(
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
    pub(crate) fn refine(
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

/// Why a backend's point is not a fit. A point the backend claims but that
/// is not strictly inside is still measured by our verifier, so callers see
/// why.
fn unusable_note(sol: &Solution, claimed: bool, measured: Option<&Verification>) -> String {
    if claimed {
        format!(
            "backend reported {}; verifier found violation {:.2e}",
            sol.status,
            measured.map_or(sol.residuals.max_violation, |v| v.max_violation)
        )
    } else {
        sol.status.to_string()
    }
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
    let fit = prep.solve(data, n_p, n_q, true, &mut Vec::new())?;
    prep.centre(fit, data)
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
