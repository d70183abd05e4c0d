//! What the plugin needs to know when it runs inside the `struck` program's
//! standalone host rather than a DAW (the host itself is started by the binary,
//! `src/bin/struck/live.rs`): whether it is the standalone, whether a window can
//! open, and whether a stop signal has come (the editor then closes its window).
//! Also what the standalone is told at start by its environment (load smoothing)
//! and, when asked, how long each audio callback takes against its period.
//!
//! A signal stops the program cleanly with or without a window: nice-plug's
//! handler (extended to SIGTERM and SIGHUP through `ctrlc`'s `termination`
//! feature) ends a headless run, and [`watch_stop_signals`] chains onto it so
//! that [`stop_requested`] turns true.

use std::path::{Path, PathBuf};
use std::sync::Once;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};

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

// ------------------------------------------------------------------ load smoothing at start

/// The environment variable that sets load smoothing when the standalone starts
/// (`on` or `off`; unset: the parameter's own default, on). nice-plug's standalone
/// restores no saved state, so without it a live run could only change the setting
/// from the panel.
pub const SMOOTHING_VAR: &str = "STRUCK_LOAD_SMOOTHING";

/// What [`SMOOTHING_VAR`] asks for: None when it is unset, an error naming the
/// variable and the reason when its value is neither `on` nor `off`.
pub fn smoothing_from_env() -> Result<Option<bool>, String> {
    let Some(value) = std::env::var_os(SMOOTHING_VAR) else { return Ok(None) };
    match value.to_str() {
        Some("on") => Ok(Some(true)),
        Some("off") => Ok(Some(false)),
        _ => Err(format!("{SMOOTHING_VAR}={}: must be on or off", value.to_string_lossy())),
    }
}

/// Load smoothing's value as the plugin is built: `default` in a host, what
/// [`SMOOTHING_VAR`] asks for in the standalone (checked before it starts).
pub fn smoothing_at_start(default: bool) -> bool {
    if is_standalone() { smoothing_from_env().ok().flatten().unwrap_or(default) } else { default }
}

// ------------------------------------------------------------------ callback timing

/// The environment variable naming a file where the standalone writes how long its
/// audio callbacks took (rewritten twice a second while it plays, and at the end).
pub const CALLBACK_STATS_VAR: &str = "STRUCK_CALLBACK_STATS";

/// Timing is on (set once, before the audio starts, by [`report_callbacks_to`]).
static TIMING: AtomicBool = AtomicBool::new(false);
/// How many of the worst callbacks are kept, with when they came.
const KEPT: usize = 8;
/// Shares of the period are counted in millionths; the histogram in bins of 5 %
/// up to 100 %, and one bin above.
const PPM: f64 = 1e6;
const BINS: usize = 21;

/// What the callbacks measured. One audio thread writes (the JACK or ALSA
/// callback calls the plugin's process from one thread); a reporting thread
/// reads. Relaxed atomics: each figure is a plain counter or maximum, and a
/// report read while a callback writes may mix two callbacks' figures, which the
/// final report (written once the audio has stopped) cannot.
struct CallbackStats {
    callbacks: AtomicU64,
    /// Sum of the shares, millionths (for the mean).
    share_sum: AtomicU64,
    over_half: AtomicU64,
    over_period: AtomicU64,
    worst_cpu_share: AtomicU64,
    period_ns: AtomicU64,
    histogram: [AtomicU64; BINS],
    /// The worst callbacks, worst first: share (millionths), callback number,
    /// CLOCK_MONOTONIC at its start (ns), its own thread's CPU time share (millionths).
    worst: [[AtomicU64; 4]; KEPT],
}

static STATS: CallbackStats = CallbackStats {
    callbacks: AtomicU64::new(0),
    share_sum: AtomicU64::new(0),
    over_half: AtomicU64::new(0),
    over_period: AtomicU64::new(0),
    worst_cpu_share: AtomicU64::new(0),
    period_ns: AtomicU64::new(0),
    histogram: [const { AtomicU64::new(0) }; BINS],
    worst: [const { [const { AtomicU64::new(0) }; 4] }; KEPT],
};

/// The clocks read at the start of a callback; recorded when it is dropped.
pub struct CallbackTimer {
    /// Wall and CPU clocks at the start, ns.
    start: Option<(u64, u64)>,
    period_ns: u64,
}

/// CLOCK_MONOTONIC (wall) or CLOCK_THREAD_CPUTIME_ID (this thread's CPU time), ns.
/// A vDSO read and a system call that never blocks.
fn clock_ns(clock: libc::clockid_t) -> u64 {
    let mut t = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: a valid pointer to a timespec; the clocks exist on every Linux.
    if unsafe { libc::clock_gettime(clock, &mut t) } != 0 {
        return 0;
    }
    t.tv_sec as u64 * 1_000_000_000 + t.tv_nsec as u64
}

/// Start timing one audio callback of `samples` at `sample_rate_hz`; the time is
/// taken when the returned guard is dropped, at the end of the callback, so
/// everything the callback does counts. Does nothing unless the standalone was
/// asked for the figures ([`CALLBACK_STATS_VAR`]). Real-time safe: clock reads
/// and relaxed atomics.
pub fn time_callback(samples: usize, sample_rate_hz: f64) -> CallbackTimer {
    if !TIMING.load(Ordering::Relaxed) || sample_rate_hz <= 0.0 || samples == 0 {
        return CallbackTimer { start: None, period_ns: 0 };
    }
    let period_ns = (samples as f64 / sample_rate_hz * 1e9) as u64;
    let cpu = clock_ns(libc::CLOCK_THREAD_CPUTIME_ID);
    let wall = clock_ns(libc::CLOCK_MONOTONIC);
    CallbackTimer { start: Some((wall, cpu)), period_ns }
}

impl Drop for CallbackTimer {
    fn drop(&mut self) {
        let Some((wall_start, cpu_start)) = self.start else { return };
        let elapsed = clock_ns(libc::CLOCK_MONOTONIC).saturating_sub(wall_start) as f64;
        let cpu = clock_ns(libc::CLOCK_THREAD_CPUTIME_ID).saturating_sub(cpu_start) as f64;
        record(elapsed, cpu, self.period_ns, wall_start);
    }
}

fn record(elapsed_ns: f64, cpu_ns: f64, period_ns: u64, wall_start_ns: u64) {
    let s = &STATS;
    let period = period_ns.max(1) as f64;
    let share = (elapsed_ns / period * PPM) as u64;
    let cpu_share = (cpu_ns / period * PPM) as u64;
    let n = s.callbacks.fetch_add(1, Ordering::Relaxed);
    s.period_ns.store(period_ns, Ordering::Relaxed);
    s.share_sum.fetch_add(share, Ordering::Relaxed);
    if share >= PPM as u64 / 2 {
        s.over_half.fetch_add(1, Ordering::Relaxed);
    }
    if share >= PPM as u64 {
        s.over_period.fetch_add(1, Ordering::Relaxed);
    }
    s.worst_cpu_share.fetch_max(cpu_share, Ordering::Relaxed);
    let bin = ((share * 20) / PPM as u64).min(BINS as u64 - 1) as usize;
    s.histogram[bin].fetch_add(1, Ordering::Relaxed);
    // Keep the worst few, worst first (one writer: shifting down is safe).
    if share <= s.worst[KEPT - 1][0].load(Ordering::Relaxed) {
        return;
    }
    let mut at = KEPT - 1;
    while at > 0 && share > s.worst[at - 1][0].load(Ordering::Relaxed) {
        for k in 0..4 {
            s.worst[at][k].store(s.worst[at - 1][k].load(Ordering::Relaxed), Ordering::Relaxed);
        }
        at -= 1;
    }
    for (slot, value) in s.worst[at].iter().zip([share, n, wall_start_ns, cpu_share]) {
        slot.store(value, Ordering::Relaxed);
    }
}

/// The figures so far, as `key value` lines (shares as fractions of the period;
/// times in CLOCK_MONOTONIC seconds, Python's `time.monotonic()`).
pub fn callback_report() -> String {
    let s = &STATS;
    let load = |a: &AtomicU64| a.load(Ordering::Relaxed);
    let callbacks = load(&s.callbacks);
    let mut out = String::new();
    let mut line = |key: &str, value: String| out.push_str(&format!("{key} {value}\n"));
    line("callbacks", callbacks.to_string());
    line("period_s", format!("{:.9}", load(&s.period_ns) as f64 / 1e9));
    line("mean_share", format!("{:.6}", load(&s.share_sum) as f64 / PPM / callbacks.max(1) as f64));
    line("worst_share", format!("{:.6}", load(&s.worst[0][0]) as f64 / PPM));
    line("worst_cpu_share", format!("{:.6}", load(&s.worst_cpu_share) as f64 / PPM));
    line("over_half", load(&s.over_half).to_string());
    line("over_period", load(&s.over_period).to_string());
    let bins: Vec<String> = s.histogram.iter().map(|b| load(b).to_string()).collect();
    line("histogram_5pct", bins.join(" "));
    for w in s.worst.iter().filter(|w| load(&w[0]) > 0) {
        line(
            "worst",
            format!(
                "share {:.6} callback {} at_s {:.6} cpu_share {:.6}",
                load(&w[0]) as f64 / PPM,
                load(&w[1]),
                load(&w[2]) as f64 / 1e9,
                load(&w[3]) as f64 / PPM
            ),
        );
    }
    out
}

/// Write [`callback_report`] to `path` (through a temporary file, so a reader
/// never sees half of it).
pub fn write_callback_report(path: &Path) -> std::io::Result<()> {
    // (Each write has a temporary file of its own: the final report and the thread's may overlap.)
    static WRITES: AtomicU64 = AtomicU64::new(0);
    let mut tmp = path.as_os_str().to_owned();
    tmp.push(format!(".{}.part", WRITES.fetch_add(1, Ordering::Relaxed)));
    std::fs::write(&tmp, callback_report())?;
    std::fs::rename(&tmp, path)
}

/// Turn the callback timing on and write the figures to `path` twice a second
/// from a thread of its own (the audio thread only updates atomics). Checks
/// first that the file can be written. Call before the audio starts.
pub fn report_callbacks_to(path: PathBuf) -> Result<(), String> {
    write_callback_report(&path)
        .map_err(|e| format!("{CALLBACK_STATS_VAR}={}: cannot write it: {e}", path.display()))?;
    TIMING.store(true, Ordering::Relaxed);
    std::thread::Builder::new()
        .name("struck-callback-stats".into())
        .spawn(move || {
            loop {
                std::thread::sleep(std::time::Duration::from_millis(500));
                // (A failure here is seen by the reader as a stale file.)
                let _ = write_callback_report(&path);
            }
        })
        .map(|_| ())
        .map_err(|e| format!("cannot start the callback report's thread: {e}"))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn figure(report: &str, key: &str) -> f64 {
        report.lines().find_map(|l| l.strip_prefix(key)?.strip_prefix(' ')?.parse().ok()).unwrap()
    }

    #[test]
    fn the_report_keeps_the_worst_callbacks_in_order_and_counts_the_late_ones() {
        // (The only test that records: the figures are the process's.)
        let period = 1_333_333;
        for (i, elapsed) in [100_000.0, 900_000.0, 300_000.0, 1_500_000.0, 200_000.0].into_iter().enumerate() {
            record(elapsed, elapsed / 2.0, period, 1_000_000_000 * (i as u64 + 1));
        }
        let report = callback_report();
        assert_eq!(figure(&report, "callbacks"), 5.0);
        assert!((figure(&report, "worst_share") - 1.125).abs() < 1e-3, "{report}");
        assert!((figure(&report, "worst_cpu_share") - 0.5625).abs() < 1e-3, "{report}");
        assert_eq!((figure(&report, "over_half"), figure(&report, "over_period")), (2.0, 1.0));
        let worst: Vec<&str> = report.lines().filter(|l| l.starts_with("worst ")).collect();
        assert_eq!(worst.len(), 5);
        assert!(worst[0].contains("callback 3 at_s 4.000000"), "{report}");
        assert!(worst[1].contains("callback 1 at_s 2.000000"), "{report}");
        assert!(worst[4].contains("callback 0 "), "{report}");
        let bins: Vec<u64> = report
            .lines()
            .find_map(|l| l.strip_prefix("histogram_5pct "))
            .unwrap()
            .split(' ')
            .map(|n| n.parse().unwrap())
            .collect();
        assert_eq!((bins.len(), bins.iter().sum::<u64>(), bins[BINS - 1]), (BINS, 5, 1));
    }

    #[test]
    fn a_timer_does_nothing_unless_asked_for() {
        assert!(time_callback(64, 48_000.0).start.is_none());
        assert!(!is_standalone());
        assert!(smoothing_at_start(true) && !smoothing_at_start(false));
    }
}
