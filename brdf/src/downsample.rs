//! The honest "just store less" peer: a table downsampled to a byte budget.

use crate::geometry::{HalfDiff, Vec3};
use crate::Brdf;
use rayon::prelude::*;
use std::f64::consts::PI;

/// An isotropic table on a coarse `(sqrt(theta_h / (pi/2)), theta_d, phi_d)`
/// grid of cell averages (RGB, f32 in storage), interpolated trilinearly
/// between cell centres and held constant beyond the outer centres.
#[derive(Debug, Clone, PartialEq)]
pub struct DownsampledTable {
    /// Bins in the warped `theta_h`, `theta_d` and folded `phi_d`.
    pub bins: [usize; 3],
    /// RGB per cell, `phi_d` fastest.
    pub values: Vec<[f32; 3]>,
    name: String,
}

/// Sub-samples per axis when averaging a cell.
const SUPERSAMPLE: usize = 3;

impl DownsampledTable {
    /// The grid whose RGB f32 cells fit in `bytes`: `theta_h` and `theta_d`
    /// get twice the bins of `phi_d` (a BRDF varies least along `phi_d`).
    pub fn bins_for_bytes(bytes: usize) -> [usize; 3] {
        let cells = (bytes / 12).max(1);
        let mut best = [1, 1, 1];
        let score = |b: [usize; 3]| (b[0] * b[1] * b[2], b[0]);
        for nh in 1..=cells {
            for nd in 1..=cells / nh {
                let np = (cells / (nh * nd)).min(nh.min(nd).div_ceil(2)).max(1);
                let candidate = [nh, nd, np];
                // Near-square in theta_h and theta_d; phi_d at most half of either.
                let square = nh.abs_diff(nd) <= 1.max(nh.max(nd) / 3);
                if square && score(candidate) > score(best) {
                    best = candidate;
                }
            }
        }
        best
    }

    /// Averages `material` over each cell of a `bins` grid.
    pub fn new(material: &dyn Brdf, bins: [usize; 3]) -> Self {
        let bins = bins.map(|b| b.max(1));
        let [nh, nd, np] = bins;
        let values = (0..nh * nd * np)
            .into_par_iter()
            .map(|n| {
                let (i, j, k) = (n / (nd * np), (n / np) % nd, n % np);
                let (mut sum, mut count) = ([0.0f64; 3], 0usize);
                for a in 0..SUPERSAMPLE {
                    for b in 0..SUPERSAMPLE {
                        for c in 0..SUPERSAMPLE {
                            let sub = |cell: usize, s: usize, bins: usize| {
                                (cell as f64 + (s as f64 + 0.5) / SUPERSAMPLE as f64) / bins as f64
                            };
                            let u = sub(i, a, nh);
                            let (wi, wo) = HalfDiff {
                                theta_h: u * u * PI / 2.0,
                                phi_h: 0.0,
                                theta_d: sub(j, b, nd) * PI / 2.0,
                                phi_d: sub(k, c, np) * PI,
                            }
                            .to_directions();
                            if wi[2] > 0.0 && wo[2] > 0.0 {
                                let v = material.eval(wi, wo);
                                if v.iter().all(|x| x.is_finite()) {
                                    for ch in 0..3 {
                                        sum[ch] += v[ch].max(0.0);
                                    }
                                    count += 1;
                                }
                            }
                        }
                    }
                }
                sum.map(|s| (s / count.max(1) as f64) as f32)
            })
            .collect();
        Self {
            bins,
            values,
            name: material.name(),
        }
    }

    /// Bytes of the stored cells (RGB f32).
    pub fn byte_size_f32(&self) -> usize {
        self.values.len() * 12
    }
}

/// Linear interpolation position between cell centres: lower index and weight.
fn cell_position(x: f64, bins: usize) -> (usize, f64) {
    let p = (x * bins as f64 - 0.5).clamp(0.0, (bins - 1) as f64);
    let i = (p.floor() as usize).min(bins.saturating_sub(2));
    (i, if bins > 1 { p - i as f64 } else { 0.0 })
}

impl Brdf for DownsampledTable {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if wi[2] <= 0.0 || wo[2] <= 0.0 {
            return [0.0; 3];
        }
        let [theta_h, theta_d, phi_d] = HalfDiff::isotropic_angles(wi, wo);
        let [nh, nd, np] = self.bins;
        let u = (theta_h.max(0.0) / (PI / 2.0)).sqrt();
        let (i, wi_) = cell_position(u, nh);
        let (j, wj) = cell_position(theta_d / (PI / 2.0), nd);
        let (k, wk) = cell_position(crate::geometry::fold_phi_d(phi_d) / PI, np);
        let mut out = [0.0; 3];
        for (di, fi) in [(0, 1.0 - wi_), (1, wi_)] {
            for (dj, fj) in [(0, 1.0 - wj), (1, wj)] {
                for (dk, fk) in [(0, 1.0 - wk), (1, wk)] {
                    let w = fi * fj * fk;
                    if w == 0.0 {
                        continue;
                    }
                    let (a, b, c) = (
                        (i + di).min(nh - 1),
                        (j + dj).min(nd - 1),
                        (k + dk).min(np - 1),
                    );
                    let v = self.values[(a * nd + b) * np + c];
                    for ch in 0..3 {
                        out[ch] += w * f64::from(v[ch]);
                    }
                }
            }
        }
        out
    }

    fn name(&self) -> String {
        format!(
            "{} downsampled to {}x{}x{}",
            self.name, self.bins[0], self.bins[1], self.bins[2]
        )
    }
}

/// A material seen through the 2-D reduction (`phi_d = pi/2`): at a pair
/// whose elevations are both within `within_deg`, its value at the pair's
/// `(theta_h, theta_d)` on that slice, which is all a 2-D fit sees; beyond,
/// its own value. Rendered, it is about the least a 2-D fit evaluated within
/// that cut can lose (a fit adds its own error, and a shell factor beyond
/// the cut at best matches the material there): a 2-D fit would have to
/// render closer than it to reach a target it misses.
pub struct SliceView<B> {
    material: B,
    cos_within: f64,
}

impl<B: Brdf> SliceView<B> {
    /// `material` seen through the slice within `within_deg` of the normal.
    pub fn new(material: B, within_deg: f64) -> Self {
        Self {
            material,
            cos_within: within_deg.to_radians().cos(),
        }
    }
}

impl<B: Brdf> Brdf for SliceView<B> {
    fn eval(&self, wi: Vec3, wo: Vec3) -> [f64; 3] {
        if wi[2] < self.cos_within || wo[2] < self.cos_within {
            return self.material.eval(wi, wo);
        }
        let [theta_h, theta_d, _] = HalfDiff::isotropic_angles(wi, wo);
        let (si, so) = HalfDiff::pair_at([theta_h, theta_d, PI / 2.0]);
        self.material.eval(si, so)
    }

    fn name(&self) -> String {
        format!("{} on the phi_d = pi/2 slice", self.material.name())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::{from_spherical, Lambert};

    #[test]
    fn budgets_give_grids_that_fit_them() {
        for bytes in [12, 100, 300, 1024, 4096] {
            let b = DownsampledTable::bins_for_bytes(bytes);
            let cells: usize = b.iter().product();
            assert!(cells * 12 <= bytes.max(12), "{bytes}: {b:?}");
            assert!(
                cells * 12 * 2 > bytes,
                "{bytes}: {b:?} wastes half the budget"
            );
        }
    }

    #[test]
    fn a_constant_material_is_reproduced_exactly() {
        let m = Lambert {
            albedo: [0.2, 0.5, 0.8],
        };
        let t = DownsampledTable::new(&m, [4, 3, 2]);
        assert_eq!(t.byte_size_f32(), 4 * 3 * 2 * 12);
        let v = t.eval(from_spherical(0.3, 0.1), from_spherical(1.2, 2.0));
        for c in 0..3 {
            assert!((v[c] - m.albedo[c] / PI).abs() < 1e-6);
        }
    }

    /// Within the cut, the view takes the slice's value at the pair's
    /// `(theta_h, theta_d)`; beyond it, the material's own.
    #[test]
    fn the_slice_view_ignores_phi_d_within_the_cut_only() {
        // Its shadowing term depends on each direction's elevation, so on
        // phi_d at fixed (theta_h, theta_d).
        let m = crate::CookTorranceGgx {
            kd: [0.1, 0.1, 0.1],
            f0: [0.04, 0.05, 0.06],
            alpha: 0.3,
        };
        let view = SliceView::new(m, 70.0);
        let at = |th: f64, td: f64, pd: f64| HalfDiff::pair_at([th, td, pd]);
        // Two pairs with the same (theta_h, theta_d) and other phi_d.
        let (a, b) = (at(0.3, 0.4, 0.2), at(0.3, 0.4, 1.3));
        assert!(a.0[2] > 0.5 && a.1[2] > 0.5 && b.0[2] > 0.5 && b.1[2] > 0.5);
        let (va, vb) = (m.eval(a.0, a.1), m.eval(b.0, b.1));
        assert!((va[0] - vb[0]).abs() > 1e-3 * va[0], "{va:?} {vb:?}");
        let on_slice = at(0.3, 0.4, PI / 2.0);
        for (wi, wo) in [a, b] {
            let v = view.eval(wi, wo);
            let s = m.eval(on_slice.0, on_slice.1);
            for c in 0..3 {
                assert!((v[c] - s[c]).abs() <= 1e-9 * s[c].abs().max(1e-12));
            }
        }
        // Beyond 70 degrees the material's own value.
        let grazing = (
            from_spherical(80f64.to_radians(), 0.0),
            from_spherical(0.2, 2.0),
        );
        let bits = |v: [f64; 3]| v.map(f64::to_bits);
        assert_eq!(
            bits(view.eval(grazing.0, grazing.1)),
            bits(m.eval(grazing.0, grazing.1))
        );
    }
}
