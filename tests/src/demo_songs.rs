//! The demo songs of `demo-songs/`, written out as note lists (original
//! compositions for this project), one per instrument, each 30 to 40 seconds:
//!
//! - `piano-nocturne.mid`: a slow waltz of alternating major-seventh chords under a
//!   melody, legato pedalling (the pedal lifted at each bar line and pressed again
//!   just after the new bass), una corda in the quiet opening, half-pedal at the
//!   close, dynamics from pp to f.
//! - `santoor-tremolo.mid`: on a D scale: an unmeasured opening of single strokes
//!   and rolls, a melody in tremolo (two mallets alternating about twelve times a
//!   second) over a low drone, a fast rhythmic section of melody and drone strokes,
//!   and a closing roll.
//! - `fortepiano-sonatina.mid`: a sonatina movement in C major: a singing melody
//!   over an Alberti bass, sforzando accents, a turn to G major and back, the
//!   knee lever (sustain) only under the closing chords.
//! - `dulcimer-reel.mid`: a reel in D, two mallets alternating in eighth notes with
//!   drone strokes, the tune crossing between the two sides of the treble bridge.
//! - `cimbalom-csardas.mid`: a slow lassu with the pedal down (rolls and broken
//!   chords ringing together), then a fast friss with the pedal up, where the
//!   damper bar makes every stroke short.
//! - `clavichord-two-part.mid`: a two-part invention in A minor: a one-bar subject
//!   and countersubject in imitation through D minor and E minor, softly, with
//!   Bebung (channel aftertouch) on the long notes.
//! - `harpsichord-prelude.mid`: a prelude of broken chords in sixteenths (a bass
//!   held under arpeggios) through a cadence in D major.
//!
//! `cargo xtask demo` renders `demo-songs/<instrument>-<name>.mid` with
//! `--instrument <instrument>`.

use std::path::PathBuf;

use midly::Format;

use crate::midi_gen::{TICKS_PER_QUARTER, TrackBuilder, key, metrical, smf_bytes};

/// Where the demo songs live.
pub fn demo_dir() -> PathBuf {
    crate::crate_dir().parent().expect("the workspace").join("demo-songs")
}

/// Every demo song: its file name and its bytes.
pub fn all() -> Vec<(&'static str, Vec<u8>)> {
    vec![
        ("piano-nocturne.mid", piano_nocturne()),
        ("fortepiano-sonatina.mid", fortepiano_sonatina()),
        ("santoor-tremolo.mid", santoor_tremolo()),
        ("dulcimer-reel.mid", dulcimer_reel()),
        ("cimbalom-csardas.mid", cimbalom_csardas()),
        ("clavichord-two-part.mid", clavichord_two_part()),
        ("harpsichord-prelude.mid", harpsichord_prelude()),
    ]
}

/// Ticks of a time in beats (quarter notes).
fn ticks(beats: f64) -> u64 {
    (beats * f64::from(TICKS_PER_QUARTER)).round() as u64
}

/// A small deterministic scatter in -1..1, so repeated strokes are not identical.
fn scatter(i: u64) -> f64 {
    let x = i.wrapping_mul(0x9E37_79B9_7F4A_7C15).rotate_left(17).wrapping_mul(0xBF58_476D_1CE4_E5B9);
    (x >> 11) as f64 / (1u64 << 53) as f64 * 2.0 - 1.0
}

fn velocity(v: f64) -> u8 {
    v.round().clamp(1.0, 127.0) as u8
}

/// A voice playing a line: notes one after another from a start beat.
struct Line<'a> {
    track: &'a mut TrackBuilder,
    beat: f64,
    /// Fraction of each note's length that it is held.
    legato: f64,
}

impl<'a> Line<'a> {
    fn at(track: &'a mut TrackBuilder, beat: f64, legato: f64) -> Self {
        Self { track, beat, legato }
    }

    /// Play `notes` (name, beats), transposed by `semitones`, at velocity `vel(i)`.
    fn play(&mut self, notes: &[(&str, f64)], semitones: i32, vel: impl Fn(usize) -> f64) -> &mut Self {
        for (i, &(name, beats)) in notes.iter().enumerate() {
            let k = u8::try_from(i32::from(key(name)) + semitones).expect("a MIDI key");
            let start = ticks(self.beat);
            let length = ticks(beats * self.legato).max(1);
            self.track.note(start, length, k, velocity(vel(i)));
            self.beat += beats;
        }
        self
    }
}

/// Piano: a slow waltz (72 bpm, 3/4), thirteen bars and a held close.
fn piano_nocturne() -> Vec<u8> {
    const BPM: f64 = 72.0;
    // Each bar: bass, a chord on beat 2 held through beat 3, and a level (0..1).
    let bars: [(&str, [&str; 3], f64); 14] = [
        ("G2", ["B3", "D4", "F#4"], 0.15),
        ("D2", ["A3", "C#4", "F#4"], 0.18),
        ("G2", ["B3", "D4", "F#4"], 0.30),
        ("D2", ["A3", "C#4", "F#4"], 0.35),
        ("G2", ["B3", "D4", "F#4"], 0.42),
        ("D2", ["A3", "C#4", "F#4"], 0.40),
        ("E2", ["G3", "B3", "D4"], 0.50),
        ("A2", ["G3", "D4", "E4"], 0.62),
        ("G2", ["B3", "D4", "F#4"], 0.80),
        ("F#2", ["A3", "C#4", "E4"], 0.75),
        ("E2", ["G3", "B3", "F#4"], 0.55),
        ("A2", ["G3", "C#4", "E4"], 0.40),
        ("D2", ["A3", "C#4", "F#4"], 0.25),
        ("D2", ["A3", "D4", "F#4"], 0.15),
    ];
    // The melody from bar 3, (name, beats); "r" is a rest.
    let melody: [(&str, f64); 28] = [
        ("B4", 2.0),
        ("D5", 1.0),
        ("C#5", 3.0),
        ("B4", 1.0),
        ("A4", 1.0),
        ("B4", 1.0),
        ("F#4", 3.0),
        ("G4", 2.0),
        ("A4", 1.0),
        ("B4", 1.0),
        ("D5", 2.0),
        ("F#5", 2.0),
        ("E5", 1.0),
        ("D5", 1.0),
        ("C#5", 1.0),
        ("A4", 1.0),
        ("B4", 2.0),
        ("D5", 0.5),
        ("C#5", 0.5),
        ("C#5", 2.0),
        ("E5", 1.0),
        ("D5", 1.5),
        ("C#5", 0.5),
        ("A4", 1.0),
        ("D5", 3.0),
        ("r", 0.0),
        ("r", 0.0),
        ("r", 0.0),
    ];
    let mut left = TrackBuilder::new();
    let mut right = TrackBuilder::new();
    left.tempo(0, BPM);
    // Una corda for the two quiet bars of introduction.
    left.cc(0, 67, 127).cc(ticks(6.0) - 1, 67, 0);
    let last = bars.len() - 1;
    for (b, &(bass, chord, level)) in bars.iter().enumerate() {
        let bar = 3.0 * b as f64;
        let held = if b == last { 6.0 } else { 3.0 };
        // Legato pedal: up at the bar line (the new bass is struck with the dampers
        // falling on the old harmony), down again an eighth of a beat later.
        if b > 0 {
            left.cc(ticks(bar), 64, 0);
        }
        left.cc(ticks(bar + 0.125), 64, if b == last { 80 } else { 127 });
        let v = 30.0 + 75.0 * level;
        left.note(ticks(bar), ticks(held) - 10, key(bass), velocity(v + 6.0 + 4.0 * scatter(b as u64)));
        for (i, &note) in chord.iter().enumerate() {
            let vel = v - 12.0 + 3.0 * scatter(100 + 10 * b as u64 + i as u64);
            left.note(ticks(bar + 1.0), ticks(held - 1.0) - 10, key(note), velocity(vel));
        }
    }
    left.cc(ticks(3.0 * bars.len() as f64 + 3.0), 64, 0);
    // The melody's level follows the bars it sounds over.
    let mut beat = 6.0;
    for (i, &(name, beats)) in melody.iter().enumerate() {
        if name == "r" || beats == 0.0 {
            continue;
        }
        let bar = ((beat / 3.0) as usize).min(last);
        let v = 40.0 + 70.0 * bars[bar].2 + 4.0 * scatter(1000 + i as u64);
        let length = if i + 1 == melody.len() || melody[i + 1].1 == 0.0 { 6.0 } else { beats * 0.95 };
        right.note(ticks(beat), ticks(length), key(name), velocity(v));
        beat += beats;
    }
    smf_bytes(Format::Parallel, metrical(), &[left, right])
}

/// Two santoor mallets taking turns.
struct Mallets {
    track: TrackBuilder,
    stroke: u64,
}

impl Mallets {
    /// Strokes of a roll, beats apart: twelve a second at 90 bpm.
    const ROLL: f64 = 0.125;

    /// One stroke at `level` (0..1); the right hand (even strokes) a little heavier than the left.
    fn strike(&mut self, beat: f64, name: &str, level: f64) {
        let hand = if self.stroke.is_multiple_of(2) { 1.0 } else { 0.88 };
        let v = (20.0 + 100.0 * level) * hand + 5.0 * scatter(self.stroke);
        // A santoor has no dampers: the note-off only ends the MIDI note.
        self.track.note(ticks(beat), ticks(0.1), key(name), velocity(v));
        self.stroke += 1;
    }

    /// A roll on `name` from `from` for `beats`, its level moving from `a` to `b`.
    fn roll(&mut self, from: f64, beats: f64, name: &str, a: f64, b: f64) {
        let n = (beats / Self::ROLL).round() as usize;
        for i in 0..n {
            let x = i as f64 / (n.max(2) - 1) as f64;
            self.strike(from + i as f64 * Self::ROLL, name, a + (b - a) * x);
        }
    }
}

/// Santoor: about 32 s at 90 bpm on a D scale (D E F# G A B C#).
fn santoor_tremolo() -> Vec<u8> {
    const BPM: f64 = 90.0;
    let mut m = Mallets { track: TrackBuilder::new(), stroke: 0 };
    m.track.tempo(0, BPM);

    // Opening, beats 0 to 12: single strokes and rolls, unmeasured in feel.
    m.strike(0.0, "D4", 0.55);
    m.strike(1.0, "A4", 0.45);
    m.strike(2.0, "D5", 0.5);
    m.roll(3.0, 2.0, "F#5", 0.2, 0.6);
    m.strike(5.0, "E5", 0.5);
    m.roll(6.0, 2.5, "D5", 0.3, 0.65);
    m.strike(8.5, "A4", 0.5);
    m.roll(9.0, 1.0, "B4", 0.5, 0.4);
    m.roll(10.0, 2.0, "A4", 0.45, 0.15);

    // A melody in rolls over a drone, beats 12 to 28.
    let melody: [(&str, f64); 12] = [
        ("D5", 1.0),
        ("E5", 1.0),
        ("F#5", 2.0),
        ("G5", 1.0),
        ("F#5", 1.0),
        ("E5", 1.0),
        ("D5", 1.0),
        ("E5", 2.0),
        ("C#5", 1.0),
        ("D5", 1.0),
        ("A4", 2.0),
        ("D5", 2.0),
    ];
    let mut beat = 12.0;
    for (i, &(name, beats)) in melody.iter().enumerate() {
        let rise = 0.45 + 0.25 * (std::f64::consts::PI * i as f64 / 11.0).sin();
        m.roll(beat, beats, name, rise, rise - 0.1);
        beat += beats;
    }
    for drone in [12.0, 16.0, 20.0, 24.0] {
        m.strike(drone, "D4", 0.5);
    }

    // Fast section, beats 28 to 44: each beat a melody stroke then drone strokes,
    // in sixteenths and, for the last four beats, in sextuplets.
    let tune = ["A5", "G5", "F#5", "E5", "F#5", "E5", "D5", "C#5", "D5", "E5", "F#5", "A5", "B5", "A5", "F#5", "E5"];
    for (i, &name) in tune.iter().enumerate() {
        let b = 28.0 + i as f64;
        let accent = 0.55 + 0.2 * f64::from(u8::from(i.is_multiple_of(4)));
        if i < 12 {
            m.strike(b, name, accent);
            m.strike(b + 0.25, "D4", 0.35);
            m.strike(b + 0.5, "A4", 0.4);
            m.strike(b + 0.75, "D4", 0.35);
        } else {
            m.strike(b, name, accent + 0.1);
            for s in 1..6 {
                let drone = if s % 2 == 1 { "D4" } else { "A4" };
                m.strike(b + s as f64 / 6.0, drone, 0.4 + 0.04 * s as f64);
            }
        }
    }

    // Close: a roll on D5 dying away, then D4 and D5 together, left to ring.
    m.roll(44.0, 3.0, "D5", 0.7, 0.15);
    m.strike(47.0, "D4", 0.6);
    m.strike(47.0, "D5", 0.5);
    smf_bytes(Format::SingleTrack, metrical(), &[m.track])
}

/// Fortepiano: sixteen bars of 4/4 at 126 bpm (about 31 s) in C major.
fn fortepiano_sonatina() -> Vec<u8> {
    const BPM: f64 = 126.0;
    let mut right = TrackBuilder::new();
    let mut left = TrackBuilder::new();
    right.tempo(0, BPM);
    // The left hand's Alberti figure for each bar's chord (low, high, middle, high).
    let chords: [[&str; 3]; 16] = [
        ["C3", "E3", "G3"],
        ["C3", "F3", "A3"],
        ["B2", "D3", "G3"],
        ["C3", "E3", "G3"],
        ["C3", "E3", "A3"],
        ["D3", "F3", "A3"],
        ["D3", "F#3", "A3"],
        ["B2", "D3", "G3"],
        ["B2", "D3", "G3"],
        ["C3", "E3", "G3"],
        ["A2", "C3", "F#3"],
        ["B2", "D3", "G3"],
        ["C3", "E3", "G3"],
        ["C3", "F3", "A3"],
        ["B2", "D3", "G3"],
        ["C3", "E3", "G3"],
    ];
    for (b, [low, mid, high]) in chords.iter().enumerate() {
        for beat in 0..4 {
            for (e, name) in [low, high, mid, high].iter().enumerate() {
                let on = 4.0 * b as f64 + beat as f64 + 0.25 * e as f64;
                let v = 42.0 + 6.0 * f64::from(u8::from(e == 0)) + 3.0 * scatter((16 * b + 4 * beat + e) as u64);
                left.note(ticks(on), ticks(0.22), key(name), velocity(v));
            }
        }
    }
    let melody: [(&str, f64); 40] = [
        // bars 1-4
        ("E5", 2.0),
        ("C5", 1.0),
        ("G5", 1.0),
        ("F5", 1.5),
        ("E5", 0.5),
        ("D5", 1.0),
        ("C5", 1.0),
        ("D5", 1.0),
        ("G4", 1.0),
        ("B4", 1.0),
        ("D5", 1.0),
        ("C5", 4.0),
        // bars 5-8: toward G major
        ("A5", 1.5),
        ("G5", 0.5),
        ("E5", 1.0),
        ("C5", 1.0),
        ("A5", 1.0),
        ("F5", 1.0),
        ("D5", 2.0),
        ("F#5", 1.0),
        ("A5", 1.0),
        ("D6", 1.0),
        ("C6", 1.0),
        ("B5", 4.0),
        // bars 9-12
        ("D5", 1.0),
        ("G5", 1.0),
        ("B5", 1.0),
        ("G5", 1.0),
        ("E5", 2.0),
        ("C6", 2.0),
        ("A5", 1.0),
        ("F#5", 1.0),
        ("D5", 1.0),
        ("C5", 1.0),
        ("B4", 4.0),
        // bars 13-16: home
        ("G5", 2.0),
        ("E5", 2.0),
        ("F5", 2.0),
        ("D5", 2.0),
        ("C5", 8.0),
    ];
    // Sforzando on the first beat of bars 5 and 9, a diminuendo to the close.
    let mut beat = 0.0;
    for (i, &(name, beats)) in melody.iter().enumerate() {
        let sf = beat == 16.0 || beat == 32.0;
        let fade = if beat >= 48.0 { (beat - 48.0) * 4.0 } else { 0.0 };
        let v = if sf { 112.0 } else { 70.0 + 8.0 * scatter(i as u64) - fade };
        right.note(ticks(beat), ticks(beats * 0.9), key(name), velocity(v));
        beat += beats;
    }
    // The knee lever under the last two bars.
    right.cc(ticks(56.0), 64, 127).cc(ticks(63.5), 64, 0);
    smf_bytes(Format::Parallel, metrical(), &[right, left])
}

/// Hammered dulcimer: a reel in D at 104 bpm, 16 bars of 2/2 plus a final
/// stroke (about 38 s). Two mallets alternate on eighth notes; the drones sound on
/// the beats.
fn dulcimer_reel() -> Vec<u8> {
    const BPM: f64 = 104.0;
    let mut m = Mallets { track: TrackBuilder::new(), stroke: 0 };
    m.track.tempo(0, BPM);
    // Four bars of eighth notes, played twice (A part) and the B part twice.
    let a_part = [
        "D5", "F#5", "A5", "F#5", "D5", "F#5", "A5", "F#5", "E5", "G5", "B5", "G5", "E5", "G5", "B5", "A5", "D5",
        "F#5", "A5", "D6", "C#6", "A5", "B5", "A5", "G5", "E5", "C#5", "E5", "D5", "D5", "D5", "A4",
    ];
    let b_part = [
        "A5", "B5", "A5", "F#5", "D5", "E5", "F#5", "A5", "G5", "A5", "B5", "G5", "E5", "F#5", "G5", "B5", "A5", "F#5",
        "D6", "F#5", "A5", "F#5", "E5", "D5", "E5", "C#5", "A4", "C#5", "D5", "F#5", "D5", "D5",
    ];
    let mut beat = 0.0;
    for (pass, tune) in [a_part, a_part, b_part, b_part].iter().enumerate() {
        for (i, name) in tune.iter().enumerate() {
            let accent = if i % 4 == 0 { 0.62 } else { 0.45 };
            m.strike(beat + 0.5 * i as f64, name, accent + 0.04 * pass as f64);
            if i % 4 == 0 {
                m.strike(beat + 0.5 * i as f64, if i % 8 == 0 { "D4" } else { "A3" }, 0.35);
            }
        }
        beat += 16.0;
    }
    m.roll(64.0, 2.0, "D5", 0.6, 0.2);
    m.strike(64.0, "D4", 0.6);
    m.strike(64.0, "A4", 0.45);
    smf_bytes(Format::SingleTrack, metrical(), &[m.track])
}

/// Cimbalom: a lassu (slow, 60 bpm, pedal down) and a friss (fast, 132 bpm, pedal
/// up) in A minor, about 36 s.
fn cimbalom_csardas() -> Vec<u8> {
    let mut m = Mallets { track: TrackBuilder::new(), stroke: 0 };
    m.track.tempo(0, 60.0);
    // Lassu, beats 0 to 16 at 60 bpm: the pedal down; arpeggiated chords and rolls.
    m.track.cc(0, 64, 127);
    let chords: [[&str; 4]; 4] =
        [["A2", "E3", "A3", "C4"], ["D3", "A3", "D4", "F4"], ["E2", "B2", "E3", "G#3"], ["A2", "E3", "A3", "C4"]];
    for (c, chord) in chords.iter().enumerate() {
        let at = 4.0 * c as f64;
        for (i, name) in chord.iter().enumerate() {
            m.strike(at + 0.2 * i as f64, name, 0.4 + 0.05 * i as f64);
        }
    }
    let song: [(&str, f64); 8] =
        [("E5", 2.0), ("C5", 1.0), ("B4", 1.0), ("A4", 2.0), ("F5", 2.0), ("E5", 3.0), ("D5", 1.0), ("C5", 4.0)];
    let mut beat = 0.0;
    for &(name, beats) in &song {
        m.roll(beat + 0.5, beats - 0.25, name, 0.35, 0.55);
        beat += beats;
    }
    // Friss from beat 16 at 132 bpm (tick positions continue in beats): pedal up.
    m.track.tempo(ticks(16.0), 132.0);
    m.track.cc(ticks(16.0) - 10, 64, 0);
    let tune = [
        "A4", "C5", "E5", "A5", "G#5", "A5", "B5", "A5", "F5", "E5", "D5", "C5", "B4", "C5", "D5", "B4", "A4", "C5",
        "E5", "A5", "B5", "C6", "B5", "A5", "G#5", "E5", "F5", "D5", "E5", "B4", "C5", "A4",
    ];
    for round in 0..2 {
        for (i, name) in tune.iter().enumerate() {
            let b = 16.0 + 16.0 * round as f64 + 0.5 * i as f64;
            m.strike(b, name, 0.55 + 0.1 * f64::from(u8::from(i % 2 == 0)) + 0.1 * round as f64);
            if i % 2 == 0 {
                let bass = if (i / 4) % 2 == 0 { "A2" } else { "E2" };
                m.strike(b, bass, 0.45);
                m.strike(b + 0.5, "E3", 0.35);
                m.strike(b + 0.5, "A3", 0.35);
            }
        }
    }
    // Final chord with the pedal down, left to ring.
    m.track.cc(ticks(47.5), 64, 127);
    // Final chord, spread from the bass up as a cimbalom player rolls it.
    for (i, name) in ["A2", "E3", "A3", "C4", "E4", "A4"].iter().enumerate() {
        m.strike(48.0 + 0.06 * i as f64, name, 0.45);
    }
    m.track.cc(ticks(52.0), 64, 0);
    smf_bytes(Format::SingleTrack, metrical(), &[m.track])
}

/// Clavichord: ten bars of 4/4 at 80 bpm, soft (velocities 30 to 70).
fn clavichord_two_part() -> Vec<u8> {
    const BPM: f64 = 80.0;
    let subject: [(&str, f64); 10] = [
        ("A4", 0.25),
        ("B4", 0.25),
        ("C5", 0.25),
        ("D5", 0.25),
        ("E5", 0.5),
        ("C5", 0.5),
        ("A4", 0.5),
        ("E5", 0.5),
        ("D5", 0.5),
        ("C5", 0.5),
    ];
    let counter: [(&str, f64); 7] =
        [("E5", 1.0), ("D5", 0.5), ("C5", 0.5), ("B4", 0.5), ("C5", 0.25), ("D5", 0.25), ("E5", 1.0)];
    let mut upper = TrackBuilder::new();
    let mut lower = TrackBuilder::new();
    upper.tempo(0, BPM);
    // A phrase shape: louder towards the middle of a four-beat bar.
    let shape = |base: f64, n: usize| move |i: usize| base + 12.0 * (std::f64::consts::PI * i as f64 / n as f64).sin();
    {
        let mut u = Line::at(&mut upper, 0.0, 0.92);
        u.play(&subject, 0, shape(50.0, 10)); // bar 1
        u.play(&counter, 0, shape(48.0, 7)); // bar 2
        u.play(&subject, 5, shape(52.0, 10)); // bar 3: D minor
        u.play(&counter, 5, shape(50.0, 7)); // bar 4
        u.play(&subject, 7, shape(54.0, 10)); // bar 5: E minor
        u.play(&counter, 7, shape(52.0, 7)); // bar 6
        u.play(&subject, 0, shape(50.0, 10)); // bar 7: home
        let descent =
            [("E5", 0.5), ("D5", 0.5), ("C5", 0.5), ("B4", 0.5), ("A4", 0.5), ("G#4", 0.5), ("A4", 0.5), ("B4", 0.5)];
        u.play(&descent, 0, |i| 50.0 - 1.5 * i as f64); // bar 8
        u.play(&[("C5", 1.0), ("B4", 1.0), ("A4", 1.0), ("G#4", 1.0)], 0, |i| 44.0 - 2.0 * i as f64); // bar 9
        u.play(&[("A4", 4.0)], 0, |_| 36.0); // bar 10
    }
    // Bebung: the finger rocks on the long notes of bars 9 and 10, about five
    // times a second, deepening and then easing off.
    for (from, beats) in [(32.0, 1.0), (33.0, 1.0), (34.0, 1.0), (35.0, 1.0), (36.0, 4.0)] {
        let steps = (beats * 16.0) as usize;
        for i in 0..steps {
            let t = from + i as f64 / 16.0;
            let depth = (std::f64::consts::PI * i as f64 / steps as f64).sin();
            let rock = 0.5 + 0.5 * (2.0 * std::f64::consts::PI * 5.0 * (t - from) * 60.0 / BPM).sin();
            upper.pressure(ticks(t), velocity(10.0 + 100.0 * depth * rock));
        }
        upper.pressure(ticks(from + beats) - 1, 0);
    }
    {
        let mut l = Line::at(&mut lower, 4.0, 0.92);
        l.play(&subject, -12, shape(40.0, 10)); // bar 2
        l.play(&counter, 5 - 24, shape(40.0, 7)); // bar 3
        l.play(&subject, 5 - 12, shape(42.0, 10)); // bar 4
        l.play(&counter, 7 - 24, shape(42.0, 7)); // bar 5
        l.play(&subject, 7 - 12, shape(44.0, 10)); // bar 6
        l.play(&counter, -24, shape(40.0, 7)); // bar 7
        l.play(&[("A3", 2.0), ("E3", 2.0)], 0, |_| 40.0); // bar 8
        l.play(&[("F3", 2.0), ("E3", 2.0)], 0, |i| 38.0 - 2.0 * i as f64); // bar 9
        l.play(&[("A2", 4.0)], 0, |_| 32.0); // bar 10
    }
    smf_bytes(Format::Parallel, metrical(), &[upper, lower])
}

/// Harpsichord: twelve bars of broken chords in sixteenths at 84 bpm, and a final chord.
fn harpsichord_prelude() -> Vec<u8> {
    const BPM: f64 = 84.0;
    // Each bar's chord, lowest first: the bass and tenor are held, the upper three broken.
    let bars: [[&str; 5]; 12] = [
        ["D3", "A3", "D4", "F#4", "A4"],
        ["D3", "B3", "D4", "G4", "B4"],
        ["C#3", "A3", "E4", "G4", "A4"],
        ["D3", "A3", "D4", "F#4", "A4"],
        ["B2", "F#3", "B3", "D4", "F#4"],
        ["G2", "G3", "B3", "E4", "G4"],
        ["A2", "G3", "D4", "E4", "A4"],
        ["A2", "G3", "C#4", "E4", "A4"],
        ["F#2", "A3", "D4", "F#4", "A4"],
        ["G2", "B3", "D4", "G4", "B4"],
        ["A2", "G3", "C#4", "E4", "G4"],
        ["D2", "A3", "D4", "F#4", "D5"],
    ];
    let mut t = TrackBuilder::new();
    t.tempo(0, BPM);
    // Sixteenths of a half bar: the chord tones in this order.
    const FIGURE: [usize; 8] = [0, 1, 2, 3, 4, 2, 3, 4];
    let last = bars.len() - 1;
    for (b, chord) in bars.iter().enumerate() {
        for half in 0..2 {
            let start = 4.0 * b as f64 + 2.0 * half as f64;
            if b == last && half == 1 {
                // The close: the whole chord together, held.
                for &note in chord {
                    t.note(ticks(start), ticks(3.0), key(note), 90);
                }
                continue;
            }
            for (s, &tone) in FIGURE.iter().enumerate() {
                let on = start + 0.25 * s as f64;
                // Held until the tone is struck again, or to the end of the half bar.
                let again = FIGURE[s + 1..].iter().position(|&x| x == tone);
                let off = match again {
                    Some(d) => on + 0.25 * (d + 1) as f64,
                    None => start + 2.0,
                };
                let v = 80.0 + 8.0 * f64::from(u8::from(s == 0)) + 4.0 * scatter((16 * b + 8 * half + s) as u64);
                t.note(ticks(on), ticks(off - on) - 5, key(chord[tone]), velocity(v));
            }
        }
    }
    smf_bytes(Format::SingleTrack, metrical(), &[t])
}

#[cfg(test)]
mod tests {
    use super::*;
    use struck_engine::design::InstrumentKind;

    /// Each song is 20 to 40 s long and every note is on its instrument's keys.
    #[test]
    fn songs_fit_their_instruments() {
        for (name, bytes) in all() {
            let smf = midly::Smf::parse(&bytes).unwrap();
            let kind: InstrumentKind = name.split('-').next().unwrap().parse().unwrap();
            let midly::Timing::Metrical(tpq) = smf.header.timing else { panic!("{name}: metrical timing") };
            let tpq = f64::from(tpq.as_int());
            let mut tempo_us = 500_000.0;
            let mut end_s: f64 = 0.0;
            let mut notes = 0;
            for track in &smf.tracks {
                let (mut tick, mut seconds) = (0u64, 0.0);
                for event in track {
                    let delta = u64::from(event.delta.as_int());
                    tick += delta;
                    seconds += delta as f64 / tpq * tempo_us / 1e6;
                    match event.kind {
                        midly::TrackEventKind::Meta(midly::MetaMessage::Tempo(us)) => tempo_us = f64::from(us.as_int()),
                        midly::TrackEventKind::Midi { message: midly::MidiMessage::NoteOn { key, .. }, .. } => {
                            assert!(kind.key_range().contains(&key.as_int()), "{name}: key {key} at tick {tick}");
                            notes += 1;
                        }
                        _ => {}
                    }
                    end_s = end_s.max(seconds);
                }
            }
            assert!((20.0..=40.0).contains(&end_s), "{name} lasts {end_s} s");
            assert!(notes > 50, "{name}: {notes} notes");
        }
    }
}
