//! Small vector helpers on `[f64; 3]`, orthonormal frames and the
//! deterministic random numbers of the integrators.

pub use brdf::{cross, dot, normalize, Vec3};

/// `a + b`.
pub fn add(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] + b[0], a[1] + b[1], a[2] + b[2]]
}

/// `a - b`.
pub fn sub(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] - b[0], a[1] - b[1], a[2] - b[2]]
}

/// `s a`.
pub fn scale(a: Vec3, s: f64) -> Vec3 {
    [a[0] * s, a[1] * s, a[2] * s]
}

/// Component-wise product.
pub fn mul(a: Vec3, b: Vec3) -> Vec3 {
    [a[0] * b[0], a[1] * b[1], a[2] * b[2]]
}

/// Euclidean length.
pub fn length(a: Vec3) -> f64 {
    dot(a, a).sqrt()
}

/// `a + s b`.
pub fn add_scaled(a: Vec3, b: Vec3, s: f64) -> Vec3 {
    [a[0] + s * b[0], a[1] + s * b[1], a[2] + s * b[2]]
}

/// Largest component.
pub fn max_component(a: Vec3) -> f64 {
    a[0].max(a[1]).max(a[2])
}

/// An orthonormal frame around a normal: local z is the normal.
#[derive(Debug, Clone, Copy)]
pub struct Frame {
    /// Tangent.
    pub t: Vec3,
    /// Bitangent.
    pub b: Vec3,
    /// Normal.
    pub n: Vec3,
}

impl Frame {
    /// A frame around the unit normal `n` (Duff et al. 2017, branchless).
    pub fn from_normal(n: Vec3) -> Self {
        let sign = 1f64.copysign(n[2]);
        let a = -1.0 / (sign + n[2]);
        let b = n[0] * n[1] * a;
        Self {
            t: [1.0 + sign * n[0] * n[0] * a, sign * b, -sign * n[0]],
            b: [b, sign + n[1] * n[1] * a, -n[1]],
            n,
        }
    }

    /// World to local coordinates.
    pub fn to_local(&self, v: Vec3) -> Vec3 {
        [dot(v, self.t), dot(v, self.b), dot(v, self.n)]
    }

    /// Local to world coordinates.
    pub fn to_world(&self, v: Vec3) -> Vec3 {
        [
            self.t[0] * v[0] + self.b[0] * v[1] + self.n[0] * v[2],
            self.t[1] * v[0] + self.b[1] * v[1] + self.n[1] * v[2],
            self.t[2] * v[0] + self.b[2] * v[1] + self.n[2] * v[2],
        ]
    }
}

/// The workspace's one seeded generator (SplitMix64, `rand_xoshiro`'s),
/// seeded per pixel from a hash of the seed and the pixel, so a render is
/// the same whatever the thread schedule. Every seed lies on SplitMix64's
/// one cycle of 2^64; hashed seeds put two pixels' streams a random 64-bit
/// distance apart, so they do not overlap within any render.
#[derive(Debug, Clone)]
pub struct Rng {
    generator: rand_xoshiro::SplitMix64,
    lattice: Option<Lattice>,
}

/// Scrambled Sobol' points for the pairs of one pixel: the first `count`
/// points of the two-dimensional Sobol' sequence (a (0,2)-sequence), for
/// each pair of dimensions with its own Owen scrambling (Burley, "Practical
/// hash-based Owen scrambling", 2020) and its own random order of the
/// points (Kensler 2013). Every point is uniform, so estimates stay
/// unbiased; the points of one pair are stratified at every power of two,
/// so smooth integrands converge far faster than 1/sqrt(n).
#[derive(Debug, Clone, Copy)]
struct Lattice {
    key: u64,
    count: u32,
    sample: u32,
    dimension: u64,
}

impl Lattice {
    fn next_pair(&mut self) -> [f64; 2] {
        let key = mix(self.key ^ mix(self.dimension.wrapping_add(1)));
        self.dimension += 1;
        let j = permute(self.sample, self.count, key as u32);
        let x = owen_scramble(j.reverse_bits(), (key >> 32) as u32);
        let y = owen_scramble(sobol_second(j), mix(key) as u32);
        // 32 scrambled bits and 21 more random ones: uniform in [0, 1).
        let low = mix(key ^ u64::from(j));
        [x, y].map(|bits| unit(u64::from(bits) << 32 | (low & 0xffff_ffff)))
    }
}

/// The second dimension of Sobol's sequence at `index` (the first is the
/// bit reversal of the index).
fn sobol_second(mut index: u32) -> u32 {
    let (mut v, mut r) = (1u32 << 31, 0u32);
    while index != 0 {
        if index & 1 == 1 {
            r ^= v;
        }
        index >>= 1;
        v ^= v >> 1;
    }
    r
}

/// Nested uniform (Owen) scrambling of the bits of `x`, by the
/// Laine-Karras hash on the reversed bits.
fn owen_scramble(x: u32, seed: u32) -> u32 {
    let mut v = x.reverse_bits().wrapping_add(seed);
    v ^= v.wrapping_mul(0x6c50_b47c);
    v ^= v.wrapping_mul(0xb82f_1e52);
    v ^= v.wrapping_mul(0xc7af_e638);
    v ^= v.wrapping_mul(0x8d22_f6e6);
    v.reverse_bits()
}

/// The top 53 bits of `bits` as a number in `[0, 1)`.
fn unit(bits: u64) -> f64 {
    (bits >> 11) as f64 * (1.0 / (1u64 << 53) as f64)
}

/// A pseudo-random permutation of `0..len` chosen by `key`, evaluated at
/// `index` without storing it (Kensler, "Correlated multi-jittered
/// sampling", 2013: a hash on the next power of two, cycle-walked).
fn permute(index: u32, len: u32, key: u32) -> u32 {
    debug_assert!(index < len);
    let mut w = len - 1;
    w |= w >> 1;
    w |= w >> 2;
    w |= w >> 4;
    w |= w >> 8;
    w |= w >> 16;
    let mut i = index;
    loop {
        i ^= key;
        i = i.wrapping_mul(0xe170_893d);
        i ^= key >> 16;
        i ^= (i & w) >> 4;
        i ^= key >> 8;
        i = i.wrapping_mul(0x0929_eb3f);
        i ^= key >> 23;
        i ^= (i & w) >> 1;
        i = i.wrapping_mul(1 | key >> 27);
        i = i.wrapping_mul(0x6935_fa69);
        i ^= (i & w) >> 11;
        i = i.wrapping_mul(0x74dc_b303);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0x9e50_1cc3);
        i ^= (i & w) >> 2;
        i = i.wrapping_mul(0xc860_a3df);
        i &= w;
        i ^= i >> 5;
        if i < len {
            break;
        }
    }
    ((u64::from(i) + u64::from(key)) % u64::from(len)) as u32
}

/// The first output of SplitMix64 seeded at `z`: decorrelates nearby seeds.
fn mix(z: u64) -> u64 {
    let mut g: rand_xoshiro::SplitMix64 = rand_core::SeedableRng::seed_from_u64(z);
    rand_core::Rng::next_u64(&mut g)
}

impl Rng {
    /// The stream of `(seed, index)`, for example a pixel.
    pub fn new(seed: u64, index: u64) -> Self {
        Self {
            generator: rand_core::SeedableRng::seed_from_u64(Self::state(seed, index)),
            lattice: None,
        }
    }

    /// The generator's initial state for `(seed, index)`.
    fn state(seed: u64, index: u64) -> u64 {
        mix(seed ^ mix(index))
    }

    /// The stream of `(seed, index)` whose pairs come from scrambled
    /// Sobol' points, `count` per pair of dimensions (see
    /// [`Rng::start_sample`]); single numbers stay independent.
    pub fn lattice(seed: u64, index: u64, count: usize) -> Self {
        let mut r = Self::new(seed, index);
        r.lattice = Some(Lattice {
            // A key apart from the stream's state: `mix` of a different word.
            key: mix(Self::state(seed, index) ^ mix(index.wrapping_add(seed.rotate_left(32)))),
            count: u32::try_from(count.max(1)).unwrap_or(u32::MAX),
            sample: 0,
            dimension: 0,
        });
        r
    }

    /// Starts sample `sample` (below the lattice's count): the next pairs
    /// are the lattice's points of that sample, first dimension first. No
    /// effect on an independent stream.
    pub fn start_sample(&mut self, sample: usize) {
        if let Some(l) = &mut self.lattice {
            l.sample = u32::try_from(sample).unwrap_or(u32::MAX) % l.count;
            l.dimension = 0;
        }
    }

    /// The next 64 random bits.
    pub fn next_u64(&mut self) -> u64 {
        rand_core::Rng::next_u64(&mut self.generator)
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        unit(self.next_u64())
    }

    /// Two uniform numbers: independent, or the current sample's point of
    /// the next pair of dimensions of a scrambled Sobol' stream.
    pub fn pair(&mut self) -> [f64; 2] {
        match &mut self.lattice {
            Some(l) => l.next_pair(),
            None => [self.uniform(), self.uniform()],
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn frame_is_orthonormal_for_any_normal() {
        for n in [
            [0.0, 0.0, 1.0],
            [0.0, 0.0, -1.0],
            normalize([0.3, -0.4, 0.1]),
            normalize([-1.0, 2.0, -3.0]),
        ] {
            let f = Frame::from_normal(n);
            let v = normalize([0.2, 0.7, -0.1]);
            let back = f.to_world(f.to_local(v));
            for k in 0..3 {
                assert!((back[k] - v[k]).abs() < 1e-12);
            }
            assert!(dot(f.t, f.b).abs() < 1e-12 && dot(f.t, n).abs() < 1e-12);
            assert!((length(cross(f.t, f.b)) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn uniform_numbers_have_the_right_mean_and_differ_by_stream() {
        let mut a = Rng::new(7, 0);
        let mut b = Rng::new(7, 1);
        let n = 100_000;
        let mean = (0..n).map(|_| a.uniform()).sum::<f64>() / n as f64;
        assert!((mean - 0.5).abs() < 5.0 * (1.0 / 12.0f64 / n as f64).sqrt());
        let mut a = Rng::new(7, 0);
        assert!((0..8).any(|_| a.next_u64() != b.next_u64()));
        let (x, y) = (Rng::new(3, 9).uniform(), Rng::new(3, 9).uniform());
        assert!(x.to_bits() == y.to_bits(), "same stream, same numbers");
    }

    #[test]
    fn the_generator_is_splitmix64_from_the_hashed_state() {
        // SplitMix64 (Steele, Lea and Flood 2014), written out: renders
        // depend on the exact sequence of each pixel's stream.
        for (seed, index) in [(7u64, 0u64), (3, 9), (2012, 123_456), (u64::MAX, 1)] {
            let mut state = mix(seed ^ mix(index));
            let mut reference = || {
                state = state.wrapping_add(0x9E37_79B9_7F4A_7C15);
                let z = (state ^ (state >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
                let z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
                z ^ (z >> 31)
            };
            let mut rng = Rng::new(seed, index);
            for _ in 0..64 {
                assert_eq!(rng.next_u64(), reference());
            }
        }
        // The SplitMix64 finaliser of the reference paper's first output.
        assert_eq!(mix(0), 0xE220_A839_7B1D_CDAF);
    }

    #[test]
    fn permutations_are_bijections() {
        for len in [1u32, 2, 3, 7, 64, 100, 257] {
            for key in [0u32, 1, 0xdead_beef] {
                let mut seen = vec![false; len as usize];
                for i in 0..len {
                    let j = permute(i, len, key) as usize;
                    assert!(!seen[j], "len {len} key {key}: {j} twice");
                    seen[j] = true;
                }
            }
        }
    }

    /// Mean of `f` over the `n` pairs of one pixel's first dimension.
    fn pixel_mean(mut rng: Rng, n: usize, f: impl Fn([f64; 2]) -> f64) -> f64 {
        (0..n)
            .map(|s| {
                rng.start_sample(s);
                f(rng.pair())
            })
            .sum::<f64>()
            / n as f64
    }

    #[test]
    fn lattice_estimates_are_unbiased_and_far_less_noisy_than_independent_ones() {
        // A smooth integrand with a known integral: (1 - cos 2pi x)(y + 1/2)
        // integrates to 1 over the square.
        let f = |[x, y]: [f64; 2]| (1.0 - (std::f64::consts::TAU * x).cos()) * (y + 0.5);
        let (n, pixels) = (64, 2000);
        let stats = |make: &dyn Fn(u64) -> Rng| {
            let means: Vec<f64> = (0..pixels).map(|p| pixel_mean(make(p), n, f)).collect();
            let mean = means.iter().sum::<f64>() / pixels as f64;
            let var = means.iter().map(|m| (m - mean).powi(2)).sum::<f64>() / (pixels - 1) as f64;
            (mean, var.sqrt())
        };
        let (lattice_mean, lattice_sd) = stats(&|p| Rng::lattice(3, p, n));
        let (random_mean, random_sd) = stats(&|p| Rng::new(3, p));
        assert!((random_mean - 1.0).abs() < 5.0 * random_sd / (pixels as f64).sqrt());
        assert!(
            (lattice_mean - 1.0).abs() < 5.0 * lattice_sd / (pixels as f64).sqrt() + 1e-12,
            "lattice mean {lattice_mean} (sd {lattice_sd})"
        );
        assert!(
            lattice_sd < random_sd / 10.0,
            "lattice sd {lattice_sd} against independent {random_sd}"
        );
        // Each pair of dimensions is shifted and ordered on its own: the
        // second pair of a sample is not the first one again.
        let mut rng = Rng::lattice(3, 0, n);
        rng.start_sample(5);
        let (a, b) = (rng.pair(), rng.pair());
        assert_ne!(a.map(f64::to_bits), b.map(f64::to_bits));
        rng.start_sample(5);
        assert_eq!(
            rng.pair().map(f64::to_bits),
            a.map(f64::to_bits),
            "a sample's pairs are reproducible"
        );
    }
}
