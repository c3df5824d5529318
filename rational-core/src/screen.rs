//! Screening splits on a subsample of large data ([`crate::Screen`]): the
//! subsample, the rows of the full problem found binding, and the row
//! numbering between the two problems.

use crate::problem::SharedDesign;
use crate::{Basis, FitError, IntervalData};
use std::collections::{HashMap, HashSet, VecDeque};
use std::sync::Mutex;

/// Every `stride`-th sample of the prepared data ([`crate::Screen`]), with
/// its own design, and rows of the full problem off the stride that its
/// solves found binding; the bounds are taken from each split's data.
pub(crate) struct Subsample {
    pub(crate) stride: usize,
    pub(crate) points: IntervalData,
    pub(crate) design: SharedDesign,
    binding: Mutex<BindingRows>,
}

/// Data rows of the full problem, off the screen's stride, that full solves
/// held active or proved infeasible with (the most recent
/// [`MAX_BINDING_ROWS`]). Neighbouring splits are bound by much the same
/// rows, so screening them too lets the subsample refuse splits that its
/// stride alone would pass to the full problem; they are rows of the full
/// problem, so a refusal is still a proof.
#[derive(Default)]
struct BindingRows {
    rows: VecDeque<usize>,
    held: HashSet<usize>,
}

/// What the subsample said of a split, with its active rows as rows of the
/// full problem.
pub(crate) enum Screened {
    /// Infeasible there, so infeasible on all samples.
    Infeasible { iterations: usize, rows: Vec<usize> },
    /// Not refused: the full problem decides (starting from `rows`).
    Open { iterations: usize, rows: Vec<usize> },
}

/// Binding rows kept for the screen: enough for the certificates of many
/// neighbouring splits, few enough that the rows a screen adds (stored,
/// `n_p + n_q` values each) stay small beside the subsample.
const MAX_BINDING_ROWS: usize = 8192;

impl BindingRows {
    /// Keeps `rows` (rows of the full problem of `full` samples) that are
    /// data rows off the stride, forgetting the oldest beyond the limit.
    fn remember(&mut self, rows: &[usize], full: usize, stride: usize) {
        for &j in rows {
            if j >= 2 * full || (j / 2) % stride == 0 || !self.held.insert(j) {
                continue;
            }
            self.rows.push_back(j);
            if self.rows.len() > MAX_BINDING_ROWS {
                if let Some(old) = self.rows.pop_front() {
                    self.held.remove(&old);
                }
            }
        }
    }
}

/// The numbering of one screen problem's rows: the kept samples' two rows
/// each, the split's added rows, then the binding rows.
pub(crate) struct ScreenRows {
    stride: usize,
    kept: usize,
    full: usize,
    added: usize,
    pub(crate) binding: Vec<usize>,
    position: HashMap<usize, usize>,
}

impl ScreenRows {
    /// The screen problem's row for row `j` of the full problem, if it has one.
    pub(crate) fn to_sub(&self, j: usize) -> Option<usize> {
        if j >= 2 * self.full {
            return Some(2 * self.kept + j - 2 * self.full);
        }
        let sample = j / 2;
        if sample % self.stride == 0 {
            return Some(2 * (sample / self.stride) + j % 2);
        }
        self.position
            .get(&j)
            .map(|&k| 2 * self.kept + self.added + k)
    }

    /// The full problem's row for row `r` of the screen problem.
    pub(crate) fn to_full(&self, r: usize) -> usize {
        if r < 2 * self.kept {
            2 * (r / 2 * self.stride) + r % 2
        } else if r < 2 * self.kept + self.added {
            2 * self.full + r - 2 * self.kept
        } else {
            self.binding[r - 2 * self.kept - self.added]
        }
    }
}

impl Subsample {
    pub(crate) fn of(data: &IntervalData, stride: usize) -> Result<Self, FitError> {
        Ok(Self {
            stride,
            points: Self::pick(data, stride)?,
            design: SharedDesign::new(),
            binding: Mutex::default(),
        })
    }

    /// Every `stride`-th sample of `data`.
    pub(crate) fn pick(data: &IntervalData, stride: usize) -> Result<IntervalData, FitError> {
        let keep = (0..data.len()).step_by(stride);
        let points = keep
            .clone()
            .flat_map(|i| data.point(i).iter().copied())
            .collect();
        let lo = keep.clone().map(|i| data.lo()[i]).collect();
        let hi = keep.map(|i| data.hi()[i]).collect();
        IntervalData::new(data.dim(), points, lo, hi)
    }

    /// The subsample with `data`'s bounds (the prepared points, possibly
    /// widened).
    pub(crate) fn bounds_of(&self, data: &IntervalData) -> Result<IntervalData, FitError> {
        Self::pick(data, self.stride)
    }

    /// Remembers binding rows of a full solve on `data`.
    pub(crate) fn remember(&self, rows: &[usize], data: &IntervalData) {
        self.binding
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .remember(rows, data.len(), self.stride);
    }

    /// The numbering of a screen problem with `added` rows of the split,
    /// and the binding rows it screens.
    pub(crate) fn numbering(&self, full: usize, added: usize) -> ScreenRows {
        let binding: Vec<usize> = {
            let held = self.binding.lock().unwrap_or_else(|e| e.into_inner());
            held.rows.iter().copied().collect()
        };
        let position = binding.iter().enumerate().map(|(k, &j)| (j, k)).collect();
        ScreenRows {
            stride: self.stride,
            kept: self.points.len(),
            full,
            added,
            binding,
            position,
        }
    }
}

/// Data row `j` of P(n_p, n_q) on `data` as an added row (in the unscaled
/// coefficients [`ExtraConstraints::rows`] use): `(phi_p, -lo phi_q)` for a
/// lower bound, `(-phi_p, hi phi_q)` for an upper one.
pub(crate) fn data_row(
    basis: &Basis,
    data: &IntervalData,
    j: usize,
    n_p: usize,
    n_q: usize,
) -> Vec<f64> {
    let i = j / 2;
    let mut phi = vec![0.0; basis.len()];
    basis.eval_into(data.point(i), &mut phi);
    let (sign, bound) = if j % 2 == 0 {
        (1.0, -data.lo()[i])
    } else {
        (-1.0, data.hi()[i])
    };
    let mut row: Vec<f64> = phi[..n_p].iter().map(|v| sign * v).collect();
    row.extend(phi[..n_q].iter().map(|v| bound * v));
    row
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn screen_rows_map_to_the_full_problem_and_back() {
        let (full, stride, added) = (100, 8, 3);
        let data = IntervalData::new(
            1,
            (0..full).map(|i| i as f64).collect(),
            vec![1.0; full],
            vec![2.0; full],
        )
        .unwrap();
        let sub = Subsample::of(&data, stride).unwrap();
        sub.remember(&[21, 16, 33, 37, 21, 2 * full + 1], &data);
        let rows = sub.numbering(full, added);
        // Rows of samples on the stride (16 of sample 8, 33 of sample 16)
        // and added rows are not kept; 21 is kept once.
        assert_eq!(rows.binding, vec![21, 37]);
        let screen_len = 2 * sub.points.len() + added + rows.binding.len();
        for r in 0..screen_len {
            let j = rows.to_full(r);
            assert_eq!(rows.to_sub(j), Some(r), "screen row {r} (full row {j})");
        }
        assert_eq!(
            rows.to_sub(2 * 13),
            None,
            "sample 13 is neither kept nor binding"
        );
    }

    #[test]
    fn binding_rows_forget_the_oldest_beyond_the_limit() {
        let full = 10 * MAX_BINDING_ROWS;
        let mut held = BindingRows::default();
        let odd: Vec<usize> = (0..MAX_BINDING_ROWS + 5).map(|k| 2 * (2 * k + 1)).collect();
        held.remember(&odd, full, 2);
        assert_eq!(held.rows.len(), MAX_BINDING_ROWS);
        assert_eq!(held.held.len(), MAX_BINDING_ROWS);
        assert_eq!(held.rows.front(), Some(&odd[5]));
        assert!(!held.held.contains(&odd[0]) && held.held.contains(&odd[5]));
    }
}
