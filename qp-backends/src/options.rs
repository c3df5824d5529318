//! Solver settings, built with `Default` plus validated `with_*` methods.

use crate::Error;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;

/// Shared flags that ask a solve to stop when any of them is set: the
/// native backend checks them at every active-set change, the others
/// before they start. Two compare equal when they hold the same flags.
#[derive(Debug, Clone, Default)]
pub struct CancelFlag(Vec<Arc<AtomicBool>>);

impl CancelFlag {
    /// Wraps a flag that another thread (a signal handler, a deadline) sets.
    pub fn new(flag: Arc<AtomicBool>) -> Self {
        Self(vec![flag])
    }

    /// Stops when any of `flags` is set (none: never), so that a caller's
    /// interrupt and a stop of its own can both end a solve.
    pub fn any(flags: Vec<Arc<AtomicBool>>) -> Self {
        Self(flags)
    }

    /// Whether a stop was asked for.
    pub fn is_set(&self) -> bool {
        self.0.iter().any(|f| f.load(Ordering::Relaxed))
    }
}

impl PartialEq for CancelFlag {
    fn eq(&self, other: &Self) -> bool {
        self.0.len() == other.0.len() && self.0.iter().zip(&other.0).all(|(a, b)| Arc::ptr_eq(a, b))
    }
}

/// Settings shared by every backend (each uses what applies to it).
#[derive(Debug, Clone, PartialEq)]
pub struct SolveOptions {
    pub(crate) max_iterations: Option<usize>,
    pub(crate) dependency_tolerance: Option<f64>,
    pub(crate) warm_start: Vec<usize>,
    pub(crate) working_set_threshold: usize,
    pub(crate) generation_batch: Option<usize>,
    pub(crate) polish: bool,
    pub(crate) parallel: bool,
    pub(crate) cancel: Option<CancelFlag>,
}

impl Default for SolveOptions {
    fn default() -> Self {
        Self {
            max_iterations: None,
            dependency_tolerance: None,
            warm_start: Vec::new(),
            working_set_threshold: 3000,
            generation_batch: None,
            polish: true,
            parallel: true,
            cancel: None,
        }
    }
}

impl SolveOptions {
    /// Upper bound on active-set changes (native, summed over constraint
    /// generation passes) or iterations (others). Default:
    /// `max(1000 * cols, 10000)`; two million rows of 42 columns at a depth of
    /// 1e-7 took about 12,000.
    ///
    /// # Errors
    /// Zero is refused.
    pub fn with_max_iterations(mut self, n: usize) -> Result<Self, Error> {
        if n == 0 {
            return Err(invalid("max_iterations", "must be at least 1"));
        }
        self.max_iterations = Some(n);
        Ok(self)
    }

    /// Below this norm the projection of a new row onto the complement of the
    /// active rows counts as zero (the row is linearly dependent). Default:
    /// `64 * cols * eps`, which resolves depths far below 1e-9.
    ///
    /// # Errors
    /// Values outside `(0, 1e-3]` are refused.
    pub fn with_dependency_tolerance(mut self, tol: f64) -> Result<Self, Error> {
        if !(tol > 0.0 && tol <= 1e-3) {
            return Err(invalid("dependency_tolerance", "must lie in (0, 1e-3]"));
        }
        self.dependency_tolerance = Some(tol);
        Ok(self)
    }

    /// Rows (for example the active set of a neighbouring problem) that the
    /// native solver starts from: they seed its working set, and the dual
    /// method starts at the least-norm point of those that stay active with
    /// non-negative multipliers instead of at `x = 0`. A hint only: the
    /// optimum is the same with any rows (out-of-range ones are ignored),
    /// and a good guess saves most of the iterations. Other backends ignore
    /// it.
    pub fn with_warm_start(mut self, rows: Vec<usize>) -> Self {
        self.warm_start = rows;
        self
    }

    /// Problems with more rows than this are solved by constraint generation
    /// (native backend): a working set is solved, every row is checked, the
    /// most violated rows join, repeat. Default 3000.
    pub fn with_working_set_threshold(mut self, rows: usize) -> Self {
        self.working_set_threshold = rows;
        self
    }

    /// Rows added per constraint-generation pass. Default: `max(2 cols,
    /// 32)`, or half the working set when that is larger, so that the
    /// number of passes over every row grows like the logarithm of the
    /// final working set rather than linearly (each pass reads all of `G`).
    ///
    /// # Errors
    /// Zero is refused.
    pub fn with_generation_batch(mut self, rows: usize) -> Result<Self, Error> {
        if rows == 0 {
            return Err(invalid("generation_batch", "must be at least 1"));
        }
        self.generation_batch = Some(rows);
        Ok(self)
    }

    /// Re-solve the final active rows as equalities (least-norm solution by a
    /// fresh QR factorisation). Default on.
    pub fn with_polish(mut self, on: bool) -> Self {
        self.polish = on;
        self
    }

    /// Use rayon for passes over all rows. Default on; turn off when the
    /// caller already runs many solves in parallel.
    pub fn with_parallel(mut self, on: bool) -> Self {
        self.parallel = on;
        self
    }

    /// A flag that stops the solve once set: it returns
    /// [`Status::Cancelled`](crate::Status::Cancelled) with the point reached
    /// so far (native: within one active-set change; other backends only
    /// when set before they start).
    pub fn with_cancel(mut self, flag: CancelFlag) -> Self {
        self.cancel = Some(flag);
        self
    }

    /// Whether the cancel flag, if any, is set.
    pub(crate) fn cancelled(&self) -> bool {
        self.cancel.as_ref().is_some_and(CancelFlag::is_set)
    }

    pub(crate) fn max_iterations_for(&self, cols: usize) -> usize {
        self.max_iterations.unwrap_or((1000 * cols).max(10_000))
    }

    pub(crate) fn dependency_tolerance_for(&self, cols: usize) -> f64 {
        self.dependency_tolerance
            .unwrap_or(64.0 * cols.max(1) as f64 * f64::EPSILON)
    }

    pub(crate) fn generation_batch_for(&self, cols: usize, working_set: usize) -> usize {
        self.generation_batch
            .unwrap_or((2 * cols).max(32).max(working_set / 2))
    }
}

fn invalid(name: &'static str, reason: &str) -> Error {
    Error::InvalidOption {
        name,
        reason: reason.into(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_flag_of_several_stops_a_solve_and_equality_is_identity() {
        let (a, b) = (
            Arc::new(AtomicBool::new(false)),
            Arc::new(AtomicBool::new(false)),
        );
        let both = CancelFlag::any(vec![a.clone(), b.clone()]);
        assert!(!both.is_set() && !CancelFlag::any(Vec::new()).is_set());
        b.store(true, Ordering::Relaxed);
        assert!(both.is_set() && !CancelFlag::new(a.clone()).is_set());
        assert_eq!(both, CancelFlag::any(vec![a.clone(), b.clone()]));
        assert_ne!(both, CancelFlag::any(vec![b, a.clone()]));
        assert_ne!(CancelFlag::new(a), CancelFlag::new(Arc::default()));
    }

    #[test]
    fn invalid_values_are_refused() {
        assert!(SolveOptions::default().with_max_iterations(0).is_err());
        assert!(SolveOptions::default()
            .with_dependency_tolerance(0.0)
            .is_err());
        assert!(SolveOptions::default()
            .with_dependency_tolerance(f64::NAN)
            .is_err());
        assert!(SolveOptions::default().with_generation_batch(0).is_err());
        assert!(SolveOptions::default()
            .with_dependency_tolerance(1e-12)
            .is_ok());
    }
}
