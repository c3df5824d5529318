//! Light-direction samplers behind one interface: cosine-weighted (the naive
//! baseline), tabulated (binary search in CDF tables with a stored pdf) and
//! rational (the fitted inverse CDFs with the pdf-free weight).
//!
//! Directions are unit vectors with z along the normal. Isotropy: a sampler
//! works in the azimuth relative to the view, `phi_l - phi_v`, draws it on
//! `[0, pi]` and mirrors it to `[-pi, 0]` with probability 1/2 (the first
//! uniform number is split in two to choose the side).

use crate::mis::DensityGrid;
use crate::model::RationalCdf;
use crate::table::invert_cdf;
use crate::CdfTable;
use brdf::{elevation, from_spherical, to_spherical, Brdf, Vec3};
use rational_core::PowerForm;
use std::f64::consts::{FRAC_PI_2, PI};
use std::sync::OnceLock;

/// A sampled light direction and the inverse of its density.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DirectionSample {
    /// The light direction (unit, upper hemisphere).
    pub wi: Vec3,
    /// `1 / pdf(wi)` per steradian: the Monte-Carlo weight of the sample.
    pub inv_pdf: f64,
}

/// A strategy for sampling light directions given a view direction.
pub trait Sampler: Send + Sync {
    /// Short name for reports.
    fn name(&self) -> String;

    /// A direction for the view `wo` and two uniform numbers in `[0, 1)`;
    /// `None` when the sample carries no weight.
    fn sample(&self, wo: Vec3, u: [f64; 2]) -> Option<DirectionSample>;

    /// Density per steradian of the directions [`Sampler::sample`] returns.
    /// For the rational sampler it is implied by the map (found by inverting
    /// it), not stored.
    fn pdf(&self, wo: Vec3, wi: Vec3) -> f64;

    /// The density that weighs this strategy in multiple importance
    /// sampling at `wi`: zero where [`Sampler::pdf`] is zero, positive
    /// elsewhere. Any such function keeps a MIS estimator unbiased when the
    /// same one weighs the samples of every strategy (the weights still sum
    /// to one), so a sampler whose exact density is costly may approximate
    /// it here. The default is [`Sampler::pdf`].
    fn mis_pdf(&self, wo: Vec3, wi: Vec3) -> f64 {
        self.pdf(wo, wi)
    }

    /// [`Sampler::mis_pdf`] at a direction this sampler returned for `wo`;
    /// the default is the sample's exact density.
    fn mis_pdf_of_sample(&self, wo: Vec3, sample: &DirectionSample) -> f64 {
        let _ = wo;
        1.0 / sample.inv_pdf
    }

    /// Bytes the sampler stores per material (f32).
    fn byte_size(&self) -> usize;
}

/// The estimator's contribution of one sample:
/// `rho(v, l) cos(theta_l) / pdf(l)` per channel (zero when no sample).
pub fn weighted_sample(
    material: &dyn Brdf,
    sampler: &dyn Sampler,
    wo: Vec3,
    u: [f64; 2],
) -> Option<(Vec3, [f64; 3])> {
    let s = sampler.sample(wo, u)?;
    let f = material.eval(s.wi, wo);
    let w = s.wi[2].max(0.0) * s.inv_pdf;
    Some((s.wi, [f[0] * w, f[1] * w, f[2] * w]))
}

/// `(theta_v, phi_v)` of the view.
fn view_angles(wo: Vec3) -> (f64, f64) {
    let (t, p) = to_spherical(wo);
    (t, if wo[0] == 0.0 && wo[1] == 0.0 { 0.0 } else { p })
}

/// `(theta_v, theta_l, |phi_l - phi_v|)`, the azimuth difference wrapped
/// to `[0, pi]` by one `atan2` of the horizontal parts' cross and dot
/// products (a view along the normal has `phi_v = 0`).
fn pair_angles(wo: Vec3, wi: Vec3) -> (f64, f64, f64) {
    let (ax, ay) = if wo[0] == 0.0 && wo[1] == 0.0 {
        (1.0, 0.0)
    } else {
        (wo[0], wo[1])
    };
    let cross = (ax * wi[1] - ay * wi[0]).abs();
    let dot = ax * wi[0] + ay * wi[1];
    (elevation(wo), elevation(wi), cross.atan2(dot))
}

/// Splits `u` into a side (`+1` or `-1`) and a fresh uniform number.
fn mirror(u: f64) -> (f64, f64) {
    if u < 0.5 {
        (1.0, 2.0 * u)
    } else {
        (-1.0, (2.0 * u - 1.0).min(1.0))
    }
}

fn direction(phi_v: f64, theta: f64, side: f64, phi_rel: f64) -> Vec3 {
    from_spherical(theta, phi_v + side * phi_rel)
}

/// Cosine-weighted sampling: `pdf = cos(theta_l) / pi`, blind to the BRDF.
#[derive(Debug, Clone, Copy, Default)]
pub struct CosineSampler;

impl Sampler for CosineSampler {
    fn name(&self) -> String {
        "cosine".into()
    }

    fn sample(&self, _wo: Vec3, u: [f64; 2]) -> Option<DirectionSample> {
        let theta = u[0].sqrt().asin();
        let c = theta.cos();
        (c > 0.0).then(|| DirectionSample {
            wi: from_spherical(theta, 2.0 * PI * u[1]),
            inv_pdf: PI / c,
        })
    }

    fn pdf(&self, _wo: Vec3, wi: Vec3) -> f64 {
        wi[2].max(0.0) / PI
    }

    fn byte_size(&self) -> usize {
        0
    }
}

/// Tabulated sampling: the nearest view slice of a [`CdfTable`], a cell by
/// binary search in its CDFs, uniform inside the cell; the stored cell
/// probability gives the pdf.
#[derive(Debug, Clone)]
pub struct TabulatedSampler {
    table: CdfTable,
}

impl TabulatedSampler {
    /// A sampler over `table`.
    pub fn new(table: CdfTable) -> Self {
        Self { table }
    }

    /// The table.
    pub fn table(&self) -> &CdfTable {
        &self.table
    }
}

impl Sampler for TabulatedSampler {
    fn name(&self) -> String {
        "tabulated".into()
    }

    fn sample(&self, wo: Vec3, u: [f64; 2]) -> Option<DirectionSample> {
        let (tv, pv) = view_angles(wo);
        let i = self.table.nearest_view(tv);
        let s = self.table.slice_ref(i);
        let (nt, np) = self.table.cells();
        let (dt, dp) = self.table.cell_size();
        let (j, fj) = invert_cdf(&s.marginal, u[0]);
        let (side, tau) = mirror(u[1]);
        let (k, fk) = invert_cdf(&s.conditional[j * (np + 1)..(j + 1) * (np + 1)], tau);
        let theta = ((j as f64 + fj) * dt).min(FRAC_PI_2);
        let phi = (k as f64 + fk) * dp;
        let mass = s.mass[j * np + k];
        let sin = theta.sin();
        debug_assert!(j < nt);
        (mass > 0.0 && sin > 0.0).then(|| DirectionSample {
            wi: direction(pv, theta, side, phi),
            inv_pdf: 2.0 * sin * dt * dp / mass,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f64 {
        if wi[2] <= 0.0 {
            return 0.0;
        }
        let (tv, theta, phi) = pair_angles(wo, wi);
        let s = self.table.slice_ref(self.table.nearest_view(tv));
        let (nt, np) = self.table.cells();
        let (dt, dp) = self.table.cell_size();
        let j = ((theta / dt) as usize).min(nt - 1);
        let k = ((phi / dp) as usize).min(np - 1);
        let sin = theta.sin();
        if sin <= 0.0 {
            return 0.0;
        }
        s.mass[j * np + k] / (2.0 * sin * dt * dp)
    }

    fn byte_size(&self) -> usize {
        self.table.byte_size_f32()
    }
}

/// Sampling by the fitted inverse CDFs; the weight is the map's Jacobian
/// `alpha = d theta/d mu * d phi/d tau * sin(theta_l) * 2`, so no pdf is
/// stored. The estimate is unbiased whenever the map is a bijection (monotone
/// with the built-in boundaries), however accurate the fit.
///
/// Per sample it evaluates both maps in power form
/// (`rational_core::PowerForm`, built in [`RationalSampler::new`]; the
/// fitted basis where a map does not convert), which gives the basis
/// form's values to rounding in about a third of the time.
///
/// The exact density of a direction it did not choose ([`Sampler::pdf`])
/// takes two Newton inversions of the map; [`Sampler::mis_pdf`] looks it up
/// instead in a grid of those densities, derived from the map on first use
/// (16 x 32 x 33 nodes of `ln pdf`, 66 KiB in memory, nothing stored).
#[derive(Debug, Clone)]
pub struct RationalSampler {
    cdf: RationalCdf,
    /// The rational parts of theta and phi in power form, where they
    /// convert (`rational_core::PowerForm`): the per-sample path.
    power: [Option<PowerForm>; 2],
    mis_grid: OnceLock<DensityGrid>,
}

impl RationalSampler {
    /// A sampler over fitted inverse CDFs.
    pub fn new(cdf: RationalCdf) -> Self {
        let power = [
            PowerForm::new(&cdf.theta.rational),
            PowerForm::new(&cdf.phi.rational),
        ];
        Self {
            cdf,
            power,
            mis_grid: OnceLock::new(),
        }
    }

    /// Whether the theta and phi maps are evaluated in power form (false
    /// where a part's expansion would amplify rounding: see
    /// `rational_core::PowerForm`).
    pub fn uses_power_form(&self) -> [bool; 2] {
        self.power.each_ref().map(Option::is_some)
    }

    fn power(&self) -> [Option<&PowerForm>; 2] {
        self.power.each_ref().map(Option::as_ref)
    }

    /// The inverse CDFs.
    pub fn cdf(&self) -> &RationalCdf {
        &self.cdf
    }

    /// The exact density per steradian at view elevation `tv`, light
    /// elevation `tl` and relative azimuth `phi` in `[0, pi]`, by inverting
    /// the map.
    fn density(&self, tv: f64, tl: f64, phi: f64) -> f64 {
        let tv = tv.clamp(0.0, self.cdf.max_view);
        let [theta_power, phi_power] = self.power();
        let Some(mu) = self.cdf.theta.invert_in(&[tv, 0.0], tl, theta_power) else {
            return 0.0;
        };
        let Some(tau) = self.cdf.phi.invert_in(&[tv, tl, 0.0], phi, phi_power) else {
            return 0.0;
        };
        let (_, _, alpha) = self.cdf.map_in(tv, mu, tau, self.power());
        if alpha > 0.0 {
            1.0 / (2.0 * alpha)
        } else {
            f64::INFINITY
        }
    }

    fn mis_grid(&self) -> &DensityGrid {
        self.mis_grid
            .get_or_init(|| DensityGrid::new(&self.cdf, |tv, tl, phi| self.density(tv, tl, phi)))
    }
}

impl Sampler for RationalSampler {
    fn name(&self) -> String {
        "rational".into()
    }

    fn sample(&self, wo: Vec3, u: [f64; 2]) -> Option<DirectionSample> {
        let (tv, pv) = view_angles(wo);
        let (side, tau) = mirror(u[1]);
        let (theta, phi, alpha) = self.cdf.map_in(tv, u[0], tau, self.power());
        (alpha > 0.0 && alpha.is_finite()).then(|| DirectionSample {
            wi: direction(pv, theta, side, phi),
            inv_pdf: 2.0 * alpha,
        })
    }

    fn pdf(&self, wo: Vec3, wi: Vec3) -> f64 {
        if wi[2] <= 0.0 {
            return 0.0;
        }
        let (tv, theta, phi) = pair_angles(wo, wi);
        self.density(tv, theta, phi)
    }

    fn mis_pdf(&self, wo: Vec3, wi: Vec3) -> f64 {
        if wi[2] <= 0.0 {
            return 0.0;
        }
        let (tv, theta, phi) = pair_angles(wo, wi);
        self.mis_grid().density(tv, theta, phi)
    }

    fn mis_pdf_of_sample(&self, wo: Vec3, sample: &DirectionSample) -> f64 {
        self.mis_pdf(wo, sample.wi)
    }

    fn byte_size(&self) -> usize {
        self.cdf.byte_size_f32()
    }
}
