//! Property-based fuzzing of the files a user hands the lab: standard MIDI
//! files (`struck render`) and strike cases (`struck strike`).
//!
//! Inputs are valid files damaged at random (bytes flipped, cut, inserted,
//! removed, repeated; a JSON value replaced, removed or added anywhere in a
//! case's tree; `--set` edits) and random bytes behind a valid header.
//! Whatever comes in, a reader never panics; a refusal is one line of text;
//! what it accepts holds only finite numbers. `STRUCK_FUZZ_CASES` raises the
//! number of cases per property for a longer run.

#[path = "../../engine/tests/support/mod.rs"]
mod support;

use proptest::prelude::*;
use serde_json::Value;
use struck_engine::synth::Event;
use struck_lab::midi_file::{self, MAX_SONG_S, ReadOptions};
use struck_lab::strike::{ExciterSpec, StrikeCase, parse_case};

use support::{config, mutated, one_line, tweak};

/// Cases per property by default: the file runs in under two seconds in release.
const CASES: u32 = 20_000;

/// The test suite's MIDI files: every format and timing the reader knows and
/// every event it plays, some of them refused (format 2, no notes).
const MIDI_FILES: &[&[u8]] = &[
    include_bytes!("../../tests/data/midi/a0.mid"),
    include_bytes!("../../tests/data/midi/a4-bend-up.mid"),
    include_bytes!("../../tests/data/midi/a4.mid"),
    include_bytes!("../../tests/data/midi/c4-release-dry.mid"),
    include_bytes!("../../tests/data/midi/c4-release-pedal.mid"),
    include_bytes!("../../tests/data/midi/channel-10-only.mid"),
    include_bytes!("../../tests/data/midi/chord-all-sound-off.mid"),
    include_bytes!("../../tests/data/midi/d2-channel-pressure.mid"),
    include_bytes!("../../tests/data/midi/d2-poly-pressure.mid"),
    include_bytes!("../../tests/data/midi/format-2.mid"),
    include_bytes!("../../tests/data/midi/no-notes.mid"),
    include_bytes!("../../tests/data/midi/smpte-25fps.mid"),
    include_bytes!("../../tests/data/midi/tempo-map.mid"),
];

/// The sample rates songs are read at.
const SAMPLE_RATES: &[u32] = &[8_000, 22_050, 44_100, 48_000, 96_000, 192_000, 768_000];

/// A format-1 file of two tracks with running status, a SysEx, a tempo change
/// and every controller the reader answers: the seed the random tracks grow from.
fn rich_midi() -> Vec<u8> {
    let track = |events: &[u8]| {
        let mut chunk = b"MTrk".to_vec();
        chunk.extend((events.len() as u32).to_be_bytes());
        chunk.extend(events);
        chunk
    };
    let mut bytes = b"MThd\0\0\0\x06\0\x01\0\x02\x01\xe0".to_vec();
    bytes.extend(track(&[
        0x00, 0xff, 0x51, 0x03, 0x07, 0xa1, 0x20, // tempo 500000 us
        0x00, 0xf0, 0x03, 0x43, 0x12, 0xf7, // SysEx
        0x60, 0xff, 0x51, 0x03, 0x03, 0xd0, 0x90, // tempo 250000 us
        0x00, 0xff, 0x2f, 0x00,
    ]));
    bytes.extend(track(&[
        0x00, 0x90, 0x3c, 0x64, // C4 on
        0x10, 0x40, 0x50, // running status: E4 on
        0x10, 0xb0, 0x40, 0x7f, // sustain
        0x00, 0x42, 0x7f, 0x00, 0x43, 0x40, 0x00, 0x01, 0x40, // sostenuto, una corda, mod wheel
        0x10, 0xe0, 0x00, 0x60, // bend
        0x10, 0xa0, 0x3c, 0x50, 0x00, 0xd0, 0x7f, // poly and channel pressure
        0x10, 0x80, 0x3c, 0x20, 0x00, 0x90, 0x40, 0x00, // offs
        0x10, 0xb0, 0x79, 0x00, 0x00, 0x7b, 0x00, 0x00, 0x78, 0x00, // resets
        0x00, 0xff, 0x2f, 0x00,
    ]));
    bytes
}

fn midi_seeds() -> Vec<Vec<u8>> {
    MIDI_FILES.iter().map(|f| f.to_vec()).chain([rich_midi()]).collect()
}

/// A song read, or refused in one line; what is read is in order, within the
/// longest song, and carries only finite values.
fn song(bytes: &[u8], sample_rate_hz: u32, include_channel_10: bool) -> Result<(), TestCaseError> {
    let song = match midi_file::read(bytes, sample_rate_hz, ReadOptions { include_channel_10, mpe_bend_range: None }) {
        Ok(song) => song,
        Err(e) => return one_line(&e.to_string()),
    };
    prop_assert!(song.note_count() > 0);
    prop_assert!(song.events.windows(2).all(|w| w[0].0 <= w[1].0), "events out of order");
    let longest = (MAX_SONG_S * f64::from(sample_rate_hz)).ceil() as u64 + 1;
    prop_assert!(song.last_sample() <= longest, "{} samples is past the longest song", song.last_sample());
    for (_, event) in &song.events {
        let (key, values) = match *event {
            Event::NoteOn { key, velocity } => (key, [velocity as f32, 1.0]),
            Event::NoteOff { key, velocity } => (key, [velocity as f32, 0.0]),
            Event::Pressure { key, pressure } => (key, [pressure, 0.0]),
            Event::Sustain(v) | Event::Sostenuto(v) | Event::UnaCorda(v) | Event::ModWheel(v) => (0, [v, 0.0]),
            Event::PitchBend(v) => (0, [v.abs(), 0.0]),
            // An MPE note's bend, up to its range (96 semitones at most).
            Event::KeyBend { key, semitones } => (key, [semitones.abs() / 96.0, 0.0]),
            Event::KeyVolume { key, gain } => (key, [gain / 16.0, 0.0]),
            Event::KeyHammer { key, hardness, position } => (key, [hardness / 16.0, position / 16.0]),
            Event::KeyPan { key, pan } => (key, [pan.abs(), 0.0]),
            Event::AllNotesOff | Event::Reset => (0, [0.0, 0.0]),
        };
        prop_assert!(key < 128 && values.iter().all(|v| (0.0..=1.0).contains(v)), "{event:?}");
    }
    Ok(())
}

/// Strike cases: the specification's example and the reference cases, one of
/// each exciter and each way of giving a string.
const CASE_FILES: &[&str] = &[
    include_str!("../../cases/santoor-a4.json"),
    include_str!("../../tests/data/reference/K2.json"),
    include_str!("../../tests/data/reference/P4_V2p5.json"),
    include_str!("../../tests/data/reference/S1.json"),
    include_str!("../../tests/data/reference/devC7.json"),
    r#"{"sample_rate_hz": 44100, "duration_s": 0.1,
        "string": {"length_m": 0.5, "f1_hz": 220, "mass_per_length_kg_m": 0.002,
                   "internal_loss_factor": 1e-4, "bridge_admittance_s_kg": 1e-4},
        "exciter": {"kind": "pluck", "displacement_m": 0.001, "position": 0.2}}"#,
    r#"{"sample_rate_hz": 48000, "duration_s": 0.2,
        "string": {"length_m": 0.6, "tension_n": 600, "diameter_m": 0.001, "core_diameter_m": 0.0008,
                   "density_kg_m3": 7850, "youngs_modulus_pa": 2e11, "max_frequency_hz": 8000},
        "exciter": {"kind": "hammer", "mass_kg": 0.008, "stiffness": 1e9, "exponent": 2.5,
                    "speed_m_s": 3, "position": 0.12, "hysteresis": {"epsilon": 0.2, "tau_s": 2e-5}}}"#,
];

/// A case's field names, for tweaks that add a field and for `--set` paths.
static CASE_FIELDS: std::sync::LazyLock<Vec<&'static str>> =
    std::sync::LazyLock::new(struck_lab::strike::case::field_names);

fn case_seeds() -> Vec<Value> {
    CASE_FILES.iter().map(|t| serde_json::from_str(t).expect("a case file is JSON")).collect()
}

/// A case read, or refused in one line; what is read is finite and builds its string.
fn case(text: &str, sets: &[String]) -> Result<(), TestCaseError> {
    let case = match parse_case(text, sets) {
        Ok(case) => case,
        Err(e) => return one_line(&e.to_string()),
    };
    accepted(&case)
}

fn accepted(case: &StrikeCase) -> Result<(), TestCaseError> {
    prop_assert!(case.sample_rate_hz.is_finite() && case.duration_s.is_finite(), "{case:?}");
    prop_assert!(case.sample_count() >= 1);
    let exciter = match case.exciter {
        ExciterSpec::Hammer(h) => vec![h.mass_kg, h.law.stiffness, h.law.exponent, h.speed_m_s, h.position],
        ExciterSpec::Tangent(t) => vec![t.speed_m_s, t.displacement_m],
        ExciterSpec::Pluck(p) => vec![p.displacement_m, p.position],
    };
    prop_assert!(exciter.iter().all(|v| v.is_finite() && *v > 0.0), "{case:?}");
    let s = case.build_string();
    let derived = [s.length_m, s.tension_n, s.mass_per_length_kg_m, s.bending_stiffness_n_m2, s.inharmonicity, s.f0_hz];
    prop_assert!(derived.iter().all(|v| v.is_finite() && *v >= 0.0), "{s:?}");
    prop_assert!(!s.modes.is_empty());
    for m in &s.modes {
        prop_assert!(m.omega_rad_s.is_finite() && m.omega_rad_s > 0.0 && m.wavenumber_rad_m.is_finite(), "{m:?}");
        prop_assert!(m.q > 0.5, "{m:?}");
    }
    Ok(())
}

/// A `--set` edit: a field path (known names, an index, odd text) and a value.
fn set_edit() -> impl Strategy<Value = String> {
    let part = prop_oneof![
        proptest::sample::select(CASE_FIELDS.as_slice()).prop_map(str::to_string),
        "[0-9]{1,2}",
        "\\PC{0,6}",
    ];
    let value = prop_oneof![
        "-?[0-9]{1,4}(\\.[0-9]{1,3})?(e-?[0-9]{1,3})?",
        Just("1e999".to_string()),
        Just("[]".to_string()),
        Just("{}".to_string()),
        "\\PC{0,10}",
    ];
    (proptest::collection::vec(part, 0..4), value).prop_map(|(path, value)| format!("{}={value}", path.join(".")))
}

proptest! {
    #![proptest_config(config(CASES))]

    #[test]
    fn a_damaged_midi_file_is_read_or_refused_in_one_line(
        bytes in mutated(midi_seeds()),
        sample_rate_hz in proptest::sample::select(SAMPLE_RATES),
        include_channel_10 in any::<bool>(),
    ) {
        song(&bytes, sample_rate_hz, include_channel_10)?;
    }

    #[test]
    fn random_track_bytes_are_read_or_refused_in_one_line(
        division in prop_oneof![any::<u16>(), 1u16..960, Just(0xe728u16)],
        events in proptest::collection::vec(any::<u8>(), 0..400),
        sample_rate_hz in proptest::sample::select(SAMPLE_RATES),
    ) {
        let mut bytes = b"MThd\0\0\0\x06\0\0\0\x01".to_vec();
        bytes.extend(division.to_be_bytes());
        bytes.extend(b"MTrk");
        bytes.extend((events.len() as u32).to_be_bytes());
        bytes.extend(&events);
        song(&bytes, sample_rate_hz, true)?;
    }

    #[test]
    fn a_damaged_strike_case_is_read_or_refused_in_one_line(
        bytes in mutated(CASE_FILES.iter().map(|t| t.as_bytes().to_vec()).collect()),
    ) {
        case(&String::from_utf8_lossy(&bytes), &[])?;
    }

    #[test]
    fn a_strike_case_with_odd_values_is_read_or_refused_in_one_line(
        seed in proptest::sample::select(case_seeds()),
        tweaks in proptest::collection::vec(tweak(CASE_FIELDS.as_slice()), 1..6),
    ) {
        case(&support::apply(seed, &tweaks).to_string(), &[])?;
    }

    #[test]
    fn random_set_edits_are_applied_or_refused_in_one_line(
        text in proptest::sample::select(CASE_FILES),
        sets in proptest::collection::vec(set_edit(), 1..4),
    ) {
        case(text, &sets)?;
    }
}

/// Found by the fuzzing above: a case's unknown field name, or an unknown
/// exciter kind, was quoted raw, so a line break in it made a two-line
/// refusal and a control character reached the terminal.
#[test]
fn a_case_field_name_with_a_line_break_is_refused_in_one_line() {
    let seed = CASE_FILES[0];
    let cases = [
        seed.replacen("\"name\"", "\"\\n\"", 1),
        seed.replacen("\"hammer\"", "\"\\u007fammer\"", 1),
        seed.replacen("\"q\"", "\"q\\r\\n\"", 1),
    ];
    for text in &cases {
        let message = parse_case(text, &[]).expect_err("an unknown field or kind").to_string();
        assert!(!message.contains(char::is_control), "{message:?}");
    }
    let message = parse_case(seed, &["string.q\u{1b}=1".into()]).expect_err("an unknown field").to_string();
    assert!(!message.contains(char::is_control), "{message:?}");
}

/// Found by the fuzzing above in a debug build (the one `cargo xtask test`
/// runs; a release build wraps silently): SMPTE timing at -128 frames per
/// second, the division's high byte 0x80, was negated as an i8, which
/// overflows, and the reader panicked.
#[test]
fn an_smpte_division_of_minus_128_frames_is_refused_in_one_line() {
    let bytes = b"MThd\0\0\0\x06\0\0\0\x01\x80\x28MTrk\0\0\0\x04\0\xff\x2f\0";
    let message = midi_file::read(bytes, 48_000, ReadOptions::default()).expect_err("no such frame rate").to_string();
    assert!(message.contains("128 frames per second"), "{message}");
}
