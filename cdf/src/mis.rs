//! A density grid derived from a rational sampler's map, for the weights of
//! multiple importance sampling.
//!
//! MIS weights `w_s(x) = p_s(x) / sum_t p_t(x)` keep the estimator unbiased
//! for any positive functions `p_t` that are the same for every strategy's
//! samples: the weights still sum to one at every `x`. Only the sample's own
//! weight `f / pdf` needs the exact density, and the rational sampler has
//! that from its map's Jacobian. The exact density of a direction another
//! strategy chose needs two Newton inversions of the map; this grid, built
//! once from those inversions, answers with a trilinear lookup instead.

use crate::model::RationalCdf;
use std::f64::consts::{FRAC_PI_2, PI};

/// Nodes along the view elevation, `[0, max_view]` both ends included.
const VIEW_NODES: usize = 16;
/// Cell centres along the light elevation, `[0, pi/2]`.
const THETA_NODES: usize = 32;
/// Nodes along the relative azimuth, `[0, pi]` both ends included.
const PHI_NODES: usize = 33;
/// Densities are clamped to `[1 / LIMIT, LIMIT]` per steradian before the
/// logarithm, so a node where the map is degenerate stays finite.
const LIMIT: f64 = 1e8;

/// `ln pdf` of a rational sampler on a `(theta_v, theta_l, phi_rel)` grid.
#[derive(Debug, Clone)]
pub(crate) struct DensityGrid {
    max_view: f64,
    ln_pdf: Vec<f32>,
}

impl DensityGrid {
    /// The grid of `cdf`'s exact density, `density(theta_v, theta_l, phi)`
    /// per steradian on the half azimuth range, at every node.
    pub(crate) fn new(cdf: &RationalCdf, density: impl Fn(f64, f64, f64) -> f64) -> Self {
        let mut ln_pdf = Vec::with_capacity(VIEW_NODES * THETA_NODES * PHI_NODES);
        for i in 0..VIEW_NODES {
            let tv = cdf.max_view * i as f64 / (VIEW_NODES - 1) as f64;
            for j in 0..THETA_NODES {
                let tl = (j as f64 + 0.5) * FRAC_PI_2 / THETA_NODES as f64;
                for k in 0..PHI_NODES {
                    let phi = PI * k as f64 / (PHI_NODES - 1) as f64;
                    let p = density(tv, tl, phi);
                    let p = if p.is_nan() { LIMIT } else { p };
                    ln_pdf.push(p.clamp(1.0 / LIMIT, LIMIT).ln() as f32);
                }
            }
        }
        Self {
            max_view: cdf.max_view,
            ln_pdf,
        }
    }

    /// The interpolated density at view elevation `tv`, light elevation
    /// `tl` and relative azimuth `phi` in `[0, pi]`.
    pub(crate) fn density(&self, tv: f64, tl: f64, phi: f64) -> f64 {
        let fv = (tv / self.max_view).clamp(0.0, 1.0) * (VIEW_NODES - 1) as f64;
        let ft = (tl / FRAC_PI_2 * THETA_NODES as f64 - 0.5).clamp(0.0, (THETA_NODES - 1) as f64);
        let fp = (phi / PI).clamp(0.0, 1.0) * (PHI_NODES - 1) as f64;
        let (i, j, k) = (
            lower(fv, VIEW_NODES),
            lower(ft, THETA_NODES),
            lower(fp, PHI_NODES),
        );
        let (a, b, c) = (fv - i as f64, ft - j as f64, fp - k as f64);
        let at = |i: usize, j: usize, k: usize| {
            f64::from(self.ln_pdf[(i * THETA_NODES + j) * PHI_NODES + k])
        };
        let plane = |i: usize| {
            let near = at(i, j, k) * (1.0 - c) + at(i, j, k + 1) * c;
            let far = at(i, j + 1, k) * (1.0 - c) + at(i, j + 1, k + 1) * c;
            near * (1.0 - b) + far * b
        };
        (plane(i) * (1.0 - a) + plane(i + 1) * a).exp()
    }
}

/// The node below `f` such that the node above exists.
fn lower(f: f64, nodes: usize) -> usize {
    (f as usize).min(nodes - 2)
}
