//! Rebuilding instruments off the audio thread.
//!
//! A [`Workshop`] thread watches the settings (through a function the host
//! supplies, typically reading its parameters' atomics), builds a new
//! [`Instrument`] when they have changed and stayed put for a moment, and sends
//! it to the audio thread over an `rtrb` queue. The audio thread's [`Delivery`]
//! installs it and sends the replaced instrument back the same way, so that it
//! is dropped here and never on the audio thread.

use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::thread::JoinHandle;
use std::time::Duration;

use rtrb::{Consumer, Producer, RingBuffer};

use super::{Instrument, InstrumentSettings, Synth};

/// How often the workshop looks at the settings.
const POLL: Duration = Duration::from_millis(10);

/// The audio thread's end: new instruments in, replaced ones out.
pub struct Delivery {
    incoming: Consumer<Box<Instrument>>,
    outgoing: Producer<Box<Instrument>>,
}

impl Delivery {
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
        let (mut to_audio, incoming) = RingBuffer::new(2);
        let (outgoing, mut from_audio) = RingBuffer::<Box<Instrument>>::new(16);
        let stop = Arc::new(AtomicBool::new(false));
        let stopping = stop.clone();
        let thread = std::thread::Builder::new()
            .name("struck-workshop".into())
            .spawn(move || {
                let mut last = built;
                let mut seen: Option<InstrumentSettings> = None;
                while !stopping.load(Ordering::Relaxed) {
                    std::thread::sleep(POLL);
                    while let Ok(old) = from_audio.pop() {
                        drop(old);
                    }
                    let Some(wanted) = settings() else { continue };
                    // Build once the settings have held still for one poll (a knob being dragged).
                    let steady = seen.as_ref() == Some(&wanted);
                    seen = Some(wanted.clone());
                    if wanted == last || !steady || to_audio.is_full() {
                        continue;
                    }
                    match Instrument::build(&wanted) {
                        Ok(instrument) => {
                            let _ = to_audio.push(Box::new(instrument));
                        }
                        Err(e) => eprintln!("struck: cannot build the instrument: {e}"),
                    }
                    last = wanted;
                }
            })
            // Without the thread the instrument first built keeps playing; changes
            // that need new tables are not heard.
            .map_err(|e| eprintln!("struck: cannot start the thread that rebuilds the instrument: {e}"))
            .ok();
        (Self { stop, thread }, Delivery { incoming, outgoing })
    }
}

impl Drop for Workshop {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            let _ = thread.join();
        }
    }
}
