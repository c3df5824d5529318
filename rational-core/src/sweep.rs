//! The sweep over coefficient budgets: the splits each budget tries (all,
//! by condition, probes or the staircase), the widening levels, and the
//! selection among accepted splits. One split's solve is in `fit.rs`.

use crate::fit::{Centring, Prepared, SplitFit};
use crate::problem::{condition_number, ExtraConstraints, NoExtraConstraints};
use crate::report::{FitReport, SplitSummary};
use crate::verify::error_figures;
use crate::{FitError, FitSettings, IntervalData, NoFitProof, Progress, Search, Selection};
use rayon::prelude::*;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// The sweep's largest budget: the settings' `max_coeffs`, at most one
/// coefficient per sample; too few samples for `min_coeffs` is an error.
fn check_sizes(data: &IntervalData, settings: &FitSettings) -> Result<usize, FitError> {
    if data.len() < settings.min_coeffs {
        return Err(FitError::TooFewSamples {
            samples: data.len(),
            coeffs: settings.min_coeffs,
        });
    }
    Ok(settings.max_coeffs.min(data.len()))
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
                let best = prep.centre(best, &current)?;
                if best.summary.centred {
                    let split = (best.summary.n_p, best.summary.n_q);
                    if let Some(s) = summaries[first..]
                        .iter_mut()
                        .rev()
                        .find(|s| s.accepted && (s.n_p, s.n_q) == split)
                    {
                        s.centred = true;
                    }
                }
                let function = best.function.expect("accepted splits carry a function");
                let errors = error_figures(&function, &current);
                let largest_margin = match best.centring {
                    Centring::Replaced(point) => Some(point),
                    _ => None,
                };
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
                    centred: best.summary.centred,
                    largest_margin,
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
