//! A one-line progress display on standard error, shown only on a terminal.

use rational_core::{Progress, ProgressFn};
use std::io::{IsTerminal, Write};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A progress callback for sweeps, or `None` when stderr is not a terminal.
pub fn sweep_bar() -> Option<ProgressFn> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let start = Instant::now();
    let last = Mutex::new(Instant::now());
    Some(Arc::new(move |p: Progress| {
        let mut l = last.lock().unwrap_or_else(|e| e.into_inner());
        if p.done < p.total && l.elapsed().as_millis() < 100 {
            return;
        }
        *l = Instant::now();
        let width = 30;
        let filled = width * p.done / p.total.max(1);
        eprint!(
            "\r  budget {:>3} [{}{}] {:>3}/{:<3} splits  {:>6.1} s ",
            p.budget,
            "#".repeat(filled),
            " ".repeat(width - filled),
            p.done,
            p.total,
            start.elapsed().as_secs_f64()
        );
        std::io::stderr().flush().ok();
    }))
}

/// Clears the progress line.
pub fn finish() {
    if std::io::stderr().is_terminal() {
        eprint!("\r{}\r", " ".repeat(72));
    }
}
