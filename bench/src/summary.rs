//! What a run means: `summary.md` (fastest backend at the best error, speed
//! ratios at equal verified depth, the sweep against the paper, time growth
//! with samples, AAA against interval fits) and the two figures.

use super::run::{median, Row};
use crate::chart::{pareto_front, Figure, Panel};
use std::collections::BTreeMap;
use std::fmt::Write as _;

/// Where and how a run was made.
pub struct RunInfo {
    /// UTC date, `YYYY-MM-DD`.
    pub date: String,
    /// `git describe` of the working tree.
    pub commit: String,
    /// CPU model.
    pub machine: String,
    /// Worker threads.
    pub threads: usize,
    /// The command line.
    pub command: String,
    /// Wall time of the whole run.
    pub wall_s: f64,
    /// Instance names and descriptions.
    pub instances: Vec<(String, String)>,
}

/// The paper's time for the sweep of 41 splits at 42 coefficients (8 threads).
const PAPER_SWEEP_S: f64 = 22.0;

/// Two verified depths are equal within this relative difference: backends
/// solve the same strictly convex problem, so equal depth means the same point.
const EQUAL_DEPTH: f64 = 1e-2;

fn instances_in_order(rows: &[Row]) -> Vec<String> {
    let mut seen = Vec::new();
    for r in rows {
        if !seen.contains(&r.instance) {
            seen.push(r.instance.clone());
        }
    }
    seen
}

/// The size each instance is plotted at: its first.
fn plot_size(rows: &[Row], instance: &str) -> Option<String> {
    rows.iter()
        .find(|r| r.instance == instance && r.mode != "aaa")
        .map(|r| r.size.clone())
}

fn secs(t: f64) -> String {
    if t < 1e-3 {
        format!("{:.0} us", t * 1e6)
    } else if t < 1.0 {
        format!("{:.1} ms", t * 1e3)
    } else {
        format!("{t:.2} s")
    }
}

fn same_case(a: &Row, b: &Row) -> bool {
    a.instance == b.instance
        && a.size == b.size
        && a.rel_tol.to_bits() == b.rel_tol.to_bits()
        && a.n_p == b.n_p
        && a.n_q == b.n_q
        && a.mode == b.mode
}

/// Least-squares slope of `ln y` on `ln x`.
pub fn log_log_slope(points: &[(f64, f64)]) -> Option<f64> {
    let pts: Vec<(f64, f64)> = points
        .iter()
        .filter(|(x, y)| *x > 0.0 && *y > 0.0)
        .map(|(x, y)| (x.ln(), y.ln()))
        .collect();
    if pts.len() < 2 {
        return None;
    }
    let n = pts.len() as f64;
    let (mx, my) = (
        pts.iter().map(|p| p.0).sum::<f64>() / n,
        pts.iter().map(|p| p.1).sum::<f64>() / n,
    );
    let sxx: f64 = pts.iter().map(|p| (p.0 - mx).powi(2)).sum();
    let sxy: f64 = pts.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    (sxx > 0.0).then(|| sxy / sxx)
}

/// The split-row group `(split, tol)` of each (instance, backend) with the
/// most verified sizes (ties: the larger budget), for time growth.
fn growth_groups(rows: &[Row]) -> BTreeMap<(String, String), Vec<&Row>> {
    let mut groups: BTreeMap<(String, String, usize, usize, u64), Vec<&Row>> = BTreeMap::new();
    for r in rows
        .iter()
        .filter(|r| r.mode == "split" && r.verified && r.median_s.is_some())
    {
        groups
            .entry((
                r.instance.clone(),
                r.backend.clone(),
                r.n_p,
                r.n_q,
                r.rel_tol.to_bits(),
            ))
            .or_default()
            .push(r);
    }
    let mut best: BTreeMap<(String, String), Vec<&Row>> = BTreeMap::new();
    for ((inst, backend, np, nq, _), g) in groups {
        let e = best.entry((inst, backend)).or_default();
        let better = g.len() > e.len()
            || (g.len() == e.len() && e.first().is_some_and(|f| np + nq > f.n_p + f.n_q));
        if better {
            *e = g;
        }
    }
    best
}

/// `summary.md`.
pub fn summary_md(rows: &[Row], info: &RunInfo) -> String {
    let mut s = String::new();
    let _ = writeln!(s, "# Fitting benchmark: error against run time\n");
    let _ = writeln!(
        s,
        "`{}` on {}, {} threads, {} (UTC), commit `{}`; the run took {:.0} s. Every point is measured by ratfit's own f64 verifier; \"verified\" means inside every interval at every sample. Times are medians of the timed runs after a warm-up.\n",
        info.command, info.machine, info.threads, info.date, info.commit, info.wall_s
    );
    for (name, what) in &info.instances {
        let _ = writeln!(s, "- `{name}`: {what}");
    }
    let _ = writeln!(s);

    let instances = instances_in_order(rows);
    fastest_section(&mut s, rows, &instances);
    ratios_section(&mut s, rows, &instances);
    sweep_section(&mut s, rows);
    growth_section(&mut s, rows);
    aaa_section(&mut s, rows);
    s
}

/// The fastest backend at each instance's best verified error.
fn fastest_section(s: &mut String, rows: &[Row], instances: &[String]) {
    let _ = writeln!(s, "## Fastest backend at the best verified error\n");
    let _ = writeln!(s, "At each instance's first size: the split and tolerance whose verified fit has the smallest max relative error, the fastest backend there, and every other backend at that point.\n");
    let _ = writeln!(s, "| instance | samples | best max rel error | split, tol | fastest | time | others at that point |");
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    for inst in instances {
        let Some(size) = plot_size(rows, inst) else {
            continue;
        };
        let at: Vec<&Row> = rows
            .iter()
            .filter(|r| &r.instance == inst && r.size == size && r.mode == "split")
            .collect();
        let best = at
            .iter()
            .filter(|r| r.verified && r.max_rel_error.is_some())
            .min_by(|a, b| {
                a.max_rel_error
                    .unwrap_or(f64::INFINITY)
                    .total_cmp(&b.max_rel_error.unwrap_or(f64::INFINITY))
            });
        let Some(best) = best else {
            let samples = at.first().map_or(0, |r| r.samples);
            let _ = writeln!(s, "| {inst} | {samples} | no verified fit | | | | |");
            continue;
        };
        let point: Vec<&&Row> = at.iter().filter(|r| same_case(r, best)).collect();
        let fastest = point
            .iter()
            .filter(|r| r.verified)
            .min_by(|a, b| {
                a.median_s
                    .unwrap_or(f64::INFINITY)
                    .total_cmp(&b.median_s.unwrap_or(f64::INFINITY))
            })
            .expect("the best row is verified");
        let t0 = fastest.median_s.unwrap_or(f64::NAN);
        let others: Vec<String> = point
            .iter()
            .filter(|r| r.backend != fastest.backend)
            .map(|r| match (r.verified, r.median_s) {
                (true, Some(t)) => format!("{} {} ({:.1}x)", r.backend, secs(t), t / t0),
                (false, Some(t)) => format!("{} {} ({})", r.backend, r.status, secs(t)),
                _ => format!("{} {}", r.backend, r.status),
            })
            .collect();
        let _ = writeln!(
            s,
            "| {inst} | {} | {:.3e} | ({},{}), {:e} | {} | {} | {} |",
            best.samples,
            best.max_rel_error.unwrap_or(f64::NAN),
            best.n_p,
            best.n_q,
            best.rel_tol,
            fastest.backend,
            secs(t0),
            others.join("; ")
        );
    }
}

/// Each backend's time over the native solver's at equal verified depth.
fn ratios_section(s: &mut String, rows: &[Row], instances: &[String]) {
    let _ = writeln!(s, "\n## Speed ratios at equal verified depth\n");
    let _ = writeln!(s, "Over every case (size, tolerance, split) where both the native solver and the other backend returned a verified point of the same depth (within {EQUAL_DEPTH:e} relative): the other backend's time over the native time. \"Failed\" counts cases the native solver verified and the other did not.\n");
    let _ = writeln!(
        s,
        "| instance | backend | cases | median ratio | min | max | failed |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|---|");
    let mut backends: Vec<String> = Vec::new();
    for r in rows
        .iter()
        .filter(|r| r.mode == "split" && r.backend != "native" && r.backend != "-")
    {
        if !backends.contains(&r.backend) {
            backends.push(r.backend.clone());
        }
    }
    let mut all: BTreeMap<String, Vec<f64>> = BTreeMap::new();
    for inst in instances {
        for b in &backends {
            let (mut ratios, mut failed) = (Vec::new(), 0);
            for n in rows.iter().filter(|r| {
                &r.instance == inst && r.mode == "split" && r.backend == "native" && r.verified
            }) {
                let Some(o) = rows.iter().find(|r| r.backend == *b && same_case(r, n)) else {
                    continue;
                };
                if o.status == "skipped" {
                    continue;
                }
                let equal = match (n.depth, o.depth) {
                    (Some(a), Some(c)) => (a - c).abs() <= EQUAL_DEPTH * a.abs().max(c.abs()),
                    _ => false,
                };
                match (o.verified && equal, n.median_s, o.median_s) {
                    (true, Some(tn), Some(to)) => ratios.push(to / tn),
                    _ => failed += 1,
                }
            }
            if ratios.is_empty() && failed == 0 {
                continue;
            }
            all.entry(b.clone()).or_default().extend(&ratios);
            let (med, lo, hi) = if ratios.is_empty() {
                ("-".to_string(), "-".to_string(), "-".to_string())
            } else {
                (
                    format!("**{:.1}x**", median(&ratios)),
                    format!(
                        "{:.1}x",
                        ratios.iter().copied().fold(f64::INFINITY, f64::min)
                    ),
                    format!("{:.1}x", ratios.iter().copied().fold(0.0, f64::max)),
                )
            };
            let _ = writeln!(
                s,
                "| {inst} | {b} | {} | {med} | {lo} | {hi} | {failed} |",
                ratios.len()
            );
        }
    }
    for (b, r) in &all {
        if !r.is_empty() {
            let _ = writeln!(
                s,
                "| all instances | {b} | {} | **{:.1}x** | | | |",
                r.len(),
                median(r)
            );
        }
    }
}

/// The paper-like sweep rows.
fn sweep_section(s: &mut String, rows: &[Row]) {
    let sweeps: Vec<&Row> = rows
        .iter()
        .filter(|r| r.mode.starts_with("sweep"))
        .collect();
    if !sweeps.is_empty() {
        let _ = writeln!(s, "\n## The paper-like sweep\n");
        let _ = writeln!(s, "Every split at the budget, selection by condition number (`sweep`: no pole check; `sweep+grid`: the default dense-grid check of q > 0). The paper reports {PAPER_SWEEP_S} s on 8 threads.\n");
        let _ = writeln!(s, "| instance | samples | mode | backend | feasible | chosen | max rel error | time | paper / this |");
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
        for r in sweeps {
            let chosen = if r.n_p + r.n_q > 0 {
                format!("({},{})", r.n_p, r.n_q)
            } else {
                "-".into()
            };
            let _ = writeln!(
                s,
                "| {} | {} | {} | {} | {} | {chosen} | {} | {} | {} |",
                r.instance,
                r.samples,
                r.mode,
                r.backend,
                if r.status == "skipped" {
                    format!("skipped: {}", r.note)
                } else {
                    r.status.clone()
                },
                r.max_rel_error
                    .map_or_else(|| "-".into(), |e| format!("{e:.3}")),
                r.median_s.map_or_else(|| "-".into(), secs),
                r.median_s
                    .map_or_else(|| "-".into(), |t| format!("{:.0}x", PAPER_SWEEP_S / t)),
            );
        }
    }
}

/// Log-log slopes of time against samples.
fn growth_section(s: &mut String, rows: &[Row]) {
    let _ = writeln!(s, "\n## Time against samples\n");
    let _ = writeln!(s, "Least-squares slope of log time on log samples, per instance and backend, for the split and tolerance verified at the most sizes (at least 3 for a slope).\n");
    let _ = writeln!(
        s,
        "| instance | backend | split, tol | samples | times | slope |"
    );
    let _ = writeln!(s, "|---|---|---|---|---|---|");
    for ((inst, b), g) in growth_groups(rows) {
        let pts: Vec<(f64, f64)> = g
            .iter()
            .map(|r| (r.samples as f64, r.median_s.unwrap_or(f64::NAN)))
            .collect();
        let slope = if pts.len() >= 3 {
            log_log_slope(&pts)
        } else {
            None
        };
        let times: Vec<String> = g
            .iter()
            .map(|r| secs(r.median_s.unwrap_or(f64::NAN)))
            .collect();
        let _ = writeln!(
            s,
            "| {inst} | {b} | ({},{}), {:e} | {} to {} | {} | {} |",
            g[0].n_p,
            g[0].n_q,
            g[0].rel_tol,
            g.first().map_or(0, |r| r.samples),
            g.last().map_or(0, |r| r.samples),
            times.join(", "),
            slope.map_or_else(|| "-".into(), |v| format!("**{v:.2}**"))
        );
    }
}

/// AAA against the interval fits of the same type.
fn aaa_section(s: &mut String, rows: &[Row]) {
    let aaa: Vec<&Row> = rows.iter().filter(|r| r.mode == "aaa").collect();
    if !aaa.is_empty() {
        let _ = writeln!(s, "\n## AAA against interval fits (1-D)\n");
        let _ = writeln!(s, "AAA (Nakatsukasa, Sete, Trefethen 2018) with m support points has type (m-1, m-1), the degrees of the split (m, m). It minimises a linearised least-squares residual: nothing bounds its error at any sample, so it is checked against the same intervals. Its time is cumulative up to step m. At each instance's first size:\n");
        let _ = writeln!(s, "| instance | tol | m | AAA max rel error | AAA inside every interval | AAA time | native (m,m) | native max rel error | native time |");
        let _ = writeln!(s, "|---|---|---|---|---|---|---|---|---|");
        for r in aaa {
            if plot_size(rows, &r.instance).as_deref() != Some(r.size.as_str()) {
                continue;
            }
            let native = rows.iter().find(|n| {
                n.mode == "split"
                    && n.backend == "native"
                    && n.instance == r.instance
                    && n.size == r.size
                    && n.rel_tol.to_bits() == r.rel_tol.to_bits()
                    && n.n_p == r.n_p
                    && n.n_q == r.n_q
            });
            let outside = r.note.split(';').nth(1).map_or("", str::trim);
            let _ = writeln!(
                s,
                "| {} | {:e} | {} | {:.3e} | {} | {} | {} | {} | {} |",
                r.instance,
                r.rel_tol,
                r.n_q,
                r.max_rel_error.unwrap_or(f64::NAN),
                if r.verified {
                    "yes".to_string()
                } else {
                    format!("no ({outside})")
                },
                r.median_s.map_or_else(|| "-".into(), secs),
                native.map_or("-".into(), |n| if n.verified {
                    "verified".into()
                } else {
                    n.status.clone()
                }),
                native
                    .and_then(|n| n.max_rel_error)
                    .map_or_else(|| "-".into(), |e| format!("{e:.3e}")),
                native
                    .and_then(|n| n.median_s)
                    .map_or_else(|| "-".into(), secs),
            );
        }
    }
}

/// The error-against-time figure (one panel per instance at its first
/// size) and the time-against-samples figure.
pub fn figures(rows: &[Row], backends: &[&str]) -> (Figure, Figure) {
    let mut legend: Vec<String> = backends.iter().map(|b| b.to_string()).collect();
    let aaa = legend.len();
    legend.push("aaa (no bound at the samples)".into());
    let series = |r: &Row| -> Option<usize> {
        if r.mode == "aaa" {
            Some(aaa)
        } else {
            backends.iter().position(|b| *b == r.backend)
        }
    };
    let mut err = Figure {
        title: "MAX RELATIVE ERROR AGAINST MEDIAN WALL TIME".into(),
        x_label: "wall time (s)".into(),
        y_label: "max relative error".into(),
        legend: legend.clone(),
        columns: 3,
        ..Figure::default()
    };
    let mut time = Figure {
        title: "WALL TIME AGAINST SAMPLES".into(),
        x_label: "samples".into(),
        y_label: "wall time (s)".into(),
        legend: backends.iter().map(|b| b.to_string()).collect(),
        columns: 3,
        ..Figure::default()
    };
    let groups = growth_groups(rows);
    for inst in instances_in_order(rows) {
        let Some(size) = plot_size(rows, &inst) else {
            continue;
        };
        let mut panel = Panel {
            title: inst.clone(),
            ..Panel::default()
        };
        // Verified interval fits, and AAA once per support count (its
        // error does not depend on the tolerance it is checked against).
        let mut seen_aaa = Vec::new();
        for r in rows.iter().filter(|r| r.instance == inst && r.size == size) {
            let keep = match r.mode.as_str() {
                "split" => r.verified,
                "aaa" if !seen_aaa.contains(&r.n_q) => {
                    seen_aaa.push(r.n_q);
                    true
                }
                _ => false,
            };
            let (true, Some(k), Some(t), Some(e)) = (keep, series(r), r.median_s, r.max_rel_error)
            else {
                continue;
            };
            panel.points.push((k, t, e));
        }
        let all: Vec<(f64, f64)> = panel.points.iter().map(|p| (p.1, p.2)).collect();
        panel.front = pareto_front(&all);
        if let Some(r) = rows.iter().find(|r| r.instance == inst && r.size == size) {
            panel.title = format!("{inst} ({} samples)", r.samples);
        }
        err.panels.push(panel);
        let mut tp = Panel {
            title: inst.clone(),
            ..Panel::default()
        };
        for ((i, b), g) in &groups {
            if *i != inst {
                continue;
            }
            let Some(k) = backends.iter().position(|x| x == b) else {
                continue;
            };
            tp.points.extend(
                g.iter()
                    .filter_map(|r| Some((k, r.samples as f64, r.median_s?))),
            );
        }
        if !tp.points.is_empty() {
            time.panels.push(tp);
        }
    }
    (err, time)
}

/// Today's UTC date, `YYYY-MM-DD`.
pub fn utc_date() -> String {
    let secs = std::time::SystemTime::now()
        .duration_since(std::time::UNIX_EPOCH)
        .map_or(0, |d| d.as_secs());
    civil_date(secs / 86_400)
}

/// The proleptic Gregorian date of a day count since 1970-01-01
/// (Howard Hinnant's `civil_from_days`).
fn civil_date(days: u64) -> String {
    let z = days as i64 + 719_468;
    let era = z.div_euclid(146_097);
    let doe = z - era * 146_097;
    let yoe = (doe - doe / 1460 + doe / 36_524 - doe / 146_096) / 365;
    let doy = doe - (365 * yoe + yoe / 4 - yoe / 100);
    let mp = (5 * doy + 2) / 153;
    let d = doy - (153 * mp + 2) / 5 + 1;
    let m = if mp < 10 { mp + 3 } else { mp - 9 };
    let y = yoe + era * 400 + i64::from(m <= 2);
    format!("{y:04}-{m:02}-{d:02}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn civil_dates() {
        assert_eq!(civil_date(0), "1970-01-01");
        assert_eq!(civil_date(11_016), "2000-02-29");
        assert_eq!(civil_date(20_779), "2026-11-22");
    }

    #[test]
    fn slope_of_a_power_law() {
        let pts: Vec<(f64, f64)> = [1e3, 1e4, 1e5]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(1.2)))
            .collect();
        assert!((log_log_slope(&pts).unwrap() - 1.2).abs() < 1e-12);
        assert!(log_log_slope(&pts[..1]).is_none());
    }
}
