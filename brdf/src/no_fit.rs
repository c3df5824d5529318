//! Proofs that a function's intervals have no fit, kept between the fits
//! of one search ([`crate::BrdfFitSettings::with_no_fit_memo`]).

use rational_core::{FitError, FitReport, FitSettings, IntervalData, NoFitProof};
use std::sync::{Arc, Mutex, MutexGuard};

/// Most proofs a memo keeps (the oldest go first): a search tries a handful
/// of tolerances, each proof a copy of one function's data.
const MAX_PROOFS: usize = 16;

/// Proofs of no fit ([`NoFitProof`]) shared by the fits of one search, for
/// any of their functions: a fit skips the widening levels they cover and
/// adds what its own sweep proves. A search that tightens its tolerance
/// then solves nothing it has already refused; a looser tolerance is
/// seldom covered (widening is symmetric on a log scale, a tolerance on a
/// linear one). Clones share the proofs.
#[derive(Debug, Clone, Default)]
pub struct NoFitMemo(Arc<Mutex<Vec<NoFitProof>>>);

impl NoFitMemo {
    /// An empty memo.
    pub fn new() -> Self {
        Self::default()
    }

    /// The proofs held.
    pub fn len(&self) -> usize {
        self.lock().len()
    }

    /// Whether no proof is held.
    pub fn is_empty(&self) -> bool {
        self.lock().is_empty()
    }

    /// A copy of the proofs, for one sweep.
    pub(crate) fn proofs(&self) -> Vec<NoFitProof> {
        self.lock().clone()
    }

    /// Keeps the proof a sweep of `data` with `settings` gave, unless one
    /// held already covers it.
    pub(crate) fn record(
        &self,
        data: &IntervalData,
        settings: &FitSettings,
        result: &Result<FitReport, FitError>,
    ) {
        let Some(proof) = NoFitProof::from_sweep(data, settings, result) else {
            return;
        };
        let mut proofs = self.lock();
        if proofs.iter().any(|p| p.covers_proof(&proof)) {
            return;
        }
        if proofs.len() == MAX_PROOFS {
            proofs.remove(0);
        }
        proofs.push(proof);
    }

    /// The proofs, whatever a panicking holder left (each is whole).
    fn lock(&self) -> MutexGuard<'_, Vec<NoFitProof>> {
        self.0.lock().unwrap_or_else(|e| e.into_inner())
    }
}
