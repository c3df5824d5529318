//! Pole control: `q` may vanish between samples (the paper's stated
//! limitation). Two remedies, both linear in the denominator coefficients:
//!
//! * dense grid: evaluate `q` on a grid finer than the data, add the points
//!   where `q <= 0` as constraints `q(x) > 0`, re-solve;
//! * Bernstein certificate: the tensor Bernstein coefficients of `q` on the
//!   domain box are a fixed linear map `T b` of its coefficients; if all are
//!   positive, `q > 0` on the whole box (a Bernstein polynomial is a convex
//!   combination of its coefficients). Adding `T b > 0` makes every fit
//!   provably pole-free on the box.

use crate::Basis;
use serde::{Deserialize, Serialize};

/// How poles between samples are excluded.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case", tag = "method")]
#[non_exhaustive]
pub enum PoleControl {
    /// Only `q > 0` at the samples (the paper's formulation).
    None,
    /// Check `q` on a tensor grid of `points_per_dim` points per coordinate
    /// (0: chosen from the sample count), add failing points, re-solve.
    DenseGrid {
        /// Grid points per coordinate; 0 picks `clamp(4 s^(1/d), 64, ...)`.
        points_per_dim: usize,
    },
    /// Require positive tensor Bernstein coefficients of `q`, degree-elevated
    /// by `elevation` (higher elevation: less conservative, more rows).
    Bernstein {
        /// Extra degree per coordinate.
        elevation: usize,
    },
}

impl Default for PoleControl {
    fn default() -> Self {
        PoleControl::DenseGrid { points_per_dim: 0 }
    }
}

/// Parses `none`, `grid` (the dense grid, its size chosen from the samples)
/// or `bernstein` (elevation 2).
impl std::str::FromStr for PoleControl {
    type Err = crate::FitError;
    fn from_str(s: &str) -> Result<Self, crate::FitError> {
        match s {
            "none" => Ok(Self::None),
            "grid" => Ok(Self::DenseGrid { points_per_dim: 0 }),
            "bernstein" => Ok(Self::Bernstein { elevation: 2 }),
            _ => Err(crate::FitError::InvalidSetting {
                name: "poles",
                reason: format!("unknown pole control `{s}` (none, grid, bernstein)"),
            }),
        }
    }
}

fn binomial(n: usize, k: usize) -> f64 {
    (0..k).fold(1.0, |acc, i| acc * (n - i) as f64 / (i + 1) as f64)
}

/// `B[a][i]`: coefficient `i` of univariate basis function `a` (0..=deg) in
/// the degree-`m` Bernstein basis on `[-1, 1]`.
fn univariate_bernstein(basis: &Basis, deg: usize, m: usize) -> Vec<Vec<f64>> {
    let power = basis.family().power_coefficients(deg);
    (0..=deg)
        .map(|a| {
            // x = 2t - 1: power coefficients in t.
            let mut tc = vec![0.0; m + 1];
            for (j, &cj) in power[a].iter().enumerate() {
                if cj == 0.0 {
                    continue;
                }
                for i in 0..=j {
                    let sign = if (j - i) % 2 == 0 { 1.0 } else { -1.0 };
                    tc[i] += cj * binomial(j, i) * 2f64.powi(i as i32) * sign;
                }
            }
            // t-power to Bernstein: b_i = sum_{j<=i} C(i,j)/C(m,j) a_j.
            (0..=m)
                .map(|i| {
                    (0..=i)
                        .map(|j| binomial(i, j) / binomial(m, j) * tc[j])
                        .sum()
                })
                .collect()
        })
        .collect()
}

/// Rows `T` (one per tensor Bernstein coefficient, each of length `n_q`) with
/// `T b` = the Bernstein coefficients of `q = sum b_k phi_k` on the box.
pub fn bernstein_rows(basis: &Basis, n_q: usize, elevation: usize) -> Vec<Vec<f64>> {
    let d = basis.dim();
    let degs: Vec<usize> = (0..d).map(|k| basis.degree_in(k, n_q)).collect();
    let ms: Vec<usize> = degs.iter().map(|&g| g + elevation).collect();
    let tables: Vec<Vec<Vec<f64>>> = (0..d)
        .map(|k| univariate_bernstein(basis, degs[k], ms[k]))
        .collect();
    let total: usize = ms.iter().map(|m| m + 1).product();
    let mut rows = Vec::with_capacity(total);
    let mut beta = vec![0usize; d];
    for _ in 0..total {
        let row = (0..n_q)
            .map(|j| {
                let idx = basis.multi_index(j);
                (0..d)
                    .map(|k| tables[k][idx[k] as usize][beta[k]])
                    .product()
            })
            .collect();
        rows.push(row);
        for k in 0..d {
            beta[k] += 1;
            if beta[k] <= ms[k] {
                break;
            }
            beta[k] = 0;
        }
    }
    rows
}

/// Smallest Bernstein coefficient of `q` divided by the largest magnitude:
/// positive means `q > 0` on the whole box (a certificate).
pub fn bernstein_margin(basis: &Basis, b: &[f64], elevation: usize) -> f64 {
    let rows = bernstein_rows(basis, b.len(), elevation);
    let coef: Vec<f64> = rows
        .iter()
        .map(|r| r.iter().zip(b).map(|(x, y)| x * y).sum())
        .collect();
    let max = coef.iter().fold(0.0_f64, |m, v| m.max(v.abs()));
    let min = coef.iter().cloned().fold(f64::INFINITY, f64::min);
    if max > 0.0 {
        min / max
    } else {
        0.0
    }
}

/// Grid points per coordinate for `samples` samples in `dim` dimensions:
/// at least 4x denser than the data, at most about a million points in all.
pub fn grid_size(samples: usize, dim: usize, requested: usize) -> usize {
    if requested > 0 {
        return requested;
    }
    let per_dim = (samples as f64).powf(1.0 / dim as f64);
    let cap = (1.0e6_f64).powf(1.0 / dim as f64).floor() as usize;
    ((4.0 * per_dim).ceil() as usize).clamp(64.min(cap), cap.max(2))
}

/// Largest dense coefficient tensor (`prod (degree_k + 1)` entries) that
/// [`grid_check`] contracts; beyond it each grid point sums the terms.
const MAX_DENSE_TENSOR: usize = 1 << 20;

/// Univariate values of each axis at the grid's points: `tables[k][i * w_k +
/// a]` is `phi_a(t_i)` on axis `k`, for the `w_k` degrees `q` uses there.
fn axis_tables(basis: &Basis, widths: &[usize], per_dim: usize) -> Vec<Vec<f64>> {
    widths
        .iter()
        .map(|&m| {
            let mut t = vec![0.0; per_dim * m];
            for (i, row) in t.chunks_exact_mut(m).enumerate() {
                basis.family().values(grid_t(i, per_dim), row, None);
            }
            t
        })
        .collect()
}

/// Mapped coordinate of grid index `i` of `per_dim` points on `[-1, 1]`.
fn grid_t(i: usize, per_dim: usize) -> f64 {
    -1.0 + 2.0 * i as f64 / (per_dim - 1).max(1) as f64
}

/// `q = sum b_j phi_j` at every point of the tensor grid (axis 0 fastest),
/// by contracting one axis at a time: the coefficient tensor's axis `k`
/// (its `w_k` degrees) becomes the grid's `per_dim` points, which costs
/// about `per_dim^d w_0` products in all instead of `per_dim^d n_q d`.
fn grid_values_contracted(
    basis: &Basis,
    b: &[f64],
    widths: &[usize],
    tables: &[Vec<f64>],
    per_dim: usize,
) -> Vec<f64> {
    let d = widths.len();
    let mut shape = widths.to_vec();
    let mut tensor = vec![0.0; widths.iter().product()];
    for (j, &bj) in b.iter().enumerate() {
        let idx = basis.multi_index(j);
        let (mut at, mut stride) = (0, 1);
        for k in 0..d {
            at += idx[k] as usize * stride;
            stride *= widths[k];
        }
        tensor[at] += bj;
    }
    for k in (0..d).rev() {
        let inner: usize = shape[..k].iter().product();
        let outer: usize = shape[k + 1..].iter().product();
        let w = shape[k];
        let table = &tables[k];
        let mut next = vec![0.0; inner * per_dim * outer];
        for o in 0..outer {
            let src = &tensor[o * inner * w..(o + 1) * inner * w];
            let dst = &mut next[o * inner * per_dim..(o + 1) * inner * per_dim];
            for (i, out) in dst.chunks_exact_mut(inner).enumerate() {
                let row = &table[i * w..(i + 1) * w];
                for (c, &phi) in row.iter().enumerate() {
                    for (y, &x) in out.iter_mut().zip(&src[c * inner..(c + 1) * inner]) {
                        *y += phi * x;
                    }
                }
            }
        }
        shape[k] = per_dim;
        tensor = next;
    }
    tensor
}

/// `q` at grid point `id` (axis 0 fastest), summing its terms: the
/// fallback when the dense coefficient tensor would be too large.
fn grid_value_direct(
    basis: &Basis,
    b: &[f64],
    widths: &[usize],
    tables: &[Vec<f64>],
    per_dim: usize,
    at: &mut [usize],
    id: usize,
) -> f64 {
    let mut rest = id;
    for slot in at.iter_mut() {
        *slot = rest % per_dim;
        rest /= per_dim;
    }
    let mut q = 0.0;
    for (j, bj) in b.iter().enumerate() {
        let idx = basis.multi_index(j);
        let mut v = 1.0;
        for k in 0..at.len() {
            v *= tables[k][at[k] * widths[k] + idx[k] as usize];
        }
        q += v * bj;
    }
    q
}

/// Minimum of `q` over a tensor grid on `[-1, 1]^d` (mapped coordinates),
/// and up to `keep` grid points (original coordinates) where `q <= 0`.
pub fn grid_check(basis: &Basis, b: &[f64], per_dim: usize, keep: usize) -> (f64, Vec<Vec<f64>>) {
    use rayon::prelude::*;
    let d = basis.dim();
    let total = per_dim.pow(d as u32);
    let dom = basis.domain();
    // The grid is a tensor product: the univariate values of each axis are
    // computed once.
    let widths: Vec<usize> = (0..d).map(|k| basis.degree_in(k, b.len()) + 1).collect();
    let tables = axis_tables(basis, &widths, per_dim);
    let dense: usize = widths.iter().product();
    let values: Vec<f64> = if dense <= MAX_DENSE_TENSOR {
        grid_values_contracted(basis, b, &widths, &tables, per_dim)
    } else {
        (0..total)
            .into_par_iter()
            .map_init(
                || vec![0usize; d],
                |at, id| grid_value_direct(basis, b, &widths, &tables, per_dim, at, id),
            )
            .collect()
    };
    let min = values.iter().copied().fold(f64::INFINITY, f64::min);
    let mut bad: Vec<(f64, usize)> = values
        .iter()
        .enumerate()
        .filter(|(_, &q)| q <= 0.0)
        .map(|(id, &q)| (q, id))
        .collect();
    bad.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
    let pts = bad
        .into_iter()
        .take(keep)
        .map(|(_, mut id)| {
            (0..d)
                .map(|k| {
                    let t = grid_t(id % per_dim, per_dim);
                    id /= per_dim;
                    dom.lower[k] + 0.5 * (t + 1.0) * (dom.upper[k] - dom.lower[k])
                })
                .collect()
        })
        .collect();
    (min, pts)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{BasisFamily, Domain};

    #[test]
    fn pole_controls_parse_by_name() {
        assert_eq!("none".parse::<PoleControl>().unwrap(), PoleControl::None);
        assert_eq!(
            "grid".parse::<PoleControl>().unwrap(),
            PoleControl::default()
        );
        assert_eq!(
            "bernstein".parse::<PoleControl>().unwrap(),
            PoleControl::Bernstein { elevation: 2 }
        );
        let err = "poles".parse::<PoleControl>().unwrap_err().to_string();
        assert!(err.contains("unknown pole control `poles`"), "{err}");
    }

    #[test]
    fn bernstein_coefficients_reproduce_the_polynomial() {
        for family in [
            BasisFamily::Monomial,
            BasisFamily::Chebyshev,
            BasisFamily::Legendre,
        ] {
            let dom = Domain::new(vec![0.0, -2.0], vec![1.0, 2.0]).unwrap();
            let basis = Basis::new(family, dom, 10).unwrap();
            let b: Vec<f64> = (0..10).map(|k| 1.0 / (k as f64 + 1.0) - 0.2).collect();
            let rows = bernstein_rows(&basis, 10, 1);
            let coef: Vec<f64> = rows
                .iter()
                .map(|r| r.iter().zip(&b).map(|(x, y)| x * y).sum())
                .collect();
            // Evaluate the tensor Bernstein form at a point and compare.
            let (u, v): (f64, f64) = (0.3, 0.8); // in [0, 1]
            let ms = [basis.degree_in(0, 10) + 1, basis.degree_in(1, 10) + 1];
            let mut s = 0.0;
            let mut k = 0;
            for j in 0..=ms[1] {
                for i in 0..=ms[0] {
                    let bu =
                        binomial(ms[0], i) * u.powi(i as i32) * (1.0 - u).powi((ms[0] - i) as i32);
                    let bv =
                        binomial(ms[1], j) * v.powi(j as i32) * (1.0 - v).powi((ms[1] - j) as i32);
                    s += coef[k] * bu * bv;
                    k += 1;
                }
            }
            let x = [u, -2.0 + 4.0 * v];
            let direct = basis.combine(&b, &x);
            assert!((s - direct).abs() < 1e-12, "{family}: {s} vs {direct}");
        }
    }

    #[test]
    fn the_contracted_grid_matches_summing_every_term_at_every_point() {
        // A 3-D denominator with a sign change, in each family and with
        // weighted degrees (unequal widths per axis).
        let dom = Domain::new(vec![0.0, -1.0, 2.0], vec![1.0, 3.0, 2.5]).unwrap();
        for family in [
            BasisFamily::Monomial,
            BasisFamily::Chebyshev,
            BasisFamily::Legendre,
        ] {
            for weights in [vec![1, 1, 1], vec![1, 2, 3]] {
                let basis = Basis::weighted(family, dom.clone(), 35, &weights).unwrap();
                let b: Vec<f64> = (0..35)
                    .map(|j| ((j as f64 * 0.618_034).fract() - 0.45) / (1.0 + j as f64))
                    .collect();
                let per_dim = 9;
                let d = 3;
                let widths: Vec<usize> = (0..d).map(|k| basis.degree_in(k, b.len()) + 1).collect();
                let tables = axis_tables(&basis, &widths, per_dim);
                let contracted = grid_values_contracted(&basis, &b, &widths, &tables, per_dim);
                let mut at = vec![0; d];
                for (id, &q) in contracted.iter().enumerate() {
                    let direct =
                        grid_value_direct(&basis, &b, &widths, &tables, per_dim, &mut at, id);
                    // And through the basis in original coordinates.
                    let x: Vec<f64> = (0..d)
                        .map(|k| {
                            let t = grid_t(at[k], per_dim);
                            dom.lower[k] + 0.5 * (t + 1.0) * (dom.upper[k] - dom.lower[k])
                        })
                        .collect();
                    let combined = basis.combine(&b, &x);
                    assert!((q - direct).abs() <= 1e-12, "{family} {weights:?} {id}");
                    assert!((q - combined).abs() <= 1e-12, "{family} {weights:?} {id}");
                }
                let (min, pts) = grid_check(&basis, &b, per_dim, 1000);
                let smallest = contracted.iter().copied().fold(f64::INFINITY, f64::min);
                assert!((min - smallest).abs() <= 0.0, "{min} {smallest}");
                assert!(
                    min < 0.0,
                    "{family} {weights:?}: the test wants a sign change"
                );
                let negative = contracted.iter().filter(|&&q| q <= 0.0).count();
                assert_eq!(pts.len(), negative);
                for p in &pts {
                    assert!(basis.combine(&b, p) <= 1e-12);
                }
            }
        }
    }

    #[test]
    fn grid_finds_a_sign_change() {
        let dom = Domain::new(vec![0.0], vec![1.0]).unwrap();
        let basis = Basis::new(BasisFamily::Chebyshev, dom, 2).unwrap();
        // q(t) = 0.1 + t on [-1, 1] is negative near t = -1 (x = 0).
        let (min, pts) = grid_check(&basis, &[0.1, 1.0], 101, 5);
        assert!(min < 0.0);
        assert!(!pts.is_empty() && pts[0][0] < 0.5);
        assert!(bernstein_margin(&basis, &[0.1, 1.0], 0) < 0.0);
        assert!(bernstein_margin(&basis, &[1.1, 1.0], 0) > 0.0);
    }
}
