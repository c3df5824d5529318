//! Numeric CSV input through the `csv` crate: comma separated, optional
//! header row, errors by line and column.

use anyhow::{bail, Context, Result};
use std::path::Path;

/// Rows of numbers; a first line that does not parse is taken as a header.
pub fn read_numeric(path: &Path) -> Result<Vec<Vec<f64>>> {
    let text =
        std::fs::read_to_string(path).with_context(|| format!("cannot read {}", path.display()))?;
    parse_numeric(&text).with_context(|| format!("in {}", path.display()))
}

/// As [`read_numeric`] on text: fields trimmed, `#` lines and blank lines
/// skipped, a UTF-8 byte-order mark dropped (else the first data row would
/// not parse, and so be taken as a header without a word).
pub fn parse_numeric(text: &str) -> Result<Vec<Vec<f64>>> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut reader = csv::ReaderBuilder::new()
        .has_headers(false)
        .flexible(true)
        .comment(Some(b'#'))
        .trim(csv::Trim::All)
        .from_reader(text.as_bytes());
    let mut rows: Vec<Vec<f64>> = Vec::new();
    let mut width = None;
    for record in reader.records() {
        let record = record?;
        let line = record.position().map_or(0, |p| line_of(text, p.byte()));
        if record.iter().all(str::is_empty) {
            continue;
        }
        let parsed: Result<Vec<f64>, _> = record.iter().map(str::parse::<f64>).collect();
        let row = match parsed {
            Ok(r) => r,
            Err(_) if rows.is_empty() && width.is_none() => {
                width = Some(record.len()); // header
                continue;
            }
            Err(e) => {
                let col = record
                    .iter()
                    .position(|f| f.parse::<f64>().is_err())
                    .unwrap_or(0);
                bail!(
                    "line {line}: column {} `{}` is not a number ({e})",
                    col + 1,
                    &record[col]
                );
            }
        };
        if let Some(k) = row.iter().position(|v| !v.is_finite()) {
            bail!("line {line}: column {} is not finite ({})", k + 1, row[k]);
        }
        match width {
            Some(w) if w != row.len() => {
                bail!("line {line}: {} columns, expected {w}", row.len())
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

/// The line of the record that csv places at `byte`: its position is where
/// the reader started, before the blank and `#` lines it passed over.
fn line_of(text: &str, byte: u64) -> usize {
    let mut at = usize::try_from(byte).unwrap_or(usize::MAX).min(text.len());
    while let Some(end) = text[at..].find('\n') {
        let line = &text[at..at + end];
        if !(line.trim().is_empty() || line.starts_with('#')) {
            break;
        }
        at += end + 1;
    }
    text[..at].matches('\n').count() + 1
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
        // Comments, blank lines and spaces around fields.
        assert_eq!(
            parse_numeric("# a comment\n x , v\n\n 1 , 2\n").unwrap(),
            vec![vec![1.0, 2.0]]
        );
        let e = parse_numeric("1,2\n\n# c\n3,abc\n")
            .unwrap_err()
            .to_string();
        assert!(e.contains("line 4") && e.contains("`abc`"), "{e}");
    }
}
