//! Interval data: points in R^d with a lower and an upper bound each.

use crate::{Domain, FitError};

/// Samples `x_i` with intervals `[lo_i, hi_i]` and, optionally, the measured
/// value the interval was built around (used for error figures).
#[derive(Debug, Clone, PartialEq)]
pub struct IntervalData {
    dim: usize,
    points: Vec<f64>,
    lo: Vec<f64>,
    hi: Vec<f64>,
    values: Option<Vec<f64>>,
}

impl IntervalData {
    /// Data from row-major points (`len * dim`) and bounds.
    ///
    /// # Errors
    /// Empty data, size mismatch, NaN or infinite entries, `lo > hi`.
    pub fn new(dim: usize, points: Vec<f64>, lo: Vec<f64>, hi: Vec<f64>) -> Result<Self, FitError> {
        let d = Self {
            dim,
            points,
            lo,
            hi,
            values: None,
        };
        d.validate()?;
        Ok(d)
    }

    /// Intervals `[v - t|v|, v + t|v|]` around values `v` (relative tolerance `t`).
    ///
    /// # Errors
    /// As [`IntervalData::new`], plus a negative or non-finite `t`.
    pub fn from_values_relative(
        dim: usize,
        points: Vec<f64>,
        values: Vec<f64>,
        t: f64,
    ) -> Result<Self, FitError> {
        check_tolerance("relative tolerance", t)?;
        Self::from_values_with(dim, points, values, |v| t * v.abs())
    }

    /// Intervals `[v - a, v + a]` (absolute tolerance `a`).
    ///
    /// # Errors
    /// As [`IntervalData::new`], plus a negative or non-finite `a`.
    pub fn from_values_absolute(
        dim: usize,
        points: Vec<f64>,
        values: Vec<f64>,
        a: f64,
    ) -> Result<Self, FitError> {
        check_tolerance("absolute tolerance", a)?;
        Self::from_values_with(dim, points, values, |_| a)
    }

    fn from_values_with(
        dim: usize,
        points: Vec<f64>,
        values: Vec<f64>,
        half: impl Fn(f64) -> f64,
    ) -> Result<Self, FitError> {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(FitError::NonFinite {
                what: "value of sample",
                index: i,
                value: values[i],
            });
        }
        let lo = values.iter().map(|&v| v - half(v)).collect();
        let hi = values.iter().map(|&v| v + half(v)).collect();
        let d = Self {
            dim,
            points,
            lo,
            hi,
            values: Some(values),
        };
        d.validate()?;
        Ok(d)
    }

    fn validate(&self) -> Result<(), FitError> {
        if self.dim == 0 {
            return Err(FitError::DimensionMismatch(
                "points need at least one coordinate".into(),
            ));
        }
        if self.lo.is_empty() {
            return Err(FitError::Empty);
        }
        let n = self.lo.len();
        if self.points.len() != n * self.dim || self.hi.len() != n {
            return Err(FitError::DimensionMismatch(format!(
                "{} coordinates for {} samples of dimension {}, {} lower and {} upper bounds",
                self.points.len(),
                n,
                self.dim,
                n,
                self.hi.len()
            )));
        }
        if let Some(k) = self.points.iter().position(|v| !v.is_finite()) {
            return Err(FitError::NonFinite {
                what: "coordinate of sample",
                index: k / self.dim,
                value: self.points[k],
            });
        }
        for i in 0..n {
            if !self.lo[i].is_finite() {
                return Err(FitError::NonFinite {
                    what: "lower bound of sample",
                    index: i,
                    value: self.lo[i],
                });
            }
            if !self.hi[i].is_finite() {
                return Err(FitError::NonFinite {
                    what: "upper bound of sample",
                    index: i,
                    value: self.hi[i],
                });
            }
            if self.lo[i] > self.hi[i] {
                return Err(FitError::LowerAboveUpper {
                    index: i,
                    lo: self.lo[i],
                    hi: self.hi[i],
                });
            }
        }
        if let Some(v) = &self.values {
            if v.len() != n {
                return Err(FitError::DimensionMismatch(format!(
                    "{} values for {n} samples",
                    v.len()
                )));
            }
        }
        Ok(())
    }

    /// Attaches the measured values (for error figures).
    ///
    /// # Errors
    /// Wrong length or non-finite values.
    pub fn with_values(mut self, values: Vec<f64>) -> Result<Self, FitError> {
        if let Some(i) = values.iter().position(|v| !v.is_finite()) {
            return Err(FitError::NonFinite {
                what: "value of sample",
                index: i,
                value: values[i],
            });
        }
        self.values = Some(values);
        self.validate()?;
        Ok(self)
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.lo.len()
    }

    /// Always false for validated data.
    pub fn is_empty(&self) -> bool {
        self.lo.is_empty()
    }

    /// Number of coordinates.
    pub fn dim(&self) -> usize {
        self.dim
    }

    /// Point `i`.
    pub fn point(&self, i: usize) -> &[f64] {
        &self.points[i * self.dim..(i + 1) * self.dim]
    }

    /// All points, row-major.
    pub fn points(&self) -> &[f64] {
        &self.points
    }

    /// Lower bounds.
    pub fn lo(&self) -> &[f64] {
        &self.lo
    }

    /// Upper bounds.
    pub fn hi(&self) -> &[f64] {
        &self.hi
    }

    /// Measured value of sample `i`: the stored value, else the midpoint.
    pub fn value(&self, i: usize) -> f64 {
        match &self.values {
            Some(v) => v[i],
            None => 0.5 * (self.lo[i] + self.hi[i]),
        }
    }

    /// The largest bound magnitude (1 when all bounds are zero): dividing by
    /// it makes the data unit-free, so scaled data give the same fit.
    pub fn value_scale(&self) -> f64 {
        let m = self
            .lo
            .iter()
            .chain(&self.hi)
            .fold(0.0_f64, |m, v| m.max(v.abs()));
        if m > 0.0 && m.is_finite() {
            m
        } else {
            1.0
        }
    }

    /// The bounding box of the points.
    pub fn bounding_box(&self) -> Domain {
        let mut lower = vec![f64::INFINITY; self.dim];
        let mut upper = vec![f64::NEG_INFINITY; self.dim];
        for p in self.points.chunks_exact(self.dim) {
            for k in 0..self.dim {
                lower[k] = lower[k].min(p[k]);
                upper[k] = upper[k].max(p[k]);
            }
        }
        Domain { lower, upper }
    }

    /// Every interval widened by `factor`. An interval of one sign is
    /// widened on a log scale: its half-width in `ln |v|` is multiplied
    /// about the geometric centre, so the relative error allowed grows but
    /// zero never enters (a relative interval widened linearly soon
    /// contains zero, and the zero function then "fits" every sample). An
    /// interval with zero at one end keeps it there and moves the other end
    /// out by the factor (non-negative data stay non-negative); one with
    /// zero inside has its half-width multiplied about its centre.
    pub fn widened(&self, factor: f64) -> Self {
        let mut out = self.clone();
        for i in 0..self.len() {
            let (lo, hi) = (self.lo[i], self.hi[i]);
            if lo > 0.0 || hi < 0.0 {
                let sign = if lo > 0.0 { 1.0 } else { -1.0 };
                let (a, b) = ((sign * lo).ln(), (sign * hi).ln());
                let c = 0.5 * (a + b);
                let h = 0.5 * (b - a).abs() * factor;
                let (x, y) = (sign * (c - h).exp(), sign * (c + h).exp());
                out.lo[i] = x.min(y);
                out.hi[i] = x.max(y);
            } else if lo == 0.0 && hi > 0.0 {
                // A bound of one sign with zero inside stays of that sign.
                out.hi[i] = hi * factor;
            } else if hi == 0.0 && lo < 0.0 {
                out.lo[i] = lo * factor;
            } else {
                let c = 0.5 * (lo + hi);
                let h = 0.5 * (hi - lo) * factor;
                out.lo[i] = c - h;
                out.hi[i] = c + h;
            }
        }
        out
    }

    /// Data for `r` in the model `f(x) = base(x) + weight(x) r(x)`: bounds
    /// become `(lo - base) / weight` (swapped where the weight is negative).
    /// Samples with zero weight carry no information about `r` and are
    /// dropped; the indices kept are returned.
    ///
    /// # Errors
    /// Length mismatch, non-finite base or weight, or no sample left.
    pub fn with_known_part(
        &self,
        base: &[f64],
        weight: &[f64],
    ) -> Result<(Self, Vec<usize>), FitError> {
        let n = self.len();
        if base.len() != n || weight.len() != n {
            return Err(FitError::DimensionMismatch(format!(
                "{} base and {} weight values for {n} samples",
                base.len(),
                weight.len()
            )));
        }
        let mut kept = Vec::new();
        let (mut pts, mut lo, mut hi, mut vals) = (Vec::new(), Vec::new(), Vec::new(), Vec::new());
        for i in 0..n {
            if !base[i].is_finite() || !weight[i].is_finite() {
                return Err(FitError::NonFinite {
                    what: "known part at sample",
                    index: i,
                    value: base[i] + weight[i],
                });
            }
            if weight[i] == 0.0 {
                continue;
            }
            let a = (self.lo[i] - base[i]) / weight[i];
            let b = (self.hi[i] - base[i]) / weight[i];
            kept.push(i);
            pts.extend_from_slice(self.point(i));
            lo.push(a.min(b));
            hi.push(a.max(b));
            vals.push((self.value(i) - base[i]) / weight[i]);
        }
        if kept.is_empty() {
            return Err(FitError::Empty);
        }
        let d = Self {
            dim: self.dim,
            points: pts,
            lo,
            hi,
            values: Some(vals),
        };
        d.validate()?;
        Ok((d, kept))
    }
}

fn check_tolerance(name: &'static str, t: f64) -> Result<(), FitError> {
    if !(t.is_finite() && t >= 0.0) {
        return Err(FitError::InvalidSetting {
            name,
            reason: format!("{t} is not a finite non-negative number"),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn rejects_bad_input_with_named_errors() {
        assert!(matches!(
            IntervalData::new(1, vec![0.0], vec![2.0], vec![1.0]),
            Err(FitError::LowerAboveUpper { index: 0, .. })
        ));
        assert!(matches!(
            IntervalData::new(1, vec![f64::NAN], vec![0.0], vec![1.0]),
            Err(FitError::NonFinite { .. })
        ));
        assert!(matches!(
            IntervalData::new(2, vec![0.0], vec![0.0], vec![1.0]),
            Err(FitError::DimensionMismatch(_))
        ));
        assert!(matches!(
            IntervalData::new(1, vec![], vec![], vec![]),
            Err(FitError::Empty)
        ));
        assert!(IntervalData::from_values_relative(1, vec![0.0], vec![1.0], -0.1).is_err());
        assert!(
            IntervalData::from_values_relative(1, vec![0.0], vec![f64::INFINITY], 0.1).is_err()
        );
    }

    #[test]
    fn known_part_transforms_and_drops_zero_weights() {
        let d = IntervalData::new(
            1,
            vec![0.0, 1.0, 2.0],
            vec![1.0, 2.0, 3.0],
            vec![2.0, 4.0, 5.0],
        )
        .unwrap();
        let (t, kept) = d
            .with_known_part(&[1.0, 0.0, 1.0], &[2.0, 0.0, -1.0])
            .unwrap();
        assert_eq!(kept, vec![0, 2]);
        assert_eq!(t.lo(), &[0.0, -4.0]);
        assert_eq!(t.hi(), &[0.5, -2.0]);
    }
}
