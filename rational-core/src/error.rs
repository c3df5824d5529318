//! The crate's error type.

/// Bad input, bad settings, or no fit within the allowed budget.
#[derive(Debug, thiserror::Error, Clone, PartialEq)]
#[non_exhaustive]
pub enum FitError {
    /// A coordinate, bound or value is NaN or infinite.
    #[error("{what} {index} is not finite ({value})")]
    NonFinite {
        /// Which quantity ("point", "lower bound", ...).
        what: &'static str,
        /// Sample index.
        index: usize,
        /// The offending value.
        value: f64,
    },
    /// A lower bound lies above its upper bound.
    #[error("sample {index}: lower bound {lo} is above upper bound {hi}")]
    LowerAboveUpper {
        /// Sample index.
        index: usize,
        /// Lower bound.
        lo: f64,
        /// Upper bound.
        hi: f64,
    },
    /// Sizes of points, bounds or coefficients disagree.
    #[error("dimension mismatch: {0}")]
    DimensionMismatch(String),
    /// There are no samples at all.
    #[error("the data set is empty")]
    Empty,
    /// Fewer samples than the smallest coefficient budget.
    #[error("{samples} samples cannot determine {coeffs} coefficients")]
    TooFewSamples {
        /// Samples available.
        samples: usize,
        /// Coefficients requested.
        coeffs: usize,
    },
    /// A setting is out of range.
    #[error("invalid setting `{name}`: {reason}")]
    InvalidSetting {
        /// Setting name.
        name: &'static str,
        /// Why it was refused.
        reason: String,
    },
    /// No split of any budget up to the maximum was feasible.
    #[error(
        "no feasible rational fit with at most {max_coeffs} coefficients \
         ({} splits tried, intervals widened {widenings} times by x{}); \
         raise the coefficient budget or widen the intervals",
        splits.len(),
        format!("{factor:.3}").trim_end_matches('0').trim_end_matches('.')
    )]
    NoFeasibleFit {
        /// Every split solved, in order, with why it was refused.
        splits: Vec<crate::SplitSummary>,
        /// Largest budget tried.
        max_coeffs: usize,
        /// Widenings tried.
        widenings: usize,
        /// Widening factor.
        factor: f64,
    },
    /// The sweep was stopped through [`crate::FitSettings::with_cancel`].
    #[error("the fit was cancelled after {splits_tried} splits")]
    Cancelled {
        /// Splits solved before the flag was seen.
        splits_tried: usize,
    },
    /// A fit exists, found while settling only that
    /// ([`crate::FitSettings::with_existence_only`]); none is returned.
    #[error("a fit exists (found after {splits_tried} splits); the sweep settled only that")]
    FitExists {
        /// Splits solved in all.
        splits_tried: usize,
    },
    /// The solver layer refused (bad problem, backend not compiled, ...).
    #[error(transparent)]
    Backend(#[from] qp_backends::Error),
    /// A serialised function is malformed.
    #[error("malformed rational function: {0}")]
    Malformed(String),
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_widening_factor_is_named_briefly() {
        let message = |factor: f64| {
            FitError::NoFeasibleFit {
                splits: Vec::new(),
                max_coeffs: 60,
                widenings: 3,
                factor,
            }
            .to_string()
        };
        assert!(message(std::f64::consts::SQRT_2).contains("3 times by x1.414)"));
        assert!(message(2.0).contains("3 times by x2)"));
    }
}
