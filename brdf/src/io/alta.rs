//! ALTA's text data format: rows of inputs and outputs in a named
//! parametrisation, with optional vertical segments (intervals).

use super::numbers;
use crate::BrdfError;
use std::path::Path;

/// ALTA text data: `#DIM n m`, `#PARAM_IN`, `#PARAM_OUT`, optional `#VS`,
/// then rows of `n` inputs and `m` outputs (each output followed by its lower
/// and upper bound when `#VS 2` says so).
#[derive(Debug, Clone, PartialEq)]
pub struct AltaData {
    /// Input dimension.
    pub dim_in: usize,
    /// Output dimension.
    pub dim_out: usize,
    /// Input parametrisation name.
    pub param_in: String,
    /// Output quantity name.
    pub param_out: String,
    /// Rows: inputs then outputs.
    pub rows: Vec<Vec<f64>>,
    /// Per row and output, `(lo, hi)` when the file has vertical segments.
    pub intervals: Option<Vec<Vec<(f64, f64)>>>,
}

/// Most outputs per row an ALTA data file may declare (`#DIM n m`); every
/// row then holds `n + m` to `n + 3 m` numbers.
pub const MAX_ALTA_OUTPUTS: usize = 256;

impl AltaData {
    /// Reads an ALTA data file (`.alta`, `.dat`).
    ///
    /// # Errors
    /// Unreadable file, missing `#DIM`, rows of the wrong length, non-finite
    /// values.
    pub fn read(path: &Path) -> Result<Self, BrdfError> {
        let text = std::fs::read_to_string(path).map_err(|e| BrdfError::io(path, e))?;
        Self::parse(&text, path)
    }

    /// Parses the text of an ALTA data file; `path` names it in errors.
    ///
    /// # Errors
    /// As [`AltaData::read`], but for the file's own reading.
    pub fn parse(text: &str, path: &Path) -> Result<Self, BrdfError> {
        let bad = |r: String| BrdfError::malformed(path, "ALTA data", r);
        let (mut dim, mut vs) = (None, 0usize);
        let (mut param_in, mut param_out) = (String::new(), String::new());
        let mut rows = Vec::new();
        let mut intervals = Vec::new();
        for (no, line) in text.lines().enumerate() {
            let t = line.trim();
            if t.is_empty() {
                continue;
            }
            if let Some(h) = t.strip_prefix('#') {
                let mut it = h.split_whitespace();
                match it.next() {
                    // The row shape follows from `#DIM` and `#VS`: both
                    // once, before the data.
                    Some(key @ ("DIM" | "VS")) if !rows.is_empty() || (key == "DIM" && dim.is_some()) => {
                        return Err(bad(format!(
                            "line {}: `#{key}` after the data rows or a second `#DIM`",
                            no + 1
                        )));
                    }
                    Some("DIM") => {
                        let v: Vec<usize> = it.filter_map(|x| x.parse().ok()).collect();
                        if v.len() != 2
                            || !(1..=rational_core::MAX_DIMENSION).contains(&v[0])
                            || !(1..=MAX_ALTA_OUTPUTS).contains(&v[1])
                        {
                            return Err(bad(format!(
                                "line {}: `#DIM` needs two sizes, 1..={} inputs and 1..={MAX_ALTA_OUTPUTS} outputs",
                                no + 1,
                                rational_core::MAX_DIMENSION
                            )));
                        }
                        dim = Some((v[0], v[1]));
                    }
                    Some("VS") => {
                        vs = match (it.next().map(str::parse::<u8>), it.next()) {
                            (Some(Ok(k @ (0 | 2))), None) => usize::from(k),
                            _ => {
                                return Err(bad(format!(
                                    "line {}: `#{h}`: `#VS` takes 0 or 2 (no interval, or lower and upper bounds)",
                                    no + 1
                                )))
                            }
                        }
                    }
                    Some("PARAM_IN") => param_in = it.collect::<Vec<_>>().join(" "),
                    Some("PARAM_OUT") => param_out = it.collect::<Vec<_>>().join(" "),
                    _ => {}
                }
                continue;
            }
            let (n, m) = dim.ok_or_else(|| bad("data before `#DIM`".into()))?;
            let (row, iv) = data_row(t, no + 1, (n, m), vs).map_err(bad)?;
            rows.push(row);
            intervals.push(iv);
        }
        let (dim_in, dim_out) = dim.ok_or_else(|| bad("no `#DIM` header".into()))?;
        if rows.is_empty() {
            return Err(bad("no data rows".into()));
        }
        Ok(Self {
            dim_in,
            dim_out,
            param_in,
            param_out,
            rows,
            intervals: (vs == 2).then_some(intervals),
        })
    }

    /// Interval data for output `k` with relative tolerance `t` (or the
    /// file's own intervals when it has them).
    ///
    /// # Errors
    /// `k` out of range or invalid values.
    pub fn channel(&self, k: usize, t: f64) -> Result<rational_core::IntervalData, BrdfError> {
        if k >= self.dim_out {
            return Err(BrdfError::Invalid {
                name: "output",
                reason: format!("{k} of {} outputs", self.dim_out),
            });
        }
        let n = self.dim_in;
        let points = self.rows.iter().flat_map(|r| r[..n].to_vec()).collect();
        let values: Vec<f64> = self.rows.iter().map(|r| r[n + k]).collect();
        let wrap = |e| BrdfError::Fit {
            channel: ['r', 'g', 'b', 'a'][k.min(3)],
            source: e,
        };
        match &self.intervals {
            Some(iv) => rational_core::IntervalData::new(
                n,
                points,
                iv.iter().map(|r| r[k].0).collect(),
                iv.iter().map(|r| r[k].1).collect(),
            )
            .and_then(|d| d.with_values(values))
            .map_err(wrap),
            None => rational_core::IntervalData::from_values_relative(n, points, values, t)
                .map_err(wrap),
        }
    }
}

/// A data row's inputs and outputs, and each output's interval if the file
/// gives intervals.
type DataRow = (Vec<f64>, Vec<(f64, f64)>);

/// The inputs and outputs of the data row `t` (line `line`) of a file of
/// `n` inputs and `m` outputs, and with `vs == 2` each output's interval;
/// what is wrong otherwise.
fn data_row(t: &str, line: usize, (n, m): (usize, usize), vs: usize) -> Result<DataRow, String> {
    let v = numbers(t).ok_or_else(|| format!("line {line}: not numbers"))?;
    let per_out = if vs == 2 { 3 } else { 1 };
    if v.len() != n + m * per_out {
        return Err(format!(
            "line {line}: {} numbers, expected {}",
            v.len(),
            n + m * per_out
        ));
    }
    if let Some(x) = v.iter().find(|x| !x.is_finite()) {
        return Err(format!("line {line}: non-finite value {x}"));
    }
    let mut row = v[..n].to_vec();
    let mut iv = Vec::new();
    for k in 0..m {
        row.push(v[n + k * per_out]);
        if vs == 2 {
            let (value, lo, hi) = (
                v[n + k * per_out],
                v[n + k * per_out + 1],
                v[n + k * per_out + 2],
            );
            if !(lo <= value && value <= hi) {
                return Err(format!(
                    "line {line}: output {k} value {value} is outside its own interval [{lo}, {hi}]"
                ));
            }
            iv.push((lo, hi));
        }
    }
    Ok((row, iv))
}
