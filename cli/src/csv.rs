//! Reading numeric CSV: comma separated, optional header row.

use anyhow::{bail, Context, Result};
use std::path::Path;

/// A CSV field: quoted when it holds a comma, a quote or a line break
/// (quotes doubled, line breaks made spaces).
pub fn quote(s: &str) -> String {
    if s.contains([',', '"', '\n']) {
        format!("\"{}\"", s.replace('"', "\"\"").replace('\n', " "))
    } else {
        s.to_string()
    }
}

/// Rows of numbers; a first line that does not parse is taken as a header.
pub fn read_numeric(path: &Path) -> Result<Vec<Vec<f64>>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_numeric(&text).with_context(|| format!("in {}", path.display()))
}

/// As [`read_numeric`] on text.
pub fn parse_numeric(text: &str) -> Result<Vec<Vec<f64>>> {
    // A UTF-8 byte-order mark would make the first data row unparseable,
    // and so silently a "header".
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut rows = Vec::new();
    let mut width = None;
    for (lineno, line) in text.lines().enumerate() {
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        let parsed: Result<Vec<f64>, _> = fields.iter().map(|f| f.parse::<f64>()).collect();
        let row = match parsed {
            Ok(r) => r,
            Err(_) if rows.is_empty() && width.is_none() => {
                width = Some(fields.len()); // header
                continue;
            }
            Err(e) => {
                let col = fields
                    .iter()
                    .position(|f| f.parse::<f64>().is_err())
                    .unwrap_or(0);
                bail!(
                    "line {}: column {} `{}` is not a number ({e})",
                    lineno + 1,
                    col + 1,
                    fields[col]
                );
            }
        };
        if let Some(k) = row.iter().position(|v| !v.is_finite()) {
            bail!(
                "line {}: column {} is not finite ({})",
                lineno + 1,
                k + 1,
                row[k]
            );
        }
        match width {
            Some(w) if w != row.len() => {
                bail!("line {}: {} columns, expected {w}", lineno + 1, row.len())
            }
            _ => width = Some(row.len()),
        }
        rows.push(row);
    }
    if rows.is_empty() {
        bail!("no numeric rows");
    }
    Ok(rows)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_byte_order_mark_is_not_a_header() {
        let rows = parse_numeric("\u{feff}0.5,1\n1,2\n").unwrap();
        assert_eq!(rows, vec![vec![0.5, 1.0], vec![1.0, 2.0]]);
    }

    #[test]
    fn header_and_errors() {
        assert_eq!(
            parse_numeric("x,v\n1,2\n3,4\n").unwrap(),
            vec![vec![1.0, 2.0], vec![3.0, 4.0]]
        );
        assert!(parse_numeric("1,2\n3\n")
            .unwrap_err()
            .to_string()
            .contains("line 2"));
        assert!(parse_numeric("1,2\n3,abc\n")
            .unwrap_err()
            .to_string()
            .contains("column 2"));
        assert!(parse_numeric("1,NaN\n").is_err());
        assert!(parse_numeric("x,y\n").is_err());
    }
}
