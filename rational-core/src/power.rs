//! A rational function rewritten in power form, for paths that evaluate
//! one function millions of times (an inverse CDF per sample): `p`, `q`
//! and their partial derivatives in the last coordinate, with no tables of
//! basis values per call.
//!
//! The numerator and denominator are expanded once into monomials of the
//! mapped coordinates `t_k in [-1, 1]` and written as polynomials in the
//! last coordinate `z` whose coefficients are polynomials in the leading
//! ones: `p = sum_c z^c P_c`. A call forms the products of leading powers
//! once, sums each `P_c` and `Q_c`, and runs Horner's rule in `z` for the
//! values and the derivatives together, so the derivative costs a few
//! operations, not a second pass.
//!
//! Chebyshev and Legendre coefficients grow when written as powers (by up to
//! `(1 + sqrt 2)^deg` for Chebyshev), so a function whose expansion would
//! amplify rounding by more than [`PowerForm::MAX_AMPLIFICATION`] is refused
//! and its caller keeps the basis evaluation.

use crate::RationalFunction;

/// Most coordinates a [`PowerForm`] handles.
const MAX_DIMS: usize = 4;
/// Largest exponent of a leading coordinate plus one (the powers are kept
/// in fixed arrays on the stack).
const MAX_LEADING_POWERS: usize = 16;
/// Largest exponent of the last coordinate (its power coefficients take
/// `(degree + 1)^2` values; a Chebyshev expansion of this degree already
/// amplifies rounding by up to 10^11, far beyond what is accepted).
const MAX_LAST_DEGREE: usize = 31;
/// Most monomials the expansion may hold (the tensor of exponents).
const MAX_MONOMIALS: usize = 1 << 16;
/// Most distinct products of leading powers (kept on the stack per call).
const MAX_LEADING_PRODUCTS: usize = 128;
/// The smaller stack table used when it suffices (clearing the larger one
/// costs as much as an inverse CDF's sums).
const SMALL_LEADING_PRODUCTS: usize = 32;

/// `[1, t, t^2, ..., t^15]` in registers, by products of depth at most 4
/// (a loop over the table would chain each power through memory).
#[inline]
fn all_powers(t: f64) -> [f64; MAX_LEADING_POWERS] {
    let t2 = t * t;
    let t3 = t2 * t;
    let t4 = t2 * t2;
    let t8 = t4 * t4;
    [
        1.0,
        t,
        t2,
        t3,
        t4,
        t4 * t,
        t4 * t2,
        t4 * t3,
        t8,
        t8 * t,
        t8 * t2,
        t8 * t3,
        t8 * t4,
        t8 * (t4 * t),
        t8 * (t4 * t2),
        t8 * (t4 * t3),
    ]
}

/// [`RationalFunction::parts_and_partials`] in the last coordinate, from
/// the function's power expansion (see the module documentation).
#[derive(Debug, Clone, PartialEq)]
pub struct PowerForm {
    dim: usize,
    /// `t_k = scale_k x_k + offset_k`, the basis's map onto `[-1, 1]`.
    scale: [f64; MAX_DIMS],
    offset: [f64; MAX_DIMS],
    /// Each product of leading powers some coefficient multiplies: the
    /// exponents of the leading coordinates (zero past them).
    products: Vec<[u8; MAX_DIMS - 1]>,
    /// `[p, q]` coefficients of `z^c` times the first products, `z^0`'s
    /// first: the products are in graded order, so for a graded basis the
    /// products of each power of `z` are nearly a prefix and this dense
    /// layout (zeros in its few gaps) needs no indices.
    coefficients: Vec<[f64; 2]>,
    /// `runs[c]..runs[c + 1]`: the coefficients of `z^c`.
    runs: Vec<u32>,
}

impl PowerForm {
    /// Largest ratio of the expansion's absolute coefficient sum to the
    /// basis coefficients' own, for `p` and for `q`: rounding in the power
    /// form is at most about this many times that of the basis form.
    pub const MAX_AMPLIFICATION: f64 = 1.0e6;

    /// The power form of `f`, or `None` when it has more than four
    /// coordinates, an exponent above 15 in a leading coordinate or above
    /// 31 in the last, more than 65,536 monomials or 128 products of leading
    /// powers, or an expansion that amplifies rounding beyond
    /// [`PowerForm::MAX_AMPLIFICATION`].
    pub fn new(f: &RationalFunction) -> Option<Self> {
        let basis = f.basis();
        let dim = basis.dim();
        if dim > MAX_DIMS {
            return None;
        }
        let (np, nq) = f.split();
        let n = np.max(nq);
        let degree: Vec<usize> = (0..dim).map(|k| basis.degree_in(k, n)).collect();
        if degree[..dim - 1].iter().any(|&d| d >= MAX_LEADING_POWERS)
            || degree[dim - 1] > MAX_LAST_DEGREE
        {
            return None;
        }
        let sizes: Vec<usize> = degree.iter().map(|d| d + 1).collect();
        let monomials = sizes
            .iter()
            .try_fold(1usize, |acc, &s| acc.checked_mul(s))?;
        if monomials > MAX_MONOMIALS {
            return None;
        }
        let top = degree.iter().copied().max().unwrap_or(0);
        let power = basis.family().power_coefficients(top);
        let mut tensor = vec![[0.0f64; 2]; monomials];
        for j in 0..n {
            let c = [
                f.numerator().get(j).copied().unwrap_or(0.0),
                f.denominator().get(j).copied().unwrap_or(0.0),
            ];
            if c == [0.0, 0.0] {
                continue;
            }
            add_product(&mut tensor, &sizes, basis.multi_index(j), &power, c);
        }
        for side in 0..2 {
            let own: f64 = [f.numerator(), f.denominator()][side]
                .iter()
                .map(|c| c.abs())
                .sum();
            let expanded: f64 = tensor.iter().map(|c| c[side].abs()).sum();
            if !expanded.is_finite() || expanded > Self::MAX_AMPLIFICATION * own {
                return None;
            }
        }
        let domain = basis.domain();
        let (mut scale, mut offset) = ([0.0; MAX_DIMS], [0.0; MAX_DIMS]);
        for k in 0..dim {
            scale[k] = domain.scale(k);
            // `map` sends a degenerate side to 0 (scale 0, offset 0).
            offset[k] = if scale[k] > 0.0 {
                -scale[k] * domain.lower[k] - 1.0
            } else {
                0.0
            };
        }
        let (products, coefficients, runs) = by_last_exponent(&tensor, &sizes)?;
        Some(Self {
            dim,
            scale,
            offset,
            products,
            coefficients,
            runs,
        })
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// `[p, q, dp/dx_last, dq/dx_last]` at `x` (original coordinates), as
    /// [`RationalFunction::parts_and_partials`] with `k` the last coordinate,
    /// to rounding.
    #[inline]
    pub fn parts_and_last_partial(&self, x: &[f64]) -> [f64; 4] {
        let small = self.products.len() <= SMALL_LEADING_PRODUCTS;
        match (self.dim - 1, small) {
            (0, _) => self.parts_with::<0, 1>(x),
            (1, true) => self.parts_with::<1, SMALL_LEADING_PRODUCTS>(x),
            (1, false) => self.parts_with::<1, MAX_LEADING_PRODUCTS>(x),
            (2, true) => self.parts_with::<2, SMALL_LEADING_PRODUCTS>(x),
            (2, false) => self.parts_with::<2, MAX_LEADING_PRODUCTS>(x),
            (_, true) => self.parts_with::<3, SMALL_LEADING_PRODUCTS>(x),
            (_, false) => self.parts_with::<3, MAX_LEADING_PRODUCTS>(x),
        }
    }

    /// [`PowerForm::parts_and_last_partial`] with `L` leading coordinates
    /// and a stack table of `N` leading products (`N` at least their number).
    #[inline]
    fn parts_with<const L: usize, const N: usize>(&self, x: &[f64]) -> [f64; 4] {
        let last = self.dim - 1;
        let powers: [[f64; MAX_LEADING_POWERS]; L] =
            std::array::from_fn(|k| all_powers(self.scale[k] * x[k] + self.offset[k]));
        let mut products = [1.0f64; N];
        for (m, exponents) in products.iter_mut().zip(&self.products) {
            for (row, &e) in powers.iter().zip(exponents) {
                // The mask keeps the index in the row without a check.
                *m *= row[usize::from(e) & (MAX_LEADING_POWERS - 1)];
            }
        }
        let z = self.scale[last] * x[last] + self.offset[last];
        let (mut value, mut derivative) = ([0.0f64; 2], [0.0f64; 2]);
        for run in self.runs.windows(2).rev() {
            let coefficients = &self.coefficients[run[0] as usize..run[1] as usize];
            // Two partial sums: half the addition chain's latency.
            let (mut even, mut odd) = ([0.0f64; 2], [0.0f64; 2]);
            let mut pairs = coefficients.chunks_exact(2);
            let mut weights = products.chunks_exact(2);
            for (c, w) in (&mut pairs).zip(&mut weights) {
                even[0] += w[0] * c[0][0];
                even[1] += w[0] * c[0][1];
                odd[0] += w[1] * c[1][0];
                odd[1] += w[1] * c[1][1];
            }
            if let [c] = pairs.remainder() {
                let w = products[coefficients.len() - 1];
                even[0] += w * c[0];
                even[1] += w * c[1];
            }
            let sum = [even[0] + odd[0], even[1] + odd[1]];
            for side in 0..2 {
                derivative[side] = derivative[side] * z + value[side];
                value[side] = value[side] * z + sum[side];
            }
        }
        let scale = self.scale[last];
        [
            value[0],
            value[1],
            derivative[0] * scale,
            derivative[1] * scale,
        ]
    }

    /// `r(x)` and `d r / d x_last`.
    #[inline]
    pub fn value_and_last_partial(&self, x: &[f64]) -> (f64, f64) {
        let [p, q, dp, dq] = self.parts_and_last_partial(x);
        (p / q, (dp * q - p * dq) / (q * q))
    }
}

/// Adds `c` times the product over coordinates of the power expansions of
/// `phi_{index[k]}` to the row-major `tensor` of monomials.
fn add_product(
    tensor: &mut [[f64; 2]],
    sizes: &[usize],
    index: &[u16],
    power: &[Vec<f64>],
    c: [f64; 2],
) {
    // Exponents of the current monomial, odometer style, each up to the
    // univariate polynomial's own degree.
    let dim = sizes.len();
    let mut e = vec![0usize; dim];
    loop {
        let mut factor = 1.0;
        for k in 0..dim {
            factor *= power[index[k] as usize][e[k]];
        }
        if factor != 0.0 {
            let at = e.iter().zip(sizes).fold(0, |acc, (&ek, &s)| acc * s + ek);
            tensor[at][0] += c[0] * factor;
            tensor[at][1] += c[1] * factor;
        }
        let mut k = dim;
        loop {
            if k == 0 {
                return;
            }
            k -= 1;
            if e[k] < index[k] as usize {
                e[k] += 1;
                break;
            }
            e[k] = 0;
        }
    }
}

/// The leading products, coefficients and runs of [`PowerForm`] from the
/// row-major `tensor` of monomials (last coordinate fastest); `None` when
/// there are more than [`MAX_LEADING_PRODUCTS`] products.
#[allow(clippy::type_complexity)]
fn by_last_exponent(
    tensor: &[[f64; 2]],
    sizes: &[usize],
) -> Option<(Vec<[u8; MAX_DIMS - 1]>, Vec<[f64; 2]>, Vec<u32>)> {
    let dim = sizes.len();
    let inner = sizes[dim - 1];
    // The leading combinations (rows) that carry a coefficient, with their
    // exponents, in graded order.
    let mut rows: Vec<(usize, [usize; MAX_DIMS - 1])> = Vec::new();
    for (row, chunk) in tensor.chunks_exact(inner).enumerate() {
        if chunk.iter().all(|c| *c == [0.0, 0.0]) {
            continue;
        }
        let mut exponents = [0; MAX_DIMS - 1];
        let mut rest = row;
        for k in (0..dim - 1).rev() {
            exponents[k] = rest % sizes[k];
            rest /= sizes[k];
        }
        rows.push((row, exponents));
    }
    if rows.len() > MAX_LEADING_PRODUCTS {
        return None;
    }
    rows.sort_by_key(|&(row, e)| (e.iter().sum::<usize>(), row));
    let products = rows
        .iter()
        .map(|(_, e)| {
            let mut exponents = [0u8; MAX_DIMS - 1];
            for k in 0..dim - 1 {
                exponents[k] = e[k] as u8;
            }
            exponents
        })
        .collect();
    let (mut coefficients, mut runs) = (Vec::new(), vec![0u32]);
    for c in 0..inner {
        let at = |i: usize| tensor[rows[i].0 * inner + c];
        let len = (0..rows.len())
            .rposition(|i| at(i) != [0.0, 0.0])
            .map_or(0, |i| i + 1);
        coefficients.extend((0..len).map(at));
        runs.push(coefficients.len() as u32);
    }
    // Trailing powers of `z` with no coefficient add nothing.
    while runs.len() > 2 && runs[runs.len() - 1] == runs[runs.len() - 2] {
        runs.pop();
    }
    Some((products, coefficients, runs))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{Basis, BasisFamily, Domain};

    fn function(family: BasisFamily, dim: usize, np: usize, nq: usize) -> RationalFunction {
        let lower: Vec<f64> = (0..dim).map(|k| -0.3 * k as f64).collect();
        let upper: Vec<f64> = (0..dim).map(|k| 1.0 + 0.7 * k as f64).collect();
        let basis = Basis::new(family, Domain::new(lower, upper).unwrap(), np.max(nq)).unwrap();
        let coef = |n: usize, s: f64| -> Vec<f64> {
            (0..n)
                .map(|j| ((j as f64 + s) * 1.37).sin() / (1.0 + j as f64))
                .collect()
        };
        let mut q = coef(nq, 0.5);
        q[0] = 3.0;
        RationalFunction::new(basis, coef(np, 0.1), q).unwrap()
    }

    #[test]
    fn matches_the_basis_evaluation_in_every_family_and_dimension() {
        for family in [
            BasisFamily::Chebyshev,
            BasisFamily::Legendre,
            BasisFamily::Monomial,
        ] {
            for (dim, np, nq) in [
                (1, 7, 9),
                (2, 19, 10),
                (3, 37, 70),
                (3, 70, 37),
                (4, 30, 20),
            ] {
                let f = function(family, dim, np, nq);
                let power = PowerForm::new(&f).expect("low degrees convert");
                for i in 0..50 {
                    let x: Vec<f64> = (0..dim)
                        .map(|k| {
                            -0.3 * k as f64
                                + (1.0 + k as f64) * ((i * (k + 3)) as f64 * 0.377).fract()
                        })
                        .collect();
                    let want = f.parts_and_partials(&x, dim - 1);
                    let got = power.parts_and_last_partial(&x);
                    for (g, w) in got.iter().zip(&want) {
                        assert!(
                            (g - w).abs() <= 1e-12 * (1.0 + w.abs()),
                            "{family} dim {dim}: {got:?} against {want:?}"
                        );
                    }
                }
            }
        }
    }

    #[test]
    fn refuses_what_it_cannot_hold_exactly() {
        // Leading degree 20 in two coordinates: above the stack arrays.
        let f = function(BasisFamily::Chebyshev, 2, 231, 5);
        assert!(PowerForm::new(&f).is_none());
        // Five coordinates.
        let f = function(BasisFamily::Chebyshev, 5, 6, 6);
        assert!(PowerForm::new(&f).is_none());
        // Degree 39 in one coordinate: refused before any table of that
        // degree is built (a file may declare degrees in the thousands).
        let f = function(BasisFamily::Monomial, 1, 40, 3);
        assert!(PowerForm::new(&f).is_none());
        let f = function(BasisFamily::Chebyshev, 1, 1000, 3);
        assert!(PowerForm::new(&f).is_none());
        // Degree 30 in Chebyshev form amplifies rounding beyond the limit
        // (the sum of T_30's power coefficients is about 1.5e11).
        let f = function(BasisFamily::Chebyshev, 1, 31, 3);
        assert!(PowerForm::new(&f).is_none());
    }
}
