//! Rebuilding instruments off the audio thread.
//!
//! A [`Workshop`] thread watches the settings (through a function the host
//! supplies, typically reading its parameters' atomics), builds a new
//! [`Instrument`] when they have changed and stayed put for a moment, and sends
//! it to the audio thread over an `rtrb` queue. The audio thread's [`Delivery`]
//! installs it and sends the replaced instrument back the same way, so that it
//! is dropped here and never on the audio thread.
//!
//! Rendering offline, a host does not wait for the clock: a change of the
//! settings must be heard from the sample it comes at, and every bounce alike.
//! There the audio thread asks the workshop to catch up at once
//! ([`Delivery::catch_up`]) and waits for the answer: the settings read then
//! are the ones the host has set at that sample. A setting that moves on
//! (a ramp, an LFO) is built again about once every [`REBUILD_SPACING_S`]
//! of audio ([`OfflineBuilds`]), at its value then; between builds the synth
//! takes what it can of a voicing live ([`Synth::set_voicing`]).

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::thread::{JoinHandle, Thread};
use std::time::{Duration, Instant};

use rtrb::{Consumer, Producer, RingBuffer};

use super::{Instrument, InstrumentSettings, Synth};

/// How often the workshop looks at the settings.
const POLL: Duration = Duration::from_millis(10);

/// What the audio thread and the workshop say to each other besides the
/// instruments: requests to catch up, and answers.
#[derive(Default)]
struct Talk {
    asked: AtomicU64,
    answered: AtomicU64,
}

/// How long an offline render waits for the workshop before it plays on with
/// what it has.
const CATCH_UP_AT_MOST: Duration = Duration::from_secs(60);

/// Offline, a change that needs new tables is built at once; one that moves
/// on (a ramp, an LFO) is built about once every this much audio, s. The
/// piano builds in about a second on two cores at 48 kHz, the other
/// instruments in 0.1-0.5 s: an automated parameter keeps the bounce ahead
/// of real time.
pub const REBUILD_SPACING_S: f64 = 2.0;

/// Builds the automation may ask for in a row before the spacing holds it
/// back (a few changes close together, e.g. an instrument and its preset,
/// each land at their sample).
const REBUILDS_IN_A_ROW: u64 = 2;

/// Offline, when the settings the automation moves are to be built
/// ([`Delivery::catch_up`]): a change at its sample, while builds are not
/// coming faster than one every [`REBUILD_SPACING_S`] of audio on average
/// (a few in a row allowed), and then at the next turn, at the value of
/// then. Counted in samples, so every bounce is built alike. `K` is what the
/// tables are built from.
#[derive(Clone, Debug)]
pub struct OfflineBuilds<K> {
    built: Option<K>,
    /// Samples of audio the next builds may take, one spacing a build (at
    /// most [`REBUILDS_IN_A_ROW`] spacings).
    credit: u64,
    spacing: u64,
}

impl<K: PartialEq> OfflineBuilds<K> {
    pub fn new(sample_rate_hz: f64) -> Self {
        let spacing = ((REBUILD_SPACING_S * sample_rate_hz.max(0.0)).round() as u64).max(1);
        Self { built: None, credit: REBUILDS_IN_A_ROW * spacing, spacing }
    }

    /// The instrument playing is built from something else now (a new
    /// activation): the next block builds what is asked.
    pub fn forget(&mut self) {
        self.built = None;
    }

    /// Whether a block of `samples` asking for `wanted` is to have it built
    /// first (then it is taken as built). Real-time safe for a `K` that is.
    pub fn due(&mut self, wanted: K, samples: usize) -> bool {
        let due = match &self.built {
            // (What an activation built: nothing to wait for.)
            None => true,
            Some(built) if *built != wanted && self.credit >= self.spacing => {
                self.credit -= self.spacing;
                true
            }
            Some(_) => false,
        };
        if due {
            self.built = Some(wanted);
        }
        self.credit = (self.credit + samples as u64).min(REBUILDS_IN_A_ROW * self.spacing);
        due
    }
}

/// The audio thread's end: new instruments in, replaced ones out.
pub struct Delivery {
    incoming: Consumer<Box<Instrument>>,
    outgoing: Producer<Box<Instrument>>,
    talk: Arc<Talk>,
    workshop: Option<Thread>,
}

impl Delivery {
    /// Offline only (it waits): have the workshop build what the settings say
    /// now, at once, and install it. Returns whether the workshop answered
    /// (false: no workshop thread, or none within a minute). Allocates: no;
    /// blocks until the instrument is built.
    pub fn catch_up(&mut self, synth: &mut Synth) -> bool {
        // Room for what comes, and nothing older installed after it.
        self.exchange(synth);
        let Some(workshop) = self.workshop.as_ref() else { return false };
        let asked = self.talk.asked.fetch_add(1, Ordering::SeqCst) + 1;
        workshop.unpark();
        let start = Instant::now();
        while self.talk.answered.load(Ordering::SeqCst) < asked {
            if start.elapsed() > CATCH_UP_AT_MOST {
                return false;
            }
            std::thread::park_timeout(Duration::from_micros(200));
        }
        self.exchange(synth);
        true
    }

    /// Install whatever has arrived and hand back what was replaced. Real-time safe.
    pub fn exchange(&mut self, synth: &mut Synth) {
        while let Ok(instrument) = self.incoming.pop() {
            synth.install(instrument);
        }
        while let Some(old) = synth.take_retired() {
            if let Err(rtrb::PushError::Full(old)) = self.outgoing.push(old) {
                synth.keep_retired(old);
                break;
            }
        }
    }
}

/// The builder thread. Dropping it stops the thread.
pub struct Workshop {
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
}

impl Workshop {
    /// Start watching `settings` (None: nothing to build now, e.g. not activated).
    /// `built` is what the synth plays already.
    pub fn spawn(
        built: InstrumentSettings,
        settings: impl Fn() -> Option<InstrumentSettings> + Send + 'static,
    ) -> (Self, Delivery) {
        Self::spawn_telling(built, settings, Arc::new(AtomicBool::new(false)))
    }

    /// [`Self::spawn`], holding `building` true while it builds (for a panel
    /// to say so).
    pub fn spawn_telling(
        built: InstrumentSettings,
        settings: impl Fn() -> Option<InstrumentSettings> + Send + 'static,
        building: Arc<AtomicBool>,
    ) -> (Self, Delivery) {
        let (mut to_audio, incoming) = RingBuffer::new(2);
        let (outgoing, mut from_audio) = RingBuffer::<Box<Instrument>>::new(16);
        let stop = Arc::new(AtomicBool::new(false));
        let talk = Arc::new(Talk::default());
        let (stopping, told) = (stop.clone(), talk.clone());
        let thread = std::thread::Builder::new()
            .name("struck-workshop".into())
            .spawn(move || {
                let mut last = built;
                let mut seen: Option<InstrumentSettings> = None;
                while !stopping.load(Ordering::Relaxed) {
                    // A request to catch up wakes it early.
                    std::thread::park_timeout(POLL);
                    while let Ok(old) = from_audio.pop() {
                        drop(old);
                    }
                    let asked = told.asked.load(Ordering::SeqCst);
                    let urgent = asked > told.answered.load(Ordering::SeqCst);
                    if let Some(wanted) = settings() {
                        // Build once the settings have held still for one poll (a
                        // knob being dragged), or at once when asked to catch up.
                        let steady = seen.as_ref() == Some(&wanted);
                        seen = Some(wanted.clone());
                        if wanted != last && (steady || urgent) && !to_audio.is_full() {
                            building.store(true, Ordering::Relaxed);
                            match Instrument::build(&wanted) {
                                Ok(instrument) => {
                                    let _ = to_audio.push(Box::new(instrument));
                                }
                                Err(e) => eprintln!("struck: cannot build the instrument: {e}"),
                            }
                            building.store(false, Ordering::Relaxed);
                            last = wanted;
                        }
                    }
                    if urgent {
                        told.answered.store(asked, Ordering::SeqCst);
                    }
                }
            })
            // Without the thread the instrument first built keeps playing; changes
            // that need new tables are not heard.
            .map_err(|e| eprintln!("struck: cannot start the thread that rebuilds the instrument: {e}"))
            .ok();
        let workshop = thread.as_ref().map(|t| t.thread().clone());
        (Self { stop, thread }, Delivery { incoming, outgoing, talk, workshop })
    }
}

impl Drop for Workshop {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            thread.thread().unpark();
            let _ = thread.join();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn changes_are_built_at_once_and_a_moving_one_once_a_spacing() {
        let fs = 1000.0;
        let mut builds = OfflineBuilds::new(fs);
        let spacing = (REBUILD_SPACING_S * fs) as usize;
        assert!(builds.due(1, 10), "the first block builds");
        assert!(!builds.due(1, 10), "nothing changed");
        // Two changes close together each land at their block.
        assert!(builds.due(2, 10) && builds.due(3, 10));
        // Long after: a change is built at its block.
        for _ in 0..2 * spacing {
            builds.due(3, 1);
        }
        assert!(builds.due(4, 1), "a change after a quiet while lands at once");
        // A ramp, a new value every sample, over ten spacings: about a build a
        // spacing (the first few in a row).
        let ramp = 10 * spacing;
        let built: Vec<usize> = (5..5 + ramp).filter(|&v| builds.due(v, 1)).collect();
        assert!((10..=12).contains(&built.len()), "{} builds", built.len());
        assert!(built.windows(2).skip(2).all(|w| w[1] - w[0] == spacing), "{built:?}");
        // The ramp's end is built once its turn comes, and then rests.
        let end = 5 + ramp;
        let later: Vec<usize> = (0..3 * spacing).filter(|_| builds.due(end, 1)).collect();
        assert_eq!(later.len(), 1, "the last value is built once");
        builds.forget();
        assert!(builds.due(end, 1), "after forget the next block builds");
    }
}
