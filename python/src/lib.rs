//! The native half of the `ratfit` Python package: rational functions fitted
//! inside intervals (`fit`, `RationalFit`) and measured BRDFs fitted by them
//! (`read_material`, `fit_brdf`, `FittedMaterial`), thin over the Rust
//! crates. The Python half (`python/ratfit/`) gives the public signatures,
//! docstrings and the Dask front end.
//!
//! Every fit runs with the GIL released on a worker thread while the calling
//! thread watches for signals, so Ctrl-C stops a long sweep (within one
//! active-set change of the native solver) and raises `KeyboardInterrupt`.

mod errors;
mod function;
mod material;
mod options;

use pyo3::prelude::*;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::Duration;

/// How often the waiting thread looks for a pending signal.
const SIGNAL_POLL: Duration = Duration::from_millis(50);

/// Runs `work` on a worker thread with the GIL released, handing it a cancel
/// flag; a signal handler that raises (Ctrl-C) sets the flag, waits for the
/// worker to stop and returns that exception.
pub(crate) fn interruptible<T, F>(py: Python<'_>, work: F) -> PyResult<T>
where
    T: Send,
    F: FnOnce(Arc<AtomicBool>) -> T + Send,
{
    let cancel = Arc::new(AtomicBool::new(false));
    py.detach(|| {
        std::thread::scope(|scope| {
            let flag = cancel.clone();
            // The worker reports on a channel, so a short fit returns as soon
            // as it is done rather than at the next poll.
            let (done, finished) = std::sync::mpsc::channel();
            let worker = scope.spawn(move || {
                let out = work(flag);
                let _ = done.send(());
                out
            });
            let mut interrupted = None;
            while let Err(std::sync::mpsc::RecvTimeoutError::Timeout) =
                finished.recv_timeout(SIGNAL_POLL)
            {
                if interrupted.is_none() {
                    if let Err(e) = Python::attach(|py| py.check_signals()) {
                        cancel.store(true, Ordering::Relaxed);
                        interrupted = Some(e);
                    }
                }
            }
            let result = worker.join().map_err(|panic| {
                let what = panic
                    .downcast_ref::<String>()
                    .cloned()
                    .or_else(|| panic.downcast_ref::<&str>().map(|s| s.to_string()))
                    .unwrap_or_default();
                pyo3::exceptions::PyRuntimeError::new_err(format!("ratfit panicked: {what}"))
            });
            match interrupted {
                Some(e) => Err(e),
                None => result,
            }
        })
    })
}

/// The extension module `ratfit._ratfit`.
#[pymodule]
fn _ratfit(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("NoFeasibleFit", py.get_type::<errors::NoFeasibleFit>())?;
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add_class::<function::RationalFit>()?;
    m.add_class::<material::Material>()?;
    m.add_class::<material::FittedMaterial>()?;
    m.add_function(wrap_pyfunction!(function::fit, m)?)?;
    m.add_function(wrap_pyfunction!(material::read_material, m)?)?;
    m.add_function(wrap_pyfunction!(material::fit_brdf, m)?)?;
    m.add_function(wrap_pyfunction!(material::fit_brdf_channel, m)?)?;
    m.add_function(wrap_pyfunction!(material::assemble_channels, m)?)?;
    m.add_function(wrap_pyfunction!(material::check_brdf_options, m)?)?;
    Ok(())
}
