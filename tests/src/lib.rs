//! Test support shared by every crate's suite, and the host of the
//! workspace's property and stability suite in `tests/` (which uses the
//! public APIs of the crates).
//!
//! The library itself depends on no crate of the workspace (only on
//! `rand_xoshiro`), so that any crate can take it as a dev-dependency
//! without a cycle:
//!
//! ```
//! let mut g = ratfit_tests::SplitMix64::new(7);
//! let u = g.next_f64();
//! assert!((0.0..1.0).contains(&u));
//! if let Some(dir) = ratfit_tests::data_dir() {
//!     assert!(dir.is_dir());
//! }
//! ```

use std::path::PathBuf;

/// The measured data folder: `RATFIT_DATA`, else `shared/data` beside the
/// repository; `None` when neither is a folder (suites then skip, and say
/// so, outside CI, which always sets it).
pub fn data_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("RATFIT_DATA")
        .map(PathBuf::from)
        .unwrap_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../../shared/data"));
    dir.is_dir().then_some(dir)
}

/// SplitMix64 (Steele, Lea and Flood 2014; `rand_xoshiro`'s): the suites'
/// seeded generator, so that every failure names a reproducible case.
#[derive(Debug, Clone)]
pub struct SplitMix64(rand_xoshiro::SplitMix64);

impl SplitMix64 {
    /// The generator at `seed`.
    pub fn new(seed: u64) -> Self {
        Self(rand_core::SeedableRng::seed_from_u64(seed))
    }

    /// The next 64 bits.
    pub fn next_u64(&mut self) -> u64 {
        rand_core::Rng::next_u64(&mut self.0)
    }

    /// Uniform in `[0, 1)`, 53 bits.
    pub fn next_f64(&mut self) -> f64 {
        (self.next_u64() >> 11) as f64 / (1u64 << 53) as f64
    }

    /// Uniform in `0..n` (`0` when `n` is 0); the modulo bias is below
    /// `n / 2^64`.
    pub fn below(&mut self, n: usize) -> usize {
        (self.next_u64() % n.max(1) as u64) as usize
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn splitmix64_gives_the_reference_sequence() {
        // The first outputs for seed 0 (Vigna's reference implementation).
        let mut g = SplitMix64::new(0);
        assert_eq!(g.next_u64(), 0xE220_A839_7B1D_CDAF);
        assert_eq!(g.next_u64(), 0x6E78_9E6A_A1B9_65F4);
    }
}
