//! What the panel's keyboard and the audio thread share, in atomics only: the
//! keys the panel plays, the keys and pedals the performer last saw down (the
//! panel draws them), and the softest and loudest velocities of a velocity
//! learn. The audio thread never waits on the panel, nor the panel on it.

use std::sync::atomic::{AtomicBool, AtomicU32, AtomicU64, Ordering};

use struck_engine::synth::{Event, TimedEvent, midi_velocity};

/// The panel's request for one key: how many times it has been struck
/// (above the low byte), whether it is held (bit 7) and its velocity (the low
/// seven bits, 1..=127).
const HELD: u32 = 1 << 7;
const VELOCITY: u32 = 0x7f;
const STRIKE: u32 = 1 << 8;

/// No velocity learnt yet.
const NONE_LEARNT: u32 = u32::MAX;

pub struct KeyboardLink {
    /// Per key, what the panel asks (see [`HELD`]).
    asked: [AtomicU32; 128],
    /// The panel asked something since the performer last looked.
    news: AtomicBool,
    /// Keys down as the performer last saw them, from any source: two words of 64.
    down: [AtomicU64; 2],
    /// Pedals as the performer last saw them (f32 bits): sustain, sostenuto, una corda.
    pedals: [AtomicU32; 3],
    /// Pedals as the panel holds them (f32 bits, same order).
    asked_pedals: [AtomicU32; 3],
    /// Learning: the softest and loudest note-on velocity since the learn
    /// began, in 1/16383 (none: [`NONE_LEARNT`] and 0).
    learning: AtomicBool,
    softest: AtomicU32,
    loudest: AtomicU32,
}

impl Default for KeyboardLink {
    fn default() -> Self {
        Self {
            asked: std::array::from_fn(|_| AtomicU32::new(0)),
            news: AtomicBool::new(false),
            down: [AtomicU64::new(0), AtomicU64::new(0)],
            pedals: std::array::from_fn(|_| AtomicU32::new(0)),
            asked_pedals: std::array::from_fn(|_| AtomicU32::new(0)),
            learning: AtomicBool::new(false),
            softest: AtomicU32::new(NONE_LEARNT),
            loudest: AtomicU32::new(0),
        }
    }
}

/// What the performer last took of the panel's keys and pedals.
#[derive(Clone, Copy, Debug)]
pub struct PanelSeen {
    keys: [u32; 128],
    pedals: [u32; 3],
}

impl Default for PanelSeen {
    fn default() -> Self {
        Self { keys: [0; 128], pedals: [0; 3] }
    }
}

/// The pedals the panel shows.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Pedal {
    Sustain = 0,
    Sostenuto = 1,
    UnaCorda = 2,
}

impl KeyboardLink {
    // The panel's side.

    /// Strike `key` from the panel at `velocity` (1..=127) and hold it.
    pub fn press(&self, key: u8, velocity: u8) {
        let Some(asked) = self.asked.get(usize::from(key)) else { return };
        let velocity = u32::from(velocity.clamp(1, 127));
        let strikes = (asked.load(Ordering::Relaxed) & !(HELD | VELOCITY)).wrapping_add(STRIKE);
        asked.store(strikes | HELD | velocity, Ordering::Release);
        self.news.store(true, Ordering::Release);
    }

    /// Let go of a key the panel holds.
    pub fn release(&self, key: u8) {
        let Some(asked) = self.asked.get(usize::from(key)) else { return };
        asked.fetch_and(!HELD, Ordering::AcqRel);
        self.news.store(true, Ordering::Release);
    }

    /// Put a pedal where the panel holds it, 0..=1.
    pub fn set_pedal_from_panel(&self, pedal: Pedal, value: f32) {
        self.asked_pedals[pedal as usize].store(value.clamp(0.0, 1.0).to_bits(), Ordering::Release);
        self.news.store(true, Ordering::Release);
    }

    /// Where the panel holds a pedal, 0..=1.
    pub fn panel_pedal(&self, pedal: Pedal) -> f32 {
        f32::from_bits(self.asked_pedals[pedal as usize].load(Ordering::Relaxed))
    }

    /// Whether the panel holds `key`.
    pub fn panel_holds(&self, key: u8) -> bool {
        self.asked.get(usize::from(key)).is_some_and(|a| a.load(Ordering::Relaxed) & HELD != 0)
    }

    /// Whether `key` was down when the performer last looked (any source).
    pub fn is_down(&self, key: u8) -> bool {
        let key = usize::from(key & 127);
        self.down[key / 64].load(Ordering::Relaxed) & (1 << (key % 64)) != 0
    }

    /// A pedal as the performer last saw it, 0..=1.
    pub fn pedal(&self, pedal: Pedal) -> f32 {
        f32::from_bits(self.pedals[pedal as usize].load(Ordering::Relaxed))
    }

    /// Start a velocity learn (forgetting the last one).
    pub fn start_learning(&self) {
        self.softest.store(NONE_LEARNT, Ordering::Relaxed);
        self.loudest.store(0, Ordering::Relaxed);
        self.learning.store(true, Ordering::Release);
    }

    /// End a velocity learn; the softest and loudest velocity played (0..=1), if any.
    pub fn stop_learning(&self) -> Option<(f32, f32)> {
        self.learning.store(false, Ordering::Release);
        self.learnt()
    }

    pub fn is_learning(&self) -> bool {
        self.learning.load(Ordering::Acquire)
    }

    /// The softest and loudest velocity played since the learn began (0..=1).
    pub fn learnt(&self) -> Option<(f32, f32)> {
        let (soft, loud) = (self.softest.load(Ordering::Relaxed), self.loudest.load(Ordering::Relaxed));
        (soft != NONE_LEARNT).then(|| (soft as f32 / 16383.0, loud as f32 / 16383.0))
    }

    // The audio thread's side: no allocation, no waiting.

    /// The panel's presses and releases since the last call, as engine events
    /// at sample 0 (a key struck again since is released and struck anew; a
    /// key struck and let go since is struck and let go).
    /// `seen` is the performer's copy of what it last took.
    pub fn take_panel_events(&self, seen: &mut PanelSeen, mut push: impl FnMut(TimedEvent)) {
        if !self.news.swap(false, Ordering::AcqRel) {
            return;
        }
        for (i, (asked, seen)) in self.asked_pedals.iter().zip(seen.pedals.iter_mut()).enumerate() {
            let now = asked.load(Ordering::Acquire);
            if now != *seen {
                *seen = now;
                let value = f32::from_bits(now);
                push(TimedEvent::new(0, [Event::Sustain(value), Event::Sostenuto(value), Event::UnaCorda(value)][i]));
            }
        }
        for (key, (asked, seen)) in self.asked.iter().zip(seen.keys.iter_mut()).enumerate() {
            let now = asked.load(Ordering::Acquire);
            if now == *seen {
                continue;
            }
            let key = key as u8;
            let (was_held, struck_again) = (*seen & HELD != 0, now & !(HELD | VELOCITY) != *seen & !(HELD | VELOCITY));
            let off = TimedEvent::new(0, Event::NoteOff { key, velocity: 0.5 });
            if was_held && (struck_again || now & HELD == 0) {
                push(off);
            }
            if struck_again {
                push(TimedEvent::new(0, Event::NoteOn { key, velocity: midi_velocity((now & VELOCITY) as u8) }));
                // A tap shorter than a block: struck, and let go at once.
                if now & HELD == 0 {
                    push(off);
                }
            }
            *seen = now;
        }
    }

    /// Note what `events` do to the keys and pedals the panel shows, and a
    /// learn's velocities (note-ons from the panel's own keyboard count too).
    pub fn watch(&self, events: &[TimedEvent]) {
        let learning = self.learning.load(Ordering::Relaxed);
        for event in events {
            match event.event {
                Event::NoteOn { key, velocity } => {
                    self.set_down(key, true);
                    if learning {
                        let v = (velocity.clamp(0.0, 1.0) * 16383.0).round() as u32;
                        self.softest.fetch_min(v, Ordering::Relaxed);
                        self.loudest.fetch_max(v, Ordering::Relaxed);
                    }
                }
                Event::NoteOff { key, .. } => self.set_down(key, false),
                Event::AllNotesOff => self.down.iter().for_each(|d| d.store(0, Ordering::Relaxed)),
                Event::Reset => {
                    self.down.iter().for_each(|d| d.store(0, Ordering::Relaxed));
                    self.pedals.iter().for_each(|p| p.store(0, Ordering::Relaxed));
                }
                Event::Sustain(v) => self.set_pedal(Pedal::Sustain, v),
                Event::Sostenuto(v) => self.set_pedal(Pedal::Sostenuto, v),
                Event::UnaCorda(v) => self.set_pedal(Pedal::UnaCorda, v),
                _ => {}
            }
        }
    }

    fn set_down(&self, key: u8, down: bool) {
        let key = usize::from(key & 127);
        let bit = 1u64 << (key % 64);
        if down {
            self.down[key / 64].fetch_or(bit, Ordering::Relaxed);
        } else {
            self.down[key / 64].fetch_and(!bit, Ordering::Relaxed);
        }
    }

    fn set_pedal(&self, pedal: Pedal, value: f32) {
        self.pedals[pedal as usize].store(value.clamp(0.0, 1.0).to_bits(), Ordering::Relaxed);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn taken(link: &KeyboardLink, seen: &mut PanelSeen) -> Vec<Event> {
        let mut out = Vec::new();
        link.take_panel_events(seen, |e| {
            assert_eq!(e.time, 0);
            out.push(e.event)
        });
        out
    }

    #[test]
    fn the_panels_presses_become_note_events_once() {
        let link = KeyboardLink::default();
        let mut seen = PanelSeen::default();
        assert!(taken(&link, &mut seen).is_empty());
        link.press(60, 100);
        assert_eq!(taken(&link, &mut seen), [Event::NoteOn { key: 60, velocity: midi_velocity(100) }]);
        assert!(taken(&link, &mut seen).is_empty(), "once");
        assert!(link.panel_holds(60));
        link.release(60);
        assert_eq!(taken(&link, &mut seen), [Event::NoteOff { key: 60, velocity: 0.5 }]);
        // Struck, let go and struck again between two blocks: the key sounds once more.
        link.press(62, 40);
        link.release(62);
        link.press(62, 80);
        assert_eq!(
            taken(&link, &mut seen),
            [Event::NoteOn { key: 62, velocity: midi_velocity(80) }],
            "the last strike"
        );
        link.press(62, 90);
        assert_eq!(
            taken(&link, &mut seen),
            [Event::NoteOff { key: 62, velocity: 0.5 }, Event::NoteOn { key: 62, velocity: midi_velocity(90) }]
        );
        // Struck and let go before the block: struck, and let go at once.
        link.press(64, 50);
        link.release(64);
        assert_eq!(
            taken(&link, &mut seen),
            [Event::NoteOn { key: 64, velocity: midi_velocity(50) }, Event::NoteOff { key: 64, velocity: 0.5 }]
        );
        // The panel's sustain pedal, down and up.
        link.set_pedal_from_panel(Pedal::Sustain, 1.0);
        assert_eq!(taken(&link, &mut seen), [Event::Sustain(1.0)]);
        assert_eq!(link.panel_pedal(Pedal::Sustain), 1.0);
        link.set_pedal_from_panel(Pedal::Sustain, 0.0);
        assert_eq!(taken(&link, &mut seen), [Event::Sustain(0.0)]);
    }

    #[test]
    fn the_performers_events_show_keys_pedals_and_a_learn() {
        let link = KeyboardLink::default();
        let at = |event| TimedEvent::new(0, event);
        link.start_learning();
        link.watch(&[
            at(Event::NoteOn { key: 21, velocity: 0.3 }),
            at(Event::NoteOn { key: 108, velocity: 0.9 }),
            at(Event::Sustain(1.0)),
            at(Event::UnaCorda(0.5)),
        ]);
        assert!(link.is_down(21) && link.is_down(108) && !link.is_down(60));
        assert_eq!((link.pedal(Pedal::Sustain), link.pedal(Pedal::UnaCorda)), (1.0, 0.5));
        link.watch(&[at(Event::NoteOff { key: 21, velocity: 0.5 }), at(Event::NoteOn { key: 60, velocity: 0.6 })]);
        assert!(!link.is_down(21) && link.is_down(60));
        let (soft, loud) = link.stop_learning().unwrap();
        assert!((soft - 0.3).abs() < 1e-4 && (loud - 0.9).abs() < 1e-4, "{soft} {loud}");
        // Not learning: velocities are not taken.
        link.watch(&[at(Event::NoteOn { key: 61, velocity: 0.05 })]);
        assert_eq!(link.learnt().map(|l| l.0), Some(soft));
        link.watch(&[at(Event::Reset)]);
        assert!(!link.is_down(60) && link.pedal(Pedal::Sustain) == 0.0);
        link.start_learning();
        assert_eq!(link.learnt(), None, "a new learn forgets the last");
    }
}
