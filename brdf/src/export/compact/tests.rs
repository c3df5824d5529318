//! The f32 form's evaluation paths against each other.

use super::*;
use rational_core::{Basis, Domain};

/// A channel on `len` functions of a graded basis in `dim` coordinates,
/// with coefficients from `next`.
fn channel(
    dim: usize,
    len: usize,
    (np, nq): (usize, usize),
    next: &mut impl FnMut() -> f32,
) -> CompactChannel {
    let domain = Domain::new(vec![0.0; dim], vec![1.5; dim]).unwrap();
    let basis = Basis::new(BasisFamily::Chebyshev, domain, len).unwrap();
    let (indices, degrees) = basis_layout(&basis);
    CompactChannel {
        family: BasisFamily::Chebyshev,
        lower: vec![0.0; dim],
        upper: vec![1.5; dim],
        weights: vec![1; dim],
        indices,
        num: (0..np).map(|_| 2.0 * next() - 1.0).collect(),
        den: (0..nq).map(|_| 1.0 + next()).collect(),
        degrees,
    }
}

#[test]
fn the_unrolled_channel_matches_the_general_path_to_the_last_bit() {
    let mut rng = crate::io::merl::SplitMix::new(2012);
    let mut next = move || rng.uniform() as f32;
    // Degrees below 16 and from 16 up, in one to three coordinates; the
    // numerator longer, the denominator longer.
    for (dim, len) in [(1, 12), (1, 40), (2, 60), (2, 300), (3, 120), (3, 1000)] {
        for split in [(len, len / 3), (len / 4, len)] {
            let c = channel(dim, len, split, &mut next);
            for _ in 0..100 {
                let x: Vec<f32> = (0..dim).map(|_| 1.6 * next() - 0.05).collect();
                assert_eq!(
                    c.eval(&x).to_bits(),
                    c.eval_slow(&x).to_bits(),
                    "{dim} coordinates, {len} functions, split {split:?} at {x:?}"
                );
            }
        }
    }
}
