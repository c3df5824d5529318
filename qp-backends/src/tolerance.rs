//! The one place where floating-point tolerances are decided.
//!
//! Rounding in a dot product of length `n` is bounded by `n * eps * sum |a_k b_k|`
//! (Higham, *Accuracy and Stability of Numerical Algorithms*, 3.1). Every
//! tolerance in the workspace is this bound times a small safety factor, scaled
//! by the magnitude of the quantities compared, never a bare constant.

/// Safety factor applied on top of the worst-case rounding bound.
pub const SAFETY: f64 = 16.0;

/// Relative rounding tolerance for quantities built from `n`-term sums.
pub fn rounding_tolerance(n: usize) -> f64 {
    SAFETY * f64::EPSILON * (n.max(1) as f64)
}

/// Absolute tolerance for comparing `a` and `b`, computed from `n`-term sums
/// whose terms have total magnitude `scale`.
pub fn absolute_tolerance(n: usize, scale: f64) -> f64 {
    rounding_tolerance(n) * scale.abs().max(f64::MIN_POSITIVE)
}

/// `true` when `a` and `b` agree to the rounding tolerance of `n`-term sums.
pub fn approx_eq(a: f64, b: f64, n: usize) -> bool {
    (a - b).abs() <= absolute_tolerance(n, a.abs().max(b.abs()).max(1e-300))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tolerance_grows_with_size() {
        assert!(rounding_tolerance(100) > rounding_tolerance(10));
        assert!(rounding_tolerance(0) > 0.0);
    }

    #[test]
    fn approx_eq_is_relative() {
        assert!(approx_eq(1e12, 1e12 * (1.0 + 1e-15), 4));
        assert!(!approx_eq(1.0, 1.0 + 1e-6, 4));
    }
}
