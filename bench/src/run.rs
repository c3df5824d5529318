//! The benchmark executor: times every (instance, size, tolerance, split,
//! backend) case with a warm-up and repetitions, measures every point with
//! our verifier, and skips cases predicted to exceed the time budget.

use super::aaa::{aaa, Barycentric};
use super::instances::{Instance, InstanceFile, Sampled};
use anyhow::Result;
use rational_core::verify::{error_figures, verify};
use rational_core::{
    fit, Backend, FitError, FitSettings, Fitter, IntervalData, PoleControl, Selection,
};
use std::collections::HashMap;
use std::path::Path;
use std::time::Instant;

/// One line of `results.csv` (fields in the order of its columns).
#[derive(Debug, Clone, Default, serde::Serialize, serde::Deserialize)]
pub struct Row {
    /// Instance name.
    pub instance: String,
    /// split, sweep, sweep+grid or aaa.
    pub mode: String,
    /// Backend (or `aaa`).
    pub backend: String,
    /// Relative half-width of the intervals.
    pub rel_tol: f64,
    /// The size as declared (samples or grid).
    pub size: String,
    /// Samples fitted.
    pub samples: usize,
    /// Numerator coefficients (AAA: support points).
    pub n_p: usize,
    /// Denominator coefficients (AAA: support points).
    pub n_q: usize,
    /// Backend status, `skipped`, `error` or, for AAA, `aaa`.
    pub status: String,
    /// Inside every interval by our f64 verifier.
    pub verified: bool,
    /// Depth of the backend's point.
    pub depth: Option<f64>,
    /// Largest violation measured by our verifier (relative to the interval's scale).
    pub max_violation: Option<f64>,
    /// Largest relative error against the data values.
    pub max_rel_error: Option<f64>,
    /// Mean relative error.
    pub mean_rel_error: Option<f64>,
    /// Median wall time of the timed runs.
    pub median_s: Option<f64>,
    /// Fastest run.
    pub min_s: Option<f64>,
    /// Slowest run.
    pub max_s: Option<f64>,
    /// Timed runs after the warm-up (0: the warm-up alone was timed).
    pub reps: usize,
    /// Backend iterations of the last run.
    pub iterations: Option<usize>,
    /// Threads of the run (set when written).
    pub threads: usize,
    /// Commit of the run (set when written).
    pub commit: String,
    /// Why, for skips, errors and rejected points.
    pub note: String,
}

impl Row {
    /// Marks the case as failed with `e` as the note.
    fn fail(&mut self, e: impl std::fmt::Display) {
        self.status = "error".into();
        self.note = e.to_string();
    }
}

/// How a run is carried out.
pub struct RunOptions<'a> {
    /// `--quick`.
    pub quick: bool,
    /// Backends to run.
    pub backends: Vec<Backend>,
    /// The measured-data folder.
    pub data_dir: Option<&'a Path>,
}

/// Timing of one case.
struct Timed<T> {
    last: T,
    times: Vec<f64>,
    reps: usize,
}

/// Runs `f` once as warm-up, then `max_reps` timed runs when the warm-up
/// took under 0.2 s, 3 under 2 s, 1 under a quarter of `budget_s`; a slower
/// warm-up is the only timing.
fn timed<T>(budget_s: f64, max_reps: usize, mut f: impl FnMut() -> T) -> Timed<T> {
    let t = Instant::now();
    let mut last = f();
    let warm = t.elapsed().as_secs_f64();
    let reps = if warm < 0.2 {
        max_reps
    } else if warm < 2.0 {
        max_reps.min(3)
    } else if warm < 0.25 * budget_s {
        1
    } else {
        0
    };
    if reps == 0 {
        return Timed {
            last,
            times: vec![warm],
            reps,
        };
    }
    let mut times = Vec::with_capacity(reps);
    for _ in 0..reps {
        let t = Instant::now();
        last = f();
        times.push(t.elapsed().as_secs_f64());
    }
    Timed { last, times, reps }
}

/// Median of a non-empty slice.
pub fn median(v: &[f64]) -> f64 {
    let mut s = v.to_vec();
    s.sort_by(f64::total_cmp);
    let n = s.len();
    if n % 2 == 1 {
        s[n / 2]
    } else {
        0.5 * (s[n / 2 - 1] + s[n / 2])
    }
}

fn set_times(row: &mut Row, times: &[f64], reps: usize) {
    row.median_s = Some(median(times));
    row.min_s = times.iter().copied().reduce(f64::min);
    row.max_s = times.iter().copied().reduce(f64::max);
    row.reps = reps;
}

/// Runs every instance of `file`, printing one line per case, and returns
/// the rows.
pub fn run(file: &InstanceFile, opts: &RunOptions) -> Vec<Row> {
    let mut rows = Vec::new();
    for inst in file.instances.iter().filter(|i| i.quick || !opts.quick) {
        // Rows of the sizes that ran are kept; the error ends the instance.
        if let Err(e) = run_instance(inst, file, opts, &mut rows) {
            println!("{:<24} error: {}", inst.name, crate::output::chain_text(&e));
            rows.push(Row {
                instance: inst.name.clone(),
                mode: "split".into(),
                backend: "-".into(),
                status: "error".into(),
                note: crate::output::chain_text(&e),
                ..Row::default()
            });
        }
    }
    rows
}

fn run_instance(
    inst: &Instance,
    file: &InstanceFile,
    opts: &RunOptions,
    rows: &mut Vec<Row>,
) -> Result<()> {
    let (budget, max_reps) = if opts.quick {
        (
            file.settings.quick_budget_s,
            file.settings.quick_repetitions,
        )
    } else {
        (file.settings.budget_s, file.settings.repetitions)
    };
    let source = inst.source(opts.data_dir)?;
    // (backend, split, tol) -> (samples, fastest time) of the last size run.
    let mut last_cost: HashMap<(Backend, [usize; 2], u64), (usize, f64)> = HashMap::new();
    for size in inst.sizes(opts.quick) {
        let sampled = inst.sample(&source, &size)?;
        for &tol in &inst.rel_tol {
            let data = sampled.intervals(tol)?;
            let base = Row {
                instance: inst.name.clone(),
                rel_tol: tol,
                size: size.to_string(),
                samples: data.len(),
                ..Row::default()
            };
            let mut split_medians: HashMap<Backend, f64> = HashMap::new();
            for &split in inst.splits(opts.quick) {
                for &backend in &opts.backends {
                    let mut row = Row {
                        mode: "split".into(),
                        backend: backend.name().into(),
                        n_p: split[0],
                        n_q: split[1],
                        ..base.clone()
                    };
                    if let Some(note) = over_sample_limit(backend, data.len(), file) {
                        push_skipped(row, note, rows);
                        continue;
                    }
                    let key = (backend, split, tol.to_bits());
                    if let Some(&(s0, t0)) = last_cost.get(&key) {
                        // Quadratic growth: the simplex and interior-point
                        // backends grow faster than linearly in practice, and
                        // a fast infeasible answer at one size says little
                        // about the next.
                        let predicted = t0 * (data.len() as f64 / s0 as f64).powi(2);
                        if predicted > budget {
                            let note =
                                format!("predicted {predicted:.0} s per run (budget {budget} s)");
                            push_skipped(row, note, rows);
                            continue;
                        }
                    }
                    split_row(&mut row, &data, backend, budget, max_reps);
                    if let Some(t) = row.min_s {
                        last_cost.insert(key, (data.len(), t));
                        let m = split_medians.entry(backend).or_insert(0.0);
                        *m = m.max(row.median_s.unwrap_or(t));
                    }
                    print_row(&row);
                    rows.push(row);
                }
            }
            if let Some(n) = inst.sweep {
                let limits = CaseLimits {
                    backends: &opts.backends,
                    file,
                    budget,
                    max_reps,
                };
                sweep_rows(n, &data, &base, &split_medians, &limits, rows);
            }
        }
        if inst.aaa {
            if let Some((x, v)) = sampled.one_dimensional() {
                aaa_rows(
                    inst,
                    opts,
                    &sampled,
                    x,
                    v,
                    &size.to_string(),
                    budget,
                    max_reps,
                    rows,
                )?;
            }
        }
    }
    Ok(())
}

/// What the cases of one instance share.
#[derive(Clone, Copy)]
struct CaseLimits<'a> {
    /// The backends to run.
    backends: &'a [Backend],
    /// The instance file (its comparison sample limit).
    file: &'a InstanceFile,
    /// Seconds per case.
    budget: f64,
    /// Repetitions per case.
    max_reps: usize,
}

/// The sweep rows of one sample size and tolerance, with and without pole
/// control, for each backend: skipped when the slowest split's median times
/// the `n - 1` budgets predicts more than the time budget.
fn sweep_rows(
    n: usize,
    data: &IntervalData,
    base: &Row,
    split_medians: &HashMap<Backend, f64>,
    limits: &CaseLimits,
    rows: &mut Vec<Row>,
) {
    let CaseLimits {
        backends,
        file,
        budget,
        max_reps,
    } = *limits;
    for &backend in backends {
        for (mode, poles) in [
            ("sweep", PoleControl::None),
            ("sweep+grid", PoleControl::default()),
        ] {
            let mut row = Row {
                mode: mode.into(),
                backend: backend.name().into(),
                ..base.clone()
            };
            if let Some(note) = over_sample_limit(backend, data.len(), file) {
                push_skipped(row, note, rows);
                continue;
            }
            let per_split = split_medians.get(&backend).copied();
            let predicted = per_split.map(|t| t * (n - 1) as f64);
            if predicted.is_none_or(|p| p > budget) {
                row.status = "skipped".into();
                row.note = match predicted {
                    Some(p) => format!("predicted {p:.0} s (budget {budget} s)"),
                    None => "no timed split of this backend at this size".into(),
                };
            } else {
                sweep_row(&mut row, data, backend, n, poles, budget, max_reps);
            }
            print_row(&row);
            rows.push(row);
        }
    }
}

/// Records a case that was not run, and why.
fn push_skipped(mut row: Row, note: String, rows: &mut Vec<Row>) {
    row.status = "skipped".into();
    row.note = note;
    print_row(&row);
    rows.push(row);
}

/// Why a comparison backend is not run on `samples` samples, if it is not.
fn over_sample_limit(backend: Backend, samples: usize, file: &InstanceFile) -> Option<String> {
    let limit = file.settings.comparison_max_samples;
    (backend != Backend::Native && samples > limit)
        .then(|| format!("comparison backends stop at {limit} samples"))
}

fn split_row(row: &mut Row, data: &IntervalData, backend: Backend, budget: f64, max_reps: usize) {
    let settings = FitSettings::default()
        .with_backend(backend)
        .map(|s| s.with_pole_control(PoleControl::None));
    let settings = match settings {
        Ok(s) => s,
        Err(e) => return row.fail(e),
    };
    let fitter = Fitter::new(data).settings(settings);
    let t = timed(budget, max_reps, || fitter.split(row.n_p, row.n_q));
    match t.last {
        Ok(f) => {
            set_times(row, &t.times, t.reps);
            let s = &f.summary;
            row.status = s.status.to_string();
            row.verified = s.accepted;
            row.depth = Some(s.depth);
            row.iterations = Some(s.iterations);
            row.note = s.note.clone();
            row.max_violation = f.verification.map(|v| v.max_violation);
            if let Some(func) = &f.function {
                let e = error_figures(func, data);
                row.max_rel_error = Some(e.max_relative);
                row.mean_rel_error = Some(e.mean_relative);
            }
        }
        Err(e) => row.fail(e),
    }
}

fn sweep_row(
    row: &mut Row,
    data: &IntervalData,
    backend: Backend,
    budget_coeffs: usize,
    poles: PoleControl,
    budget: f64,
    max_reps: usize,
) {
    let settings = FitSettings::default()
        .with_backend(backend)
        .and_then(|s| s.with_coeff_range(budget_coeffs, budget_coeffs))
        .map(|s| {
            s.with_selection(Selection::ConditionNumber)
                .with_pole_control(poles)
        });
    let settings = match settings {
        Ok(s) => s,
        Err(e) => return row.fail(e),
    };
    let t = timed(budget, max_reps, || fit(data, &settings));
    set_times(row, &t.times, t.reps);
    match t.last {
        Ok(rep) => {
            let feasible = rep.splits.iter().filter(|s| s.accepted).count();
            row.n_p = rep.n_p;
            row.n_q = rep.n_q;
            row.status = format!("{feasible}/{} feasible", rep.splits.len());
            let v = verify(&rep.function, data, &[]);
            row.verified = v.satisfied;
            row.max_violation = Some(v.max_violation);
            row.depth = Some(rep.depth);
            row.iterations = Some(rep.splits.iter().map(|s| s.iterations).sum());
            row.max_rel_error = Some(rep.errors.max_relative);
            row.mean_rel_error = Some(rep.errors.mean_relative);
            row.note = format!("chosen by condition number among {feasible} feasible splits");
        }
        Err(FitError::NoFeasibleFit { .. }) => {
            row.status = format!("0/{} feasible", budget_coeffs - 1);
        }
        Err(e) => row.fail(e),
    }
}

/// AAA up to the largest `n_q` of the splits; one row per support count
/// `m` in the splits' `n_q` (type `(m-1, m-1)`, the degrees of split
/// `(m, m)`) and tolerance. Times are cumulative to step `m`.
#[allow(clippy::too_many_arguments)]
fn aaa_rows(
    inst: &Instance,
    opts: &RunOptions,
    sampled: &Sampled,
    x: &[f64],
    v: &[f64],
    size: &str,
    budget: f64,
    max_reps: usize,
    rows: &mut Vec<Row>,
) -> Result<()> {
    let mut ms: Vec<usize> = inst.splits(opts.quick).iter().map(|s| s[1]).collect();
    ms.sort_unstable();
    ms.dedup();
    let max_m = *ms.last().expect("splits are not empty");
    let t = timed(budget, max_reps, || {
        let start = Instant::now();
        let mut steps: Vec<(Barycentric, f64)> = Vec::new();
        let r = aaa(x, v, max_m, 0.0, |b| {
            steps.push((b.clone(), start.elapsed().as_secs_f64()))
        });
        r.map(|_| steps)
    });
    let runs = t.times.len();
    let steps = t.last?;
    // Cumulative times of the timed runs are not kept apart; scale the last
    // run's step times to the median of the whole-run times.
    let total = steps.last().map_or(0.0, |s| s.1).max(f64::MIN_POSITIVE);
    let whole = median(&t.times);
    let intervals = inst
        .rel_tol
        .iter()
        .map(|&tol| Ok((tol, sampled.intervals(tol)?)))
        .collect::<Result<Vec<_>>>()?;
    for &m in &ms {
        let Some((b, at)) = steps.get(m - 1).or(steps.last()) else {
            continue;
        };
        let fitted: Vec<f64> = x.iter().map(|&xi| b.eval(xi)).collect();
        for (tol, data) in &intervals {
            let tol = *tol;
            let mut row = Row {
                instance: inst.name.clone(),
                mode: "aaa".into(),
                backend: "aaa".into(),
                rel_tol: tol,
                size: size.into(),
                samples: x.len(),
                n_p: m,
                n_q: m,
                status: "aaa".into(),
                reps: t.reps,
                ..Row::default()
            };
            let (mut viol, mut outside, mut max_rel, mut sum_rel) = (0.0_f64, 0usize, 0.0_f64, 0.0);
            for i in 0..x.len() {
                let (lo, hi, r) = (data.lo()[i], data.hi()[i], fitted[i]);
                let out = if r.is_finite() {
                    (lo - r).max(r - hi).max(0.0)
                } else {
                    f64::INFINITY
                };
                if out > 0.0 {
                    outside += 1;
                }
                viol = viol.max(out / lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE));
                let rel = (r - v[i]).abs() / v[i].abs().max(f64::MIN_POSITIVE);
                max_rel = max_rel.max(rel);
                sum_rel += rel;
            }
            row.verified = outside == 0;
            row.max_violation = Some(viol);
            row.max_rel_error = Some(max_rel);
            row.mean_rel_error = Some(sum_rel / x.len() as f64);
            let step_time = at / total * whole;
            row.median_s = Some(step_time);
            row.min_s = Some(step_time);
            row.max_s = Some(step_time);
            row.note = format!(
                "type ({0},{0}); {outside} of {1} samples outside the intervals; {runs} timed run(s){2}",
                m - 1,
                x.len(),
                if b.support() < m { format!("; converged at m = {}", b.support()) } else { String::new() }
            );
            print_row(&row);
            rows.push(row);
        }
    }
    Ok(())
}

fn fmt_opt(v: Option<f64>) -> String {
    v.map_or_else(|| "-".into(), |v| format!("{v:.3e}"))
}

fn print_row(r: &Row) {
    println!(
        "{:<24} {:<10} {:<9} {:>8.0e} {:>8} {:>7} {:<18} {:>5} {:>10} {:>10} {:>10}  {}",
        r.instance,
        r.mode,
        r.backend,
        r.rel_tol,
        r.samples,
        format!("{},{}", r.n_p, r.n_q),
        r.status,
        if r.verified { "yes" } else { "no" },
        fmt_opt(r.max_rel_error),
        fmt_opt(r.max_violation),
        r.median_s.map_or_else(|| "-".into(), |t| format!("{t:.4}")),
        r.note
    );
}

/// The header line printed before the rows.
pub fn print_header() {
    println!(
        "{:<24} {:<10} {:<9} {:>8} {:>8} {:>7} {:<18} {:>5} {:>10} {:>10} {:>10}  note",
        "instance",
        "mode",
        "backend",
        "rel tol",
        "samples",
        "split",
        "status",
        "ok",
        "max rel",
        "violation",
        "median s"
    );
}
