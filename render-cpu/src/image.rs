//! Linear RGB images: OpenEXR input and output (linear, f32), PNG output
//! (exposure, then the sRGB transfer curve, clamped to 8 bits).

use crate::error::RenderError;
use brdf::write_atomic;
use std::path::Path;

/// A linear RGB image, row-major, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Width in pixels.
    pub width: usize,
    /// Height in pixels.
    pub height: usize,
    /// `width * height` linear RGB values.
    pub pixels: Vec<[f32; 3]>,
}

fn image_error(path: &Path, reason: impl Into<String>) -> RenderError {
    RenderError::Image {
        path: path.display().to_string(),
        reason: reason.into(),
    }
}

/// The sRGB transfer curve of a linear value, clamped to `[0, 1]`.
pub fn srgb_encode(v: f64) -> f64 {
    let v = v.clamp(0.0, 1.0);
    if v <= 0.003_130_8 {
        12.92 * v
    } else {
        1.055 * v.powf(1.0 / 2.4) - 0.055
    }
}

impl Image {
    /// An image from its pixels.
    ///
    /// # Panics
    /// If `pixels.len() != width * height` (a programming error).
    pub fn new(width: usize, height: usize, pixels: Vec<[f32; 3]>) -> Self {
        assert_eq!(pixels.len(), width * height, "pixel count");
        Self {
            width,
            height,
            pixels,
        }
    }

    /// The pixel at column `x`, row `y`.
    pub fn at(&self, x: usize, y: usize) -> [f32; 3] {
        self.pixels[y * self.width + x]
    }

    /// Mean of each channel.
    pub fn mean(&self) -> [f64; 3] {
        let mut s = [0.0; 3];
        for p in &self.pixels {
            for c in 0..3 {
                s[c] += f64::from(p[c]);
            }
        }
        s.map(|v| v / self.pixels.len().max(1) as f64)
    }

    /// 8-bit sRGB bytes after multiplying by `exposure`.
    pub fn to_srgb8(&self, exposure: f64) -> Vec<u8> {
        self.pixels
            .iter()
            .flat_map(|p| p.map(|v| (srgb_encode(f64::from(v) * exposure) * 255.0 + 0.5) as u8))
            .collect()
    }

    /// Writes by extension: `.exr` (linear f32) or `.png` (exposure, sRGB).
    ///
    /// # Errors
    /// Another extension, or the file cannot be written.
    pub fn write(&self, path: &Path, exposure: f64) -> Result<(), RenderError> {
        match extension(path).as_str() {
            "exr" => self.write_exr(path),
            "png" => write_png(path, self.width, self.height, &self.to_srgb8(exposure)),
            other => Err(image_error(
                path,
                format!("unknown extension `{other}`: use .png or .exr"),
            )),
        }
    }

    /// Writes a linear OpenEXR file.
    ///
    /// # Errors
    /// The file cannot be written.
    pub fn write_exr(&self, path: &Path) -> Result<(), RenderError> {
        write_atomic(path, |tmp| {
            exr::prelude::write_rgb_file(tmp, self.width, self.height, |x, y| {
                let p = self.at(x, y);
                (p[0], p[1], p[2])
            })
            .map_err(|e| std::io::Error::other(e.to_string()))
        })
        .map_err(|e| image_error(path, e.to_string()))
    }

    /// Reads the first RGB(A) layer of an OpenEXR file (alpha ignored).
    ///
    /// # Errors
    /// Not a readable OpenEXR file with RGB channels, or non-finite values.
    pub fn read_exr(path: &Path) -> Result<Self, RenderError> {
        if extension(path) != "exr" {
            return Err(image_error(
                path,
                "expected a linear OpenEXR (.exr) image; PNG files are tone-mapped and cannot be compared",
            ));
        }
        // The header first: a declared size is checked before anything of
        // that size is allocated.
        let meta = exr::meta::MetaData::read_from_file(path, false)
            .map_err(|e| image_error(path, e.to_string()))?;
        for h in &meta.headers {
            let (w, h) = (h.layer_size.0, h.layer_size.1);
            if w > MAX_IMAGE_SIDE || h > MAX_IMAGE_SIDE {
                return Err(image_error(
                    path,
                    format!(
                        "declares {w} x {h} pixels; at most {MAX_IMAGE_SIDE} per side are read"
                    ),
                ));
            }
        }
        let img = exr::prelude::read_first_rgba_layer_from_file(
            path,
            |size, _| Image::new(size.0, size.1, vec![[0.0; 3]; size.0 * size.1]),
            |img: &mut Image, pos, (r, g, b, _a): (f32, f32, f32, f32)| {
                let w = img.width;
                img.pixels[pos.1 * w + pos.0] = [r, g, b];
            },
        )
        .map_err(|e| image_error(path, e.to_string()))?;
        let image = img.layer_data.channel_data.pixels;
        if let Some(i) = image
            .pixels
            .iter()
            .position(|p| p.iter().any(|v| !v.is_finite()))
        {
            return Err(image_error(
                path,
                format!(
                    "pixel ({}, {}) is {:?}: not finite",
                    i % image.width,
                    i / image.width,
                    image.pixels[i]
                ),
            ));
        }
        Ok(image)
    }
}

fn extension(path: &Path) -> String {
    path.extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase()
}

/// Encodes 8-bit RGB (row-major, 3 bytes a pixel) as PNG (the `png`
/// crate, its default adaptive filters).
///
/// # Errors
/// A zero or too large size, or `rgb.len() != width * height * 3`.
pub fn encode_png(width: usize, height: usize, rgb: &[u8]) -> Result<Vec<u8>, std::io::Error> {
    let bad = |reason: String| std::io::Error::new(std::io::ErrorKind::InvalidInput, reason);
    if rgb.len() != width.saturating_mul(height).saturating_mul(3) {
        return Err(bad(format!(
            "{} bytes for {width} x {height} RGB pixels",
            rgb.len()
        )));
    }
    let side = |v: usize| u32::try_from(v).map_err(|_| bad(format!("{v} pixels on a side")));
    let mut out = Vec::new();
    let mut encoder = png::Encoder::new(&mut out, side(width)?, side(height)?);
    encoder.set_color(png::ColorType::Rgb);
    encoder.set_depth(png::BitDepth::Eight);
    let mut writer = encoder.write_header().map_err(std::io::Error::other)?;
    writer
        .write_image_data(rgb)
        .map_err(std::io::Error::other)?;
    writer.finish().map_err(std::io::Error::other)?;
    Ok(out)
}

/// Largest width or height of an image read from a file (as of a render).
pub const MAX_IMAGE_SIDE: usize = 16_384;

/// Writes 8-bit RGB as PNG (atomically, see [`write_atomic`]).
///
/// # Errors
/// The file cannot be written.
pub fn write_png(path: &Path, width: usize, height: usize, rgb: &[u8]) -> Result<(), RenderError> {
    let bytes = encode_png(width, height, rgb).map_err(|e| crate::error::io(path, e))?;
    write_atomic(path, |tmp| std::fs::write(tmp, &bytes)).map_err(|e| crate::error::io(path, e))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_exr_header_declaring_a_huge_image_is_refused_before_reading() {
        let dir = std::env::temp_dir().join(format!("ratfit-huge-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("huge.exr");
        Image::new(4, 4, vec![[0.5; 3]; 16])
            .write_exr(&path)
            .unwrap();
        let mut bytes = std::fs::read(&path).unwrap();
        // dataWindow: name, type "box2i", size 16, then xmin ymin xmax ymax.
        let key = b"dataWindow\0box2i\0";
        let at = bytes.windows(key.len()).position(|w| w == key).unwrap() + key.len() + 4;
        bytes[at + 8..at + 12].copy_from_slice(&99_999i32.to_le_bytes());
        bytes[at + 12..at + 16].copy_from_slice(&99_999i32.to_le_bytes());
        std::fs::write(&path, &bytes).unwrap();
        let e = Image::read_exr(&path).unwrap_err().to_string();
        assert!(
            e.contains("huge.exr") && e.contains("100000 x 100000"),
            "{e}"
        );
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn atomic_writes_leave_the_old_file_or_the_new_one() {
        let dir = std::env::temp_dir().join(format!("ratfit-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("out.txt");
        std::fs::write(&path, "old").unwrap();
        let failed = write_atomic(&path, |tmp| {
            std::fs::write(tmp, "half")?;
            Err(std::io::Error::other("interrupted"))
        });
        assert!(failed.is_err());
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "old");
        assert_eq!(
            std::fs::read_dir(&dir).unwrap().count(),
            1,
            "no temporary file left"
        );
        write_atomic(&path, |tmp| std::fs::write(tmp, "new")).unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "new");
        std::fs::remove_dir_all(&dir).ok();
    }

    #[test]
    fn png_decodes_to_the_same_pixels() {
        let rgb: Vec<u8> = (0..5 * 3 * 3).map(|i| (i * 7) as u8).collect();
        let png = encode_png(5, 3, &rgb).unwrap();
        let decoder = png::Decoder::new(std::io::Cursor::new(png));
        let mut reader = decoder.read_info().unwrap();
        let mut pixels = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut pixels).unwrap();
        assert_eq!((info.width, info.height), (5, 3));
        assert_eq!(info.color_type, png::ColorType::Rgb);
        assert_eq!(&pixels[..info.buffer_size()], &rgb[..]);
        assert!(encode_png(5, 3, &rgb[1..]).is_err());
    }

    #[test]
    fn exr_round_trip_is_exact_in_f32() {
        let dir = std::env::temp_dir().join(format!("ratfit-exr-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("a.exr");
        let img = Image::new(
            3,
            2,
            (0..6).map(|i| [i as f32 * 0.37, 1e-4, 12.5]).collect(),
        );
        img.write(&path, 1.0).unwrap();
        let back = Image::read_exr(&path).unwrap();
        assert_eq!(back, img);
        let err = Image::read_exr(&dir.join("missing.exr"))
            .unwrap_err()
            .to_string();
        assert!(err.contains("missing.exr"), "{err}");
        std::fs::write(dir.join("bad.exr"), b"not an exr").unwrap();
        assert!(Image::read_exr(&dir.join("bad.exr")).is_err());
        assert!(Image::read_exr(&dir.join("a.png"))
            .unwrap_err()
            .to_string()
            .contains("OpenEXR"));
        std::fs::remove_dir_all(&dir).ok();
    }
}
