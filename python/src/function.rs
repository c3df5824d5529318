//! `fit` and `RationalFit`: a rational function fitted inside intervals,
//! evaluated on numpy arrays.

use crate::errors::{fit_error, json_error};
use crate::options::{json_to_py, vector};
use numpy::ndarray::{ArrayD, IxDyn};
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArrayDyn, PyArrayLikeDyn};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyTuple;
use rational_core::{
    Backend, BasisFamily, Domain, FitReport, FitSettings, IntervalData, PoleControl,
    RationalFunction, Search, Selection,
};

/// A rational function `p / q` fitted inside intervals, with the report of
/// its fit when it has one (a function read from a bare function JSON has
/// none).
#[pyclass(module = "ratfit._ratfit", frozen)]
pub struct RationalFit {
    pub(crate) function: RationalFunction,
    pub(crate) report: Option<FitReport>,
}

impl RationalFit {
    pub(crate) fn bare(function: RationalFunction) -> Self {
        Self {
            function,
            report: None,
        }
    }
}

/// Points of an array of shape (s,) (dimension 1) or (s, d), row-major,
/// with the dimension.
fn points(x: &PyArrayLikeDyn<'_, f64, AllowTypeChange>) -> PyResult<(Vec<f64>, usize)> {
    let a = x.as_array();
    match a.ndim() {
        1 => Ok((a.iter().copied().collect(), 1)),
        2 if a.shape()[1] >= 1 => Ok((a.iter().copied().collect(), a.shape()[1])),
        _ => Err(PyValueError::new_err(format!(
            "x has shape {:?}; give (s,) or (s, d) points",
            a.shape()
        ))),
    }
}

/// The interval data from the arguments of `fit`.
#[allow(clippy::too_many_arguments)]
fn interval_data(
    x: &PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    y: Option<&PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    lo: Option<&PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    hi: Option<&PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    rel_tol: Option<f64>,
    abs_tol: Option<f64>,
) -> PyResult<Result<IntervalData, rational_core::FitError>> {
    let (pts, dim) = points(x)?;
    let samples = pts.len() / dim;
    let column = |name: &str, a: &PyArrayLikeDyn<'_, f64, AllowTypeChange>| -> PyResult<Vec<f64>> {
        vector(name, a, samples)
    };
    let values = y.map(|y| column("y", y)).transpose()?;
    Ok(match (lo, hi, rel_tol, abs_tol) {
        (Some(lo), Some(hi), None, None) => {
            let d = IntervalData::new(dim, pts, column("lo", lo)?, column("hi", hi)?);
            match values {
                Some(v) => d.and_then(|d| d.with_values(v)),
                None => d,
            }
        }
        (None, None, Some(t), None) | (None, None, None, Some(t)) => {
            let Some(v) = values else {
                return Err(PyValueError::new_err(
                    "rel_tol and abs_tol build intervals around y: give y",
                ));
            };
            if rel_tol.is_some() {
                IntervalData::from_values_relative(dim, pts, v, t)
            } else {
                IntervalData::from_values_absolute(dim, pts, v, t)
            }
        }
        (None, None, None, None) => {
            return Err(PyValueError::new_err(
                "no intervals: give lo and hi, or y with rel_tol or abs_tol",
            ))
        }
        _ => {
            return Err(PyValueError::new_err(
                "give the intervals one way: lo and hi (both), or one of rel_tol and abs_tol",
            ))
        }
    })
}

/// Parses a setting's name through the library's own parser (which names the
/// choices when it refuses).
fn parse<T: std::str::FromStr<Err = rational_core::FitError>>(
    py: Python<'_>,
    text: &str,
) -> PyResult<T> {
    text.parse().map_err(|e| fit_error(py, e))
}

/// Fits a rational function inside intervals (see `ratfit.fit` for the
/// arguments); the GIL is released while the sweep runs.
#[pyfunction]
#[pyo3(signature = (
    x, y=None, *, lo=None, hi=None, rel_tol=None, abs_tol=None, max_coeffs=40,
    min_coeffs=2, basis="chebyshev", poles="grid", search="exhaustive",
    selection="condition", degree_weights=None, domain=None, max_widenings=0,
    backend="native", value_scaling=true
))]
#[allow(clippy::too_many_arguments)]
pub fn fit(
    py: Python<'_>,
    x: PyArrayLikeDyn<'_, f64, AllowTypeChange>,
    y: Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    lo: Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    hi: Option<PyArrayLikeDyn<'_, f64, AllowTypeChange>>,
    rel_tol: Option<f64>,
    abs_tol: Option<f64>,
    max_coeffs: usize,
    min_coeffs: usize,
    basis: &str,
    poles: &str,
    search: &str,
    selection: &str,
    degree_weights: Option<Vec<u16>>,
    domain: Option<(Vec<f64>, Vec<f64>)>,
    max_widenings: usize,
    backend: &str,
    value_scaling: bool,
) -> PyResult<RationalFit> {
    let data = interval_data(&x, y.as_ref(), lo.as_ref(), hi.as_ref(), rel_tol, abs_tol)?
        .map_err(|e| fit_error(py, e))?;
    let with = |s: Result<FitSettings, rational_core::FitError>| s.map_err(|e| fit_error(py, e));
    let mut settings = with(FitSettings::default().with_coeff_range(min_coeffs, max_coeffs))?
        .with_family(parse::<BasisFamily>(py, basis)?)
        .with_pole_control(parse::<PoleControl>(py, poles)?)
        .with_search(parse::<Search>(py, search)?)
        .with_selection(parse::<Selection>(py, selection)?)
        .with_value_scaling(value_scaling);
    let backend = backend
        .parse::<Backend>()
        .map_err(|e| PyValueError::new_err(format!("backend: {e}")))?;
    settings = with(settings.with_backend(backend))?;
    if let Some(w) = degree_weights {
        settings = with(settings.with_degree_weights(w))?;
    }
    if let Some((lower, upper)) = domain {
        let domain = Domain::new(lower, upper).map_err(|e| fit_error(py, e))?;
        settings = settings.with_domain(domain);
    }
    if max_widenings > 0 {
        settings = with(settings.with_widening(2.0, max_widenings))?;
    }
    let report = crate::interruptible(py, move |cancel| {
        rational_core::fit(&data, &settings.with_cancel(cancel))
    })?
    .map_err(|e| fit_error(py, e))?;
    Ok(RationalFit {
        function: report.function.clone(),
        report: Some(report),
    })
}

#[pymethods]
impl RationalFit {
    /// Evaluates the function: `x` of shape (s,) for a 1-D function (any
    /// shape, elementwise), or (..., d) for a d-D one (the last axis holds
    /// the coordinates); returns an array of the remaining shape (a float
    /// for a single point).
    fn __call__<'py>(
        &self,
        py: Python<'py>,
        x: PyArrayLikeDyn<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyAny>> {
        let a = x.as_array();
        let d = self.function.dim();
        let shape: Vec<usize> = if d == 1 {
            a.shape().to_vec()
        } else {
            match a.shape().split_last() {
                Some((&last, rest)) if last == d => rest.to_vec(),
                _ => {
                    return Err(PyValueError::new_err(format!(
                        "points of shape {:?} for a function of {d} coordinates: the last axis must be {d}",
                        a.shape()
                    )))
                }
            }
        };
        let flat: Vec<f64> = a.iter().copied().collect();
        let f = &self.function;
        let values = py.detach(|| f.eval_many(&flat));
        if shape.is_empty() {
            return Ok(values[0].into_pyobject(py)?.into_any());
        }
        let out = ArrayD::from_shape_vec(IxDyn(&shape), values)
            .map_err(|e| PyValueError::new_err(e.to_string()))?;
        Ok(PyArrayDyn::from_owned_array(py, out).into_any())
    }

    /// Numerator coefficients.
    #[getter]
    fn n_p(&self) -> usize {
        self.function.split().0
    }

    /// Denominator coefficients.
    #[getter]
    fn n_q(&self) -> usize {
        self.function.split().1
    }

    /// Number of coordinates.
    #[getter]
    fn dim(&self) -> usize {
        self.function.dim()
    }

    /// Numerator coefficients, in the basis order.
    #[getter]
    fn numerator<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.function.numerator().to_vec().into_pyarray(py)
    }

    /// Denominator coefficients, in the basis order.
    #[getter]
    fn denominator<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray1<f64>> {
        self.function.denominator().to_vec().into_pyarray(py)
    }

    /// The box mapped to [-1, 1]^d: (lower corner, upper corner).
    #[getter]
    fn domain(&self) -> (Vec<f64>, Vec<f64>) {
        let d = self.function.basis().domain();
        (d.lower.clone(), d.upper.clone())
    }

    /// Basis family name.
    #[getter]
    fn basis(&self) -> String {
        format!("{:?}", self.function.basis().family()).to_lowercase()
    }

    /// Bytes of the coefficients stored as f32.
    #[getter]
    fn nbytes(&self) -> usize {
        self.function.byte_size_f32()
    }

    /// The fit's report as a dict (None for a bare function): `verified`,
    /// `depth`, `condition_number`, `errors`, `splits_tried`, `seconds`,
    /// the verification and pole figures, and every split solved.
    #[getter]
    fn report<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let Some(r) = &self.report else {
            return Ok(None);
        };
        let mut value = serde_json::to_value(r).map_err(|e| json_error("report", e))?;
        if let Some(map) = value.as_object_mut() {
            map.remove("function");
            map.insert(
                "verified".into(),
                serde_json::Value::Bool(r.verification.satisfied),
            );
        }
        json_to_py(py, &value).map(Some)
    }

    /// The JSON the CLI writes: `ratfit fit-csv`'s report (with the
    /// function), or the bare function when there is no report.
    fn to_json(&self) -> PyResult<String> {
        match &self.report {
            Some(r) => serde_json::to_string_pretty(r),
            None => serde_json::to_string_pretty(&self.function),
        }
        .map_err(|e| json_error("fit", e))
    }

    /// Reads what `to_json` or `ratfit fit-csv` wrote (a report with its
    /// function, or a bare function), validated.
    #[staticmethod]
    fn from_json(text: &str) -> PyResult<Self> {
        let value: serde_json::Value =
            serde_json::from_str(text).map_err(|e| json_error("not JSON", e))?;
        if value.get("function").is_some() {
            let report: FitReport =
                serde_json::from_value(value).map_err(|e| json_error("malformed fit report", e))?;
            if report.function.split() != (report.n_p, report.n_q) {
                return Err(PyValueError::new_err(format!(
                    "malformed fit report: n_p, n_q = {}, {} but the function has {:?}",
                    report.n_p,
                    report.n_q,
                    report.function.split()
                )));
            }
            return Ok(Self {
                function: report.function.clone(),
                report: Some(report),
            });
        }
        let function: RationalFunction = serde_json::from_value(value)
            .map_err(|e| json_error("malformed rational function", e))?;
        Ok(Self::bare(function))
    }

    /// Pickling (Dask moves fits between processes) through the JSON.
    fn __reduce__<'py>(
        slf: &Bound<'py, Self>,
        py: Python<'py>,
    ) -> PyResult<(Bound<'py, PyAny>, Bound<'py, PyTuple>)> {
        let from_json = py.get_type::<Self>().getattr("from_json")?;
        let args = PyTuple::new(py, [slf.get().to_json()?])?;
        Ok((from_json, args))
    }

    fn __repr__(&self) -> String {
        let (np, nq) = self.function.split();
        match &self.report {
            Some(r) => format!(
                "RationalFit(n_p={np}, n_q={nq}, dim={}, verified={}, max_relative={:.3e})",
                self.function.dim(),
                r.verification.satisfied,
                r.errors.max_relative
            ),
            None => format!(
                "RationalFit(n_p={np}, n_q={nq}, dim={})",
                self.function.dim()
            ),
        }
    }
}
