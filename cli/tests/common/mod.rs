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
