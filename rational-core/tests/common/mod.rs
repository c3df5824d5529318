//! Sample grids shared by the integration tests.
// Each test file uses its own subset of these helpers.
#![allow(dead_code)]

use rational_core::IntervalData;

/// `f` on `n` equally spaced points of `[0, 1]`, relative intervals `rel`.
pub fn grid_1d(n: usize, f: impl Fn(f64) -> f64, rel: f64) -> IntervalData {
    let x: Vec<f64> = (0..n).map(|i| i as f64 / (n - 1) as f64).collect();
    let v = x.iter().map(|&x| f(x)).collect();
    IntervalData::from_values_relative(1, x, v, rel).unwrap()
}

/// `f` on an `n x n` grid of the unit square, relative intervals `rel`.
pub fn grid_2d(n: usize, f: impl Fn(f64, f64) -> f64, rel: f64) -> IntervalData {
    let mut pts = Vec::new();
    let mut v = Vec::new();
    for i in 0..n {
        for j in 0..n {
            let (x, y) = (i as f64 / (n - 1) as f64, j as f64 / (n - 1) as f64);
            pts.extend([x, y]);
            v.push(f(x, y));
        }
    }
    IntervalData::from_values_relative(2, pts, v, rel).unwrap()
}
