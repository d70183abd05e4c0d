//! What a player does, as the real-time engine receives it.

/// One performance event. Values are normalised the way MIDI 1.0 carries them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A key goes down; `velocity` in (0, 1] (MIDI velocity / 127).
    NoteOn { key: u8, velocity: f32 },
    /// A key comes up.
    NoteOff { key: u8 },
    /// CC64, 0 (dampers on the strings) to 1 (all dampers lifted); in between, half-pedal.
    Sustain(f32),
    /// CC66, held at or above 0.5: the keys down at that moment keep their dampers lifted.
    Sostenuto(f32),
    /// CC67, at or above 0.5: una corda (the hammer shifts to fewer strings of each unison).
    UnaCorda(f32),
    /// Pitch wheel, -1 to 1 (centre 0); the bend range is a control.
    PitchBend(f32),
    /// CC123: every key is released (dampers fall where the pedals allow).
    AllNotesOff,
    /// CC120 / reset: every key falls silent within a few milliseconds, pedals up, bend centred.
    Reset,
}

/// An event at a sample offset within the block being processed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimedEvent {
    pub time: u32,
    pub event: Event,
}

impl TimedEvent {
    pub fn new(time: u32, event: Event) -> Self {
        Self { time, event }
    }
}
