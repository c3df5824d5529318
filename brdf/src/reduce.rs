//! From a BRDF to interval data: the paper's 2-D reduction
//! `rho(theta_h, theta_d)` (Romeiro et al. 2008), the spread over `phi_d` as
//! the interval, or the full 3-D `(theta_h, theta_d, phi_d)` grid; the
//! grazing cut; the fitting coordinates.

use crate::geometry::HalfDiff;
use crate::{Brdf, BrdfError};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use std::f64::consts::PI;

/// Which function of the isotropic BRDF is fitted.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum ReductionKind {
    /// `rho(theta_h, theta_d)` on the slice `phi_d = pi/2`.
    Slice2d,
    /// `rho(theta_h, theta_d)` with the interval spanning the values over
    /// `phi_d` (widened by the relative tolerance); the value is the slice.
    Spread2d,
    /// The full `(theta_h, theta_d, phi_d)` table, `phi_d` folded to `[0, pi)`.
    Full3d,
}

/// The coordinates the rational function is fitted in.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum Coordinates {
    /// `(theta_h, theta_d[, phi_d])` in radians.
    Radians,
    /// `(sqrt(theta_h / (pi/2)), theta_d[, phi_d])`: the MERL warp, which
    /// spreads the specular peak.
    SqrtThetaH,
    /// `(cos theta_h, cos theta_d[, phi_d])`.
    Cosines,
}

impl Coordinates {
    /// Fitting coordinates of Rusinkiewicz angles.
    pub fn map(self, theta_h: f64, theta_d: f64, phi_d: f64, dims: usize) -> Vec<f64> {
        let (a, b) = match self {
            Coordinates::Radians => (theta_h, theta_d),
            Coordinates::SqrtThetaH => ((theta_h.max(0.0) / (PI / 2.0)).sqrt(), theta_d),
            Coordinates::Cosines => (theta_h.cos(), theta_d.cos()),
        };
        if dims == 3 {
            vec![a, b, phi_d]
        } else {
            vec![a, b]
        }
    }

    /// Rusinkiewicz angles `(theta_h, theta_d, phi_d)` of fitting
    /// coordinates (the inverse of [`Coordinates::map`]); a 2-D point is on
    /// the slice `phi_d = pi / 2`.
    pub fn angles(self, x: &[f64]) -> [f64; 3] {
        let (theta_h, theta_d) = match self {
            Coordinates::Radians => (x[0], x[1]),
            Coordinates::SqrtThetaH => (x[0] * x[0] * (PI / 2.0), x[1]),
            Coordinates::Cosines => (x[0].clamp(-1.0, 1.0).acos(), x[1].clamp(-1.0, 1.0).acos()),
        };
        [theta_h, theta_d, x.get(2).copied().unwrap_or(PI / 2.0)]
    }
}

/// How `phi_d` (folded into `[0, pi]`) enters a 3-D reduction's fitting
/// coordinates.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
#[non_exhaustive]
pub enum PhiCoordinate {
    /// `phi_d` in radians.
    #[default]
    Radians,
    /// `cos phi_d`, over `[-1, 1]`. Folded by mirror symmetry, an isotropic
    /// BRDF is an even function of `phi_d` about 0 and about pi, so a
    /// smooth function of `cos phi_d` (its cosine series in `phi_d` is a
    /// Chebyshev series in `cos phi_d`): a polynomial in `cos phi_d` has
    /// the zero slope at both folds that a polynomial in `phi_d` spends
    /// degrees to approach.
    Cosine,
}

impl PhiCoordinate {
    /// The fitting coordinate of a folded `phi_d`.
    pub fn map(self, phi_d: f64) -> f64 {
        match self {
            PhiCoordinate::Radians => phi_d,
            PhiCoordinate::Cosine => phi_d.cos(),
        }
    }

    /// The folded `phi_d` of a fitting coordinate (the inverse of
    /// [`PhiCoordinate::map`]).
    pub fn angle(self, x: f64) -> f64 {
        match self {
            PhiCoordinate::Radians => x,
            PhiCoordinate::Cosine => x.clamp(-1.0, 1.0).acos(),
        }
    }

    /// Whether this is the default, [`PhiCoordinate::Radians`] (left out
    /// of fit files).
    pub fn is_radians(&self) -> bool {
        *self == PhiCoordinate::Radians
    }
}

impl std::fmt::Display for PhiCoordinate {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            PhiCoordinate::Radians => "radians",
            PhiCoordinate::Cosine => "cosine",
        })
    }
}

impl std::str::FromStr for PhiCoordinate {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "radians" => Ok(PhiCoordinate::Radians),
            "cosine" => Ok(PhiCoordinate::Cosine),
            other => Err(format!(
                "unknown phi_d coordinate {other:?} (radians or cosine)"
            )),
        }
    }
}

/// How a BRDF is sampled for fitting.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct Reduction {
    /// What is fitted.
    pub kind: ReductionKind,
    /// Fitting coordinates.
    pub coordinates: Coordinates,
    /// Bins in `theta_h` (sqrt-warped like MERL's).
    pub n_theta_h: usize,
    /// Bins in `theta_d`.
    pub n_theta_d: usize,
    /// Bins in `phi_d` over `[0, pi)` (3-D and spread).
    pub n_phi_d: usize,
    /// Samples with `theta_d` above this many degrees are not fitted (the
    /// paper removes those above 78).
    pub max_theta_d_deg: f64,
    /// Cells whose incident or outgoing elevation exceeds this many degrees
    /// are not sampled: near the horizon, measured tables divide small noisy
    /// values by a vanishing cosine.
    pub max_elevation_deg: f64,
    /// How `phi_d` enters the fitting coordinates of a 3-D reduction.
    #[serde(default, skip_serializing_if = "PhiCoordinate::is_radians")]
    pub phi: PhiCoordinate,
}

impl Default for Reduction {
    /// The 2-D slice on the MERL grid (90 x 90), sqrt-warped `theta_h`,
    /// grazing `theta_d > 78` degrees cut, directions within 70 degrees of
    /// the normal.
    fn default() -> Self {
        Self {
            kind: ReductionKind::Slice2d,
            coordinates: Coordinates::SqrtThetaH,
            n_theta_h: 90,
            n_theta_d: 90,
            n_phi_d: 180,
            max_theta_d_deg: 78.0,
            max_elevation_deg: 70.0,
            phi: PhiCoordinate::Radians,
        }
    }
}

/// How far inside the horizon [`Reduction::domain`] stops (radians, about
/// 0.06 degrees): at the horizon itself a cosine vanishes.
pub const HORIZON_INSET_RAD: f64 = 1e-3;

/// Most bins a reduction may have along one angle.
pub const MAX_BINS: usize = 4096;

impl Reduction {
    /// Checks bin counts (`1..=`[`MAX_BINS`]) and cuts (finite, in
    /// `(0, 90]` degrees).
    ///
    /// # Errors
    /// The first field out of range, named with its value.
    pub fn validate(&self) -> Result<(), BrdfError> {
        let bad = |name: &'static str, reason: String| Err(BrdfError::Invalid { name, reason });
        for (name, n) in [
            ("reduction n_theta_h", self.n_theta_h),
            ("reduction n_theta_d", self.n_theta_d),
            ("reduction n_phi_d", self.n_phi_d),
        ] {
            if !(1..=MAX_BINS).contains(&n) {
                return bad(name, format!("{n} is outside 1..={MAX_BINS}"));
            }
        }
        for (name, v) in [
            ("reduction max_theta_d_deg", self.max_theta_d_deg),
            ("reduction max_elevation_deg", self.max_elevation_deg),
        ] {
            if !(v > 0.0 && v <= 90.0) {
                return bad(name, format!("{v} degrees is outside (0, 90]"));
            }
        }
        Ok(())
    }

    /// Sets the kind.
    pub fn with_kind(mut self, kind: ReductionKind) -> Self {
        self.kind = kind;
        self
    }

    /// Sets the coordinates.
    pub fn with_coordinates(mut self, c: Coordinates) -> Self {
        self.coordinates = c;
        self
    }

    /// Sets how `phi_d` enters the fitting coordinates (3-D reductions).
    pub fn with_phi(mut self, phi: PhiCoordinate) -> Self {
        self.phi = phi;
        self
    }

    /// This reduction as a fit records it: a 2-D fit has no third
    /// coordinate, so it records `phi_d` as the default (radians, left out
    /// of fit files), whatever the settings it came from said.
    pub fn as_fitted(self) -> Self {
        match self.dims() {
            3 => self,
            _ => self.with_phi(PhiCoordinate::Radians),
        }
    }

    /// The reduction's kind and coordinates as reports name them, with
    /// `cos phi_d` where that is a 3-D fit's third coordinate.
    pub fn label(&self) -> String {
        let phi = match (self.dims(), self.phi) {
            (3, PhiCoordinate::Cosine) => ", cos phi_d",
            _ => "",
        };
        format!("{:?} in {:?} coordinates{phi}", self.kind, self.coordinates)
    }

    /// Fitting coordinates of Rusinkiewicz angles (`phi_d` folded into
    /// `[0, pi]`), in this reduction's coordinates and number of them.
    pub fn point(&self, theta_h: f64, theta_d: f64, phi_d: f64) -> Vec<f64> {
        let mut x = self.coordinates.map(theta_h, theta_d, phi_d, self.dims());
        if let Some(p) = x.get_mut(2) {
            *p = self.phi.map(*p);
        }
        x
    }

    /// Rusinkiewicz angles of fitting coordinates (the inverse of
    /// [`Reduction::point`]); a 2-D point is on the slice `phi_d = pi / 2`.
    pub fn angles(&self, x: &[f64]) -> [f64; 3] {
        let [theta_h, theta_d, phi_d] = self.coordinates.angles(x);
        [
            theta_h,
            theta_d,
            x.get(2).map_or(phi_d, |&p| self.phi.angle(p)),
        ]
    }

    /// Sets the `theta_h` and `theta_d` resolutions.
    pub fn with_resolution(mut self, n_theta_h: usize, n_theta_d: usize) -> Self {
        self.n_theta_h = n_theta_h.max(2);
        self.n_theta_d = n_theta_d.max(2);
        self
    }

    /// Sets the `phi_d` resolution.
    pub fn with_phi_resolution(mut self, n_phi_d: usize) -> Self {
        self.n_phi_d = n_phi_d.max(2);
        self
    }

    /// Sets the largest elevation of either direction, in degrees.
    pub fn with_max_elevation(mut self, degrees: f64) -> Self {
        self.max_elevation_deg = degrees;
        self
    }

    /// Sets the grazing cut in degrees (90 keeps everything).
    pub fn with_max_theta_d(mut self, degrees: f64) -> Self {
        self.max_theta_d_deg = degrees;
        self
    }

    /// Every cell up to the horizon: no elevation cut, no grazing cut (the
    /// perceptual interval design bounds those cells loosely instead).
    pub fn whole_hemisphere(self) -> Self {
        self.with_max_elevation(90.0).with_max_theta_d(90.0)
    }

    /// The box of fitting coordinates a fit of this reduction is evaluated
    /// on: `theta_h` and `theta_d` from 0 to just inside the horizon
    /// (`theta_d` no further than the grazing cut, where evaluation clamps
    /// it), `phi_d` over `[0, pi]`; lower and upper corners. The sample
    /// cells' centres span less, so a check over this box also covers the
    /// extrapolation beyond the outermost cells.
    pub fn domain(&self) -> (Vec<f64>, Vec<f64>) {
        let horizon = PI / 2.0 - HORIZON_INSET_RAD;
        let theta_d_max = self.max_theta_d_deg.to_radians().min(horizon);
        let a = self.point(0.0, 0.0, 0.0);
        let b = self.point(horizon, theta_d_max, PI);
        (
            a.iter().zip(&b).map(|(x, y)| x.min(*y)).collect(),
            a.iter().zip(&b).map(|(x, y)| x.max(*y)).collect(),
        )
    }

    /// Number of fitting coordinates.
    pub fn dims(&self) -> usize {
        if self.kind == ReductionKind::Full3d {
            3
        } else {
            2
        }
    }

    fn theta_h(&self, i: usize) -> f64 {
        let u = (i as f64 + 0.5) / self.n_theta_h as f64;
        u * u * PI / 2.0
    }

    fn theta_d(&self, j: usize) -> f64 {
        (j as f64 + 0.5) / self.n_theta_d as f64 * PI / 2.0
    }

    fn phi_d(&self, k: usize) -> f64 {
        (k as f64 + 0.5) / self.n_phi_d as f64 * PI
    }

    /// Samples `material` on the reduction's grid.
    pub fn sample(&self, material: &dyn Brdf) -> Samples {
        let dims = self.dims();
        let mut cells = Vec::new();
        for i in 0..self.n_theta_h {
            for j in 0..self.n_theta_d {
                let index = |k: usize| [i as u32, j as u32, k as u32];
                match self.kind {
                    ReductionKind::Full3d => {
                        for k in 0..self.n_phi_d {
                            cells.push((self.theta_h(i), self.theta_d(j), self.phi_d(k), index(k)));
                        }
                    }
                    _ => cells.push((self.theta_h(i), self.theta_d(j), PI / 2.0, index(0))),
                }
            }
        }
        let spread = self.kind == ReductionKind::Spread2d;
        let rows: Vec<Option<SampleRow>> = cells
            .par_iter()
            .map(|&(th, td, pd, cell)| {
                let min_cos = self.max_elevation_deg.to_radians().cos();
                let value = eval_at(material, th, td, pd, min_cos)?;
                let (mut lo, mut hi) = (value.0, value.0);
                if spread {
                    for k in 0..self.n_phi_d {
                        let v = eval_at(material, th, td, self.phi_d(k), min_cos)?.0;
                        for c in 0..3 {
                            lo[c] = lo[c].min(v[c]);
                            hi[c] = hi[c].max(v[c]);
                        }
                    }
                }
                Some(SampleRow {
                    point: self.point(th, td, pd),
                    cell: Some(cell),
                    angles: [th, td, pd],
                    value: value.0,
                    lo,
                    hi,
                    cos_weight: value.1,
                    grazing: td.to_degrees() > self.max_theta_d_deg,
                })
            })
            .collect();
        let rows: Vec<SampleRow> = rows.into_iter().flatten().collect();
        Samples { dims, rows }
    }
}

/// The BRDF at Rusinkiewicz angles (with `phi_h = 0`) and `cos_i cos_o`;
/// `None` below the horizon.
fn eval_at(
    material: &dyn Brdf,
    theta_h: f64,
    theta_d: f64,
    phi_d: f64,
    min_cos: f64,
) -> Option<([f64; 3], f64)> {
    let (wi, wo) = HalfDiff::pair_at([theta_h, theta_d, phi_d]);
    if wi[2] <= min_cos.max(1e-9) || wo[2] <= min_cos.max(1e-9) {
        return None;
    }
    Some((material.eval(wi, wo), wi[2] * wo[2]))
}

/// One sampled cell.
#[derive(Debug, Clone, PartialEq)]
pub struct SampleRow {
    /// Fitting coordinates.
    pub point: Vec<f64>,
    /// Grid indices `(theta_h, theta_d, phi_d)` of the cell (`None` for
    /// scattered measurements).
    pub cell: Option<[u32; 3]>,
    /// `(theta_h, theta_d, phi_d)` of the cell.
    pub angles: [f64; 3],
    /// RGB value.
    pub value: [f64; 3],
    /// Lower end of the spread (equal to `value` unless spread).
    pub lo: [f64; 3],
    /// Upper end of the spread.
    pub hi: [f64; 3],
    /// `cos theta_i cos theta_o` of the cell's direction pair.
    pub cos_weight: f64,
    /// Beyond the grazing cut.
    pub grazing: bool,
}

/// A sampled BRDF.
#[derive(Debug, Clone, PartialEq)]
pub struct Samples {
    /// Number of fitting coordinates.
    pub dims: usize,
    /// Cells above the horizon.
    pub rows: Vec<SampleRow>,
}

impl Samples {
    /// The same cells with the values of a colour mode's functions (for
    /// luminance-chroma: `Y`, `r / Y`, `b / Y`; NaN where `Y` is not
    /// positive, which the interval builders leave out). Spreads keep the
    /// interval of the luminance and the value of the ratios.
    pub fn in_colour_mode(&self, mode: crate::ColourMode) -> Samples {
        let split = |v: [f64; 3]| mode.split(v).map(|x| x.unwrap_or(f64::NAN));
        let rows = self
            .rows
            .iter()
            .map(|r| {
                let value = split(r.value);
                let (mut lo, mut hi) = (value, value);
                lo[0] = split(r.lo)[0];
                hi[0] = split(r.hi)[0];
                SampleRow {
                    value,
                    lo,
                    hi,
                    ..r.clone()
                }
            })
            .collect();
        Samples {
            dims: self.dims,
            rows,
        }
    }

    /// Interval data of channel `c`: half-width `max(t |v|, floor * median)`
    /// (relative intervals with a noise floor, `median` the channel's median
    /// positive value, robust to specular peaks; `floor = 0` gives purely
    /// relative intervals), from the non-grazing cells with a finite value;
    /// also returns the rows used. A cell measured at zero or below (noise
    /// about a dark value, or a colour outside the RGB gamut) has no
    /// relative bound; it gets `[-median, median]`, so the fit is no brighter
    /// than the channel's typical value where the table is dark instead of
    /// free there, without having to follow the edge of the dark region
    /// down to the noise floor. A positive cell whose spread reaches zero is
    /// left out.
    ///
    /// # Errors
    /// No usable sample, or invalid values.
    pub fn channel(
        &self,
        c: usize,
        t: f64,
        floor: f64,
    ) -> Result<(rational_core::IntervalData, Vec<usize>), rational_core::FitError> {
        let finite = |r: &SampleRow| {
            !r.grazing && r.value[c].is_finite() && r.lo[c].is_finite() && r.hi[c].is_finite()
        };
        let mut sorted: Vec<f64> = self
            .rows
            .iter()
            .filter(|r| finite(r) && r.value[c] > 0.0)
            .map(|r| r.value[c])
            .collect();
        sorted.sort_by(f64::total_cmp);
        let median = sorted.get(sorted.len() / 2).copied().unwrap_or(0.0);
        let h = floor * median;
        let used: Vec<usize> = (0..self.rows.len())
            .filter(|&i| {
                let r = &self.rows[i];
                let dark_bounded = r.value[c] <= 0.0 && median > 0.0;
                finite(r) && (dark_bounded || (r.value[c] > 0.0 && r.lo[c] > 0.0))
            })
            .collect();
        let points = used
            .iter()
            .flat_map(|&i| self.rows[i].point.clone())
            .collect();
        let dark = |r: &SampleRow| r.value[c] <= 0.0;
        let lo = used
            .iter()
            .map(|&i| {
                let r = &self.rows[i];
                if dark(r) {
                    -median
                } else {
                    r.lo[c] - (t * r.lo[c]).max(h)
                }
            })
            .collect();
        let hi = used
            .iter()
            .map(|&i| {
                let r = &self.rows[i];
                if dark(r) {
                    median
                } else {
                    r.hi[c] + (t * r.hi[c]).max(h)
                }
            })
            .collect();
        let values = used.iter().map(|&i| self.rows[i].value[c]).collect();
        let data =
            rational_core::IntervalData::new(self.dims, points, lo, hi)?.with_values(values)?;
        Ok((data, used))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cos_phi_d_points_map_back_to_their_angles_and_span_minus_one_to_one() {
        let r = Reduction::default()
            .with_kind(ReductionKind::Full3d)
            .with_phi(PhiCoordinate::Cosine);
        for &(th, td, pd) in &[(0.1, 0.4, 0.0), (0.7, 1.1, 1.3), (0.02, 0.3, PI)] {
            let x = r.point(th, td, pd);
            assert!((x[2] - pd.cos()).abs() < 1e-15, "{x:?}");
            let back = r.angles(&x);
            for (a, b) in back.iter().zip([th, td, pd]) {
                assert!((a - b).abs() < 1e-9, "{back:?} against {:?}", [th, td, pd]);
            }
        }
        let (lower, upper) = r.domain();
        assert_eq!((lower[2], upper[2]), (-1.0, 1.0));
        // A slice has no third coordinate, records none, and radians stay
        // the default.
        let slice = r.with_kind(ReductionKind::Slice2d);
        assert_eq!(slice.point(0.1, 0.4, 1.0).len(), 2);
        assert_eq!(slice.as_fitted().phi, PhiCoordinate::Radians);
        assert_eq!(r.as_fitted(), r);
        assert_eq!(Reduction::default().phi, PhiCoordinate::Radians);
        // Reports name the cosine only where a 3-D fit takes it.
        assert_eq!(r.label(), "Full3d in SqrtThetaH coordinates, cos phi_d");
        assert_eq!(slice.label(), "Slice2d in SqrtThetaH coordinates");
        for phi in [PhiCoordinate::Radians, PhiCoordinate::Cosine] {
            assert_eq!(phi.to_string().parse::<PhiCoordinate>(), Ok(phi));
        }
        let e = "sine".parse::<PhiCoordinate>().unwrap_err();
        assert!(e.contains("sine") && e.contains("radians or cosine"), "{e}");
    }
}
