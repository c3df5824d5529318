//! What the binary's test files share.

use std::path::PathBuf;

/// The real data folder: `RATFIT_DATA`, else `shared/data` beside the
/// repository (it may not exist; callers skip or fail as they must).
pub fn data_dir() -> PathBuf {
    std::env::var_os("RATFIT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"))
}
