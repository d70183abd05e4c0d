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

/// MIDI controllers Struck answers.
pub mod cc {
    pub const SUSTAIN: u8 = 64;
    pub const SOSTENUTO: u8 = 66;
    pub const UNA_CORDA: u8 = 67;
    pub const ALL_SOUND_OFF: u8 = 120;
    pub const RESET_ALL_CONTROLLERS: u8 = 121;
    pub const ALL_NOTES_OFF: u8 = 123;
}

impl Event {
    /// What a MIDI controller change means (value 0..=1): up to four events, for
    /// the plugin and the MIDI-file renderer alike. CC 124..=127 (mode changes)
    /// imply all notes off, as MIDI 1.0 says.
    pub fn from_controller(controller: u8, value: f32) -> [Option<Event>; 4] {
        let one = |e| [Some(e), None, None, None];
        match controller {
            cc::SUSTAIN => one(Event::Sustain(value)),
            cc::SOSTENUTO => one(Event::Sostenuto(value)),
            cc::UNA_CORDA => one(Event::UnaCorda(value)),
            cc::ALL_SOUND_OFF => one(Event::Reset),
            cc::RESET_ALL_CONTROLLERS => [
                Some(Event::Sustain(0.0)),
                Some(Event::Sostenuto(0.0)),
                Some(Event::UnaCorda(0.0)),
                Some(Event::PitchBend(0.0)),
            ],
            cc::ALL_NOTES_OFF..=127 => one(Event::AllNotesOff),
            _ => [None; 4],
        }
    }

    /// A 14-bit pitch-wheel value as -1..=1: 0 is -1, 8192 the centre (exactly 0), 16383 is +1.
    pub fn pitch_wheel(raw: u16) -> f32 {
        let offset = f32::from(raw.min(16_383)) - 8192.0;
        if offset < 0.0 { offset / 8192.0 } else { offset / 8191.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn controllers_and_the_wheel() {
        assert_eq!(Event::from_controller(64, 0.5), [Some(Event::Sustain(0.5)), None, None, None]);
        assert_eq!(Event::from_controller(121, 1.0).iter().flatten().count(), 4);
        assert_eq!(Event::from_controller(126, 0.0)[0], Some(Event::AllNotesOff));
        assert_eq!(Event::from_controller(1, 1.0), [None; 4]);
        assert_eq!(Event::pitch_wheel(0), -1.0);
        assert_eq!(Event::pitch_wheel(8192), 0.0);
        assert_eq!(Event::pitch_wheel(16383), 1.0);
    }
}
