//! The binaries' process plumbing.
//!
//! Ctrl-C: a command that can stop cleanly (the fits) asks for the shared
//! flag: the first Ctrl-C sets it, the sweep stops within one active-set
//! change, and the command ends with status 130 writing nothing. A second
//! Ctrl-C, or the first during any other command, ends the process at once
//! (outputs are written atomically, so no truncated file is left).

use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};
use std::sync::{Arc, OnceLock};

/// The exit status of a command stopped by Ctrl-C (128 + SIGINT).
pub const EXIT_INTERRUPTED: i32 = 130;

static STOP: OnceLock<Arc<AtomicBool>> = OnceLock::new();
static COOPERATIVE: AtomicBool = AtomicBool::new(false);
static PRESSES: AtomicUsize = AtomicUsize::new(0);

fn stop() -> &'static Arc<AtomicBool> {
    STOP.get_or_init(|| Arc::new(AtomicBool::new(false)))
}

/// Installs the handler (once, at start-up). A platform without signal
/// support keeps the default behaviour.
pub fn install() {
    let result = ctrlc::set_handler(|| {
        let presses = PRESSES.fetch_add(1, Ordering::SeqCst) + 1;
        if presses == 1 && COOPERATIVE.load(Ordering::SeqCst) {
            stop().store(true, Ordering::SeqCst);
            eprintln!("\ninterrupted: stopping the fit (Ctrl-C again to quit at once)");
        } else {
            eprintln!("\ninterrupted");
            std::process::exit(EXIT_INTERRUPTED);
        }
    });
    if let Err(e) = result {
        eprintln!("warning: Ctrl-C handler not installed ({e}); Ctrl-C ends the process");
    }
}

/// The flag that the first Ctrl-C sets; asking for it tells the handler that
/// this command stops cleanly.
pub fn flag() -> Arc<AtomicBool> {
    COOPERATIVE.store(true, Ordering::SeqCst);
    stop().clone()
}

/// Whether Ctrl-C asked the command to stop.
pub fn requested() -> bool {
    stop().load(Ordering::SeqCst)
}

/// A reader that stops early (`ratfit demo | head`) closes our standard
/// output; printing then fails with a broken pipe, which is not an error of
/// ours: exit quietly instead of reporting a panic.
pub fn exit_quietly_on_broken_pipe() {
    let default = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let message = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if message.contains("Broken pipe") {
            std::process::exit(0);
        }
        default(info);
    }));
}
