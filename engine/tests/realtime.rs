//! The audio thread allocates nothing, and what it plays stays sound: a long
//! randomised session at every sample rate Struck is meant for (22.05 to
//! 192 kHz), in host blocks of 1 to 8192 samples, with notes, pedals, bends,
//! every control thrown to the ends of its range and anywhere between, and
//! rebuilds (instrument, voicing, tuning, microphones, body or bridge) and
//! instrument switches delivered by the workshop thread, under an allocator that
//! counts what the audio thread asks for. Every sample is finite, bounded and
//! never subnormal.
//!
//! Each sample rate plays 12 s by default (a minute of audio in all, about
//! 10 s in release on two cores); `STRUCK_SOAK_SECONDS` sets the seconds per
//! rate for a longer soak, and `STRUCK_SOAK_SEED` another session.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::atomic::{AtomicUsize, Ordering};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

use struck_engine::body::Output;
use struck_engine::body::soundboard::{MicPlacement, Perspective};
use struck_engine::design::{InstrumentKind, Voicing};
use struck_engine::rng::Rng;
use struck_engine::synth::{
    Controls, Delivery, Event, Instrument, InstrumentSettings, MAX_PACED_LATENCY, Paced, Synth, TimedEvent, Workshop,
    default_settings,
};
use struck_engine::tuning::{Temperament, TuningSettings};

struct Counting;

thread_local! {
    static WATCHED: Cell<bool> = const { Cell::new(false) };
}
static ON_AUDIO_THREAD: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if WATCHED.try_with(|w| w.get()).unwrap_or(false) {
            ON_AUDIO_THREAD.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if WATCHED.try_with(|w| w.get()).unwrap_or(false) {
            ON_AUDIO_THREAD.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

/// The sample rates the sound is meant for, Hz.
const SAMPLE_RATES: [f64; 5] = [22_050.0, 44_100.0, 48_000.0, 96_000.0, 192_000.0];

/// Host block sizes always among those played (others are drawn from 1..=8192).
const BLOCK_SIZES: [usize; 5] = [1, 7, 64, 512, 8192];

/// Largest sample accepted at the loudest output gain (+12 dB): full scale
/// is 1, and the loudest chord of the loudest instrument stays within a few
/// times that.
const BOUND: f32 = 100.0;

/// Seconds of audio per sample rate.
fn soak_seconds() -> f64 {
    std::env::var("STRUCK_SOAK_SECONDS").ok().and_then(|v| v.trim().parse().ok()).unwrap_or(12.0)
}

/// The first sample rate's seed; each further rate takes the next.
fn soak_seed() -> u64 {
    std::env::var("STRUCK_SOAK_SEED").ok().and_then(|v| v.trim().parse().ok()).unwrap_or(0x5eed_1234_abcd)
}

#[test]
fn a_long_random_session_allocates_nothing_on_the_audio_thread() {
    // The counter itself works: one watched allocation (and its free) is seen.
    WATCHED.with(|w| w.set(true));
    drop(std::hint::black_box(Box::new(7u64)));
    WATCHED.with(|w| w.set(false));
    assert_eq!(ON_AUDIO_THREAD.swap(0, Ordering::Relaxed), 2);

    let (seconds, seed) = (soak_seconds(), soak_seed());
    for (i, fs) in SAMPLE_RATES.into_iter().enumerate() {
        session(fs, seconds, seed.wrapping_add(i as u64));
    }
}

/// A value at one end of `lo..=hi` a third of the time, else anywhere between.
fn extreme(rng: &mut Rng, lo: f64, hi: f64) -> f64 {
    match rng.below(6) {
        0 => lo,
        1 => hi,
        _ => lo + (hi - lo) * rng.unit(),
    }
}

/// Every control thrown: to either end of the range a preset or the plugin
/// allows, or anywhere between. The output gain spans the plugin's level, -60
/// to +12 dB, and silence.
fn random_controls(rng: &mut Rng) -> Controls {
    Controls {
        touch_min: extreme(rng, 0.0, 1.0),
        touch_max: extreme(rng, 0.0, 1.0),
        touch_shape: extreme(rng, 0.1, 10.0),
        polyphony: [1, 128, 1 + rng.below(128) as usize][rng.below(3) as usize],
        output_gain: [0.0, 1e-3, 10f64.powf(extreme(rng, -60.0, 12.0) / 20.0)][rng.below(3) as usize],
        bend_range_semitones: extreme(rng, 0.0, 48.0),
        bebung_cents: extreme(rng, 0.0, 100.0),
        velocity_floor: extreme(rng, 0.0, 0.5),
        velocity_ceiling: extreme(rng, 0.5, 1.0),
        output: [Output::Microphones, Output::BridgeForce][rng.below(2) as usize],
        sympathy: extreme(rng, 0.0, 1.0),
        phantom: extreme(rng, 0.0, 4.0),
        key_noise: extreme(rng, 0.0, 4.0),
        damper_noise: extreme(rng, 0.0, 4.0),
        pedal_noise: extreme(rng, 0.0, 4.0),
    }
}

/// Settings at `fs` with every rebuilding parameter thrown within the plugin's
/// ranges: instrument, voicing, tuning, microphones, strings on the body or not.
fn random_settings(rng: &mut Rng, fs: f64) -> InstrumentSettings {
    let voicing = Voicing {
        hammer_mass: extreme(rng, 0.25, 4.0),
        hammer_stiffness: extreme(rng, 0.25, 4.0),
        hammer_exponent: extreme(rng, 0.5, 2.0),
        strike_position: extreme(rng, 0.25, 4.0),
        damping: extreme(rng, 0.25, 4.0),
        unison_detune: extreme(rng, 0.0, 4.0),
        tangent_depth: extreme(rng, 0.5, 2.0),
        fretted: rng.below(2) == 0,
        board_size: extreme(rng, 0.5, 2.0),
        board_irregularity: extreme(rng, 0.0, 1.0),
        felt_hysteresis: extreme(rng, 0.0, 3.0),
        hammer_unevenness: extreme(rng, 0.0, 1.0),
    };
    // The historical temperaments (a Scala scale needs a file: the fuzzing tests cover those).
    let temperaments: Vec<Temperament> = Temperament::ALL.into_iter().filter(|t| *t != Temperament::Scala).collect();
    let tuning = TuningSettings {
        a4_hz: extreme(rng, 380.0, 480.0),
        temperament: temperaments[rng.below(temperaments.len() as u64) as usize],
        root: rng.below(12) as u8,
        stretch: extreme(rng, 0.0, 1.0),
        scale: None,
    };
    InstrumentSettings {
        kind: InstrumentKind::ALL[rng.below(InstrumentKind::ALL.len() as u64) as usize],
        voicing,
        sample_rate_hz: fs,
        tuning,
        mics: MicPlacement {
            perspective: Perspective::ALL[rng.below(Perspective::ALL.len() as u64) as usize],
            width: extreme(rng, 0.0, 1.0),
        },
        strings_on_body: rng.below(2) == 0,
    }
}

/// One key event, its values often at the ends of their ranges.
fn random_event(rng: &mut Rng) -> Event {
    let key = 21 + rng.below(88) as u8;
    let level = |rng: &mut Rng| [0.0, 1.0, rng.unit_f32()][rng.below(3) as usize];
    match rng.below(12) {
        0..=4 => Event::NoteOn {
            key,
            velocity: [1.0 / 127.0, 1.0, 0.05 + 0.95 * f64::from(rng.unit_f32())][rng.below(3) as usize],
        },
        5..=7 => Event::NoteOff { key, velocity: f64::from(level(rng)) },
        8 => Event::Sustain(level(rng)),
        9 => Event::PitchBend([-1.0, 1.0, 2.0 * rng.unit_f32() - 1.0][rng.below(3) as usize]),
        _ => match rng.below(10) {
            0 => Event::Sostenuto(level(rng)),
            1 => Event::UnaCorda(level(rng)),
            2 => Event::ModWheel(level(rng)),
            3 => Event::Pressure { key, pressure: level(rng) },
            4 => Event::AllNotesOff,
            5 => {
                let factor = |rng: &mut Rng| [1.0 / 16.0, 16.0, 0.25 + 3.75 * rng.unit_f32()][rng.below(3) as usize];
                Event::KeyHammer { key, hardness: factor(rng), position: factor(rng) }
            }
            6 => Event::KeyVolume { key, gain: 2.0 * level(rng) },
            7 => Event::KeyBend { key, semitones: 48.0 * (2.0 * rng.unit_f32() - 1.0) },
            8 => Event::KeyPan { key, pan: [-1.0, 1.0, 2.0 * rng.unit_f32() - 1.0][rng.below(3) as usize] },
            _ => Event::Reset,
        },
    }
}

/// Every sample finite, within [`BOUND`], and not subnormal (hosts must not be handed those).
fn check(samples: &[f32], fs: f64, at: usize) {
    for (i, s) in samples.iter().enumerate() {
        assert!(s.is_finite() && s.abs() < BOUND && !s.is_subnormal(), "sample {s:e} at {} at {fs} Hz", at + i);
    }
}

/// The audio thread's side of a session: the synth, its delivery of new
/// instruments, and a tally of what it played.
struct Player {
    /// Played late now and then (load smoothing), as the plugin may.
    synth: Paced,
    delivery: Delivery,
    fs: f64,
    left: Vec<f32>,
    right: Vec<f32>,
    rendered: usize,
    installs: usize,
    peak: f32,
}

impl Player {
    /// One host block of `n` samples under the allocation counter, then checked.
    fn play(&mut self, events: &[TimedEvent], n: usize, controls: Controls) {
        let before = self.synth.synth().settings().clone();
        WATCHED.with(|w| w.set(true));
        self.delivery.exchange(self.synth.synth_mut());
        self.synth.synth_mut().set_controls(controls);
        self.synth.process(events, &mut self.left[..n], &mut self.right[..n]);
        WATCHED.with(|w| w.set(false));
        check(&self.left[..n], self.fs, self.rendered);
        check(&self.right[..n], self.fs, self.rendered);
        self.peak = self.left[..n].iter().chain(&self.right[..n]).fold(self.peak, |p, v| p.max(v.abs()));
        self.rendered += n;
        if *self.synth.synth().settings() != before {
            self.installs += 1;
        }
    }

    /// Be heard `latency` samples late from the next block on, under the
    /// allocation counter.
    fn retime(&mut self, latency: usize) {
        WATCHED.with(|w| w.set(true));
        self.synth.set_latency(latency);
        WATCHED.with(|w| w.set(false));
    }
}

/// `seconds` of random playing and automation at `fs`, under the allocation counter.
fn session(fs: f64, seconds: f64, seed: u64) {
    let mut rng = Rng::new(seed);
    let first = random_settings(&mut rng, fs);
    let (synth, _scope) = Synth::new(Box::new(Instrument::build(&first).unwrap()));
    // What the "host" wants built: changed between the blocks below, read by the workshop.
    let wanted = Arc::new(Mutex::new(random_settings(&mut rng, fs)));
    let reader = wanted.clone();
    let (workshop, delivery) = Workshop::spawn(first, move || reader.lock().ok().map(|w| w.clone()));
    let latencies = [0, Paced::latency_for(fs), MAX_PACED_LATENCY];
    let mut player = Player {
        synth: Paced::new(synth, latencies[rng.below(3) as usize]),
        delivery,
        fs,
        left: vec![0.0; 8192],
        right: vec![0.0; 8192],
        rendered: 0,
        installs: 0,
        peak: 0.0,
    };

    let mut events: Vec<TimedEvent> = Vec::with_capacity(64);
    let mut controls = random_controls(&mut rng);
    let mut sizes_played = [false; BLOCK_SIZES.len()];
    let total = (seconds * fs) as usize;
    while player.rendered < total {
        let pick = rng.below(BLOCK_SIZES.len() as u64 + 2) as usize;
        let block = match BLOCK_SIZES.get(pick) {
            Some(&size) => {
                sizes_played[pick] = true;
                size
            }
            None => 1 + rng.below(8192) as usize,
        };
        events.clear();
        for _ in 0..rng.below(8) {
            events.push(TimedEvent::new(rng.below(block as u64) as u32, random_event(&mut rng)));
        }
        events.sort_by_key(|e| e.time);
        // Controls move now and then (held a while, the output gain's glide
        // reaches even silence); rebuilds are asked for less often.
        if rng.below(8) == 0 {
            controls = random_controls(&mut rng);
        }
        if rng.below(40) == 0 {
            *wanted.lock().unwrap() = random_settings(&mut rng, fs);
        }
        if rng.below(100) == 0 {
            player.retime(latencies[rng.below(3) as usize]);
        }
        player.play(&events, block, controls);
        // Give the workshop a moment now and then, as real time would.
        if rng.below(50) == 0 {
            std::thread::sleep(Duration::from_millis(30));
        }
    }
    // The last settings asked for arrive within a moment.
    let last = wanted.lock().unwrap().clone();
    let deadline = Instant::now() + Duration::from_secs(60);
    while *player.synth.synth().settings() != last {
        assert!(Instant::now() < deadline, "the workshop never delivered {last:?} at {fs} Hz");
        std::thread::sleep(Duration::from_millis(5));
        player.play(&[], 64, controls);
    }
    drop(workshop);
    assert_eq!(ON_AUDIO_THREAD.load(Ordering::Relaxed), 0, "the audio thread allocated or freed memory at {fs} Hz");
    assert!(sizes_played.iter().all(|p| *p), "every listed block size was played at {fs} Hz");
    let Player { installs, peak, .. } = player;
    assert!(installs >= 1, "the session should have installed new instruments at {fs} Hz ({installs})");
    assert!(peak > 0.01, "the session should have made sound at {fs} Hz (peak {peak})");
}

/// Found by the session above: with the output gain turned to 0, the gain's
/// glide went on toward silence for ever, and a ringing chord came out as
/// subnormal samples (4.99e-39 after 3.7 s at 22.05 kHz). The glide now
/// arrives, and silence is exact zeros.
#[test]
fn the_output_gain_turned_to_zero_gives_exact_silence_not_subnormals() {
    let settings = default_settings(InstrumentKind::Piano, 22_050.0);
    let (mut synth, _scope) = Synth::new(Box::new(Instrument::build(&settings).unwrap()));
    let chord: Vec<TimedEvent> =
        [48, 55, 60, 64, 67].map(|key| TimedEvent::new(0, Event::NoteOn { key, velocity: 1.0 })).to_vec();
    let (mut left, mut right) = (vec![0.0f32; 512], vec![0.0f32; 512]);
    synth.process(&chord, &mut left, &mut right);
    synth.set_controls(Controls { output_gain: 0.0, ..Controls::default() });
    for block in 0..100 {
        synth.process(&[], &mut left, &mut right);
        check(&left, 22_050.0, block * 512);
        check(&right, 22_050.0, block * 512);
    }
    assert!(left.iter().chain(&right).all(|s| *s == 0.0), "silence after 2.3 s at gain 0");
}
