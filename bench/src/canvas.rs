//! A raster canvas for plots: lines, markers and a 3x5 pixel font, written
//! as PNG without an image dependency.

use anyhow::Result;
use std::path::Path;

/// 3x5 bitmaps (rows top to bottom, bit 2 the left column); lower-case
/// letters are drawn as capitals.
fn glyph(c: char) -> [u8; 5] {
    match c {
        '0' => [7, 5, 5, 5, 7],
        '1' => [2, 6, 2, 2, 7],
        '2' => [7, 1, 7, 4, 7],
        '3' => [7, 1, 7, 1, 7],
        '4' => [5, 5, 7, 1, 1],
        '5' => [7, 4, 7, 1, 7],
        '6' => [7, 4, 7, 5, 7],
        '7' => [7, 1, 1, 1, 1],
        '8' => [7, 5, 7, 5, 7],
        '9' => [7, 5, 7, 1, 7],
        'A' => [2, 5, 7, 5, 5],
        'B' => [6, 5, 6, 5, 6],
        'C' => [3, 4, 4, 4, 3],
        'D' => [6, 5, 5, 5, 6],
        'E' => [7, 4, 6, 4, 7],
        'F' => [7, 4, 6, 4, 4],
        'G' => [3, 4, 5, 5, 3],
        'H' => [5, 5, 7, 5, 5],
        'I' => [7, 2, 2, 2, 7],
        'J' => [1, 1, 1, 5, 2],
        'K' => [5, 5, 6, 5, 5],
        'L' => [4, 4, 4, 4, 7],
        'M' => [5, 7, 7, 5, 5],
        'N' => [6, 5, 5, 5, 5],
        'O' => [2, 5, 5, 5, 2],
        'P' => [6, 5, 6, 4, 4],
        'Q' => [2, 5, 5, 6, 3],
        'R' => [6, 5, 6, 5, 5],
        'S' => [3, 4, 2, 1, 6],
        'T' => [7, 2, 2, 2, 2],
        'U' => [5, 5, 5, 5, 7],
        'V' => [5, 5, 5, 5, 2],
        'W' => [5, 5, 7, 7, 5],
        'X' => [5, 5, 2, 5, 5],
        'Y' => [5, 5, 2, 2, 2],
        'Z' => [7, 1, 2, 4, 7],
        '-' => [0, 0, 7, 0, 0],
        '.' => [0, 0, 0, 0, 2],
        ',' => [0, 0, 0, 2, 4],
        '+' => [0, 2, 7, 2, 0],
        '(' => [1, 2, 2, 2, 1],
        ')' => [4, 2, 2, 2, 4],
        '[' => [3, 2, 2, 2, 3],
        ']' => [6, 2, 2, 2, 6],
        '/' => [1, 1, 2, 4, 4],
        ':' => [0, 2, 0, 2, 0],
        '=' => [0, 7, 0, 7, 0],
        '_' => [0, 0, 0, 0, 7],
        '%' => [5, 1, 2, 4, 5],
        c if c.is_ascii_lowercase() => glyph(c.to_ascii_uppercase()),
        _ => [0; 5],
    }
}

/// Pixel width of `s` drawn by [`Canvas::text`] at `scale`.
pub fn text_width(s: &str, scale: i64) -> i64 {
    4 * scale * s.chars().count() as i64
}

/// An RGB image in [0, 1], row-major.
pub struct Canvas {
    /// Width in pixels.
    pub w: usize,
    /// Height in pixels.
    pub h: usize,
    px: Vec<[f64; 3]>,
}

impl Canvas {
    /// A `w` x `h` canvas filled with `background`.
    pub fn new(w: usize, h: usize, background: [f64; 3]) -> Self {
        Self {
            w,
            h,
            px: vec![background; w * h],
        }
    }

    /// Sets one pixel (ignored outside the canvas).
    pub fn set(&mut self, x: i64, y: i64, c: [f64; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            self.px[y as usize * self.w + x as usize] = c;
        }
    }

    /// A one-pixel line.
    pub fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [f64; 3]) {
        let n = ((x1 - x0).abs().max((y1 - y0).abs()).ceil() as usize).max(1);
        for i in 0..=n {
            let t = i as f64 / n as f64;
            self.set(
                (x0 + t * (x1 - x0)).round() as i64,
                (y0 + t * (y1 - y0)).round() as i64,
                c,
            );
        }
    }

    /// A filled square of side `2 r + 1` centred on `(x, y)`.
    pub fn dot(&mut self, x: f64, y: f64, r: i64, c: [f64; 3]) {
        let (x, y) = (x.round() as i64, y.round() as i64);
        for dy in -r..=r {
            for dx in -r..=r {
                self.set(x + dx, y + dy, c);
            }
        }
    }

    /// The outline of a square of side `2 r + 1` centred on `(x, y)`.
    pub fn ring(&mut self, x: f64, y: f64, r: i64, c: [f64; 3]) {
        let (x, y) = (x.round() as i64, y.round() as i64);
        for d in -r..=r {
            self.set(x + d, y - r, c);
            self.set(x + d, y + r, c);
            self.set(x - r, y + d, c);
            self.set(x + r, y + d, c);
        }
    }

    /// Text with its top-left corner at `(x, y)`, each font pixel drawn as
    /// `scale` x `scale`.
    pub fn text(&mut self, x: i64, y: i64, s: &str, scale: i64, c: [f64; 3]) {
        for (k, ch) in s.chars().enumerate() {
            for (row, bits) in glyph(ch).iter().enumerate() {
                for col in 0..3 {
                    if bits >> (2 - col) & 1 == 1 {
                        for dy in 0..scale {
                            for dx in 0..scale {
                                self.set(
                                    x + 4 * scale * k as i64 + scale * col + dx,
                                    y + scale * row as i64 + dy,
                                    c,
                                );
                            }
                        }
                    }
                }
            }
        }
    }

    /// Writes the canvas as PNG (values taken as display-ready, clamped to
    /// [0, 1]).
    pub fn save_png(&self, path: &Path) -> Result<()> {
        let bytes: Vec<u8> = self
            .px
            .iter()
            .flat_map(|p| p.map(|v| (v.clamp(0.0, 1.0) * 255.0 + 0.5) as u8))
            .collect();
        Ok(render_cpu::write_png(path, self.w, self.h, &bytes)?)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_printable_letter_has_a_glyph() {
        for c in ('A'..='Z').chain('0'..='9') {
            assert!(glyph(c).iter().any(|&b| b != 0), "{c}");
        }
        assert_eq!(glyph('q'), glyph('Q'));
        assert_eq!(glyph('e'), glyph('E'));
    }

    #[test]
    fn text_lands_where_measured() {
        let mut c = Canvas::new(40, 10, [1.0; 3]);
        c.text(0, 0, "1", 2, [0.0; 3]);
        // '1' has its top row in the middle column only.
        assert!(c.px[2].iter().all(|v| v.abs() < 1e-12));
        assert!(c.px[0].iter().all(|v| (v - 1.0).abs() < 1e-12));
        assert_eq!(text_width("ab", 2), 16);
    }
}
