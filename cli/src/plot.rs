//! `ratfit plot`: theta_h slices of the data and of the fit at several
//! theta_d, on a log scale, as a PNG (the picture users check first).

use anyhow::Result;
use brdf::{Brdf, HalfDiff};
use std::path::Path;

/// 3x5 bitmaps of the characters tick labels need.
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
        'e' => [0, 7, 7, 4, 7],
        '-' => [0, 0, 7, 0, 0],
        '.' => [0, 0, 0, 0, 2],
        _ => [0; 5],
    }
}

struct Canvas {
    w: usize,
    h: usize,
    px: Vec<[f64; 3]>,
}

impl Canvas {
    fn set(&mut self, x: i64, y: i64, c: [f64; 3]) {
        if x >= 0 && y >= 0 && (x as usize) < self.w && (y as usize) < self.h {
            self.px[y as usize * self.w + x as usize] = c;
        }
    }

    fn line(&mut self, (x0, y0): (f64, f64), (x1, y1): (f64, f64), c: [f64; 3]) {
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

    fn text(&mut self, x: i64, y: i64, s: &str, c: [f64; 3]) {
        for (k, ch) in s.chars().enumerate() {
            let g = glyph(ch);
            for (row, bits) in g.iter().enumerate() {
                for col in 0..3 {
                    if bits >> (2 - col) & 1 == 1 {
                        for dy in 0..2 {
                            for dx in 0..2 {
                                self.set(
                                    x + 8 * k as i64 + 2 * col + dx,
                                    y + 2 * row as i64 + dy,
                                    c,
                                );
                            }
                        }
                    }
                }
            }
        }
    }
}

/// Draws `channel` of `data` (dots) and `fit` (lines) against theta_h for
/// each theta_d in `theta_d_deg`, on the slice phi_d = pi/2.
pub fn slices(
    data: &dyn Brdf,
    fit: &dyn Brdf,
    channel: usize,
    theta_d_deg: &[f64],
    path: &Path,
) -> Result<()> {
    let (w, h) = (900usize, 560usize);
    let (left, right, top, bottom) = (80.0, 20.0, 20.0, 50.0);
    let value = |b: &dyn Brdf, th: f64, td: f64| {
        let (wi, wo) = HalfDiff {
            theta_h: th,
            phi_h: 0.0,
            theta_d: td,
            phi_d: std::f64::consts::FRAC_PI_2,
        }
        .to_directions();
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return None;
        }
        let v = b.eval(wi, wo)[channel];
        (v > 0.0 && v.is_finite()).then_some(v)
    };
    let n = 400;
    let theta = |i: usize| (i as f64 / n as f64).powi(2) * std::f64::consts::FRAC_PI_2;
    let mut curves = Vec::new();
    for &td in theta_d_deg {
        let td = td.to_radians();
        let d: Vec<(f64, Option<f64>)> = (0..=n)
            .map(|i| (theta(i), value(data, theta(i), td)))
            .collect();
        let f: Vec<(f64, Option<f64>)> = (0..=n)
            .map(|i| (theta(i), value(fit, theta(i), td)))
            .collect();
        curves.push((d, f));
    }
    let all = curves
        .iter()
        .flat_map(|(d, f)| d.iter().chain(f.iter()).filter_map(|p| p.1));
    let (mut lo, mut hi) = (f64::INFINITY, 0.0_f64);
    for v in all {
        lo = lo.min(v);
        hi = hi.max(v);
    }
    if !(lo.is_finite() && hi > 0.0) {
        anyhow::bail!("nothing positive to plot");
    }
    let (ylo, yhi) = (
        lo.log10().floor().max(hi.log10().ceil() - 8.0),
        hi.log10().ceil(),
    );
    let sx = |th: f64| left + (th.to_degrees() / 90.0) * (w as f64 - left - right);
    let sy = |v: f64| top + (yhi - v.log10()) / (yhi - ylo) * (h as f64 - top - bottom);
    let mut c = Canvas {
        w,
        h,
        px: vec![[1.0; 3]; w * h],
    };
    let grey = [0.8; 3];
    let black = [0.0; 3];
    for deg in (0..=90).step_by(15) {
        let x = sx((deg as f64).to_radians());
        c.line((x, top), (x, h as f64 - bottom), grey);
        c.text(
            x as i64 - 8,
            h as i64 - bottom as i64 + 10,
            &deg.to_string(),
            black,
        );
    }
    let mut e = ylo as i64;
    while e <= yhi as i64 {
        let y = sy(10f64.powi(e as i32));
        c.line((left, y), (w as f64 - right, y), grey);
        c.text(8, y as i64 - 5, &format!("1e{e}"), black);
        e += 1;
    }
    c.line((left, top), (left, h as f64 - bottom), black);
    c.line(
        (left, h as f64 - bottom),
        (w as f64 - right, h as f64 - bottom),
        black,
    );
    let colours = [
        [0.85, 0.1, 0.1],
        [0.1, 0.5, 0.1],
        [0.1, 0.2, 0.85],
        [0.8, 0.5, 0.0],
        [0.5, 0.0, 0.6],
        [0.0, 0.6, 0.6],
    ];
    for (k, (d, f)) in curves.iter().enumerate() {
        let col = colours[k % colours.len()];
        for w2 in f.windows(2) {
            if let (Some(a), Some(b)) = (w2[0].1, w2[1].1) {
                let (ya, yb) = (sy(a.max(10f64.powf(ylo))), sy(b.max(10f64.powf(ylo))));
                c.line((sx(w2[0].0), ya), (sx(w2[1].0), yb), col);
            }
        }
        for (i, p) in d.iter().enumerate() {
            if let (true, Some(v)) = (i % 4 == 0, p.1) {
                let (x, y) = (sx(p.0) as i64, sy(v.max(10f64.powf(ylo))) as i64);
                for dy in -1..=1 {
                    for dx in -1..=1 {
                        c.set(x + dx, y + dy, col);
                    }
                }
            }
        }
    }
    crate::png::write_srgb_raw(path, w, h, &c.px)
}
