//! A one-line progress display on standard error, shown only on a terminal.

use brdf::ChannelProgressFn;
use rational_core::{Progress, ProgressFn};
use std::io::{IsTerminal, Write};
use std::sync::{Arc, Mutex};
use std::time::Instant;

/// A 30-character bar, `done` of `total` filled.
fn bar(done: usize, total: usize) -> String {
    let filled = (30 * done / total.max(1)).min(30);
    format!("{}{}", "#".repeat(filled), " ".repeat(30 - filled))
}

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
        eprint!(
            "\r  budget {:>3} [{}] {:>3}/{:<3} splits  {:>6.1} s ",
            p.budget,
            bar(p.done, p.total),
            p.done,
            p.total,
            start.elapsed().as_secs_f64()
        );
        std::io::stderr().flush().ok();
    }))
}

/// A progress callback for the three channels of a BRDF fit, fitted in
/// parallel (one line: each channel's budget and splits), or `None` when
/// stderr is not a terminal.
pub fn channel_bar(names: [char; 3]) -> Option<ChannelProgressFn> {
    if !std::io::stderr().is_terminal() {
        return None;
    }
    let start = Instant::now();
    let state = Mutex::new((Instant::now(), [None::<Progress>; 3]));
    Some(Arc::new(move |channel: usize, p: Progress| {
        let mut s = state.lock().unwrap_or_else(|e| e.into_inner());
        s.1[channel.min(2)] = Some(p);
        if s.0.elapsed().as_millis() < 100 {
            return;
        }
        s.0 = Instant::now();
        let mut line = String::from("\r ");
        for (name, p) in names.iter().zip(&s.1) {
            match p {
                Some(p) => {
                    line += &format!(
                        " {name}: budget {:>3}, {:>3}/{:<3}",
                        p.budget, p.done, p.total
                    )
                }
                None => line += &format!(" {name}: starting       "),
            }
        }
        eprint!("{line}  {:>6.1} s ", start.elapsed().as_secs_f64());
        std::io::stderr().flush().ok();
    }))
}

/// A progress bar over `done` of `total` steps named `what` (terminals
/// only; cleared when done).
pub fn count_bar(what: &'static str) -> impl Fn(usize, usize) + Sync {
    let tty = std::io::stderr().is_terminal();
    let start = Instant::now();
    move |done: usize, total: usize| {
        if !tty {
            return;
        }
        eprint!(
            "\r  {what} [{}] {done:>4}/{total:<4} {:>7.1} s ",
            bar(done, total),
            start.elapsed().as_secs_f64()
        );
        std::io::stderr().flush().ok();
        if done == total {
            finish();
        }
    }
}

/// Clears the progress line.
pub fn finish() {
    if std::io::stderr().is_terminal() {
        eprint!("\r{}\r", " ".repeat(100));
    }
}
