//! Standard MIDI files (SMF 1.0) read as the synth's events, each at a sample time.
//!
//! The container (the `MThd` header and the chunk lengths) is checked here, so a
//! file cut short is named as truncated; the events inside each `MTrk` chunk are
//! decoded by midly (running status, variable-length deltas, meta and SysEx events).
//!
//! What is played:
//!
//! - formats 0 and 1; every track is merged into one stream. Events at the same
//!   tick keep the order of their tracks, then their order within the track.
//!   Format 2 (a collection of independent songs) is refused.
//! - timing by ticks per quarter note, with every Set Tempo event of any track
//!   forming one tempo map (120 bpm until the first); or SMPTE timecode timing
//!   (24, 25, 29.97 drop-frame or 30 frames per second, ticks per frame), where
//!   tempo events are ignored as the standard says.
//! - sample times are exact rational conversions rounded half up:
//!   t = (sum of ticks x tempo) x fs / (ticks per quarter x 10^6), in integers, so
//!   the same file gives the same sample times on every machine.
//! - all sixteen channels are merged onto the one instrument (it has keys, not
//!   channels: a note-off on any channel releases the key, a pedal on any channel
//!   moves the pedal), except channel 10, which General MIDI reserves for drum
//!   sounds whose note numbers are not pitches; it is ignored unless asked for.
//! - note-on (velocity 0 is a note-off), note-off, CC64 sustain (value / 127,
//!   continuous: half-pedalling), CC66 sostenuto and CC67 una corda (down at
//!   64 and above), CC120 all sound off (a reset: silence within milliseconds),
//!   CC121 reset all controllers (pedals up, pitch bend centred, mod wheel at rest; RP-015), CC123
//!   all notes off (and CC124 to CC127, which imply it), and pitch bend (14 bits,
//!   centre 8192: 0 is -1, 16383 is +1), CC1 the mod wheel (mallet hardness),
//!   polyphonic aftertouch (a key's pressure) and channel aftertouch (the
//!   pressure of every key held on that channel, and of keys pressed there while
//!   it lasts: MPE files give each note its own channel). Everything else (other
//!   controllers, program changes, SysEx, meta events other than tempo) is ignored.
//! - events after a track's End of Track are ignored.

use struck_engine::synth::{BendRouter, Event, HammerRouter, PressureRouter, cc, midi_velocity};

/// A song longer than this (its last event), s, is refused rather than rendered.
pub const MAX_SONG_S: f64 = 3600.0;
/// Tempo before the first Set Tempo event: 120 bpm, in microseconds per quarter note.
const DEFAULT_TEMPO_US: u64 = 500_000;
/// General MIDI's percussion channel (channel 10, numbered 9 on the wire).
const DRUM_CHANNEL: u8 = 9;

/// Why a file cannot be played.
#[derive(Debug, thiserror::Error)]
pub enum MidiError {
    #[error("not a MIDI file (it does not begin with an MThd header)")]
    NotMidi,
    #[error("truncated: {0}")]
    Truncated(String),
    #[error("malformed MIDI: {0}")]
    Malformed(String),
    #[error("MIDI format 2 (a set of independent sequences) is not supported; use format 0 or 1")]
    Format2,
    #[error("no notes to play{0}")]
    NoNotes(String),
    #[error("the last event is at {0:.0} s; songs up to {MAX_SONG_S:.0} s are rendered")]
    TooLong(f64),
}

/// Choices about what to play.
#[derive(Clone, Copy, Debug, Default)]
pub struct ReadOptions {
    /// Play channel 10 too (General MIDI drums by default, so ignored).
    pub include_channel_10: bool,
    /// MPE (its lower zone): channels 2-16 each carry one note, bending it
    /// over this many semitones each way and setting its timbre (CC74);
    /// channel 1 bends every note. None: every bend is the pitch wheel.
    pub mpe_bend_range: Option<f32>,
}

/// A song as the synth's events.
#[derive(Clone, Debug)]
pub struct Song {
    /// Every event with its time in samples from the start, in playing order.
    pub events: Vec<(u64, Event)>,
    /// Note-ons played, per MIDI key.
    pub notes_per_key: [usize; 128],
}

impl Song {
    pub fn note_count(&self) -> usize {
        self.notes_per_key.iter().sum()
    }

    /// Sample time of the last event (0 for none).
    pub fn last_sample(&self) -> u64 {
        self.events.last().map_or(0, |&(t, _)| t)
    }
}

/// How ticks become time.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Timing {
    /// Ticks per quarter note, with the tempo map.
    Metrical { ticks_per_quarter: u64 },
    /// Ticks per second = fps_num / fps_den x ticks_per_frame.
    Timecode { fps_num: u64, fps_den: u64, ticks_per_frame: u64 },
}

/// An event of interest, before its tick becomes a sample time.
#[derive(Clone, Copy, Debug)]
enum Item {
    Tempo(u64),
    Play {
        channel: u8,
        event: Event,
    },
    ChannelPressure {
        channel: u8,
        pressure: f32,
    },
    /// CC74: MPE's timbre on a member channel.
    Timbre {
        channel: u8,
        value: f32,
    },
}

/// Read a standard MIDI file's bytes into events at `sample_rate_hz`.
pub fn read(bytes: &[u8], sample_rate_hz: u32, options: ReadOptions) -> Result<Song, MidiError> {
    let (declared_tracks, timing, mut rest) = read_header(bytes)?;
    let mut tracks: Vec<&[u8]> = Vec::new();
    while !rest.is_empty() {
        let chunk_number = tracks.len() + 1;
        if rest.len() < 8 {
            return Err(MidiError::Truncated(format!(
                "the file ends {} bytes into the header of chunk {chunk_number} (8 bytes)",
                rest.len()
            )));
        }
        let (id, length) = (&rest[..4], u32::from_be_bytes([rest[4], rest[5], rest[6], rest[7]]) as usize);
        let available = rest.len() - 8;
        if length > available {
            let what = if id == b"MTrk" { format!("track {chunk_number}") } else { "a chunk".to_string() };
            return Err(MidiError::Truncated(format!(
                "{what} declares {length} bytes but the file holds only {available} more"
            )));
        }
        if id == b"MTrk" {
            tracks.push(&rest[8..8 + length]);
        }
        // Chunks of other types are skipped, as the standard asks.
        rest = &rest[8 + length..];
    }
    if tracks.len() < declared_tracks {
        return Err(MidiError::Truncated(format!(
            "the header declares {declared_tracks} tracks but the file holds {}",
            tracks.len()
        )));
    }

    let mut items: Vec<(u64, Item)> = Vec::new();
    let mut notes_per_key = [0usize; 128];
    let mut drum_notes = 0usize;
    for (t, data) in tracks.iter().enumerate() {
        read_track(t + 1, data, options, &mut items, &mut notes_per_key, &mut drum_notes)?;
    }
    // Tracks were appended in order and each in its own order: a stable sort on the
    // tick alone keeps ties in track order, then file order.
    items.sort_by_key(|&(tick, _)| tick);

    let clock = Clock::new(timing, sample_rate_hz);
    let mut events = Vec::with_capacity(items.len());
    let mut tempo_us = DEFAULT_TEMPO_US;
    let mut last_tick = 0u64;
    let mut pressure = PressureRouter::default();
    let mut bends = BendRouter::default();
    bends.set_mpe(options.mpe_bend_range);
    let mut hammers = HammerRouter::default();
    hammers.set_mpe(options.mpe_bend_range.is_some());
    // Sum of ticks x tempo in microseconds (metrical), or the tick (timecode).
    let mut elapsed: u128 = 0;
    for (tick, item) in items {
        elapsed += match timing {
            Timing::Metrical { .. } => u128::from(tick - last_tick) * u128::from(tempo_us),
            Timing::Timecode { .. } => u128::from(tick - last_tick),
        };
        last_tick = tick;
        if let Item::Tempo(us) = item {
            tempo_us = us;
            continue;
        }
        let seconds = clock.seconds(elapsed);
        if seconds > MAX_SONG_S {
            return Err(MidiError::TooLong(seconds));
        }
        let at = clock.samples(elapsed);
        match item {
            Item::Tempo(_) => {}
            Item::Play { channel, event } => match event {
                // A note's own bend and hammer go ahead of its strike.
                Event::NoteOn { key, .. } => {
                    events.extend(bends.note_on(key, channel).map(|e| (at, e)));
                    events.extend(hammers.note_on(key, channel).map(|e| (at, e)));
                    events.push((at, event));
                    events.extend(pressure.note_on(key, channel).map(|e| (at, e)));
                }
                Event::NoteOff { key, .. } => {
                    events.push((at, event));
                    pressure.note_off(key);
                    bends.note_off(key);
                    hammers.note_off(key);
                }
                Event::PitchBend(value) => bends.pitch_bend(channel, value, |e| events.push((at, e))),
                _ => events.push((at, event)),
            },
            Item::Timbre { channel, value } => hammers.timbre(channel, value, |e| events.push((at, e))),
            Item::ChannelPressure { channel, pressure: p } => {
                pressure.channel_pressure(channel, p, |e| events.push((at, e)))
            }
        }
    }

    let song = Song { events, notes_per_key };
    if song.note_count() == 0 {
        let drums = "on channel 10, General MIDI's drum channel";
        let why = match drum_notes {
            0 => String::new(),
            1 => format!(" (1 note {drums} is ignored; --include-channel-10 plays it)"),
            n => format!(" ({n} notes {drums} are ignored; --include-channel-10 plays them)"),
        };
        return Err(MidiError::NoNotes(why));
    }
    Ok(song)
}

/// The declared track count, the timing and what follows the header chunk.
fn read_header(bytes: &[u8]) -> Result<(usize, Timing, &[u8]), MidiError> {
    if bytes.len() < 4 || &bytes[..4] != b"MThd" {
        return Err(MidiError::NotMidi);
    }
    if bytes.len() < 14 {
        return Err(MidiError::Truncated(format!("the header chunk needs 14 bytes, the file has {}", bytes.len())));
    }
    let length = u32::from_be_bytes([bytes[4], bytes[5], bytes[6], bytes[7]]) as usize;
    if length < 6 {
        return Err(MidiError::Malformed(format!("the header chunk is {length} bytes long (6 expected)")));
    }
    if length > bytes.len() - 8 {
        return Err(MidiError::Truncated(format!(
            "the header chunk declares {length} bytes but the file holds only {} more",
            bytes.len() - 8
        )));
    }
    let word = |i: usize| u16::from_be_bytes([bytes[8 + i], bytes[9 + i]]);
    let (format, track_count, division) = (word(0), word(2), word(4));
    match format {
        0 | 1 => {}
        2 => return Err(MidiError::Format2),
        other => return Err(MidiError::Malformed(format!("unknown format {other} (0, 1 or 2 expected)"))),
    }
    let timing = if division & 0x8000 == 0 {
        if division == 0 {
            return Err(MidiError::Malformed("the header's division is 0 ticks per quarter note".to_string()));
        }
        Timing::Metrical { ticks_per_quarter: u64::from(division) }
    } else {
        // The high byte is minus the frame rate, in two's complement (-128 is no rate).
        let fps = -i32::from((division >> 8) as u8 as i8);
        let ticks_per_frame = u64::from(division & 0xff);
        let (fps_num, fps_den) = match fps {
            24 => (24, 1),
            25 => (25, 1),
            // 29 stands for 30 drop-frame: 30 / 1.001 frames per second.
            29 => (30_000, 1_001),
            30 => (30, 1),
            other => {
                return Err(MidiError::Malformed(format!(
                    "SMPTE timing at {other} frames per second (24, 25, 29 or 30 expected)"
                )));
            }
        };
        if ticks_per_frame == 0 {
            return Err(MidiError::Malformed("SMPTE timing with 0 ticks per frame".to_string()));
        }
        Timing::Timecode { fps_num, fps_den, ticks_per_frame }
    };
    Ok((usize::from(track_count), timing, &bytes[8 + length..]))
}

/// Decode one track's events, appending those of interest at their absolute tick.
fn read_track(
    number: usize,
    data: &[u8],
    options: ReadOptions,
    items: &mut Vec<(u64, Item)>,
    notes_per_key: &mut [usize; 128],
    drum_notes: &mut usize,
) -> Result<(), MidiError> {
    use midly::{MetaMessage, MidiMessage, TrackEventKind};

    let mut events = midly::EventIter::new(data);
    let mut tick = 0u64;
    loop {
        let unread = events.unread().len();
        let event = match events.next() {
            Some(Ok(event)) => event,
            Some(Err(e)) => {
                return Err(MidiError::Malformed(format!("track {number}, byte {}: {e}", data.len() - unread)));
            }
            // midly stops quietly at an event it cannot read (unless built `strict`).
            None if unread > 0 => {
                return Err(MidiError::Malformed(format!(
                    "track {number}, byte {}: an event that cannot be read",
                    data.len() - unread
                )));
            }
            None => break,
        };
        tick += u64::from(event.delta.as_int());
        match event.kind {
            TrackEventKind::Meta(MetaMessage::EndOfTrack) => break,
            TrackEventKind::Meta(MetaMessage::Tempo(us)) if us.as_int() == 0 => {
                return Err(MidiError::Malformed(format!(
                    "track {number}: a Set Tempo event of 0 microseconds a quarter note"
                )));
            }
            TrackEventKind::Meta(MetaMessage::Tempo(us)) => items.push((tick, Item::Tempo(u64::from(us.as_int())))),
            // midly reads a Set Tempo of fewer than its 3 bytes as an unknown meta event.
            TrackEventKind::Meta(MetaMessage::Unknown(0x51, data)) => {
                return Err(MidiError::Malformed(format!(
                    "track {number}: a Set Tempo event of {} bytes (it takes 3)",
                    data.len()
                )));
            }
            TrackEventKind::Midi { channel, message } => {
                let is_note_on = matches!(message, MidiMessage::NoteOn { vel, .. } if vel.as_int() > 0);
                // (An MPE song's channel 10 is a member channel like any other.)
                let drums = !options.include_channel_10 && options.mpe_bend_range.is_none();
                if channel.as_int() == DRUM_CHANNEL && drums {
                    *drum_notes += usize::from(is_note_on);
                    continue;
                }
                if let MidiMessage::NoteOn { key, .. } = message
                    && is_note_on
                {
                    notes_per_key[usize::from(key.as_int())] += 1;
                }
                let channel = channel.as_int();
                if let MidiMessage::ChannelAftertouch { vel } = message {
                    items.push((tick, Item::ChannelPressure { channel, pressure: f32::from(vel.as_int()) / 127.0 }));
                }
                if let MidiMessage::Controller { controller, value } = message
                    && controller.as_int() == cc::TIMBRE
                {
                    items.push((tick, Item::Timbre { channel, value: f32::from(value.as_int()) / 127.0 }));
                }
                for event in events_of(message) {
                    items.push((tick, Item::Play { channel, event }));
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// The synth's events for one channel message (none, one, or four for a controller reset).
fn events_of(message: midly::MidiMessage) -> impl Iterator<Item = Event> {
    use midly::MidiMessage;

    let mut out: [Option<Event>; 5] = [None; 5];
    match message {
        MidiMessage::NoteOn { key, vel } if vel.as_int() > 0 => {
            out[0] = Some(Event::NoteOn { key: key.as_int(), velocity: midi_velocity(vel.as_int()) });
        }
        // A note-on at velocity 0 carries no release velocity: MIDI's default, 64.
        MidiMessage::NoteOn { key, .. } => {
            out[0] = Some(Event::NoteOff { key: key.as_int(), velocity: midi_velocity(64) })
        }
        MidiMessage::NoteOff { key, vel } => {
            out[0] = Some(Event::NoteOff { key: key.as_int(), velocity: midi_velocity(vel.as_int()) });
        }
        MidiMessage::Controller { controller, value } => {
            out = Event::from_controller(controller.as_int(), f32::from(value.as_int()) / 127.0);
        }
        MidiMessage::PitchBend { bend } => out[0] = Some(Event::PitchBend(Event::pitch_wheel(bend.0.as_int()))),
        MidiMessage::Aftertouch { key, vel } => {
            out[0] = Some(Event::Pressure { key: key.as_int(), pressure: f32::from(vel.as_int()) / 127.0 });
        }
        _ => {}
    }
    out.into_iter().flatten()
}

/// Ticks (weighted by tempo) to samples and seconds.
struct Clock {
    /// samples = elapsed x numerator / denominator, rounded half up.
    numerator: u128,
    denominator: u128,
    sample_rate_hz: f64,
}

impl Clock {
    fn new(timing: Timing, sample_rate_hz: u32) -> Self {
        let fs = u128::from(sample_rate_hz);
        let (numerator, denominator) = match timing {
            // elapsed is in microsecond-ticks per quarter note.
            Timing::Metrical { ticks_per_quarter } => (fs, u128::from(ticks_per_quarter) * 1_000_000),
            Timing::Timecode { fps_num, fps_den, ticks_per_frame } => {
                (fs * u128::from(fps_den), u128::from(fps_num) * u128::from(ticks_per_frame))
            }
        };
        Self { numerator, denominator, sample_rate_hz: f64::from(sample_rate_hz) }
    }

    fn samples(&self, elapsed: u128) -> u64 {
        let twice = 2 * elapsed * self.numerator + self.denominator;
        u64::try_from(twice / (2 * self.denominator)).unwrap_or(u64::MAX)
    }

    fn seconds(&self, elapsed: u128) -> f64 {
        (elapsed as f64) * (self.numerator as f64) / (self.denominator as f64) / self.sample_rate_hz
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A format-0 file whose one track is `track`'s raw bytes.
    fn raw(track: &[u8]) -> Vec<u8> {
        let mut bytes = b"MThd\0\0\0\x06\0\0\0\x01\0\x60MTrk".to_vec();
        bytes.extend_from_slice(&(track.len() as u32).to_be_bytes());
        bytes.extend_from_slice(track);
        bytes
    }

    #[test]
    fn a_sysex_running_past_its_track_and_a_short_tempo_are_refused() {
        let options = ReadOptions::default();
        // A note, then a SysEx that says 50 bytes and has 3.
        let sysex = raw(&[0, 0x90, 60, 100, 10, 0xF0, 50, 1, 2, 3]);
        let e = read(&sysex, 48_000, options).unwrap_err().to_string();
        assert!(e.starts_with("malformed MIDI: track 1"), "{e}");
        // A Set Tempo of 2 bytes.
        let tempo = raw(&[0, 0xFF, 0x51, 2, 7, 0xA1, 0, 0x90, 60, 100, 0x60, 0x80, 60, 0, 0, 0xFF, 0x2F, 0]);
        let e = read(&tempo, 48_000, options).unwrap_err().to_string();
        assert!(e.contains("a Set Tempo event of 2 bytes"), "{e}");
        let zero = raw(&[0, 0xFF, 0x51, 3, 0, 0, 0, 0, 0x90, 60, 100, 0x60, 0x80, 60, 0, 0, 0xFF, 0x2F, 0]);
        assert!(read(&zero, 48_000, options).unwrap_err().to_string().contains("0 microseconds"));
    }

    /// A format-0 file of `(delta ticks, channel, message)`.
    fn smf(events: &[(u32, u8, midly::MidiMessage)]) -> Vec<u8> {
        use midly::{Header, Smf, Track, TrackEvent, TrackEventKind};
        let mut track: Track = events
            .iter()
            .map(|&(delta, channel, message)| TrackEvent {
                delta: delta.into(),
                kind: TrackEventKind::Midi { channel: channel.into(), message },
            })
            .collect();
        track.push(TrackEvent { delta: 0.into(), kind: TrackEventKind::Meta(midly::MetaMessage::EndOfTrack) });
        let smf = Smf {
            header: Header::new(midly::Format::SingleTrack, midly::Timing::Metrical(480.into())),
            tracks: vec![track],
        };
        let mut bytes = Vec::new();
        smf.write_std(&mut bytes).unwrap();
        bytes
    }

    #[test]
    fn aftertouch_reaches_the_keys_held_on_its_channel() {
        use midly::MidiMessage::{Aftertouch, ChannelAftertouch, NoteOff, NoteOn};
        let bytes = smf(&[
            (0, 0, NoteOn { key: 60.into(), vel: 100.into() }),
            (0, 1, NoteOn { key: 64.into(), vel: 100.into() }),
            (10, 0, ChannelAftertouch { vel: 127.into() }),
            (10, 1, Aftertouch { key: 64.into(), vel: 127.into() }),
            (10, 0, NoteOn { key: 67.into(), vel: 100.into() }),
            (10, 0, NoteOff { key: 60.into(), vel: 0.into() }),
            (10, 0, ChannelAftertouch { vel: 0.into() }),
        ]);
        let song = read(&bytes, 48_000, ReadOptions::default()).unwrap();
        let pressures: Vec<(u8, f32)> = song
            .events
            .iter()
            .filter_map(|(_, e)| match *e {
                Event::Pressure { key, pressure } => Some((key, pressure)),
                _ => None,
            })
            .collect();
        // Channel 1's pressure reaches key 60 only; the poly pressure key 64; key 67,
        // pressed on channel 1 under pressure, starts with it; the release reaches 67 alone.
        assert_eq!(pressures, [(60, 1.0), (64, 1.0), (67, 1.0), (67, 0.0)]);
    }

    #[test]
    fn tempo_map_rounds_half_up() {
        // 480 ticks per quarter at 120 bpm: one tick is 1/960 s = 50 samples at 48 kHz.
        let clock = Clock::new(Timing::Metrical { ticks_per_quarter: 480 }, 48_000);
        assert_eq!(clock.samples(u128::from(DEFAULT_TEMPO_US)), 50);
        // 44.1 kHz: 45.9375 samples per tick.
        let clock = Clock::new(Timing::Metrical { ticks_per_quarter: 480 }, 44_100);
        assert_eq!(clock.samples(u128::from(DEFAULT_TEMPO_US)), 46);
        assert_eq!(clock.samples(16 * u128::from(DEFAULT_TEMPO_US)), 735);
        // 29.97 fps, 80 ticks a frame: 2400 frames = 80.08 s.
        let clock = Clock::new(Timing::Timecode { fps_num: 30_000, fps_den: 1_001, ticks_per_frame: 80 }, 48_000);
        assert_eq!(clock.samples(2400 * 80), 3_843_840);
    }
}
