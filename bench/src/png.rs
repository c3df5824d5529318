//! PNG output for renders and plots, through render-cpu's compressed
//! encoder.

use anyhow::Result;
use std::path::Path;

/// Writes linear RGB (f64) as an sRGB-encoded PNG, clamped to [0, 1].
pub fn write_linear(path: &Path, width: usize, height: usize, rgb: &[[f64; 3]]) -> Result<()> {
    let bytes: Vec<u8> = rgb
        .iter()
        .flat_map(|p| p.map(|v| (render_cpu::srgb_encode(v) * 255.0 + 0.5) as u8))
        .collect();
    Ok(render_cpu::write_png(path, width, height, &bytes)?)
}

/// Writes display-ready RGB in [0, 1] (no transfer function) as PNG.
pub fn write_srgb_raw(path: &Path, width: usize, height: usize, rgb: &[[f64; 3]]) -> Result<()> {
    let bytes: Vec<u8> = rgb
        .iter()
        .flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8))
        .collect();
    Ok(render_cpu::write_png(path, width, height, &bytes)?)
}
