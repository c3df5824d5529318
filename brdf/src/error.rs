//! The crate's error type.

use std::path::{Path, PathBuf};

/// Errors reading, writing or fitting reflectance data.
#[derive(Debug, thiserror::Error)]
#[non_exhaustive]
pub enum BrdfError {
    /// The file could not be read or written.
    #[error("{path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        source: std::io::Error,
    },
    /// The content does not follow the format.
    #[error("{path}: malformed {format} file: {reason}")]
    Malformed {
        /// The file (or `<memory>`).
        path: PathBuf,
        /// Format name.
        format: &'static str,
        /// What is wrong.
        reason: String,
    },
    /// A parameter is out of range.
    #[error("invalid {name}: {reason}")]
    Invalid {
        /// Parameter name.
        name: &'static str,
        /// Why.
        reason: String,
    },
    /// The fitting engine failed.
    #[error("channel {channel}: {source}")]
    Fit {
        /// Colour channel (r, g or b).
        channel: char,
        /// The engine's error.
        source: rational_core::FitError,
    },
}

impl BrdfError {
    pub(crate) fn malformed(
        path: &std::path::Path,
        format: &'static str,
        reason: impl Into<String>,
    ) -> Self {
        Self::Malformed {
            path: path.to_path_buf(),
            format,
            reason: reason.into(),
        }
    }

    pub(crate) fn io(path: &std::path::Path, source: std::io::Error) -> Self {
        Self::Io {
            path: path.to_path_buf(),
            source,
        }
    }
}

/// The bytes of a file and its stem (the material's name in reports).
pub(crate) fn read_named(path: &std::path::Path) -> Result<(Vec<u8>, String), BrdfError> {
    let bytes = std::fs::read(path).map_err(|e| BrdfError::io(path, e))?;
    let name = path
        .file_stem()
        .map(|s| s.to_string_lossy().into_owned())
        .unwrap_or_default();
    Ok((bytes, name))
}

/// Writes `path` by `write` into a temporary file beside it, then renames
/// it into place: a failed or interrupted command never leaves a truncated
/// output, and a reader never sees a half-written file.
///
/// # Errors
/// Whatever `write` or the rename returns (the temporary file is removed).
pub fn write_atomic(
    path: &Path,
    write: impl FnOnce(&Path) -> std::io::Result<()>,
) -> std::io::Result<()> {
    let name = path
        .file_name()
        .ok_or_else(|| std::io::Error::new(std::io::ErrorKind::InvalidInput, "no file name"))?;
    let mut tmp_name = std::ffi::OsString::from(".");
    tmp_name.push(name);
    tmp_name.push(format!(".partial-{}", std::process::id()));
    let tmp = path.with_file_name(tmp_name);
    let result = write(&tmp).and_then(|()| std::fs::rename(&tmp, path));
    if result.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    result
}
