//! CIELAB and the colour differences CIE76 and CIEDE2000.
//!
//! Linear sRGB (D65) goes to XYZ and to L*a*b* with the reference white at
//! luminance 1, so a linear value of 1 in every channel is L* = 100; brighter
//! pixels get L* above 100 rather than being clamped.

/// Linear sRGB to CIE XYZ (D65, IEC 61966-2-1).
pub fn linear_srgb_to_xyz(c: [f64; 3]) -> [f64; 3] {
    [
        0.412_456_4 * c[0] + 0.357_576_1 * c[1] + 0.180_437_5 * c[2],
        0.212_672_9 * c[0] + 0.715_152_2 * c[1] + 0.072_175_0 * c[2],
        0.019_333_9 * c[0] + 0.119_192_0 * c[1] + 0.950_304_1 * c[2],
    ]
}

/// D65 white with `Y = 1`.
const WHITE: [f64; 3] = [0.950_47, 1.0, 1.088_83];

/// CIE XYZ to L*a*b* relative to D65 with `Y = 1`.
pub fn xyz_to_lab(xyz: [f64; 3]) -> [f64; 3] {
    let f = |t: f64| {
        const D: f64 = 6.0 / 29.0;
        if t > D * D * D {
            t.cbrt()
        } else {
            t / (3.0 * D * D) + 4.0 / 29.0
        }
    };
    let [fx, fy, fz] = [0, 1, 2].map(|k| f(xyz[k] / WHITE[k]));
    [116.0 * fy - 16.0, 500.0 * (fx - fy), 200.0 * (fy - fz)]
}

/// Linear sRGB to L*a*b*.
pub fn linear_srgb_to_lab(c: [f64; 3]) -> [f64; 3] {
    xyz_to_lab(linear_srgb_to_xyz(c))
}

/// CIE76: Euclidean distance in L*a*b*.
pub fn delta_e76(a: [f64; 3], b: [f64; 3]) -> f64 {
    ((a[0] - b[0]).powi(2) + (a[1] - b[1]).powi(2) + (a[2] - b[2]).powi(2)).sqrt()
}

/// CIEDE2000 (kL = kC = kH = 1), following Sharma, Wu and Dalal (2005).
pub fn delta_e2000(lab1: [f64; 3], lab2: [f64; 3]) -> f64 {
    use std::f64::consts::PI;
    let [l1, a1, b1] = lab1;
    let [l2, a2, b2] = lab2;
    let c_bar = 0.5 * ((a1 * a1 + b1 * b1).sqrt() + (a2 * a2 + b2 * b2).sqrt());
    let c7 = c_bar.powi(7);
    let g = 0.5 * (1.0 - (c7 / (c7 + 25f64.powi(7))).sqrt());
    let (a1p, a2p) = ((1.0 + g) * a1, (1.0 + g) * a2);
    let (c1p, c2p) = ((a1p * a1p + b1 * b1).sqrt(), (a2p * a2p + b2 * b2).sqrt());
    let hue = |b: f64, a: f64| {
        if b.abs() < 1e-300 && a.abs() < 1e-300 {
            0.0
        } else {
            b.atan2(a).rem_euclid(2.0 * PI)
        }
    };
    let (h1p, h2p) = (hue(b1, a1p), hue(b2, a2p));
    let dl = l2 - l1;
    let dc = c2p - c1p;
    let chroma_zero = c1p * c2p < 1e-300;
    let mut dh = h2p - h1p;
    if chroma_zero {
        dh = 0.0;
    } else if dh > PI {
        dh -= 2.0 * PI;
    } else if dh < -PI {
        dh += 2.0 * PI;
    }
    let d_hh = 2.0 * (c1p * c2p).sqrt() * (0.5 * dh).sin();
    let l_bar = 0.5 * (l1 + l2);
    let c_bar_p = 0.5 * (c1p + c2p);
    let h_bar = if chroma_zero {
        h1p + h2p
    } else if (h1p - h2p).abs() <= PI {
        0.5 * (h1p + h2p)
    } else if h1p + h2p < 2.0 * PI {
        0.5 * (h1p + h2p + 2.0 * PI)
    } else {
        0.5 * (h1p + h2p - 2.0 * PI)
    };
    let t = 1.0 - 0.17 * (h_bar - PI / 6.0).cos()
        + 0.24 * (2.0 * h_bar).cos()
        + 0.32 * (3.0 * h_bar + PI / 30.0).cos()
        - 0.20 * (4.0 * h_bar - 63f64.to_radians()).cos();
    let d_theta = 30f64.to_radians() * (-((h_bar.to_degrees() - 275.0) / 25.0).powi(2)).exp();
    let cb7 = c_bar_p.powi(7);
    let rc = 2.0 * (cb7 / (cb7 + 25f64.powi(7))).sqrt();
    let l50 = (l_bar - 50.0).powi(2);
    let sl = 1.0 + 0.015 * l50 / (20.0 + l50).sqrt();
    let sc = 1.0 + 0.045 * c_bar_p;
    let sh = 1.0 + 0.015 * c_bar_p * t;
    let rt = -(2.0 * d_theta).sin() * rc;
    ((dl / sl).powi(2) + (dc / sc).powi(2) + (d_hh / sh).powi(2) + rt * (dc / sc) * (d_hh / sh))
        .sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn ciede2000_matches_sharma_test_data() {
        // Pairs 1, 2, 3, 7, 17 and 25 of Sharma, Wu and Dalal (2005), Table 1.
        let cases = [
            ([50.0, 2.6772, -79.7751], [50.0, 0.0, -82.7485], 2.0425),
            ([50.0, 3.1571, -77.2803], [50.0, 0.0, -82.7485], 2.8615),
            ([50.0, 2.8361, -74.0200], [50.0, 0.0, -82.7485], 3.4412),
            ([50.0, 0.0, 0.0], [50.0, -1.0, 2.0], 2.3669),
            ([50.0, 2.5, 0.0], [73.0, 25.0, -18.0], 27.1492),
            (
                [60.2574, -34.0099, 36.2677],
                [60.4626, -34.1751, 39.4387],
                1.2644,
            ),
        ];
        for (a, b, want) in cases {
            let got = delta_e2000(a, b);
            assert!((got - want).abs() < 5e-5, "{a:?} {b:?}: {got} vs {want}");
            assert!((delta_e2000(b, a) - got).abs() < 1e-9, "symmetric");
        }
    }

    #[test]
    fn white_is_l100_and_black_is_zero() {
        let w = linear_srgb_to_lab([1.0; 3]);
        assert!(
            (w[0] - 100.0).abs() < 1e-3 && w[1].abs() < 1e-2 && w[2].abs() < 1e-2,
            "{w:?}"
        );
        let k = linear_srgb_to_lab([0.0; 3]);
        assert!(k.iter().all(|v| v.abs() < 1e-12));
        // Linear 0.18 grey is L* ~ 49.5.
        assert!((linear_srgb_to_lab([0.18; 3])[0] - 49.5).abs() < 0.1);
        assert!((delta_e76([1.0, 2.0, 3.0], [1.0, 2.0, 7.0]) - 4.0).abs() < 1e-12);
    }
}
