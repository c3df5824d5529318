//! Every file the CLI and the benchmarks write goes through here:
//! atomically (a temporary file beside it, then a rename), with the path in
//! the error; CSV through the `csv` crate, NumPy arrays through `npyz`; and
//! errors as the CLI prints them.

use anyhow::{Context, Result};
use std::path::Path;

/// Writes `contents` to `path` atomically.
pub fn write(path: impl AsRef<Path>, contents: impl AsRef<[u8]>) -> Result<()> {
    let path = path.as_ref();
    render_cpu::write_atomic(path, |tmp| std::fs::write(tmp, contents.as_ref()))
        .with_context(|| format!("cannot write {}", path.display()))
}

/// `data` as a C-ordered little-endian f64 NumPy array of `shape`,
/// written atomically.
pub fn write_npy(path: &Path, shape: &[usize], data: &[f64]) -> Result<()> {
    use npyz::WriterBuilder;
    let shape: Vec<u64> = shape.iter().map(|&d| d as u64).collect();
    let mut bytes = std::io::Cursor::new(Vec::new());
    let mut writer = npyz::WriteOptions::<f64>::new()
        .default_dtype()
        .shape(&shape)
        .writer(&mut bytes)
        .begin_nd()?;
    writer.extend(data.iter().copied())?;
    writer.finish()?;
    write(path, bytes.into_inner())
}

/// Writes `rows` as CSV atomically, the header from the fields' names.
pub fn write_csv<T: serde::Serialize>(
    path: impl AsRef<Path>,
    rows: impl IntoIterator<Item = T>,
) -> Result<()> {
    let path = path.as_ref();
    let mut csv = csv::Writer::from_writer(Vec::new());
    for row in rows {
        csv.serialize(row)
            .with_context(|| format!("cannot write a row of {}", path.display()))?;
    }
    let bytes = csv
        .into_inner()
        .map_err(|e| anyhow::anyhow!("cannot write {}: {e}", path.display()))?;
    write(path, bytes)
}

/// The error and its causes on one line, each cause once: library errors
/// often repeat their source in their own message, and that copy is not
/// printed again.
pub fn chain_text(e: &anyhow::Error) -> String {
    let mut text = String::new();
    for cause in e.chain() {
        let message = cause.to_string();
        if text.ends_with(&message) {
            continue;
        }
        if !text.is_empty() {
            text += ": ";
        }
        text += &message;
    }
    text
}
