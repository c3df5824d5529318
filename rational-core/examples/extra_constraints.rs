//! Add your own linear constraints to the fit: here, a quantity that cannot
//! be negative, measured with an offset that dips below zero. The intervals
//! allow negative values; the extra rows forbid them on a dense grid.
//!
//! Each extra row `g` is read as `g . (a, b) > 0` over the coefficients of
//! `p` (`a`) and `q` (`b`); `p(x) > 0` at a point is the row
//! `(phi_0(x), ..., phi_{n_p - 1}(x), 0, ..., 0)`, and with `q > 0` it makes
//! `r = p / q` positive there.
//!
//! ```sh
//! cargo run --release -p rational-core --example extra_constraints
//! ```

use rational_core::{Basis, ExtraConstraints, FitReport, FitSettings, Fitter};
use rational_core::{IntervalData, RationalFunction};

/// `p > 0` at `grid` (1-D points).
struct PositiveOn {
    grid: Vec<f64>,
}

impl ExtraConstraints for PositiveOn {
    fn rows(&self, basis: &Basis, n_p: usize, n_q: usize) -> Vec<Vec<f64>> {
        let mut phi = vec![0.0; basis.len()];
        self.grid
            .iter()
            .map(|&x| {
                basis.eval_into(&[x], &mut phi);
                let mut row = phi[..n_p].to_vec();
                row.resize(n_p + n_q, 0.0);
                row
            })
            .collect()
    }
}

/// `x^2` read with an offset of -0.03, within +-0.05 (absolute): the
/// intervals hold the true value and reach below zero near `x = 0`.
fn measured() -> IntervalData {
    let x: Vec<f64> = (0..200).map(|i| -1.0 + 2.0 * i as f64 / 199.0).collect();
    let v: Vec<f64> = x.iter().map(|x| x * x - 0.03).collect();
    IntervalData::from_values_absolute(1, x, v, 0.05).expect("finite data")
}

/// The smallest value of `f` on a fine grid of [-1, 1].
fn smallest(f: &RationalFunction) -> f64 {
    (0..=4000)
        .map(|i| f.eval(&[-1.0 + i as f64 / 2000.0]))
        .fold(f64::INFINITY, f64::min)
}

fn fits() -> (FitReport, FitReport) {
    let data = measured();
    let settings = FitSettings::default();
    let plain = rational_core::fit(&data, &settings).expect("a fit");
    let grid = (0..=400).map(|i| -1.0 + i as f64 / 200.0).collect();
    let positive_on_grid = PositiveOn { grid };
    let positive = Fitter::new(&data)
        .settings(settings)
        .constraints(&positive_on_grid)
        .fit()
        .expect("a positive fit");
    (plain, positive)
}

fn main() {
    let (plain, positive) = fits();
    println!(
        "intervals only:      {} coefficients, smallest value {:.3e}",
        plain.n_p + plain.n_q,
        smallest(&plain.function)
    );
    println!(
        "and p > 0 on a grid: {} coefficients, smallest value {:.3e}",
        positive.n_p + positive.n_q,
        smallest(&positive.function)
    );
}

#[test]
fn the_constrained_fit_is_verified_and_positive_on_its_grid() {
    let (plain, positive) = fits();
    // The intervals alone let the fit dip below zero; the rows do not.
    assert!(smallest(&plain.function) < 0.0);
    assert!(positive.verification.satisfied);
    for i in 0..=400 {
        assert!(positive.function.eval(&[-1.0 + i as f64 / 200.0]) > 0.0);
    }
}
