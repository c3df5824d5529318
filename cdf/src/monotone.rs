//! Monotonicity of `r = base + weight * p/q` in the sampled variable `u` as
//! linear rows in the coefficients `(a, b)` of `p` and `q`.
//!
//! `d r / d u = base' + weight' p/q + weight (p' q - p q') / q^2`. Times
//! `q > 0`: `base' q + weight' p + weight (p' - (p/q) q')`, linear in `(a, b)`
//! except for the one factor `p/q`. Where the data confine `p/q` to
//! `[lo, hi]`, the expression is affine in that factor, so requiring it at
//! both ends makes `d r / d u >= 0` hold for every admissible value: two rows
//! per sample. Where `weight = 0` the factor drops out and one row suffices.

use crate::model::KnownPart;
use rational_core::{Basis, ExtraConstraints};
use rayon::prelude::*;

/// One point where `d r / d u >= 0` is required.
#[derive(Debug, Clone, Copy)]
pub(crate) struct MonotonePoint {
    pub(crate) known: KnownPart,
    /// Bounds of the rational part at the point (unused where the weight is 0).
    pub(crate) lo: f64,
    pub(crate) hi: f64,
}

/// Monotonicity rows at a set of points (fit coordinates).
#[derive(Debug, Clone)]
pub(crate) struct MonotoneRows {
    pub(crate) dim: usize,
    pub(crate) sampled: usize,
    pub(crate) points: Vec<f64>,
    pub(crate) entries: Vec<MonotonePoint>,
}

impl MonotoneRows {
    pub(crate) fn new(dim: usize, sampled: usize) -> Self {
        Self {
            dim,
            sampled,
            points: Vec::new(),
            entries: Vec::new(),
        }
    }

    pub(crate) fn push(&mut self, fit_point: &[f64], entry: MonotonePoint) {
        self.points.extend_from_slice(fit_point);
        self.entries.push(entry);
    }

    pub(crate) fn len(&self) -> usize {
        self.entries.len()
    }
}

impl ExtraConstraints for MonotoneRows {
    fn rows(&self, basis: &Basis, n_p: usize, n_q: usize) -> Vec<Vec<f64>> {
        let nb = n_p.max(n_q);
        self.entries
            .par_iter()
            .enumerate()
            .flat_map_iter(|(i, e)| {
                let x = &self.points[i * self.dim..(i + 1) * self.dim];
                let mut phi = vec![0.0; nb];
                let mut grad = vec![vec![0.0; nb]; self.dim];
                basis.eval_with_gradient(x, &mut phi, &mut grad);
                let dphi = &grad[self.sampled];
                let k = e.known;
                let ends: &[f64] = if k.weight == 0.0 {
                    &[0.0]
                } else {
                    &[e.lo, e.hi]
                };
                ends.iter()
                    .map(|&end| {
                        let mut row = Vec::with_capacity(n_p + n_q);
                        row.extend((0..n_p).map(|j| k.weight_d * phi[j] + k.weight * dphi[j]));
                        row.extend((0..n_q).map(|j| k.base_d * phi[j] - k.weight * end * dphi[j]));
                        row
                    })
                    .collect::<Vec<_>>()
            })
            .collect()
    }
}
