//! Checking samplers: the directional albedo by quadrature, its Monte-Carlo
//! estimate with standard errors, and a chi-square test of sampled
//! directions against the density a sampler claims.

use crate::sampler::{weighted_sample, Sampler};
use brdf::{from_spherical, to_spherical, Brdf, Vec3};
use rayon::prelude::*;
use serde::Serialize;
use std::f64::consts::{FRAC_PI_2, PI};
use std::time::Instant;

/// A seeded SplitMix64 with reproducible streams per chunk.
#[derive(Debug, Clone)]
pub struct Rng(rand_xoshiro::SplitMix64);

impl Rng {
    /// Stream `stream` of seed `seed`.
    pub fn new(seed: u64, stream: u64) -> Self {
        let mut r = Self(rand_core::SeedableRng::seed_from_u64(
            seed ^ stream.wrapping_mul(0xA076_1D64_78BD_642F),
        ));
        r.next_u64();
        r
    }

    /// Next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        rand_core::Rng::next_u64(&mut self.0)
    }

    /// Uniform in `[0, 1)` (53 bits).
    pub fn uniform(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
    }
}

/// Gauss-Legendre nodes and weights on `[-1, 1]`.
pub fn gauss_legendre(n: usize) -> (Vec<f64>, Vec<f64>) {
    // `(P_n(z), P_n'(z))` by the three-term recurrence.
    let legendre = |z: f64| {
        let (mut p0, mut p1) = (1.0, z);
        for k in 1..n {
            let p2 = ((2 * k + 1) as f64 * z * p1 - k as f64 * p0) / (k + 1) as f64;
            p0 = p1;
            p1 = p2;
        }
        let (pn, pn1) = if n == 1 { (z, 1.0) } else { (p1, p0) };
        (pn, n as f64 * (z * pn - pn1) / (z * z - 1.0))
    };
    let (mut x, mut w) = (vec![0.0; n], vec![0.0; n]);
    for i in 0..n {
        let mut z = (PI * (i as f64 + 0.75) / (n as f64 + 0.5)).cos();
        for _ in 0..100 {
            let (pn, dp) = legendre(z);
            let dz = pn / dp;
            z -= dz;
            if dz.abs() < 1e-15 {
                break;
            }
        }
        let dp = legendre(z).1;
        x[i] = z;
        w[i] = 2.0 / ((1.0 - z * z) * dp * dp);
    }
    (x, w)
}

/// Nodes and weights of a composite rule: `panels` equal panels of
/// `order`-point Gauss-Legendre on `[a, b]`.
fn composite(a: f64, b: f64, panels: usize, order: usize) -> Vec<(f64, f64)> {
    let (x, w) = gauss_legendre(order);
    let h = (b - a) / panels as f64;
    (0..panels)
        .flat_map(|p| {
            let c = a + (p as f64 + 0.5) * h;
            x.iter()
                .zip(&w)
                .map(move |(xi, wi)| (c + 0.5 * h * xi, 0.5 * h * wi))
                .collect::<Vec<_>>()
        })
        .collect()
}

/// A quadrature value with an error estimate (difference to half the panels).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Quadrature {
    /// The value per channel.
    pub value: [f64; 3],
    /// `|Q(panels) - Q(panels / 2)|` per channel.
    pub error: [f64; 3],
}

fn albedo_rule(material: &dyn Brdf, wo: Vec3, panels: usize) -> [f64; 3] {
    let (_, pv) = to_spherical(wo);
    let th = composite(0.0, FRAC_PI_2, panels, 4);
    let ph = composite(-PI, PI, 2 * panels, 4);
    th.par_iter()
        .map(|&(t, wt)| {
            let cs = t.cos() * t.sin() * wt;
            let mut acc = [0.0; 3];
            for &(p, wp) in &ph {
                let f = material.eval(from_spherical(t, pv + p), wo);
                for c in 0..3 {
                    acc[c] += f[c] * cs * wp;
                }
            }
            acc
        })
        .reduce(|| [0.0; 3], |a, b| [a[0] + b[0], a[1] + b[1], a[2] + b[2]])
}

/// Directional albedo `integral rho(wi, wo) cos(theta_i) dwi` per channel by
/// composite 4-point Gauss-Legendre rules in `theta` (`panels` panels) and
/// relative `phi` (`2 panels`), with an error estimate.
pub fn albedo_quadrature(material: &dyn Brdf, wo: Vec3, panels: usize) -> Quadrature {
    let fine = albedo_rule(material, wo, panels.max(2));
    let coarse = albedo_rule(material, wo, (panels / 2).max(1));
    Quadrature {
        value: fine,
        error: [0, 1, 2].map(|c| (fine[c] - coarse[c]).abs()),
    }
}

/// A Monte-Carlo estimate of the directional albedo.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct AlbedoEstimate {
    /// Sample mean per channel.
    pub mean: [f64; 3],
    /// Variance of one sample per channel.
    pub variance: [f64; 3],
    /// Standard error of the mean per channel.
    pub std_error: [f64; 3],
    /// Samples drawn.
    pub samples: usize,
    /// Wall time per sample (sampling and BRDF evaluation), nanoseconds.
    pub ns_per_sample: f64,
}

#[derive(Clone, Copy)]
struct Moments {
    n: f64,
    mean: [f64; 3],
    m2: [f64; 3],
}

impl Moments {
    fn empty() -> Self {
        Self {
            n: 0.0,
            mean: [0.0; 3],
            m2: [0.0; 3],
        }
    }

    fn push(&mut self, x: [f64; 3]) {
        self.n += 1.0;
        for c in 0..3 {
            let d = x[c] - self.mean[c];
            self.mean[c] += d / self.n;
            self.m2[c] += d * (x[c] - self.mean[c]);
        }
    }

    /// Chan et al.'s pairwise combination.
    fn merge(self, o: Self) -> Self {
        let n = self.n + o.n;
        if n == 0.0 {
            return self;
        }
        let mut r = Self { n, ..self };
        for c in 0..3 {
            let d = o.mean[c] - self.mean[c];
            r.mean[c] = self.mean[c] + d * o.n / n;
            r.m2[c] = self.m2[c] + o.m2[c] + d * d * self.n * o.n / n;
        }
        r
    }
}

const CHUNK: usize = 1 << 14;

/// Estimates the albedo at view `wo` from `samples` samples of `sampler`
/// (seeded, deterministic for a seed whatever the thread count).
pub fn estimate_albedo(
    material: &dyn Brdf,
    sampler: &dyn Sampler,
    wo: Vec3,
    samples: usize,
    seed: u64,
) -> AlbedoEstimate {
    let start = Instant::now();
    let chunks = samples.div_ceil(CHUNK);
    let m = (0..chunks)
        .into_par_iter()
        .map(|j| {
            let mut rng = Rng::new(seed, j as u64);
            let mut m = Moments::empty();
            for _ in 0..CHUNK.min(samples - j * CHUNK) {
                let u = [rng.uniform(), rng.uniform()];
                m.push(weighted_sample(material, sampler, wo, u).map_or([0.0; 3], |s| s.1));
            }
            m
        })
        .reduce(Moments::empty, Moments::merge);
    let ns = start.elapsed().as_secs_f64() * 1e9 / samples.max(1) as f64;
    let variance = m.m2.map(|v| v / (m.n - 1.0).max(1.0));
    AlbedoEstimate {
        mean: m.mean,
        variance,
        std_error: variance.map(|v| (v / m.n.max(1.0)).sqrt()),
        samples,
        ns_per_sample: ns,
    }
}

/// Result of [`chi_square`].
#[derive(Debug, Clone, Copy, Serialize)]
pub struct ChiSquare {
    /// Pearson's statistic.
    pub statistic: f64,
    /// Degrees of freedom (bins after pooling, minus one).
    pub dof: usize,
    /// Probability of a statistic at least this large under the hypothesis.
    pub p_value: f64,
    /// Integral of the claimed pdf over the hemisphere (1 for a normalised
    /// density; for the rational sampler, a check that the map is onto).
    pub total_probability: f64,
    /// Estimated quadrature error of `total_probability` (its change from
    /// 2 x 2 to 4 x 4 sub-panels per cell).
    pub quadrature_error: f64,
}

/// Pearson's chi-square test of `samples` directions drawn by `sampler` at
/// view `wo` against the density [`Sampler::pdf`] claims, on
/// `theta_bins x phi_bins` cells of `(theta_l, phi_l - phi_v)`; expected
/// counts by 4 x 4 sub-panels of 4-point Gauss-Legendre per cell, cells
/// expecting fewer than 5 samples pooled (as in pbrt's tests).
pub fn chi_square(
    sampler: &dyn Sampler,
    wo: Vec3,
    samples: usize,
    theta_bins: usize,
    phi_bins: usize,
    seed: u64,
) -> ChiSquare {
    let (_, pv) = to_spherical(wo);
    let (dt, dp) = (FRAC_PI_2 / theta_bins as f64, 2.0 * PI / phi_bins as f64);
    let bins = theta_bins * phi_bins;
    let chunks = samples.div_ceil(CHUNK);
    let observed = (0..chunks)
        .into_par_iter()
        .map(|j| {
            let mut rng = Rng::new(seed, j as u64);
            let mut h = vec![0u64; bins];
            for _ in 0..CHUNK.min(samples - j * CHUNK) {
                let u = [rng.uniform(), rng.uniform()];
                if let Some(s) = sampler.sample(wo, u) {
                    let (t, p) = to_spherical(s.wi);
                    let rel = (p - pv + PI).rem_euclid(2.0 * PI);
                    let a = ((t / dt) as usize).min(theta_bins - 1);
                    let b = ((rel / dp) as usize).min(phi_bins - 1);
                    h[a * phi_bins + b] += 1;
                }
            }
            h
        })
        .reduce(
            || vec![0u64; bins],
            |mut a, b| {
                a.iter_mut().zip(b).for_each(|(x, y)| *x += y);
                a
            },
        );
    let cell_probability = |c: usize, sub: usize| {
        let (a, b) = (c / phi_bins, c % phi_bins);
        let th = composite(a as f64 * dt, (a + 1) as f64 * dt, sub, 4);
        let ph = composite(b as f64 * dp - PI, (b + 1) as f64 * dp - PI, sub, 4);
        let mut s = 0.0;
        for &(t, wt) in &th {
            for &(p, wp) in &ph {
                s += sampler.pdf(wo, from_spherical(t, pv + p)) * t.sin() * wt * wp;
            }
        }
        s
    };
    let expected: Vec<f64> = (0..bins)
        .into_par_iter()
        .map(|c| cell_probability(c, 4))
        .collect();
    let coarse: f64 = (0..bins)
        .into_par_iter()
        .map(|c| cell_probability(c, 2))
        .sum();
    let total_probability: f64 = expected.iter().sum();
    let quadrature_error = (total_probability - coarse).abs();
    let n = samples as f64;
    let (mut stat, mut used) = (0.0, 0usize);
    let (mut pool_o, mut pool_e) = (0.0, 0.0);
    for (o, e) in observed.iter().zip(&expected) {
        let (o, e) = (*o as f64, e * n);
        if e < 5.0 {
            pool_o += o;
            pool_e += e;
        } else {
            stat += (o - e) * (o - e) / e;
            used += 1;
        }
    }
    if pool_e > 0.0 || pool_o > 0.0 {
        // Observations where nothing is expected make the statistic infinite.
        stat += (pool_o - pool_e) * (pool_o - pool_e) / pool_e.max(f64::MIN_POSITIVE);
        used += 1;
    }
    let dof = used.saturating_sub(1).max(1);
    ChiSquare {
        statistic: stat,
        dof,
        p_value: gamma_q(dof as f64 / 2.0, stat / 2.0),
        total_probability,
        quadrature_error,
    }
}

/// One sampler's figures at one view elevation: [`compare_samplers`].
#[derive(Debug, Clone, Serialize)]
pub struct SamplerRow {
    /// Sampler name.
    pub sampler: String,
    /// View elevation (degrees).
    pub view_deg: f64,
    /// Bytes the sampler stores (f32).
    pub bytes: usize,
    /// The estimate.
    pub estimate: AlbedoEstimate,
    /// The quadrature value it estimates.
    pub reference: Quadrature,
}

/// Rows of [`compare_samplers`] as an aligned text table (one header
/// line): views, samplers, bytes, time and per-channel variance.
pub fn rows_text(rows: &[SamplerRow]) -> String {
    let mut s = format!(
        "{:>5} {:<10} {:>10} {:>8} {:>11} {:>11} {:>11} {:>10} {:>10}\n",
        "view", "sampler", "bytes", "ns/smp", "var R", "var G", "var B", "mean G", "quad G"
    );
    for r in rows {
        let e = &r.estimate;
        s.push_str(&format!(
            "{:>5.0} {:<10} {:>10} {:>8.0} {:>11.3e} {:>11.3e} {:>11.3e} {:>10.5} {:>10.5}\n",
            r.view_deg,
            r.sampler,
            r.bytes,
            e.ns_per_sample,
            e.variance[0],
            e.variance[1],
            e.variance[2],
            e.mean[1],
            r.reference.value[1]
        ));
    }
    s
}

/// Variance of one sample over the squared albedo (the quadrature value),
/// averaged over the channels: the row's variance independent of the
/// material's brightness.
pub fn relative_variance(row: &SamplerRow) -> f64 {
    (0..3)
        .map(|c| row.estimate.variance[c] / row.reference.value[c].powi(2).max(1e-300))
        .sum::<f64>()
        / 3.0
}

/// Albedo estimates of every sampler at every view elevation, with the same
/// sample count and seed, next to the quadrature value.
pub fn compare_samplers(
    material: &dyn Brdf,
    samplers: &[&dyn Sampler],
    views_deg: &[f64],
    samples: usize,
    seed: u64,
) -> Vec<SamplerRow> {
    let mut rows = Vec::new();
    for &deg in views_deg {
        let wo = from_spherical(deg.to_radians(), 0.0);
        let reference = albedo_quadrature(material, wo, 64);
        for s in samplers {
            rows.push(SamplerRow {
                sampler: s.name(),
                view_deg: deg,
                bytes: s.byte_size(),
                estimate: estimate_albedo(material, *s, wo, samples, seed),
                reference,
            });
        }
    }
    rows
}

fn ln_gamma(x: f64) -> f64 {
    // Lanczos (g = 7, n = 9).
    const C: [f64; 9] = [
        0.999_999_999_999_809_9,
        676.520_368_121_885_1,
        -1_259.139_216_722_402_8,
        771.323_428_777_653_1,
        -176.615_029_162_140_6,
        12.507_343_278_686_905,
        -0.138_571_095_265_720_12,
        9.984_369_578_019_572e-6,
        1.505_632_735_149_311_6e-7,
    ];
    let x = x - 1.0;
    let mut a = C[0];
    let t = x + 7.5;
    for (i, c) in C.iter().enumerate().skip(1) {
        a += c / (x + i as f64);
    }
    0.5 * (2.0 * PI).ln() + (x + 0.5) * t.ln() - t + a.ln()
}

/// Regularised upper incomplete gamma `Q(a, x)` (series below `a + 1`,
/// Lentz's continued fraction above).
pub fn gamma_q(a: f64, x: f64) -> f64 {
    if x <= 0.0 {
        return 1.0;
    }
    if !x.is_finite() {
        return 0.0;
    }
    let lg = ln_gamma(a);
    if x < a + 1.0 {
        let (mut sum, mut term, mut ap) = (1.0 / a, 1.0 / a, a);
        for _ in 0..10_000 {
            ap += 1.0;
            term *= x / ap;
            sum += term;
            if term.abs() < sum.abs() * 1e-16 {
                break;
            }
        }
        1.0 - sum * (-x + a * x.ln() - lg).exp()
    } else {
        let tiny = 1e-300;
        let mut b = x + 1.0 - a;
        let mut c = 1.0 / tiny;
        let mut d = 1.0 / b;
        let mut h = d;
        for i in 1..10_000 {
            let an = -(i as f64) * (i as f64 - a);
            b += 2.0;
            d = an * d + b;
            if d.abs() < tiny {
                d = tiny;
            }
            c = b + an / c;
            if c.abs() < tiny {
                c = tiny;
            }
            d = 1.0 / d;
            let del = d * c;
            h *= del;
            if (del - 1.0).abs() < 1e-16 {
                break;
            }
        }
        (-x + a * x.ln() - lg).exp() * h
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn gauss_legendre_integrates_polynomials_exactly() {
        let (x, w) = gauss_legendre(5);
        // Degree 9 is exact with 5 points: integral of t^8 on [-1, 1] is 2/9.
        let s: f64 = x.iter().zip(&w).map(|(x, w)| w * x.powi(8)).sum();
        assert!((s - 2.0 / 9.0).abs() < 1e-14, "{s}");
        let total: f64 = w.iter().sum();
        assert!((total - 2.0).abs() < 1e-14);
    }

    #[test]
    fn gamma_q_matches_known_values() {
        // Chi-square with 2 dof: Q(1, x/2) = exp(-x/2).
        for x in [0.5, 3.0, 10.0, 40.0] {
            assert!((gamma_q(1.0, x / 2.0) - (-x / 2.0).exp()).abs() < 1e-12);
        }
        // Chi-square 95% point with 10 dof is 18.307.
        assert!((gamma_q(5.0, 18.307 / 2.0) - 0.05).abs() < 1e-4);
        // 99% point with 100 dof is 135.807.
        assert!((gamma_q(50.0, 135.807 / 2.0) - 0.01).abs() < 1e-4);
    }

    #[test]
    fn rng_streams_are_uniform_and_distinct() {
        let mut a = Rng::new(7, 0);
        let mut b = Rng::new(7, 1);
        let n = 100_000;
        let mean: f64 = (0..n).map(|_| a.uniform()).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 0.005, "{mean}");
        assert_ne!(a.next_u64(), b.next_u64());
    }
}
