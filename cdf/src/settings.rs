//! Settings of the inverse-CDF fits.

use crate::error::invalid;
use crate::CdfError;
use rational_core::FitSettings;

/// Settings of [`fit_table`](crate::fit_table).
#[derive(Debug, Clone)]
pub struct CdfFitSettings {
    pub(crate) cdf_tolerance: f64,
    pub(crate) min_half_width: f64,
    pub(crate) mu_samples: usize,
    pub(crate) tau_samples: usize,
    pub(crate) phi_rows: usize,
    pub(crate) phi_view_stride: usize,
    pub(crate) max_coeffs: [usize; 2],
    pub(crate) widenings: usize,
    pub(crate) refinement_rounds: usize,
    pub(crate) check_density: usize,
    pub(crate) engine: FitSettings,
}

impl Default for CdfFitSettings {
    /// Intervals of +-0.05 in CDF space (at least +-1e-3 rad), 32 steps in
    /// `mu` per view, 16 in `tau` on 16 rows of `theta_l` at every other
    /// view, at most 64 (theta) and 120 (phi) coefficients, 4 doublings of
    /// the tolerance, 8 refinement rounds per split, a check grid 6x
    /// denser than the data.
    fn default() -> Self {
        Self {
            cdf_tolerance: 0.05,
            min_half_width: 1e-3,
            mu_samples: 32,
            tau_samples: 16,
            phi_rows: 16,
            phi_view_stride: 2,
            max_coeffs: [64, 120],
            widenings: 4,
            refinement_rounds: 8,
            check_density: 6,
            engine: FitSettings::default(),
        }
    }
}

impl CdfFitSettings {
    /// The half-width of every interval in CDF space.
    pub fn cdf_tolerance(&self) -> f64 {
        self.cdf_tolerance
    }

    /// The smallest half-width in radians.
    pub fn min_half_width(&self) -> f64 {
        self.min_half_width
    }

    /// Half-width of every interval in CDF space, and the smallest half-width
    /// in radians.
    ///
    /// # Errors
    /// Not in `(0, 0.5)`, or a negative or non-finite minimum.
    pub fn with_tolerance(mut self, cdf: f64, min_radians: f64) -> Result<Self, CdfError> {
        if !(cdf > 0.0 && cdf < 0.5) {
            return Err(invalid(
                "cdf tolerance",
                format!("{cdf} is outside (0, 0.5)"),
            ));
        }
        if !(min_radians.is_finite() && min_radians >= 0.0) {
            return Err(invalid("minimum half-width", format!("{min_radians}")));
        }
        self.cdf_tolerance = cdf;
        self.min_half_width = min_radians;
        Ok(self)
    }

    /// Steps in `mu` (per view) and `tau` (per view and row), rows of
    /// `theta_l` for the phi data, and the stride through the table's views
    /// for the phi data.
    ///
    /// # Errors
    /// Fewer than 4 steps or rows, a zero stride.
    pub fn with_samples(
        mut self,
        mu: usize,
        tau: usize,
        phi_rows: usize,
        phi_view_stride: usize,
    ) -> Result<Self, CdfError> {
        if mu < 4 || tau < 4 || phi_rows < 4 || phi_view_stride == 0 {
            return Err(invalid(
                "samples",
                format!("mu {mu}, tau {tau}, rows {phi_rows} (each >= 4), stride {phi_view_stride} (>= 1)"),
            ));
        }
        self.mu_samples = mu;
        self.tau_samples = tau;
        self.phi_rows = phi_rows;
        self.phi_view_stride = phi_view_stride;
        Ok(self)
    }

    /// Largest coefficient budgets of the theta and phi fits.
    ///
    /// # Errors
    /// A budget below 2.
    pub fn with_max_coeffs(mut self, theta: usize, phi: usize) -> Result<Self, CdfError> {
        if theta < 2 || phi < 2 {
            return Err(invalid(
                "max coefficients",
                format!("{theta}, {phi} (each >= 2)"),
            ));
        }
        self.max_coeffs = [theta, phi];
        Ok(self)
    }

    /// How often the CDF tolerance may double when no budget is feasible.
    pub fn with_widenings(mut self, times: usize) -> Self {
        self.widenings = times;
        self
    }

    /// Rounds of added monotonicity constraints per split (then the split
    /// is refused), and how much denser than the data the check grid is per
    /// coordinate.
    ///
    /// # Errors
    /// A density below 4 (the check must be denser than the data).
    pub fn with_monotone_check(mut self, rounds: usize, density: usize) -> Result<Self, CdfError> {
        if density < 4 {
            return Err(invalid("check density", format!("{density} is below 4")));
        }
        self.refinement_rounds = rounds;
        self.check_density = density;
        Ok(self)
    }

    /// Engine settings (basis family, backend, pole control); the domain and
    /// coefficient range are set per fit.
    pub fn with_engine(mut self, engine: FitSettings) -> Self {
        self.engine = engine;
        self
    }
}
