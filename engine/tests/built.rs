//! Instruments kept as built: a second build of the same settings is a copy of
//! the first, which plays as a build afresh, and only the same settings at the
//! same sample rate find it.

use struck_engine::design::InstrumentKind;
use struck_engine::synth::{Event, Instrument, InstrumentSettings, Synth, TimedEvent, built, default_settings};

const BLOCK: usize = 256;

/// A chord struck with the sustain pedal down (the strings that ring free
/// trade through the body), rendered for `seconds`.
fn chord(instrument: Instrument, seconds: f64) -> Vec<f32> {
    let fs = instrument.settings().sample_rate_hz;
    let (mut synth, _scope) = Synth::new(Box::new(instrument));
    let (mut left, mut right) = (vec![0.0f32; BLOCK], vec![0.0f32; BLOCK]);
    let mut out = Vec::new();
    for b in 0..(seconds * fs / BLOCK as f64).ceil() as usize {
        let events = if b == 0 {
            vec![
                TimedEvent::new(0, Event::Sustain(1.0)),
                TimedEvent::new(5, Event::NoteOn { key: 48, velocity: 0.8 }),
                TimedEvent::new(5, Event::NoteOn { key: 64, velocity: 0.6 }),
                TimedEvent::new(9, Event::NoteOn { key: 79, velocity: 0.7 }),
            ]
        } else {
            Vec::new()
        };
        synth.process(&events, &mut left, &mut right);
        out.extend(left.iter().zip(&right).flat_map(|(l, r)| [*l, *r]));
    }
    out
}

fn build(settings: &InstrumentSettings) -> Instrument {
    Instrument::build(settings).expect("the built-in instruments build")
}

#[test]
fn a_kept_instrument_plays_as_one_built_afresh_and_only_for_its_own_settings() {
    // (One test: the instruments kept are the process's, and the harness runs
    // tests side by side.)
    let piano = default_settings(InstrumentKind::Piano, 48_000.0);
    let afresh = chord(Instrument::build_afresh(&piano).expect("a piano"), 0.6);
    assert!(afresh.iter().any(|s| s.abs() > 1e-3), "the chord sounds");
    built::forget();
    let first = chord(build(&piano), 0.6);
    let kept = chord(build(&piano), 0.6);
    // The first takes the voicing that came with the program: found on a
    // machine whose kernels may round otherwise than this one's, so the same
    // to within rounding (on the machine it was found on, the same bits).
    let most = first.iter().zip(&afresh).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max);
    assert!(first.len() == afresh.len() && most <= 1e-6, "the first build plays as one afresh: {most}");
    assert!(kept == first, "the kept copy plays as the first");

    // Another rate, or other settings, is another instrument.
    let harpsichord = default_settings(InstrumentKind::Harpsichord, 48_000.0);
    let at_48k = chord(build(&harpsichord), 0.3);
    let at_44k = chord(build(&InstrumentSettings { sample_rate_hz: 44_100.0, ..harpsichord.clone() }), 0.3);
    assert_eq!(
        build(&InstrumentSettings { sample_rate_hz: 44_100.0, ..harpsichord.clone() }).settings().sample_rate_hz,
        44_100.0
    );
    assert!(at_44k.len() != at_48k.len() || at_44k != at_48k);
    let mut damped = harpsichord.clone();
    damped.voicing.damping *= 2.0;
    let more_damped = chord(build(&damped), 0.3);
    assert!(more_damped != at_48k, "other settings find another instrument");
    assert!(chord(build(&harpsichord), 0.3) == at_48k, "the first settings still find theirs");
    // Only a few are kept, however many settings are built.
    for size in [0.8, 0.9, 1.1, 1.2, 1.3] {
        let mut sized = default_settings(InstrumentKind::Clavichord, 48_000.0);
        sized.voicing.board_size = size;
        build(&sized);
        assert!(built::kept_count() <= built::KEPT);
    }
    built::forget();
    assert_eq!(built::kept_count(), 0);
}

/// Voiced, every key is left as a strike at its level touch leaves it, its
/// regulation's gain there 1: a key the others wake before it is first
/// struck (an undamped treble key) rings at that gain, not at whatever
/// touch the voicing happened to strike last.
#[test]
fn a_voiced_key_is_left_at_its_level_touchs_gain() {
    for kind in [InstrumentKind::Piano, InstrumentKind::Fortepiano, InstrumentKind::Harpsichord] {
        let voicing = build(&default_settings(kind, 48_000.0)).voicing();
        for key in &voicing.keys {
            let near = |g: f64| (g - 1.0).abs() <= 1e-12;
            assert!(
                near(key.gain) && near(key.gain_to),
                "{} key {}: {} -> {}",
                kind.name(),
                key.midi_key,
                key.gain,
                key.gain_to
            );
        }
    }
}
