//! A key: a course of strings, the exciter that plays it, its damper, and whether
//! it is sounding.
//!
//! Usually one MIDI key plays one course. Some instruments play a course from
//! several keys (a hammered dulcimer's course from either side of its treble
//! bridge, a fretted clavichord's string pair from two or three tangents): the
//! key is then the course, and each of those MIDI keys is one of its notes.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::ops::Range;

use num_complex::Complex64;

use crate::body::boards::ZoneShare;
use crate::body::load::{BoardLoad, trade, unison_step};
use crate::body::{Bridge, BridgePoint};
use crate::damper::Damper;
use crate::design::{ExciterDesign, KeyDesign, Touch, TouchRange};
use crate::exciter::hammer::HammerSpec;
use crate::exciter::hammer::contact::ContactLaw;
use crate::exciter::hammer::substeps::SubstepPlan;
use crate::exciter::pluck::PluckSpec;
use crate::exciter::tangent::{self, TangentSpec};
use crate::modal_bank::{LANES, lane_sum};
use crate::string::StringError;
use crate::struck_string::{DEFAULT_SUBSTEPS, StruckString};

use crate::CONTROL_BLOCK;

/// Time constant of a tangent falling back from the strings when the key comes up, s.
const TANGENT_LIFT_S: f64 = 0.002;
/// A hammer that has left the strings this far, moving away, this long after
/// the strike, will not come back: the strings go free (the fast path). Chosen
/// above a mallet's repeated bounces (a few ms) and a string's swing (below 0.5 mm).
const HAMMER_GONE_GAP_M: f64 = 0.5e-3;
const HAMMER_GONE_AFTER_S: f64 = 0.03;
/// Una corda: the hammer meets the strings with its less worn, softer felt. The
/// factor on K is our assumption (the physics reference has no measurement of it).
const UNA_CORDA_STIFFNESS: f64 = 0.5;
/// A ringing key stops computing the modes that have fallen this far below its
/// loudest (-120 dB; high partials die first, and a key's strings ring for
/// tens of seconds after them)...
const CULL_BELOW_LOUDEST: f64 = 1e-6;
/// ... or below this fraction of the silence threshold (-40 dB under it: a mode
/// there adds nothing a listener or the key's switch-off could notice).
const CULL_FLOOR: f64 = 1e-2;
/// Most notes one course can have (they are kept as bits).
pub(crate) const MAX_NOTES: usize = 32;
/// Time constant smoothing the finger's pressure on a tangent (aftertouch), s: a
/// player's Bebung is a few hertz at most, MIDI pressure comes in steps.
const PRESSURE_SMOOTHING_S: f64 = 0.015;
/// The strings are retuned when their pitch has moved by more than this ratio
/// (0.002 cent).
const RETUNE_THRESHOLD: f64 = 1.0e-6;

/// One way of playing the course.
struct Note {
    midi_key: u8,
    /// The strings its exciter reaches.
    struck: Range<usize>,
    exciter: ExciterDesign,
    /// Its pitch over the course's own.
    pitch_ratio: f64,
    /// How finely its hammer's strikes are sub-stepped (none for other exciters).
    substeps: Option<SubstepPlan>,
}

/// A unison's strings trade through the body every this many control blocks
/// (10.7 ms at 48 kHz: the coupling moves them by under a tenth of their
/// motion in that time, and a cent's mistuning turns them apart by under a
/// tenth of a radian even at C8).
pub(crate) const TRADE_BLOCKS: usize = 8;

/// The most strings of a unison that trade through the body (a santoor's
/// course has four).
const MAX_UNISON: usize = 8;

/// Per-sample step of a key's strike gain toward a new strike's regulation
/// (a time constant of 256 samples, about 5 ms at 48 kHz: the new strike
/// masks it).
const STRIKE_GAIN_GLIDE: f64 = 1.0 / 256.0;

pub(crate) struct Key {
    /// The MIDI key the course is listed under (its first note).
    midi_key: u8,
    strings: Vec<StruckString>,
    notes: Vec<Note>,
    damper: Damper,
    /// How [`TRADE_BLOCKS`] control blocks of the unison's trading through the
    /// body move each partial: the share that differs from the strings' mean by
    /// alpha, the mean by beta (empty: strings not coupled so).
    unison: Vec<(Complex64, Complex64)>,
    /// Control blocks since the unison last traded.
    blocks_since_trade: usize,
    /// Re Y of the shared bridge point (0: strings not coupled), and the force each
    /// string put on it last sample.
    bridge_coupling_s_kg: f64,
    bridge_force_n: Vec<f64>,
    /// Scratch for this sample's forces.
    force_now_n: Vec<f64>,
    /// The free strings' bridge force by lane, for a control block.
    lanes: Box<[[f64; LANES]; CONTROL_BLOCK]>,
    /// Full scale per newton of bridge force.
    gain_per_n: f64,
    /// Where its strings bear on the bridge.
    bridge_point: BridgePoint,
    /// How much louder the body hears it than the bridge-force output does (its
    /// ringing gain over the gain the bridge force's peak allows).
    body_boost: f64,
    /// Its regulation: the gain of a strike by its touch (empty: 1), and the
    /// gain now and where it glides to (the last strike's).
    regulation: Vec<(f64, f64)>,
    strike_gain: f64,
    strike_gain_to: f64,
    // What the player is doing with it.
    /// Sounding (struck and not yet silent or faded out).
    active: bool,
    /// Notes held down, and notes struck since the key last fell silent (bit i: note i).
    held: u32,
    sounded: u32,
    /// Held up by the sostenuto pedal.
    sostenuto: bool,
    /// The note whose pitch the strings speak at (a fretted clavichord: the highest tangent down).
    speaking: usize,
    /// Finger pressure 0..=1 (aftertouch), and its smoothed value.
    pressure: f64,
    pressure_now: f64,
    /// How much deeper full pressure presses a tangent, as a fraction of its depth.
    bebung: f64,
    /// The pitch the poles were last set for.
    pitch_set: f64,
    /// Output gain for stealing and resets: `fade` moves by `fade_step` per sample, within 0..=1.
    fade: f64,
    fade_step: f64,
    /// Upper bound on the key's output at the last control tick (full scale = 1).
    level: f64,
    /// The loudest mode of its strings at the last control tick, N (0 while one is played).
    loudest_n: f64,
}

impl Key {
    /// Build every table the key will need, for touches up to `touch.max()`,
    /// its strings loaded by `board` (None: by the design's resistive bridge).
    /// Allocates; off the audio thread.
    pub fn build(
        design: KeyDesign,
        sample_rate_hz: f64,
        touch: TouchRange,
        board: Option<&BoardLoad>,
    ) -> Result<Self, StringError> {
        let mut notes = vec![Note {
            midi_key: design.midi_key,
            struck: design.struck.clone(),
            exciter: design.exciter,
            pitch_ratio: 1.0,
            substeps: None,
        }];
        notes.extend(design.shared.iter().map(|s| Note {
            midi_key: s.midi_key,
            struck: s.struck.clone(),
            exciter: s.exciter,
            pitch_ratio: s.pitch_ratio,
            substeps: None,
        }));
        notes.truncate(MAX_NOTES);
        let mut modes = design.strings.iter().map(|spec| spec.build()).collect::<Result<Vec<_>, _>>()?;
        // A course's strings trade energy through the board where they bear
        // together (a dulcimer's courses already move their bridge point).
        let coupled = board.is_some() && (2..=MAX_UNISON).contains(&modes.len()) && design.bridge_coupling_s_kg <= 0.0;
        let mut unison = Vec::new();
        if let Some(board) = board {
            let n = if coupled { modes.len() } else { 1 };
            if coupled {
                let step_s = (TRADE_BLOCKS * CONTROL_BLOCK) as f64 / sample_rate_hz;
                let eps = board.coupling(design.midi_key, design.resistive_bridge, &modes[0]);
                let partials = modes.iter().map(|m| m.modes.len()).min().unwrap_or(0).min(eps.len());
                unison = eps[..partials].iter().map(|&e| unison_step(e, n, step_s)).collect();
            }
            for string in &mut modes {
                board.load(design.midi_key, design.resistive_bridge, n, string);
            }
        }
        // Each hammer's strikes measured on the last string it reaches, with its
        // share of the hammer (as `press` splits it).
        for note in &mut notes {
            if let (ExciterDesign::Hammer { mass_kg, law, position }, Some(last), Some(top_speed_m_s)) =
                (note.exciter, note.struck.clone().last(), touch.top_speed_m_s())
            {
                let hammer = HammerSpec::one_of(note.struck.len(), mass_kg, law, top_speed_m_s, position);
                note.substeps = Some(SubstepPlan::measure(&modes[last], sample_rate_hz, hammer));
            }
        }
        let mut strings = Vec::with_capacity(design.strings.len());
        for (i, string) in modes.into_iter().enumerate() {
            let counts: Vec<usize> = notes
                .iter()
                .filter(|n| n.struck.contains(&i))
                .filter_map(|n| n.substeps.as_ref())
                .flat_map(SubstepPlan::counts)
                .collect();
            let mut s = StruckString::with_substep_counts(string, sample_rate_hz, &counts);
            for note in notes.iter().filter(|n| n.struck.contains(&i)) {
                match note.exciter {
                    ExciterDesign::Hammer { position, .. } => s.prepare_hammer(position),
                    ExciterDesign::Tangent { .. } => s.prepare_tangent(),
                    ExciterDesign::Pluck { position } => s.prepare_pluck(position),
                }
            }
            if design.bridge_coupling_s_kg > 0.0 {
                s.prepare_bridge_drive();
            }
            strings.push(s);
        }
        Ok(Self {
            midi_key: design.midi_key,
            strings,
            notes,
            damper: Damper::new(design.damper),
            unison,
            blocks_since_trade: 0,
            bridge_coupling_s_kg: design.bridge_coupling_s_kg.max(0.0),
            bridge_force_n: vec![0.0; design.strings.len()],
            force_now_n: vec![0.0; design.strings.len()],
            lanes: Box::new([[0.0; LANES]; CONTROL_BLOCK]),
            gain_per_n: design.gain_per_n,
            bridge_point: BridgePoint::panned(design.pan),
            body_boost: if design.gain_per_n > 0.0 {
                (design.ring_gain_per_n / design.gain_per_n).max(1.0)
            } else {
                1.0
            },
            regulation: Vec::new(),
            strike_gain: 1.0,
            strike_gain_to: 1.0,
            active: false,
            held: 0,
            sounded: 0,
            sostenuto: false,
            speaking: 0,
            pressure: 0.0,
            pressure_now: 0.0,
            bebung: 0.0,
            pitch_set: 1.0,
            fade: 1.0,
            fade_step: 0.0,
            level: 0.0,
            loudest_n: 0.0,
        })
    }

    /// The MIDI key the course is listed under (its first note).
    pub fn midi_key(&self) -> u8 {
        self.midi_key
    }

    /// Whether it is sounding: struck, and neither silent yet nor faded out.
    pub fn is_sounding(&self) -> bool {
        self.active
    }

    /// How much louder the body should hear it than the bridge-force output
    /// does, before the body's own colour is taken out (its ringing gain over
    /// the gain the bridge force's peak allows).
    pub fn body_boost(&self) -> f64 {
        self.body_boost
    }

    /// Regulate it: a strike at touch t (in the touch's unit) is heard at the
    /// gain `table` gives there (see `synth::body_voicing`).
    pub fn regulate(&mut self, table: Vec<(f64, f64)>) {
        self.regulation = table;
    }

    /// Bear on the body's zones as `share` says, `voicing` times louder there
    /// than at its bridge-force gain.
    pub fn bear_on(&mut self, share: ZoneShare, voicing: f64) {
        let weights = share.weights.map(|w| w * voicing);
        self.bridge_point = self.bridge_point.on_zones(ZoneShare { weights, ..share });
    }

    /// Play its first note at `touch` alone for `force.len()` samples, writing
    /// the force it hands the bridge (at its output gain), and return what its
    /// strings then ring with, string by string and mode by mode: the force
    /// Re(z e^(lambda t)) at output gain, as (z, lambda). The key is left silent. Allocates; for
    /// voicing the key through the body when the instrument is built.
    pub fn probe(&mut self, touch: Touch, force: &mut [f64]) -> Vec<Vec<(Complex64, Complex64)>> {
        self.press(0, touch, false, 1.0, 1.0);
        for (b, chunk) in force.chunks_mut(CONTROL_BLOCK).enumerate() {
            chunk.fill(0.0);
            self.render(chunk, None);
            if chunk.len() == CONTROL_BLOCK && (b + 1) % TRADE_BLOCKS == 0 {
                self.trade_through_bridge(0.0);
            }
        }
        force.iter_mut().for_each(|f| *f *= self.gain_per_n);
        let gain = self.gain_per_n;
        let partials = self
            .strings
            .iter()
            .map(|s| s.bank().bridge_partials().into_iter().map(|(z, lambda)| (z * gain, lambda)).collect())
            .collect();
        self.silence();
        self.sounded = 0;
        partials
    }

    /// Whether its exciter stays on the strings after the strike (a tangent):
    /// what they ring with is then not their free modes'.
    pub fn stays_on_strings(&self) -> bool {
        matches!(self.notes[0].exciter, ExciterDesign::Tangent { .. })
    }

    /// How [`TRADE_BLOCKS`] control blocks of its unison's trading through the
    /// body move each partial (see [`Self::trade_through_bridge`]; empty when
    /// its strings do not trade so).
    pub fn unison(&self) -> &[(Complex64, Complex64)] {
        &self.unison
    }

    /// Whether it is fading out (stolen, reset, or its instrument replaced).
    pub fn is_fading_out(&self) -> bool {
        self.fade_step < 0.0
    }

    /// Upper bound on its output at the last control tick (full scale = 1).
    pub fn level(&self) -> f64 {
        self.level
    }

    /// Fade it out over `seconds`, then silence it (at the next control tick).
    pub fn fade_out(&mut self, seconds: f64, sample_rate_hz: f64) {
        self.fade_step = -1.0 / (seconds * sample_rate_hz);
    }

    /// The sostenuto pedal goes down: a sounding key held now stays up with it.
    pub fn catch_sostenuto(&mut self) {
        self.sostenuto = self.active && self.down();
    }

    /// The sostenuto pedal comes up.
    pub fn drop_sostenuto(&mut self) {
        self.sostenuto = false;
    }

    /// The finger's pressure on the key, 0..=1 (aftertouch).
    pub fn set_pressure(&mut self, pressure: f64) {
        self.pressure = pressure.clamp(0.0, 1.0);
    }

    /// How much deeper full pressure presses a tangent, as a fraction of its depth.
    pub fn set_bebung(&mut self, bebung: f64) {
        self.bebung = bebung;
    }

    /// The MIDI keys that play this course, with their note numbers.
    pub fn note_keys(&self) -> impl Iterator<Item = (usize, u8)> + '_ {
        self.notes.iter().enumerate().map(|(i, n)| (i, n.midi_key))
    }

    /// Modes of all the course's strings.
    pub fn mode_count(&self) -> usize {
        self.strings.iter().map(|s| s.bank().len()).sum()
    }

    /// Modes being computed now (culled modes left out).
    pub fn running_modes(&self) -> usize {
        self.strings.iter().map(|s| s.bank().running()).sum()
    }

    /// Whether any of the course's keys is down.
    pub fn down(&self) -> bool {
        self.held != 0
    }

    /// The MIDI keys struck since the key last fell silent, forgotten once read.
    pub fn take_sounded(&mut self) -> impl Iterator<Item = u8> + '_ {
        let sounded = std::mem::take(&mut self.sounded);
        self.notes.iter().enumerate().filter(move |(i, _)| sounded & (1 << i) != 0).map(|(_, n)| n.midi_key)
    }

    /// The string the live view shows: the last the first note strikes, which a
    /// hammer reaches even under una corda.
    pub fn watched_string(&self) -> &StruckString {
        let last = self.notes[0].struck.end.clamp(1, self.strings.len()) - 1;
        &self.strings[last]
    }

    /// Note `note` goes down with `touch` (a speed for hammers, mallets and
    /// tangents, a lift for a plectrum), with the mallet's hardness `hardness`
    /// times as built. A touch in the other unit than the note's exciter is
    /// ignored.
    pub fn press(&mut self, note: usize, touch: Touch, una_corda: bool, hardness: f64, bend: f64) {
        let Some(played) = self.notes.get(note) else { return };
        let fits = match played.exciter {
            ExciterDesign::Pluck { .. } => matches!(touch, Touch::PluckHeight { .. }),
            _ => matches!(touch, Touch::Speed { .. }),
        };
        if !fits {
            return;
        }
        let touch = touch.value();
        let bit = 1u32 << note;
        if !self.regulation.is_empty() {
            self.strike_gain_to = regulated(&self.regulation, touch);
            if !self.active {
                self.strike_gain = self.strike_gain_to;
            }
        }
        self.active = true;
        if self.fade < 1.0 || self.fade_step < 0.0 {
            self.fade_step = self.fade_step.abs().max(1e-4);
        }
        // The damper leaves the strings before the hammer arrives (a cimbalom's
        // damper bar answers the pedal alone).
        self.damper.lift_for_strike();
        if let ExciterDesign::Tangent { .. } = played.exciter {
            // The higher tangent wins: a lower one under it meets a string it does not
            // sound, and waits there in case the higher key comes up first.
            let above = self.held != 0 && self.notes[self.speaking].pitch_ratio > played.pitch_ratio;
            self.held |= bit;
            self.sounded |= bit;
            if above {
                return;
            }
            self.speaking = note;
            self.pressure = 0.0;
        }
        self.held |= bit;
        self.sounded |= bit;
        let pitch = self.pitch(bend);
        self.set_poles(pitch);
        let played = &self.notes[note];
        let strings = &mut self.strings[played.struck.clone()];
        match played.exciter {
            ExciterDesign::Hammer { mass_kg, law, position } => {
                let n = strings.len();
                // Una corda shifts the action: the first string of a unison is missed.
                let skip = usize::from(una_corda && n >= 2);
                let stiffness = law.stiffness * hardness * if una_corda { UNA_CORDA_STIFFNESS } else { 1.0 };
                let felt = ContactLaw { stiffness, exponent: law.exponent };
                let hammer = HammerSpec::one_of(n - skip, mass_kg, felt, touch, position);
                let substeps = played.substeps.as_ref().map_or(DEFAULT_SUBSTEPS, |plan| plan.substeps(touch));
                for s in &mut strings[skip..] {
                    s.strike_substepped(hammer, substeps);
                }
            }
            ExciterDesign::Tangent { displacement_m, .. } => {
                for s in strings {
                    s.press_tangent(TangentSpec { speed_m_s: touch, displacement_m });
                }
            }
            ExciterDesign::Pluck { position } => {
                for s in strings {
                    s.pluck(PluckSpec { displacement_m: touch * 1e-3, position });
                    s.release_exciter();
                }
            }
        }
    }

    /// Note `note` comes up.
    pub fn release(&mut self, note: usize) {
        let bit = 1u32 << note;
        if self.held & bit == 0 {
            return;
        }
        self.held &= !bit;
        let Some(ExciterDesign::Tangent { .. }) = self.notes.get(note).map(|n| n.exciter) else { return };
        if self.held == 0 {
            let struck = self.notes[note].struck.clone();
            for s in &mut self.strings[struck] {
                s.lift_tangent(TANGENT_LIFT_S);
            }
        } else if note == self.speaking {
            // A lower tangent still down takes over the string (its pitch follows at
            // the next control tick).
            let held = self.held;
            if let Some((i, _)) = self
                .notes
                .iter()
                .enumerate()
                .filter(|(i, _)| held & (1 << i) != 0)
                .max_by(|a, b| a.1.pitch_ratio.total_cmp(&b.1.pitch_ratio))
            {
                self.speaking = i;
            }
        }
    }

    /// Every note of the course comes up.
    pub fn release_all(&mut self) {
        for note in 0..self.notes.len() {
            self.release(note);
        }
    }

    /// The strings' pitch over their own: the bend, the speaking note's interval
    /// and, under a tangent, the stretch of the press. A tangent holding the end at
    /// W raises the tension by the factor 1 + s W^2 and the pitch by its square
    /// root; the finger's pressure presses deeper by up to `bebung` of the depth
    /// (Bebung: the pitch follows the finger).
    fn pitch(&self, bend: f64) -> f64 {
        let note = &self.notes[self.speaking];
        let stretch = match note.exciter {
            ExciterDesign::Tangent { stretch_per_m2, .. } => {
                let w = self.strings[note.struck.start].tangent_position_m() * (1.0 + self.bebung * self.pressure_now);
                tangent::stretched_pitch_ratio(stretch_per_m2, w)
            }
            _ => 1.0,
        };
        bend * note.pitch_ratio * stretch
    }

    /// Once per control block: move the damper, retune for a bend or a press, let
    /// go of hammers that have flown off, and notice silence. Returns true when the
    /// key has just fallen silent (it is then inactive and at rest).
    pub fn control(&mut self, block_s: f64, sustain: f64, bend: f64, silence: f64) -> bool {
        if self.fade <= 0.0 {
            // Faded out (stolen, reset, or its instrument replaced).
            self.silence();
            return true;
        }
        let held = self.down() || self.sostenuto;
        self.damper.follow(block_s, held, sustain);
        self.pressure_now += (self.pressure - self.pressure_now) * (1.0 - (-block_s / PRESSURE_SMOOTHING_S).exp());
        let pitch = self.pitch(bend);
        if self.damper.moved() || (pitch / self.pitch_set - 1.0).abs() > RETUNE_THRESHOLD {
            self.set_poles(pitch);
        }
        let floor_n = (CULL_BELOW_LOUDEST * self.loudest_n).max(CULL_FLOOR * silence / self.gain_per_n.max(1e-300));
        self.blocks_since_trade += 1;
        if self.blocks_since_trade >= TRADE_BLOCKS {
            self.blocks_since_trade = 0;
            self.trade_through_bridge(floor_n);
        }
        let mut settled = true;
        let mut bound = 0.0;
        let mut loudest_n = 0.0f64;
        for s in &mut self.strings {
            if s.hammer_gone(HAMMER_GONE_GAP_M, HAMMER_GONE_AFTER_S) {
                s.release_exciter();
            }
            settled &= s.is_settled();
            let (string_bound, string_loudest) = s.cull(floor_n);
            bound += string_bound;
            loudest_n = loudest_n.max(string_loudest);
        }
        // A string still being played reports an infinite loudest: no relative culling next time.
        self.loudest_n = if loudest_n.is_finite() { loudest_n } else { 0.0 };
        if (self.strike_gain - self.strike_gain_to).abs() < 1e-6 * self.strike_gain_to {
            self.strike_gain = self.strike_gain_to;
        }
        self.level = bound * self.gain_per_n * self.fade * self.strike_gain.max(self.strike_gain_to);
        if settled && self.level < silence {
            self.silence();
            return true;
        }
        false
    }

    /// A control block of the unison's strings trading energy through their
    /// bridge point (Weinreich 1977): partial by partial, the strings' mean
    /// moves the bridge and with it every string, so the mean (the strings in
    /// step) loses into the body N times as fast as one string alone, and
    /// whatever differs from it (strings out of step) not at all. Each string's
    /// own loss is in its free step; this applies the rest, exactly for the
    /// coupling over [`TRADE_BLOCKS`] blocks (the detuning turns the strings
    /// apart by hundredths of a radian in that time). Partials no string
    /// computes are left alone, and a mode at rest takes its share only if it
    /// is over `floor_n`. Allocates: no.
    fn trade_through_bridge(&mut self, floor_n: f64) {
        if self.unison.is_empty() {
            return;
        }
        let top = self.strings.iter().map(|s| s.bank().running()).max().unwrap_or(0).min(self.unison.len());
        let mut phasors = [Complex64::new(0.0, 0.0); MAX_UNISON];
        let strings = self.strings.len().min(MAX_UNISON);
        for (i, &step) in self.unison[..top].iter().enumerate() {
            for (z, s) in phasors.iter_mut().zip(&self.strings) {
                *z = s.bank().phasor(i);
            }
            if phasors[..strings].iter().all(|z| z.re.abs() + z.im.abs() < floor_n.max(f64::MIN_POSITIVE)) {
                continue;
            }
            trade(step, &mut phasors[..strings]);
            for (z, s) in phasors.iter().zip(&mut self.strings) {
                // A mode at rest is woken only if what it takes would not be
                // culled at once.
                if i < s.bank().running() || z.re.abs() + z.im.abs() >= floor_n {
                    s.bank_mut().set_phasor(i, *z);
                }
            }
        }
    }

    /// Set every string's free step for the damper's present engagement and `pitch`.
    fn set_poles(&mut self, pitch: f64) {
        let (rate_s, rate_per_hz_s) = self.damper.extra_decay();
        for s in &mut self.strings {
            s.set_free_step(rate_s, rate_per_hz_s, pitch);
        }
        self.pitch_set = pitch;
    }

    /// At rest and inactive (the notes struck are kept for [`Self::take_sounded`]).
    pub fn silence(&mut self) {
        for s in &mut self.strings {
            s.silence();
        }
        self.active = false;
        self.held = 0;
        self.sostenuto = false;
        self.speaking = 0;
        self.pressure = 0.0;
        self.pressure_now = 0.0;
        self.bridge_force_n.fill(0.0);
        self.fade = 1.0;
        self.fade_step = 0.0;
        self.level = 0.0;
        self.loudest_n = 0.0;
    }

    /// Drive `bridge` for its stretch with the key's force at its output gain,
    /// moving its fade; `scratch` is as long as the stretch. The summed contact
    /// force goes to `contact` when given.
    pub fn sound(&mut self, bridge: &mut Bridge, scratch: &mut [f64], contact: Option<&mut [f32]>) {
        scratch.fill(0.0);
        self.render(scratch, contact);
        let glide = self.strike_gain != self.strike_gain_to;
        for v in scratch.iter_mut() {
            if glide {
                self.strike_gain += (self.strike_gain_to - self.strike_gain) * STRIKE_GAIN_GLIDE;
            }
            *v = *v * self.gain_per_n * self.fade * self.strike_gain;
            if self.fade_step != 0.0 {
                self.fade = (self.fade + self.fade_step).clamp(0.0, 1.0);
                if self.fade >= 1.0 && self.fade_step > 0.0 {
                    self.fade_step = 0.0;
                }
            }
        }
        if self.fade <= 0.0 && self.fade_step < 0.0 {
            // Faded out: silent from the next sample; reported at the next control tick.
            self.fade_step = 0.0;
            self.fade = 0.0;
        }
        bridge.drive(self.bridge_point, scratch);
    }

    /// Add the key's summed bridge force (N) over `out.len()` samples to `out`,
    /// and the summed contact force to `contact` when given.
    fn render(&mut self, out: &mut [f64], mut contact: Option<&mut [f32]>) {
        if self.bridge_coupling_s_kg > 0.0 {
            self.render_coupled(out, contact);
            return;
        }
        let acc = &mut self.lanes[..out.len()];
        acc.fill([0.0; LANES]);
        for s in &mut self.strings {
            if contact.is_none() && s.accumulate_free(acc, out) {
                continue;
            }
            for (t, o) in out.iter_mut().enumerate() {
                let tick = s.tick();
                *o += tick.bridge_force_n;
                if let Some(c) = contact.as_deref_mut() {
                    c[t] += tick.contact_force_n as f32;
                }
            }
        }
        for (o, a) in out.iter_mut().zip(acc.iter()) {
            *o += lane_sum(a);
        }
    }

    /// [`Self::render`] for a course whose strings share a bridge point: each
    /// sample the bridge moves under the strings' force, at Re Y times it, and
    /// carries every string's end with it. A string's own push on the bridge is
    /// already among its losses, so each string's end is moved by the others'
    /// force alone: with its own share that makes the whole coupling Y times the
    /// square of the summed force, which only ever takes energy out.
    fn render_coupled(&mut self, out: &mut [f64], mut contact: Option<&mut [f32]>) {
        let y = self.bridge_coupling_s_kg;
        for (t, o) in out.iter_mut().enumerate() {
            let (mut total, mut total_before) = (0.0, 0.0);
            for (i, s) in self.strings.iter_mut().enumerate() {
                let tick = s.tick();
                self.force_now_n[i] = tick.bridge_force_n;
                total += tick.bridge_force_n;
                total_before += self.bridge_force_n[i];
                if let Some(c) = contact.as_deref_mut() {
                    c[t] += tick.contact_force_n as f32;
                }
            }
            *o += total;
            for (i, s) in self.strings.iter_mut().enumerate() {
                let own_change = self.force_now_n[i] - self.bridge_force_n[i];
                s.move_bridge(y * (total - total_before - own_change));
            }
            std::mem::swap(&mut self.bridge_force_n, &mut self.force_now_n);
        }
    }

    /// Take over a ringing key of the same instrument whose tables were rebuilt.
    pub fn take_over(&mut self, old: &mut Key, bend: f64) {
        for (new, old) in self.strings.iter_mut().zip(old.strings.iter_mut()) {
            new.take_motion_from(old);
        }
        // The same courses (Synth::install checks the routes), so the notes match.
        let notes = if self.notes.len() >= 32 { u32::MAX } else { (1u32 << self.notes.len()) - 1 };
        self.active = old.active;
        self.held = old.held & notes;
        self.sounded = std::mem::take(&mut old.sounded) & notes;
        self.sostenuto = old.sostenuto;
        self.speaking = old.speaking.min(self.notes.len() - 1);
        self.pressure = old.pressure;
        self.pressure_now = old.pressure_now;
        if self.bridge_force_n.len() == old.bridge_force_n.len() {
            self.bridge_force_n.copy_from_slice(&old.bridge_force_n);
        }
        self.damper.take_over(&old.damper);
        self.fade = old.fade;
        self.fade_step = old.fade_step;
        self.level = old.level;
        let pitch = self.pitch(bend);
        self.set_poles(pitch);
        old.silence();
    }
}

/// A regulation's gain at touch `value` (see [`Key::regulate`]): interpolated
/// in log gain over log touch, held at the ends.
pub(crate) fn regulated(table: &[(f64, f64)], value: f64) -> f64 {
    match table.iter().position(|&(t, _)| t >= value) {
        None => table.last().map_or(1.0, |p| p.1),
        Some(0) => table[0].1,
        Some(i) => {
            let ((t0, g0), (t1, g1)) = (table[i - 1], table[i]);
            let x = ((value / t0).ln() / (t1 / t0).ln()).clamp(0.0, 1.0);
            g0 * (g1 / g0).powf(x)
        }
    }
}
