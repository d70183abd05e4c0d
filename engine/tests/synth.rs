//! The real-time synth: keys, pedals, stealing, block-size independence, rebuilds.

use struck_engine::body::Output;
use struck_engine::design::{InstrumentKind, Voicing, clavichord_pitch_rise_cents};
use struck_engine::synth::{
    Ahead, Controls, Delivery, Event, Instrument, InstrumentSettings, Paced, Synth, TimedEvent, Workshop,
};

const FS: f64 = 48_000.0;

/// Heard as the bridge force: these tests are about keys, strings, pedals and
/// dampers (the body has its own, tests/body.rs).
fn synth(kind: InstrumentKind) -> Synth {
    let mut synth = Synth::new(Box::new(Instrument::build(&default_settings(kind, FS)).unwrap())).0;
    synth.set_controls(bridge());
    synth
}

/// The default controls, heard as the bridge force.
fn bridge() -> Controls {
    Controls { output: Output::BridgeForce, ..Controls::default() }
}

/// The default settings for the bridge-force output: strings on the seed's
/// resistive bridge.
fn default_settings(kind: InstrumentKind, fs: f64) -> InstrumentSettings {
    struck_engine::synth::default_settings(kind, fs).heard_through(Output::BridgeForce)
}

/// Render `seconds` with events given as (time in s, event), in host blocks
/// of `block`, as mono.
fn render(synth: &mut Synth, seconds: f64, events: &[(f64, Event)], block: usize) -> Vec<f32> {
    let (left, right) = render_stereo(synth, seconds, events, block);
    left.iter().zip(&right).map(|(l, r)| 0.5 * (l + r)).collect()
}

/// [`render`]'s two channels, as built.
fn render_stereo(synth: &mut Synth, seconds: f64, events: &[(f64, Event)], block: usize) -> (Vec<f32>, Vec<f32>) {
    let total = (seconds * FS) as usize;
    let mut timed: Vec<(usize, Event)> = events.iter().map(|&(t, e)| ((t * FS).round() as usize, e)).collect();
    timed.sort_by_key(|e| e.0);
    let (mut left, mut right) = (vec![0.0f32; total], vec![0.0f32; total]);
    let mut start = 0;
    let mut block_events = Vec::new();
    while start < total {
        let end = (start + block).min(total);
        block_events.clear();
        block_events.extend(
            timed.iter().filter(|e| e.0 >= start && e.0 < end).map(|e| TimedEvent::new((e.0 - start) as u32, e.1)),
        );
        synth.process(&block_events, &mut left[start..end], &mut right[start..end]);
        start = end;
    }
    (left, right)
}

fn rms(x: &[f32]) -> f64 {
    (x.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() / x.len().max(1) as f64).sqrt()
}

fn window(x: &[f32], from_s: f64, to_s: f64) -> &[f32] {
    &x[(from_s * FS) as usize..(to_s * FS) as usize]
}

/// Frequency of the strongest spectral peak near `guess_hz` (DTFT scan).
fn peak_near(x: &[f32], guess_hz: f64) -> f64 {
    peak_near_at(x, guess_hz, FS)
}

fn peak_near_at(x: &[f32], guess_hz: f64, fs: f64) -> f64 {
    let mut best = (0.0, guess_hz);
    let n = x.len() as f64;
    for i in -400..=400 {
        let f = guess_hz * 2f64.powf(i as f64 / 1200.0 * 0.25);
        let (mut re, mut im) = (0.0, 0.0);
        for (k, v) in x.iter().enumerate() {
            let w = 0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / n).cos();
            let ph = 2.0 * std::f64::consts::PI * f * k as f64 / fs;
            re += w * *v as f64 * ph.cos();
            im += w * *v as f64 * ph.sin();
        }
        let m = re * re + im * im;
        if m > best.0 {
            best = (m, f);
        }
    }
    best.1
}

fn cents(a: f64, b: f64) -> f64 {
    1200.0 * (a / b).log2()
}

#[test]
fn every_instrument_sounds_its_key_in_tune_after_silence() {
    for kind in InstrumentKind::ALL {
        let key = 69; // A4 is on every instrument
        let mut s = synth(kind);
        // The sustain pedal down: a cimbalom's damper bar is on the strings without it.
        let events = [(0.0, Event::Sustain(1.0)), (0.2, Event::NoteOn { key, velocity: 0.8 })];
        let out = render(&mut s, 1.0, &events, 256);
        assert_eq!(rms(window(&out, 0.0, 0.2)), 0.0, "{kind}: sound before the note");
        let ring = window(&out, 0.4, 0.9);
        assert!(rms(ring) > 1e-3, "{kind}: too quiet ({})", rms(ring));
        assert!(out.iter().all(|v| v.is_finite() && v.abs() < 1.0), "{kind}: not finite or clipping");
        let f = peak_near(ring, 440.0);
        assert!(cents(f, 440.0).abs() < 15.0, "{kind}: {f} Hz");
    }
}

fn session() -> Vec<(f64, Event)> {
    vec![
        (0.010, Event::NoteOn { key: 60, velocity: 0.5 }),
        (0.0101, Event::NoteOn { key: 64, velocity: 0.9 }),
        (0.05, Event::Sustain(1.0)),
        (0.13, Event::NoteOff { key: 60, velocity: 0.5 }),
        (0.2, Event::PitchBend(0.3)),
        (0.2003, Event::KeyVolume { key: 64, gain: 0.4 }),
        (0.2051, Event::KeyBend { key: 64, semitones: 0.7 }),
        (0.209, Event::KeyHammer { key: 60, hardness: 1.5, position: 0.7 }),
        (0.2093, Event::KeyPan { key: 64, pan: -0.6 }),
        (0.21, Event::NoteOn { key: 60, velocity: 1.0 }),
        (0.25, Event::NoteOff { key: 64, velocity: 0.5 }),
        (0.3, Event::Sustain(0.4)),
        (0.31, Event::UnaCorda(1.0)),
        (0.33, Event::NoteOn { key: 72, velocity: 0.3 }),
        (0.38, Event::Sostenuto(1.0)),
        (0.4, Event::NoteOff { key: 72, velocity: 0.5 }),
        (0.41, Event::Sustain(0.0)),
        (0.45, Event::AllNotesOff),
    ]
}

#[test]
fn any_block_size_gives_the_same_samples() {
    // Watched by a live view (as in the plugin, which keeps its side), and not;
    // the piano, and the dulcimer, whose divided courses move their bridge
    // sample by sample (each string taking a move with its next step, the
    // last of a stretch at its end).
    for (kind, watched) in
        [(InstrumentKind::Piano, true), (InstrumentKind::Piano, false), (InstrumentKind::Dulcimer, false)]
    {
        let play = |block: usize| {
            let (mut s, scope) = Synth::new(Box::new(Instrument::build(&default_settings(kind, FS)).unwrap()));
            s.set_controls(bridge());
            let _kept = watched.then_some(scope);
            render(&mut s, 0.5, &session(), block)
        };
        let reference = play(64);
        for block in [1, 7, 4096, 8192] {
            let out = play(block);
            assert!(
                out.iter().zip(&reference).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{kind}: block {block} differs (watched: {watched})"
            );
        }
    }
}

#[test]
fn a_paced_synth_is_the_same_synth_heard_later() {
    // Heard through the body and watched by a live view, as in the plugin;
    // the synth rendering ahead as far as it may (the host's block), only as
    // far as it must (the latency), and anywhere between at random, in host
    // blocks shorter and longer than the latency and longer than the ring;
    // a chord struck on one sample; thousands of events on one sample. The samples are the synth's, later by
    // the latency; keys fallen silent are reported no later than heard.
    let fs = FS;
    let mut events = session();
    events.extend((36..=96u8).step_by(4).map(|key| (0.1203, Event::NoteOn { key, velocity: 1.0 })));
    // (A reset silences every key: they are reported fallen silent.)
    events.extend([(0.5017, Event::Reset), (0.52, Event::NoteOn { key: 55, velocity: 0.9 })]);
    // More events on one sample than the paced synth queues.
    events.extend((0..9000).map(|i| (0.3003, Event::KeyVolume { key: 64, gain: 0.4 + 1e-5 * i as f32 })));
    events.sort_by(|a, b| a.0.total_cmp(&b.0));
    let seconds = 0.6;
    let total = (seconds * fs) as usize;
    let timed: Vec<(usize, Event)> = events.iter().map(|&(t, e)| ((t * fs).round() as usize, e)).collect();
    let piano = || {
        let settings = struck_engine::synth::default_settings(InstrumentKind::Piano, fs);
        Synth::new(Box::new(Instrument::build(&settings).unwrap()))
    };
    let (mut plain, _plain_scope) = piano();
    let ((reference_left, reference_right), reference_ended) = {
        let (mut l, mut r) = (vec![0.0f32; total], vec![0.0f32; total]);
        let mut ended = Vec::new();
        for start in (0..total).step_by(64) {
            let end = (start + 64).min(total);
            plain.process(&events_in(&timed, start, end), &mut l[start..end], &mut r[start..end]);
            ended.extend(plain.ended_keys().iter().map(|e| (start + e.time as usize, e.key)));
        }
        assert!(!ended.is_empty(), "no key fell silent");
        ((l, r), ended)
    };
    let latency = Paced::latency_for(fs);
    assert_eq!(latency, 128);
    // And the latency changed while playing: from then on the synth is heard
    // that late, what was queued before having happened first (what was
    // rendered and not yet heard is dropped; a longer latency starts with
    // silence).
    let switch = (0.25 * fs) as usize / 64 * 64;
    for (block, rule, switched) in [
        (64, "as far as it may", None),
        (64, "as far as it must", None),
        (37, "at random", None),
        (200, "at random", None),
        (3000, "at random", None),
        (1, "at random", None),
        (64, "at random", Some((latency, 0))),
        (64, "as far as it must", Some((0, latency))),
    ] {
        let (synth, _scope) = piano();
        let (first_latency, then) = switched.unwrap_or((latency, latency));
        let switch = if switched.is_some() { switch } else { usize::MAX };
        let mut paced = Paced::new(synth, first_latency);
        let mut seed = 0x9e37_79b9_u64 ^ block as u64;
        let mut ahead = |a: Ahead| match rule {
            "as far as it may" => a.may,
            "as far as it must" => 0,
            _ => {
                seed = seed.wrapping_mul(6_364_136_223_846_793_005).wrapping_add(1_442_695_040_888_963_407);
                // Stop one time in eight, else any length (more than it may, too).
                if seed >> 61 == 0 { 0 } else { (seed >> 32) as usize % (a.may + 9) }
            }
        };
        let heard = total + latency;
        let (mut l, mut r) = (vec![0.0f32; heard], vec![0.0f32; heard]);
        let mut ended = Vec::new();
        for start in (0..heard).step_by(block) {
            if start == switch {
                paced.set_latency(then);
                assert_eq!(paced.latency(), then);
            }
            let end = (start + block).min(heard);
            let events = events_in(&timed, start, end);
            // (At random, a block's events on its first sample come in a call
            // of no samples before it, as a host may send them.)
            let first = if rule == "at random" { events.iter().take_while(|e| e.time == 0).count() } else { 0 };
            paced.process_with(&events[..first], &mut [], &mut [], &mut ahead);
            ended.extend(paced.ended_keys().iter().map(|e| (start + e.time as usize, e.key)));
            paced.process_with(&events[first..], &mut l[start..end], &mut r[start..end], &mut ahead);
            ended.extend(paced.ended_keys().iter().map(|e| (start + e.time as usize, e.key)));
        }
        let case = format!("blocks of {block}, rendering ahead {rule}, latency {first_latency} then {then}");
        for (channel, (heard, reference)) in [("left", (&l, &reference_left)), ("right", (&r, &reference_right))] {
            for (h, &v) in heard.iter().enumerate() {
                let (latency, since) = if h < switch { (first_latency, 0) } else { (then, switch) };
                // (Past the reference's end, nothing to compare.)
                let expected = if h >= since + latency { reference.get(h - latency).copied() } else { Some(0.0) };
                let Some(expected) = expected else { continue };
                assert!(v.to_bits() == expected.to_bits(), "{channel} differs at {h}: {case}");
            }
        }
        let keys: Vec<u8> = ended.iter().map(|e| e.1).collect();
        let reference_keys: Vec<u8> = reference_ended.iter().map(|e| e.1).collect();
        assert_eq!(keys, reference_keys, "{case}: keys fallen silent");
        for (&(at, key), &(fell, _)) in ended.iter().zip(&reference_ended) {
            assert!(
                at <= fell + latency && at + 1 >= fell,
                "{case}: key {key} reported at {at}, fell silent at {fell}"
            );
        }
    }
}

/// The events of `timed` (at their samples) from `start` up to `end`, as a
/// host block's.
fn events_in(timed: &[(usize, Event)], start: usize, end: usize) -> Vec<TimedEvent> {
    timed.iter().filter(|e| e.0 >= start && e.0 < end).map(|e| TimedEvent::new((e.0 - start) as u32, e.1)).collect()
}

/// What a synth gave over `seconds` in host blocks of `block`: both channels
/// as computed (before they are rounded to f32), and each key reported
/// fallen silent, with its sample.
fn play_exactly(synth: &mut Synth, seconds: f64, events: &[(f64, Event)], block: usize) -> [Vec<u64>; 3] {
    let total = (seconds * FS) as usize;
    let mut timed: Vec<(usize, Event)> = events.iter().map(|&(t, e)| ((t * FS).round() as usize, e)).collect();
    timed.sort_by_key(|e| e.0);
    let (mut left, mut right) = (vec![0.0f64; total], vec![0.0f64; total]);
    let mut ended = Vec::new();
    let mut start = 0;
    while start < total {
        let end = (start + block).min(total);
        synth.process_f64(&events_in(&timed, start, end), &mut left[start..end], &mut right[start..end]);
        ended.extend(synth.ended_keys().iter().map(|e| ((start as u64 + u64::from(e.time)) << 8) | u64::from(e.key)));
        start = end;
    }
    [left.iter().map(|v| v.to_bits()).collect(), right.iter().map(|v| v.to_bits()).collect(), ended]
}

#[test]
fn a_busy_session_gives_the_same_samples_in_any_blocks() {
    // Through the body (split per microphone once a key is placed) and as the
    // bridge force; watched by a live view (which cuts the stretches finer
    // while it records a strike) and not; across a pedalled chord, a reset
    // and a switch of instrument, whose keys fade out beside the new one's:
    // host blocks of 7 and 4096 samples give the samples of blocks of 64 once
    // rounded to f32, and the same keys reported fallen silent at the same
    // samples.
    let play = |output: Output, block: usize, watched: bool| {
        let settings = struck_engine::synth::default_settings(InstrumentKind::Piano, FS).heard_through(output);
        let (mut s, scope) = Synth::new(Box::new(Instrument::build(&settings).unwrap()));
        let mut scope = watched.then_some(scope);
        s.set_controls(Controls { output, ..Controls::default() });
        let mut events = session();
        events.extend((36..=96u8).step_by(5).map(|key| (0.012, Event::NoteOn { key, velocity: 0.8 })));
        events.push((0.02, Event::Sustain(1.0)));
        events.push((0.25, Event::Sustain(0.0)));
        events.extend((36..=96u8).step_by(5).map(|key| (0.26, Event::NoteOff { key, velocity: 0.5 })));
        events.push((0.5017, Event::Reset));
        events.push((0.52, Event::NoteOn { key: 55, velocity: 0.9 }));
        let mut out = play_exactly(&mut s, 0.6, &events, block);
        let kind = InstrumentKind::Fortepiano;
        let settings = struck_engine::synth::default_settings(kind, FS).heard_through(output);
        s.install(Box::new(Instrument::build(&settings).unwrap()));
        let more = play_exactly(&mut s, 0.2, &[(0.01, Event::NoteOn { key: 60, velocity: 0.7 })], block);
        for (all, more) in out.iter_mut().zip(more) {
            all.extend(more);
        }
        let frame = scope.as_mut().and_then(|s| s.latest()).map(|f| (f.midi_key, f.contact_len, f.contact_n.to_vec()));
        (out, frame)
    };
    let rounded = |bits: &[u64]| bits.iter().map(|&b| (f64::from_bits(b) as f32).to_bits()).collect::<Vec<_>>();
    for output in [Output::Microphones, Output::BridgeForce] {
        for watched in [true, false] {
            let (reference, frame) = play(output, 64, watched);
            assert!(reference[0].iter().any(|&v| f64::from_bits(v).abs() > 1e-4), "{output:?}: silent");
            assert!(!reference[2].is_empty(), "{output:?}: no key fell silent");
            assert_eq!(frame.is_some(), watched, "{output:?}: the live view's frame (watched: {watched})");
            for block in [7, 4096] {
                let (out, blocks_frame) = play(output, block, watched);
                for (channel, name) in [(0, "left"), (1, "right")] {
                    assert!(
                        rounded(&out[channel]) == rounded(&reference[channel]),
                        "{output:?}: {name} differs, blocks of {block}, watched: {watched}"
                    );
                }
                assert!(out[2] == reference[2], "{output:?}: keys fallen silent differ, blocks of {block}");
                assert!(blocks_frame == frame, "{output:?}: the live view differs, blocks of {block}");
            }
        }
    }
}

/// Partial `n`'s level in dB over 0.05-0.55 s of `out`: the strongest bin of
/// a Hann-windowed spectrum within 2 % of n times `f_hz` (a stiff string's
/// partials run sharp; C3's 14th by well under 2 %).
fn partial_db(out: &[f32], f_hz: f64, n: usize) -> f64 {
    let x = window(out, 0.05, 0.55);
    let len = x.len();
    let fft = realfft::RealFftPlanner::<f64>::new().plan_fft_forward(len);
    let mut input: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(k, v)| (0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / len as f64).cos()) * *v as f64)
        .collect();
    let mut spectrum = fft.make_output_vec();
    fft.process(&mut input, &mut spectrum).unwrap();
    let bin = FS / len as f64;
    let target = n as f64 * f_hz;
    let (lo, hi) = ((target * 0.995 / bin) as usize, (target * 1.02 / bin) as usize);
    20.0 * spectrum[lo..=hi].iter().map(|c| c.norm()).fold(1e-30, f64::max).log10()
}

/// Where `key`'s exciter meets its strings as built, a fraction of the length.
fn exciter_position(kind: InstrumentKind, key: u8) -> f64 {
    match struck_engine::design::key_design(kind, &Voicing::default(), key, 20_000.0).unwrap().exciter {
        struck_engine::design::ExciterDesign::Hammer { position, .. }
        | struck_engine::design::ExciterDesign::Pluck { position } => position,
        other => panic!("{other:?}"),
    }
}

#[test]
fn a_keys_own_hammer_is_harder_and_strikes_where_it_is_told() {
    // C3 on the bridge force: a key's own hardness brightens its next strike;
    // its own strike point at a quarter of the string takes out the 4th
    // partial (a node there), and at an eighth the 8th. Other keys are not moved.
    let key = 48;
    let f = struck_engine::design::key_frequency_hz(key);
    let built = exciter_position(InstrumentKind::Piano, key);
    let strike = |hammer: Option<(f32, f32)>| {
        let mut s = synth(InstrumentKind::Piano);
        let mut events = vec![];
        if let Some((hardness, position)) = hammer {
            events.push((0.0, Event::KeyHammer { key, hardness, position }));
        }
        // 2.7 m/s, a mezzo-forte strike.
        events.push((0.0, Event::NoteOn { key, velocity: 0.38 }));
        render(&mut s, 0.6, &events, 256)
    };
    let plain = strike(None);
    let brightness = |out: &[f32]| (9..=14).map(|n| partial_db(out, f, n)).sum::<f64>() / 6.0 - partial_db(out, f, 1);
    let (hard, soft) = (strike(Some((4.0, 1.0))), strike(Some((0.25, 1.0))));
    let (b_plain, b_hard, b_soft) = (brightness(&plain), brightness(&hard), brightness(&soft));
    println!("C3: partials 9-14 re the 1st: {b_soft:.1} dB (felt 1/4), {b_plain:.1} (as voiced), {b_hard:.1} (4x)");
    assert!(b_hard > b_plain + 3.0 && b_soft < b_plain - 3.0);
    for n in [4usize, 8] {
        let moved = strike(Some((1.0, (1.0 / (n as f64 * built)) as f32)));
        let (before, after) =
            (partial_db(&plain, f, n) - partial_db(&plain, f, 1), partial_db(&moved, f, n) - partial_db(&moved, f, 1));
        println!("C3 struck at 1/{n} (built at {built:.4}): partial {n} re the 1st {before:.1} -> {after:.1} dB");
        assert!(after < before - 15.0, "partial {n}: {before:.1} -> {after:.1} dB");
    }
    // A harpsichord's plectrum moves the same way: plucked at a quarter of
    // the string, D3's 4th partial is gone.
    let (d3, harpsichord_key) = (struck_engine::design::key_frequency_hz(50), 50);
    let pluck_point = exciter_position(InstrumentKind::Harpsichord, harpsichord_key);
    let pluck = |position: Option<f32>| {
        let mut s = synth(InstrumentKind::Harpsichord);
        let mut events = vec![];
        if let Some(position) = position {
            events.push((0.0, Event::KeyHammer { key: harpsichord_key, hardness: 1.0, position }));
        }
        events.push((0.0, Event::NoteOn { key: harpsichord_key, velocity: 0.7 }));
        render(&mut s, 0.6, &events, 256)
    };
    let (as_built, moved) = (pluck(None), pluck(Some((0.25 / pluck_point) as f32)));
    let (before, after) = (
        partial_db(&as_built, d3, 4) - partial_db(&as_built, d3, 1),
        partial_db(&moved, d3, 4) - partial_db(&moved, d3, 1),
    );
    println!("D3 plucked at 1/4 (built at {pluck_point:.4}): partial 4 re the 1st {before:.1} -> {after:.1} dB");
    assert!(after < before - 15.0, "the plectrum did not move: {before:.1} -> {after:.1} dB");
    // Back to 1: as voiced, bit for bit.
    let mut s = synth(InstrumentKind::Piano);
    let events = [
        (0.0, Event::KeyHammer { key, hardness: 2.0, position: 0.5 }),
        (0.0, Event::KeyHammer { key, hardness: 1.0, position: 1.0 }),
        (0.0, Event::NoteOn { key, velocity: 0.38 }),
    ];
    let back = render(&mut s, 0.6, &events, 256);
    assert!(back.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()));
}

#[test]
fn keys_that_share_strings_keep_their_own_hammer() {
    // The dulcimer's C#5 course sounds G#5 on its short side. G#5 struck
    // with a mallet 16 times softer, then C#5 struck as voiced: C#5's strike
    // is the same as after a plain G#5 (its 5th and 7th partials, which
    // G#5's do not meet, against its 1st).
    let c_sharp = struck_engine::design::key_frequency_hz(73);
    let after = |hardness: f32| {
        let mut s = synth(InstrumentKind::Dulcimer);
        let events = [
            (0.0, Event::KeyHammer { key: 80, hardness, position: 1.0 }),
            (0.0, Event::NoteOn { key: 80, velocity: 0.7 }),
            (1.0, Event::NoteOn { key: 73, velocity: 0.7 }),
        ];
        let out = render(&mut s, 1.6, &events, 256);
        let x = &out[(1.0 * FS) as usize..];
        let g_sharp = struck_engine::design::key_frequency_hz(80);
        let own = [5, 7].map(|n| partial_db(&out, g_sharp, n) - partial_db(&out, g_sharp, 1));
        (own, [5, 7].map(|n| partial_db(x, c_sharp, n) - partial_db(x, c_sharp, 1)))
    };
    let ((g_plain, plain), (g_soft, soft)) = (after(1.0), after(1.0 / 16.0));
    println!(
        "G#5 plain: partials 5, 7 at {g_plain:.1?} dB, soft: {g_soft:.1?}; C#5 after a plain G#5: {plain:.1?} dB, after a soft one: {soft:.1?} dB"
    );
    assert!(g_plain.iter().zip(&g_soft).any(|(a, b)| (a - b).abs() > 3.0), "G#5's own mallet did not change");
    assert!(plain.iter().zip(&soft).all(|(a, b)| (a - b).abs() < 0.5), "{plain:?} against {soft:?}");
}

#[test]
fn a_key_placed_in_the_stereo_image_is_heard_there() {
    // C4 through the microphones: placed hard left, the right microphone hears
    // nothing of it and the left 3 dB more; at 0.5 right, the right side gains
    // and the left loses as a constant-power pan has it; in the middle,
    // exactly as built. E4 beside it stays where it was.
    let mics_with = |pan: Option<f32>, sympathy: f64| {
        let settings = struck_engine::synth::default_settings(InstrumentKind::Piano, FS);
        let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
        s.set_controls(Controls { sympathy, ..Controls::default() });
        let mut events = vec![];
        if let Some(pan) = pan {
            events.push((0.0, Event::KeyPan { key: 60, pan }));
        }
        events.push((0.0, Event::NoteOn { key: 60, velocity: 0.38 }));
        render_stereo(&mut s, 1.0, &events, 256)
    };
    let mics = |pan: Option<f32>| mics_with(pan, 1.0);
    let db = |x: &[f32]| 10.0 * (x.iter().map(|v| (*v as f64).powi(2)).sum::<f64>() + 1e-300).log10();
    let (l, r) = mics(None);
    let (l0, r0) = mics(Some(0.0));
    assert!(l.iter().zip(&l0).chain(r.iter().zip(&r0)).all(|(a, b)| a.to_bits() == b.to_bits()), "the middle moved");
    let (hl, hr) = mics(Some(-1.0));
    // What the right microphone hears is the undamped treble's answer, where
    // the instrument has those strings; without sympathy, nothing.
    println!("C4 hard left: right {:.1} dB re its left (the treble's answer)", db(&hr) - db(&hl));
    // (-34.6 dB: the close pair hears the treble bridge's end, where those
    // strings bear, from 0.7 m.)
    assert!(db(&hr) < db(&hl) - 30.0, "the right microphone hears a key placed hard left");
    let (_, alone) = mics_with(Some(-1.0), 0.0);
    assert!(alone.iter().all(|&v| v == 0.0), "without sympathy the right microphone hears nothing");
    let (pl, pr) = mics(Some(0.5));
    let angle = 1.5 * std::f64::consts::FRAC_PI_4;
    let (gl, gr) = (
        20.0 * (angle.cos() * std::f64::consts::SQRT_2).log10(),
        20.0 * (angle.sin() * std::f64::consts::SQRT_2).log10(),
    );
    println!(
        "C4 hard left: left {:+.2} dB; at 0.5 right: left {:+.2} dB (expected {gl:+.2}), right {:+.2} dB (expected {gr:+.2})",
        db(&hl) - db(&l),
        db(&pl) - db(&l),
        db(&pr) - db(&r)
    );
    assert!((db(&hl) - db(&l) - 3.01).abs() < 0.05);
    assert!((db(&pl) - db(&l) - gl).abs() < 0.05 && (db(&pr) - db(&r) - gr).abs() < 0.05);
    // Moved while it rings: no click, and the body runs once per microphone
    // until it rests.
    let settings = struck_engine::synth::default_settings(InstrumentKind::Piano, FS);
    let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
    let events = [(0.0, Event::NoteOn { key: 60, velocity: 0.38 }), (0.5, Event::KeyPan { key: 60, pan: 1.0 })];
    let (ml, mr) = render_stereo(&mut s, 1.0, &events, 256);
    let i = (0.5 * FS) as usize;
    let steps = |x: &[f32], a: usize, b: usize| x[a..b].windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0f32, f32::max);
    // Against the key left in the middle over the same 50 ms, the right side
    // at most its new gain (sqrt 2) times, the left no more than before.
    let (after_l, after_r) =
        (steps(&ml, i, i + 2400) / steps(&l, i, i + 2400), steps(&mr, i, i + 2400) / steps(&r, i, i + 2400));
    println!(
        "moved hard right at 0.5 s: largest sample step against the middle's: left {after_l:.3}, right {after_r:.3}"
    );
    assert!(after_l <= 1.05 && after_r <= 1.05 * std::f64::consts::SQRT_2 as f32, "a click where the key moved");
    assert!(db(&ml[i + 4800..]) < db(&l[i + 4800..]) - 20.0, "the left still hears a key placed hard right");
}

#[test]
fn restriking_a_ringing_key_continues_without_a_click() {
    let mut s = synth(InstrumentKind::Piano);
    let out = render(
        &mut s,
        0.6,
        &[(0.0, Event::NoteOn { key: 57, velocity: 0.7 }), (0.3, Event::NoteOn { key: 57, velocity: 0.7 })],
        128,
    );
    // The sample-to-sample step around the re-strike is no larger than the ringing's own.
    let i = (0.3 * FS) as usize;
    let steps = |a: usize, b: usize| out[a..b].windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0f32, f32::max);
    assert!(steps(i - 2, i + 2) <= 1.5 * steps(i - 200, i - 2), "a jump at the re-strike");
    assert_eq!(s.active_keys(), 1);
}

#[test]
fn dampers_pedals_and_half_pedal() {
    let level_after_release = |extra: &[(f64, Event)]| {
        let mut events =
            vec![(0.0, Event::NoteOn { key: 48, velocity: 0.8 }), (0.3, Event::NoteOff { key: 48, velocity: 0.5 })];
        events.extend_from_slice(extra);
        let out = render(&mut synth(InstrumentKind::Piano), 1.2, &events, 512);
        rms(window(&out, 0.9, 1.2)) / rms(window(&out, 0.2, 0.3))
    };
    let damped = level_after_release(&[]);
    let half = level_after_release(&[(0.1, Event::Sustain(0.5))]);
    let held = level_after_release(&[(0.1, Event::Sustain(1.0))]);
    assert!(damped < 0.01, "the damper should silence the key: {damped}");
    assert!(held > 0.3, "the pedal should hold the key: {held}");
    assert!(damped < half && half < held, "half-pedal between: {damped} {half} {held}");
    // Re-pedalling: the pedal pressed again while the strings still ring keeps them ringing.
    let repedal = level_after_release(&[(0.305, Event::Sustain(1.0))]);
    assert!(repedal > 10.0 * damped, "re-pedal {repedal} vs {damped}");
    // Sostenuto holds the keys that were down when it was pressed, and not others.
    let sost = level_after_release(&[(0.1, Event::Sostenuto(1.0))]);
    assert!(sost > 0.3, "sostenuto should hold: {sost}");
    let late = level_after_release(&[(0.35, Event::Sostenuto(1.0))]);
    assert!(late < 0.01, "sostenuto pressed after the release must not hold: {late}");
}

#[test]
fn santoor_and_dulcimer_note_offs_change_nothing() {
    for kind in [InstrumentKind::Santoor, InstrumentKind::Dulcimer] {
        let strike = (0.0, Event::NoteOn { key: 62, velocity: 0.8 });
        let held = render(&mut synth(kind), 1.0, &[strike], 512);
        let released = render(&mut synth(kind), 1.0, &[strike, (0.1, Event::NoteOff { key: 62, velocity: 0.5 })], 512);
        assert!(rms(window(&held, 0.8, 1.0)) > 0.2 * rms(window(&held, 0.05, 0.1)), "{kind}: no ringing");
        assert!(held.iter().zip(&released).all(|(a, b)| a.to_bits() == b.to_bits()), "{kind}: the note-off acted");
    }
}

#[test]
fn a_santoor_restrike_adds_to_the_ringing_string() {
    let (first, second) = (Event::NoteOn { key: 69, velocity: 0.6 }, Event::NoteOn { key: 69, velocity: 0.6 });
    let once = render(&mut synth(InstrumentKind::Santoor), 0.6, &[(0.0, first)], 64);
    let fresh = render(&mut synth(InstrumentKind::Santoor), 0.6, &[(0.3, second)], 64);
    let twice = render(&mut synth(InstrumentKind::Santoor), 0.6, &[(0.0, first), (0.3, second)], 64);
    // Up to the re-strike, the first note alone.
    let i = (0.3 * FS) as usize;
    assert!(twice[..i].iter().zip(&once[..i]).all(|(a, b)| a.to_bits() == b.to_bits()));
    // After it: not a fresh strike from rest, but the ringing string struck again
    // (how much the old ringing and the new strike add up depends on how the
    // string under the mallet was moving when it arrived).
    let after = |x: &[f32]| window(x, 0.35, 0.6).to_vec();
    let (t, f, o) = (after(&twice), after(&fresh), after(&once));
    let from_fresh: Vec<f32> = t.iter().zip(&f).map(|(a, b)| a - b).collect();
    assert!(rms(&from_fresh) > 0.3 * rms(&o), "the re-strike forgot the ringing");
    // And no click where the mallet lands.
    let steps = |a: usize, b: usize| twice[a..b].windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0f32, f32::max);
    assert!(steps(i - 2, i + 2) <= 1.5 * steps(i - 200, i - 2), "a jump at the re-strike");
}

#[test]
fn a_cimbalom_is_damped_unless_the_pedal_is_down() {
    let decay = |pedal: f32| {
        let events = [(0.0, Event::Sustain(pedal)), (0.01, Event::NoteOn { key: 60, velocity: 0.8 })];
        let out = render(&mut synth(InstrumentKind::Cimbalom), 1.5, &events, 512);
        rms(window(&out, 1.2, 1.5)) / rms(window(&out, 0.05, 0.15))
    };
    let (free, damped) = (decay(1.0), decay(0.0));
    assert!(free > 0.1, "the pedal should let it ring: {free}");
    assert!(damped < 0.01 * free, "the damper bar should stop it: {damped} vs {free}");
    // A note-off changes nothing either way.
    let events = [(0.0, Event::Sustain(1.0)), (0.01, Event::NoteOn { key: 60, velocity: 0.8 })];
    let held = render(&mut synth(InstrumentKind::Cimbalom), 0.5, &events, 512);
    let mut with_off = events.to_vec();
    with_off.push((0.1, Event::NoteOff { key: 60, velocity: 0.5 }));
    let released = render(&mut synth(InstrumentKind::Cimbalom), 0.5, &with_off, 512);
    assert!(held.iter().zip(&released).all(|(a, b)| a.to_bits() == b.to_bits()));
}

/// Spectral centroid of `x`, Hz (a plain DFT up to 8 kHz in 50 Hz steps).
fn centroid_hz(x: &[f32]) -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for f in (1..160).map(|i| i as f64 * 50.0) {
        let (mut re, mut im) = (0.0, 0.0);
        for (k, v) in x.iter().enumerate() {
            let ph = 2.0 * std::f64::consts::PI * f * k as f64 / FS;
            re += *v as f64 * ph.cos();
            im += *v as f64 * ph.sin();
        }
        let m = (re * re + im * im).sqrt();
        num += f * m;
        den += m;
    }
    num / den
}

#[test]
fn the_mod_wheel_softens_the_mallets() {
    let strike = |wheel: f32| {
        let events = [(0.0, Event::ModWheel(wheel)), (0.01, Event::NoteOn { key: 57, velocity: 0.8 })];
        let out = render(&mut synth(InstrumentKind::Santoor), 0.3, &events, 256);
        centroid_hz(window(&out, 0.02, 0.12))
    };
    let (hard, soft) = (strike(0.0), strike(1.0));
    assert!(soft < 0.8 * hard, "a softer mallet should sound darker: {hard:.0} Hz -> {soft:.0} Hz");
}

#[test]
fn polyphony_steals_the_quietest_released_key() {
    let mut s = synth(InstrumentKind::Santoor);
    s.set_controls(Controls { polyphony: 2, ..bridge() });
    let events = [
        (0.0, Event::NoteOn { key: 60, velocity: 1.0 }),
        (0.01, Event::NoteOn { key: 64, velocity: 0.2 }),
        (0.02, Event::NoteOff { key: 64, velocity: 0.5 }),
        (0.1, Event::NoteOn { key: 67, velocity: 0.8 }),
    ];
    render(&mut s, 0.2, &events, 64);
    assert_eq!(s.active_keys(), 2);
    // Key 64 (released and the quietest) was the one to go.
    assert!(s.key_sounding(60) && s.key_sounding(67) && !s.key_sounding(64));
    // With every key held, the quietest goes: 67 (velocity 0.8 against 60's 1.0, and younger).
    let more = [(0.0, Event::NoteOn { key: 64, velocity: 1.0 })];
    render(&mut s, 0.05, &more, 64);
    assert!(s.key_sounding(64) && s.key_sounding(60) != s.key_sounding(67));
}

#[test]
fn silent_keys_stop_and_are_reported() {
    let mut s = synth(InstrumentKind::Harpsichord);
    let events = [(0.0, Event::NoteOn { key: 84, velocity: 1.0 }), (0.05, Event::NoteOff { key: 84, velocity: 0.5 })];
    let mut ended = Vec::new();
    let total = (3.0 * FS) as usize;
    let (mut l, mut r) = (vec![0.0f32; 512], vec![0.0f32; 512]);
    for b in 0..total / 512 {
        let evs: Vec<TimedEvent> = events
            .iter()
            .map(|&(t, e)| ((t * FS) as usize, e))
            .filter(|(t, _)| *t >= b * 512 && *t < (b + 1) * 512)
            .map(|(t, e)| TimedEvent::new((t - b * 512) as u32, e))
            .collect();
        s.process(&evs, &mut l, &mut r);
        ended.extend(s.ended_keys().iter().map(|e| e.key));
    }
    assert_eq!(s.active_keys(), 0);
    assert_eq!(ended, vec![84]);
}

#[test]
fn velocity_curve_maps_the_touch_range() {
    let c = Controls::default();
    let range = InstrumentKind::Piano.touch_range();
    let (min, max) = range.bounds();
    assert!((c.touch(range, 1.0).value() - max).abs() < 1e-9);
    assert!((c.touch(range, 0.0).value() - min).abs() < 1e-9);
    assert_eq!(c.touch(range, 0.5).unit(), "m/s");
    let hard = Controls { touch_shape: 2.0, ..c };
    assert!(hard.touch(range, 0.5).value() < c.touch(range, 0.5).value());
    // A player whose softest is 20 and loudest 100 plays the whole range.
    let learnt = Controls { velocity_floor: 20.0 / 127.0, velocity_ceiling: 100.0 / 127.0, ..c };
    assert!((learnt.touch(range, 100.0 / 127.0).value() - max).abs() < 1e-9);
    assert!((learnt.touch(range, 110.0 / 127.0).value() - max).abs() < 1e-9);
    assert!((learnt.touch(range, 20.0 / 127.0).value() - min).abs() < 1e-9);
    assert!((learnt.touch(range, 60.0 / 127.0).value() - c.touch(range, 0.5).value()).abs() < 1e-9);
    let narrow = Controls { touch_min: 0.5, touch_max: 0.5, ..c };
    assert!((narrow.touch(range, 0.1).value() - narrow.touch(range, 0.9).value()).abs() < 1e-12);
    // A harpsichord's velocity lifts its plectrum: millimetres, not a speed.
    let pluck = InstrumentKind::Harpsichord.touch_range();
    assert_eq!(c.touch(pluck, 0.5).unit(), "mm");
    assert_eq!(pluck.top_speed_m_s(), None);
}

#[test]
fn the_pianos_velocity_sets_its_level_in_proportion() {
    // The hammer's speed is in proportion to velocity (7 m/s at 127, never
    // under 0.1 m/s), so that the sound is too, near enough: a recorded
    // Yamaha C5's layers fall 19.6 to 20.8 dB from velocity 124 to 13.
    let c = Controls::default();
    let range = InstrumentKind::Piano.touch_range();
    let at = |velocity: f64| c.touch(range, velocity / 127.0).value();
    for velocity in 3..=127 {
        let v = f64::from(velocity);
        assert!((at(v) - 7.0 * v / 127.0).abs() < 1e-9, "velocity {velocity}: {} m/s", at(v));
    }
    assert!((at(1.0) - 0.1).abs() < 1e-9 && (at(0.0) - 0.1).abs() < 1e-9);
    // The level scale is set at 1.96 m/s, now velocity 35.6.
    let level = range.level_velocity() * 127.0;
    assert!((c.touch(range, range.level_velocity()).value() - range.level_touch().value()).abs() < 1e-12);
    assert!((35.0..36.5).contains(&level), "{level}");
    // Heard: C4's first second at velocities 30, 60 and 120, re 120.
    let settings = default_settings(InstrumentKind::Piano, FS);
    let instrument = Instrument::build(&settings).unwrap();
    let mut s = Synth::new(Box::new(instrument)).0;
    let mut level_db = |velocity: f64| {
        let out = render(&mut s, 1.0, &[(0.0, Event::NoteOn { key: 60, velocity: velocity / 127.0 })], 256);
        render(&mut s, 3.0, &[(0.0, Event::NoteOff { key: 60, velocity: 0.5 })], 256);
        20.0 * rms(&out).log10()
    };
    let loud = level_db(120.0);
    let (soft, middle) = (level_db(30.0) - loud, level_db(60.0) - loud);
    println!("C4 re velocity 120: 30 at {soft:.1} dB, 60 at {middle:.1} dB");
    assert!((-16.5..-10.0).contains(&soft), "{soft}");
    assert!((-8.5..-4.5).contains(&middle), "{middle}");
}

#[test]
fn a_rebuild_of_the_same_instrument_keeps_keys_ringing() {
    let settings = default_settings(InstrumentKind::Piano, FS);
    let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
    let before = render(&mut s, 0.3, &[(0.0, Event::NoteOn { key: 60, velocity: 0.8 })], 256);
    let damper = InstrumentSettings { voicing: Voicing { damping: 2.0, ..Voicing::default() }, ..settings };
    s.install(Box::new(Instrument::build(&damper).unwrap()));
    assert!(s.take_retired().is_some(), "the old tables come back to be dropped elsewhere");
    let after = render(&mut s, 0.3, &[], 256);
    assert_eq!(s.active_keys(), 1);
    let edge = (before[before.len() - 1] - after[0]).abs();
    assert!(edge < 0.8 * rms(window(&before, 0.2, 0.3)) as f32, "a jump at the rebuild: {edge}");
    assert!(rms(&after[..4800]) > 0.5 * rms(window(&before, 0.25, 0.3)));
    // Another instrument: the piano fades out and is handed back.
    s.install(Box::new(Instrument::build(&default_settings(InstrumentKind::Santoor, FS)).unwrap()));
    render(&mut s, 0.05, &[], 256);
    assert_eq!(s.active_keys(), 0);
    assert!(s.take_retired().is_some());
}

#[test]
fn the_workshop_builds_off_the_audio_thread_and_delivers() {
    let settings = default_settings(InstrumentKind::Clavichord, FS);
    let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
    let wanted = InstrumentSettings { kind: InstrumentKind::Harpsichord, ..settings.clone() };
    let (workshop, mut delivery): (Workshop, Delivery) = Workshop::spawn(settings, move || Some(wanted.clone()));
    let deadline = std::time::Instant::now() + std::time::Duration::from_secs(20);
    while s.settings().kind != InstrumentKind::Harpsichord {
        assert!(std::time::Instant::now() < deadline, "no delivery");
        std::thread::sleep(std::time::Duration::from_millis(5));
        delivery.exchange(&mut s);
    }
    render(&mut s, 0.05, &[], 256);
    delivery.exchange(&mut s);
    assert!(s.take_retired().is_none(), "the replaced instrument went back to the workshop");
    drop(workshop);
}

#[test]
fn any_sample_rate_gives_the_same_note() {
    // Pitch and level of a piano C4 at rates from 22.05 to 192 kHz.
    let measure = |fs: f64| {
        let settings = default_settings(InstrumentKind::Piano, fs);
        let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
        let n = (0.6 * fs) as usize;
        let (mut l, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
        let on = [TimedEvent::new(0, Event::NoteOn { key: 60, velocity: 0.7 })];
        s.process(&on, &mut l, &mut r);
        let ring = &l[(0.3 * fs) as usize..];
        (peak_near_at(ring, 261.6, fs), rms(ring))
    };
    let (f_ref, level_ref) = measure(48_000.0);
    for fs in [22_050.0, 44_100.0, 96_000.0, 192_000.0] {
        let (f, level) = measure(fs);
        assert!(cents(f, f_ref).abs() < 1.0, "{fs} Hz: pitch {f} vs {f_ref}");
        let db = 20.0 * (level / level_ref).log10();
        assert!(db.abs() < 1.0, "{fs} Hz: level {db:.2} dB from 48 kHz");
    }
}

#[test]
fn the_live_view_shows_the_strike_and_the_output() {
    let (mut s, mut scope) =
        Synth::new(Box::new(Instrument::build(&default_settings(InstrumentKind::Piano, FS)).unwrap()));
    let out = render(&mut s, 0.1, &[(0.01, Event::NoteOn { key: 48, velocity: 0.9 })], 256);
    let frame = scope.latest().expect("a frame within 0.1 s").clone();
    assert_eq!(frame.midi_key, 48);
    assert!(frame.contact_len > 100 && frame.contact_n[..frame.contact_len].iter().any(|f| *f > 1.0));
    assert!(frame.strike_force_n > 1.0 && frame.strike_hammer.is_some(), "no picture at peak contact");
    // The string at peak contact, drawn when the frame went out: pushed up under
    // the hammer, most near where it strikes, and held at both ends.
    let (at, _) = frame.hammer.unwrap_or_default();
    let peak = frame.strike_shape_m.iter().enumerate().max_by(|a, b| a.1.abs().total_cmp(&b.1.abs())).unwrap();
    let n = frame.strike_shape_m.len() as f32 - 1.0;
    assert!(peak.1.abs() > 1e-5, "no picture of the string at peak contact");
    assert!(
        (peak.0 as f32 / n - frame.strike_hammer.unwrap().0).abs() < 0.1,
        "peak at {} of {n}, hammer at {at}",
        peak.0
    );
    assert!(frame.strike_shape_m[0] == 0.0 && frame.strike_shape_m[n as usize].abs() < 1e-3 * peak.1.abs());
    assert!(frame.shape_m.iter().any(|y| y.abs() > 0.0));
    let mut samples = Vec::new();
    scope.drain_samples(&mut samples);
    assert_eq!(samples.len(), out.len());
    assert!(samples.iter().zip(&out).all(|(a, b)| (a - b).abs() < 1e-6));
}

#[test]
fn the_tail_reaches_exact_silence_without_subnormals() {
    let mut s = synth(InstrumentKind::Piano);
    let out = render(
        &mut s,
        12.0,
        &[(0.0, Event::NoteOn { key: 72, velocity: 0.8 }), (0.1, Event::NoteOff { key: 72, velocity: 0.5 })],
        512,
    );
    assert!(out.iter().all(|v| !v.is_subnormal()), "a subnormal sample");
    assert_eq!(s.active_keys(), 0);
    assert!(out[out.len() - 4800..].iter().all(|&v| v == 0.0), "the output should end in exact zeros");
}

#[test]
fn odd_sample_rates_build_and_play() {
    // What a host may ask (clap-validator does): keys without a partial below Nyquist stay silent.
    for fs in [1_234.567_8, 8_000.0, 12_345.678, 768_000.0] {
        for kind in InstrumentKind::ALL {
            let instrument =
                Instrument::build(&default_settings(kind, fs)).unwrap_or_else(|e| panic!("{kind} at {fs}: {e}"));
            let (mut s, _) = Synth::new(Box::new(instrument));
            let n = (0.05 * fs) as usize;
            let (mut l, mut r) = (vec![0.0f32; n], vec![0.0f32; n]);
            let notes: Vec<TimedEvent> =
                kind.key_range().map(|key| TimedEvent::new(0, Event::NoteOn { key, velocity: 0.5 })).collect();
            s.process(&notes, &mut l, &mut r);
            assert!(l.iter().chain(&r).all(|v| v.is_finite()), "{kind} at {fs}");
        }
    }
    assert!(Instrument::build(&default_settings(InstrumentKind::Piano, 999.0)).is_err());
    assert!(Instrument::build(&default_settings(InstrumentKind::Piano, 800_000.0)).is_err());
}

/// The frequency of the strongest component within half a cent of `guess_hz`,
/// refined to a hundredth of a cent (Hann window, DTFT scan).
fn fine_peak(x: &[f32], guess_hz: f64) -> f64 {
    let coarse = peak_near(x, guess_hz);
    let n = x.len() as f64;
    let window: Vec<f64> = x
        .iter()
        .enumerate()
        .map(|(k, v)| (0.5 - 0.5 * (2.0 * std::f64::consts::PI * k as f64 / n).cos()) * *v as f64)
        .collect();
    let power = |f: f64| {
        let (mut re, mut im) = (0.0, 0.0);
        let step = 2.0 * std::f64::consts::PI * f / FS;
        for (k, w) in window.iter().enumerate() {
            let ph = step * k as f64;
            re += w * ph.cos();
            im += w * ph.sin();
        }
        re * re + im * im
    };
    (-50..=50)
        .map(|i| coarse * 2f64.powf(i as f64 * 0.01 / 1200.0))
        .max_by(|a, b| power(*a).total_cmp(&power(*b)))
        .unwrap()
}

/// The clavichord unstretched: each key at its own equal-tempered pitch.
fn clavichord(voicing: Voicing) -> Synth {
    let mut settings = InstrumentSettings { voicing, ..default_settings(InstrumentKind::Clavichord, FS) };
    settings.tuning.stretch = 0.0;
    let mut synth = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
    synth.set_controls(bridge());
    synth
}

#[test]
fn a_clavichord_press_raises_the_pitch_as_the_stretch_says() {
    // D2, the seed's string; one string's pitch (no unison spread) measured over 2 s.
    let key = 38;
    let f_key = struck_engine::design::key_frequency_hz(key);
    let built_m = 2.0e-3;
    // At rest the strings sit flat by the built press's rise (tuned with the key down).
    let rest_hz = f_key / 2f64.powf(clavichord_pitch_rise_cents(key, built_m) / 1200.0);
    for depth in [1.0, 0.5, 1.5] {
        let voicing = Voicing { unison_detune: 0.0, tangent_depth: depth, ..Voicing::default() };
        let out = render(&mut clavichord(voicing), 2.6, &[(0.0, Event::NoteOn { key, velocity: 0.8 })], 512);
        let f = fine_peak(window(&out, 0.5, 2.5), f_key);
        let rise = cents(f, rest_hz);
        let expected = clavichord_pitch_rise_cents(key, built_m * depth);
        eprintln!("D2 pressed {:.2} mm: {rise:.3} cents (the stretch: {expected:.3})", built_m * depth * 1e3);
        assert!((rise - expected).abs() < 0.2, "depth {depth}: {rise:.2} cents, the stretch says {expected:.2}");
    }
}

#[test]
fn bebung_bends_a_held_clavichord_note_smoothly_by_its_range() {
    // Full pressure raises the held note by the Bebung's range: the tangent
    // presses deeper and the string, stretched over it, rises (with the square
    // of the depth); half pressure, half as deep, a little under half as far.
    for (key, range) in [(38, 30.0), (57, 30.0), (57, 10.0), (76, 50.0)] {
        let f_key = struck_engine::design::key_frequency_hz(key);
        let voicing = Voicing { unison_detune: 0.0, ..Voicing::default() };
        let events = [
            (0.0, Event::NoteOn { key, velocity: 0.8 }),
            (1.0, Event::Pressure { key, pressure: 0.5 }),
            (2.0, Event::Pressure { key, pressure: 1.0 }),
            (3.0, Event::Pressure { key, pressure: 0.0 }),
        ];
        let mut synth = clavichord(voicing);
        synth.set_controls(Controls { bebung_cents: range, ..bridge() });
        let out = render(&mut synth, 4.0, &events, 256);
        let pitch = |from: f64, to: f64| fine_peak(window(&out, from, to), f_key);
        let rest = pitch(0.2, 1.0);
        let (half, full, back) =
            (cents(pitch(1.2, 2.0), rest), cents(pitch(2.2, 3.0), rest), cents(pitch(3.2, 4.0), rest));
        println!("key {key}, Bebung {range} cents: half pressure {half:.2}, full {full:.2}, let go {back:.2} cents");
        assert!((full - range).abs() < 0.5, "key {key}: {full:.2} cents at full pressure, expected {range}");
        assert!(half > 0.2 * range && half < 0.5 * range, "key {key}: {half:.2} cents at half pressure");
        assert!(back.abs() < 0.3, "key {key}: {back:.2} cents after letting go");
        // No click where the pressure comes.
        let i = (2.0 * FS) as usize;
        let steps = |a: usize, b: usize| out[a..b].windows(2).map(|w| (w[1] - w[0]).abs()).fold(0.0f32, f32::max);
        assert!(steps(i, i + 2400) <= 1.2 * steps(i - 4800, i), "key {key}: a click under the finger");
    }
}

#[test]
fn on_a_fretted_clavichord_the_higher_tangent_wins() {
    let mut synth = clavichord(Voicing { fretted: true, unison_detune: 0.0, ..Voicing::default() });
    // C4 and C#4 share a pair of strings. C4 alone; C#4 pressed over it; C#4 up again.
    let events = [
        (0.0, Event::NoteOn { key: 60, velocity: 0.8 }),
        (1.0, Event::NoteOn { key: 61, velocity: 0.8 }),
        (2.0, Event::NoteOff { key: 61, velocity: 0.5 }),
    ];
    let out = render(&mut synth, 3.0, &events, 256);
    let f = |from, to, guess| fine_peak(window(&out, from, to), guess);
    let (c4, cs4) = (261.6256, 277.1826);
    assert!(cents(f(0.2, 1.0, c4), c4).abs() < 0.3);
    assert!(cents(f(1.2, 2.0, cs4), cs4).abs() < 0.3, "the upper tangent did not take the string in tune");
    // Back to the lower tangent, still down: the string sounds C4 again.
    assert!(cents(f(2.2, 3.0, c4), c4).abs() < 0.3);
    assert_eq!(synth.active_keys(), 1, "one pair of strings");
}

#[test]
fn a_dulcimer_course_coupled_through_its_bridge_only_loses_energy() {
    // Unisons exactly in tune and pure fifths: the coupling has every chance to
    // pump energy between the strings, and must not.
    let tuning = struck_engine::tuning::TuningSettings {
        temperament: struck_engine::tuning::Temperament::Vallotti,
        ..Default::default()
    };
    let voicing = Voicing { unison_detune: 0.0, ..Voicing::default() };
    let settings = InstrumentSettings { voicing, tuning, ..default_settings(InstrumentKind::Dulcimer, FS) };
    let mut synth = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
    let out = render(&mut synth, 12.0, &[(0.0, Event::NoteOn { key: 67, velocity: 1.0 })], 1024);
    let levels: Vec<f64> = (0..6).map(|i| rms(window(&out, 1.0 + 2.0 * i as f64, 2.0 + 2.0 * i as f64))).collect();
    eprintln!("dulcimer G4 ringing, 2 s apart: {levels:?}");
    assert!(levels.windows(2).all(|w| w[1] < w[0]), "the ringing grew: {levels:?}");
    assert!(out.iter().all(|v| v.is_finite()));
}

#[test]
fn a_held_clavichord_key_stays_pressed_after_its_sound_has_died() {
    // The tangent keeps pressing on the string, and through it on the bridge,
    // as long as the key is down: once the sound has died the key must not
    // fall silent and drop that force (a thump, 0.2 of full scale at C6).
    for output in [Output::BridgeForce, Output::Microphones] {
        let settings = default_settings(InstrumentKind::Clavichord, FS).heard_through(output);
        let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
        s.set_controls(Controls { output, ..Controls::default() });
        let out = render(&mut s, 8.0, &[(0.0, Event::NoteOn { key: 84, velocity: 1.0 })], 256);
        let peak = |x: &[f32]| x.iter().fold(0.0f32, |m, v| m.max(v.abs()));
        let (ringing, after) = (peak(window(&out, 1.0, 2.0)), peak(window(&out, 2.0, 8.0)));
        assert!(after <= ringing, "{output:?}: {after:e} after 2 s against {ringing:e} at 1-2 s");
    }
}

#[test]
fn a_soft_release_lets_the_damper_down_slowly_and_the_note_fades_longer() {
    // C4 held half a second and let up at a release velocity of 1, 0.5 and
    // 0.1 (the damper's landing thump off): samples from the release until the
    // output has fallen 40 dB under its level then.
    let fade = |velocity: f64| {
        let mut s = synth(InstrumentKind::Piano);
        s.set_controls(Controls { damper_noise: 0.0, ..bridge() });
        let events = [(0.0, Event::NoteOn { key: 60, velocity: 0.7 }), (0.5, Event::NoteOff { key: 60, velocity })];
        let out = render(&mut s, 1.5, &events, 256);
        let at = (0.5 * FS) as usize;
        let frame = 96;
        let level = |i: usize| rms(&out[i..i + frame]);
        let start = level(at - frame);
        (at..out.len() - frame).step_by(frame / 4).find(|&i| level(i) < start * 0.01).map(|i| i - at)
    };
    let (hard, middling, soft) = (fade(1.0).unwrap(), fade(0.5).unwrap(), fade(0.1).unwrap());
    eprintln!(
        "C4 down 40 dB after its release in {hard} samples at release velocity 1, {middling} at 0.5, {soft} at 0.1"
    );
    // The felt settles in 7.5, 15 and 240 ms (a ramp of the damping: half its
    // time adds to the fade); the damper's decay takes about 0.15 s besides.
    assert!(hard <= middling && middling < soft, "{hard} {middling} {soft}");
    assert!(soft - middling >= (0.1 * FS) as usize, "{hard} {middling} {soft}");
}

#[test]
fn a_hand_held_mallet_meets_the_strings_anew_at_each_stroke() {
    // An uneven santoor mallet, held in the hand, meets a course's strings in
    // a new order at each stroke; a piano's uneven hammer, on its key, always
    // in the same one. Each course struck twice, at rest both times.
    let strokes = |kind: InstrumentKind, unevenness: f64| {
        let voicing = Voicing { hammer_unevenness: unevenness, ..Voicing::default() };
        let settings = InstrumentSettings { voicing, ..default_settings(kind, FS) };
        let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
        s.set_controls(bridge());
        let mut stroke = || {
            let out = render(&mut s, 0.2, &[(0.0, Event::NoteOn { key: 60, velocity: 0.7 })], 256);
            render(&mut s, 0.01, &[(0.0, Event::Reset)], 256);
            render(&mut s, 0.1, &[], 256);
            out
        };
        let (first, second) = (stroke(), stroke());
        first.iter().zip(&second).map(|(a, b)| (a - b).abs()).fold(0.0f32, f32::max)
    };
    // (A stroke after a reset is not quite the first: the body and the
    // strike's gain glide keep a trace, some 1e-5 of full scale.)
    let (santoor, level_santoor) = (strokes(InstrumentKind::Santoor, 1.0), strokes(InstrumentKind::Santoor, 0.0));
    let (piano, level_piano) = (strokes(InstrumentKind::Piano, 1.0), strokes(InstrumentKind::Piano, 0.0));
    println!(
        "second stroke against the first, largest difference: santoor {santoor:.2e} (level {level_santoor:.2e}), piano {piano:.2e} (level {level_piano:.2e})"
    );
    assert!(santoor > 100.0 * level_santoor, "the santoor's strokes were alike");
    assert!(piano < 10.0 * level_piano.max(1e-7), "the piano's uneven hammer changed between strokes");
}

#[test]
fn a_clavichord_key_let_go_leaves_its_strings_no_faster_than_they_can_throw_its_tangent() {
    // The tangent holds the strings aside, and through them loads the bridge;
    // let go, it falls back as fast as their push moves its mass (some
    // milliseconds), more slowly as a finger lets the key up slowly. The
    // load comes off that smoothly, so the body's lowest modes are not rung
    // as by a step: C4 (velocity 0.8, let go after 1 s, heard through the
    // microphones) must not rise over its own dying note when let go, and a
    // soft release must ring the body less than a hard one. (Left in 2 ms
    // whatever the release, the 50 ms after it stood 11 dB over the note's
    // last 50 ms, its peak 21 dB over its level.)
    let after_release = |velocity: f64| {
        let settings = struck_engine::synth::default_settings(InstrumentKind::Clavichord, FS);
        let mut s = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
        let events = [(0.0, Event::NoteOn { key: 60, velocity: 0.8 }), (1.0, Event::NoteOff { key: 60, velocity })];
        let out = render(&mut s, 1.6, &events, 256);
        let peak = window(&out, 1.0, 1.5).iter().fold(0.0f32, |m, v| m.max(v.abs())) as f64;
        let db = |x: f64, y: f64| 20.0 * (x / y).log10();
        let before = rms(window(&out, 0.95, 1.0));
        (db(rms(window(&out, 1.0, 1.05)), before), db(peak, before))
    };
    let (middling, soft, hard) = (after_release(0.5), after_release(0.05), after_release(1.0));
    eprintln!(
        "C4 let go, re its last 50 ms: (first 50 ms, peak) {middling:.1?} dB middling, {soft:.1?} soft, {hard:.1?} hard"
    );
    assert!(middling.0 < 3.0 && hard.0 < 3.0, "{middling:?} {hard:?}");
    assert!(soft.1 < middling.1 - 3.0, "{soft:?} against {middling:?}");
}

/// The output's guard ([`struck_engine::synth::guard`]): the largest sample
/// of a render heard through the microphones, as the plugin plays.
fn flood_peak(events: &[(f64, Event)], seconds: f64) -> (f32, struck_engine::synth::GuardReport) {
    let settings = struck_engine::synth::default_settings(InstrumentKind::Piano, FS);
    let mut synth = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
    let (left, right) = render_stereo(&mut synth, seconds, events, 512);
    assert!(left.iter().chain(&right).all(|v| v.is_finite()), "a sample is not finite");
    (left.iter().chain(&right).fold(0.0f32, |m, v| m.max(v.abs())), synth.guard())
}

/// +6 dBFS, the guard's ceiling.
const CEILING: f32 = 1.995_262_4;

#[test]
fn a_flood_of_notes_is_held_under_the_ceiling() {
    // A hundred thousand notes in a second, every key in turn at every
    // velocity (a MIDI feedback loop): +30 dBFS before the guard.
    let events: Vec<(f64, Event)> = (0..100_000)
        .map(|i| (i as f64 * 1e-5, Event::NoteOn { key: 21 + (i % 88) as u8, velocity: (1 + i % 127) as f64 / 127.0 }))
        .collect();
    let (peak, report) = flood_peak(&events, 1.5);
    assert!(peak <= CEILING, "peak {peak}");
    assert!(report.held_samples > 0 && report.deepest_db < -6.0, "{report:?}");
    assert_eq!(report.silenced, 0, "{report:?}");
}

#[test]
fn a_key_struck_a_thousand_times_is_held_under_the_ceiling() {
    // C4 struck a thousand times in a second at full velocity, never let
    // up (a runaway arpeggiator): +14.5 dBFS before the guard.
    let events: Vec<(f64, Event)> =
        (0..1000).map(|i| (i as f64 * 1e-3, Event::NoteOn { key: 60, velocity: 1.0 })).collect();
    let (peak, report) = flood_peak(&events, 1.5);
    assert!(peak <= CEILING, "peak {peak}");
    assert!(report.held_samples > 0, "{report:?}");
}

#[test]
fn ordinary_playing_never_meets_the_guard() {
    // Both hands' chord fortissimo with the pedal down, then a forte run
    // over it: the guard changes nothing. (Nine keys at the top velocity
    // with the pedal down reach +6.7 dBFS, where it holds them by 0.7 dB.)
    let mut events = vec![(0.0, Event::Sustain(1.0))];
    events.extend([36u8, 43, 48, 64, 67, 72, 76].map(|key| (0.01, Event::NoteOn { key, velocity: 1.0 })));
    events.extend((0..40u8).map(|i| (0.5 + 0.05 * i as f64, Event::NoteOn { key: 40 + i, velocity: 0.8 })));
    let (peak, report) = flood_peak(&events, 3.0);
    assert!(!report.acted(), "{report:?}, peak {peak}");
}

/// Decay of `x`'s level from `from_s` to `to_s`, dB/s (from its RMS in 50 ms
/// frames, a least-squares line).
fn decay_db_s(x: &[f32], from_s: f64, to_s: f64) -> f64 {
    let frame = (0.05 * FS) as usize;
    let points: Vec<(f64, f64)> = window(x, from_s, to_s)
        .chunks_exact(frame)
        .enumerate()
        .map(|(i, c)| (i as f64 * 0.05, 20.0 * rms(c).max(1e-30).log10()))
        .collect();
    let n = points.len() as f64;
    let (mt, ml) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let cov: f64 = points.iter().map(|p| (p.0 - mt) * (p.1 - ml)).sum();
    let var: f64 = points.iter().map(|p| (p.0 - mt).powi(2)).sum();
    -cov / var
}

fn built_with(voicing: Voicing) -> Synth {
    let settings = InstrumentSettings { voicing, ..default_settings(InstrumentKind::Piano, FS) };
    let mut synth = Synth::new(Box::new(Instrument::build(&settings).unwrap())).0;
    synth.set_controls(bridge());
    synth
}

#[test]
fn a_voicing_moved_while_playing_is_heard_as_one_built_with_it() {
    // The synth takes the strings' damping and the hammer live (no new
    // tables): C3 on the bridge force, the damping doubled 0.3 s into the
    // note, decays from then on as a piano built with it does; a hammer
    // twice as heavy, with felt 4 times as stiff, half the hysteresis and a
    // strike point moved in, strikes as a hammer built so does.
    let key = 48;
    let f = struck_engine::design::key_frequency_hz(key);
    let strike = [(0.0, Event::NoteOn { key, velocity: 0.7 })];
    let doubled = Voicing { damping: 2.0, ..Voicing::default() };
    let mut live = synth(InstrumentKind::Piano);
    let mut moved = render(&mut live, 0.3, &strike, 256);
    live.set_voicing(&doubled);
    moved.extend(render(&mut live, 1.5, &[], 256));
    let plain = render(&mut synth(InstrumentKind::Piano), 1.8, &strike, 256);
    let built = render(&mut built_with(doubled), 1.8, &strike, 256);
    let (d_plain, d_live, d_built) =
        (decay_db_s(&plain, 0.6, 1.8), decay_db_s(&moved, 0.6, 1.8), decay_db_s(&built, 0.6, 1.8));
    println!("C3 decay 0.6-1.8 s: {d_plain:.1} dB/s as built, {d_live:.1} doubled live, {d_built:.1} built doubled");
    assert!(d_live > 1.4 * d_plain, "the live damping is not heard");
    assert!((d_live / d_built - 1.0).abs() < 0.15, "live {d_live:.1} dB/s, built {d_built:.1} dB/s");

    let hammer = Voicing {
        hammer_mass: 2.0,
        hammer_stiffness: 4.0,
        felt_hysteresis: 0.5,
        strike_position: 0.8,
        ..Voicing::default()
    };
    let mut live = synth(InstrumentKind::Piano);
    live.set_voicing(&hammer);
    let live = render(&mut live, 0.6, &strike, 256);
    let built = render(&mut built_with(hammer), 0.6, &strike, 256);
    let plain = &plain[..live.len()];
    let brightness = |out: &[f32]| (9..=14).map(|n| partial_db(out, f, n)).sum::<f64>() / 6.0 - partial_db(out, f, 1);
    let (b_plain, b_live, b_built) = (brightness(plain), brightness(&live), brightness(&built));
    println!("C3 partials 9-14 re the 1st: {b_plain:.1} dB as built, {b_live:.1} live, {b_built:.1} built so");
    assert!((b_live - b_plain).abs() > 2.0, "the live hammer is not heard");
    assert!((b_live - b_built).abs() < 1.5, "live {b_live:.1} dB, built {b_built:.1} dB");
    // The exponent too: a felt hardening faster (alpha 1.5 times).
    let steeper = Voicing { hammer_exponent: 1.5, ..Voicing::default() };
    let mut live = synth(InstrumentKind::Piano);
    live.set_voicing(&steeper);
    let (live, built) = (render(&mut live, 0.6, &strike, 256), render(&mut built_with(steeper), 0.6, &strike, 256));
    let (b_live, b_built) = (brightness(&live), brightness(&built));
    println!("C3 with the felt's exponent 1.5 times: {b_live:.1} dB live, {b_built:.1} built so");
    assert!((b_live - b_built).abs() < 1.5 && (b_live - b_plain).abs() > 1.0, "{b_plain:.1} {b_live:.1} {b_built:.1}");
}

#[test]
fn an_instrument_built_with_the_live_voicing_takes_none_of_it_twice() {
    // The live factors are taken over what the playing instrument was built
    // with: once one built with the new voicing is installed, its keys play
    // as built, bit for bit.
    let doubled = Voicing { damping: 2.0, hammer_mass: 1.5, ..Voicing::default() };
    let strike = [(0.0, Event::NoteOn { key: 60, velocity: 0.7 })];
    let mut synth = synth(InstrumentKind::Piano);
    synth.set_voicing(&doubled);
    let settings = InstrumentSettings { voicing: doubled, ..default_settings(InstrumentKind::Piano, FS) };
    synth.install(Box::new(Instrument::build(&settings).unwrap()));
    let installed = render(&mut synth, 0.5, &strike, 256);
    let built = render(&mut built_with(doubled), 0.5, &strike, 256);
    assert!(installed.iter().zip(&built).all(|(a, b)| a.to_bits() == b.to_bits()));
    // And set back to the built voicing, a synth plays as it always did.
    let mut back = built_with(Voicing::default());
    back.set_voicing(&doubled);
    back.set_voicing(&Voicing::default());
    let plain = render(&mut built_with(Voicing::default()), 0.5, &strike, 256);
    assert!(render(&mut back, 0.5, &strike, 256).iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()));
}
