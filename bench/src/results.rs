//! `results.csv`: writing, reading back, and the sanity check run on it.

use super::run::Row;
use anyhow::{bail, Context, Result};
use std::path::Path;

/// Column names of `results.csv`.
pub const COLUMNS: [&str; 22] = [
    "instance",
    "mode",
    "backend",
    "rel_tol",
    "size",
    "samples",
    "n_p",
    "n_q",
    "status",
    "verified",
    "depth",
    "max_violation",
    "max_rel_error",
    "mean_rel_error",
    "median_s",
    "min_s",
    "max_s",
    "reps",
    "iterations",
    "threads",
    "commit",
    "note",
];

/// Writes the rows with the run's thread count and commit.
pub fn write_csv(path: &Path, rows: &[Row], threads: usize, commit: &str) -> Result<()> {
    let mut writer = csv::Writer::from_writer(Vec::new());
    for r in rows {
        writer.serialize(Row {
            threads,
            commit: commit.to_string(),
            ..r.clone()
        })?;
    }
    let bytes = writer.into_inner().map_err(|e| anyhow::anyhow!("{e}"))?;
    crate::output::write(path, String::from_utf8(bytes)?)
}

/// Reads `results.csv` back.
///
/// # Errors
/// Missing file, wrong header, or a malformed row (named by line).
pub fn read_csv(path: &Path) -> Result<Vec<Row>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    let mut reader = csv::Reader::from_reader(text.as_bytes());
    let header = reader
        .headers()
        .with_context(|| format!("{}: no header", path.display()))?;
    if header.iter().ne(COLUMNS) {
        bail!("{}: the header is not that of results.csv", path.display());
    }
    // csv's messages name the line and the field.
    reader
        .deserialize::<Row>()
        .collect::<Result<_, _>>()
        .with_context(|| format!("{}: a malformed row", path.display()))
}

/// Relative slack of a verified point's error over its tolerance: the
/// verifier accepts rounding of order `1e-13` relative (64 eps per term).
const ROUNDING: f64 = 1e-9;

/// Problems with a finished run's outputs in `dir`: missing files, backends
/// that never ran, and any point whose claim and measurement disagree.
pub fn check(dir: &Path, expected_backends: &[&str]) -> Result<Vec<String>> {
    let mut problems = Vec::new();
    for f in [
        "results.csv",
        "error_vs_time.png",
        "error_vs_time.svg",
        "time_vs_samples.svg",
        "summary.md",
    ] {
        let p = dir.join(f);
        match std::fs::metadata(&p) {
            Ok(m) if m.len() > 0 => {}
            _ => problems.push(format!("{} is missing or empty", p.display())),
        }
    }
    let rows = read_csv(&dir.join("results.csv"))?;
    for b in expected_backends {
        if !rows.iter().any(|r| r.backend == *b && r.median_s.is_some()) {
            problems.push(format!("backend {b} has no timed row"));
        }
    }
    if !rows.iter().any(|r| r.verified && r.mode == "split") {
        problems.push("no verified split at all".into());
    }
    for (k, r) in rows.iter().enumerate() {
        let line = k + 2;
        let claimed = matches!(r.status.as_str(), "solved" | "inaccurate");
        let viol = r.max_violation.unwrap_or(0.0);
        if r.verified && (viol > ROUNDING || viol.is_nan()) {
            problems.push(format!(
                "line {line}: {} {} marked verified with violation {viol:e}",
                r.instance, r.backend
            ));
        }
        if r.verified && r.mode != "aaa" {
            if let Some(e) = r.max_rel_error {
                // Relative intervals: inside means within rel_tol of the value.
                if e > r.rel_tol * (1.0 + ROUNDING) + 1e-12 || e.is_nan() {
                    problems.push(format!(
                        "line {line}: {} {} verified, yet its relative error {e:e} exceeds the tolerance {:e}",
                        r.instance, r.backend, r.rel_tol
                    ));
                }
            } else {
                problems.push(format!("line {line}: verified without error figures"));
            }
        }
        if claimed && !r.verified && r.mode == "split" {
            // A rejected claim must carry the verifier's own measurement.
            if r.max_violation.is_none() && !r.note.contains("verif") {
                problems.push(format!(
                    "line {line}: {} {} reported {} but was rejected without a measured violation",
                    r.instance, r.backend, r.status
                ));
            }
        }
        if claimed && viol > ROUNDING && r.verified {
            problems.push(format!(
                "line {line}: {} {} reported {} on a violated point and the verifier did not flag it",
                r.instance, r.backend, r.status
            ));
        }
        if r.median_s.is_some_and(|t| !(t >= 0.0 && t.is_finite())) {
            problems.push(format!("line {line}: bad time"));
        }
    }
    Ok(problems)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn row(verified: bool, viol: f64, err: f64) -> Row {
        Row {
            instance: "x, with comma".into(),
            mode: "split".into(),
            backend: "native".into(),
            rel_tol: 0.01,
            size: "20 samples".into(),
            samples: 20,
            n_p: 2,
            n_q: 2,
            status: "solved".into(),
            verified,
            depth: Some(1e-3),
            max_violation: Some(viol),
            max_rel_error: Some(err),
            mean_rel_error: Some(err / 2.0),
            median_s: Some(0.5),
            min_s: Some(0.4),
            max_s: Some(0.6),
            reps: 3,
            iterations: Some(7),
            note: "say \"hi\"".into(),
            ..Row::default()
        }
    }

    fn dir_with(rows: &[Row], name: &str) -> std::path::PathBuf {
        let dir =
            std::env::temp_dir().join(format!("ratfit-bench-check-{name}-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        write_csv(&dir.join("results.csv"), rows, 2, "abc").unwrap();
        for f in [
            "error_vs_time.png",
            "error_vs_time.svg",
            "time_vs_samples.svg",
            "summary.md",
        ] {
            std::fs::write(dir.join(f), "x").unwrap();
        }
        dir
    }

    #[test]
    fn csv_round_trips() {
        let dir = dir_with(&[row(true, 0.0, 0.005)], "roundtrip");
        let back = read_csv(&dir.join("results.csv")).unwrap();
        assert_eq!(back.len(), 1);
        assert_eq!(back[0].instance, "x, with comma");
        assert_eq!(back[0].note, "say \"hi\"");
        assert_eq!(back[0].iterations, Some(7));
        assert_eq!((back[0].threads, back[0].commit.as_str()), (2, "abc"));
        assert!(check(&dir, &["native"]).unwrap().is_empty());
    }

    #[test]
    fn check_flags_a_violated_point_marked_verified() {
        let dir = dir_with(&[row(true, 0.0, 0.005), row(true, 1e-3, 0.005)], "violated");
        let p = check(&dir, &["native"]).unwrap();
        assert!(p.iter().any(|p| p.contains("violation")), "{p:?}");
    }

    #[test]
    fn check_flags_errors_beyond_the_tolerance_and_missing_backends() {
        let dir = dir_with(&[row(true, 0.0, 0.05)], "beyond");
        let p = check(&dir, &["native", "clarabel"]).unwrap();
        assert!(p.iter().any(|p| p.contains("exceeds")), "{p:?}");
        assert!(p.iter().any(|p| p.contains("clarabel")), "{p:?}");
        std::fs::remove_file(dir.join("summary.md")).unwrap();
        let p = check(&dir, &["native"]).unwrap();
        assert!(p.iter().any(|p| p.contains("summary.md")), "{p:?}");
    }
}
