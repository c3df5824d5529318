//! Comparing two renders: CIELAB differences, RMSE and a false-colour map.

use crate::color::{delta_e2000, delta_e76, linear_srgb_to_lab};
use crate::error::invalid;
use crate::image::Image;
use crate::RenderError;
use serde::Serialize;

/// Differences between two images of the same size.
#[derive(Debug, Clone, Serialize)]
pub struct Comparison {
    /// Pixels compared.
    pub pixels: usize,
    /// Pixels where either image is not black (the object, not the
    /// background).
    pub covered: usize,
    /// Mean CIEDE2000 difference over the covered pixels.
    pub covered_mean_de2000: f64,
    /// Mean CIE76 difference over the covered pixels.
    pub covered_mean_de76: f64,
    /// Mean CIE76 difference.
    pub mean_de76: f64,
    /// Largest CIE76 difference.
    pub max_de76: f64,
    /// Mean CIEDE2000 difference.
    pub mean_de2000: f64,
    /// Largest CIEDE2000 difference.
    pub max_de2000: f64,
    /// 99th percentile of CIEDE2000.
    pub p99_de2000: f64,
    /// Root-mean-square difference of the linear values, per channel.
    pub rmse: [f64; 3],
    /// Root-mean-square difference over all channels.
    pub rmse_all: f64,
}

impl std::fmt::Display for Comparison {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        writeln!(
            f,
            "pixels            {} ({} not black in either image)",
            self.pixels, self.covered
        )?;
        writeln!(
            f,
            "over those        CIEDE2000 mean {:.4}, CIE76 mean {:.4}",
            self.covered_mean_de2000, self.covered_mean_de76
        )?;
        writeln!(
            f,
            "CIEDE2000         mean {:.4}  p99 {:.4}  max {:.4}",
            self.mean_de2000, self.p99_de2000, self.max_de2000
        )?;
        writeln!(
            f,
            "CIE76             mean {:.4}  max {:.4}",
            self.mean_de76, self.max_de76
        )?;
        write!(
            f,
            "RMSE (linear)     {:.4e}  (r {:.4e}, g {:.4e}, b {:.4e})",
            self.rmse_all, self.rmse[0], self.rmse[1], self.rmse[2]
        )
    }
}

/// Compares `a` and `b` after multiplying both by `exposure` (Lab white at
/// linear 1); also returns the per-pixel CIEDE2000 map.
///
/// # Errors
/// Different sizes, an empty image or a non-positive exposure.
pub fn compare(a: &Image, b: &Image, exposure: f64) -> Result<(Comparison, Vec<f64>), RenderError> {
    if (a.width, a.height) != (b.width, b.height) {
        return Err(invalid(
            "images",
            format!(
                "sizes differ: {}x{} and {}x{}",
                a.width, a.height, b.width, b.height
            ),
        ));
    }
    if a.pixels.is_empty() {
        return Err(invalid("images", "no pixels"));
    }
    if !(exposure > 0.0 && exposure.is_finite()) {
        return Err(invalid("exposure", format!("{exposure} is not positive")));
    }
    let n = a.pixels.len();
    let mut de00 = Vec::with_capacity(n);
    let (mut s76, mut m76, mut sq) = (0.0, 0.0f64, [0.0; 3]);
    let (mut covered, mut c76, mut c00) = (0usize, 0.0, 0.0);
    for (p, q) in a.pixels.iter().zip(&b.pixels) {
        let pa = p.map(|v| f64::from(v) * exposure);
        let pb = q.map(|v| f64::from(v) * exposure);
        let (la, lb) = (linear_srgb_to_lab(pa), linear_srgb_to_lab(pb));
        let d76 = delta_e76(la, lb);
        s76 += d76;
        m76 = m76.max(d76);
        let d00 = delta_e2000(la, lb);
        de00.push(d00);
        if p.iter().chain(q).any(|v| v.abs() > 0.0) {
            covered += 1;
            c76 += d76;
            c00 += d00;
        }
        for c in 0..3 {
            sq[c] += (f64::from(p[c]) - f64::from(q[c])).powi(2);
        }
    }
    let mut sorted = de00.clone();
    sorted.sort_by(f64::total_cmp);
    let p99 = sorted[((0.99 * (n - 1) as f64).round() as usize).min(n - 1)];
    let rmse = sq.map(|s| (s / n as f64).sqrt());
    Ok((
        Comparison {
            pixels: n,
            covered,
            covered_mean_de2000: c00 / covered.max(1) as f64,
            covered_mean_de76: c76 / covered.max(1) as f64,
            mean_de76: s76 / n as f64,
            max_de76: m76,
            mean_de2000: de00.iter().sum::<f64>() / n as f64,
            max_de2000: sorted[n - 1],
            p99_de2000: p99,
            rmse,
            rmse_all: ((sq[0] + sq[1] + sq[2]) / (3 * n) as f64).sqrt(),
        },
        de00,
    ))
}

/// A false-colour image of per-pixel differences: black at 0 through blue,
/// green and yellow to white at `full_scale` and above (8-bit RGB).
pub fn false_colour(values: &[f64], full_scale: f64) -> Vec<u8> {
    const STOPS: [[f64; 3]; 5] = [
        [0.0, 0.0, 0.0],
        [0.1, 0.2, 0.8],
        [0.1, 0.75, 0.3],
        [0.95, 0.85, 0.1],
        [1.0, 1.0, 1.0],
    ];
    values
        .iter()
        .flat_map(|&v| {
            let t = (v / full_scale).clamp(0.0, 1.0) * (STOPS.len() - 1) as f64;
            let i = (t.floor() as usize).min(STOPS.len() - 2);
            let f = t - i as f64;
            [0, 1, 2].map(|c| {
                let x = STOPS[i][c] + (STOPS[i + 1][c] - STOPS[i][c]) * f;
                (x * 255.0 + 0.5) as u8
            })
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn identical_images_differ_by_zero_and_sizes_must_match() {
        let a = Image::new(2, 2, vec![[0.2, 0.4, 0.1]; 4]);
        let (c, map) = compare(&a, &a, 1.0).unwrap();
        assert!(
            c.mean_de2000.abs() < 1e-12 && c.max_de76.abs() < 1e-12 && c.rmse_all.abs() < 1e-12
        );
        assert_eq!(map.len(), 4);
        let b = Image::new(1, 4, vec![[0.2, 0.4, 0.1]; 4]);
        assert!(compare(&a, &b, 1.0)
            .unwrap_err()
            .to_string()
            .contains("sizes differ"));
        let mut c2 = a.clone();
        c2.pixels[0] = [0.3, 0.4, 0.1];
        let (c, _) = compare(&a, &c2, 1.0).unwrap();
        assert!(c.max_de2000 > 1.0 && (c.mean_de2000 - c.max_de2000 / 4.0).abs() < 1e-9);
        assert_eq!(c.covered, 4);
        let mut black = a.clone();
        black.pixels[1] = [0.0; 3];
        let mut black2 = c2.clone();
        black2.pixels[1] = [0.0; 3];
        let (c, _) = compare(&black, &black2, 1.0).unwrap();
        assert_eq!(c.covered, 3);
        assert!((c.covered_mean_de2000 - c.max_de2000 / 3.0).abs() < 1e-9);
        assert!((c.rmse[0] - 0.05).abs() < 1e-6 && c.rmse[1].abs() < 1e-12);
        assert_eq!(
            false_colour(&[0.0, 100.0], 10.0),
            vec![0, 0, 0, 255, 255, 255]
        );
    }
}
