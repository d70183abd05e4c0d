//! A key: a course of strings, the exciter that plays it, its damper, and whether
//! it is sounding.
//!
//! Usually one MIDI key plays one course. Some instruments play a course from
//! several keys (a hammered dulcimer's course from either side of its treble
//! bridge, a fretted clavichord's string pair from two or three tangents): the
//! key is then the course, and each of those MIDI keys is one of its notes.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

mod build;
mod control;
mod phantom_state;
mod ports;
mod render;
mod strike;
mod unison;

use std::ops::Range;

use num_complex::Complex64;

use crate::action;
use crate::body::boards::ZoneShare;
use crate::body::load::{BoardLoad, trade, unison_step};
use crate::body::{Bridge, BridgePoint, KeyPan};
use crate::damper::Damper;
use crate::design::{ExciterDesign, InstrumentKind, KeyDesign, LiveVoicing, ResistiveBridge, Touch};
use crate::exciter::hammer::contact::ContactLaw;
use crate::exciter::hammer::{HammerSpec, Hysteresis};
use crate::exciter::pluck::PluckSpec;
use crate::exciter::tangent::{self, TangentSpec};
use crate::modal_bank::{FreeGather, LANES, add_lane_sums};
use crate::performance::{OwnNote, PerformanceState};
use crate::phantom::{Phantom, PhantomTable};
use crate::string::{StringError, StringModes};
use crate::struck_string::substeps::SubstepPlan;
use crate::struck_string::{DEFAULT_SUBSTEPS, StruckString};
use control::Cull;
use phantom_state::PhantomState;
pub(crate) use ports::{Port, wakes};
use render::FreeRun;
pub(crate) use strike::regulated;
use strike::{ActionSounds, Regulation, StrikeShares};
use unison::{CourseBridge, Unison};

use crate::CONTROL_BLOCK;

/// A hammer that has left the strings this far, moving away, this long after
/// the strike, will not come back: the strings go free (the fast path). Chosen
/// above a mallet's repeated bounces (a few ms) and a string's swing (below 0.5 mm).
const HAMMER_GONE_GAP_M: f64 = 0.5e-3;
const HAMMER_GONE_AFTER_S: f64 = 0.03;
/// Una corda: the hammer meets the strings with its less worn, softer felt. The
/// factor on K is our assumption (no measurement of it was found).
const UNA_CORDA_STIFFNESS: f64 = 0.5;
/// A string the shifted hammer meets with less than this share of its width
/// is missed.
const MISSED: f64 = 1e-3;
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
/// Where a key's own strike position may move the hammer, fractions of the string.
const MIN_STRIKE_POINT: f64 = 0.02;
const MAX_STRIKE_POINT: f64 = 0.5;
/// The deepest Bebung, cents at full pressure.
pub const MAX_BEBUNG_CENTS: f64 = 100.0;
/// The strings are retuned when their pitch has moved by more than this ratio
/// (0.002 cent).
const RETUNE_THRESHOLD: f64 = 1.0e-6;

/// One way of playing the course.
#[derive(Clone)]
struct Note {
    midi_key: u8,
    /// The strings its exciter reaches.
    struck: Range<usize>,
    exciter: ExciterDesign,
    /// Its pitch over the course's own.
    pitch_ratio: f64,
    /// How finely its hammer's strikes are sub-stepped (none for other exciters).
    substeps: Option<SubstepPlan>,
    /// Its hammer's felt's hysteresis (None: elastic).
    hysteresis: Option<Hysteresis>,
}

/// A unison's strings trade through the body every this many control blocks
/// (21.3 ms at 48 kHz: the trade is exact for the coupling over the
/// interval; the strings' mistuning turns them apart by a few hundredths of a
/// radian in that time, a cent at C4 by 0.03).
pub(crate) const TRADE_BLOCKS: usize = 16;

/// The strings of different keys trade through the body every this many
/// control blocks (10.7 ms at 48 kHz). Each pair's forced answer over the
/// interval is exact for a freely turning partner, but a partial trades with
/// a dozen partners at once, and the explicit step's error grows with the
/// interval: a held C4's difference with the pedal down is -8.2 dB at 8
/// blocks and -9.5 at 4 (each key taking from its partners at its own block
/// of the interval; -8.4 and -9.5 when each pair traded both ways at once).
/// (Shorter intervals are not comparable: the pairs dropped as negligible
/// are judged per interval, and at 2 blocks so many fall under it that the
/// difference was -16.5 dB.)
pub(crate) const SYMPATHY_BLOCKS: usize = 8;

/// A silent key is woken by the other strings only by a drive this many
/// times over the silence floor (about 10 dB: a string barely moved would
/// ring unheard, at the cost of a key's computing). At 30 dB a mezzo-forte
/// staccato C4 left most of the undamped treble asleep (its answer 3 dB
/// weaker, and none at all at velocity 64); the 32-note chord of `struck
/// bench` wakes one key more (27 sounding), at no measurable cost.
const WAKE_OVER_SILENCE: f64 = 3.0;

/// Free strings are culled every this many control blocks.
const CULL_EVERY_BLOCKS: u8 = 4;

/// A key the other strings move stays sounding for this many control blocks
/// after they last did (it takes from them at its own block of every
/// [`SYMPATHY_BLOCKS`], before the keys' control counts down: one to spare).
const DRIVEN_BLOCKS: usize = SYMPATHY_BLOCKS + 1;

/// Keys above this make no phantom partials (Conklin's and Bank's are the
/// wound strings' and the lowest plain ones'; above C4 the strings'
/// products are masked).
const LAST_PHANTOM_KEY: u8 = 60;

/// The dampers lifting set ringing only partials under this, Hz (the bend
/// their weight leaves is a broad one).
const LIFT_TOP_HZ: f64 = 2_000.0;

/// Partials above this are not offered to the other strings through the
/// body, Hz (the body's modes thin out above it, and the strings' partials
/// there die within a second).
const SYMPATHY_TOP_HZ: f64 = 5_000.0;

/// Strings of a key whose first partials lie within this ratio of each other
/// ring together as one group for the other strings (a dulcimer course's two
/// sides do not).
const SAME_PITCH: f64 = 0.01;

/// The most a course's strings sharing a bridge point move each other over a
/// sample: the bridge's admittance times the sum of their answers to its
/// motion ([`StruckString::bridge_answer_ns_m`]). The trade is explicit, one
/// sample behind, and grows without bound past about 1; a dulcimer's courses
/// loop at 0.001 to 0.024 in equal temperament, and only a course tuned
/// hundreds of times tighter reaches this. Over it the bridge is taken as
/// that much stiffer for the whole course (a smaller admittance: still
/// passive).
const COURSE_LOOP_LIMIT: f64 = 0.25;

/// The most strings of a unison that trade through the body (a santoor's
/// course has four).
const MAX_UNISON: usize = 8;

/// Time constant of a key's strike gain gliding to a new strike's regulation,
/// s (the new strike masks it; a step would click on the strings still
/// ringing from the last).
const STRIKE_GAIN_GLIDE_S: f64 = 0.005;

impl Note {
    /// Where its damper sits on the strings: over the place its hammer
    /// strikes or its plectrum plucks (None: a tangent's strings, damped by
    /// the listing cloth).
    fn damper_position(&self) -> Option<f64> {
        match self.exciter {
            ExciterDesign::Hammer { position, .. } | ExciterDesign::Pluck { position } => Some(position),
            ExciterDesign::Tangent { .. } => None,
        }
    }
}

/// The levels of the action's sounds, 1 = the physics ([`crate::action`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct ActionNoise {
    /// The key striking its bed.
    pub key_bed: f64,
    /// A damper's felt landing on its strings.
    pub damper: f64,
    /// The dampers leaving the strings when the pedal lifts them.
    pub pedal: f64,
}

impl Default for ActionNoise {
    fn default() -> Self {
        Self { key_bed: 1.0, damper: 1.0, pedal: 1.0 }
    }
}

/// A course of strings and everything that plays it: its notes (the ways
/// into it), the strike, the damper, the unison's trading, the phantom
/// products, the action's sounds, and the player's hold on it.
#[derive(Clone)]
pub(crate) struct Key {
    /// The MIDI key the course is listed under (its first note).
    midi_key: u8,
    strings: Vec<StruckString>,
    notes: Vec<Note>,
    /// How the hammer's width falls on the strings, stroke by stroke.
    strike: StrikeShares,
    damper: Damper,
    /// The unison's partials trading through the body.
    unison: Unison,
    /// Moved by the other strings since the last control block (it does not
    /// fall silent while they move it, however faintly).
    driven: usize,
    /// Its strings' stretch pulling on the bridge at sums of their partials.
    phantom: PhantomState,
    /// The key bed's knock, the damper's landing, the pedal's lift.
    action: ActionSounds,
    /// Its partials as the other strings on the body meet them (empty: strings
    /// on the seed's rigid bridge, or a tangent's, which the listing damps).
    ports: Vec<Port>,
    /// Strings moving each other sample by sample through a shared bridge point.
    course: CourseBridge,
    /// The free strings' modes, run together over a control block.
    run: FreeRun,
    /// Full scale per newton of bridge force.
    gain_per_n: f64,
    /// Where its strings bear on the bridge.
    bridge_point: BridgePoint,
    /// How much louder the body hears it than the bridge-force output does (its
    /// ringing gain over the gain the bridge force's peak allows).
    body_boost: f64,
    /// How much louder than its bridge-force gain it bears on the body (its
    /// voicing there, [`Key::bear_on`]; 1 until voiced).
    body_gain: f64,
    /// The gain of a strike by its touch, and its glide.
    regulation: Regulation,
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
    /// The finger's pressure on a tangent, and the Bebung it makes.
    finger: Finger,
    /// Its own pitch, gain and place ([`Self::set_tune`], [`Self::set_volume`], [`Self::set_pan`]).
    trim: Trim,
    /// Its own hammer and the player's voicing over the built one.
    voicing: OwnVoicing,
    /// The pitch the poles were last set for.
    pitch_set: f64,
    /// Output gain for stealing and resets.
    fade: Fade,
    /// How loud it is, and which of its modes are worth computing.
    cull: Cull,
}

/// Finger pressure 0..=1 (aftertouch) and its smoothed value; how far full
/// pressure raises a tangent's pitch, cents, and the tension's factor that
/// makes it (the pitch's squared).
#[derive(Clone)]
struct Finger {
    pressure: f64,
    pressure_now: f64,
    bebung_cents: f64,
    bebung: f64,
}

/// Its own pitch offset as a ratio, its own output gain, the gain it glides
/// to and its step a sample, and its own place in the stereo image.
#[derive(Clone, Copy)]
struct Trim {
    tune: f64,
    volume: f64,
    volume_to: f64,
    volume_step: f64,
    pan: KeyPan,
}

/// Its own hammer over the voicing (felt stiffness and strike position
/// factors, [`Key::set_hammer`]), and the player's voicing over the one the
/// key was built with ([`Key::set_live_voicing`]).
#[derive(Clone)]
struct OwnVoicing {
    hardness: f64,
    position: f64,
    live: LiveVoicing,
}

/// The fade's gain, moving by `step` per sample within 0..=1.
#[derive(Clone, Copy)]
struct Fade {
    gain: f64,
    step: f64,
}

impl Key {
    /// The MIDI key the course is listed under (its first note).
    pub fn midi_key(&self) -> u8 {
        self.midi_key
    }

    /// The energy its strings hold, J, weighed by the square of what a
    /// newton of theirs is heard at ([`Self::heard_per_n`]): the measure in
    /// which the trade between keys is the physics' own (see
    /// `synth::sympathy`), so the sum over the keys can only fall while
    /// nothing strikes them.
    #[cfg(test)]
    pub fn heard_energy(&mut self) -> f64 {
        self.settle();
        self.heard_per_n().powi(2) * self.strings.iter().map(|s| s.bank().phasor_energy_j()).sum::<f64>()
    }

    /// Its strings' first mode made not a number: what a blow-up would leave
    /// (for checks of the output's guard).
    #[cfg(test)]
    pub fn poison(&mut self) {
        self.settle();
        for s in &mut self.strings {
            s.bank_mut().set_phasor(0, Complex64::new(f64::NAN, 0.0));
        }
    }

    /// Whether it is sounding: struck, and neither silent yet nor faded out.
    pub fn is_sounding(&self) -> bool {
        self.active
    }

    /// Its output gain, full scale per newton of its strings' force on the
    /// bridge (the bridge-force output's level scale).
    pub fn output_gain_per_n(&self) -> f64 {
        self.gain_per_n
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
        self.regulation.table = table;
    }

    /// Its regulation: the gain of a strike by its touch (empty: 1).
    pub fn regulation(&self) -> &[(f64, f64)] {
        &self.regulation.table
    }

    /// Bear on the body's zones as `share` says, `voicing` times louder there
    /// than at its bridge-force gain.
    pub fn bear_on(&mut self, share: ZoneShare, voicing: f64) {
        self.body_gain = voicing;
        let weights = share.weights.map(|w| w * voicing);
        self.bridge_point = self.bridge_point.on_zones(ZoneShare { weights, ..share });
    }

    /// What its voicing through the body left it with ([`KeyVoicing`]).
    pub fn voicing(&self) -> KeyVoicing {
        KeyVoicing {
            midi_key: self.midi_key(),
            body_gain: self.body_gain,
            regulation: self.regulation.table.clone(),
            gain: self.regulation.gain,
            gain_to: self.regulation.gain_to,
            strokes: self.strike.strokes,
        }
    }

    /// Take `voicing`, found for the same key voicing it through the body (at
    /// the voicing's own sample rate, or in an earlier build), bearing on the
    /// body as `share` says: as if it had been voiced here.
    pub fn voice_as(&mut self, voicing: &KeyVoicing, share: ZoneShare) {
        self.regulation.table = voicing.regulation.clone();
        self.regulation.gain = voicing.gain;
        self.regulation.gain_to = voicing.gain_to;
        self.strike.strokes = voicing.strokes;
        self.bear_on(share, voicing.body_gain);
    }

    /// What a newton of its strings' force on the bridge is heard at: its
    /// output gain, its voicing on the body and the last strike's regulation.
    /// A key's strings are heard at their own gain; energy that moves between
    /// keys through the bridge is weighed by the ratio of theirs, so that what
    /// one string hands another is heard as loud as it was (see
    /// `synth::sympathy`).
    pub fn heard_per_n(&self) -> f64 {
        self.gain_per_n * self.body_gain * self.regulation.gain
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
        &self.unison.steps
    }

    /// Its partials as the other strings on the body meet them.
    pub fn ports(&self) -> &[Port] {
        &self.ports
    }

    /// Whether its strings would ring if moved, silent as it is: its damper
    /// off with the sustain pedal at `sustain` (or none at all).
    pub fn rings_free(&self, performance: &PerformanceState) -> bool {
        self.damper.target(self.down() || self.sostenuto, performance.sustain) < 1.0
    }

    /// Whether it is fading out (stolen, reset, or its instrument replaced).
    pub fn is_fading_out(&self) -> bool {
        self.fade.step < 0.0
    }

    /// Upper bound on its output at the last control tick (full scale = 1).
    pub fn level(&self) -> f64 {
        self.cull.level
    }

    /// Fade it out over `seconds`, then silence it (at the next control tick).
    pub fn fade_out(&mut self, seconds: f64, sample_rate_hz: f64) {
        self.fade.step = -1.0 / (seconds * sample_rate_hz);
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
        self.finger.pressure = pressure.clamp(0.0, 1.0);
    }

    /// How loud the action's sounds are against the physics.
    pub fn set_noise(&mut self, noise: ActionNoise) {
        self.action.noise = noise;
    }

    /// How loud its phantom partials are against the physics (0: none).
    pub fn set_phantom(&mut self, level: f64) {
        self.phantom.set_level(level);
    }

    /// Its own pitch offset as a ratio, on top of the bend (an MPE note's
    /// channel bend, a CLAP tuning expression); heard from the next control tick.
    pub fn set_tune(&mut self, ratio: f64) {
        if ratio.is_finite() && ratio > 0.0 {
            self.trim.tune = ratio;
        }
    }

    /// Its own output gain (1 as built), reached in even steps over a control
    /// block's samples (however the blocks are cut).
    pub fn set_volume(&mut self, gain: f64) {
        if gain.is_finite() && gain >= 0.0 {
            self.trim.volume_to = gain.min(16.0);
            self.trim.volume_step = (self.trim.volume_to - self.trim.volume) / CONTROL_BLOCK as f64;
        }
    }

    /// Its own place in the stereo image, -1 (left) ..= 1 (right), 0 where the
    /// instrument puts it; reached over a control block.
    pub fn set_pan(&mut self, pan: f64) {
        if self.is_sounding() {
            self.trim.pan.set(pan, self.bridge_point)
        } else {
            self.trim.pan.set_now(pan, self.bridge_point)
        }
    }

    /// Whether it has a place of its own in the stereo image (or is moving to one).
    pub fn is_placed(&self) -> bool {
        self.trim.pan.is_placed()
    }

    /// Give its strings a MIDI key's own note shaping: tuning, volume,
    /// place and hammer.
    pub fn shape(&mut self, own: OwnNote) {
        self.set_tune(own.tune);
        self.set_volume(own.volume);
        self.set_pan(own.pan);
        self.set_hammer(own.hammer.0, own.hammer.1);
    }

    /// Its own hammer (or mallets) over the voicing, for its next strikes:
    /// felt stiffness and strike position as factors, 1 as voiced (held to
    /// 1/16 to 16 times). Allocates: no (a strike at a new point rebuilds the
    /// string's hammer tables in place).
    pub fn set_hammer(&mut self, hardness: f64, position: f64) {
        self.voicing.hardness = if hardness > 0.0 { hardness.clamp(1.0 / 16.0, 16.0) } else { 1.0 };
        self.voicing.position = if position > 0.0 { position.clamp(1.0 / 16.0, 16.0) } else { 1.0 };
    }

    /// The player's voicing over the one the key was built with: the
    /// strings' losses from now on (a ringing key's poles are worked out
    /// again: one exp and one sin/cos per mode), the hammer's at its next
    /// strike. Allocates: no.
    pub fn set_live_voicing(&mut self, live: LiveVoicing) {
        if live == self.voicing.live {
            return;
        }
        let repole = live.damping != self.voicing.live.damping;
        self.voicing.live = live;
        for s in &mut self.strings {
            s.set_loss_scale(live.damping);
        }
        if repole && self.is_sounding() {
            self.set_poles(self.pitch_set);
        }
    }

    /// How far full pressure raises a held tangent's pitch, cents (Bebung).
    pub fn set_bebung(&mut self, cents: f64) {
        if cents != self.finger.bebung_cents {
            self.finger.bebung_cents = cents;
            // The tension's factor over the rest press's (the pitch's, squared).
            self.finger.bebung =
                if cents.is_finite() { 2f64.powf(cents.clamp(0.0, MAX_BEBUNG_CENTS) / 600.0) } else { 1.0 };
        }
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

    /// Take over a ringing key of the same instrument whose tables were rebuilt.
    pub fn take_over(&mut self, old: &mut Key, performance: &PerformanceState) {
        self.settle();
        old.settle();
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
        self.finger.pressure = old.finger.pressure;
        self.finger.pressure_now = old.finger.pressure_now;
        (self.finger.bebung_cents, self.finger.bebung) = (old.finger.bebung_cents, old.finger.bebung);
        (self.voicing.hardness, self.voicing.position) = (old.voicing.hardness, old.voicing.position);
        self.trim.pan = old.trim.pan;
        self.trim.tune = old.trim.tune;
        (self.trim.volume, self.trim.volume_to, self.trim.volume_step) =
            (old.trim.volume, old.trim.volume_to, old.trim.volume_step);
        if self.course.force_n.len() == old.course.force_n.len() {
            self.course.force_n.copy_from_slice(&old.course.force_n);
        }
        self.damper.take_over(&old.damper);
        self.fade.gain = old.fade.gain;
        self.fade.step = old.fade.step;
        self.cull.level = old.cull.level;
        let pitch = self.pitch(performance.bend);
        self.set_poles(pitch);
        old.silence();
    }
}

/// What voicing a key through the body leaves it with: its gain onto the body
/// (times its bridge-force gain), its regulation (gain by touch), the gain its
/// last strike was heard at and glided to, and the strokes struck (a
/// hand-held mallet's turn across the strings follows them). Nothing in it
/// depends on the sample rate.
#[derive(Clone, Debug, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct KeyVoicing {
    pub midi_key: u8,
    pub body_gain: f64,
    pub regulation: Vec<(f64, f64)>,
    pub gain: f64,
    pub gain_to: f64,
    pub strokes: u32,
}
