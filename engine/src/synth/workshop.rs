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
//! are the ones the host has set at that sample.

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
