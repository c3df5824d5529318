//! What the binary's test files share.

use std::path::PathBuf;
use std::process::Command;

/// The binary under test.
pub fn ratfit() -> Command {
    Command::new(env!("CARGO_BIN_EXE_ratfit"))
}

/// A fresh scratch folder named after the test file, the process and
/// `name`.
pub fn scratch(name: &str) -> PathBuf {
    let d = std::env::temp_dir().join(format!(
        "ratfit-{}-{}-{name}",
        env!("CARGO_CRATE_NAME"),
        std::process::id()
    ));
    std::fs::create_dir_all(&d).unwrap();
    d
}

/// The real data folder, or a path that does not exist (callers skip or
/// fail as they must).
pub fn data_dir() -> PathBuf {
    ratfit_tests::data_dir().unwrap_or_else(|| PathBuf::from("no-data-folder"))
}

/// The real data folder when it holds the RGL files; otherwise `None`,
/// after saying that the test of `what` is skipped (CI always sets
/// `RATFIT_DATA`).
pub fn rgl_data(what: &str) -> Option<PathBuf> {
    let data = data_dir();
    if data.join("rgl").is_dir() {
        Some(data)
    } else {
        eprintln!("SKIPPED {what}: no data folder (set RATFIT_DATA)");
        None
    }
}

/// A MERL file written from a Blinn-Phong material (a stand-in for a
/// download), in `dir`.
pub fn blinn_phong_merl(dir: &std::path::Path) -> PathBuf {
    let merl = dir.join("m.binary");
    brdf::MerlBrdf::tabulate(
        &brdf::BlinnPhong {
            kd: [0.2, 0.3, 0.4],
            ks: [0.3; 3],
            exponent: 20.0,
        },
        brdf::TabulateOptions::default(),
    )
    .write(&merl)
    .unwrap();
    merl
}
