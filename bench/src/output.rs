//! Every file the CLI writes goes through here: atomically (a temporary file
//! beside it, then a rename), with the path in the error; and errors as the
//! CLI prints them.

use anyhow::{Context, Result};
use std::path::Path;

/// Writes `contents` to `path` atomically.
pub fn write(path: impl AsRef<Path>, contents: impl AsRef<[u8]>) -> Result<()> {
    let path = path.as_ref();
    render_cpu::write_atomic(path, |tmp| std::fs::write(tmp, contents.as_ref()))
        .with_context(|| format!("cannot write {}", path.display()))
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
