//! Writing standard MIDI files from note lists, with midly's writer: the small
//! files `struck render` is tested on (`tests/data/midi/`) and, through
//! [`crate::demo_songs`], the demo songs (`demo-songs/`).
//!
//! The files are committed; a test checks that they are what this code writes.
//! Regenerate them after a change here with
//! `STRUCK_REGENERATE_MIDI=1 cargo test -p struck-tests --test render`.

use std::path::PathBuf;

use midly::num::{u4, u7, u14, u15, u24, u28};
use midly::{Format, Fps, Header, MetaMessage, MidiMessage, PitchBend, Smf, Timing, TrackEvent, TrackEventKind};

/// Ticks per quarter note of every metrical file written here.
pub const TICKS_PER_QUARTER: u16 = 480;

/// The MIDI number of a note name: "C4" is 60, "A4" 69, "F#3" 54, "Bb2" 46.
pub fn key(name: &str) -> u8 {
    let bytes = name.as_bytes();
    let letter = match bytes.first().map(u8::to_ascii_uppercase) {
        Some(b'C') => 0,
        Some(b'D') => 2,
        Some(b'E') => 4,
        Some(b'F') => 5,
        Some(b'G') => 7,
        Some(b'A') => 9,
        Some(b'B') => 11,
        _ => panic!("note name {name:?}"),
    };
    let (accidental, octave) = match bytes.get(1) {
        Some(b'#') => (1, &name[2..]),
        Some(b'b') => (-1, &name[2..]),
        _ => (0, &name[1..]),
    };
    let octave: i32 = octave.parse().unwrap_or_else(|_| panic!("note name {name:?}"));
    u8::try_from(12 * (octave + 1) + letter + accidental).unwrap_or_else(|_| panic!("note {name:?} out of range"))
}

/// One track's events at absolute ticks, in any order; written sorted by tick
/// (note-offs first among equal ticks, so a repeated note is released before it
/// is struck again; otherwise in the order they were added).
#[derive(Clone, Debug, Default)]
pub struct TrackBuilder {
    events: Vec<(u64, TrackEventKind<'static>)>,
}

impl TrackBuilder {
    pub fn new() -> Self {
        Self::default()
    }

    /// Set the tempo at `tick`, in quarter notes per minute.
    pub fn tempo(&mut self, tick: u64, bpm: f64) -> &mut Self {
        let us = (60e6 / bpm).round() as u32;
        self.events.push((tick, TrackEventKind::Meta(MetaMessage::Tempo(u24::new(us)))));
        self
    }

    fn midi(&mut self, tick: u64, channel: u8, message: MidiMessage) -> &mut Self {
        self.events.push((tick, TrackEventKind::Midi { channel: u4::new(channel), message }));
        self
    }

    pub fn note_on(&mut self, tick: u64, channel: u8, key: u8, velocity: u8) -> &mut Self {
        self.midi(tick, channel, MidiMessage::NoteOn { key: u7::new(key), vel: u7::new(velocity) })
    }

    pub fn note_off(&mut self, tick: u64, channel: u8, key: u8) -> &mut Self {
        self.midi(tick, channel, MidiMessage::NoteOff { key: u7::new(key), vel: u7::new(64) })
    }

    /// A note on channel 1 from `tick` for `length` ticks.
    pub fn note(&mut self, tick: u64, length: u64, key: u8, velocity: u8) -> &mut Self {
        self.note_on(tick, 0, key, velocity).note_off(tick + length, 0, key)
    }

    /// A controller change on channel 1.
    pub fn cc(&mut self, tick: u64, controller: u8, value: u8) -> &mut Self {
        self.midi(tick, 0, MidiMessage::Controller { controller: u7::new(controller), value: u7::new(value) })
    }

    /// Polyphonic pressure (aftertouch) on `key`, channel 1, 0..=127.
    pub fn poly_pressure(&mut self, tick: u64, key: u8, value: u8) -> &mut Self {
        self.midi(tick, 0, MidiMessage::Aftertouch { key: u7::new(key), vel: u7::new(value) })
    }

    /// Channel pressure (aftertouch) on channel 1, 0..=127.
    pub fn pressure(&mut self, tick: u64, value: u8) -> &mut Self {
        self.midi(tick, 0, MidiMessage::ChannelAftertouch { vel: u7::new(value) })
    }

    /// The pitch wheel on channel 1, 0..=16383 (8192 centred).
    pub fn bend(&mut self, tick: u64, raw: u16) -> &mut Self {
        self.channel_bend(tick, 0, raw)
    }

    /// The pitch wheel on `channel` (0 is channel 1), 0..=16383 (8192 centred).
    pub fn channel_bend(&mut self, tick: u64, channel: u8, raw: u16) -> &mut Self {
        self.midi(tick, channel, MidiMessage::PitchBend { bend: PitchBend(u14::new(raw)) })
    }

    /// The track as midly events with delta times, ending with End of Track.
    pub fn build(&self) -> Vec<TrackEvent<'static>> {
        let mut sorted = self.events.clone();
        let is_off = |kind: &TrackEventKind| match kind {
            TrackEventKind::Midi { message: MidiMessage::NoteOff { .. }, .. } => true,
            TrackEventKind::Midi { message: MidiMessage::NoteOn { vel, .. }, .. } => vel.as_int() == 0,
            _ => false,
        };
        sorted.sort_by_key(|(tick, kind)| (*tick, !is_off(kind)));
        let mut last = 0;
        let mut track = Vec::with_capacity(sorted.len() + 1);
        for (tick, kind) in sorted {
            track.push(TrackEvent { delta: u28::new((tick - last) as u32), kind });
            last = tick;
        }
        track.push(TrackEvent { delta: u28::new(0), kind: TrackEventKind::Meta(MetaMessage::EndOfTrack) });
        track
    }
}

/// The bytes of a standard MIDI file.
pub fn smf_bytes(format: Format, timing: Timing, tracks: &[TrackBuilder]) -> Vec<u8> {
    let mut smf = Smf::new(Header::new(format, timing));
    smf.tracks = tracks.iter().map(TrackBuilder::build).collect();
    let mut bytes = Vec::new();
    smf.write_std(&mut bytes).expect("writing to memory");
    bytes
}

/// Metrical timing at [`TICKS_PER_QUARTER`].
pub fn metrical() -> Timing {
    Timing::Metrical(u15::new(TICKS_PER_QUARTER))
}

/// Ticks of `seconds` at 120 bpm (960 ticks a second).
pub fn at_120(seconds: f64) -> u64 {
    (seconds * 2.0 * f64::from(TICKS_PER_QUARTER)).round() as u64
}

/// A format 0 file at 120 bpm holding one track.
fn single(track: &TrackBuilder) -> Vec<u8> {
    let mut with_tempo = track.clone();
    with_tempo.tempo(0, 120.0);
    smf_bytes(Format::SingleTrack, metrical(), &[with_tempo])
}

/// Where the test files live.
pub fn test_dir() -> PathBuf {
    crate::crate_dir().join("data").join("midi")
}

/// Every test file: its name in [`test_dir`] and its bytes.
pub fn test_files() -> Vec<(&'static str, Vec<u8>)> {
    let a4 = key("A4");
    let c4 = key("C4");
    let mut files = Vec::new();

    // A4, velocity 100, from 0.5 s to 1.5 s.
    files.push(("a4.mid", single(TrackBuilder::new().note(at_120(0.5), at_120(1.0), a4, 100))));

    // The same with the wheel fully up from the start.
    files.push(("a4-bend-up.mid", single(TrackBuilder::new().bend(0, 16_383).note(at_120(0.5), at_120(1.0), a4, 100))));

    // D2 held from 0.1 s to 3.1 s, pressed harder from 1.5 s: by channel pressure,
    // and by polyphonic pressure (Bebung on a clavichord).
    let d2 = key("D2");
    let held = TrackBuilder::new().note(at_120(0.1), at_120(3.0), d2, 90).clone();
    files.push(("d2-channel-pressure.mid", single(held.clone().pressure(at_120(1.5), 127))));
    files.push(("d2-poly-pressure.mid", single(held.clone().poly_pressure(at_120(1.5), d2, 127))));

    // C4 from 0.1 s to 0.5 s, with and without the sustain pedal held throughout.
    let dry = TrackBuilder::new().note(at_120(0.1), at_120(0.4), c4, 100).clone();
    files.push(("c4-release-dry.mid", single(&dry)));
    files.push(("c4-release-pedal.mid", single(dry.clone().cc(0, 64, 127))));

    // A chord held by the pedal, then all sound off (CC120) at 0.5 s and a last
    // event (pedal up) at 1.0 s.
    let mut reset = TrackBuilder::new();
    reset.cc(0, 64, 127);
    for k in ["C4", "E4", "G4"] {
        reset.note(at_120(0.1), at_120(0.2), key(k), 110);
    }
    reset.cc(at_120(0.5), 120, 0).cc(at_120(1.0), 64, 0);
    files.push(("chord-all-sound-off.mid", single(&reset)));

    // Format 1: a tempo track (120 bpm, then 60 bpm from beat 2) and a note track
    // with C4 on beat 3 (2.0 s) to beat 4 (3.0 s).
    let q = u64::from(TICKS_PER_QUARTER);
    let mut tempo = TrackBuilder::new();
    tempo.tempo(0, 120.0).tempo(2 * q, 60.0);
    let mut notes = TrackBuilder::new();
    notes.note(3 * q, q, c4, 90);
    files.push(("tempo-map.mid", smf_bytes(Format::Parallel, metrical(), &[tempo, notes])));

    // SMPTE timing, 25 frames of 40 ticks a second: A4 from 0.25 s to 0.75 s.
    files.push((
        "smpte-25fps.mid",
        smf_bytes(
            Format::SingleTrack,
            Timing::Timecode(Fps::Fps25, 40),
            &[TrackBuilder::new().note(250, 500, a4, 100).clone()],
        ),
    ));

    // Format 2 (refused).
    files.push((
        "format-2.mid",
        smf_bytes(Format::Sequential, metrical(), &[TrackBuilder::new().note(0, q, a4, 100).clone()]),
    ));

    // Controllers but no notes (refused).
    files.push(("no-notes.mid", single(TrackBuilder::new().cc(0, 64, 127).cc(q, 64, 0))));

    // Notes only on channel 10, the General MIDI drum channel (ignored unless asked).
    let mut drums = TrackBuilder::new();
    drums.note_on(at_120(0.1), 9, a4, 100).note_off(at_120(0.5), 9, a4);
    files.push(("channel-10-only.mid", single(&drums)));

    // A0, a key only the piano has.
    files.push(("a0.mid", single(TrackBuilder::new().note(at_120(0.1), at_120(0.4), key("A0"), 100))));

    files
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn note_names() {
        assert_eq!(key("C4"), 60);
        assert_eq!(key("A4"), 69);
        assert_eq!(key("F#3"), 54);
        assert_eq!(key("Bb2"), 46);
        assert_eq!(key("A0"), 21);
        assert_eq!(key("C8"), 108);
    }

    #[test]
    fn note_offs_come_first_among_equal_ticks() {
        let mut t = TrackBuilder::new();
        t.note(0, 10, 60, 100).note(10, 10, 60, 100);
        let track = t.build();
        let kinds: Vec<_> = track.iter().map(|e| (e.delta.as_int(), e.kind)).collect();
        assert!(matches!(kinds[1], (10, TrackEventKind::Midi { message: MidiMessage::NoteOff { .. }, .. })));
        assert!(matches!(kinds[2], (0, TrackEventKind::Midi { message: MidiMessage::NoteOn { .. }, .. })));
    }
}
