//! Directions on the hemisphere (z is the normal) and the Rusinkiewicz
//! half/difference parametrisation.

use std::f64::consts::PI;

/// A 3-vector.
pub type Vec3 = [f64; 3];

/// Dot product.
pub fn dot(a: Vec3, b: Vec3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

/// Cross product.
pub fn cross(a: Vec3, b: Vec3) -> Vec3 {
    [
        a[1] * b[2] - a[2] * b[1],
        a[2] * b[0] - a[0] * b[2],
        a[0] * b[1] - a[1] * b[0],
    ]
}

/// Unit vector along `a` (unchanged if zero).
pub fn normalize(a: Vec3) -> Vec3 {
    let n = dot(a, a).sqrt();
    if n > 0.0 {
        [a[0] / n, a[1] / n, a[2] / n]
    } else {
        a
    }
}

/// Direction of elevation `theta` from the normal and azimuth `phi`.
pub fn from_spherical(theta: f64, phi: f64) -> Vec3 {
    let (st, ct) = theta.sin_cos();
    let (sp, cp) = phi.sin_cos();
    [st * cp, st * sp, ct]
}

/// `d` moved to the elevation whose cosine and sine are `cos_cut` and
/// `sin_cut`, at the same azimuth, when it lies further from the normal.
/// A fit whose samples stop at an elevation cut is evaluated at the cut
/// beyond it; every evaluation path of a fit (f64, f32, the shaders) uses
/// this one rule.
pub fn clamp_elevation(d: Vec3, cos_cut: f64, sin_cut: f64) -> Vec3 {
    if d[2] >= cos_cut {
        return d;
    }
    let s = (d[0] * d[0] + d[1] * d[1]).sqrt();
    if s <= 0.0 {
        return d;
    }
    [d[0] * sin_cut / s, d[1] * sin_cut / s, cos_cut]
}

/// `(theta, phi)` of a unit direction; `theta` as [`elevation`], `phi` in
/// `(-pi, pi]`.
pub fn to_spherical(d: Vec3) -> (f64, f64) {
    (elevation(d), d[1].atan2(d[0]))
}

/// `theta` of a unit direction, from its distance to the normal (accurate
/// near the normal, where `acos(z)` loses half its digits).
pub fn elevation(d: Vec3) -> f64 {
    let dist = (d[0] * d[0] + d[1] * d[1] + (d[2] - 1.0) * (d[2] - 1.0)).sqrt();
    2.0 * (0.5 * dist).clamp(-1.0, 1.0).asin()
}

/// Rotation of `v` about the unit `axis` by `angle` (Rodrigues).
pub fn rotate(v: Vec3, axis: Vec3, angle: f64) -> Vec3 {
    let (s, c) = angle.sin_cos();
    let k = cross(axis, v);
    let d = dot(axis, v) * (1.0 - c);
    [
        v[0] * c + k[0] * s + axis[0] * d,
        v[1] * c + k[1] * s + axis[1] * d,
        v[2] * c + k[2] * s + axis[2] * d,
    ]
}

/// Rusinkiewicz coordinates of a direction pair (Rusinkiewicz 1998, as in
/// the MERL reference code): half vector `(theta_h, phi_h)` and the incident
/// direction seen from the half-vector frame `(theta_d, phi_d)`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct HalfDiff {
    /// Elevation of the half vector.
    pub theta_h: f64,
    /// Azimuth of the half vector.
    pub phi_h: f64,
    /// Elevation of the incident direction about the half vector.
    pub theta_d: f64,
    /// Azimuth of the incident direction about the half vector.
    pub phi_d: f64,
}

/// `phi_d` folded into `[0, pi]`: [`HalfDiff::folded_phi_d`] of an angle.
pub fn fold_phi_d(phi_d: f64) -> f64 {
    let p = phi_d.rem_euclid(2.0 * PI);
    if p > PI {
        2.0 * PI - p
    } else {
        p
    }
}

/// The unit half vector of a pair and its `[theta_h, theta_d, phi_d]`:
/// `wi` rotated by `-phi_h` about the normal and by `-theta_h` about `y`
/// (Rusinkiewicz), with the rotations' sines and cosines taken from the
/// half vector's components rather than from its angles (no `sin_cos`,
/// as the f32 path does).
fn half_and_angles(wi: Vec3, wo: Vec3) -> (Vec3, [f64; 3]) {
    let h = normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
    let theta_h = elevation(h);
    let s = (h[0] * h[0] + h[1] * h[1]).sqrt();
    let (cp, sp) = if s > 0.0 {
        (h[0] / s, h[1] / s)
    } else {
        (1.0, 0.0)
    };
    let a = [wi[0] * cp + wi[1] * sp, wi[1] * cp - wi[0] * sp, wi[2]];
    let (ct, st) = (h[2], s);
    let diff = [a[0] * ct - a[2] * st, a[1], a[0] * st + a[2] * ct];
    let (theta_d, phi_d) = to_spherical(diff);
    (h, [theta_h, theta_d, phi_d])
}

impl HalfDiff {
    /// From incident (`wi`) and outgoing (`wo`) unit directions.
    pub fn from_directions(wi: Vec3, wo: Vec3) -> Self {
        let (h, [theta_h, theta_d, phi_d]) = half_and_angles(wi, wo);
        Self {
            theta_h,
            phi_h: h[1].atan2(h[0]),
            theta_d,
            phi_d,
        }
    }

    /// `[theta_h, theta_d, phi_d]` of a pair, as [`HalfDiff::from_directions`]
    /// computes them without `phi_h`, which an isotropic BRDF never reads
    /// (and whose `atan2` is a sixth of the conversion's cost).
    pub fn isotropic_angles(wi: Vec3, wo: Vec3) -> [f64; 3] {
        half_and_angles(wi, wo).1
    }

    /// The direction pair at Rusinkiewicz angles `[theta_h, theta_d,
    /// phi_d]` with `phi_h = 0`: the pair a cell of an isotropic table
    /// stands for.
    pub fn pair_at(angles: [f64; 3]) -> (Vec3, Vec3) {
        Self {
            theta_h: angles[0],
            phi_h: 0.0,
            theta_d: angles[1],
            phi_d: angles[2],
        }
        .to_directions()
    }

    /// The direction pairs at the centres of an `nh x nd x np` grid of
    /// half-difference cells (`theta_h` warped by a square root, so that
    /// cells are fine at the specular peak; `theta_d` over `[0, pi/2]`,
    /// `phi_d` over `[0, pi]`), in that order, those below the horizon left
    /// out: the dense grids on which fits are checked.
    pub fn cell_centres([nh, nd, np]: [usize; 3]) -> Vec<(Vec3, Vec3)> {
        (0..nh * nd * np)
            .map(|n| {
                let (i, j, k) = (n / (nd * np), (n / np) % nd, n % np);
                let u = (i as f64 + 0.5) / nh as f64;
                Self::pair_at([
                    u * u * PI / 2.0,
                    (j as f64 + 0.5) / nd as f64 * PI / 2.0,
                    (k as f64 + 0.5) / np as f64 * PI,
                ])
            })
            .filter(|(wi, wo)| wi[2] > 0.0 && wo[2] > 0.0)
            .collect()
    }

    /// The direction pair `(wi, wo)`.
    pub fn to_directions(self) -> (Vec3, Vec3) {
        let diff = from_spherical(self.theta_d, self.phi_d);
        let wi = rotate(
            rotate(diff, [0.0, 1.0, 0.0], self.theta_h),
            [0.0, 0.0, 1.0],
            self.phi_h,
        );
        let h = from_spherical(self.theta_h, self.phi_h);
        let k = 2.0 * dot(wi, h);
        let wo = [k * h[0] - wi[0], k * h[1] - wi[1], k * h[2] - wi[2]];
        (wi, wo)
    }

    /// `phi_d` folded into `[0, pi]` by mirror symmetry, `|phi_d|` with
    /// `phi_d` in `(-pi, pi]`: mirroring both directions across the plane
    /// of incidence negates `phi_d`, so an isotropic BRDF depends only on
    /// the folded angle, and the fold is continuous. (Folding by `pi`
    /// instead assumes reciprocity, which measured tables do not have, and
    /// puts a seam where `phi_d` crosses 0.)
    pub fn folded_phi_d(self) -> f64 {
        fold_phi_d(self.phi_d)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn round_trip_directions() {
        for &(ti, pi_, to, po) in &[
            (0.3, 0.1, 0.7, 2.0),
            (1.2, -2.0, 0.2, 0.4),
            (0.01, 0.0, 1.5, 3.0),
            (0.9, 1.0, 0.9, 1.0 + PI),
        ] {
            let wi = from_spherical(ti, pi_);
            let wo = from_spherical(to, po);
            let hd = HalfDiff::from_directions(wi, wo);
            let (a, b) = hd.to_directions();
            for k in 0..3 {
                assert!(
                    (a[k] - wi[k]).abs() < 1e-12 && (b[k] - wo[k]).abs() < 1e-12,
                    "{hd:?}"
                );
            }
        }
    }

    /// The rotations taken from the half vector's components give the
    /// angles the rotations by `phi_h` and `theta_h` themselves give
    /// (Rusinkiewicz's construction, as the MERL reference code computes
    /// it), and [`HalfDiff::isotropic_angles`] is
    /// [`HalfDiff::from_directions`] without `phi_h`.
    #[test]
    fn half_vector_rotations_match_rotations_by_the_angles() {
        let by_angles = |wi: Vec3, wo: Vec3| {
            let h = normalize([wi[0] + wo[0], wi[1] + wo[1], wi[2] + wo[2]]);
            let (theta_h, phi_h) = to_spherical(h);
            let tmp = rotate(wi, [0.0, 0.0, 1.0], -phi_h);
            let diff = rotate(tmp, [0.0, 1.0, 0.0], -theta_h);
            let (theta_d, phi_d) = to_spherical(diff);
            [theta_h, phi_h, theta_d, phi_d]
        };
        let mut worst = 0.0_f64;
        for a in 0..12 {
            for b in 0..12 {
                for p in 0..8 {
                    let wi = from_spherical(0.13 * a as f64, 0.3 * p as f64 - 1.0);
                    let wo = from_spherical(0.13 * b as f64, 2.1 - 0.7 * p as f64);
                    let hd = HalfDiff::from_directions(wi, wo);
                    let want = by_angles(wi, wo);
                    let got = [hd.theta_h, hd.phi_h, hd.theta_d, hd.phi_d];
                    for (g, w) in got.iter().zip(&want) {
                        // phi_d is undefined where theta_d vanishes.
                        let d = (g - w).abs();
                        let d = if want[2] < 1e-9 {
                            0.0
                        } else {
                            d.min(2.0 * PI - d)
                        };
                        worst = worst.max(d);
                    }
                    let iso = HalfDiff::isotropic_angles(wi, wo);
                    let same = [hd.theta_h, hd.theta_d, hd.phi_d].map(f64::to_bits);
                    assert_eq!(iso.map(f64::to_bits), same);
                }
            }
        }
        assert!(worst < 1e-12, "{worst:e}");
    }

    #[test]
    fn mirrored_directions_share_the_folded_phi_d_and_the_fold_is_continuous() {
        let mirror = |d: Vec3| [d[0], -d[1], d[2]];
        let wi = from_spherical(0.4, 0.3);
        let wo = from_spherical(0.9, 2.1);
        let a = HalfDiff::from_directions(wi, wo);
        let b = HalfDiff::from_directions(mirror(wi), mirror(wo));
        assert!((a.theta_h - b.theta_h).abs() < 1e-12 && (a.theta_d - b.theta_d).abs() < 1e-12);
        assert!((a.folded_phi_d() - b.folded_phi_d()).abs() < 1e-12);
        // Swapping the directions adds pi: not the same angle for a
        // non-reciprocal table.
        let c = HalfDiff::from_directions(wo, wi);
        assert!((a.folded_phi_d() + c.folded_phi_d() - PI).abs() < 1e-12);
        // Across phi_d = 0 and pi the folded angle changes continuously.
        for p in [0.0, PI] {
            for eps in [1e-6, -1e-6] {
                let h = HalfDiff {
                    theta_h: 0.3,
                    phi_h: 0.0,
                    theta_d: 0.5,
                    phi_d: p + eps,
                };
                assert!((h.folded_phi_d() - p).abs() < 2e-6, "{p} {eps}");
            }
        }
    }

    #[test]
    fn mirror_configuration_has_zero_half_angle() {
        let hd = HalfDiff::from_directions(from_spherical(0.5, 0.0), from_spherical(0.5, PI));
        assert!(hd.theta_h.abs() < 1e-12);
        assert!((hd.theta_d - 0.5).abs() < 1e-12);
    }
}
