//! The instrument's body, measured on what comes out of the synth (the targets
//! of the body's issue): the treble sings, a crescendo never dips, nothing
//! below 20 Hz, and a pair of microphones that hears a stereo image.
//!
//! The checks write their rows of docs/validation.md's tables of the body and
//! of the strings that share the bridge (`cargo xtask docs`).

use std::f64::consts::PI;

use struck_engine::body::Output;
use struck_engine::design::InstrumentKind;
use struck_engine::synth::{Controls, Event, Instrument, Synth, TimedEvent, default_settings, midi_velocity};

#[path = "support/validation_doc.rs"]
mod validation_doc;

const FS: f64 = 48_000.0;

fn synth(kind: InstrumentKind, output: Output) -> Synth {
    let settings = default_settings(kind, FS).heard_through(output);
    let (mut synth, _) = Synth::new(Box::new(Instrument::build(&settings).unwrap()));
    synth.set_controls(Controls { output, ..Controls::default() });
    synth
}

/// One note held from 0 for `seconds` (velocity 0..=1), left and right.
fn note(synth: &mut Synth, key: u8, velocity: f64, seconds: f64) -> (Vec<f64>, Vec<f64>) {
    note_pedalled(synth, key, velocity, seconds, false)
}

/// [`note`], the sustain pedal down with it if `pedal`.
fn note_pedalled(synth: &mut Synth, key: u8, velocity: f64, seconds: f64, pedal: bool) -> (Vec<f64>, Vec<f64>) {
    let total = (seconds * FS) as usize;
    let (mut left, mut right) = (vec![0.0f32; total], vec![0.0f32; total]);
    let mut start = 0;
    while start < total {
        let end = (start + 256).min(total);
        let mut events = Vec::new();
        if start == 0 {
            if pedal {
                events.push(TimedEvent::new(0, Event::Sustain(1.0)));
            }
            events.push(TimedEvent::new(0, Event::NoteOn { key, velocity }));
        }
        synth.process(&events, &mut left[start..end], &mut right[start..end]);
        start = end;
    }
    synth.process(&[TimedEvent::new(0, Event::Reset)], &mut [0.0; 64], &mut [0.0; 64]);
    let mut rest = [0.0f32; 256];
    for _ in 0..400 {
        let mut other = [0.0f32; 256];
        synth.process(&[], &mut rest, &mut other);
    }
    (left.iter().map(|&v| v as f64).collect(), right.iter().map(|&v| v as f64).collect())
}

/// A key's name as the doc writes it: 60 is C4.
fn key_name(key: u8) -> String {
    const NAMES: [&str; 12] = ["C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"];
    format!("{}{}", NAMES[usize::from(key % 12)], i32::from(key / 12) - 1)
}

fn mean_square(x: &[f64]) -> f64 {
    x.iter().map(|v| v * v).sum::<f64>() / x.len().max(1) as f64
}

fn db(power: f64) -> f64 {
    10.0 * power.max(1e-30).log10()
}

/// Ring level: the RMS of both channels 50-300 ms after the note-on, dB.
fn ring_db(left: &[f64], right: &[f64]) -> f64 {
    let (a, b) = ((0.05 * FS) as usize, (0.3 * FS) as usize);
    db(0.5 * (mean_square(&left[a..b]) + mean_square(&right[a..b])))
}

/// The strike's peak over the ring: the largest sample of the first 50 ms
/// against the ring's RMS, dB.
fn peak_to_ring_db(left: &[f64], right: &[f64]) -> f64 {
    let end = (0.05 * FS) as usize;
    let peak = left[..end].iter().chain(&right[..end]).fold(0.0f64, |m, v| m.max(v.abs()));
    db(peak * peak) - ring_db(left, right)
}

/// From 100 ms on: the correlation of left and right, and the mono sum's
/// power against the stereo pair's, dB.
fn stereo(left: &[f64], right: &[f64]) -> (f64, f64) {
    let (a, b) = ((0.1 * FS) as usize, left.len());
    let (l, r) = (&left[a..b], &right[a..b]);
    let cross = l.iter().zip(r).map(|(l, r)| l * r).sum::<f64>() / l.len() as f64;
    let correlation = cross / (mean_square(l) * mean_square(r)).sqrt();
    let mono: Vec<f64> = l.iter().zip(r).map(|(l, r)| 0.5 * (l + r)).collect();
    (correlation, db(mean_square(&mono)) - db(0.5 * (mean_square(l) + mean_square(r))))
}

/// A fourth-order Butterworth low-pass at `fc` (two biquads, bilinear).
fn low_pass(x: &[f64], fc: f64) -> Vec<f64> {
    let mut y = x.to_vec();
    for q in [0.541_196_1, 1.306_563] {
        let w = (PI * fc / FS).tan();
        let norm = 1.0 / (1.0 + w / q + w * w);
        let (b0, b1, b2) = (w * w * norm, 2.0 * w * w * norm, w * w * norm);
        let (a1, a2) = (2.0 * (w * w - 1.0) * norm, (1.0 - w / q + w * w) * norm);
        let (mut x1, mut x2, mut y1, mut y2) = (0.0, 0.0, 0.0, 0.0);
        for v in y.iter_mut() {
            let out = b0 * *v + b1 * x1 + b2 * x2 - a1 * y1 - a2 * y2;
            (x2, x1, y2, y1) = (x1, *v, y1, out);
            *v = out;
        }
    }
    y
}

#[test]
fn the_treble_falls_away_as_a_recorded_grands_and_its_knock_stays_in_bounds() {
    // The recorded Yamaha C5 (velocity layer 10, velocities 73-80): its ring
    // (50-300 ms) falls 19.6 dB from A4 to C8, and from C7 up a strike peaks
    // 21 to 26 dB over its ring. The piano is heard as built: its treble falls
    // away as much, give or take 8 dB. Its top octave knocks harder (C7 32 dB
    // over its ring at velocity 76, F7 37.7, C8 45.2: the close pair hears the
    // hammer's push on the body while the top strings ring faintly): the
    // octave's median within 12 dB of the recording's loudest, every key
    // within 20.
    let mut s = synth(InstrumentKind::Piano, Output::Microphones);
    let velocity = 76.0 / 127.0;
    let (mut rings, mut knocks) = (Vec::new(), Vec::new());
    for key in (69..=108).step_by(3).chain([108]) {
        let (l, r) = note(&mut s, key, velocity, 0.35);
        let ring = ring_db(&l, &r);
        let peak = peak_to_ring_db(&l, &r);
        println!("piano key {key}: ring {ring:6.1} dB, strike peak {peak:5.1} dB over it");
        rings.push((key, ring));
        if key >= 96 {
            assert!(peak <= 26.0 + 20.0, "key {key}: the strike peaks {peak:.1} dB over the ring");
            knocks.push(peak);
        }
    }
    knocks.sort_by(f64::total_cmp);
    let median = knocks[knocks.len() / 2];
    assert!(median <= 26.0 + 12.0, "the top octave's knock: {knocks:?}");
    let a4 = rings[0].1;
    let c8 = rings.last().map_or(a4, |r| r.1);
    let fall = a4 - c8;
    let over = rings.iter().map(|r| r.1 - a4).fold(f64::MIN, f64::max);
    println!("ring from A4 to C8: falls {fall:.1} dB, at most {over:+.1} dB over A4");
    assert!((19.6 - 8.0..=19.6 + 8.0).contains(&fall), "{rings:?}");
    // (F#5 stands 6.6 dB over A4, where the recording's is 0.8 dB over.)
    assert!(over <= 8.0, "{rings:?}");
    validation_doc::row(
        "row: body treble",
        &[
            "the piano's ring (RMS 50-300 ms, velocity 76, every third key) falls from A4 to C8 as the recorded \
             C5's (19.6 dB) within 8 dB, and no key rings more than 8 dB over A4"
                .to_string(),
            format!("falls {fall:.1} dB ({a4:.1} to {c8:.1} dBFS); at most {over:+.1} dB over A4"),
            "met".to_string(),
        ],
    );
    validation_doc::row(
        "row: body knock",
        &[
            "the top octave's strike peak over its ring: the median within 12 dB of the recording's loudest \
             (26 dB), every key within 20"
                .to_string(),
            format!("{:.1} to {:.1} dB, median {median:.1}", knocks[0], knocks[knocks.len() - 1]),
            "met".to_string(),
        ],
    );
}

#[test]
fn neighbouring_keys_ring_alike_at_every_touch() {
    // No key of the piano stands out from the keys beside it, soft or loud:
    // within 5 dB of the mean of its two neighbours (the knock-limited top
    // octave included). Keys are voiced at the level scale's touch (1.96
    // m/s, velocity 77), and evened out touch by touch where one rings over or under its
    // neighbours: a treble key's ring leaps by 6 to 13 dB over one step of 8
    // in velocity where its felt stiffens past the point its contact is short
    // enough to sound the fundamental, B7 leaps at a softer touch than its
    // neighbours, and A#6 and B6 set the undamped octave above them ringing
    // (their second partials on its strings' first), 5-7 dB of their ring
    // from about 1 m/s up, nothing at the softest touches (voiced with it,
    // they were holes there before the evening raised them). Before the
    // voicing weighed what rings with a key and evened up as well as down, B6
    // stood 5.2-5.7 dB over its neighbours from 2 m/s on (velocity 79 up) and
    // F6 6-7 dB under them below 1.2 m/s (velocity 60).
    let mut s = synth(InstrumentKind::Piano, Output::Microphones);
    let mut worsts = Vec::new();
    for velocity in [40u8, 64, 80, 100, 120] {
        let rings: Vec<(u8, f64)> = (21..=108)
            .map(|key| {
                let (l, r) = note(&mut s, key, midi_velocity(velocity), 0.3);
                (key, ring_db(&l, &r))
            })
            .collect();
        let mut worst = (0u8, 0.0f64);
        for w in rings.windows(3) {
            let off = w[1].1 - 0.5 * (w[0].1 + w[2].1);
            if off.abs() > worst.1.abs() {
                worst = (w[1].0, off);
            }
        }
        println!(
            "piano at velocity {velocity}: the key furthest from its neighbours is {} at {:+.1} dB",
            worst.0, worst.1
        );
        assert!(
            worst.1.abs() <= 5.0,
            "velocity {velocity}: key {} rings {:+.1} dB off its neighbours",
            worst.0,
            worst.1
        );
        worsts.push((velocity, worst));
    }
    let most = worsts.iter().map(|w| w.1.1.abs()).fold(0.0, f64::max);
    let shown: Vec<String> = worsts
        .iter()
        .map(|(v, (key, off))| {
            let side = if *off < 0.0 { "under" } else { "over" };
            format!("{} {:.1} dB {side} at {v}", key_name(*key), off.abs())
        })
        .collect();
    validation_doc::section(
        "figure: body neighbours",
        &format!("{most:.1} dB at velocities 40, 64, 80, 100 and 120 (the furthest: {})", shown.join(", ")),
    );
}

/// The amplitude (dB) of the strongest component within `band_hz` of `x`
/// (Hann-windowed, searched every 0.25 Hz).
fn peak_in_band_db(x: &[f64], band_hz: (f64, f64)) -> f64 {
    let n = x.len() as f64;
    let window: Vec<f64> = (0..x.len()).map(|i| x[i] * (0.5 - 0.5 * (2.0 * PI * i as f64 / n).cos())).collect();
    let steps = ((band_hz.1 - band_hz.0) / 0.25).ceil() as usize;
    (0..=steps)
        .map(|j| {
            let w = 2.0 * PI * (band_hz.0 + j as f64 * 0.25) / FS;
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in window.iter().enumerate() {
                let (s, c) = (w * i as f64).sin_cos();
                re += v * c;
                im -= v * s;
            }
            db(re * re + im * im)
        })
        .fold(f64::MIN, f64::max)
}

/// Decay rates (dB/s) of a held note's first `count` partials, from their
/// amplitudes over 0.3-0.8 s and 2.0-2.5 s of the mono sum.
fn partial_decays_db_s(left: &[f64], right: &[f64], f1_hz: f64, count: usize) -> Vec<f64> {
    let mono: Vec<f64> = left.iter().zip(right).map(|(l, r)| l + r).collect();
    let frame = |t: f64| &mono[(t * FS) as usize..((t + 0.5) * FS) as usize];
    (1..=count)
        .map(|n| {
            let f = n as f64 * f1_hz;
            let band = (0.99 * f, 1.03 * f + 1.0);
            (peak_in_band_db(frame(0.3), band) - peak_in_band_db(frame(2.0), band)) / 1.7
        })
        .collect()
}

/// On the rigid, resistive bridge A0's partials 1-10 decay within 3 % of one
/// rate. On the body each partial loses energy into the
/// board as its admittance at that frequency says: on a resonance fast,
/// between two slowly.
#[test]
fn each_partial_decays_at_its_own_rate_through_the_body() {
    let (mut spreads, mut spans) = (Vec::new(), Vec::new());
    for output in [Output::BridgeForce, Output::Microphones] {
        let mut s = synth(InstrumentKind::Piano, output);
        let (l, r) = note(&mut s, 21, 80.0 / 127.0, 2.6);
        let rates = partial_decays_db_s(&l, &r, 27.5, 10);
        let (lo, hi) = rates.iter().fold((f64::MAX, f64::MIN), |(a, b), &v| (a.min(v), b.max(v)));
        let shown: Vec<String> = rates.iter().map(|v| format!("{v:.1}")).collect();
        println!(
            "piano A0 {output:?}: partials 1-10 decay at {} dB/s (slowest to fastest {:.2}x)",
            shown.join(" "),
            hi / lo
        );
        assert!(rates.iter().all(|&v| v > 0.0), "{output:?}: {rates:?}");
        spreads.push(hi / lo);
        spans.push((lo, hi));
    }
    assert!(spreads[1] > 1.5 && spreads[1] > 1.3 * spreads[0], "{spreads:?}");
    validation_doc::row(
        "row: body partial decays",
        &[
            "each partial's decay follows the board: piano A0 held (velocity 80), the rates of partials 1-10 \
             through the body span at least 1.5x, and 1.3x as much as on the resistive bridge"
                .to_string(),
            format!(
                "{:.1} to {:.1} dB/s through the body ({:.1} to {:.1} on the resistive bridge)",
                spans[1].0, spans[1].1, spans[0].0, spans[0].1
            ),
            "met".to_string(),
        ],
    );
}

/// The ring of `key` at velocities 8, 16, ..., 120, 127 (velocity, dB).
fn crescendo(s: &mut Synth, key: u8) -> Vec<(u8, f64)> {
    (8..=127)
        .step_by(8)
        .chain([127])
        .map(|v| {
            let (l, r) = note(s, key, midi_velocity(v), 0.3);
            (v, ring_db(&l, &r))
        })
        .collect()
}

/// Every key of every instrument, through the microphones: the ring never
/// falls by more than 0.5 dB from one velocity to the next 8 above it.
#[test]
fn a_crescendo_never_dips_on_any_key_of_any_instrument() {
    let worst = std::thread::scope(|scope| {
        let handles: Vec<_> = InstrumentKind::ALL
            .into_iter()
            .map(|kind| {
                scope.spawn(move || {
                    let mut s = synth(kind, Output::Microphones);
                    let mut worst = (0u8, 0u8, f64::MIN);
                    let mut from = 0u8;
                    for key in kind.key_range() {
                        let levels = crescendo(&mut s, key);
                        for w in levels.windows(2) {
                            let fall = w[0].1 - w[1].1;
                            if fall > worst.2 {
                                worst = (key, w[1].0, fall);
                                from = w[0].0;
                            }
                        }
                        let shown: Vec<String> = levels.iter().map(|(v, r)| format!("{v}:{r:.1}")).collect();
                        assert!(
                            levels.windows(2).all(|w| w[1].1 > w[0].1 - 0.5),
                            "{kind} key {key}: the ring falls as the velocity rises ({})",
                            shown.join(" ")
                        );
                    }
                    println!(
                        "{kind}: the largest fall is {:.2} dB (key {}, velocity {})",
                        worst.2.max(0.0),
                        worst.0,
                        worst.1
                    );
                    (kind, worst, from)
                })
            })
            .collect();
        let worsts = handles.into_iter().map(|h| h.join().expect("every key of the instrument passes"));
        worsts.max_by(|a, b| a.1.2.total_cmp(&b.1.2)).expect("instruments")
    });
    let (kind, (key, velocity, fall), from) = worst;
    validation_doc::row(
        "row: body crescendo",
        &[
            "the ring never falls by more than 0.5 dB from one velocity to the next 8 up, every key of every \
             instrument (velocities 8 to 127)"
                .to_string(),
            format!("at most {:.2} dB ({kind} {} from velocity {from} to {velocity})", fall.max(0.0), key_name(key)),
            "met".to_string(),
        ],
    );
}

/// The share of the first 0.3 s's energy that lies below 0.8 times `f0_hz`
/// (Hann window, padded to four times its length), dB: how much of a note is
/// a boom of the body's lowest modes (as `struck compare` measures it).
fn boom_share_db(mono: &[f64], f0_hz: f64) -> f64 {
    let n = (0.3 * FS) as usize;
    let mut planner = realfft::RealFftPlanner::<f64>::new();
    let fft = planner.plan_fft_forward(4 * n);
    let mut input = vec![0.0; 4 * n];
    for (i, (x, v)) in input.iter_mut().zip(mono).take(n).enumerate() {
        *x = v * (0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos());
    }
    let mut spectrum = fft.make_output_vec();
    fft.process(&mut input, &mut spectrum).unwrap();
    let bin_hz = FS / (4 * n) as f64;
    let (mut low, mut total) = (0.0, 0.0);
    for (k, c) in spectrum.iter().enumerate() {
        total += c.norm_sqr();
        if (k as f64) * bin_hz < 0.8 * f0_hz {
            low += c.norm_sqr();
        }
    }
    db(low / total)
}

/// The strike pushes the bridge, and the body's lowest modes ring from it:
/// a thud under every note, which must stay under the note. Keys from C4 up,
/// every third, at velocity 92, the cimbalom's pedal down (as it is played:
/// without it the dampers stop a note within half a second): the share of a
/// note's first 0.3 s below 0.8 f0. The recorded Yamaha C5 keeps -12 dB on C6
/// (-23 to -32 dB from C4 to A5, up to -1 dB at C8 where the hammer's knock
/// outlasts the string); FluidR3's recorded dulcimer -22 to -32 dB, its
/// harpsichord -25 to -33 dB. The boxed instruments keep their median under
/// -10 dB and every key under -7 (clavichord -18 and -15 dB, cimbalom -17 and
/// -10.5, santoor -14 and -8, dulcimer -13 and -8), the piano its median (its
/// top octave knocks as the recording's does); the fortepiano's open board
/// is held where it is (median -6.4 dB, worst -2.4: docs/calibration.md).
#[test]
fn the_body_does_not_boom_under_the_strikes() {
    for kind in InstrumentKind::ALL {
        let mut s = synth(kind, Output::Microphones);
        let range = kind.key_range();
        let mut shares = Vec::new();
        for key in (60.max(*range.start())..=*range.end()).step_by(3) {
            let pedal = kind == InstrumentKind::Cimbalom;
            let (l, r) = note_pedalled(&mut s, key, 92.0 / 127.0, 0.35, pedal);
            let mono: Vec<f64> = l.iter().zip(&r).map(|(l, r)| l + r).collect();
            shares.push((key, boom_share_db(&mono, struck_engine::design::key_frequency_hz(key))));
        }
        let mut sorted: Vec<f64> = shares.iter().map(|s| s.1).collect();
        sorted.sort_by(f64::total_cmp);
        let (median, worst) = (sorted[sorted.len() / 2], sorted[sorted.len() - 1]);
        println!(
            "{kind}: below 0.8 f0 median {median:.1} dB, worst {worst:.1} dB: {}",
            shares.iter().map(|(k, v)| format!("{k}:{v:.0}")).collect::<Vec<_>>().join(" ")
        );
        let (median_at_most, worst_at_most) = match kind {
            InstrumentKind::Fortepiano => (-6.0, -2.0),
            InstrumentKind::Piano => (-10.0, 0.0),
            _ => (-10.0, -7.0),
        };
        assert!(median <= median_at_most && worst <= worst_at_most, "{kind}: {shares:?}");
    }
}

#[test]
fn nothing_comes_out_below_20_hz() {
    let (mut most, mut least) = ((String::new(), f64::MIN), f64::MAX);
    for kind in InstrumentKind::ALL {
        let mut s = synth(kind, Output::Microphones);
        let range = kind.key_range();
        let (lo, hi) = (*range.start(), *range.end());
        for key in [lo, lo + (hi - lo) / 2, hi - 3] {
            let (l, r) = note(&mut s, key, 1.0, 1.0);
            let mono: Vec<f64> = l.iter().zip(&r).map(|(l, r)| 0.5 * (l + r)).collect();
            let below = db(mean_square(&low_pass(&mono, 20.0))) - db(mean_square(&mono));
            println!("{kind} key {key}: energy below 20 Hz {below:.1} dB under the whole");
            assert!(below <= -30.0, "{kind} key {key}: {below:.1} dB");
            if below > most.1 {
                most = (format!("{kind} {}", key_name(key)), below);
            }
            least = least.min(below);
        }
    }
    validation_doc::row(
        "row: body below 20 Hz",
        &[
            "energy below 20 Hz at least 30 dB under the whole, every instrument (lowest, middle and a high key, \
             velocity 127)"
                .to_string(),
            format!("{:.1} dB ({}) to {least:.0} dB", most.1, most.0),
            "met".to_string(),
        ],
    );
}

#[test]
fn a_sustained_middle_note_is_heard_in_stereo_and_survives_mono() {
    let (mut piano, mut others) = (String::new(), Vec::new());
    for kind in InstrumentKind::ALL {
        let mut s = synth(kind, Output::Microphones);
        let range = kind.key_range();
        let key = (*range.start() + *range.end()) / 2;
        let (l, r) = note(&mut s, key, 0.7, 1.0);
        let (correlation, mono_db) = stereo(&l, &r);
        println!("{kind} key {key}: L/R correlation {correlation:.3}, mono sum {mono_db:.1} dB");
        // The piano's pair over its 1.6 m^2 board hears a wide image; a small
        // box (the clavichord's) radiates mostly through its volume modes and
        // is near mono close up, as it is in life.
        if kind == InstrumentKind::Piano {
            assert!(correlation < 0.9, "{kind}: {correlation:.3}");
            assert!(mono_db >= -3.0, "{kind}: {mono_db:.1} dB");
            piano = format!("piano {}: {correlation:.2} and {mono_db:.1} dB", key_name(key));
        } else {
            others.push((correlation, format!("{kind} {}", key_name(key))));
        }
        assert!(mono_db >= -6.0, "{kind}: the pair cancels in mono, {mono_db:.1} dB");
    }
    others.sort_by(|a, b| a.0.total_cmp(&b.0));
    let (low, high) = (&others[0], &others[others.len() - 1]);
    validation_doc::row(
        "row: body stereo",
        &[
            "a sustained middle note (velocity 89): L/R correlation under 0.9, mono sum at least -3 dB (the piano; \
             every instrument's mono sum at least -6 dB)"
                .to_string(),
            format!(
                "{piano} (the other instruments' correlation {:.2}, {}, to {:.2}, {})",
                low.0, low.1, high.0, high.1
            ),
            "met".to_string(),
        ],
    );
}

#[test]
fn the_loudest_touch_peaks_under_minus_1_dbfs_through_the_microphones() {
    let mut s = synth(InstrumentKind::Piano, Output::Microphones);
    let mut worst = (0, f64::MIN);
    for key in (21..=108).step_by(3).chain([108]) {
        let (l, r) = note(&mut s, key, 1.0, 0.3);
        let peak = l.iter().chain(&r).fold(0.0f64, |m, v| m.max(v.abs()));
        let dbfs = 20.0 * peak.log10();
        if dbfs > worst.1 {
            worst = (key, dbfs);
        }
    }
    println!("loudest peak through the microphones: key {} at {:.1} dBFS", worst.0, worst.1);
    assert!(worst.1 <= -1.0, "key {} peaks at {:.1} dBFS", worst.0, worst.1);
    validation_doc::row(
        "row: body loudest",
        &[
            "the loudest touch under -1 dBFS through the microphones (every third piano key)".to_string(),
            format!("{:.1} dBFS at most ({})", worst.1, key_name(worst.0)),
            "met".to_string(),
        ],
    );
}

/// Every instrument from every perspective, its compass played note by note
/// (every key, velocity 89, 0.6 s each): what the mono sum keeps of the stereo
/// pair's power over them all, and each perspective's worst single note. The
/// spaced pairs keep most of it over a compass, but a note can lose much more
/// (the modes either side of a node across the board reach the two microphones
/// in opposite phase); the coincident pair's mono sum is its mid microphone
/// alone, and no note loses more than 3 dB.
#[test]
fn every_instrument_survives_mono_from_every_perspective() {
    use struck_engine::body::soundboard::{MicPlacement, Perspective};
    use struck_engine::synth::InstrumentSettings;
    // Per instrument, per perspective: over the compass, and the worst note (dB, key).
    type Kept = (InstrumentKind, Perspective, f64, (f64, u8));
    let kept: Vec<Kept> = std::thread::scope(|scope| {
        let handles: Vec<_> = InstrumentKind::ALL
            .into_iter()
            .map(|kind| {
                scope.spawn(move || {
                    let mut kept_all = Vec::new();
                    for perspective in Perspective::ALL {
                        let settings = InstrumentSettings {
                            mics: MicPlacement { perspective, width: 1.0 },
                            ..default_settings(kind, FS)
                        };
                        let (mut s, _) = Synth::new(Box::new(Instrument::build(&settings).unwrap()));
                        let (mut mono, mut pair) = (0.0, 0.0);
                        let mut worst = (0.0f64, 0u8);
                        for key in kind.key_range() {
                            let (l, r) = note(&mut s, key, 0.7, 0.6);
                            let a = (0.1 * FS) as usize;
                            let m: Vec<f64> = l[a..].iter().zip(&r[a..]).map(|(l, r)| 0.5 * (l + r)).collect();
                            let (pm, pp) = (mean_square(&m), 0.5 * (mean_square(&l[a..]) + mean_square(&r[a..])));
                            mono += pm;
                            pair += pp;
                            if db(pm) - db(pp) < worst.0 {
                                worst = (db(pm) - db(pp), key);
                            }
                        }
                        let kept = db(mono) - db(pair);
                        println!(
                            "{kind} {}: mono keeps {kept:.1} dB over the compass; worst note {} at {:.1} dB",
                            perspective.name(),
                            key_name(worst.1),
                            worst.0
                        );
                        kept_all.push((kind, perspective, kept, worst));
                    }
                    kept_all
                })
            })
            .collect();
        handles.into_iter().flat_map(|h| h.join().expect("every perspective renders")).collect()
    });
    for &(kind, perspective, over, (note_db, key)) in &kept {
        assert!(over >= -3.0, "{kind} {}: mono keeps {over:.1} dB over the compass", perspective.name());
        if perspective == Perspective::Coincident {
            assert!(note_db >= -3.0, "{kind} {} from coincident: {note_db:.1} dB in mono", key_name(key));
        }
    }
    let from = |perspective: Perspective| match perspective {
        Perspective::Player => "the player's seat",
        Perspective::Lid => "over the lid",
        other => other.name(),
    };
    let note = |(kind, perspective, _, (note_db, key)): &Kept| {
        format!("{note_db:.1} dB on the {kind}'s {} from {}", key_name(*key), from(*perspective))
    };
    let spaced: Vec<&Kept> = kept.iter().filter(|k| k.1 != Perspective::Coincident).collect();
    let (low, high) = spaced.iter().fold((f64::MAX, f64::MIN), |(a, b), k| (a.min(k.2), b.max(k.2)));
    validation_doc::section("figure: body mono", &format!("{high:.1} to {low:.1} dB"));
    let mut notes = spaced.clone();
    notes.sort_by(|a, b| a.3.0.total_cmp(&b.3.0));
    validation_doc::section("figure: body mono notes", &format!("{}, {}", note(notes[0]), note(notes[1])));
    let rows: Vec<Vec<String>> = Perspective::ALL
        .into_iter()
        .map(|perspective| {
            let of: Vec<&Kept> = kept.iter().filter(|k| k.1 == perspective).collect();
            let (low, high) = of.iter().fold((f64::MAX, f64::MIN), |(a, b), k| (a.min(k.2), b.max(k.2)));
            let worst = of.iter().min_by(|a, b| a.3.0.total_cmp(&b.3.0)).expect("seven instruments");
            let (kind, (note_db, key)) = (worst.0, worst.3);
            vec![
                perspective.name().to_string(),
                format!("{high:.1} to {low:.1} dB"),
                format!("{note_db:.1} dB ({kind} {})", key_name(key)),
            ]
        })
        .collect();
    validation_doc::table(
        "table: body mono perspectives",
        &["perspective", "a compass in mono (the seven instruments)", "the worst note in mono"],
        &rows,
    );
}

#[test]
#[ignore = "a measurement to look at, not a check"]
fn print_stereo_for_every_perspective() {
    use struck_engine::body::soundboard::{MicPlacement, Perspective};
    use struck_engine::synth::InstrumentSettings;
    for kind in InstrumentKind::ALL {
        for perspective in Perspective::ALL {
            let settings =
                InstrumentSettings { mics: MicPlacement { perspective, width: 1.0 }, ..default_settings(kind, FS) };
            let (mut s, _) = Synth::new(Box::new(Instrument::build(&settings).unwrap()));
            let range = kind.key_range();
            let mut line = format!("{kind} {}:", perspective.name());
            for key in [*range.start() + 7, (*range.start() + *range.end()) / 2, *range.end() - 7] {
                let (l, r) = note(&mut s, key, 0.7, 1.0);
                let (c, m) = stereo(&l, &r);
                line += &format!(" {key}: {c:.2} {m:.1} dB;");
            }
            println!("{line}");
        }
    }
}

#[test]
#[ignore = "a measurement to look at, not a check"]
fn print_ring_evenness_of_every_instrument() {
    for kind in InstrumentKind::ALL {
        for output in [Output::Microphones, Output::BridgeForce] {
            let mut s = synth(kind, output);
            let range = kind.key_range();
            let rings: Vec<f64> = range
                .clone()
                .step_by(3)
                .map(|key| {
                    let (l, r) = note(&mut s, key, 80.0 / 127.0, 0.35);
                    ring_db(&l, &r)
                })
                .collect();
            let (lo, hi) = rings.iter().fold((f64::MAX, f64::MIN), |(a, b), &r| (a.min(r), b.max(r)));
            println!("{kind} {output:?}: ring {lo:.1} to {hi:.1} dB, span {:.1} dB", hi - lo);
            if std::env::var_os("STRUCK_SHOW_RINGS").is_some() {
                let shown: Vec<String> =
                    range.clone().step_by(3).zip(&rings).map(|(k, r)| format!("{k}:{r:.1}")).collect();
                println!("  {}", shown.join(" "));
            }
        }
    }
}

/// Least-squares slope of `y` against `x`.
fn slope(points: &[(f64, f64)]) -> f64 {
    let n = points.len() as f64;
    let (mx, my) = (points.iter().map(|p| p.0).sum::<f64>() / n, points.iter().map(|p| p.1).sum::<f64>() / n);
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let sxx: f64 = points.iter().map(|p| (p.0 - mx) * (p.0 - mx)).sum();
    sxy / sxx
}

/// The fundamental's level (dB) of a held note in 0.2 s frames starting at
/// each of `times`.
fn fundamental_db(mono: &[f64], f1_hz: f64, times: impl Iterator<Item = f64>) -> Vec<(f64, f64)> {
    times
        .map(|t| {
            let a = (t * FS) as usize;
            let frame = &mono[a..a + (0.2 * FS) as usize];
            (t + 0.1, peak_in_band_db(frame, (0.985 * f1_hz, 1.015 * f1_hz)))
        })
        .collect()
}

/// Weinreich's prompt sound and aftersound: a unison's strings struck
/// together swing in step and load the bridge as one, then what differs
/// between them (their mistuning turns them apart) rings on without moving it.
#[test]
fn a_held_note_decays_fast_then_slowly() {
    let mut s = synth(InstrumentKind::Piano, Output::Microphones);
    let (mut doubled, mut shown) = (Vec::new(), Vec::new());
    for key in [48u8, 60, 72] {
        let (l, r) = note(&mut s, key, 80.0 / 127.0, 7.3);
        let mono: Vec<f64> = l.iter().zip(&r).map(|(l, r)| l + r).collect();
        let f1 = 440.0 * 2f64.powf((key as f64 - 69.0) / 12.0);
        let early = -slope(&fundamental_db(&mono, f1, (0..=16).map(|i| 0.15 + 0.05 * i as f64)));
        let late = -slope(&fundamental_db(&mono, f1, (0..=16).map(|i| 3.0 + 0.25 * i as f64)));
        println!("piano key {key}: the fundamental falls {early:.1} dB/s over 0.15-1 s, {late:.1} dB/s over 3-7 s");
        shown.push(format!("{} {early:.1} dB/s then {late:.1}", key_name(key)));
        // Twice as fast at first as later (a later level that no longer falls,
        // the strings turning in and out of step, counts), and a prompt sound
        // that does fall.
        if early >= 2.0 * late && early >= 4.0 {
            doubled.push(key);
        }
    }
    assert!(doubled.len() >= 2, "a double decay on {doubled:?} only");
    validation_doc::row(
        "row: bridge double decay",
        &[
            "double decay: the fundamental's rate over 0.15-1 s at least twice that over 3-7 s and at least 4 dB/s, \
             for two of C3, C4, C5 (velocity 80, held)"
                .to_string(),
            shown.join("; "),
            "met".to_string(),
        ],
    );
}

/// Weinreich's uneven hammer: a crown out of level strikes a unison's strings
/// unequally, so what differs between them (the aftersound, which does not
/// move the bridge) starts at once instead of waiting for their mistuning to
/// turn them apart: a held note's fundamental keeps more of its level into
/// the aftersound (and its prompt sound falls more slowly, by how much
/// depends on which string the hammer meets hardest against the mistuning).
/// The unisons are spread a cent at C4 here: the piano's own fifth of a
/// cent sits within the bridge's hold, where what differs between the
/// strings barely reaches the bridge at all.
#[test]
fn an_uneven_hammer_starts_the_aftersound_at_once() {
    let measure = |key: u8, unevenness: f64| {
        let voicing =
            struck_engine::design::Voicing { hammer_unevenness: unevenness, unison_detune: 5.0, ..Default::default() };
        let settings = struck_engine::synth::InstrumentSettings {
            voicing,
            ..default_settings(InstrumentKind::Piano, FS).heard_through(Output::Microphones)
        };
        let (mut s, _) = Synth::new(Box::new(Instrument::build(&settings).unwrap()));
        s.set_controls(Controls { output: Output::Microphones, ..Controls::default() });
        let (l, r) = note(&mut s, key, 80.0 / 127.0, 5.3);
        let mono: Vec<f64> = l.iter().zip(&r).map(|(l, r)| l + r).collect();
        let f1 = 440.0 * 2f64.powf((key as f64 - 69.0) / 12.0);
        let early = fundamental_db(&mono, f1, (0..=16).map(|i| 0.15 + 0.05 * i as f64));
        let late = fundamental_db(&mono, f1, (0..=8).map(|i| 3.0 + 0.25 * i as f64));
        let mean = |p: &[(f64, f64)]| p.iter().map(|p| p.1).sum::<f64>() / p.len() as f64;
        (-slope(&early), mean(&late) - early[0].1)
    };
    for key in [48u8, 60, 72] {
        let (level_rate, level_kept) = measure(key, 0.0);
        let (uneven_rate, uneven_kept) = measure(key, 1.0);
        println!(
            "key {key} at velocity 80: level hammer: prompt {level_rate:.1} dB/s, 3-5 s at {level_kept:.1} dB re 0.15 s; \
             uneven: {uneven_rate:.1} dB/s, {uneven_kept:.1} dB"
        );
        // (Measured: the fundamental at 3-5 s 2.9, 11.5 and 8.4 dB higher on
        // C3, C4 and C5, the prompt sound 0.3, 0.3 and 14.0 dB/s slower.)
        assert!(uneven_kept > level_kept + 2.0, "key {key}: {uneven_kept:.1} against {level_kept:.1} dB");
    }
}
