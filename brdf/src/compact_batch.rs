//! Batched f32 evaluation of a [`CompactBrdf`]: [`LANES`] direction pairs
//! at a time in structure-of-arrays form, every step a loop over the lanes
//! without calls or branches, so the compiler turns it into vector
//! instructions. The one transcendental function on the path, `atan2`, is
//! a branch-free polynomial ([`atan2_lanes`], within two ulps of pi,
//! 4.8e-7 radians, of the library's); everything else is the arithmetic of [`CompactBrdf::eval`]
//! in the same order.

use crate::compact::{CompactBrdf, CompactChannel};
use crate::{ColourMode, Coordinates};
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};

/// Pairs evaluated together: two AVX or four SSE registers of f32.
pub const LANES: usize = 8;

/// One f32 per lane.
type Lanes = [f32; LANES];

/// Largest degree per coordinate of the batched path; fits with higher
/// degrees are evaluated pair by pair.
const MAX_DEGREE: usize = 31;

fn map1(a: &Lanes, f: impl Fn(f32) -> f32) -> Lanes {
    std::array::from_fn(|l| f(a[l]))
}

fn map2(a: &Lanes, b: &Lanes, f: impl Fn(f32, f32) -> f32) -> Lanes {
    std::array::from_fn(|l| f(a[l], b[l]))
}

/// `atan(a)` for `a` in `[0, 1]`: reduced by `tan(pi/8)` to `|x| <= 0.4142`
/// and a degree-9 odd polynomial there (Cephes' `atanf` coefficients).
fn atan_unit(a: f32) -> f32 {
    let big = a > 0.414_213_57;
    let x = if big { (a - 1.0) / (a + 1.0) } else { a };
    let z = x * x;
    let p =
        (((8.053_744_5e-2 * z - 1.387_768_6e-1) * z + 1.997_771_1e-1) * z - 3.333_295e-1) * z * x
            + x;
    if big {
        FRAC_PI_4 + p
    } else {
        p
    }
}

/// `atan2(y, x)` lane by lane, branch-free: the octant is chosen by
/// selections, so the loop vectorises. `atan2(0, 0) = 0` as in libm.
pub fn atan2_lanes(y: &Lanes, x: &Lanes) -> Lanes {
    std::array::from_fn(|l| {
        let (ax, ay) = (x[l].abs(), y[l].abs());
        let (lo, hi) = (ax.min(ay), ax.max(ay));
        let a = if hi > 0.0 { lo / hi } else { 0.0 };
        let mut r = atan_unit(a);
        r = if ay > ax { FRAC_PI_2 - r } else { r };
        r = if x[l] < 0.0 { PI - r } else { r };
        if y[l] < 0.0 {
            -r
        } else {
            r
        }
    })
}

/// Directions of [`LANES`] pairs, by component.
struct Pairs {
    wi: [Lanes; 3],
    wo: [Lanes; 3],
}

impl Pairs {
    fn load(wi: &[[f32; 3]], wo: &[[f32; 3]]) -> Self {
        // Missing lanes of a last, short batch hold the normal.
        let pick = |v: &[[f32; 3]], l: usize, c: usize| {
            v.get(l).map_or(if c == 2 { 1.0 } else { 0.0 }, |d| d[c])
        };
        Self {
            wi: std::array::from_fn(|c| std::array::from_fn(|l| pick(wi, l, c))),
            wo: std::array::from_fn(|c| std::array::from_fn(|l| pick(wo, l, c))),
        }
    }
}

/// [`crate::compact::clamp_elevation_f32`] lane by lane.
fn clamp_elevation_lanes(d: &mut [Lanes; 3], cos_cut: f32, sin_cut: f32) {
    for l in 0..LANES {
        let s = (d[0][l] * d[0][l] + d[1][l] * d[1][l]).sqrt();
        let moved = d[2][l] < cos_cut && s > 0.0;
        let k = if moved { sin_cut / s } else { 1.0 };
        d[0][l] *= k;
        d[1][l] *= k;
        d[2][l] = if moved { cos_cut } else { d[2][l] };
    }
}

/// [`crate::compact::half_diff_f32`] lane by lane: `(theta_h, theta_d,
/// phi_d)`.
fn half_diff_lanes(wi: &[Lanes; 3], wo: &[Lanes; 3]) -> [Lanes; 3] {
    let mut h: [Lanes; 3] = std::array::from_fn(|c| map2(&wi[c], &wo[c], |a, b| a + b));
    let n: Lanes =
        std::array::from_fn(|l| (h[0][l] * h[0][l] + h[1][l] * h[1][l] + h[2][l] * h[2][l]).sqrt());
    for c in &mut h {
        *c = map2(c, &n, |a, b| a / b);
    }
    let s: Lanes = std::array::from_fn(|l| (h[0][l] * h[0][l] + h[1][l] * h[1][l]).sqrt());
    let theta_h = atan2_lanes(&s, &h[2]);
    let cp = map2(&h[0], &s, |x, s| if s > 0.0 { x / s } else { 1.0 });
    let sp = map2(&h[1], &s, |y, s| if s > 0.0 { y / s } else { 0.0 });
    let mut d: [Lanes; 3] = [[0.0; LANES]; 3];
    for l in 0..LANES {
        let a = [
            wi[0][l] * cp[l] + wi[1][l] * sp[l],
            wi[1][l] * cp[l] - wi[0][l] * sp[l],
            wi[2][l],
        ];
        let (ct, st) = (h[2][l], s[l]);
        d[0][l] = a[0] * ct - a[2] * st;
        d[1][l] = a[1];
        d[2][l] = a[0] * st + a[2] * ct;
    }
    let sd: Lanes = std::array::from_fn(|l| (d[0][l] * d[0][l] + d[1][l] * d[1][l]).sqrt());
    let theta_d = atan2_lanes(&sd, &d[2]);
    let phi_d = map1(&atan2_lanes(&d[1], &d[0]), f32::abs);
    [theta_h, theta_d, phi_d]
}

/// Univariate basis values per coordinate, degree and lane.
type Tables = [[Lanes; MAX_DEGREE + 1]; 3];

/// `p / q` of one channel at [`LANES`] points (`x[k]` the k-th coordinate);
/// `tables` is scratch, reused so that it is not cleared for every batch.
fn channel_lanes(c: &CompactChannel, x: &[Lanes; 3], dims: usize, tables: &mut Tables) -> Lanes {
    for k in 0..dims {
        let w = c.upper[k] - c.lower[k];
        let t = map1(&x[k], |v| {
            if w > 0.0 {
                2.0 * (v - c.lower[k]) / w - 1.0
            } else {
                0.0
            }
        });
        let table = &mut tables[k];
        table[0] = [1.0; LANES];
        let deg = c.max_degree(k);
        if deg >= 1 {
            table[1] = t;
        }
        for j in 1..deg {
            let jf = j as f32;
            let (prev, cur) = (table[j - 1], table[j]);
            // The family is chosen outside the lane loop, which stays
            // branch-free.
            table[j + 1] = match c.family {
                rational_core::BasisFamily::Monomial => map2(&cur, &t, |c, t| c * t),
                rational_core::BasisFamily::Chebyshev => {
                    std::array::from_fn(|l| 2.0 * t[l] * cur[l] - prev[l])
                }
                rational_core::BasisFamily::Legendre => std::array::from_fn(|l| {
                    ((2.0 * jf + 1.0) * t[l] * cur[l] - jf * prev[l]) / (jf + 1.0)
                }),
            };
        }
    }
    let (mut p, mut q) = ([0.0f32; LANES], [0.0f32; LANES]);
    let [t0, t1, t2] = &*tables;
    for (j, idx) in c.indices.iter().enumerate() {
        // The basis function at every lane; the dimension is fixed per
        // loop so that the product has no inner loop.
        let phi: Lanes = match dims {
            1 => t0[idx[0] as usize],
            2 => map2(&t0[idx[0] as usize], &t1[idx[1] as usize], |a, b| a * b),
            _ => {
                let (u, v, w) = (
                    &t0[idx[0] as usize],
                    &t1[idx[1] as usize],
                    &t2[idx[2] as usize],
                );
                std::array::from_fn(|l| u[l] * v[l] * w[l])
            }
        };
        if let Some(&a) = c.num.get(j) {
            for l in 0..LANES {
                p[l] += a * phi[l];
            }
        }
        if let Some(&b) = c.den.get(j) {
            for l in 0..LANES {
                q[l] += b * phi[l];
            }
        }
    }
    map2(&p, &q, |p, q| p / q)
}

impl CompactBrdf {
    /// Whether every channel fits the batched path (at most 3 coordinates,
    /// degrees up to 31).
    fn batchable(&self) -> bool {
        self.dims <= 3
            && self
                .channels
                .iter()
                .all(|c| (0..self.dims).all(|k| c.max_degree(k) <= MAX_DEGREE))
    }

    /// RGB of up to [`LANES`] pairs, written to `out` (as long as `wi`).
    fn eval_lanes(
        &self,
        wi: &[[f32; 3]],
        wo: &[[f32; 3]],
        out: &mut [[f32; 3]],
        tables: &mut Tables,
    ) {
        let Pairs { mut wi, mut wo } = Pairs::load(wi, wo);
        let above: [bool; LANES] = std::array::from_fn(|l| wi[2][l] > 0.0 && wo[2][l] > 0.0);
        if self.has_elevation_cut() {
            let (sin_cut, cos_cut) = self.max_elevation.sin_cos();
            clamp_elevation_lanes(&mut wi, cos_cut, sin_cut);
            clamp_elevation_lanes(&mut wo, cos_cut, sin_cut);
        }
        let [th, td, pd] = half_diff_lanes(&wi, &wo);
        let td = map1(&td, |v| v.min(self.max_theta_d));
        let (a, b) = match self.coordinates {
            Coordinates::Radians => (th, td),
            Coordinates::SqrtThetaH => (map1(&th, |v| (v.max(0.0) / FRAC_PI_2).sqrt()), td),
            Coordinates::Cosines => (map1(&th, f32::cos), map1(&td, f32::cos)),
        };
        let x = [a, b, pd];
        let v: [Lanes; 3] =
            std::array::from_fn(|c| channel_lanes(&self.channels[c], &x, self.dims, tables));
        for (l, o) in out.iter_mut().enumerate() {
            if !above[l] {
                *o = [0.0; 3];
                continue;
            }
            let mut rgb = [v[0][l], v[1][l], v[2][l]];
            if let Some(lobe) = &self.lobe {
                let pick = |d: &[Lanes; 3]| [d[0][l], d[1][l], d[2][l]];
                let f = lobe.factors(pick(&wi), pick(&wo), self.mode);
                rgb = [rgb[0] * f[0], rgb[1] * f[1], rgb[2] * f[2]];
            }
            *o = match self.mode {
                ColourMode::Rgb => rgb.map(|x| x.max(0.0)),
                mode => mode.combine_f32(rgb),
            };
        }
    }

    /// RGB of every pair `(wi[i], wo[i])` into `out[i]`, [`LANES`] pairs at
    /// a time (one thread). Equal to [`CompactBrdf::eval`] up to the
    /// polynomial `atan2` (4.8e-7 radians) and f32 rounding.
    ///
    /// # Panics
    /// If the three slices differ in length.
    pub fn eval_batch(&self, wi: &[[f32; 3]], wo: &[[f32; 3]], out: &mut [[f32; 3]]) {
        assert!(
            wi.len() == wo.len() && wi.len() == out.len(),
            "eval_batch: {} wi, {} wo, {} outputs",
            wi.len(),
            wo.len(),
            out.len()
        );
        if !self.batchable() {
            for ((a, b), o) in wi.iter().zip(wo).zip(out.iter_mut()) {
                *o = self.eval(*a, *b);
            }
            return;
        }
        let mut tables: Tables = [[[0.0; LANES]; MAX_DEGREE + 1]; 3];
        for ((a, b), o) in wi
            .chunks(LANES)
            .zip(wo.chunks(LANES))
            .zip(out.chunks_mut(LANES))
        {
            self.eval_lanes(a, b, o, &mut tables);
        }
    }

    /// [`CompactBrdf::eval_batch`] over all threads, in blocks of 1024 pairs.
    pub fn eval_many_batched(&self, wi: &[[f32; 3]], wo: &[[f32; 3]]) -> Vec<[f32; 3]> {
        use rayon::prelude::*;
        const BLOCK: usize = 1024;
        let mut out = vec![[0.0f32; 3]; wi.len().min(wo.len())];
        out.par_chunks_mut(BLOCK)
            .zip(wi.par_chunks(BLOCK).zip(wo.par_chunks(BLOCK)))
            .for_each(|(o, (a, b))| self.eval_batch(a, b, o));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_polynomial_atan2_follows_the_library_on_every_octant() {
        let mut worst = 0.0f32;
        for i in 0..4096 {
            let angle = -PI + 2.0 * PI * (i as f32 + 0.5) / 4096.0;
            for r in [1e-3f32, 1.0, 7.5e3] {
                let (y, x) = (r * angle.sin(), r * angle.cos());
                let got = atan2_lanes(&[y; LANES], &[x; LANES])[0];
                worst = worst.max((got - y.atan2(x)).abs());
            }
        }
        // Two ulps of pi (2.4e-7 each): `pi - r` and `pi/2 - r` round.
        assert!(worst <= 4.8e-7, "worst {worst:e} radians");
        let z = atan2_lanes(&[0.0; LANES], &[0.0; LANES]);
        assert_eq!(z[0].to_bits(), 0.0f32.to_bits());
    }
}
