//! The last few instruments built, kept as built, by their settings: the same
//! settings asked for again get a copy instead of a second build. A host
//! activating a plugin again (at each sample rate it tries, or on every
//! transport start), a session reopened, a preset chosen again each ask for
//! an instrument that was built a moment ago; building one voices every key
//! through the body, up to seconds, where a copy takes milliseconds.
//!
//! Touched only where instruments are built (a builder thread, a CLI), never
//! by the audio thread: the lock is held for a lookup or an insertion.

use std::sync::{Mutex, MutexGuard, OnceLock};

use super::{Instrument, InstrumentSettings};

/// How many instruments are kept (the least recently used goes first): a
/// piano is tens of megabytes of tables, and a host trying the sample rates
/// (44.1, 48, 96 and 192 kHz) asks for four.
pub const KEPT: usize = 4;

/// The instruments kept, most recently used last, each under its settings'
/// [`key`].
type Kept = Vec<(String, Instrument)>;

fn kept() -> MutexGuard<'static, Kept> {
    static KEPT_BUILT: OnceLock<Mutex<Kept>> = OnceLock::new();
    // A thread that panicked while holding the lock left the list whole (it
    // is only ever pushed to, removed from or cleared): carry on with it.
    KEPT_BUILT.get_or_init(|| Mutex::new(Vec::with_capacity(KEPT + 1))).lock().unwrap_or_else(|e| e.into_inner())
}

/// The settings as a key: every field, numbers by their exact value (the
/// shortest decimal that reads back to the same bits, which tells -0 from 0
/// and keeps a NaN apart from every other), so that two settings share a key
/// only if they build the same instrument.
fn key(settings: &InstrumentSettings) -> String {
    format!("{settings:?}")
}

/// A copy of the instrument kept for `settings`, if there is one (it becomes
/// the most recently used).
pub(super) fn find(settings: &InstrumentSettings) -> Option<Instrument> {
    let key = key(settings);
    let mut kept = kept();
    let at = kept.iter().position(|(k, _)| *k == key)?;
    let entry = kept.remove(at);
    let copy = entry.1.clone();
    kept.push(entry);
    Some(copy)
}

/// Keep a copy of `instrument`, as just built for `settings`, dropping the
/// least recently used beyond [`KEPT`].
pub(super) fn keep(settings: &InstrumentSettings, instrument: &Instrument) {
    let key = key(settings);
    let copy = instrument.clone();
    let dropped: Vec<(String, Instrument)> = {
        let mut kept = kept();
        kept.retain(|(k, _)| *k != key);
        kept.push((key, copy));
        let over = kept.len().saturating_sub(KEPT);
        kept.drain(..over).collect()
    };
    // Freed outside the lock.
    drop(dropped);
}

/// How many instruments are kept now.
pub fn kept_count() -> usize {
    kept().len()
}

/// Forget every instrument kept, every voicing found in this run and every
/// board's admittance: the next build of any settings is as a program's
/// first, with only the voicings that came with it to go on (for measuring a
/// first build).
pub fn forget() {
    let dropped = std::mem::take(&mut *kept());
    drop(dropped);
    super::voicings::forget();
    crate::body::load::forget_boards();
}
