//! The library's errors as Python exceptions, with the library's message:
//! bad input and settings raise `ValueError`, unreadable files `OSError`,
//! an empty sweep `ratfit.NoFeasibleFit` (carrying the splits it tried).

use pyo3::exceptions::{PyFileNotFoundError, PyOSError, PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use rational_core::FitError;

pyo3::create_exception!(
    ratfit,
    NoFeasibleFit,
    PyRuntimeError,
    "No split of any coefficient budget up to the maximum fits inside every \
     interval. Attributes: `max_coeffs`, `widenings`, and `splits` (a list of \
     dicts, one per split solved: n_p, n_q, status, note, depth, seconds)."
);

/// A Python exception for `error`, whose message is `message` (the error as
/// the caller saw it, with its context); the cause is found in the chain.
fn convert(py: Python<'_>, error: &(dyn std::error::Error + 'static), message: String) -> PyErr {
    let mut cause: Option<&(dyn std::error::Error + 'static)> = Some(error);
    while let Some(e) = cause {
        if let Some(fit) = e.downcast_ref::<FitError>() {
            return from_fit(py, fit, message);
        }
        if let Some(io) = e.downcast_ref::<std::io::Error>() {
            return match io.kind() {
                std::io::ErrorKind::NotFound => PyFileNotFoundError::new_err(message),
                _ => PyOSError::new_err(message),
            };
        }
        cause = e.source();
    }
    PyValueError::new_err(message)
}

fn from_fit(py: Python<'_>, error: &FitError, message: String) -> PyErr {
    match error {
        FitError::NoFeasibleFit {
            splits,
            max_coeffs,
            widenings,
            ..
        } => {
            let err = NoFeasibleFit::new_err(format!(
                "{message} (keywords: max_coeffs for the budget, rel_tol or lo and hi for the intervals)"
            ));
            let attach = || -> PyResult<()> {
                let value = err.value(py);
                value.setattr("max_coeffs", *max_coeffs)?;
                value.setattr("widenings", *widenings)?;
                let json = serde_json::to_string(splits)
                    .map_err(|e| PyRuntimeError::new_err(e.to_string()))?;
                let list = py.import("json")?.call_method1("loads", (json,))?;
                value.setattr("splits", list)
            };
            match attach() {
                Ok(()) => err,
                Err(e) => e,
            }
        }
        FitError::Backend(_) => PyRuntimeError::new_err(message),
        FitError::Cancelled { .. } => pyo3::exceptions::PyKeyboardInterrupt::new_err(message),
        _ => PyValueError::new_err(message),
    }
}

/// A fit error of `rational_core`.
pub(crate) fn fit_error(py: Python<'_>, error: FitError) -> PyErr {
    let message = error.to_string();
    from_fit(py, &error, message)
}

/// A reader's or fitter's error of `brdf`.
pub(crate) fn brdf_error(py: Python<'_>, error: brdf::BrdfError) -> PyErr {
    let message = error.to_string();
    convert(py, &error, message)
}

/// A renderer's error (the render check, `target_de`).
pub(crate) fn render_error(py: Python<'_>, error: render_cpu::RenderError) -> PyErr {
    let message = error.to_string();
    convert(py, &error, message)
}

/// A JSON document that does not parse or does not hold what was expected.
pub(crate) fn json_error(what: &str, error: serde_json::Error) -> PyErr {
    PyValueError::new_err(format!("{what}: {error}"))
}
