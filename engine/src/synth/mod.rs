//! The real-time instrument: keys, pedals and the audio-thread loop.
//!
//! An [`Instrument`] holds every key's precomputed tables and state; it is built
//! off the audio thread ([`Instrument::build`], or by a [`Workshop`] thread
//! whenever the settings change) and handed to the [`Synth`], which plays it.
//! [`Synth::process`] never allocates, locks or waits.
//!
//! Keys, not notes (engine-numerics 5): a note-on strikes the key's strings in
//! whatever state they are in. Processing is split at events and at every
//! [`CONTROL_BLOCK`] samples of the synth's own clock, where dampers move,
//! bends retune, silent keys stop and the live view is fed. The split points
//! depend only on the events' times, so any host block size gives the same samples.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

mod body_voicing;
mod event;
pub mod guard;
mod paced;
pub mod scope;
mod sympathy;
#[cfg(test)]
mod tuning_safety;
mod workshop;

use serde::{Deserialize, Serialize};

pub use event::{BendRouter, Event, HAMMER_SPAN, HammerRouter, PressureRouter, TimedEvent, cc};
pub use guard::{GuardReport, Silenced};
pub use paced::{Ahead, MAX_PACED_LATENCY, PACED_BUDGET, PACED_LATENCY_S, Paced};
pub use scope::{Scope, ScopeFrame};
pub use workshop::{Delivery, OfflineBuilds, REBUILD_SPACING_S, Workshop};

use crate::body::boards;
use crate::body::load::BoardLoad;
use crate::body::soundboard::{BODY_TOP_HZ, HeardModes, MicPlacement, Soundboard};
use crate::body::{Bridge, Output};
use crate::design::{self, InstrumentKind, KeyDesign, LiveVoicing, Touch, TouchRange, Voicing, key_frequency_hz};
use crate::key::{ActionNoise, Key, SYMPATHY_BLOCKS};
use crate::performance::{LIFT_SPREAD_BLOCKS, OwnNote, PerformanceState};
use crate::string::StringError;
use crate::tuning::TuningSettings;
use body_voicing::{Voiced, Voicer, heard_pa_per_n};
use scope::ScopeWriter;
use sympathy::Sympathy;

pub use crate::CONTROL_BLOCK;
pub use crate::key::MAX_BEBUNG_CENTS;
pub use crate::performance::SOFTEST_MALLET;

/// A key whose output can no longer exceed this (-120 dBFS) stops computing.
pub const SILENCE: f64 = 1e-6;
/// A stolen key fades out over this long, s.
pub const STEAL_FADE_S: f64 = 0.005;
/// Keys of an instrument being replaced by another fade out over this long, s.
pub const SWITCH_FADE_S: f64 = 0.02;
/// Highest mode frequency kept, Hz (lower at low sample rates: 0.45 fs).
pub const MAX_MODE_FREQUENCY_HZ: f64 = 20_000.0;
/// Sample rates an instrument can be built for, Hz (hosts may ask for odd ones; the
/// sound is meant for 22.05 to 192 kHz).
pub const MIN_SAMPLE_RATE_HZ: f64 = 1_000.0;
pub const MAX_SAMPLE_RATE_HZ: f64 = 768_000.0;
/// Chunk length while the live view records a strike.
const SCOPE_CHUNK: usize = 8;
/// The most threads an instrument's keys are voiced on when it is built.
const MAX_VOICING_THREADS: usize = 8;

/// The release velocity of a key released by a note-on at velocity 0 (MIDI's
/// default, 64).
const DEFAULT_RELEASE: f64 = 64.0 / 127.0;

/// Corner of the output's DC blocker, Hz (a pressed tangent holds a static force).
const DC_BLOCK_HZ: f64 = 5.0;

/// What an instrument's tables depend on. Changing any of these means a rebuild.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InstrumentSettings {
    pub kind: InstrumentKind,
    pub voicing: Voicing,
    pub sample_rate_hz: f64,
    pub tuning: TuningSettings,
    /// Where the body's microphones listen from.
    #[serde(default)]
    pub mics: MicPlacement,
    /// Whether the strings bear on the body (their partials lose energy into it
    /// and are pulled in pitch by it, as its admittance says), or on the seed's
    /// rigid, resistive bridge: what [`Output::BridgeForce`] stands for.
    #[serde(default = "bear_on_body")]
    pub strings_on_body: bool,
}

fn bear_on_body() -> bool {
    true
}

impl InstrumentSettings {
    /// These settings for an instrument heard through `output`: the strings
    /// bear on the body when the microphones hear it.
    pub fn heard_through(self, output: Output) -> Self {
        Self { strings_on_body: output == Output::Microphones, ..self }
    }
}

/// Why an instrument could not be built.
#[derive(Debug, thiserror::Error)]
pub enum BuildError {
    #[error("sample rate {0} Hz is outside 1000..=768000 Hz")]
    SampleRate(f64),
    #[error("{kind} key {key}: {source}")]
    String { kind: InstrumentKind, key: u8, source: StringError },
}

/// Settings read once per block, needing no rebuild.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Controls {
    /// Softest and hardest touch as fractions 0..=1 of the instrument's touch
    /// range, on a logarithmic scale.
    pub touch_min: f64,
    pub touch_max: f64,
    /// Velocity curve exponent, raised before the instrument's own curve
    /// ([`TouchRange::curve`]): 1 as built, above 1 needs a harder touch.
    pub touch_shape: f64,
    /// Most keys sounding at once.
    pub polyphony: usize,
    /// Linear output gain.
    pub output_gain: f64,
    /// Pitch-wheel range, semitones.
    pub bend_range_semitones: f64,
    /// Bebung: how far full aftertouch raises a held clavichord note, cents.
    /// The finger presses the tangent deeper (the depth follows the pressure)
    /// and the pitch rises as the press stretches the string: with the square
    /// of the depth, reaching this at full pressure.
    pub bebung_cents: f64,
    /// The player's softest and loudest velocity, 0..=1 (MIDI velocity / 127):
    /// they play the instrument's softest and hardest touch (a velocity learn
    /// sets them; 0 and 1 take velocities as they come).
    pub velocity_floor: f64,
    pub velocity_ceiling: f64,
    /// What is heard: the body through its microphones, or the bridge force.
    pub output: Output,
    /// How strongly the strings ring with each other through the body, 0..=1
    /// of the physics (sympathetic resonance).
    pub sympathy: f64,
    /// How loud the strings' phantom partials are, 0..=4 times the physics
    /// (above 1: the wood's own, which the strings' model leaves out).
    pub phantom: f64,
    /// How loud the action's sounds are, 0..=4 times the physics: a key
    /// striking its bed, a damper landing on its strings, the dampers
    /// lifting off them together under the pedal.
    pub key_noise: f64,
    pub damper_noise: f64,
    pub pedal_noise: f64,
}

impl Default for Controls {
    fn default() -> Self {
        Self {
            touch_min: 0.0,
            touch_max: 1.0,
            touch_shape: 1.0,
            polyphony: 64,
            output_gain: 1.0,
            bend_range_semitones: 2.0,
            bebung_cents: 20.0,
            velocity_floor: 0.0,
            velocity_ceiling: 1.0,
            output: Output::Microphones,
            sympathy: 1.0,
            phantom: 1.0,
            key_noise: 1.0,
            damper_noise: 1.0,
            pedal_noise: 1.0,
        }
    }
}

impl Controls {
    /// The action's sounds' levels, each held to 0..=4.
    pub(crate) fn noise(&self) -> ActionNoise {
        let level = |v: f64| if v.is_finite() { v.clamp(0.0, 4.0) } else { 1.0 };
        ActionNoise { key_bed: level(self.key_noise), damper: level(self.damper_noise), pedal: level(self.pedal_noise) }
    }

    /// A velocity (0..=1) within the player's range, as 0..=1 of it: the
    /// floor or under is 0, the ceiling or over 1. A range of no width (or an
    /// upside-down one) takes velocities as they come.
    pub fn played_velocity(&self, velocity: f64) -> f64 {
        let (floor, ceiling) = (self.velocity_floor.clamp(0.0, 1.0), self.velocity_ceiling.clamp(0.0, 1.0));
        let v = velocity.clamp(0.0, 1.0);
        if ceiling > floor { ((v - floor) / (ceiling - floor)).clamp(0.0, 1.0) } else { v }
    }

    /// The touch (exciter speed or pluck height) for a velocity in (0, 1],
    /// through the player's range and the curve.
    pub fn touch(&self, range: TouchRange, velocity: f64) -> Touch {
        let (min, max) = range.bounds();
        let span = (max / min).ln();
        let lo = self.touch_min.clamp(0.0, 1.0);
        let hi = self.touch_max.clamp(0.0, 1.0);
        let v = range.share(self.played_velocity(velocity).powf(self.touch_shape.clamp(0.1, 10.0)));
        range.with(min * (span * (lo + (hi - lo) * v)).exp())
    }
}

/// Every key of one instrument, built for one sample rate.
pub struct Instrument {
    settings: InstrumentSettings,
    /// The courses, each at the index of the MIDI key it is listed under.
    keys: Vec<Option<Key>>,
    /// For every MIDI key: the course it plays and which of its notes it is.
    route: [Option<(u8, u8)>; 128],
    touch: TouchRange,
    /// What its keys drive, the body those forces set ringing, and what the
    /// body's microphones heard last.
    bridge: Box<Bridge>,
    soundboard: Soundboard,
    heard: Box<[[f64; CONTROL_BLOCK]; 2]>,
    /// A key's force over a stretch, as it sounds.
    force: Box<[f64; CONTROL_BLOCK]>,
    /// The pairs of partials of different keys that trade through the body.
    sympathy: Sympathy,
}

impl Instrument {
    /// Build every key's tables. Allocates; takes tens of milliseconds.
    pub fn build(settings: &InstrumentSettings) -> Result<Self, BuildError> {
        let fs = settings.sample_rate_hz;
        if !(MIN_SAMPLE_RATE_HZ..=MAX_SAMPLE_RATE_HZ).contains(&fs) {
            return Err(BuildError::SampleRate(fs));
        }
        let max_frequency_hz = MAX_MODE_FREQUENCY_HZ.min(0.45 * fs);
        let designs: Vec<KeyDesign> = settings
            .kind
            .key_range()
            .filter_map(|k| design::key_design(settings.kind, &settings.voicing, k, max_frequency_hz))
            .collect();
        let frequencies_hz = settings.tuning.frequencies_hz(&|k| {
            let design = designs.iter().find(|d| d.midi_key == k)?;
            let spec = design.strings.get(design.struck.start)?;
            spec.build().ok().map(|s| s.inharmonicity)
        });
        let board = boards::design(settings.kind).scaled(settings.voicing.board_size);
        let mics = settings.mics.positions(&board);
        let load = settings.strings_on_body.then(|| BoardLoad::new(&board, settings.voicing.board_irregularity));
        let mut keys: Vec<Option<Key>> = (0..128).map(|_| None).collect();
        let mut route = [None; 128];
        for design in designs {
            let midi_key = design.midi_key;
            let moved = (frequencies_hz[midi_key as usize] / key_frequency_hz(midi_key) - 1.0).abs() > 1e-9;
            let design = design.retuned(&frequencies_hz);
            {
                match Key::build(design, fs, settings.kind, load.as_ref()) {
                    Ok(key) => {
                        for (note, k) in key.note_keys() {
                            route[k as usize & 127] = Some((midi_key, note as u8));
                        }
                        keys[midi_key as usize] = Some(key);
                    }
                    // At a very low sample rate the top keys have no partial below Nyquist: they stay silent.
                    Err(StringError::NoModes { .. }) => {}
                    // A tuning can ask a string for a pitch it cannot reach (a Scala
                    // file's key hundreds of octaves off): that key stays silent.
                    Err(_) if moved => {}
                    Err(source) => return Err(BuildError::String { kind: settings.kind, key: midi_key, source }),
                }
            }
        }
        let sympathy = match &load {
            Some(load) => Sympathy::build(load, &keys, (SYMPATHY_BLOCKS * CONTROL_BLOCK) as f64 / fs),
            None => Sympathy::none(),
        };
        // The body's gain puts the middle key's partials where the bridge-force
        // output has them; every other key is voiced through the body to ring as
        // its own partials would there (a technician's regulation: the body still
        // shapes each note's spectrum, decay and image, not the keyboard's
        // evenness).
        let heard = HeardModes::new(&board, BODY_TOP_HZ.min(0.45 * fs), mics);
        let middle = heard_pa_per_n(&board, &heard, board.middle_key(), frequencies_hz[board.middle_key() as usize]);
        let soundboard = Soundboard::build(&board, fs, &board.zone_points(), mics, middle.max(1e-12).recip());
        let range = settings.kind.touch_range();
        let ringing = range.level_touch();
        // Where each key bears on the body, and what it sets ringing of the
        // strings that ring free beside it (the undamped treble, a dulcimer's
        // courses), heard where they bear.
        let shapes: Vec<Vec<f64>> = (0..128u8)
            .map(|k| if keys[k as usize].is_some() { heard.shapes(&board.share_points(k)) } else { Vec::new() })
            .collect();
        let partners: Vec<Vec<body_voicing::Partner>> =
            (0..128u8).map(|k| body_voicing::partners(&sympathy, &keys, k, &shapes)).collect();
        // Keys are voiced one by one, each from a body at rest: on every core,
        // the keys dealt out in turn (a treble key costs more than a bass one).
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, MAX_VOICING_THREADS);
        let mut hands: Vec<Vec<(u8, &mut Key)>> = (0..cores).map(|_| Vec::new()).collect();
        for (i, (k, key)) in
            keys.iter_mut().enumerate().filter_map(|(k, key)| Some((k as u8, key.as_mut()?))).enumerate()
        {
            hands[i % cores].push((k, key));
        }
        let voicer = Voicer {
            board: &board,
            heard_modes: &heard,
            shapes: &shapes,
            partners: &partners,
            range,
            ringing,
            regulate: settings.strings_on_body,
        };
        fn voice_hand<'k>(
            voicer: &Voicer,
            hand: Vec<(u8, &'k mut Key)>,
            body: &mut Soundboard,
        ) -> Vec<(u8, &'k mut Key, Voiced)> {
            hand.into_iter()
                .map(|(k, key)| {
                    let v = voicer.voice(key, k, body);
                    (k, key, v)
                })
                .collect()
        }
        let mut voiced: Vec<(u8, &mut Key, Voiced)> = std::thread::scope(|scope| {
            // A hand goes to its thread once the thread runs; one no thread
            // could be started for (a limit on threads or memory) is voiced
            // here, the same (each key from a body at rest).
            let mut workers = Vec::new();
            let mut here = Vec::new();
            for hand in hands {
                let (give, take) = std::sync::mpsc::channel::<Vec<(u8, &mut Key)>>();
                let (voicer, mut body) = (&voicer, soundboard.clone());
                let worker = std::thread::Builder::new()
                    .spawn_scoped(scope, move || voice_hand(voicer, take.recv().unwrap_or_default(), &mut body));
                match worker {
                    Ok(worker) => match give.send(hand) {
                        Ok(()) => workers.push(worker),
                        Err(std::sync::mpsc::SendError(hand)) => here.push(hand),
                    },
                    Err(_) => here.push(hand),
                }
            }
            let mut voiced: Vec<_> =
                here.into_iter().flat_map(|hand| voice_hand(&voicer, hand, &mut soundboard.clone())).collect();
            voiced.extend(workers.into_iter().flat_map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))));
            voiced
        });
        if settings.kind.heard_as_built() {
            // Every key bears on the body with the middle key's gain per newton
            // of bridge force: the microphones hear the keyboard's balance as
            // the strings and the body make it.
            let middle = board.middle_key();
            let per_n = voiced.iter().find(|v| v.0 == middle).map(|v| v.2.level * v.1.output_gain_per_n());
            if let Some(per_n) = per_n.filter(|g| *g > 0.0 && g.is_finite()) {
                for (_, key, v) in &mut voiced {
                    v.relevel(per_n / key.output_gain_per_n().max(f64::MIN_POSITIVE));
                }
            }
        }
        let headroom = body_voicing::headroom(&voiced.iter().map(|v| v.2.peak_cut()).collect::<Vec<_>>());
        voiced.sort_by_key(|v| v.0);
        body_voicing::even_out(&mut voiced, &frequencies_hz, headroom, range);
        for (k, key, v) in &mut voiced {
            key.bear_on(board.zone_share(*k), v.level * v.peak_cut().min(headroom));
        }
        Ok(Self {
            settings: settings.clone(),
            keys,
            route,
            touch: settings.kind.touch_range(),
            bridge: Box::default(),
            soundboard,
            force: Box::new([0.0; CONTROL_BLOCK]),
            heard: Box::new([[0.0; CONTROL_BLOCK]; 2]),
            sympathy,
        })
    }

    /// Add what `output` hears of this stretch to `left` and `right`.
    fn listen(&mut self, output: Output, left: &mut [f64], right: &mut [f64]) {
        match output {
            Output::BridgeForce => {
                // The body is not heard: it does not ring on either (heard again, it
                // starts from rest).
                if !self.soundboard.is_resting() {
                    self.soundboard.silence();
                }
                let (l, r) = self.bridge.panned();
                left.iter_mut().zip(l).for_each(|(o, v)| *o += v);
                right.iter_mut().zip(r).for_each(|(o, v)| *o += v);
            }
            Output::Microphones => {
                let n = self.bridge.len();
                run_body(&mut self.soundboard, &self.bridge, &mut self.heard);
                let [heard_l, heard_r] = &*self.heard;
                left.iter_mut().zip(&heard_l[..n]).for_each(|(o, v)| *o += v);
                right.iter_mut().zip(&heard_r[..n]).for_each(|(o, v)| *o += v);
            }
        }
    }

    pub fn settings(&self) -> &InstrumentSettings {
        &self.settings
    }

    /// Sound every key for `n` samples, each driving the bridge as soon as it
    /// has sounded; `watch` (a key, its scope) records.
    fn sound(&mut self, n: usize, mut watch: Option<(u8, &mut ScopeWriter)>) {
        let force = &mut self.force[..n];
        for key in self.keys.iter_mut().flatten().filter(|k| k.is_sounding()) {
            sound_key(key, force, watch.as_mut());
            key.drive(&mut self.bridge, force);
        }
    }

    /// Start the bridge for a stretch of `n` samples heard through `output`:
    /// the body runs once per microphone while a key has a place of its own.
    fn start_bridge(&mut self, n: usize, output: Output) {
        let split = output == Output::Microphones
            && (self.soundboard.is_split() || self.keys.iter().flatten().any(|k| k.is_sounding() && k.is_placed()));
        self.bridge.start(n, output == Output::BridgeForce, split);
    }

    fn active_keys(&self) -> impl Iterator<Item = &Key> {
        self.keys.iter().flatten().filter(|k| k.is_sounding())
    }

    /// Pairs of partials of different keys that trade through the body.
    pub fn sympathetic_pairs(&self) -> usize {
        self.sympathy.len()
    }

    /// The largest share of the sympathetic trade's budget one of its
    /// partials asks for: under 1 the pairs trade as the body has them, over
    /// 1 the crowded ones were scaled down to it (a scale with steps of a few
    /// cents).
    pub fn sympathetic_budget_used(&self) -> f64 {
        self.sympathy.budget_used()
    }

    /// Modes of every string of every key (below [`MAX_MODE_FREQUENCY_HZ`]).
    pub fn mode_count(&self) -> usize {
        self.keys.iter().flatten().map(Key::mode_count).sum()
    }

    /// The course `midi_key` plays and its note there.
    fn route(&mut self, midi_key: u8) -> Option<(&mut Key, usize)> {
        let (home, note) = (*self.route.get(midi_key as usize)?)?;
        Some((self.keys[home as usize].as_mut()?, note as usize))
    }
}

/// Report the keys fallen silent in a control block at `time`, as room allows.
fn push_ended(ended: &mut Vec<KeyEnded>, time: u32, fallen: &Fallen) {
    for &key in fallen.keys() {
        if ended.len() < ended.capacity() {
            ended.push(KeyEnded { time, key });
        }
    }
}

/// What `soundboard`'s microphones hear of `bridge`'s stretch, into `heard`.
fn run_body(soundboard: &mut Soundboard, bridge: &Bridge, heard: &mut [[f64; CONTROL_BLOCK]; 2]) {
    let n = bridge.len();
    let [heard_l, heard_r] = heard;
    if bridge.is_split() {
        let (l, r) = (bridge.zone_forces(), bridge.zone_forces_right());
        soundboard.process_split(l, r, &mut heard_l[..n], &mut heard_r[..n]);
    } else {
        soundboard.process(bridge.zone_forces(), &mut heard_l[..n], &mut heard_r[..n]);
    }
}

/// A control block's work before its keys are told ([`Synth::control`]).
#[derive(Clone, Copy)]
struct BeforeKeys {
    noise: ActionNoise,
    /// The sympathetic strings' level.
    sympathy: f64,
    /// The control block's number.
    block: u64,
}

impl BeforeKeys {
    /// The dampers the pedal is lifting (`lifting`, moved on), and the
    /// strings' trading through the body.
    fn run(self, keys: &mut [Option<Key>], sympathy: &mut Sympathy, performance: &mut PerformanceState) {
        if let Some(phase) = performance.lifting {
            for (k, key) in keys.iter_mut().enumerate() {
                if let Some(key) = key.as_mut().filter(|_| k * 5 % LIFT_SPREAD_BLOCKS == phase) {
                    key.set_noise(self.noise);
                    key.lift_damper(performance);
                }
            }
            performance.lifting = (phase + 1 < LIFT_SPREAD_BLOCKS).then_some(phase + 1);
        }
        // Each key's pairs trade once every SYMPATHY_BLOCKS blocks, an
        // eighth of the keys each block.
        let phase = (self.block % SYMPATHY_BLOCKS as u64) as usize;
        sympathy.trade(keys, self.sympathy, performance, SILENCE, phase);
    }
}

/// `key`'s force over `force.len()` samples; `watch` (a key, its scope)
/// records the contact if it is the watched key.
fn sound_key(key: &mut Key, force: &mut [f64], watch: Option<&mut (u8, &mut ScopeWriter)>) {
    match watch.filter(|(k, _)| *k == key.midi_key()) {
        Some((_, scope)) => {
            key.sound(force, scope.contact_slots(force.len()));
            scope.during_contact(key.watched_string());
        }
        None => key.sound(force, None),
    }
}

/// A sample type the synth writes.
trait OutputSample: Copy + Send {
    fn from_f64(x: f64) -> Self;
}

impl OutputSample for f32 {
    #[inline]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
}

impl OutputSample for f64 {
    #[inline]
    fn from_f64(x: f64) -> Self {
        x
    }
}

/// What every sounding key is told at a control block.
#[derive(Clone, Copy)]
struct KeyTick {
    block_s: f64,
    bebung: f64,
    phantom: f64,
    noise: ActionNoise,
}

impl KeyTick {
    /// Tell each of `keys` that is sounding, noting in `fallen` the MIDI keys
    /// of those that fell silent.
    fn control(&self, keys: &mut [Option<Key>], performance: &PerformanceState, fallen: &mut Fallen) {
        for key in keys.iter_mut().flatten().filter(|k| k.is_sounding()) {
            key.set_bebung(self.bebung);
            key.set_phantom(self.phantom);
            key.set_noise(self.noise);
            if key.control(self.block_s, performance, SILENCE) {
                for k in key.take_sounded() {
                    fallen.push(k);
                }
            }
        }
    }
}

/// MIDI keys fallen silent in a control block (each at most once).
struct Fallen {
    keys: [u8; 128],
    len: usize,
}

impl Default for Fallen {
    fn default() -> Self {
        Self { keys: [0; 128], len: 0 }
    }
}

impl Fallen {
    fn push(&mut self, key: u8) {
        if let Some(slot) = self.keys.get_mut(self.len) {
            *slot = key;
            self.len += 1;
        }
    }

    fn keys(&self) -> &[u8] {
        &self.keys[..self.len]
    }
}

/// Events the synth reports back to the host: a key that has fallen silent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyEnded {
    pub time: u32,
    pub key: u8,
}

/// One-pole DC blocker.
#[derive(Clone, Copy, Default)]
struct DcBlock {
    x1: f64,
    y1: f64,
}

impl DcBlock {
    /// One sample. Its decay into silence is cut off below 1e-30 (-600 dBFS): the
    /// output then reaches exact zero instead of f32 subnormals (which hosts must
    /// not be handed), and the state never becomes an f64 subnormal (slow on x86).
    #[inline]
    fn run(&mut self, x: f64, r: f64) -> f64 {
        let mut y = x - self.x1 + r * self.y1;
        if y.abs() < 1e-30 {
            y = 0.0;
        }
        self.x1 = x;
        self.y1 = y;
        y
    }
}

/// The player: takes events, writes audio. Built off the audio thread; then
/// [`Synth::process`] is real-time safe.
pub struct Synth {
    current: Box<Instrument>,
    /// An instrument of another kind fading out after a switch.
    outgoing: Option<Box<Instrument>>,
    /// Instruments replaced and waiting to be handed back for dropping elsewhere.
    retired: [Option<Box<Instrument>>; 8],
    controls: Controls,
    /// What the player is doing with it: pedals, wheels, per-note shaping.
    performance: PerformanceState,
    clock: u64,
    outlet: Outlet,
    ended: Vec<KeyEnded>,
    scope: ScopeWriter,
    /// The voicing the player asks for now: what of it the instrument was not
    /// built with, it takes live ([`Self::set_voicing`]); what the keys have
    /// taken of it, when, and whether a new damping waits for its turn.
    voicing: Voicing,
    live: LiveVoicing,
    live_taken_at: u64,
    live_pending: bool,
}

/// A ringing key takes a new damping at most once in this long, s: each time
/// its strings' poles are worked out again (an exp and a sin/cos a mode), and
/// a damping moved by an LFO would have that done in every block.
const LIVE_DAMPING_EVERY_S: f64 = 0.01;

impl Synth {
    /// A synth playing `instrument`, and the reader of its live view. Allocates.
    pub fn new(instrument: Box<Instrument>) -> (Self, Scope) {
        let (scope, reader) = scope::channel();
        let fs = instrument.settings.sample_rate_hz;
        let voicing = instrument.settings.voicing;
        let synth = Self {
            current: instrument,
            outgoing: None,
            retired: Default::default(),
            controls: Controls::default(),
            performance: PerformanceState::default(),
            clock: 0,
            outlet: Outlet::new(fs),
            ended: Vec::with_capacity(1024),
            scope,
            voicing,
            live: LiveVoicing::default(),
            live_taken_at: 0,
            live_pending: false,
        };
        (synth, reader)
    }

    pub fn settings(&self) -> &InstrumentSettings {
        &self.current.settings
    }

    pub fn controls(&self) -> &Controls {
        &self.controls
    }

    /// Set the per-block controls (real-time safe).
    pub fn set_controls(&mut self, controls: Controls) {
        self.controls = controls;
        self.performance.rebend(self.controls.bend_range_semitones);
    }

    /// The voicing the player asks for: what of it the instrument playing
    /// was not built with and can take live ([`LiveVoicing`]: the strings'
    /// losses, the hammer) it takes now; the rest waits for an instrument
    /// built with it ([`InstrumentSettings::builds_like`]). Real-time safe.
    pub fn set_voicing(&mut self, voicing: &Voicing) {
        if *voicing != self.voicing {
            self.voicing = *voicing;
            self.take_live_voicing(false);
        }
    }

    /// Give the keys the voicing asked for over the one they were built with:
    /// the hammer at once, a new damping once [`LIVE_DAMPING_EVERY_S`] has
    /// passed since the last (or `now`).
    fn take_live_voicing(&mut self, now: bool) {
        let mut live = LiveVoicing::between(&self.current.settings.voicing, &self.voicing);
        let every = (LIVE_DAMPING_EVERY_S * self.current.settings.sample_rate_hz) as u64;
        let due = now || self.clock >= self.live_taken_at.saturating_add(every);
        self.live_pending = !due && live.damping != self.live.damping;
        if self.live_pending {
            live.damping = self.live.damping;
        } else if live.damping != self.live.damping {
            self.live_taken_at = self.clock;
        }
        if live != self.live || now {
            self.live = live;
            for key in self.current.keys.iter_mut().flatten() {
                key.set_live_voicing(live);
            }
        }
    }

    /// What the output's guard has done so far ([`guard`]): read it off the
    /// audio thread, or after a render, to say so.
    pub fn guard(&self) -> GuardReport {
        self.outlet.guard.report()
    }

    /// Every string and body at rest at once (their state is lost: the
    /// guard found a sample that is not a number, or no music), the DC
    /// blocks too; the pedals stay where the player has them.
    /// (`time`: the control block's, where the keys that sounded end.)
    fn silence_all(&mut self, time: u32) {
        for instrument in std::iter::once(&mut self.current).chain(self.outgoing.as_mut()) {
            for key in instrument.keys.iter_mut().flatten() {
                if key.is_sounding() && self.ended.len() < self.ended.capacity() {
                    self.ended.push(KeyEnded { time, key: key.midi_key() });
                }
                key.silence();
            }
            instrument.soundboard.silence();
            instrument.sympathy.drop_held();
        }
        self.outlet.dc = [DcBlock::default(); 2];
    }

    /// Keys sounding now (the outgoing instrument's included).
    pub fn active_keys(&self) -> usize {
        self.current.active_keys().count() + self.outgoing.as_ref().map_or(0, |o| o.active_keys().count())
    }

    /// Whether anything still sounds: a key, or a body ringing on after its keys.
    pub fn is_sounding(&self) -> bool {
        let bodies = std::iter::once(&self.current).chain(self.outgoing.as_ref()).any(|i| !i.soundboard.is_resting());
        self.active_keys() > 0 || bodies
    }

    /// Modes the sounding keys are computing now (culled modes left out).
    pub fn running_modes(&self) -> usize {
        let outgoing = self.outgoing.as_ref().map_or(0, |o| o.active_keys().map(Key::running_modes).sum());
        self.current.active_keys().map(Key::running_modes).sum::<usize>() + outgoing
    }

    /// The instrument now playing.
    pub fn instrument(&self) -> &Instrument {
        &self.current
    }

    /// Whether the strings `midi_key` plays on the instrument now playing are sounding.
    pub fn key_sounding(&self, midi_key: u8) -> bool {
        let Some(Some((home, _))) = self.current.route.get(midi_key as usize) else { return false };
        self.current.keys[*home as usize].as_ref().is_some_and(Key::is_sounding)
    }

    /// Keys that fell silent during the last [`Self::process`] call.
    pub fn ended_keys(&self) -> &[KeyEnded] {
        &self.ended
    }

    /// Play `instrument` from now on. Of the same kind, ringing keys carry over
    /// into the new tables; of another kind, the old one fades out. Real-time safe:
    /// the replaced instrument waits in [`Self::take_retired`].
    pub fn install(&mut self, mut instrument: Box<Instrument>) {
        // Ringing keys carry over when every MIDI key still plays the same course
        // (a fretted clavichord made unfretted does not).
        if instrument.settings.kind == self.current.settings.kind && instrument.route == self.current.route {
            for (new, old) in instrument.keys.iter_mut().zip(self.current.keys.iter_mut()) {
                if let (Some(new), Some(old)) = (new, old)
                    && old.is_sounding()
                {
                    new.take_over(old, &self.performance);
                }
            }
            instrument.soundboard.take_over(&self.current.soundboard);
            let old = std::mem::replace(&mut self.current, instrument);
            self.retire(old);
        } else {
            let mut old = std::mem::replace(&mut self.current, instrument);
            let fs = old.settings.sample_rate_hz;
            for key in old.keys.iter_mut().flatten().filter(|k| k.is_sounding()) {
                key.fade_out(SWITCH_FADE_S, fs);
            }
            old.soundboard.fade_out(SWITCH_FADE_S);
            if let Some(previous) = self.outgoing.replace(old) {
                self.retire(previous);
            }
        }
        self.outlet.set_rate(self.current.settings.sample_rate_hz);
        self.take_live_voicing(true);
    }

    fn retire(&mut self, instrument: Box<Instrument>) {
        if let Some(slot) = self.retired.iter_mut().find(|s| s.is_none()) {
            *slot = Some(instrument);
        } else {
            // Never expected (the workshop drains every few milliseconds). Dropping
            // here would free memory on the audio thread: the oldest is leaked instead.
            let oldest = self.retired[0].replace(instrument);
            std::mem::forget(oldest);
        }
    }

    /// A replaced instrument to be dropped off the audio thread.
    pub fn take_retired(&mut self) -> Option<Box<Instrument>> {
        self.retired.iter_mut().find_map(|s| s.take())
    }

    /// Put back one that could not be handed on yet.
    pub fn keep_retired(&mut self, instrument: Box<Instrument>) {
        self.retire(instrument);
    }

    /// Render `left.len()` samples (`right` the same length), applying `events`
    /// (sorted by time) at their sample positions. Real-time safe.
    pub fn process(&mut self, events: &[TimedEvent], left: &mut [f32], right: &mut [f32]) {
        self.process_into(events, left, right);
    }

    /// [`Self::process`] with the samples as the synth makes them, before
    /// they are rounded to f32 (for checks that would see the least change).
    pub fn process_f64(&mut self, events: &[TimedEvent], left: &mut [f64], right: &mut [f64]) {
        self.process_into(events, left, right);
    }

    fn process_into<T: OutputSample>(&mut self, events: &[TimedEvent], left: &mut [T], right: &mut [T]) {
        debug_assert_eq!(left.len(), right.len());
        let n = left.len().min(right.len());
        self.ended.clear();
        let mut pos = 0;
        let mut next_event = 0;
        while pos < n {
            while next_event < events.len() && (events[next_event].time as usize) <= pos {
                self.handle(events[next_event].event);
                next_event += 1;
            }
            if self.live_pending {
                self.take_live_voicing(false);
            }
            let phase = (self.clock % CONTROL_BLOCK as u64) as usize;
            let until_event = events.get(next_event).map_or(n, |e| (e.time as usize).min(n));
            // While a strike is being recorded for the live view, finer chunks let it
            // catch the moment of peak contact (chunking never changes the samples).
            let chunk = if self.scope.recording() { SCOPE_CHUNK } else { CONTROL_BLOCK };
            let len = (n - pos).min(CONTROL_BLOCK - phase).min(chunk).min(until_event - pos);
            if phase == 0 {
                self.control(pos as u32);
            }
            self.render(&mut left[pos..pos + len], &mut right[pos..pos + len]);
            pos += len;
            self.clock += len as u64;
        }
        // Events stamped past the block's end still happen, at its end.
        for e in &events[next_event..] {
            self.handle(e.event);
        }
    }

    fn handle(&mut self, event: Event) {
        match event {
            // A velocity that is not a number is no touch at all (it would make every
            // sample of the key NaN); an infinite one is held to the range, as any other.
            Event::NoteOn { velocity, .. } if velocity.is_nan() => {}
            Event::NoteOn { key, velocity } if velocity <= 0.0 => self.note_off(key, 0.0),
            Event::NoteOn { key, velocity } => self.note_on(key, velocity as f64),
            Event::NoteOff { key, velocity } => self.note_off(key, velocity),
            Event::Sustain(v) if v.is_finite() => self.performance.pedal_to(v as f64),
            Event::Sostenuto(v) => {
                let down = v >= 0.5;
                if down && !self.performance.sostenuto {
                    for k in self.current.keys.iter_mut().flatten() {
                        k.catch_sostenuto();
                    }
                } else if !down {
                    for k in self.current.keys.iter_mut().flatten() {
                        k.drop_sostenuto();
                    }
                }
                self.performance.sostenuto = down;
            }
            Event::UnaCorda(v) if v.is_finite() => self.performance.una_corda = (v as f64).clamp(0.0, 1.0),
            Event::ModWheel(v) if v.is_finite() => self.performance.mod_wheel(v as f64),
            Event::Pressure { key, pressure } if pressure.is_finite() => {
                if let Some((k, _)) = self.current.route(key) {
                    k.set_pressure(pressure as f64);
                }
            }
            Event::KeyVolume { key, gain } if gain.is_finite() => {
                self.performance.own[key as usize & 127].volume = f64::from(gain);
                self.apply_own(key);
            }
            Event::KeyPan { key, pan } if pan.is_finite() => {
                self.performance.own[key as usize & 127].pan = f64::from(pan);
                self.apply_own(key);
            }
            Event::KeyHammer { key, hardness, position } if hardness.is_finite() && position.is_finite() => {
                self.performance.own[key as usize & 127].hammer = (f64::from(hardness), f64::from(position));
                self.apply_own(key);
            }
            Event::KeyBend { key, semitones } if semitones.is_finite() => {
                self.performance.own[key as usize & 127].tune =
                    2f64.powf(f64::from(semitones.clamp(-96.0, 96.0)) / 12.0);
                self.apply_own(key);
            }
            Event::PitchBend(v) if !v.is_nan() => {
                self.performance.pitch_wheel(v as f64, self.controls.bend_range_semitones);
            }
            Event::ModWheel(_)
            | Event::Pressure { .. }
            | Event::KeyBend { .. }
            | Event::KeyVolume { .. }
            | Event::KeyHammer { .. }
            | Event::KeyPan { .. }
            | Event::UnaCorda(_)
            | Event::Sustain(_)
            | Event::PitchBend(_) => {}
            Event::AllNotesOff => {
                let performance = &self.performance;
                for k in self.current.keys.iter_mut().flatten().filter(|k| k.down()) {
                    k.release_all(performance);
                }
            }
            Event::Reset => {
                let fs = self.current.settings.sample_rate_hz;
                let held_up = PerformanceState::held_up();
                for k in self.current.keys.iter_mut().flatten().filter(|k| k.is_sounding()) {
                    // Silenced, not let go: no damper lands.
                    k.release_all(&held_up);
                    k.fade_out(STEAL_FADE_S, fs);
                }
                self.current.soundboard.fade_out(STEAL_FADE_S);
                self.performance = PerformanceState::default();
                // (A key fading out glides back, a silent one is there at once.)
                self.current.keys.iter_mut().flatten().for_each(|k| k.shape(OwnNote::default()));
            }
        }
    }

    fn note_on(&mut self, midi_key: u8, velocity: f64) {
        let Some((key, _)) = self.current.route(midi_key) else { return };
        if !key.is_sounding() {
            self.make_room();
        }
        let touch = self.controls.touch(self.current.touch, velocity);
        // Strings shared with another MIDI key take this key's own tuning,
        // volume, place and hammer.
        if let Some((key, _)) = self.current.route(midi_key) {
            let home = key.midi_key() as usize & 127;
            if self.performance.owner[home] != midi_key {
                self.performance.owner[home] = midi_key;
                self.apply_own(midi_key);
            }
        }
        let (bebung, noise) = (self.controls.bebung_cents, self.controls.noise());
        let Some((key, note)) = self.current.route(midi_key) else { return };
        key.set_bebung(bebung);
        key.set_noise(noise);
        key.press(note, touch, &self.performance);
        let home = key.midi_key();
        self.scope.struck(home);
    }

    /// `midi_key` comes up with release `velocity` (0 or unknown: MIDI's
    /// default, 64, as many keyboards send 0 for a release they do not measure).
    fn note_off(&mut self, midi_key: u8, velocity: f32) {
        let velocity =
            if velocity > 0.0 && velocity.is_finite() { (velocity as f64).min(1.0) } else { DEFAULT_RELEASE };
        let noise = self.controls.noise();
        if let Some((key, note)) = self.current.route(midi_key) {
            key.set_noise(noise);
            key.release(note, velocity, &self.performance);
        }
    }

    /// Hand `midi_key`'s own tuning, volume, place and hammer to its strings,
    /// if they are its now.
    fn apply_own(&mut self, midi_key: u8) {
        let own = self.performance.own[midi_key as usize & 127];
        let Some((key, _)) = self.current.route(midi_key) else { return };
        if self.performance.owner[key.midi_key() as usize & 127] != midi_key {
            return;
        }
        key.shape(own);
    }

    /// Below the polyphony cap, or steal: the quietest released key first, else the quietest.
    fn make_room(&mut self) {
        let playing = self.current.active_keys().filter(|k| !k.is_fading_out()).count();
        if playing < self.controls.polyphony.max(1) {
            return;
        }
        let fs = self.current.settings.sample_rate_hz;
        let victim =
            self.current.keys.iter_mut().flatten().filter(|k| k.is_sounding() && !k.is_fading_out()).min_by(|a, b| {
                (a.down(), a.level()).partial_cmp(&(b.down(), b.level())).unwrap_or(std::cmp::Ordering::Equal)
            });
        if let Some(k) = victim {
            k.fade_out(STEAL_FADE_S, fs);
        }
    }

    fn control(&mut self, time: u32) {
        if self.outlet.guard.take_trip() {
            self.silence_all(time);
        }
        self.control_before_keys();
        let tick = self.key_tick();
        for instrument in std::iter::once(&mut self.current).chain(self.outgoing.as_mut()) {
            let mut ended = Fallen::default();
            tick.control(&mut instrument.keys, &self.performance, &mut ended);
            push_ended(&mut self.ended, time, &ended);
        }
        // The outgoing instrument leaves once its keys are silent and its body has rung out.
        if let Some(old) = self.outgoing.take_if(|o| o.active_keys().next().is_none() && o.soundboard.is_resting()) {
            self.retire(old);
        }
        if let Some(key) = self.scope.key().and_then(|k| self.current.keys[k as usize].as_mut()) {
            // (The live view reads the string: back from its gathering.)
            key.settle();
            self.scope.control(key.midi_key(), key.watched_string());
        }
    }

    /// What every sounding key is told at a control block.
    fn key_tick(&self) -> KeyTick {
        KeyTick {
            block_s: CONTROL_BLOCK as f64 / self.current.settings.sample_rate_hz,
            bebung: self.controls.bebung_cents,
            phantom: self.controls.phantom.clamp(0.0, 4.0),
            noise: self.controls.noise(),
        }
    }

    /// A control block's work before its keys are told: the dampers the
    /// pedal is lifting, the strings' trading through the body.
    fn control_before_keys(&mut self) {
        let before = self.before_keys();
        let current = &mut *self.current;
        before.run(&mut current.keys, &mut current.sympathy, &mut self.performance);
    }

    /// What a control block does before its keys are told, as it stands.
    fn before_keys(&self) -> BeforeKeys {
        BeforeKeys {
            noise: self.controls.noise(),
            sympathy: self.controls.sympathy,
            block: self.clock / CONTROL_BLOCK as u64,
        }
    }

    fn render<T: OutputSample>(&mut self, left: &mut [T], right: &mut [T]) {
        let n = left.len();
        let [mix_l, mix_r] = &mut *self.outlet.mix;
        mix_l[..n].fill(0.0);
        mix_r[..n].fill(0.0);
        let scope_key = self.scope.key();
        let output = self.controls.output;
        for (i, instrument) in std::iter::once(&mut self.current).chain(self.outgoing.as_mut()).enumerate() {
            instrument.start_bridge(n, output);
            let watch = scope_key.filter(|_| i == 0).map(|k| (k, &mut self.scope));
            instrument.sound(n, watch);
            instrument.listen(output, &mut mix_l[..n], &mut mix_r[..n]);
        }
        self.write_out(left, right);
    }

    /// The mix's first `left.len()` samples through the DC block and the
    /// output gain, to `left` and `right` (and the live view).
    fn write_out<T: OutputSample>(&mut self, left: &mut [T], right: &mut [T]) {
        self.outlet.write(self.controls.output_gain, &mut self.scope, left, right);
    }
}

/// What every instrument sounding gave, and the last stage it goes out
/// through: a DC block and the output gain, gliding to its control.
struct Outlet {
    mix: Box<[[f64; CONTROL_BLOCK]; 2]>,
    gain: f64,
    dc: [DcBlock; 2],
    dc_r: f64,
    /// Per-sample step of the output gain's glide toward its control (about 10 ms, so automation does not click).
    glide: f64,
    /// The last line: nothing non-finite or over +6 dBFS leaves.
    guard: guard::Guard,
}

impl Outlet {
    fn new(sample_rate_hz: f64) -> Self {
        let mut outlet = Self {
            mix: Box::new([[0.0; CONTROL_BLOCK]; 2]),
            gain: 1.0,
            dc: [DcBlock::default(); 2],
            dc_r: 0.0,
            glide: 0.0,
            guard: guard::Guard::new(sample_rate_hz),
        };
        outlet.set_rate(sample_rate_hz);
        outlet
    }

    fn set_rate(&mut self, sample_rate_hz: f64) {
        self.dc_r = (-2.0 * std::f64::consts::PI * DC_BLOCK_HZ / sample_rate_hz).exp();
        self.glide = glide_step(sample_rate_hz);
        self.guard.set_rate(sample_rate_hz);
    }

    /// The mix's first `left.len()` samples through the DC block and the
    /// output gain gliding to `to`, to `left` and `right` (and the live
    /// view, `scope`).
    fn write<T: OutputSample>(&mut self, to: f64, scope: &mut ScopeWriter, left: &mut [T], right: &mut [T]) {
        let n = left.len();
        let [mix_l, mix_r] = &*self.mix;
        let (glide, r) = (self.glide, self.dc_r);
        let mut heard = [0.0f32; CONTROL_BLOCK];
        for t in 0..n {
            // The glide arrives once within 1e-9 of its target (-180 dB): gliding on
            // toward silence for ever, the gain would make subnormal samples (and
            // become an f64 subnormal itself).
            self.gain = if (to - self.gain).abs() < 1e-9 { to } else { self.gain + (to - self.gain) * glide };
            let (l, rr) =
                self.guard.run(self.dc[0].run(mix_l[t], r) * self.gain, self.dc[1].run(mix_r[t], r) * self.gain);
            left[t] = T::from_f64(l);
            right[t] = T::from_f64(rr);
            heard[t] = 0.5 * (l + rr) as f32;
        }
        scope.samples(&heard[..n]);
    }
}

/// The output gain's per-sample glide coefficient: a 10 ms time constant.
fn glide_step(sample_rate_hz: f64) -> f64 {
    1.0 - (-1.0 / (0.01 * sample_rate_hz)).exp()
}

/// Settings of an instrument for `kind` at `sample_rate_hz`, voiced as built,
/// in equal temperament at A4 = 440 Hz with a tuner's stretch.
pub fn default_settings(kind: InstrumentKind, sample_rate_hz: f64) -> InstrumentSettings {
    InstrumentSettings {
        kind,
        voicing: Voicing::default(),
        sample_rate_hz,
        tuning: TuningSettings::default(),
        mics: MicPlacement::default(),
        strings_on_body: true,
    }
}
