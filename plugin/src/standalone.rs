//! What the plugin needs to know when it runs inside the `struck` program's
//! standalone host rather than a DAW (the host itself is started by the binary,
//! `src/bin/struck/live.rs`): whether it is the standalone, whether a window can
//! open, and whether a stop signal has come (the editor then closes its window).
//!
//! A signal stops the program cleanly with or without a window: nice-plug's
//! handler (extended to SIGTERM and SIGHUP through `ctrlc`'s `termination`
//! feature) ends a headless run, and [`watch_stop_signals`] chains onto it so
//! that [`stop_requested`] turns true.

use std::sync::Once;
use std::sync::atomic::{AtomicBool, AtomicUsize, Ordering};

static STANDALONE: AtomicBool = AtomicBool::new(false);
static STOP: AtomicBool = AtomicBool::new(false);

/// Called by the `struck` program before it starts the standalone host.
pub fn mark_standalone() {
    STANDALONE.store(true, Ordering::Relaxed);
}

/// True inside the `struck` program's standalone (never inside a host).
pub fn is_standalone() -> bool {
    STANDALONE.load(Ordering::Relaxed)
}

/// Whether a window can be opened (baseview on Linux speaks X11).
pub fn display_available() -> bool {
    std::env::var_os("DISPLAY").is_some_and(|d| !d.is_empty())
}

/// A stop signal arrived (the standalone's editor then closes its window).
pub fn stop_requested() -> bool {
    STOP.load(Ordering::Relaxed)
}

/// The previous handlers of the stop signals, as addresses (0: none to call).
static PREVIOUS: [AtomicUsize; 3] = [AtomicUsize::new(0), AtomicUsize::new(0), AtomicUsize::new(0)];
const STOP_SIGNALS: [libc::c_int; 3] = [libc::SIGINT, libc::SIGTERM, libc::SIGHUP];

extern "C" fn on_stop_signal(signal: libc::c_int) {
    STOP.store(true, Ordering::Relaxed);
    if let Some(i) = STOP_SIGNALS.iter().position(|&s| s == signal) {
        let previous = PREVIOUS[i].load(Ordering::Relaxed);
        if previous != 0 {
            // SAFETY: the address was read from a handler installed without SA_SIGINFO,
            // i.e. a `void (*)(int)`; calling it is what the kernel would have done.
            let previous: extern "C" fn(libc::c_int) = unsafe { std::mem::transmute(previous) };
            previous(signal);
        }
    }
}

/// Make SIGINT, SIGTERM and SIGHUP also set [`stop_requested`], keeping the handlers
/// already installed (nice-plug's). Only for the standalone; once.
pub fn watch_stop_signals() {
    static ONCE: Once = Once::new();
    if !is_standalone() {
        return;
    }
    ONCE.call_once(|| {
        for (i, &signal) in STOP_SIGNALS.iter().enumerate() {
            // SAFETY: plain sigaction calls with valid pointers; the new handler only stores
            // an atomic and calls the previous handler, both async-signal-safe.
            unsafe {
                let mut old: libc::sigaction = std::mem::zeroed();
                if libc::sigaction(signal, std::ptr::null(), &mut old) != 0 || old.sa_flags & libc::SA_SIGINFO != 0 {
                    continue;
                }
                if old.sa_sigaction == libc::SIG_IGN {
                    continue;
                }
                if old.sa_sigaction != libc::SIG_DFL {
                    PREVIOUS[i].store(old.sa_sigaction, Ordering::Relaxed);
                }
                let mut new: libc::sigaction = std::mem::zeroed();
                new.sa_sigaction = on_stop_signal as extern "C" fn(libc::c_int) as usize;
                new.sa_flags = libc::SA_RESTART;
                libc::sigemptyset(&mut new.sa_mask);
                libc::sigaction(signal, &new, std::ptr::null_mut());
            }
        }
    });
}
