//! Batched evaluation of a fitted BRDF: [`LANES`] direction pairs at a
//! time in structure-of-arrays form, every step a loop over the lanes
//! without calls or branches, so the compiler turns it into vector
//! instructions. One body serves two precisions:
//!
//! * f32, the [`CompactBrdf`] (what a shader evaluates): the one
//!   transcendental function on the path, `atan2`, is a branch-free
//!   polynomial ([`atan2_lanes`], within two ulps of pi, 4.8e-7 radians, of
//!   the library's); everything else is the arithmetic of
//!   [`CompactBrdf::eval`] in the same order;
//! * f64, the [`BatchedFit`]: the fit's own coefficients, for fits whose f32
//!   form loses its digits (a denominator that nearly cancels), with the
//!   library's `atan2`; it equals [`FittedBrdf`]'s `eval` to rounding.

use crate::compact::{CompactBrdf, CompactChannel};
use crate::fitted::FittedBrdf;
use crate::geometry::Vec3;
use crate::lobe::Lobe;
use crate::{Coordinates, PhiCoordinate};
use rational_core::BasisFamily;
use std::f32::consts::{FRAC_PI_2, FRAC_PI_4, PI};
use std::ops::{Add, AddAssign, Div, Mul, Sub};

/// Pairs evaluated together: two AVX or four SSE registers of f32.
pub const LANES: usize = 8;

/// Largest degree per coordinate of the batched path; fits with higher
/// degrees are evaluated pair by pair.
const MAX_DEGREE: usize = 31;

/// The float a batch runs in (f32 or f64).
trait Real:
    Copy
    + PartialOrd
    + Add<Output = Self>
    + Sub<Output = Self>
    + Mul<Output = Self>
    + Div<Output = Self>
    + AddAssign
{
    const ZERO: Self;
    const ONE: Self;
    const TWO: Self;
    const FRAC_PI_2: Self;
    fn from_index(j: usize) -> Self;
    fn sqrt(self) -> Self;
    fn abs(self) -> Self;
    fn min(self, o: Self) -> Self;
    fn max(self, o: Self) -> Self;
    fn cos(self) -> Self;
    fn atan2_lanes(y: &[Self; LANES], x: &[Self; LANES]) -> [Self; LANES];
}

macro_rules! real_impl {
    ($t:ty, $atan2:expr) => {
        impl Real for $t {
            const ZERO: Self = 0.0;
            const ONE: Self = 1.0;
            const TWO: Self = 2.0;
            const FRAC_PI_2: Self = std::f64::consts::FRAC_PI_2 as $t;
            fn from_index(j: usize) -> Self {
                j as $t
            }
            fn sqrt(self) -> Self {
                <$t>::sqrt(self)
            }
            fn abs(self) -> Self {
                <$t>::abs(self)
            }
            fn min(self, o: Self) -> Self {
                <$t>::min(self, o)
            }
            fn max(self, o: Self) -> Self {
                <$t>::max(self, o)
            }
            fn cos(self) -> Self {
                <$t>::cos(self)
            }
            fn atan2_lanes(y: &[Self; LANES], x: &[Self; LANES]) -> [Self; LANES] {
                $atan2(y, x)
            }
        }
    };
}

real_impl!(f32, atan2_lanes);
// The library's atan2 lane by lane: f64 serves accuracy, not speed.
real_impl!(f64, |y: &[f64; LANES], x: &[f64; LANES]| {
    std::array::from_fn(|l| y[l].atan2(x[l]))
});

/// One value per lane.
type Lanes<T> = [T; LANES];

fn map1<T: Real>(a: &Lanes<T>, f: impl Fn(T) -> T) -> Lanes<T> {
    std::array::from_fn(|l| f(a[l]))
}

fn map2<T: Real>(a: &Lanes<T>, b: &Lanes<T>, f: impl Fn(T, T) -> T) -> Lanes<T> {
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

/// `atan2(y, x)` lane by lane in f32, branch-free: the octant is chosen by
/// selections, so the loop vectorises. `atan2(0, 0) = 0` as in libm.
pub fn atan2_lanes(y: &[f32; LANES], x: &[f32; LANES]) -> [f32; LANES] {
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
struct Pairs<T> {
    wi: [Lanes<T>; 3],
    wo: [Lanes<T>; 3],
}

impl<T: Real> Pairs<T> {
    fn load(wi: &[[T; 3]], wo: &[[T; 3]]) -> Self {
        // Missing lanes of a last, short batch hold the normal.
        let pick = |v: &[[T; 3]], l: usize, c: usize| {
            v.get(l)
                .map_or(if c == 2 { T::ONE } else { T::ZERO }, |d| d[c])
        };
        Self {
            wi: std::array::from_fn(|c| std::array::from_fn(|l| pick(wi, l, c))),
            wo: std::array::from_fn(|c| std::array::from_fn(|l| pick(wo, l, c))),
        }
    }
}

/// [`crate::compact::clamp_elevation_f32`] lane by lane.
fn clamp_elevation_lanes<T: Real>(d: &mut [Lanes<T>; 3], cos_cut: T, sin_cut: T) {
    for l in 0..LANES {
        let s = (d[0][l] * d[0][l] + d[1][l] * d[1][l]).sqrt();
        let moved = d[2][l] < cos_cut && s > T::ZERO;
        let k = if moved { sin_cut / s } else { T::ONE };
        d[0][l] = d[0][l] * k;
        d[1][l] = d[1][l] * k;
        d[2][l] = if moved { cos_cut } else { d[2][l] };
    }
}

/// [`crate::compact::half_diff_f32`] lane by lane: `(theta_h, theta_d,
/// phi_d)`.
fn half_diff_lanes<T: Real>(wi: &[Lanes<T>; 3], wo: &[Lanes<T>; 3]) -> [Lanes<T>; 3] {
    let mut h: [Lanes<T>; 3] = std::array::from_fn(|c| map2(&wi[c], &wo[c], |a, b| a + b));
    let n: Lanes<T> =
        std::array::from_fn(|l| (h[0][l] * h[0][l] + h[1][l] * h[1][l] + h[2][l] * h[2][l]).sqrt());
    for c in &mut h {
        *c = map2(c, &n, |a, b| a / b);
    }
    let s: Lanes<T> = std::array::from_fn(|l| (h[0][l] * h[0][l] + h[1][l] * h[1][l]).sqrt());
    let theta_h = T::atan2_lanes(&s, &h[2]);
    let cp = map2(&h[0], &s, |x, s| if s > T::ZERO { x / s } else { T::ONE });
    let sp = map2(&h[1], &s, |y, s| if s > T::ZERO { y / s } else { T::ZERO });
    let mut d: [Lanes<T>; 3] = [[T::ZERO; LANES]; 3];
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
    let sd: Lanes<T> = std::array::from_fn(|l| (d[0][l] * d[0][l] + d[1][l] * d[1][l]).sqrt());
    let theta_d = T::atan2_lanes(&sd, &d[2]);
    let phi_d = map1(&T::atan2_lanes(&d[1], &d[0]), T::abs);
    [theta_h, theta_d, phi_d]
}

/// Univariate basis values per coordinate, degree and lane.
type Tables<T> = [[Lanes<T>; MAX_DEGREE + 1]; 3];

/// One channel as the batch reads it, in either precision.
struct ChannelView<'a, T> {
    family: BasisFamily,
    lower: &'a [T],
    upper: &'a [T],
    indices: &'a [Vec<u16>],
    num: &'a [T],
    den: &'a [T],
    degrees: &'a [usize],
}

impl<'a> From<&'a CompactChannel> for ChannelView<'a, f32> {
    fn from(c: &'a CompactChannel) -> Self {
        Self {
            family: c.family,
            lower: &c.lower,
            upper: &c.upper,
            indices: &c.indices,
            num: &c.num,
            den: &c.den,
            degrees: &c.degrees,
        }
    }
}

/// `p / q` of one channel at [`LANES`] points (`x[k]` the k-th coordinate);
/// `tables` is scratch, reused so that it is not cleared for every batch.
fn channel_lanes<T: Real>(
    c: &ChannelView<'_, T>,
    x: &[Lanes<T>; 3],
    dims: usize,
    tables: &mut Tables<T>,
) -> Lanes<T> {
    for k in 0..dims {
        let w = c.upper[k] - c.lower[k];
        let t = map1(&x[k], |v| {
            if w > T::ZERO {
                T::TWO * (v - c.lower[k]) / w - T::ONE
            } else {
                T::ZERO
            }
        });
        let table = &mut tables[k];
        table[0] = [T::ONE; LANES];
        let deg = c.degrees[k];
        if deg >= 1 {
            table[1] = t;
        }
        for j in 1..deg {
            let jf = T::from_index(j);
            let (prev, cur) = (table[j - 1], table[j]);
            // The family is chosen outside the lane loop, which stays
            // branch-free.
            table[j + 1] = match c.family {
                BasisFamily::Monomial => map2(&cur, &t, |c, t| c * t),
                BasisFamily::Chebyshev => std::array::from_fn(|l| T::TWO * t[l] * cur[l] - prev[l]),
                BasisFamily::Legendre => std::array::from_fn(|l| {
                    ((T::TWO * jf + T::ONE) * t[l] * cur[l] - jf * prev[l]) / (jf + T::ONE)
                }),
            };
        }
    }
    let (mut p, mut q) = ([T::ZERO; LANES], [T::ZERO; LANES]);
    let [t0, t1, t2] = &*tables;
    for (j, idx) in c.indices.iter().enumerate() {
        // The basis function at every lane; the dimension is fixed per
        // loop so that the product has no inner loop.
        let phi: Lanes<T> = match dims {
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

/// What the batch needs of a fit, in its precision.
trait BatchForm {
    type T: Real;
    fn dims(&self) -> usize;
    fn coordinates(&self) -> Coordinates;
    fn phi(&self) -> PhiCoordinate;
    fn max_theta_d(&self) -> Self::T;
    /// `(sin, cos)` of the elevation cut, when there is one.
    fn cut(&self) -> Option<(Self::T, Self::T)>;
    fn channel(&self, c: usize) -> ChannelView<'_, Self::T>;
    /// RGB from the three functions' values at one (clamped) pair: the
    /// lobe's factors and the colour mode.
    /// `shell`: the shell factor's multipliers ([`BatchForm::shell`]),
    /// applied after the lobe's as in the scalar paths.
    fn finish(
        &self,
        v: [Self::T; 3],
        wi: [Self::T; 3],
        wo: [Self::T; 3],
        shell: Option<[Self::T; 3]>,
    ) -> [Self::T; 3];
    /// The shell factor's multipliers of the functions at one unclamped
    /// pair, `None` for a fit without a shell.
    fn shell(&self, wi: [Self::T; 3], wo: [Self::T; 3]) -> Option<[Self::T; 3]>;

    /// Whether every channel fits the batched path (at most 3 coordinates,
    /// degrees up to 31).
    fn batchable(&self) -> bool {
        self.dims() <= 3
            && (0..3).all(|c| {
                let ch = self.channel(c);
                (0..self.dims()).all(|k| ch.degrees[k] <= MAX_DEGREE)
            })
    }
}

/// RGB of up to [`LANES`] pairs, written to `out` (as long as `wi`).
fn eval_lanes<F: BatchForm>(
    form: &F,
    wi: &[[F::T; 3]],
    wo: &[[F::T; 3]],
    out: &mut [[F::T; 3]],
    tables: &mut Tables<F::T>,
) {
    let zero = <F::T as Real>::ZERO;
    let Pairs { mut wi, mut wo } = Pairs::load(wi, wo);
    let above: [bool; LANES] = std::array::from_fn(|l| wi[2][l] > zero && wo[2][l] > zero);
    // The shell factor reads the directions before they are moved.
    let (wi_unclamped, wo_unclamped) = (wi, wo);
    if let Some((sin_cut, cos_cut)) = form.cut() {
        clamp_elevation_lanes(&mut wi, cos_cut, sin_cut);
        clamp_elevation_lanes(&mut wo, cos_cut, sin_cut);
    }
    let [th, td, pd] = half_diff_lanes(&wi, &wo);
    let max_td = form.max_theta_d();
    let td = map1(&td, |v| v.min(max_td));
    let (a, b) = match form.coordinates() {
        Coordinates::Radians => (th, td),
        Coordinates::SqrtThetaH => (
            map1(&th, |v| (v.max(zero) / <F::T as Real>::FRAC_PI_2).sqrt()),
            td,
        ),
        Coordinates::Cosines => (map1(&th, Real::cos), map1(&td, Real::cos)),
    };
    let p = match form.phi() {
        PhiCoordinate::Radians => pd,
        PhiCoordinate::Cosine => map1(&pd, Real::cos),
    };
    let x = [a, b, p];
    let v: [Lanes<F::T>; 3] =
        std::array::from_fn(|c| channel_lanes(&form.channel(c), &x, form.dims(), tables));
    for (l, o) in out.iter_mut().enumerate() {
        if !above[l] {
            *o = [zero; 3];
            continue;
        }
        let pick = |d: &[Lanes<F::T>; 3]| [d[0][l], d[1][l], d[2][l]];
        let shell = form.shell(pick(&wi_unclamped), pick(&wo_unclamped));
        *o = form.finish([v[0][l], v[1][l], v[2][l]], pick(&wi), pick(&wo), shell);
    }
}

/// Every pair `(wi[i], wo[i])` into `out[i]`, [`LANES`] pairs at a time, or
/// pair by pair through `one` where the form is not batchable.
fn eval_batch_with<F: BatchForm>(
    form: &F,
    wi: &[[F::T; 3]],
    wo: &[[F::T; 3]],
    out: &mut [[F::T; 3]],
    one: impl Fn([F::T; 3], [F::T; 3]) -> [F::T; 3],
) {
    assert!(
        wi.len() == wo.len() && wi.len() == out.len(),
        "eval_batch: {} wi, {} wo, {} outputs",
        wi.len(),
        wo.len(),
        out.len()
    );
    if !form.batchable() {
        for ((a, b), o) in wi.iter().zip(wo).zip(out.iter_mut()) {
            *o = one(*a, *b);
        }
        return;
    }
    let zero = <F::T as Real>::ZERO;
    let mut tables: Tables<F::T> = [[[zero; LANES]; MAX_DEGREE + 1]; 3];
    for ((a, b), o) in wi
        .chunks(LANES)
        .zip(wo.chunks(LANES))
        .zip(out.chunks_mut(LANES))
    {
        eval_lanes(form, a, b, o, &mut tables);
    }
}

impl BatchForm for CompactBrdf {
    type T = f32;
    fn dims(&self) -> usize {
        self.dims
    }
    fn coordinates(&self) -> Coordinates {
        self.coordinates
    }
    fn phi(&self) -> PhiCoordinate {
        self.phi
    }
    fn max_theta_d(&self) -> f32 {
        self.max_theta_d
    }
    fn cut(&self) -> Option<(f32, f32)> {
        self.has_elevation_cut()
            .then(|| self.max_elevation.sin_cos())
    }
    fn channel(&self, c: usize) -> ChannelView<'_, f32> {
        ChannelView::from(&self.channels[c])
    }
    fn finish(&self, v: [f32; 3], wi: [f32; 3], wo: [f32; 3], shell: Option<[f32; 3]>) -> [f32; 3] {
        let mut rgb = self.scale.values_f32(self.mode, v);
        if let Some(lobe) = &self.lobe {
            let f = lobe.factors(wi, wo, self.mode);
            rgb = [rgb[0] * f[0], rgb[1] * f[1], rgb[2] * f[2]];
        }
        if let Some(k) = shell {
            rgb = [rgb[0] * k[0], rgb[1] * k[1], rgb[2] * k[2]];
        }
        self.finish(rgb)
    }
    fn shell(&self, wi: [f32; 3], wo: [f32; 3]) -> Option<[f32; 3]> {
        self.shell.as_ref().map(|_| self.shell_factors(wi, wo))
    }
}

impl CompactBrdf {
    /// RGB of every pair `(wi[i], wo[i])` into `out[i]`, [`LANES`] pairs at
    /// a time (one thread). Equal to [`CompactBrdf::eval`] up to the
    /// polynomial `atan2` (4.8e-7 radians) and f32 rounding.
    ///
    /// # Panics
    /// If the three slices differ in length.
    pub fn eval_batch(&self, wi: &[[f32; 3]], wo: &[[f32; 3]], out: &mut [[f32; 3]]) {
        eval_batch_with(self, wi, wo, out, |a, b| self.eval(a, b));
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

/// One channel's basis and coefficients in f64.
#[derive(Debug, Clone)]
struct Channel64 {
    family: BasisFamily,
    lower: Vec<f64>,
    upper: Vec<f64>,
    indices: Vec<Vec<u16>>,
    num: Vec<f64>,
    den: Vec<f64>,
    degrees: Vec<usize>,
}

/// A fitted BRDF laid out for batched evaluation in f64: the f32 compact
/// form's batched path run with the fit's own coefficients, about three
/// times the speed of [`FittedBrdf`]'s pair-by-pair `eval` and equal to it
/// to rounding. For fits whose f32 form loses its digits: a denominator
/// that nearly cancels (a peak a thousand times the rest of the material)
/// keeps no digit in f32.
#[derive(Debug, Clone)]
pub struct BatchedFit {
    fit: FittedBrdf,
    channels: Vec<Channel64>,
    cut: Option<(f64, f64)>,
}

impl BatchedFit {
    /// Lays out a fit (its three functions' bases and coefficients).
    pub fn new(fit: FittedBrdf) -> Self {
        let channels = fit
            .channels
            .iter()
            .map(|r| {
                let b = r.basis();
                let (indices, degrees) = crate::compact::basis_layout(b);
                Channel64 {
                    family: b.family(),
                    lower: b.domain().lower.clone(),
                    upper: b.domain().upper.clone(),
                    degrees,
                    indices,
                    num: r.numerator().to_vec(),
                    den: r.denominator().to_vec(),
                }
            })
            .collect();
        let cut = fit.reduction.max_elevation_deg;
        let cut = (cut < 90.0).then(|| cut.to_radians().sin_cos());
        Self { fit, channels, cut }
    }

    /// The fit.
    pub fn fit(&self) -> &FittedBrdf {
        &self.fit
    }

    /// RGB of every pair `(wi[i], wo[i])` into `out[i]`, [`LANES`] pairs at
    /// a time (one thread); equal to [`FittedBrdf`]'s `eval` to rounding.
    ///
    /// # Panics
    /// If the three slices differ in length.
    pub fn eval_batch(&self, wi: &[Vec3], wo: &[Vec3], out: &mut [[f64; 3]]) {
        use crate::Brdf;
        eval_batch_with(self, wi, wo, out, |a, b| self.fit.eval(a, b));
    }
}

impl BatchForm for BatchedFit {
    type T = f64;
    fn dims(&self) -> usize {
        self.fit.reduction.dims()
    }
    fn coordinates(&self) -> Coordinates {
        self.fit.reduction.coordinates
    }
    fn phi(&self) -> PhiCoordinate {
        self.fit.reduction.phi
    }
    fn max_theta_d(&self) -> f64 {
        self.fit.reduction.max_theta_d_deg.to_radians()
    }
    fn cut(&self) -> Option<(f64, f64)> {
        self.cut
    }
    fn channel(&self, c: usize) -> ChannelView<'_, f64> {
        let ch = &self.channels[c];
        ChannelView {
            family: ch.family,
            lower: &ch.lower,
            upper: &ch.upper,
            indices: &ch.indices,
            num: &ch.num,
            den: &ch.den,
            degrees: &ch.degrees,
        }
    }
    fn finish(&self, v: [f64; 3], wi: [f64; 3], wo: [f64; 3], shell: Option<[f64; 3]>) -> [f64; 3] {
        let v = self.fit.scale.values(self.fit.mode, v);
        let v = match &self.fit.lobe {
            Some(lobe) => {
                let f = Lobe::factors(lobe, wi, wo, self.fit.mode);
                [v[0] * f[0], v[1] * f[1], v[2] * f[2]]
            }
            None => v,
        };
        let v = match shell {
            Some(k) => [v[0] * k[0], v[1] * k[1], v[2] * k[2]],
            None => v,
        };
        self.fit.finish(v)
    }
    fn shell(&self, wi: [f64; 3], wo: [f64; 3]) -> Option<[f64; 3]> {
        self.fit
            .shell
            .as_ref()
            .map(|sh| sh.multipliers(wi, wo, self.fit.mode))
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
