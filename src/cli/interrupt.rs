//! SIGINT and SIGTERM during a run: the first sets a flag the run polls after
//! every step and the simulator before every sub-step (the run then writes
//! what it has and exits 130); a second one ends the process at once (exit
//! 130), for a run that does not come back.

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, LazyLock};

static REQUESTED: LazyLock<Arc<AtomicBool>> = LazyLock::new(|| Arc::new(AtomicBool::new(false)));

/// Installs the handlers (once; later calls do nothing). Returns false where
/// they cannot be installed (the run then goes on, uninterruptible but safe).
pub fn install() -> bool {
    static INSTALLED: std::sync::OnceLock<bool> = std::sync::OnceLock::new();
    *INSTALLED.get_or_init(|| {
        let requested = flag();
        [libc::SIGINT, libc::SIGTERM].iter().all(|&sig| {
            let requested = requested.clone();
            // SAFETY: the handler only touches an atomic and calls _exit, both
            // async-signal-safe.
            unsafe {
                signal_hook_registry::register(sig, move || {
                    if requested.swap(true, Ordering::SeqCst) {
                        libc::_exit(130);
                    }
                })
            }
            .is_ok()
        })
    })
}

/// The flag a signal raises (for `Simulator::set_step_limits`).
pub fn flag() -> Arc<AtomicBool> {
    REQUESTED.clone()
}
