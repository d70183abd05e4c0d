//! An instrument built for one sample rate: every key's tables, the body,
//! the sympathetic pairs, voiced through the body; and what it does each
//! control block and each stretch (the keys told, their force on the
//! bridge, the body heard).

use std::sync::Arc;

use super::voicings::{self, InstrumentVoicing};
use super::*;

/// The sample rate instruments are voiced at. The voicing weighs each key's
/// strikes through the body (nine tenths of a build), and what it finds is
/// the strings' and the body's, not the rate's: a build at another rate takes
/// its keys' voicing from the same settings built at this one.
pub const VOICING_RATE_HZ: f64 = 48_000.0;

/// Where a build takes its keys' voicing from.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum VoicingFrom {
    /// The voicing found for the same settings before (in this run, saved in
    /// the cache folder, or come with the program), at any rate; else found
    /// here, then kept and saved.
    Kept,
    /// Found here, from nothing (at another rate, from the same settings
    /// built at the voicing's rate), and neither kept nor saved: what a build
    /// costs with nothing to go on.
    Afresh,
}

/// The most threads an instrument's keys are voiced on when it is built.
pub(super) const MAX_VOICING_THREADS: usize = 8;

/// Every key of one instrument, built for one sample rate.
#[derive(Clone)]
pub struct Instrument {
    pub(super) settings: InstrumentSettings,
    /// The courses, each at the index of the MIDI key it is listed under.
    pub(super) keys: Vec<Option<Key>>,
    /// For every MIDI key: the course it plays and which of its notes it is.
    pub(super) route: [Option<(u8, u8)>; 128],
    pub(super) touch: TouchRange,
    /// What its keys drive, the body those forces set ringing, and what the
    /// body's microphones heard last.
    pub(super) bridge: Box<Bridge>,
    pub(super) soundboard: Soundboard,
    pub(super) heard: Box<[[f64; CONTROL_BLOCK]; 2]>,
    /// A key's force over a stretch, as it sounds.
    pub(super) force: Box<[f64; CONTROL_BLOCK]>,
    /// The pairs of partials of different keys that trade through the body.
    pub(super) sympathy: Sympathy,
}

impl Instrument {
    /// Build every key's tables. Allocates; off the audio thread. The same
    /// settings built again (a host activating the plugin again, a preset
    /// chosen again) come from [`built`]'s few instruments kept as built, a
    /// copy in milliseconds; anything else is built afresh, with the voicing
    /// found for the same settings before, if any ([`Self::build_with`]).
    pub fn build(settings: &InstrumentSettings) -> Result<Self, BuildError> {
        if let Some(instrument) = built::find(settings) {
            return Ok(instrument);
        }
        let instrument = Self::build_with(settings, VoicingFrom::Kept)?;
        built::keep(settings, &instrument);
        Ok(instrument)
    }

    /// [`Self::build`] without looking among the instruments kept as built
    /// (nor keeping this one), nor among the voicings found before: every
    /// key's tables, the body and the voicing worked out anew.
    pub fn build_afresh(settings: &InstrumentSettings) -> Result<Self, BuildError> {
        Self::build_with(settings, VoicingFrom::Afresh)
    }

    /// Every key's tables and the body, built anew, and the keys voiced as
    /// `from` says. Takes up to a second where the keys are voiced here.
    pub fn build_with(settings: &InstrumentSettings, from: VoicingFrom) -> Result<Self, BuildError> {
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
        let cores = std::thread::available_parallelism().map_or(1, |n| n.get()).clamp(1, MAX_VOICING_THREADS);
        let retuned: Vec<KeyDesign> = designs.into_iter().map(|d| d.retuned(&frequencies_hz)).collect();
        for (midi_key, built) in build_keys(retuned, fs, settings.kind, load.as_ref(), cores) {
            let moved = (frequencies_hz[midi_key as usize] / key_frequency_hz(midi_key) - 1.0).abs() > 1e-9;
            {
                match built {
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
        // The body's gain puts the middle key's partials where the bridge-force
        // output has them; every other key is voiced through the body to ring as
        // its own partials would there (a technician's regulation: the body still
        // shapes each note's spectrum, decay and image, not the keyboard's
        // evenness).
        let body = || {
            let heard = HeardModes::new(&board, BODY_TOP_HZ.min(0.45 * fs), mics);
            let middle =
                heard_pa_per_n(&board, &heard, board.middle_key(), frequencies_hz[board.middle_key() as usize]);
            let soundboard = Soundboard::build(&board, fs, &board.zone_points(), mics, middle.max(1e-12).recip());
            (heard, soundboard)
        };
        // The body on a thread of its own while the pairs are found (here, if
        // no thread could be started).
        let (sympathy, (heard, soundboard)) = std::thread::scope(|scope| {
            let body_built = std::thread::Builder::new().spawn_scoped(scope, body);
            let sympathy = match &load {
                Some(load) => Sympathy::build(load, &keys, (SYMPATHY_BLOCKS * CONTROL_BLOCK) as f64 / fs),
                None => Sympathy::none(),
            };
            let built = match body_built {
                Ok(worker) => worker.join().unwrap_or_else(|e| std::panic::resume_unwind(e)),
                Err(_) => body(),
            };
            (sympathy, built)
        });
        // The voicing found for these settings before (in this run, saved in
        // the cache folder, or come with the program) is taken as found, at
        // any rate; failing that, a build at another rate takes it from the
        // same settings built at the voicing's own rate (which keeps it: a
        // host trying rate after rate voices once); either only when it has
        // every key this one has. Else the keys are voiced here (and the
        // voicing kept and saved, at the voicing's rate).
        let voicing = match from {
            VoicingFrom::Kept => voicings::find(settings),
            VoicingFrom::Afresh => None,
        }
        .or_else(|| {
            (fs != VOICING_RATE_HZ)
                .then(|| Self::build_with(&voicings::voicing_settings(settings), from).ok())
                .flatten()
                .map(|voiced| Arc::new(voiced.voicing()))
        })
        .filter(|v| keys.iter().flatten().all(|key| v.key(key.midi_key()).is_some()));
        if let Some(voicing) = voicing {
            for key in keys.iter_mut().flatten() {
                if let Some(v) = voicing.key(key.midi_key()) {
                    key.voice_as(v, board.zone_share(key.midi_key()));
                }
            }
        } else {
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
                voiced.extend(
                    workers.into_iter().flat_map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))),
                );
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
            if fs == VOICING_RATE_HZ && from == VoicingFrom::Kept {
                voicings::keep(InstrumentVoicing {
                    settings: settings.clone(),
                    keys: keys.iter().flatten().map(Key::voicing).collect(),
                });
            }
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
    pub(super) fn listen(&mut self, output: Output, left: &mut [f64], right: &mut [f64]) {
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

    /// What voicing its keys through the body found (or took), key by key.
    pub fn voicing(&self) -> InstrumentVoicing {
        InstrumentVoicing {
            settings: voicings::voicing_settings(&self.settings),
            keys: self.keys.iter().flatten().map(Key::voicing).collect(),
        }
    }

    /// Sound every key for `n` samples, each driving the bridge as soon as it
    /// has sounded; `watch` (a key, its scope) records.
    pub(super) fn sound(&mut self, n: usize, mut watch: Option<(u8, &mut ScopeWriter)>) {
        let force = &mut self.force[..n];
        for key in self.keys.iter_mut().flatten().filter(|k| k.is_sounding()) {
            sound_key(key, force, watch.as_mut());
            key.drive(&mut self.bridge, force);
        }
    }

    /// Start the bridge for a stretch of `n` samples heard through `output`:
    /// the body runs once per microphone while a key has a place of its own.
    pub(super) fn start_bridge(&mut self, n: usize, output: Output) {
        let split = output == Output::Microphones
            && (self.soundboard.is_split() || self.keys.iter().flatten().any(|k| k.is_sounding() && k.is_placed()));
        self.bridge.start(n, output == Output::BridgeForce, split);
    }

    pub(super) fn active_keys(&self) -> impl Iterator<Item = &Key> {
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
    pub(super) fn route(&mut self, midi_key: u8) -> Option<(&mut Key, usize)> {
        let (home, note) = (*self.route.get(midi_key as usize)?)?;
        Some((self.keys[home as usize].as_mut()?, note as usize))
    }
}

/// Report the keys fallen silent in a control block at `time`, as room allows.
/// Every key of `designs` built ([`Key::build`]), in their order, each with
/// the MIDI key it is listed under: on `cores` threads, the keys dealt out in
/// turn; those no thread could be started for are built here, the same.
fn build_keys(
    designs: Vec<KeyDesign>,
    fs: f64,
    kind: InstrumentKind,
    load: Option<&BoardLoad>,
    cores: usize,
) -> Vec<(u8, Result<Key, StringError>)> {
    type Built = (usize, u8, Result<Key, StringError>);
    let build = |hand: Vec<(usize, KeyDesign)>| -> Vec<Built> {
        hand.into_iter()
            .map(|(i, design)| {
                let midi_key = design.midi_key;
                (i, midi_key, Key::build(design, fs, kind, load))
            })
            .collect()
    };
    let mut hands: Vec<Vec<(usize, KeyDesign)>> = (0..cores.max(1)).map(|_| Vec::new()).collect();
    let count = hands.len();
    for (i, design) in designs.into_iter().enumerate() {
        hands[i % count].push((i, design));
    }
    let mut built: Vec<Built> = std::thread::scope(|scope| {
        let mut workers = Vec::new();
        let mut here = Vec::new();
        for hand in hands {
            let (give, take) = std::sync::mpsc::channel::<Vec<(usize, KeyDesign)>>();
            let build = &build;
            let worker =
                std::thread::Builder::new().spawn_scoped(scope, move || build(take.recv().unwrap_or_default()));
            match worker {
                Ok(worker) => match give.send(hand) {
                    Ok(()) => workers.push(worker),
                    Err(std::sync::mpsc::SendError(hand)) => here.push(hand),
                },
                Err(_) => here.push(hand),
            }
        }
        let mut built: Vec<Built> = here.into_iter().flat_map(build).collect();
        built.extend(workers.into_iter().flat_map(|w| w.join().unwrap_or_else(|e| std::panic::resume_unwind(e))));
        built
    });
    built.sort_by_key(|b| b.0);
    built.into_iter().map(|(_, k, b)| (k, b)).collect()
}

pub(super) fn push_ended(ended: &mut Vec<KeyEnded>, time: u32, fallen: &Fallen) {
    for &key in fallen.keys() {
        if ended.len() < ended.capacity() {
            ended.push(KeyEnded { time, key });
        }
    }
}

/// What `soundboard`'s microphones hear of `bridge`'s stretch, into `heard`.
pub(super) fn run_body(soundboard: &mut Soundboard, bridge: &Bridge, heard: &mut [[f64; CONTROL_BLOCK]; 2]) {
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
pub(super) struct BeforeKeys {
    pub(super) noise: ActionNoise,
    /// The sympathetic strings' level.
    pub(super) sympathy: f64,
    /// The control block's number.
    pub(super) block: u64,
}

impl BeforeKeys {
    /// The dampers the pedal is lifting (`lifting`, moved on), and the
    /// strings' trading through the body.
    pub(super) fn run(self, keys: &mut [Option<Key>], sympathy: &mut Sympathy, performance: &mut PerformanceState) {
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
pub(super) fn sound_key(key: &mut Key, force: &mut [f64], watch: Option<&mut (u8, &mut ScopeWriter)>) {
    match watch.filter(|(k, _)| *k == key.midi_key()) {
        Some((_, scope)) => {
            key.sound(force, scope.contact_slots(force.len()));
            scope.during_contact(key.watched_string());
        }
        None => key.sound(force, None),
    }
}

/// What every sounding key is told at a control block.
#[derive(Clone, Copy)]
pub(super) struct KeyTick {
    pub(super) block_s: f64,
    pub(super) bebung: f64,
    pub(super) phantom: f64,
    pub(super) noise: ActionNoise,
}

impl KeyTick {
    /// Tell each of `keys` that is sounding, noting in `fallen` the MIDI keys
    /// of those that fell silent.
    pub(super) fn control(&self, keys: &mut [Option<Key>], performance: &PerformanceState, fallen: &mut Fallen) {
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
pub(super) struct Fallen {
    pub(super) keys: [u8; 128],
    pub(super) len: usize,
}

impl Default for Fallen {
    fn default() -> Self {
        Self { keys: [0; 128], len: 0 }
    }
}

impl Fallen {
    pub(super) fn push(&mut self, key: u8) {
        if let Some(slot) = self.keys.get_mut(self.len) {
            *slot = key;
            self.len += 1;
        }
    }

    pub(super) fn keys(&self) -> &[u8] {
        &self.keys[..self.len]
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_build_at_another_rate_takes_the_voicing_found_at_the_voicing_rate() {
        // The dulcimer: hand-held mallets, whose turn across a course's
        // strings follows the strokes the voicing struck.
        let at = |fs: f64| {
            Instrument::build_with(&default_settings(InstrumentKind::Dulcimer, fs), VoicingFrom::Afresh)
                .expect("builds")
        };
        let (voiced, other) = (at(VOICING_RATE_HZ).voicing(), at(96_000.0).voicing());
        assert_eq!(voiced, other);
        assert!(voiced.keys.len() >= 20, "{} keys", voiced.keys.len());
        for key in &voiced.keys {
            assert!(key.body_gain != 1.0 && !key.regulation.is_empty() && key.strokes > 0, "voiced: {key:?}");
        }
    }
}
