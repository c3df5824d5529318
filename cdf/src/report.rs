//! Reports of the inverse-CDF fits.

use crate::model::Component;
use serde::Serialize;
use std::fmt;

/// Figures of one fitted inverse CDF.
#[derive(Debug, Clone, Serialize)]
pub struct ComponentReport {
    /// Which inverse CDF.
    pub component: Component,
    /// Numerator coefficients.
    pub n_p: usize,
    /// Denominator coefficients.
    pub n_q: usize,
    /// Samples fitted.
    pub samples: usize,
    /// Points carrying monotonicity rows before refinement.
    pub monotone_points: usize,
    /// Half-width of the intervals in CDF space (after any doubling).
    pub cdf_tolerance: f64,
    /// Largest `|r - F^-1|` at the samples (radians).
    pub max_error_rad: f64,
    /// Mean `|r - F^-1|` at the samples (radians).
    pub mean_error_rad: f64,
    /// Smallest `d r / d u` on the check grid.
    pub min_derivative: f64,
    /// Points of the check grid.
    pub check_points: usize,
    /// Rounds in which failing grid points were added to the accepted split.
    pub refinement_rounds: usize,
    /// Budgets probed by the search.
    pub budgets_tried: Vec<usize>,
    /// Smallest `q` at the samples relative to the largest (from the verifier).
    pub min_q_ratio: f64,
    /// Wall time (s).
    pub seconds: f64,
}

/// Report of [`fit_table`](crate::fit_table).
#[derive(Debug, Clone, Serialize)]
pub struct CdfFitReport {
    /// Material.
    pub material: String,
    /// Theta inverse CDF.
    pub theta: ComponentReport,
    /// Phi inverse CDF.
    pub phi: ComponentReport,
    /// Coefficient bytes (f32) of both.
    pub bytes: usize,
    /// Bytes of the table they replace (f32, with its pdf).
    pub table_bytes: usize,
    /// Total wall time (s).
    pub seconds: f64,
}

impl fmt::Display for CdfFitReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        writeln!(f, "inverse CDFs of {}", self.material)?;
        writeln!(
            f,
            "  {:<6} {:>9} {:>8} {:>8} {:>10} {:>11} {:>11} {:>12} {:>7} {:>8}",
            "",
            "(n_p,n_q)",
            "samples",
            "mono",
            "cdf tol",
            "max err rad",
            "mean err",
            "min dr/du",
            "rounds",
            "time s"
        )?;
        for c in [&self.theta, &self.phi] {
            writeln!(
                f,
                "  {:<6} {:>9} {:>8} {:>8} {:>10.4} {:>11.3e} {:>11.3e} {:>12.3e} {:>7} {:>8.2}",
                c.component.name(),
                format!("({},{})", c.n_p, c.n_q),
                c.samples,
                c.monotone_points,
                c.cdf_tolerance,
                c.max_error_rad,
                c.mean_error_rad,
                c.min_derivative,
                c.refinement_rounds,
                c.seconds
            )?;
        }
        write!(
            f,
            "  {} coefficient bytes (f32) against {} bytes of table; {:.2} s",
            self.bytes, self.table_bytes, self.seconds
        )
    }
}
