//! `ratfit plot`: theta_h slices of the data and of the fit at several
//! theta_d, on a log scale, as a PNG (the picture users check first).

use crate::canvas::Canvas;
use anyhow::Result;
use brdf::{Brdf, HalfDiff};
use std::path::Path;

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
    let mut c = Canvas::new(w, h, [1.0; 3]);
    let grey = [0.8; 3];
    let black = [0.0; 3];
    for deg in (0..=90).step_by(15) {
        let x = sx((deg as f64).to_radians());
        c.line((x, top), (x, h as f64 - bottom), grey);
        c.text(
            x as i64 - 8,
            h as i64 - bottom as i64 + 10,
            &deg.to_string(),
            2,
            black,
        );
    }
    let mut e = ylo as i64;
    while e <= yhi as i64 {
        let y = sy(10f64.powi(e as i32));
        c.line((left, y), (w as f64 - right, y), grey);
        c.text(8, y as i64 - 5, &format!("1e{e}"), 2, black);
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
                c.dot(sx(p.0), sy(v.max(10f64.powf(ylo))), 1, col);
            }
        }
    }
    c.save_png(path)
}
