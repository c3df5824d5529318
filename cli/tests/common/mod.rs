//! What the binary's test files share.

use std::path::PathBuf;

/// The real data folder, or a path that does not exist (callers skip or
/// fail as they must).
pub fn data_dir() -> PathBuf {
    ratfit_tests::data_dir().unwrap_or_else(|| PathBuf::from("no-data-folder"))
}
