//! What the binary's test files share.

use std::path::PathBuf;

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
