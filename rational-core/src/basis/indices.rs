//! The (weighted) graded order of multi-indices: which tensor products a
//! basis of `len` functions holds.

use crate::FitError;

/// Multi-indices of total degree `0, 1, 2, ...` in `dim` variables, in a fixed
/// order within each degree (first coordinate's exponent descending); the
/// first `len` of them.
pub fn graded_indices(dim: usize, len: usize) -> Vec<Vec<u16>> {
    weighted_graded_indices(&vec![1; dim], len)
}

/// Largest weight [`weighted_graded_indices`] accepts.
pub const MAX_DEGREE_WEIGHT: u16 = 16;

/// Multi-indices `a` in order of weighted degree `sum_k weights[k] a[k]`
/// (`0, 1, 2, ...`), first coordinate's exponent descending within a weighted
/// degree; the first `len` of them. Unit weights give [`graded_indices`].
/// Every prefix is a lower set, so the bases stay nested.
///
/// # Panics
/// A weight of 0 or above [`MAX_DEGREE_WEIGHT`] (validated by the settings
/// that carry weights).
pub fn weighted_graded_indices(weights: &[u16], len: usize) -> Vec<Vec<u16>> {
    assert!(
        weights
            .iter()
            .all(|&w| (1..=MAX_DEGREE_WEIGHT).contains(&w)),
        "degree weights must lie in 1..={MAX_DEGREE_WEIGHT}"
    );
    let mut out = Vec::with_capacity(len);
    let mut degree = 0u32;
    while out.len() < len {
        push_degree(weights, degree, &mut Vec::new(), &mut out, len);
        degree += 1;
    }
    out
}

fn push_degree(
    weights: &[u16],
    remaining: u32,
    prefix: &mut Vec<u16>,
    out: &mut Vec<Vec<u16>>,
    len: usize,
) {
    if out.len() >= len {
        return;
    }
    let w = u32::from(weights[prefix.len()]);
    if prefix.len() + 1 == weights.len() {
        if remaining % w == 0 {
            let mut idx = prefix.clone();
            idx.push((remaining / w) as u16);
            out.push(idx);
        }
        return;
    }
    for e in (0..=remaining / w).rev() {
        prefix.push(e as u16);
        push_degree(weights, remaining - e * w, prefix, out, len);
        prefix.pop();
    }
}

/// Validates degree weights for `dim` coordinates.
pub(crate) fn check_weights(weights: &[u16], dim: usize) -> Result<(), FitError> {
    if weights.len() != dim {
        return Err(FitError::DimensionMismatch(format!(
            "{} degree weights for data of dimension {dim}",
            weights.len()
        )));
    }
    if let Some(w) = weights
        .iter()
        .find(|&&w| !(1..=MAX_DEGREE_WEIGHT).contains(&w))
    {
        return Err(FitError::InvalidSetting {
            name: "degree weights",
            reason: format!("weight {w} outside 1..={MAX_DEGREE_WEIGHT}"),
        });
    }
    Ok(())
}
