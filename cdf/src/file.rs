//! The file `ratfit cdf` writes: the inverse CDFs, the settings of the table
//! they were fitted to (so the tabulated sampler can be rebuilt beside
//! them) and the fit report. Reading it checks every part.

use crate::{CdfError, CdfFitReport, RationalCdf, TableSettings};
use serde::{Deserialize, Serialize};
use std::path::Path;

/// A stored set of inverse CDFs.
#[derive(Debug, Clone, Serialize, Deserialize)]
pub struct CdfFile {
    /// The fitted inverse CDFs (checked on load).
    pub cdf: RationalCdf,
    /// The table they were fitted to (checked on load).
    pub table: TableSettings,
    /// The fit report (written, not read back).
    #[serde(skip_deserializing)]
    pub report: Option<CdfFitReport>,
}

impl CdfFile {
    /// Reads and checks the file at `path`.
    ///
    /// # Errors
    /// [`CdfError::Io`] when it cannot be read, [`CdfError::MalformedFile`]
    /// when it is not JSON of this form or fails a check.
    pub fn read(path: &Path) -> Result<Self, CdfError> {
        let text = std::fs::read_to_string(path).map_err(|source| CdfError::Io {
            path: path.to_path_buf(),
            source,
        })?;
        Self::parse(&text, path)
    }

    /// As [`CdfFile::read`] on text already read; `path` names it in errors.
    ///
    /// # Errors
    /// [`CdfError::MalformedFile`].
    pub fn parse(text: &str, path: &Path) -> Result<Self, CdfError> {
        serde_json::from_str(text).map_err(|e| CdfError::MalformedFile {
            path: path.to_path_buf(),
            reason: format!("not written by `ratfit cdf`, or fails its checks: {e}"),
        })
    }
}
