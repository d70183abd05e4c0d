//! Property-based fuzzing of the event stream into the synth: any events, with
//! any values (NaN, infinities, out of range, keys past 127), at any times
//! (events stamped past the block's end included), in blocks of 1 to 4096
//! samples, on every instrument. The synth never panics and its output stays
//! finite, bounded and free of subnormals. `STRUCK_FUZZ_CASES` raises the number
//! of sessions for a longer run.

mod support;

use proptest::prelude::*;
use struck_engine::design::InstrumentKind;
use struck_engine::synth::{Event, Instrument, Synth, TimedEvent, default_settings};

use support::config;

/// Sessions by default: each builds an instrument (the costly part), so few.
const SESSIONS: u32 = 24;

/// Largest sample accepted: full scale is 1, and the loudest chord of the
/// loudest instrument stays within a few times that.
const BOUND: f32 = 100.0;

/// A value as a host or a file might send it: in range, at its edges, a little
/// or far outside, or not a number at all.
fn value() -> impl Strategy<Value = f32> {
    prop_oneof![
        4 => 0.0f32..=1.0,
        1 => -1.0f32..=1.0,
        1 => prop_oneof![
            Just(0.0f32), Just(-0.0), Just(1.0), Just(-1.0), Just(0.5), Just(1e-45), Just(f32::MIN_POSITIVE),
            Just(f32::MAX), Just(f32::MIN), Just(f32::INFINITY), Just(f32::NEG_INFINITY), Just(f32::NAN),
        ],
        1 => any::<f32>(),
    ]
}

/// A key: mostly ones the instruments have, sometimes any byte.
fn key() -> impl Strategy<Value = u8> {
    prop_oneof![6 => 21u8..=108, 1 => any::<u8>()]
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        6 => (key(), value()).prop_map(|(key, velocity)| Event::NoteOn { key, velocity: f64::from(velocity) }),
        4 => (key(), value()).prop_map(|(key, velocity)| Event::NoteOff { key, velocity: f64::from(velocity) }),
        1 => value().prop_map(Event::Sustain),
        1 => value().prop_map(Event::Sostenuto),
        1 => value().prop_map(Event::UnaCorda),
        1 => value().prop_map(Event::ModWheel),
        1 => value().prop_map(Event::PitchBend),
        1 => (key(), value()).prop_map(|(key, pressure)| Event::Pressure { key, pressure }),
        1 => Just(Event::AllNotesOff),
        1 => Just(Event::Reset),
    ]
}

/// One host block: its length and its events, sorted by time (some stamped
/// past the block's end, which the synth applies at its end).
fn block() -> impl Strategy<Value = (usize, Vec<TimedEvent>)> {
    let length = prop_oneof![Just(1usize), Just(7), Just(64), Just(512), Just(4096), 1usize..=4096];
    length.prop_flat_map(|n| {
        let timed = (0..(n as u32 + n as u32 / 4 + 1), event()).prop_map(|(t, e)| TimedEvent::new(t, e));
        (Just(n), proptest::collection::vec(timed, 0..12)).prop_map(|(n, mut events)| {
            events.sort_by_key(|e| e.time);
            (n, events)
        })
    })
}

/// Every sample finite, within [`BOUND`], and not subnormal.
fn sound(samples: &[f32], at: usize) -> Result<(), TestCaseError> {
    for (i, s) in samples.iter().enumerate() {
        prop_assert!(s.is_finite() && s.abs() < BOUND && !s.is_subnormal(), "sample {s} at {}", at + i);
    }
    Ok(())
}

proptest! {
    #![proptest_config(config(SESSIONS))]

    #[test]
    fn any_event_stream_gives_finite_bounded_sound(
        kind in proptest::sample::select(InstrumentKind::ALL.to_vec()),
        sample_rate_hz in proptest::sample::select(vec![22_050.0, 48_000.0]),
        blocks in proptest::collection::vec(block(), 1..32),
    ) {
        let instrument = Instrument::build(&default_settings(kind, sample_rate_hz)).expect("an instrument as built");
        let (mut synth, _scope) = Synth::new(Box::new(instrument));
        let (mut left, mut right) = (vec![0.0f32; 4096], vec![0.0f32; 4096]);
        let mut at = 0;
        for (n, events) in &blocks {
            synth.process(events, &mut left[..*n], &mut right[..*n]);
            sound(&left[..*n], at)?;
            sound(&right[..*n], at)?;
            at += n;
        }
        // Then a second of ringing out, whatever was left down.
        for _ in 0..(sample_rate_hz as usize / 4096) {
            synth.process(&[], &mut left, &mut right);
            sound(&left, at)?;
            sound(&right, at)?;
            at += 4096;
        }
    }
}

/// One block of `events` on a piano at 22.05 kHz, then a quarter of a second:
/// every sample as [`sound`] asks.
fn plays_cleanly(events: &[TimedEvent]) {
    let instrument = Instrument::build(&default_settings(InstrumentKind::Piano, 22_050.0)).expect("a piano");
    let (mut synth, _scope) = Synth::new(Box::new(instrument));
    let (mut left, mut right) = (vec![0.0f32; 512], vec![0.0f32; 512]);
    for block in 0..12 {
        synth.process(if block == 0 { events } else { &[] }, &mut left, &mut right);
        for s in left.iter().chain(&right) {
            assert!(s.is_finite() && s.abs() < BOUND && !s.is_subnormal(), "sample {s} in block {block}");
        }
    }
}

/// Found by the fuzzing above: a note-on at velocity NaN struck the key at a
/// NaN speed, and every sample after it was NaN.
#[test]
fn a_note_on_at_velocity_nan_is_ignored() {
    plays_cleanly(&[TimedEvent::new(0, Event::NoteOn { key: 28, velocity: f64::NAN })]);
    plays_cleanly(&[
        TimedEvent::new(0, Event::NoteOn { key: 60, velocity: f64::INFINITY }),
        TimedEvent::new(3, Event::NoteOn { key: 64, velocity: f64::NEG_INFINITY }),
    ]);
}

/// Found beside the one above (the same kind of value, one event further): a
/// pitch bend of NaN made the bend ratio NaN, and every key sounding or struck
/// after it NaN.
#[test]
fn a_pitch_bend_of_nan_is_ignored() {
    plays_cleanly(&[
        TimedEvent::new(0, Event::NoteOn { key: 60, velocity: 0.8 }),
        TimedEvent::new(1, Event::PitchBend(f32::NAN)),
        TimedEvent::new(2, Event::NoteOn { key: 67, velocity: 0.8 }),
    ]);
}
