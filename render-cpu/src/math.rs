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

/// A small, fast generator (PCG-XSH-RR 32) seeded per pixel, so a render
/// is the same whatever the thread schedule.
#[derive(Debug, Clone)]
pub struct Rng {
    state: u64,
    inc: u64,
}

/// SplitMix64 finaliser: decorrelates nearby seeds.
fn mix(mut z: u64) -> u64 {
    z = z.wrapping_add(0x9E37_79B9_7F4A_7C15);
    z = (z ^ (z >> 30)).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    z = (z ^ (z >> 27)).wrapping_mul(0x94D0_49BB_1331_11EB);
    z ^ (z >> 31)
}

impl Rng {
    /// The stream of `(seed, index)`, for example a pixel.
    pub fn new(seed: u64, index: u64) -> Self {
        let mut r = Self {
            state: mix(seed ^ mix(index)),
            inc: (mix(index.wrapping_add(seed.rotate_left(32))) << 1) | 1,
        };
        r.next_u32();
        r
    }

    /// The next 32 random bits.
    pub fn next_u32(&mut self) -> u32 {
        let old = self.state;
        self.state = old
            .wrapping_mul(6_364_136_223_846_793_005)
            .wrapping_add(self.inc);
        let xorshifted = (((old >> 18) ^ old) >> 27) as u32;
        let rot = (old >> 59) as u32;
        xorshifted.rotate_right(rot)
    }

    /// Uniform in `[0, 1)` with 53 random bits.
    pub fn uniform(&mut self) -> f64 {
        let hi = u64::from(self.next_u32()) << 21;
        let lo = u64::from(self.next_u32()) >> 11;
        (hi | lo) as f64 * (1.0 / (1u64 << 53) as f64)
    }

    /// Two uniform numbers.
    pub fn pair(&mut self) -> [f64; 2] {
        [self.uniform(), self.uniform()]
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
        assert!((0..8).any(|_| a.next_u32() != b.next_u32()));
        let (x, y) = (Rng::new(3, 9).uniform(), Rng::new(3, 9).uniform());
        assert!(x.to_bits() == y.to_bits(), "same stream, same numbers");
    }
}
