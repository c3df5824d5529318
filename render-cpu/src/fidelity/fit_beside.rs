//! A target search's fit made beside the validation of the fit before it
//! ([`super::target_search::search_tolerances`]): cancelled by a flag, and
//! opening a gate for the validation once its functions have started.

use std::sync::atomic::{AtomicBool, AtomicU32, Ordering};
use std::sync::{Arc, Condvar, Mutex};

/// `settings` for a fit made beside a validation: cancelled by `stop`,
/// and telling `gate` when each function's fit has started.
pub(super) fn ahead_settings(
    settings: &brdf::BrdfFitSettings,
    stop: &Arc<AtomicBool>,
    gate: &Arc<ChannelGate>,
) -> brdf::BrdfFitSettings {
    let prior = settings.channel_progress();
    let gate = gate.clone();
    settings
        .clone()
        .with_fit_settings(settings.fit_settings().clone().with_cancel(stop.clone()))
        .with_channel_progress(Arc::new(move |c, p| {
            gate.started(c);
            if let Some(prior) = &prior {
                prior(c, p);
            }
        }))
}

/// Opens once each of a fit's functions has started (its first progress
/// report), or the fit has ended. With fewer cores than functions the last
/// starts as another ends: the validation waits for the fit's functions to
/// begin ending.
pub(super) struct ChannelGate {
    started: AtomicU32,
    needed: u32,
    open: Mutex<bool>,
    opened: Condvar,
}

impl ChannelGate {
    pub(super) fn new(functions: usize) -> Self {
        Self {
            started: AtomicU32::new(0),
            // One bit per function (a colour mode has three).
            needed: functions.clamp(1, 32) as u32,
            open: Mutex::new(false),
            opened: Condvar::new(),
        }
    }

    fn started(&self, function: usize) {
        let bit = 1u32 << function.min(31);
        let before = self.started.fetch_or(bit, Ordering::Relaxed);
        if before & bit == 0 && (before | bit).count_ones() >= self.needed {
            self.open();
        }
    }

    fn open(&self) {
        *self.open.lock().unwrap_or_else(|e| e.into_inner()) = true;
        self.opened.notify_all();
    }

    #[cfg(test)]
    fn is_open(&self) -> bool {
        *self.open.lock().unwrap_or_else(|e| e.into_inner())
    }

    pub(super) fn wait(&self) {
        let mut open = self.open.lock().unwrap_or_else(|e| e.into_inner());
        while !*open {
            open = self.opened.wait(open).unwrap_or_else(|e| e.into_inner());
        }
    }

    /// Opens the gate when dropped: at the fit's end, however it ends.
    pub(super) fn opened_when_dropped(&self) -> impl Drop + '_ {
        struct Opener<'a>(&'a ChannelGate);
        impl Drop for Opener<'_> {
            fn drop(&mut self) {
                self.0.open();
            }
        }
        Opener(self)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_gate_opens_once_every_function_has_started_or_the_fit_ends() {
        let gate = ChannelGate::new(3);
        // Each function reports progress many times; each counts once.
        for f in [0, 0, 2, 2] {
            gate.started(f);
        }
        assert!(!gate.is_open());
        gate.started(1);
        assert!(gate.is_open());
        gate.wait();
        // A fit that ends (or fails) before its functions report opens it.
        let gate = ChannelGate::new(3);
        {
            let _fit = gate.opened_when_dropped();
            gate.started(0);
            assert!(!gate.is_open());
        }
        assert!(gate.is_open());
        gate.wait();
    }
}
