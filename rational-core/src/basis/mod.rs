//! Multivariate polynomial bases: tensor products of a univariate family
//! after an affine map of every coordinate's domain to `[-1, 1]`, enumerated
//! in graded order (total degree 0, then 1, ...), or in a weighted graded
//! order where a unit of degree in coordinate `k` costs `w_k` (for data that
//! vary much faster along some coordinates than along others).

use crate::FitError;
use serde::{Deserialize, Serialize};

mod family;
mod indices;

pub use family::{BasisFamily, Domain};
pub(crate) use indices::check_weights;
pub use indices::{graded_indices, weighted_graded_indices, MAX_DEGREE_WEIGHT};

/// Coordinates [`Basis::for_each_value`] maps without allocating.
pub(crate) const STACK_DIMS: usize = 4;

/// Univariate values (summed over coordinates) [`Basis::for_each_value`]
/// keeps on the stack.
pub(crate) const STACK_TABLE: usize = 512;

/// Univariate values [`Basis::combine_with_partial`] keeps on the stack:
/// smaller than `STACK_TABLE`, since the two tables are cleared on every
/// call of a per-sample path (inverse CDFs have low degrees).
pub(crate) const PARTIAL_TABLE: usize = 128;
/// The smaller tables [`Basis::combine_with_partial`] uses when they suffice.
const SMALL_PARTIAL_TABLE: usize = 32;

/// Most functions a basis may have (a fit file declaring more is refused
/// before anything is allocated).
pub const MAX_BASIS_LEN: usize = 100_000;

/// Most coordinates a basis may have (the pole check's grid grows as 2^d).
pub const MAX_DIMENSION: usize = 16;

/// The first `len` functions of a (weighted) graded tensor basis on a domain.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
#[serde(into = "BasisSpec", try_from = "BasisSpec")]
pub struct Basis {
    family: BasisFamily,
    domain: Domain,
    weights: Vec<u16>,
    indices: Vec<Vec<u16>>,
    max_degree: Vec<usize>,
    /// `positions[j * dim + l]`: where `phi_{indices[j][l]}` of coordinate
    /// `l` sits in the univariate tables laid end to end (coordinate by
    /// coordinate, `max_degree + 1` values each), so the per-sample sums
    /// index one flat table.
    positions: Vec<u32>,
}

/// Serialised form of a [`Basis`]: the indices follow from the rule.
#[derive(Serialize, Deserialize)]
struct BasisSpec {
    family: BasisFamily,
    domain: Domain,
    len: usize,
    /// Degree weights; absent means all 1 (files written before weights
    /// existed read unchanged).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    degree_weights: Option<Vec<u16>>,
}

impl From<Basis> for BasisSpec {
    fn from(b: Basis) -> Self {
        Self {
            family: b.family,
            len: b.len(),
            degree_weights: b.is_weighted().then(|| b.weights.clone()),
            domain: b.domain,
        }
    }
}

impl TryFrom<BasisSpec> for Basis {
    type Error = FitError;
    fn try_from(s: BasisSpec) -> Result<Self, FitError> {
        let d = Domain::new(s.domain.lower, s.domain.upper)?;
        match s.degree_weights {
            Some(w) => Basis::weighted(s.family, d, s.len, &w),
            None => Basis::new(s.family, d, s.len),
        }
    }
}

impl Basis {
    /// The first `len` graded functions of `family` on `domain`.
    ///
    /// # Errors
    /// `len == 0` or degrees beyond 1000.
    pub fn new(family: BasisFamily, domain: Domain, len: usize) -> Result<Self, FitError> {
        let ones = vec![1; domain.dim()];
        Self::weighted(family, domain, len, &ones)
    }

    /// The first `len` functions of `family` on `domain` in the weighted
    /// graded order of [`weighted_graded_indices`].
    ///
    /// # Errors
    /// `len == 0`, degrees beyond 1000, or weights that are not one per
    /// coordinate in `1..=`[`MAX_DEGREE_WEIGHT`].
    pub fn weighted(
        family: BasisFamily,
        domain: Domain,
        len: usize,
        weights: &[u16],
    ) -> Result<Self, FitError> {
        check_weights(weights, domain.dim())?;
        if domain.dim() > MAX_DIMENSION {
            return Err(FitError::InvalidSetting {
                name: "dimension",
                reason: format!(
                    "{} coordinates; at most {MAX_DIMENSION} are supported",
                    domain.dim()
                ),
            });
        }
        if len > MAX_BASIS_LEN {
            return Err(FitError::InvalidSetting {
                name: "basis length",
                reason: format!("{len} functions; at most {MAX_BASIS_LEN} are supported"),
            });
        }
        if len == 0 {
            return Err(FitError::InvalidSetting {
                name: "basis length",
                reason: "must be at least 1".into(),
            });
        }
        if domain.dim() == 1 && len > 1000 {
            return Err(FitError::InvalidSetting {
                name: "basis length",
                reason: "degree above 1000".into(),
            });
        }
        let indices = weighted_graded_indices(weights, len);
        let max_degree: Vec<usize> = (0..domain.dim())
            .map(|k| indices.iter().map(|i| i[k] as usize).max().unwrap_or(0))
            .collect();
        let starts: Vec<usize> = max_degree
            .iter()
            .scan(0, |start, m| {
                let here = *start;
                *start += m + 1;
                Some(here)
            })
            .collect();
        let positions = indices
            .iter()
            .flat_map(|i| {
                i.iter()
                    .zip(&starts)
                    .map(|(&e, &s)| (s + e as usize) as u32)
            })
            .collect();
        Ok(Self {
            family,
            domain,
            weights: weights.to_vec(),
            indices,
            max_degree,
            positions,
        })
    }

    /// The same basis with its first `len` functions (`len` may exceed the
    /// current length: the order continues).
    ///
    /// # Errors
    /// As [`Basis::weighted`].
    pub fn with_len(&self, len: usize) -> Result<Self, FitError> {
        Self::weighted(self.family, self.domain.clone(), len, &self.weights)
    }

    /// Degree weight of each coordinate (all 1 for the plain graded order).
    pub fn weights(&self) -> &[u16] {
        &self.weights
    }

    /// Whether some coordinate has a degree weight other than 1.
    pub fn is_weighted(&self) -> bool {
        self.weights.iter().any(|&w| w != 1)
    }

    /// Number of functions.
    pub fn len(&self) -> usize {
        self.indices.len()
    }

    /// Always false: a basis has at least one function.
    pub fn is_empty(&self) -> bool {
        self.indices.is_empty()
    }

    /// Number of variables.
    pub fn dim(&self) -> usize {
        self.domain.dim()
    }

    /// The family.
    pub fn family(&self) -> BasisFamily {
        self.family
    }

    /// The domain box.
    pub fn domain(&self) -> &Domain {
        &self.domain
    }

    /// Multi-index of function `j`.
    pub fn multi_index(&self, j: usize) -> &[u16] {
        &self.indices[j]
    }

    /// Largest exponent of coordinate `k` among the first `n` functions.
    pub fn degree_in(&self, k: usize, n: usize) -> usize {
        self.indices[..n]
            .iter()
            .map(|i| i[k] as usize)
            .max()
            .unwrap_or(0)
    }

    /// Values of the first `out.len()` functions at `x` (original coordinates).
    pub fn eval_into(&self, x: &[f64], out: &mut [f64]) {
        self.for_each_value(x, out.len(), |j, v| out[j] = v);
    }

    /// Calls `f(j, phi_j(x))` for the first `n` functions at `x` (original
    /// coordinates). Verification evaluates every sample of every split, so
    /// this allocates nothing for up to 4 coordinates and 512 univariate
    /// values in all (the crate's `STACK_DIMS` and `STACK_TABLE`).
    pub fn for_each_value(&self, x: &[f64], n: usize, f: impl FnMut(usize, f64)) {
        let d = self.dim();
        if d <= STACK_DIMS {
            let mut t = [0.0; STACK_DIMS];
            for (k, tk) in t[..d].iter_mut().enumerate() {
                *tk = self.domain.map(k, x[k]);
            }
            self.for_each_mapped(&t[..d], n, f);
        } else {
            let t: Vec<f64> = (0..d).map(|k| self.domain.map(k, x[k])).collect();
            self.for_each_mapped(&t, n, f);
        }
    }

    /// As [`Basis::eval_into`] with coordinates already mapped to `[-1, 1]`.
    pub fn eval_mapped_into(&self, t: &[f64], out: &mut [f64]) {
        self.for_each_mapped(t, out.len(), |j, v| out[j] = v);
    }

    fn for_each_mapped(&self, t: &[f64], n: usize, mut f: impl FnMut(usize, f64)) {
        let d = self.dim();
        let n = n.min(self.len());
        // Univariate values of every coordinate, one after the other.
        let total: usize = self.max_degree.iter().map(|m| m + 1).sum();
        let mut stack = [0.0; STACK_TABLE];
        let mut heap = Vec::new();
        let flat: &mut [f64] = if total <= STACK_TABLE {
            &mut stack[..total]
        } else {
            heap.resize(total, 0.0);
            &mut heap
        };
        let mut offsets = [0usize; STACK_DIMS];
        let mut start = 0;
        for k in 0..d {
            let len = self.max_degree[k] + 1;
            if k < STACK_DIMS {
                offsets[k] = start;
            }
            self.family
                .values(t[k], &mut flat[start..start + len], None);
            start += len;
        }
        if d == 1 {
            for (j, &v) in flat[..n].iter().enumerate() {
                f(j, v);
            }
            return;
        }
        let offset = |k: usize| -> usize {
            if k < STACK_DIMS {
                offsets[k]
            } else {
                self.max_degree[..k].iter().map(|m| m + 1).sum()
            }
        };
        for j in 0..n {
            let idx = &self.indices[j];
            let mut v = 1.0;
            for k in 0..d {
                v *= flat[offset(k) + idx[k] as usize];
            }
            f(j, v);
        }
    }

    /// Values and partial derivatives (`grad[k][j] = d phi_j / d x_k`, in the
    /// original coordinates) of the first `values.len()` functions.
    pub fn eval_with_gradient(&self, x: &[f64], values: &mut [f64], grad: &mut [Vec<f64>]) {
        let d = self.dim();
        let t: Vec<f64> = (0..d).map(|k| self.domain.map(k, x[k])).collect();
        let (tab, dtab) = self.tables(&t, true);
        let n = values.len().min(self.len());
        for j in 0..n {
            let idx = &self.indices[j];
            let mut v = 1.0;
            for k in 0..d {
                v *= tab[k][idx[k] as usize];
            }
            values[j] = v;
            for k in 0..d {
                let mut g = dtab[k][idx[k] as usize] * self.domain.scale(k);
                for l in 0..d {
                    if l != k {
                        g *= tab[l][idx[l] as usize];
                    }
                }
                grad[k][j] = g;
            }
        }
    }

    /// `(sum a_j phi_j, sum b_j phi_j, sum a_j d phi_j/d x_k, sum b_j d phi_j/d x_k)`
    /// at `x` in one pass, with no per-function storage: the value and one
    /// partial derivative of a rational function `p / q`. Inverse CDFs call
    /// this for every sample, so it allocates nothing for up to
    /// `STACK_DIMS` coordinates and `PARTIAL_TABLE` univariate values.
    pub fn combine_with_partial(&self, x: &[f64], k: usize, a: &[f64], b: &[f64]) -> [f64; 4] {
        let total: usize = self.max_degree.iter().map(|m| m + 1).sum();
        if self.dim() > STACK_DIMS || total > PARTIAL_TABLE {
            let (mut flat, mut deriv) = (vec![0.0; total], vec![0.0; total]);
            self.fill_tables(x, k, &mut flat, &mut deriv);
            self.accumulate_flat(k, a, b, &flat, &deriv)
        } else if total <= SMALL_PARTIAL_TABLE {
            // Clearing the tables costs as much as the sums for small bases.
            self.combine_with_partial_stack::<SMALL_PARTIAL_TABLE>(x, k, a, b)
        } else {
            self.combine_with_partial_stack::<PARTIAL_TABLE>(x, k, a, b)
        }
    }

    /// [`Basis::combine_with_partial`] with tables of `N` values on the
    /// stack (`N` at least the univariate values of all coordinates).
    fn combine_with_partial_stack<const N: usize>(
        &self,
        x: &[f64],
        k: usize,
        a: &[f64],
        b: &[f64],
    ) -> [f64; 4] {
        let mut flat = [0.0; N];
        let mut deriv = [0.0; N];
        self.fill_tables(x, k, &mut flat, &mut deriv);
        self.accumulate_flat(k, a, b, &flat, &deriv)
    }

    /// The univariate values of every coordinate at `x`, one coordinate
    /// after the other (where `positions` points), and the derivatives of
    /// coordinate `k` at the same places.
    fn fill_tables(&self, x: &[f64], k: usize, flat: &mut [f64], deriv: &mut [f64]) {
        let mut start = 0;
        for l in 0..self.dim() {
            let len = self.max_degree[l] + 1;
            let t = self.domain.map(l, x[l]);
            let dv = (l == k).then_some(&mut deriv[start..start + len]);
            self.family.values(t, &mut flat[start..start + len], dv);
            start += len;
        }
    }

    /// The sums of [`Basis::combine_with_partial`] from the flat tables,
    /// unrolled over the coordinates for the inverse CDFs' two and three.
    fn accumulate_flat(
        &self,
        k: usize,
        a: &[f64],
        b: &[f64],
        flat: &[f64],
        deriv: &[f64],
    ) -> [f64; 4] {
        match self.dim() {
            2 => self.sums::<2>(k, a, b, flat, deriv),
            3 => self.sums::<3>(k, a, b, flat, deriv),
            _ => self.sums::<0>(k, a, b, flat, deriv),
        }
    }

    /// [`Basis::accumulate_flat`] in `D` coordinates (`D = 0`: the basis's
    /// own count, not known at compile time).
    fn sums<const D: usize>(
        &self,
        k: usize,
        a: &[f64],
        b: &[f64],
        flat: &[f64],
        deriv: &[f64],
    ) -> [f64; 4] {
        let d = if D == 0 { self.dim() } else { D };
        let scale = self.domain.scale(k);
        let n = a.len().max(b.len()).min(self.len());
        let mut out = [0.0; 4];
        for (j, p) in self.positions[..n * d].chunks_exact(d).enumerate() {
            let (ca, cb) = (
                a.get(j).copied().unwrap_or(0.0),
                b.get(j).copied().unwrap_or(0.0),
            );
            if ca == 0.0 && cb == 0.0 {
                continue;
            }
            let mut others = 1.0;
            for (l, &at) in p.iter().enumerate() {
                if l != k {
                    others *= flat[at as usize];
                }
            }
            let e = p[k] as usize;
            let v = others * flat[e];
            let g = others * deriv[e] * scale;
            out[0] += ca * v;
            out[1] += cb * v;
            out[2] += ca * g;
            out[3] += cb * g;
        }
        out
    }

    fn tables(&self, t: &[f64], with_derivative: bool) -> (Vec<Vec<f64>>, Vec<Vec<f64>>) {
        let d = self.dim();
        let mut tab = Vec::with_capacity(d);
        let mut dtab = Vec::with_capacity(if with_derivative { d } else { 0 });
        for k in 0..d {
            let mut v = vec![0.0; self.max_degree[k] + 1];
            if with_derivative {
                let mut dv = vec![0.0; self.max_degree[k] + 1];
                self.family.values(t[k], &mut v, Some(&mut dv));
                dtab.push(dv);
            } else {
                self.family.values(t[k], &mut v, None);
            }
            tab.push(v);
        }
        (tab, dtab)
    }

    /// `sum_j c_j phi_j(x)` for the first `c.len()` functions; in one
    /// variable by Clenshaw's recurrence (Horner for monomials).
    pub fn combine(&self, c: &[f64], x: &[f64]) -> f64 {
        if self.dim() == 1 {
            return self.combine_1d(c, self.domain.map(0, x[0]));
        }
        let mut sum = 0.0;
        self.for_each_value(x, c.len(), |j, v| sum += c[j] * v);
        sum
    }

    fn combine_1d(&self, c: &[f64], t: f64) -> f64 {
        let n = c.len();
        if n == 0 {
            return 0.0;
        }
        match self.family {
            BasisFamily::Monomial => c.iter().rev().fold(0.0, |acc, &ck| acc * t + ck),
            BasisFamily::Chebyshev => {
                // b_k = c_k + 2 t b_{k+1} - b_{k+2}; result c_0 + t b_1 - b_2.
                let (mut b1, mut b2) = (0.0, 0.0);
                for &ck in c[1..].iter().rev() {
                    let b0 = ck + 2.0 * t * b1 - b2;
                    b2 = b1;
                    b1 = b0;
                }
                c[0] + t * b1 - b2
            }
            BasisFamily::Legendre => {
                // alpha_k = (2k+1) t / (k+1), beta_{k+1} = -(k+1) / (k+2).
                let (mut b1, mut b2) = (0.0, 0.0);
                for k in (1..n).rev() {
                    let kf = k as f64;
                    let alpha = (2.0 * kf + 1.0) * t / (kf + 1.0);
                    let beta = -(kf + 1.0) / (kf + 2.0);
                    let b0 = c[k] + alpha * b1 + beta * b2;
                    b2 = b1;
                    b1 = b0;
                }
                c[0] + t * b1 - 0.5 * b2
            }
        }
    }
}

/// The numerator and denominator `(sum_j p_j phi_j(x), sum_j q_j phi_j(x))`
/// of a rational function on `basis` at `x` (original coordinates), in `D`
/// coordinates: the univariate values in a flat table, then one pass over
/// `j` in which both sums advance. Each sum follows the order of `j` with
/// the same products as [`Basis::for_each_value`], so it agrees with that
/// path to the last bit. `None` when the basis is not in `D` coordinates, a
/// coefficient vector is longer than the basis, or the univariate values
/// pass `STACK_TABLE`.
pub(crate) fn rational_sums<const D: usize>(
    basis: &Basis,
    p: &[f64],
    q: &[f64],
    x: &[f64],
) -> Option<(f64, f64)> {
    if basis.dim() != D || D == 0 || p.len() > basis.len() || q.len() > basis.len() {
        return None;
    }
    let total: usize = basis.max_degree.iter().map(|m| m + 1).sum();
    // A per-sample path: clear no more table than the degrees need.
    if total <= SMALL_PARTIAL_TABLE {
        Some(rational_sums_in::<D, SMALL_PARTIAL_TABLE>(basis, p, q, x))
    } else if total <= PARTIAL_TABLE {
        Some(rational_sums_in::<D, PARTIAL_TABLE>(basis, p, q, x))
    } else if total <= STACK_TABLE {
        Some(rational_sums_in::<D, STACK_TABLE>(basis, p, q, x))
    } else {
        None
    }
}

/// [`rational_sums`] with a table of `N` values.
fn rational_sums_in<const D: usize, const N: usize>(
    basis: &Basis,
    p: &[f64],
    q: &[f64],
    x: &[f64],
) -> (f64, f64) {
    let mut flat = [0.0; N];
    let mut start = 0;
    for l in 0..D {
        let len = basis.max_degree[l] + 1;
        let t = basis.domain.map(l, x[l]);
        basis.family.values(t, &mut flat[start..start + len], None);
        start += len;
    }
    let n = p.len().max(q.len());
    let (mut sp, mut sq) = (0.0, 0.0);
    for (j, at) in basis.positions[..n * D].chunks_exact(D).enumerate() {
        let mut v = 1.0;
        for &k in at {
            v *= flat[k as usize];
        }
        if let Some(c) = p.get(j) {
            sp += c * v;
        }
        if let Some(c) = q.get(j) {
            sq += c * v;
        }
    }
    (sp, sq)
}

#[cfg(test)]
mod tests;
