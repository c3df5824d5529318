//! Our own f64 check of a fit against every constraint, whatever the solver
//! reported, and the error figures printed next to it.

use crate::{IntervalData, RationalFunction};
use qp_backends::tolerance::rounding_tolerance;
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// The outcome of checking a fit against its data.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Verification {
    /// Every sample has `q > 0` and `lo <= p/q <= hi` (to rounding), and
    /// every extra row holds.
    pub satisfied: bool,
    /// Largest distance of `r` outside its interval, relative to
    /// `max(|lo|, |hi|)`; 0 when all hold.
    pub max_violation: f64,
    /// Sample (or `samples + row` for an extra row) with the worst violation.
    pub worst: usize,
    /// Smallest `q` at the samples, with `(a, b)` scaled to unit norm.
    pub min_q: f64,
    /// Smallest `q` over the largest `|q|` at the samples.
    pub min_q_ratio: f64,
    /// Smallest normalised margin of the extra rows (`+inf` without any;
    /// JSON has no infinity, so it is written as `null` and read back).
    #[serde(deserialize_with = "infinity_if_null")]
    pub extra_min_margin: f64,
}

/// `null` (how `serde_json` writes an infinite float) as `+inf`.
fn infinity_if_null<'de, D: serde::Deserializer<'de>>(d: D) -> Result<f64, D::Error> {
    Ok(Option::<f64>::deserialize(d)?.unwrap_or(f64::INFINITY))
}

/// Error figures of a fit against the measured values.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorFigures {
    /// Largest `|r - v| / |v|` over samples with `v != 0`.
    pub max_relative: f64,
    /// Mean of the same.
    pub mean_relative: f64,
    /// Largest `|r - v|`.
    pub max_absolute: f64,
    /// Root mean square of `r - v`.
    pub rmse: f64,
}

/// Checks `r` against every interval of `data` and every `extra` row
/// (`row . (a, b) >= 0`), in f64.
pub fn verify(r: &RationalFunction, data: &IntervalData, extra: &[Vec<f64>]) -> Verification {
    let basis = r.basis();
    verify_with(r, data, extra, |i, phi| basis.eval_into(data.point(i), phi))
}

/// [`verify`] with the basis values at sample `i` written by
/// `basis_values(i, phi)` (the first `phi.len()` functions of `r`'s basis):
/// a sweep reads them from its design matrix, which holds exactly what
/// [`crate::Basis::eval_into`] gives, instead of evaluating them again.
pub(crate) fn verify_with(
    r: &RationalFunction,
    data: &IntervalData,
    extra: &[Vec<f64>],
    basis_values: impl Fn(usize, &mut [f64]) + Sync,
) -> Verification {
    let (n_p, n_q) = r.split();
    let nb = n_p.max(n_q);
    let tol = rounding_tolerance(n_p + n_q);
    let acc = (0..data.len())
        .into_par_iter()
        .map_init(
            || vec![0.0; nb],
            |phi, i| {
                basis_values(i, phi);
                SampleCheck::of(r, data, i, phi, tol)
            },
        )
        .reduce(SampleCheck::empty, SampleCheck::merge);
    let c: Vec<f64> = r
        .numerator()
        .iter()
        .chain(r.denominator())
        .copied()
        .collect();
    let mut extra_min = f64::INFINITY;
    let mut ok = acc.ok;
    let mut worst = acc.worst;
    for (j, row) in extra.iter().enumerate() {
        let s: f64 = row.iter().zip(&c).map(|(a, b)| a * b).sum();
        let sa: f64 = row.iter().zip(&c).map(|(a, b)| (a * b).abs()).sum();
        let nrm = row
            .iter()
            .map(|v| v * v)
            .sum::<f64>()
            .sqrt()
            .max(f64::MIN_POSITIVE);
        extra_min = extra_min.min(s / nrm);
        if s < -tol * sa {
            ok = false;
            worst = data.len() + j;
        }
    }
    Verification {
        satisfied: ok,
        max_violation: acc.viol.max(0.0),
        worst,
        min_q: acc.min_q,
        min_q_ratio: if acc.max_q > 0.0 {
            acc.min_q / acc.max_q
        } else {
            0.0
        },
        extra_min_margin: extra_min,
    }
}

/// The check of one sample (or, merged, of many): the interval rows hold
/// within the rounding slack and the denominator is positive, the largest
/// relative distance of the value outside its interval and where, and the
/// denominator's range.
#[derive(Clone, Copy)]
struct SampleCheck {
    ok: bool,
    viol: f64,
    worst: usize,
    min_q: f64,
    max_q: f64,
}

impl SampleCheck {
    /// Sample `i` of `data`, with the basis values `phi` there.
    fn of(r: &RationalFunction, data: &IntervalData, i: usize, phi: &[f64], tol: f64) -> Self {
        let (n_p, n_q) = r.split();
        let (mut p, mut pa, mut q, mut qa) = (0.0, 0.0, 0.0, 0.0);
        for k in 0..n_p {
            p += r.numerator()[k] * phi[k];
            pa += (r.numerator()[k] * phi[k]).abs();
        }
        for k in 0..n_q {
            q += r.denominator()[k] * phi[k];
            qa += (r.denominator()[k] * phi[k]).abs();
        }
        let (lo, hi) = (data.lo()[i], data.hi()[i]);
        let slack = tol * (pa + lo.abs().max(hi.abs()) * qa);
        let ok = q > 0.0 && p - lo * q >= -slack && hi * q - p >= -slack;
        let v = p / q;
        let out = if v.is_finite() {
            (lo - v).max(v - hi).max(0.0)
        } else {
            f64::INFINITY
        };
        let viol = out / lo.abs().max(hi.abs()).max(f64::MIN_POSITIVE);
        Self {
            ok,
            viol,
            worst: i,
            min_q: q,
            max_q: q.abs(),
        }
    }

    /// The check of no sample.
    fn empty() -> Self {
        Self {
            ok: true,
            viol: -1.0,
            worst: 0,
            min_q: f64::INFINITY,
            max_q: 0.0,
        }
    }

    /// The check of both sets of samples (the first worst of equals).
    fn merge(a: Self, b: Self) -> Self {
        Self {
            ok: a.ok && b.ok,
            viol: a.viol.max(b.viol),
            worst: if b.viol > a.viol { b.worst } else { a.worst },
            min_q: a.min_q.min(b.min_q),
            max_q: a.max_q.max(b.max_q),
        }
    }
}

/// Error figures of `r` against the measured values of `data`.
pub fn error_figures(r: &RationalFunction, data: &IntervalData) -> ErrorFigures {
    let fitted = r.eval_many(data.points());
    let mut max_rel = 0.0_f64;
    let mut sum_rel = 0.0;
    let mut n_rel = 0usize;
    let mut max_abs = 0.0_f64;
    let mut sq = 0.0;
    for (i, f) in fitted.iter().enumerate() {
        let v = data.value(i);
        let e = (f - v).abs();
        max_abs = max_abs.max(e);
        sq += e * e;
        if v != 0.0 {
            let rel = e / v.abs();
            max_rel = max_rel.max(rel);
            sum_rel += rel;
            n_rel += 1;
        }
    }
    ErrorFigures {
        max_relative: max_rel,
        mean_relative: if n_rel > 0 {
            sum_rel / n_rel as f64
        } else {
            0.0
        },
        max_absolute: max_abs,
        rmse: (sq / fitted.len().max(1) as f64).sqrt(),
    }
}
