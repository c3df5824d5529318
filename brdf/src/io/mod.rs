//! Readers of measured reflectance: MERL's binary tables, RGL's `.bsdf`
//! tensors, Cornell's spectral samples and ALTA's text data. Every reader
//! checks every field and names the file and the problem.

pub(crate) mod alta;
pub(crate) mod cornell;
pub mod fit_file;
pub mod merl;
pub mod rgl;
mod table_format;

pub use table_format::TableFormat;

/// The whitespace-separated numbers of a text line; `None` if any token is
/// not a number.
fn numbers(line: &str) -> Option<Vec<f64>> {
    line.split_whitespace()
        .map(|t| t.parse::<f64>().ok())
        .collect()
}
