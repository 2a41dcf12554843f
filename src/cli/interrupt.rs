//! SIGINT and SIGTERM during a run: the first sets a flag the run polls after
//! every step (it then writes what it has and exits 130); a second one ends
//! the process at once (exit 130), for a run that does not come back.

use std::sync::atomic::{AtomicBool, Ordering};

static REQUESTED: AtomicBool = AtomicBool::new(false);

/// Installs the handlers (once; later calls do nothing). Returns false where
/// they cannot be installed (the run then goes on, uninterruptible but safe).
pub fn install() -> bool {
    static INSTALLED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *INSTALLED.get_or_init(|| {
        [libc::SIGINT, libc::SIGTERM].iter().all(|&sig| {
            // SAFETY: the handler only touches an atomic and calls _exit, both
            // async-signal-safe.
            unsafe {
                signal_hook_registry::register(sig, || {
                    if REQUESTED.swap(true, Ordering::SeqCst) {
                        libc::_exit(130);
                    }
                })
            }
            .is_ok()
        })
    })
}

/// A signal has asked the run to stop.
pub fn requested() -> bool {
    REQUESTED.load(Ordering::SeqCst)
}
