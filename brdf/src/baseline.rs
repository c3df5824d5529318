//! Baselines the paper compares rational fits against, on the same samples:
//! a polynomial with the same number of coefficients (least squares on the
//! relative error) and a nonlinear fit of an analytic model (Cook-Torrance
//! with GGX and Schlick's Fresnel, by Levenberg-Marquardt on the relative
//! error).

use crate::analytic::CookTorranceGgx;
use crate::geometry::HalfDiff;
use crate::reduce::Samples;
use crate::Brdf;
use faer::linalg::solvers::SolveLstsq;
use rational_core::{blocked_triangular_factor, Basis, BasisFamily, Domain, IntervalData};
use serde::{Deserialize, Serialize};
use std::time::Instant;

/// Error figures of a baseline fit.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct BaselineReport {
    /// What was fitted.
    pub name: String,
    /// Parameters or coefficients.
    pub parameters: usize,
    /// Max relative error over the samples.
    pub max_rel: f64,
    /// Mean relative error over the samples.
    pub mean_rel: f64,
    /// Wall time in seconds.
    pub seconds: f64,
}

fn figures(
    name: String,
    parameters: usize,
    errors: impl Iterator<Item = f64>,
    start: Instant,
) -> BaselineReport {
    let (mut max, mut sum, mut n) = (0.0_f64, 0.0, 0usize);
    for e in errors {
        max = max.max(e);
        sum += e;
        n += 1;
    }
    BaselineReport {
        name,
        parameters,
        max_rel: max,
        mean_rel: sum / n.max(1) as f64,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// A polynomial with `n` coefficients (the graded basis of `family` on the
/// data's bounding box, in the order of the degree `weights`, all 1 for
/// total degree) minimising the squared relative error.
///
/// # Panics
/// `weights` not one per coordinate in `1..=MAX_DEGREE_WEIGHT` (take them
/// from a fitted basis).
pub fn polynomial(
    data: &IntervalData,
    family: BasisFamily,
    weights: &[u16],
    n: usize,
) -> BaselineReport {
    let start = Instant::now();
    let bb = data.bounding_box();
    let domain = Domain::new(bb.lower, bb.upper).expect("a bounding box is a valid domain");
    let basis = Basis::weighted(family, domain, n.max(1), weights).expect("valid weights");
    // Relative errors need a positive value.
    let positive: Vec<usize> = (0..data.len()).filter(|&i| data.value(i) > 0.0).collect();
    // Least squares of the design weighted by 1/v (the residual is the
    // relative error) against ones, from the blocked QR of `[A | 1]`: its
    // `R` holds the normal solution's triangle and right-hand side, and no
    // `samples x n` copy of the design is stored.
    let n = basis.len();
    let r = blocked_triangular_factor(positive.len(), n + 1, |k, out| {
        let i = positive[k];
        basis.eval_into(data.point(i), &mut out[..n]);
        out[..n].iter_mut().for_each(|v| *v /= data.value(i));
        out[n] = 1.0;
    });
    let coef: Vec<f64> = if r.nrows() < n + 1 {
        vec![f64::NAN; n]
    } else {
        let mut c = r.as_ref().submatrix(0, n, n, 1).to_owned();
        faer::linalg::triangular_solve::solve_upper_triangular_in_place(
            r.as_ref().submatrix(0, 0, n, n),
            c.as_mut(),
            faer::Par::Seq,
        );
        (0..n).map(|j| c[(j, 0)]).collect()
    };
    let errors = positive
        .iter()
        .map(|&i| (basis.combine(&coef, data.point(i)) / data.value(i) - 1.0).abs());
    figures(
        format!("polynomial ({} coefficients)", basis.len()),
        basis.len(),
        errors,
        start,
    )
}

/// Cook-Torrance (GGX, Schlick) with a Lambertian base fitted to channel
/// `c` by Levenberg-Marquardt on the relative error; parameters `kd`, `f0`
/// and `alpha` (3 numbers).
pub fn cook_torrance(samples: &Samples, used: &[usize], c: usize) -> BaselineReport {
    let start = Instant::now();
    // Relative errors need a positive value.
    let rows: Vec<_> = used
        .iter()
        .filter(|&&i| samples.rows[i].value[c] > 0.0)
        .map(|&i| {
            let r = &samples.rows[i];
            let (wi, wo) = HalfDiff::pair_at(r.angles);
            (wi, wo, r.value[c])
        })
        .collect();
    // Logarithmic parameters keep kd, f0 and alpha positive.
    let model = |p: &[f64; 3]| CookTorranceGgx {
        kd: [p[0].exp(); 3],
        f0: [p[1].exp().min(1.0); 3],
        alpha: p[2].exp().clamp(1e-4, 10.0),
    };
    let residuals = |p: &[f64; 3]| -> Vec<f64> {
        let m = model(p);
        rows.iter()
            .map(|(wi, wo, v)| m.eval(*wi, *wo)[0] / v - 1.0)
            .collect()
    };
    let cost = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    // Start from a diffuse level at the median value, a dielectric Fresnel
    // term and a moderate roughness.
    let mut vals: Vec<f64> = rows.iter().map(|r| r.2).collect();
    vals.sort_by(f64::total_cmp);
    let median = vals.get(vals.len() / 2).copied().unwrap_or(0.1).max(1e-6);
    let mut p = [
        (median * std::f64::consts::PI).ln(),
        0.05f64.ln(),
        0.1f64.ln(),
    ];
    let mut r = residuals(&p);
    let mut lambda = 1e-3;
    for _ in 0..100 {
        // Numeric Jacobian, normal equations with damping.
        let mut jac = vec![[0.0; 3]; r.len()];
        for k in 0..3 {
            let mut q = p;
            let h = 1e-6;
            q[k] += h;
            let rk = residuals(&q);
            for i in 0..r.len() {
                jac[i][k] = (rk[i] - r[i]) / h;
            }
        }
        let mut jtj = [[0.0; 3]; 3];
        let mut jtr = [0.0; 3];
        for i in 0..r.len() {
            for a in 0..3 {
                jtr[a] += jac[i][a] * r[i];
                for b in 0..3 {
                    jtj[a][b] += jac[i][a] * jac[i][b];
                }
            }
        }
        let mut improved = false;
        for _ in 0..10 {
            let mut m = jtj;
            for a in 0..3 {
                m[a][a] *= 1.0 + lambda;
            }
            let Some(step) = solve3(m, jtr) else { break };
            let q = [p[0] - step[0], p[1] - step[1], p[2] - step[2]];
            let rq = residuals(&q);
            if cost(&rq).is_finite() && cost(&rq) < cost(&r) {
                p = q;
                r = rq;
                lambda *= 0.3;
                improved = true;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    let m = model(&p);
    let errors = r.iter().map(|x| x.abs());
    figures(
        format!(
            "Cook-Torrance GGX (kd {:.3}, f0 {:.3}, alpha {:.4})",
            m.kd[0], m.f0[0], m.alpha
        ),
        3,
        errors,
        start,
    )
}

/// The Levenberg-Marquardt step: `a` is `J^T J` with its diagonal raised,
/// symmetric positive definite unless the Jacobian is degenerate (`None`).
fn solve3(a: [[f64; 3]; 3], b: [f64; 3]) -> Option<[f64; 3]> {
    use faer::linalg::solvers::Solve;
    let m = faer::Mat::<f64>::from_fn(3, 3, |i, k| a[i][k]);
    let llt = m.llt(faer::Side::Lower).ok()?;
    let x = llt.solve(faer::Mat::<f64>::from_fn(3, 1, |i, _| b[i]));
    let x = [x[(0, 0)], x[(1, 0)], x[(2, 0)]];
    x.iter().all(|v| v.is_finite()).then_some(x)
}

/// Cook-Torrance GGX fitted to a whole material the way the literature fits
/// measured tables (Ngan et al. 2005): all channels at once (per-channel
/// `kd` and `f0`, one `alpha`), on a grid over the hemisphere within 80
/// degrees of the normal, minimising the cosine-weighted squared error of
/// `ln(f + eps)` (the log keeps the peak from dominating, the cosines weight
/// what a render sees), from several starts by Levenberg-Marquardt.
#[derive(Debug, Clone, PartialEq)]
pub struct GgxFit {
    /// The fitted model.
    pub model: CookTorranceGgx,
    /// Final objective (weighted mean squared log error).
    pub cost: f64,
    /// Wall time in seconds.
    pub seconds: f64,
}

/// Fits [`GgxFit`] to `material`.
pub fn fit_ggx(material: &dyn Brdf) -> GgxFit {
    use std::f64::consts::PI;
    let start = Instant::now();
    let (nh, nd, np) = (24usize, 24usize, 12usize);
    // (wi, wo, value, cos_i cos_o) per grid cell.
    type Row = ([f64; 3], [f64; 3], [f64; 3], f64);
    let mut rows: Vec<Row> = Vec::new();
    let min_cos = 80f64.to_radians().cos();
    for (wi, wo) in HalfDiff::cell_centres([nh, nd, np]) {
        if wi[2] > min_cos && wo[2] > min_cos {
            let v = material.eval(wi, wo);
            if v.iter().all(|x| x.is_finite()) {
                rows.push((wi, wo, v.map(|x| x.max(0.0)), wi[2] * wo[2]));
            }
        }
    }
    let mut sorted: Vec<f64> = rows.iter().flat_map(|r| r.2).collect();
    sorted.sort_by(f64::total_cmp);
    let eps = 1e-2
        * sorted
            .get(sorted.len() / 2)
            .copied()
            .unwrap_or(1.0)
            .max(1e-9);
    let wsum: f64 = rows.iter().map(|r| r.3).sum::<f64>().max(1e-300);
    // Parameters: ln kd (3), logit f0 (3), ln alpha.
    let model = |p: &[f64]| CookTorranceGgx {
        kd: [p[0].exp(), p[1].exp(), p[2].exp()],
        f0: [3, 4, 5].map(|k| 1.0 / (1.0 + (-p[k]).exp())),
        alpha: p[6].exp().clamp(1e-3, 2.0),
    };
    let residuals = |p: &[f64]| -> Vec<f64> {
        let m = model(p);
        let mut r = Vec::with_capacity(rows.len() * 3);
        for (wi, wo, v, w) in &rows {
            let f = m.eval(*wi, *wo);
            let sw = (w / wsum).sqrt();
            for c in 0..3 {
                r.push(sw * ((f[c] + eps).ln() - (v[c] + eps).ln()));
            }
        }
        r
    };
    let cost = |r: &[f64]| r.iter().map(|x| x * x).sum::<f64>();
    let median = sorted
        .get(sorted.len() / 2)
        .copied()
        .unwrap_or(0.1)
        .max(1e-6);
    let mut best: Option<(Vec<f64>, f64)> = None;
    for alpha in [0.03, 0.1, 0.25, 0.5] {
        for f0 in [0.04f64, 0.5] {
            let logit = (f0 / (1.0 - f0)).ln();
            let kd = (median * PI).ln();
            let p0 = vec![kd, kd, kd, logit, logit, logit, f64::ln(alpha)];
            let (p, c) = levenberg_marquardt(p0, &residuals, cost, 60);
            if best.as_ref().is_none_or(|b| c < b.1) {
                best = Some((p, c));
            }
        }
    }
    let (p, c) = best.expect("at least one start");
    GgxFit {
        model: model(&p),
        cost: c,
        seconds: start.elapsed().as_secs_f64(),
    }
}

/// Levenberg-Marquardt with a forward-difference Jacobian; each step solves
/// the damped problem `[J; sqrt(lambda) I] s = [r; 0]` by QR.
fn levenberg_marquardt(
    mut p: Vec<f64>,
    residuals: &dyn Fn(&[f64]) -> Vec<f64>,
    cost: fn(&[f64]) -> f64,
    iterations: usize,
) -> (Vec<f64>, f64) {
    let n = p.len();
    let mut r = residuals(&p);
    let mut c = cost(&r);
    if !c.is_finite() {
        return (p, f64::INFINITY);
    }
    let mut lambda = 1e-3_f64;
    for _ in 0..iterations {
        let m = r.len();
        let mut jac = faer::Mat::<f64>::zeros(m + n, n);
        for k in 0..n {
            let mut q = p.clone();
            let h = 1e-6 * (1.0 + p[k].abs());
            q[k] += h;
            let rk = residuals(&q);
            for i in 0..m {
                jac[(i, k)] = (rk[i] - r[i]) / h;
            }
        }
        let mut improved = false;
        for _ in 0..8 {
            for k in 0..n {
                for kk in 0..n {
                    jac[(m + k, kk)] = if k == kk { lambda.sqrt() } else { 0.0 };
                }
            }
            let rhs = faer::Mat::<f64>::from_fn(m + n, 1, |i, _| if i < m { r[i] } else { 0.0 });
            let step = jac.qr().solve_lstsq(&rhs);
            let q: Vec<f64> = (0..n).map(|k| p[k] - step[(k, 0)]).collect();
            let rq = residuals(&q);
            let cq = cost(&rq);
            if cq.is_finite() && cq < c {
                let gain = (c - cq) / c.max(1e-300);
                p = q;
                r = rq;
                c = cq;
                lambda = (lambda * 0.3).max(1e-12);
                improved = gain > 1e-10;
                break;
            }
            lambda *= 10.0;
        }
        if !improved {
            break;
        }
    }
    (p, c)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_multi_start_ggx_fit_recovers_a_ggx_material() {
        let truth = CookTorranceGgx {
            kd: [0.1, 0.3, 0.05],
            f0: [0.04, 0.05, 0.6],
            alpha: 0.15,
        };
        let fit = fit_ggx(&truth);
        assert!(fit.cost < 1e-8, "{fit:?}");
        assert!(
            (fit.model.alpha / truth.alpha - 1.0).abs() < 1e-2,
            "{fit:?}"
        );
        for c in 0..3 {
            assert!(
                (fit.model.kd[c] / truth.kd[c] - 1.0).abs() < 2e-2,
                "{fit:?}"
            );
        }
    }
}
