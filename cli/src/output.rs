//! Every file the CLI writes goes through here: atomically (a temporary file
//! beside it, then a rename), with the path in the error.

use anyhow::{Context, Result};
use std::path::Path;

/// Writes `contents` to `path` atomically.
pub fn write(path: impl AsRef<Path>, contents: impl AsRef<[u8]>) -> Result<()> {
    let path = path.as_ref();
    render_cpu::write_atomic(path, |tmp| std::fs::write(tmp, contents.as_ref()))
        .with_context(|| format!("cannot write {}", path.display()))
}
