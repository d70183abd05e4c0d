//! The speed goals' workloads, played through the real-time [`Synth`] exactly as
//! a host would: 48 kHz, 64-sample blocks, one thread.
//!
//! - The full keyboard: every piano key struck (one per block, bottom to top)
//!   and held with the sustain pedal down; halfway through, a 10-key chord is
//!   struck on one sample, and three quarters through a two-handed 20-key
//!   fortissimo chord; then every key and the pedal come up.
//! - A 32-key chord held for 10 s, rendered offline (512-sample blocks).
//! - Silence: the piano with nothing played.
//!
//! Every block is timed. A shared machine interrupts a run now and then, so each
//! workload runs several times and each block keeps its fastest time (the work
//! is the same on every run: the synth is deterministic); a load is the fastest
//! run's total over the audio's duration.

use std::time::Instant;

use struck_engine::design::InstrumentKind;
use struck_engine::synth::{Controls, Event, Instrument, Paced, Scope, Synth, TimedEvent, default_settings};

pub const SAMPLE_RATE_HZ: f64 = 48_000.0;
/// The host's block, samples.
pub const BLOCK: usize = 64;
/// MIDI velocity 102, as a fraction.
pub const VELOCITY: f64 = 102.0 / 127.0;
/// The 10-key chord struck into the ringing keyboard: C3 E3 G3 C4 E4 G4 C5 E5 G5 C6.
pub const CHORD10: [u8; 10] = [48, 52, 55, 60, 64, 67, 72, 76, 79, 84];
/// Where in its block the 10-key chord lands (any sample: not on a boundary).
const CHORD10_OFFSET: u32 = 17;
/// A pianist's two-handed fortissimo chord, 20 keys (about 60 strings in
/// contact at once): C2 G2 C3 E3 G3 B3 | C4 D4 E4 G4 A4 C5 D5 E5 G5 A5 C6 E6 G6 C7.
pub const CHORD20: [u8; 20] = [36, 43, 48, 52, 55, 59, 60, 62, 64, 67, 69, 72, 74, 76, 79, 81, 84, 88, 91, 96];
/// MIDI velocity 120 (fortissimo), as a fraction.
pub const CHORD20_VELOCITY: f64 = 120.0 / 127.0;
/// Where in its block the 20-key chord lands.
const CHORD20_OFFSET: u32 = 41;
/// Blocks after a chord's strike in which its hammers are on the strings (the
/// bass's contacts last a few milliseconds: a few blocks).
const CHORD_BLOCKS: usize = 8;
/// The comparison chord: C2 plus these intervals, then the same an octave and
/// two octaves up; the first 32 notes are played.
pub const CHORD32_INTERVALS: [u8; 12] = [0, 7, 12, 16, 19, 24, 28, 31, 36, 40, 43, 48];
const C2: u8 = 36;
const OFFLINE_BLOCK: usize = 512;

/// The 32 notes of the comparison chord (some keys twice: a key struck twice on
/// one sample is struck once).
pub fn chord32() -> Vec<u8> {
    (0..3).flat_map(|octave| CHORD32_INTERVALS.map(|i| C2 + 12 * octave + i)).take(32).collect()
}

/// Per-block times of one workload, fastest over the runs.
struct Timings {
    block_s: Vec<f64>,
    total_s: f64,
}

impl Timings {
    fn merge(&mut self, run: Vec<f64>) {
        let total: f64 = run.iter().sum();
        if self.block_s.is_empty() {
            self.block_s = run;
            self.total_s = total;
            return;
        }
        for (best, t) in self.block_s.iter_mut().zip(run) {
            *best = best.min(t);
        }
        self.total_s = self.total_s.min(total);
    }
}

/// What the keyboard workloads play with: the strings on the body, coupled
/// as unisons, and either everything else too (sympathetic strings, phantom
/// partials, the action's sounds) or none of it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Extras {
    On,
    Off,
}

/// The built-in piano, and its live view's side: a real-time workload keeps
/// it, as the plugin does (the synth then follows the key last struck), an
/// offline one drops it, as `struck render` does.
fn piano(polyphony: usize, extras: Extras) -> (Synth, Scope) {
    let instrument =
        Instrument::build(&default_settings(InstrumentKind::Piano, SAMPLE_RATE_HZ)).expect("the built-in piano builds");
    let (mut synth, scope) = Synth::new(Box::new(instrument));
    let controls = match extras {
        Extras::On => Controls { polyphony, ..Controls::default() },
        Extras::Off => Controls {
            polyphony,
            sympathy: 0.0,
            phantom: 0.0,
            key_noise: 0.0,
            damper_noise: 0.0,
            pedal_noise: 0.0,
            ..Controls::default()
        },
    };
    synth.set_controls(controls);
    (synth, scope)
}

/// What the full-keyboard workload measured. Fractions are of one core (a
/// block's time over its period).
#[derive(Clone, Copy, Debug)]
pub struct KeyboardRun {
    /// Modes of all 88 keys, every unison string, every mode below 20 kHz.
    pub modes: usize,
    /// Mean number of modes computed while the keys were held (after culling).
    pub running_modes_mean: f64,
    /// Load from the first strike until the keys come up.
    pub load_fraction: f64,
    /// Slowest block in that time (the 10-key chord's included).
    pub worst_block_fraction: f64,
    /// Slowest block while the 10-key chord's hammers are on the strings.
    pub chord_block_fraction: f64,
    /// Slowest block while the 20-key chord's hammers are on the strings.
    pub chord20_block_fraction: f64,
    /// Load over the seconds after every key and the pedal came up.
    pub after_release_load_fraction: f64,
    /// Slowest block in that time.
    pub after_release_worst_block_fraction: f64,
    /// Keys still sounding at the end, and how long after the release the last fell silent, s.
    pub keys_left: usize,
    pub silent_after_s: Option<f64>,
    /// Seconds held, and seconds after the release.
    pub held_s: f64,
    pub release_s: f64,
}

/// Whether a real-time workload is played with load smoothing, as the plugin
/// plays by default: the synth [`Paced`], heard 128 samples late, so a burst
/// of work spreads over the blocks after it. How much of it a block takes
/// then depends on the clock, so each run's blocks are judged together (the
/// fastest run's worst block), not block by block across runs.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Smoothing {
    Off,
    On,
}

/// The full keyboard held for `held_s` seconds, then released for `release_s`,
/// fastest block of `runs` runs, with or without the [`Extras`], with or
/// without load [`Smoothing`].
pub fn full_keyboard(held_s: f64, release_s: f64, runs: usize, extras: Extras, smoothing: Smoothing) -> KeyboardRun {
    let period_s = BLOCK as f64 / SAMPLE_RATE_HZ;
    let held_blocks = ((held_s / period_s).ceil() as usize).max(2 * 88);
    let release_blocks = ((release_s / period_s).ceil() as usize).max(1);
    let chord_block = held_blocks / 2;
    let chord20_block = held_blocks * 3 / 4;
    let keys: Vec<u8> = InstrumentKind::Piano.key_range().collect();
    let mut timings = Timings { block_s: Vec::new(), total_s: 0.0 };
    let mut modes = 0;
    let mut running_sum = 0.0;
    let mut silent_at = None;
    let mut keys_left = 0;
    let (mut left, mut right) = ([0.0f32; BLOCK], [0.0f32; BLOCK]);
    let mut events = Vec::with_capacity(128);
    let mut each_run = Vec::new();
    // (With no latency the synth renders each block as it comes, in one go.)
    let latency = if smoothing == Smoothing::On { Paced::latency_for(SAMPLE_RATE_HZ) } else { 0 };
    for run in 0..runs.max(1) {
        let (synth, _scope) = piano(128, extras);
        modes = synth.instrument().mode_count();
        let mut synth = Paced::new(synth, latency);
        let mut times = Vec::with_capacity(held_blocks + release_blocks);
        for b in 0..held_blocks + release_blocks {
            events.clear();
            if b == 0 {
                events.push(TimedEvent::new(0, Event::Sustain(1.0)));
            }
            if let Some(&key) = keys.get(b) {
                events.push(TimedEvent::new(0, Event::NoteOn { key, velocity: VELOCITY }));
            }
            if b == chord_block {
                events.extend(
                    CHORD10.map(|key| TimedEvent::new(CHORD10_OFFSET, Event::NoteOn { key, velocity: VELOCITY })),
                );
            }
            if b == chord20_block {
                events.extend(
                    CHORD20
                        .map(|key| TimedEvent::new(CHORD20_OFFSET, Event::NoteOn { key, velocity: CHORD20_VELOCITY })),
                );
            }
            if b == held_blocks {
                events.extend(keys.iter().map(|&key| TimedEvent::new(0, Event::NoteOff { key, velocity: 0.5 })));
                events.push(TimedEvent::new(0, Event::Sustain(0.0)));
            }
            let start = Instant::now();
            synth.process(&events, &mut left, &mut right);
            times.push(start.elapsed().as_secs_f64());
            let synth = synth.synth();
            if run == 0 {
                if b < held_blocks {
                    running_sum += synth.running_modes() as f64;
                }
                if b >= held_blocks && silent_at.is_none() && synth.active_keys() == 0 {
                    silent_at = Some((b + 1 - held_blocks) as f64 * period_s);
                }
            }
        }
        if run == 0 {
            keys_left = synth.synth().active_keys();
        }
        if smoothing == Smoothing::On {
            each_run.push(times);
        } else {
            timings.merge(times);
        }
    }
    let blocks = &timings.block_s;
    let worst = |range: std::ops::Range<usize>| {
        let of = |blocks: &[f64]| blocks[range.clone()].iter().copied().fold(0.0, f64::max) / period_s;
        if each_run.is_empty() { of(blocks) } else { each_run.iter().map(|b| of(b)).fold(f64::INFINITY, f64::min) }
    };
    let mean = |range: std::ops::Range<usize>| {
        let n = range.len() as f64;
        let of = |blocks: &[f64]| blocks[range.clone()].iter().sum::<f64>() / (n * period_s);
        if each_run.is_empty() { of(blocks) } else { each_run.iter().map(|b| of(b)).fold(f64::INFINITY, f64::min) }
    };
    let held = 0..held_blocks;
    // (Smoothed, a chord's work moves up to the latency's blocks later.)
    let chord_blocks = CHORD_BLOCKS + latency.div_ceil(BLOCK);
    let after = held_blocks..held_blocks + release_blocks;
    KeyboardRun {
        modes,
        running_modes_mean: running_sum / held_blocks as f64,
        load_fraction: mean(held.clone()),
        worst_block_fraction: worst(held),
        chord_block_fraction: worst(chord_block..chord_block + chord_blocks),
        chord20_block_fraction: worst(chord20_block..chord20_block + chord_blocks),
        after_release_load_fraction: mean(after.clone()),
        after_release_worst_block_fraction: worst(after),
        keys_left,
        silent_after_s: silent_at,
        held_s: held_blocks as f64 * period_s,
        release_s: release_blocks as f64 * period_s,
    }
}

/// Offline render speed of the 32-note chord held for `held_s`: seconds of audio
/// per second of computing, fastest of `runs`. Also returns how many keys it
/// sounds.
pub fn chord32_realtime_factor(held_s: f64, runs: usize) -> (f64, usize) {
    let blocks = (held_s * SAMPLE_RATE_HZ / OFFLINE_BLOCK as f64).ceil() as usize;
    let (mut left, mut right) = (vec![0.0f32; OFFLINE_BLOCK], vec![0.0f32; OFFLINE_BLOCK]);
    let notes: Vec<TimedEvent> =
        chord32().into_iter().map(|key| TimedEvent::new(0, Event::NoteOn { key, velocity: VELOCITY })).collect();
    let mut best = f64::INFINITY;
    let mut keys = 0;
    for _ in 0..runs.max(1) {
        let (mut synth, _) = piano(64, Extras::On);
        let mut elapsed = 0.0;
        for b in 0..blocks {
            let events = if b == 0 { &notes[..] } else { &[] };
            let start = Instant::now();
            synth.process(events, &mut left, &mut right);
            elapsed += start.elapsed().as_secs_f64();
            if b == 0 {
                keys = synth.active_keys();
            }
        }
        best = best.min(elapsed);
    }
    (blocks as f64 * OFFLINE_BLOCK as f64 / SAMPLE_RATE_HZ / best, keys)
}

/// Load of the piano with nothing played, over `audio_s`, fastest of `runs`.
pub fn idle_load(audio_s: f64, runs: usize) -> f64 {
    let blocks = ((audio_s * SAMPLE_RATE_HZ / BLOCK as f64).ceil() as usize).max(1);
    let (mut left, mut right) = ([0.0f32; BLOCK], [0.0f32; BLOCK]);
    let mut best = f64::INFINITY;
    for _ in 0..runs.max(1) {
        let (mut synth, _scope) = piano(64, Extras::On);
        let start = Instant::now();
        for _ in 0..blocks {
            synth.process(&[], &mut left, &mut right);
        }
        best = best.min(start.elapsed().as_secs_f64());
    }
    best / (blocks as f64 * BLOCK as f64 / SAMPLE_RATE_HZ)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_comparison_chord_is_the_published_one() {
        let chord = chord32();
        assert_eq!(chord.len(), 32);
        assert_eq!(&chord[..12], &[36, 43, 48, 52, 55, 60, 64, 67, 72, 76, 79, 84]);
        assert_eq!(&chord[24..], &[60, 67, 72, 76, 79, 84, 88, 91]);
        assert!(chord.iter().all(|k| InstrumentKind::Piano.key_range().contains(k)));
    }

    #[test]
    fn the_two_handed_chord_is_twenty_piano_keys() {
        let mut keys = CHORD20.to_vec();
        keys.dedup();
        assert_eq!(keys.len(), 20);
        assert!(keys.windows(2).all(|w| w[0] < w[1]));
        assert!(keys.iter().all(|k| InstrumentKind::Piano.key_range().contains(k)));
    }
}

/// A voicing parameter a host's automation moves ([`automated_bounce`]).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Automated {
    /// The strings' damping, 0.5..=2 (the synth takes it live between builds).
    Damping,
    /// The body's board size, 0.8..=1.25 (heard only once built).
    BoardSize,
}

impl Automated {
    pub fn label(self) -> &'static str {
        match self {
            Automated::Damping => "damping",
            Automated::BoardSize => "board_size",
        }
    }
}

/// How a plugin host bounces the piano offline with a 2 Hz LFO on `param`:
/// the voicing set every 64-sample block (what the synth takes live, it takes
/// then), the instrument rebuilt by the workshop when the automation asks
/// ([`struck_engine::synth::OfflineBuilds`]: at once, then about once every
/// [`struck_engine::synth::REBUILD_SPACING_S`] of audio while it moves), a four-note chord struck every half second with
/// the pedal down, `audio_s` long. Seconds of audio per second of wall
/// clock (building included), fastest of `runs`, and the builds of the
/// fastest.
pub fn automated_bounce(param: Automated, audio_s: f64, runs: usize) -> (f64, usize) {
    use std::sync::{Arc, Mutex};
    use struck_engine::synth::{OfflineBuilds, Workshop};
    let blocks = ((audio_s * SAMPLE_RATE_HZ / BLOCK as f64).ceil() as usize).max(1);
    let chord = [48u8, 55, 64, 72];
    let mut best = (0.0, 0);
    for _ in 0..runs.max(1) {
        let start = Instant::now();
        let settings = default_settings(InstrumentKind::Piano, SAMPLE_RATE_HZ);
        let asked = Arc::new(Mutex::new(settings.clone()));
        let mut synth = Synth::new(Box::new(Instrument::build(&settings).expect("the piano builds"))).0;
        let reader = asked.clone();
        let (workshop, mut delivery) =
            Workshop::spawn(settings, move || Some(reader.lock().unwrap_or_else(|e| e.into_inner()).clone()));
        let mut builds = OfflineBuilds::new(SAMPLE_RATE_HZ);
        let (mut left, mut right) = (vec![0.0f32; BLOCK], vec![0.0f32; BLOCK]);
        let mut events = Vec::with_capacity(8);
        let mut built = 0;
        for b in 0..blocks {
            let t = (b * BLOCK) as f64 / SAMPLE_RATE_HZ;
            let lfo = (std::f64::consts::TAU * 2.0 * t).sin();
            let wanted = {
                let mut asked = asked.lock().unwrap_or_else(|e| e.into_inner());
                match param {
                    Automated::Damping => asked.voicing.damping = 2f64.powf(lfo),
                    Automated::BoardSize => asked.voicing.board_size = 1.25f64.powf(lfo),
                }
                asked.clone()
            };
            if builds.due(wanted.clone(), BLOCK) {
                delivery.catch_up(&mut synth);
                built += 1;
            }
            synth.set_voicing(&wanted.voicing);
            events.clear();
            if b == 0 {
                events.push(TimedEvent::new(0, Event::Sustain(1.0)));
            }
            let half = (0.5 * SAMPLE_RATE_HZ) as usize;
            if (b * BLOCK) % half < BLOCK {
                let velocity = if (b * BLOCK / half).is_multiple_of(2) { VELOCITY } else { 0.5 };
                events.extend(chord.iter().map(|&key| TimedEvent::new(0, Event::NoteOn { key, velocity })));
            }
            synth.process(&events, &mut left, &mut right);
        }
        drop(workshop);
        let factor = blocks as f64 * BLOCK as f64 / SAMPLE_RATE_HZ / start.elapsed().as_secs_f64();
        if factor > best.0 {
            best = (factor, built);
        }
    }
    best
}
