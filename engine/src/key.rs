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
use crate::phantom::{Phantom, PhantomTable};
use crate::string::{StringError, StringModes};
use crate::struck_string::substeps::SubstepPlan;
use crate::struck_string::{DEFAULT_SUBSTEPS, StruckString};

use crate::CONTROL_BLOCK;

/// Time constant of a tangent leaving its strings as the key comes up at
/// release `velocity` (0..=1; 0: not known, as a middling release), s: as
/// fast as the strings push it back (`return_s`) from velocity 0.5 up, more
/// slowly below as a finger lets the key up (the damper's landing law,
/// [`crate::damper::release_slowness`]). It once left them in 2 ms whatever the release, faster than
/// they can throw it: the bridge's static load came off as a step, which rang
/// the body's lowest modes louder than the dying note (a boom on every
/// release, -26 dBFS after a C4 at -39).
fn tangent_lift_s(return_s: f64, velocity: f64) -> f64 {
    return_s * crate::damper::release_slowness(velocity).max(1.0)
}
/// A hammer that has left the strings this far, moving away, this long after
/// the strike, will not come back: the strings go free (the fast path). Chosen
/// above a mallet's repeated bounces (a few ms) and a string's swing (below 0.5 mm).
const HAMMER_GONE_GAP_M: f64 = 0.5e-3;
const HAMMER_GONE_AFTER_S: f64 = 0.03;
/// Una corda: the hammer meets the strings with its less worn, softer felt. The
/// factor on K is our assumption (the physics reference has no measurement of it).
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

/// The phantom products fade in over this long when they start, s. They wait
/// for a strike to end (while the hammer plays the strings their loudest is
/// not known), so they start at the level the strings' motion gives them
/// then: at once, a step in the bridge force (A0 at velocity 127: 0.02 of
/// full scale in one sample, 35 ms in).
const PHANTOM_FADE_S: f64 = 0.005;

/// The phantom products are set again from the strings at least this often,
/// control blocks (to drop those that have faded under the floor).
const PHANTOM_REFRESH_BLOCKS: usize = 16;

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

/// A partial of a group of a key's strings tuned alike, as the other strings
/// on the body meet it: its strings, its frequency and pole, and how the
/// board moves it ([`BoardLoad::reach`], its own loss into the board).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Port {
    /// The strings (bit i: string i) that sound it together.
    pub strings: u8,
    pub partial: usize,
    pub f_hz: f64,
    /// Its pole, s^-1 (decay and angular frequency).
    pub lambda: Complex64,
    /// c_n: its phasor moves by -c_n Y F per second for a bridge point moving at Y F, s^-1 / (s/kg).
    pub reach: f64,
    /// What it loses into the board by itself, s^-1 (Re eps_n).
    pub loss_s: f64,
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

pub(crate) struct Key {
    /// The MIDI key the course is listed under (its first note).
    midi_key: u8,
    strings: Vec<StruckString>,
    notes: Vec<Note>,
    /// How much of a hammer each string meets, over an even share (empty:
    /// even), and whether they are held in the player's hand (they meet the
    /// strings differently at each stroke: the shares turn by a string), with
    /// the strokes so far.
    strike_shares: Vec<f64>,
    hand_held: bool,
    strokes: u32,
    damper: Damper,
    /// How [`TRADE_BLOCKS`] control blocks of the unison's trading through the
    /// body move each partial: the share that differs from the strings' mean by
    /// alpha, the mean by beta (empty: strings not coupled so).
    unison: Vec<(Complex64, Complex64)>,
    /// Control blocks since the unison last traded.
    blocks_since_trade: usize,
    /// Moved by the other strings since the last control block (it does not
    /// fall silent while they move it, however faintly).
    driven: usize,
    /// Its strings' stretch pulling on the bridge at sums of their partials
    /// (none above [`LAST_PHANTOM_KEY`] or off the body), whether any product
    /// is over the cull floor this block, and at what level.
    phantom: Option<Phantom>,
    phantom_on: bool,
    /// The products must be set again from the strings (their motion changed
    /// other than freely), and blocks since they were.
    phantom_stale: bool,
    phantom_age: usize,
    phantom_level: f64,
    /// The level the products in play were set at.
    phantom_set: f64,
    /// The products fading in since they started (run apart from the
    /// gathering meanwhile), samples of the fade done, and its length.
    phantom_fading: bool,
    phantom_faded: usize,
    phantom_fade_len: usize,
    /// The action's sounds: whether the key stops on a bed (a keyboard's
    /// hammer key), the bed's pulse in play (samples since the key bottomed,
    /// hammer speed), and their levels (key bed, damper landing, dampers
    /// lifting; 1 = the physics).
    key_bed: bool,
    /// Its strings bear on the body (not the seed's rigid bridge).
    on_body: bool,
    bed_pulse: Option<(usize, f64)>,
    /// The key bed's pulse at its sample rate.
    bed: action::KeyBedPulse,
    noise: ActionNoise,
    /// Its partials as the other strings on the body meet them (empty: strings
    /// on the seed's rigid bridge, or a tangent's, which the listing damps).
    ports: Vec<Port>,
    /// Re Y of the shared bridge point (0: strings not coupled), the share of
    /// it the strings trade at sample by sample ([`COURSE_LOOP_LIMIT`]), and
    /// the force each string put on it last sample.
    bridge_coupling_s_kg: f64,
    bridge_share: f64,
    bridge_force_n: Vec<f64>,
    /// Scratch for this sample's forces.
    force_now_n: Vec<f64>,
    /// The free strings' bridge force by lane, for a control block.
    lanes: Box<[[f64; LANES]; CONTROL_BLOCK]>,
    /// The free strings' modes and the phantom products, advanced together
    /// ([`FreeGather`]), and where each string's lie in it.
    gather: FreeGather,
    gathered: Vec<Option<usize>>,
    /// Whether the gathering holds its free strings' (and products') state
    /// now: it is taken once and run on over a control block's stretches,
    /// and handed back ([`Key::settle`]) before anything else reads or moves
    /// them. Which strings ran free, and where the products lie.
    gather_live: bool,
    free_now: Vec<bool>,
    phantom_at: Option<usize>,
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
    /// Its regulation: the gain of a strike by its touch (empty: 1), and the
    /// gain now and where it glides to (the last strike's).
    regulation: Vec<(f64, f64)>,
    strike_gain: f64,
    strike_gain_to: f64,
    /// Per-sample step of the strike gain's glide ([`STRIKE_GAIN_GLIDE_S`]).
    strike_glide: f64,
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
    /// Its own pitch offset as a ratio ([`Self::set_tune`]).
    tune: f64,
    /// Its own output gain, the gain it glides to and its step a sample
    /// ([`Self::set_volume`]).
    volume: f64,
    volume_to: f64,
    volume_step: f64,
    /// Its own place in the stereo image ([`Self::set_pan`]).
    pan: KeyPan,
    /// Its own hammer over the voicing: felt stiffness and strike position
    /// factors ([`Self::set_hammer`]).
    hammer_hardness: f64,
    hammer_position: f64,
    /// The player's voicing over the one the key was built with, taken while
    /// it plays ([`Self::set_live_voicing`]).
    live: LiveVoicing,
    /// How far full pressure raises a tangent's pitch, cents, and the
    /// tension's factor that makes it (the pitch's squared).
    bebung_cents: f64,
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
    /// Control ticks until its strings are culled again (0: at the next), and
    /// what the last culling found (their bound and loudest mode, N).
    cull_in: u8,
    last_cull: (f64, f64),
}

impl Key {
    /// Build every table the key will need on a `kind`, for touches up to its
    /// touch range's top, its strings loaded by `board` (None: by the design's
    /// resistive bridge).
    /// Allocates; off the audio thread.
    pub fn build(
        design: KeyDesign,
        sample_rate_hz: f64,
        kind: InstrumentKind,
        board: Option<&BoardLoad>,
    ) -> Result<Self, StringError> {
        let (touch, hand_mallets) = (kind.touch_range(), kind.hand_mallets());
        let mut notes = vec![Note {
            midi_key: design.midi_key,
            struck: design.struck.clone(),
            exciter: design.exciter,
            pitch_ratio: 1.0,
            substeps: None,
            hysteresis: design.hammer_hysteresis,
        }];
        notes.extend(design.shared.iter().map(|s| Note {
            midi_key: s.midi_key,
            struck: s.struck.clone(),
            exciter: s.exciter,
            pitch_ratio: s.pitch_ratio,
            substeps: None,
            hysteresis: design.hammer_hysteresis,
        }));
        notes.truncate(MAX_NOTES);
        let mut modes = design.strings.iter().map(|spec| spec.build()).collect::<Result<Vec<_>, _>>()?;
        // A course's strings trade energy through the board where they bear
        // together (a dulcimer's courses already move their bridge point).
        // A tangent holds its strings where it stops them, and moves them
        // itself: they do not trade freely.
        let coupled = board.is_some()
            && (2..=MAX_UNISON).contains(&modes.len())
            && design.bridge_coupling_s_kg <= 0.0
            && !matches!(design.exciter, ExciterDesign::Tangent { .. });
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
                let alone: Vec<f64> = string.modes.iter().map(|m| m.decay_rate_s()).collect();
                board.load(design.midi_key, design.resistive_bridge, n, string);
                if design.bridge_coupling_s_kg > 0.0 {
                    // Strings moving each other through a bridge point of
                    // resistance Re Y (sample by sample, `render_coupled`)
                    // lose at least what that resistance takes from each
                    // alone: where the board under it takes less (between
                    // its resonances) the others' pull would outweigh the
                    // string's own loss, and a course strung tight enough
                    // for its bridge losses to outweigh the wire's would
                    // grow (a dulcimer tuned an octave a key did).
                    for (mode, &rate_s) in string.modes.iter_mut().zip(&alone) {
                        if mode.decay_rate_s() < rate_s {
                            mode.q = mode.omega_rad_s / (2.0 * rate_s);
                        }
                    }
                }
            }
        }
        let phantom = match (board, design.exciter, modes.get(design.struck.start)) {
            (Some(_), ExciterDesign::Hammer { .. }, Some(lead)) if design.midi_key <= LAST_PHANTOM_KEY => {
                Some(PhantomTable::new(lead, 0.5 * sample_rate_hz)).filter(|t| !t.is_empty()).map(Phantom::new)
            }
            _ => None,
        };
        // The action sounds through the body (the bridge-force output is the
        // seed's strings alone). A hand-held mallet has no key; a tangent is
        // the key's stop.
        let on_body = board.is_some();
        let key_bed = on_body && matches!(design.exciter, ExciterDesign::Hammer { .. }) && !hand_mallets;
        let ports = match (board, design.exciter) {
            (Some(board), ExciterDesign::Hammer { .. } | ExciterDesign::Pluck { .. }) => {
                ports(board, design.midi_key, design.resistive_bridge, &modes)
            }
            _ => Vec::new(),
        };
        // Each hammer's strikes measured on the last string it reaches, with its
        // share of the hammer (as `press` splits it; an uneven hammer's
        // narrowest and widest shares, the worse of the two at each speed).
        let shares = &design.strike_shares;
        for note in &mut notes {
            if let (ExciterDesign::Hammer { mass_kg, law, position }, Some(last), Some(top_speed_m_s)) =
                (note.exciter, note.struck.clone().last(), touch.top_speed_m_s())
            {
                let plan = |share: f64| {
                    let law = ContactLaw { stiffness: law.stiffness * share, ..law };
                    let hammer = HammerSpec::one_of(note.struck.len(), mass_kg * share, law, top_speed_m_s, position)
                        .with_hysteresis(note.hysteresis);
                    SubstepPlan::measure(&modes[last], sample_rate_hz, hammer)
                };
                let met: Vec<f64> = note.struck.clone().filter_map(|i| shares.get(i).copied()).collect();
                let (narrowest, widest) = met.iter().fold((1.0f64, 1.0f64), |(n, w), &s| (n.min(s), w.max(s)));
                note.substeps = Some(if met.is_empty() { plan(1.0) } else { plan(widest).worse_of(plan(narrowest)) });
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
        let room = strings.iter().map(|s| s.bank().len().next_multiple_of(LANES)).sum::<usize>()
            + phantom.as_ref().map_or(0, Phantom::room);
        Ok(Self {
            midi_key: design.midi_key,
            gather: FreeGather::with_room(room),
            gathered: vec![None; strings.len()],
            gather_live: false,
            free_now: vec![false; strings.len()],
            phantom_at: None,
            strings,
            notes,
            strike_shares: design.strike_shares.clone(),
            hand_held: hand_mallets,
            strokes: 0,
            damper: Damper::new(design.damper),
            unison,
            blocks_since_trade: 0,
            driven: 0,
            phantom,
            phantom_on: false,
            phantom_stale: true,
            phantom_age: 0,
            phantom_level: 1.0,
            phantom_set: 1.0,
            phantom_fading: false,
            phantom_faded: 0,
            phantom_fade_len: 1,
            key_bed,
            on_body,
            bed_pulse: None,
            bed: action::KeyBedPulse::new(sample_rate_hz),
            noise: ActionNoise::default(),
            ports,
            bridge_coupling_s_kg: design.bridge_coupling_s_kg.max(0.0),
            bridge_share: 1.0,
            bridge_force_n: vec![0.0; design.strings.len()],
            force_now_n: vec![0.0; design.strings.len()],
            lanes: Box::new([[0.0; LANES]; CONTROL_BLOCK]),
            gain_per_n: design.gain_per_n,
            bridge_point: BridgePoint::panned(design.pan),
            body_gain: 1.0,
            body_boost: if design.gain_per_n > 0.0 {
                (design.ring_gain_per_n / design.gain_per_n).max(1.0)
            } else {
                1.0
            },
            regulation: Vec::new(),
            strike_gain: 1.0,
            strike_gain_to: 1.0,
            strike_glide: 1.0 - (-1.0 / (STRIKE_GAIN_GLIDE_S * sample_rate_hz)).exp(),
            active: false,
            held: 0,
            sounded: 0,
            sostenuto: false,
            speaking: 0,
            pressure: 0.0,
            pressure_now: 0.0,
            tune: 1.0,
            volume: 1.0,
            volume_to: 1.0,
            volume_step: 0.0,
            pan: KeyPan::default(),
            hammer_hardness: 1.0,
            hammer_position: 1.0,
            live: LiveVoicing::default(),
            bebung_cents: 0.0,
            bebung: 1.0,
            pitch_set: 1.0,
            fade: 1.0,
            fade_step: 0.0,
            level: 0.0,
            loudest_n: 0.0,
            cull_in: 0,
            last_cull: (0.0, 0.0),
        })
    }

    /// The MIDI key the course is listed under (its first note).
    pub fn midi_key(&self) -> u8 {
        self.midi_key
    }

    /// Hand its strings' (and products') state back from the gathering they
    /// run in (see [`Self::render`]): each control block, and before anything
    /// else reads or moves them. Allocates: no.
    pub fn settle(&mut self) {
        if !self.gather_live {
            return;
        }
        self.gather_live = false;
        for (s, at) in self.strings.iter_mut().zip(&self.gathered) {
            if let Some(at) = *at
                && at != usize::MAX
            {
                s.scatter_free(&self.gather, at);
            }
        }
        if let (Some(at), Some(p)) = (self.phantom_at, self.phantom.as_mut())
            && at != usize::MAX
        {
            p.scatter_free(&self.gather, at);
        }
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

    /// How much louder the body should hear it than the bridge-force output
    /// does, before the body's own colour is taken out (its ringing gain over
    /// the gain the bridge force's peak allows).
    /// Its output gain, full scale per newton of its strings' force on the
    /// bridge (the bridge-force output's level scale).
    pub fn output_gain_per_n(&self) -> f64 {
        self.gain_per_n
    }

    pub fn body_boost(&self) -> f64 {
        self.body_boost
    }

    /// Regulate it: a strike at touch t (in the touch's unit) is heard at the
    /// gain `table` gives there (see `synth::body_voicing`).
    pub fn regulate(&mut self, table: Vec<(f64, f64)>) {
        self.regulation = table;
    }

    /// Its regulation: the gain of a strike by its touch (empty: 1).
    pub fn regulation(&self) -> &[(f64, f64)] {
        &self.regulation
    }

    /// Bear on the body's zones as `share` says, `voicing` times louder there
    /// than at its bridge-force gain.
    pub fn bear_on(&mut self, share: ZoneShare, voicing: f64) {
        self.body_gain = voicing;
        let weights = share.weights.map(|w| w * voicing);
        self.bridge_point = self.bridge_point.on_zones(ZoneShare { weights, ..share });
    }

    /// What a newton of its strings' force on the bridge is heard at: its
    /// output gain, its voicing on the body and the last strike's regulation.
    /// A key's strings are heard at their own gain; energy that moves between
    /// keys through the bridge is weighed by the ratio of theirs, so that what
    /// one string hands another is heard as loud as it was (see
    /// `synth::sympathy`).
    pub fn heard_per_n(&self) -> f64 {
        self.gain_per_n * self.body_gain * self.strike_gain
    }

    /// Play its first note at `touch` alone for `force.len()` samples, writing
    /// the force it hands the bridge (at its output gain), and return what its
    /// strings then ring with, string by string and mode by mode: the force
    /// Re(z e^(lambda t)) at output gain, as (z, lambda). The key is left silent. Allocates; for
    /// voicing the key through the body when the instrument is built.
    pub fn probe(&mut self, touch: Touch, force: &mut [f64]) -> Vec<Vec<(Complex64, Complex64)>> {
        self.settle();
        self.press(0, touch, 0.0, 1.0, 1.0);
        for (b, chunk) in force.chunks_mut(CONTROL_BLOCK).enumerate() {
            chunk.fill(0.0);
            self.render(chunk, None);
            if chunk.len() == CONTROL_BLOCK && (b + 1) % TRADE_BLOCKS == 0 {
                self.trade_through_bridge(0.0);
            }
        }
        force.iter_mut().for_each(|f| *f *= self.gain_per_n);
        self.settle();
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

    /// Its partials as the other strings on the body meet them.
    pub fn ports(&self) -> &[Port] {
        &self.ports
    }

    /// Whether its strings would ring if moved, silent as it is: its damper
    /// off with the sustain pedal at `sustain` (or none at all).
    pub fn rings_free(&self, sustain: f64) -> bool {
        self.damper.target(self.down() || self.sostenuto, sustain) < 1.0
    }

    /// For each of `ports` (strings, partial), the summed phasor of
    /// `partial` over `strings` (bit i: string i), N, into the same place of
    /// `out` (read from the gathering while its strings run there), taken
    /// string by string. `first` says that the ports are partials 0, 1, 2 ...
    /// of the same strings, as a key's are unless its strings sound apart:
    /// each string's modes are then read as one run (the same sums).
    #[inline]
    pub(crate) fn partial_sums(&self, ports: &[(u8, u16)], first: bool, out: &mut [Complex64]) {
        out.fill(Complex64::new(0.0, 0.0));
        if first && let Some(&(strings, _)) = ports.first() {
            for (i, s) in self.strings.iter().enumerate().filter(|&(i, _)| strings & (1 << i) != 0) {
                let sums = &mut out[..s.bank().running().min(ports.len())];
                match self.gathered_at(i) {
                    Some(at) => self.gather.add_phasors(at, s.audio().backs(), sums),
                    None => s.bank().add_phasors(sums),
                }
            }
            return;
        }
        for (i, s) in self.strings.iter().enumerate() {
            let (bit, running) = (1u8 << i, s.bank().running());
            let at = self.gathered_at(i);
            for (sum, &(strings, partial)) in out.iter_mut().zip(ports) {
                let partial = partial as usize;
                if strings & bit != 0 && partial < running {
                    *sum += match at {
                        Some(at) => {
                            let (back_re, _, back_inv) = s.audio().back(partial);
                            self.gather.phasor(at + partial, back_re, back_inv)
                        }
                        None => s.bank().phasor(partial),
                    };
                }
            }
        }
    }

    /// Where string `i`'s modes lie in the gathering while they run there.
    #[inline]
    fn gathered_at(&self, i: usize) -> Option<usize> {
        match self.gathered.get(i) {
            Some(&Some(at)) if self.gather_live && at != usize::MAX => Some(at),
            _ => None,
        }
    }

    /// The bridge's motion moves partial `partial` of each of `strings` by
    /// `delta` (N): a silent key whose damper would lie on its strings with
    /// the pedal at `sustain` takes nothing, nor one that would be silent at
    /// once (a drive under [`WAKE_OVER_SILENCE`] times `silence` of full
    /// scale); one that takes it starts to sound, its damper where the pedal has it and
    /// its pitch bent by `bend`, and stays sounding while it is driven that hard.
    /// Returns whether it took it. Allocates: no.
    pub fn drive_partial(
        &mut self,
        strings: u8,
        partial: usize,
        delta: Complex64,
        sustain: f64,
        bend: f64,
        silence: f64,
    ) -> bool {
        // A partial running in the gathering is moved there; one it does not
        // hold (culled, or past a string's running modes) needs them back.
        let held = |i: usize, s: &StruckString| {
            strings & (1 << i) == 0 || partial >= s.bank().len() || partial < s.bank().running()
        };
        if self.gather_live && !self.strings.iter().enumerate().all(|(i, s)| held(i, s)) {
            self.settle();
        }
        let floor_n = CULL_FLOOR * silence / self.gain_per_n.max(1e-300);
        let felt = self.would_wake(delta, silence);
        if !self.active {
            if self.damper.target(false, sustain) >= 1.0 || !felt {
                return false;
            }
            self.wake(sustain, bend);
        }
        // (The phantom products follow at their next refresh: a trade moves
        // a partial by a little.) Only a drive that would wake it keeps it
        // sounding: a damped key the undamped treble moves faintly, and keys
        // that faintly move each other, still fall silent.
        if felt {
            self.driven = DRIVEN_BLOCKS;
        }
        // The last culling's bound still bounds the strings once it holds
        // the drive too (no rescan needed).
        self.last_cull.0 += (delta.re.abs() + delta.im.abs()) * f64::from(strings.count_ones());
        for i in 0..self.strings.len() {
            if strings & (1 << i) == 0 || partial >= self.strings[i].bank().len() {
                continue;
            }
            if let Some(at) = self.gathered_at(i) {
                let (back_re, back_im, _) = self.strings[i].audio().back(partial);
                self.gather.nudge(at + partial, delta, back_re, back_im);
                continue;
            }
            let s = &mut self.strings[i];
            let z = if partial < s.bank().running() { s.bank().phasor(partial) + delta } else { delta };
            if partial < s.bank().running() || z.re.abs() + z.im.abs() >= floor_n {
                s.bank_mut().set_phasor(partial, z);
            }
        }
        true
    }

    /// Whether moving a partial of its strings by `delta` (N) would wake it
    /// silent (more than [`WAKE_OVER_SILENCE`] times `silence`, full scale).
    pub fn would_wake(&self, delta: Complex64, silence: f64) -> bool {
        wakes(delta * self.gain_per_n, silence)
    }

    /// Start sounding from rest without a stroke (its strings set ringing by
    /// the others): the damper where the pedal has it, the poles set for it.
    fn wake(&mut self, sustain: f64, bend: f64) {
        self.active = true;
        self.cull_in = 0;
        self.fade = 1.0;
        self.fade_step = 0.0;
        self.loudest_n = 0.0;
        self.damper.settle(self.down() || self.sostenuto, sustain);
        let pitch = self.pitch(bend);
        self.set_poles(pitch);
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

    /// How loud the action's sounds are against the physics.
    pub fn set_noise(&mut self, noise: ActionNoise) {
        self.noise = noise;
    }

    /// How loud its phantom partials are against the physics (0: none).
    pub fn set_phantom(&mut self, level: f64) {
        self.phantom_level = level;
    }

    /// Its own pitch offset as a ratio, on top of the bend (an MPE note's
    /// channel bend, a CLAP tuning expression); heard from the next control tick.
    pub fn set_tune(&mut self, ratio: f64) {
        if ratio.is_finite() && ratio > 0.0 {
            self.tune = ratio;
        }
    }

    /// Its own output gain (1 as built), reached in even steps over a control
    /// block's samples (however the blocks are cut).
    pub fn set_volume(&mut self, gain: f64) {
        if gain.is_finite() && gain >= 0.0 {
            self.volume_to = gain.min(16.0);
            self.volume_step = (self.volume_to - self.volume) / CONTROL_BLOCK as f64;
        }
    }

    /// Its own place in the stereo image, -1 (left) ..= 1 (right), 0 where the
    /// instrument puts it; reached over a control block.
    pub fn set_pan(&mut self, pan: f64) {
        if self.is_sounding() { self.pan.set(pan, self.bridge_point) } else { self.pan.set_now(pan, self.bridge_point) }
    }

    /// Whether it has a place of its own in the stereo image (or is moving to one).
    pub fn is_placed(&self) -> bool {
        self.pan.is_placed()
    }

    /// Its own hammer (or mallets) over the voicing, for its next strikes:
    /// felt stiffness and strike position as factors, 1 as voiced (held to
    /// 1/16 to 16 times). Allocates: no (a strike at a new point rebuilds the
    /// string's hammer tables in place).
    pub fn set_hammer(&mut self, hardness: f64, position: f64) {
        self.hammer_hardness = if hardness > 0.0 { hardness.clamp(1.0 / 16.0, 16.0) } else { 1.0 };
        self.hammer_position = if position > 0.0 { position.clamp(1.0 / 16.0, 16.0) } else { 1.0 };
    }

    /// The player's voicing over the one the key was built with: the
    /// strings' losses from now on (a ringing key's poles are worked out
    /// again: one exp and one sin/cos per mode), the hammer's at its next
    /// strike. Allocates: no.
    pub fn set_live_voicing(&mut self, live: LiveVoicing) {
        if live == self.live {
            return;
        }
        let repole = live.damping != self.live.damping;
        self.live = live;
        for s in &mut self.strings {
            s.set_loss_scale(live.damping);
        }
        if repole && self.is_sounding() {
            self.set_poles(self.pitch_set);
        }
    }

    /// How far full pressure raises a held tangent's pitch, cents (Bebung).
    pub fn set_bebung(&mut self, cents: f64) {
        if cents != self.bebung_cents {
            self.bebung_cents = cents;
            // The tension's factor over the rest press's (the pitch's, squared).
            self.bebung = if cents.is_finite() { 2f64.powf(cents.clamp(0.0, MAX_BEBUNG_CENTS) / 600.0) } else { 1.0 };
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

    /// Note `note` goes down with `touch` (a speed for hammers, mallets and
    /// tangents, a lift for a plectrum), with the mallet's hardness `hardness`
    /// times as built. A touch in the other unit than the note's exciter is
    /// ignored. Allocates: no.
    pub fn press(&mut self, note: usize, touch: Touch, una_corda: f64, hardness: f64, bend: f64) {
        self.settle();
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
        // The unison's next trade comes a whole interval after the strike (the
        // trade takes its strings' motion as free over the interval).
        self.blocks_since_trade = 0;
        let pitch = self.pitch(bend);
        self.set_poles(pitch);
        // Where its own strike point puts the hammer (or plectrum) built at `position`.
        let factor = self.hammer_position * self.live.strike_position;
        let own_point = |position: f64| {
            if factor == 1.0 { position } else { (position * factor).clamp(MIN_STRIKE_POINT, MAX_STRIKE_POINT) }
        };
        let played = &self.notes[note];
        let strings = &mut self.strings[played.struck.clone()];
        match played.exciter {
            ExciterDesign::Hammer { mass_kg, law, position } => {
                let (mass_kg, law) = (mass_kg * self.live.hammer_mass, self.live.felt(law));
                let hysteresis = self.live.hysteresis(played.hysteresis);
                if self.key_bed {
                    self.bed_pulse = Some((0, touch));
                }
                // Una corda shifts the action sideways by `una_corda` of the
                // way: the hammer meets the first string of a unison with that
                // much less of its width (missing it at full shift), and the
                // rest with its less worn, softer felt. Each string takes the
                // hammer's mass and felt in proportion to the width it meets,
                // which an uneven hammer makes more on some strings than on
                // others.
                let shift = if strings.len() >= 2 { una_corda.clamp(0.0, 1.0) } else { 0.0 };
                let (hardness, position) = (hardness * self.hammer_hardness, own_point(position));
                let soft = 1.0 - una_corda.clamp(0.0, 1.0) * (1.0 - UNA_CORDA_STIFFNESS);
                let shares = self.strike_shares.get(played.struck.clone()).unwrap_or(&[]);
                let turn = if self.hand_held { self.strokes as usize } else { 0 };
                self.strokes = self.strokes.wrapping_add(1);
                let share = |i: usize| match shares.len() {
                    0 => 1.0,
                    n => shares[(i + turn) % n],
                };
                // (A level hammer's width as it always was, to the bit.)
                let width = if shares.is_empty() {
                    strings.len() as f64 - shift
                } else {
                    (0..strings.len()).map(|i| share(i) * if i == 0 { 1.0 - shift } else { 1.0 }).sum()
                };
                let substeps = played.substeps.as_ref().map_or(DEFAULT_SUBSTEPS, |plan| plan.substeps(touch));
                for (i, s) in strings.iter_mut().enumerate() {
                    let met = share(i) * if i == 0 { 1.0 - shift } else { 1.0 };
                    if met < MISSED {
                        continue;
                    }
                    let felt =
                        ContactLaw { stiffness: law.stiffness * hardness * soft * met / width, exponent: law.exponent };
                    let hammer = HammerSpec::one_of(1, mass_kg * met / width, felt, touch, position);
                    s.strike_substepped(hammer.with_hysteresis(hysteresis), substeps);
                }
            }
            ExciterDesign::Tangent { displacement_m, .. } => {
                for s in strings {
                    s.press_tangent(TangentSpec { speed_m_s: touch, displacement_m });
                }
            }
            ExciterDesign::Pluck { position } => {
                // The plectrum's own point, as the hammer's.
                let position = own_point(position);
                for s in strings {
                    s.pluck(PluckSpec { displacement_m: touch * 1e-3, position });
                    s.release_exciter();
                }
            }
        }
    }

    /// Note `note` comes up at release `velocity` (0..=1), the sustain pedal at `sustain`.
    pub fn release(&mut self, note: usize, velocity: f64, sustain: f64) {
        self.settle();
        let bit = 1u32 << note;
        if self.held & bit == 0 {
            return;
        }
        self.held &= !bit;
        if self.held == 0 {
            self.damper.land(velocity);
        }
        if self.held == 0 && !self.sostenuto && self.damper.target(false, sustain) >= 0.5 {
            self.land_damper(note, velocity);
        }
        let Some(ExciterDesign::Tangent { return_s, .. }) = self.notes.get(note).map(|n| n.exciter) else { return };
        if self.held == 0 {
            let struck = self.notes[note].struck.clone();
            let lift_s = tangent_lift_s(return_s, velocity);
            for s in &mut self.strings[struck] {
                s.lift_tangent(lift_s);
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

    /// Every note of the course comes up, the sustain pedal at `sustain`.
    pub fn release_all(&mut self, sustain: f64) {
        for note in 0..self.notes.len() {
            self.release(note, 0.5, sustain);
        }
    }

    /// The key's damper lands on its strings as `note` comes up at release
    /// `velocity` (0..=1): its momentum goes into them at the place its note
    /// strikes, through its soft felt ([`action`]); the damper then stops
    /// them. Nothing for a key without a damper, one the pedal holds off, or
    /// a damper only the pedal works.
    fn land_damper(&mut self, note: usize, velocity: f64) {
        let Some(position) = self.notes.get(note).and_then(|n| n.damper_position()) else { return };
        if self.noise.damper <= 0.0 || !self.active || !self.on_body || !self.damper.follows_key() {
            return;
        }
        self.phantom_stale = true;
        self.cull_in = 0;
        let impulse =
            self.damper.head_mass_kg() * action::DAMPER_LANDING_M_S * velocity.clamp(0.0, 1.0) * self.noise.damper;
        let share = -impulse / self.strings.len().max(1) as f64;
        for s in &mut self.strings {
            let (string, bank) = s.string_and_bank_mut();
            action::kick_modes(string, position, share, action::DAMPER_CONTACT_S, |i, dv| bank.nudge(i, 0.0, dv));
            // (A hammer still in play is watched again on the kicked modes.)
            s.watch_hammer();
        }
    }

    /// The sustain pedal lifts the damper off its strings, which spring back
    /// from the bend its weight held them in ([`action`]) and ring. Nothing
    /// for a key without a damper or one already lifted (held, or kept up by
    /// the sostenuto pedal); a silent key starts to sound, its damper where
    /// `sustain` has it and its pitch bent by `bend`. Allocates: no.
    pub fn lift_damper(&mut self, sustain: f64, bend: f64) {
        self.settle();
        if self.noise.pedal <= 0.0 || !self.on_body || !self.damper.exists() || self.down() || self.sostenuto {
            return;
        }
        if !self.active {
            self.wake(sustain, bend);
        }
        self.let_strings_go();
    }

    /// The damper, lifted, lets its strings go: they spring back from the bend
    /// its weight held them in.
    fn let_strings_go(&mut self) {
        self.cull_in = 0;
        self.phantom_stale = true;
        let Some(position) = self.notes.first().and_then(|n| n.damper_position()) else { return };
        let level = self.noise.pedal;
        for s in &mut self.strings {
            let (string, bank) = s.string_and_bank_mut();
            action::damper_release(string, position, LIFT_TOP_HZ, |i, dv| bank.nudge(i, 0.0, dv * level));
            s.watch_hammer();
        }
    }

    /// The strings' pitch over their own: the bend, the speaking note's interval
    /// and, under a tangent, the stretch of the press. A tangent holding the end at
    /// W raises the tension by the factor 1 + s W^2 and the pitch by its square
    /// root. The finger's pressure presses deeper (Bebung: the depth follows
    /// the finger), at full pressure to the depth W_f whose stretch raises the
    /// pitch by the Bebung's cents over the rest press D: 1 + s W_f^2 =
    /// (1 + s D^2) 2^(cents / 600).
    fn pitch(&self, bend: f64) -> f64 {
        let note = &self.notes[self.speaking];
        let stretch = match note.exciter {
            ExciterDesign::Tangent { stretch_per_m2, displacement_m, .. } => {
                let mut w = self.strings[note.struck.start].tangent_position_m();
                if self.pressure_now > 0.0 && stretch_per_m2 > 0.0 {
                    let s = stretch_per_m2;
                    let full = (((1.0 + s * displacement_m * displacement_m) * self.bebung - 1.0) / s).sqrt();
                    w += self.pressure_now * (full - displacement_m);
                }
                tangent::stretched_pitch_ratio(stretch_per_m2, w)
            }
            _ => 1.0,
        };
        bend * self.tune * note.pitch_ratio * stretch
    }

    /// Once per control block: move the damper, retune for a bend or a press, let
    /// go of hammers that have flown off, and notice silence. Returns true when the
    /// key has just fallen silent (it is then inactive and at rest).
    pub fn control(&mut self, block_s: f64, sustain: f64, bend: f64, silence: f64) -> bool {
        // The strings stay gathered over blocks that neither read nor move
        // them (handed back below where one does).
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
            self.settle();
            self.set_poles(pitch);
        }
        let floor_n = (CULL_BELOW_LOUDEST * self.loudest_n).max(CULL_FLOOR * silence / self.gain_per_n.max(1e-300));
        self.blocks_since_trade += 1;
        if self.blocks_since_trade >= TRADE_BLOCKS {
            self.blocks_since_trade = 0;
            self.trade_through_bridge(floor_n);
        }
        let mut settled = true;
        // A hammer in play is watched on its string's modes as they stand (the
        // scan below brings them back in that case anyway).
        if self.strings.iter().any(|s| !s.is_settled()) {
            self.settle();
        }
        for s in &mut self.strings {
            s.watch_hammer();
            if s.hammer_gone(HAMMER_GONE_GAP_M, HAMMER_GONE_AFTER_S) {
                s.release_exciter();
            }
            settled &= s.is_settled();
        }
        // Free strings only fade: between cullings the last one's bound still
        // bounds them (a drive adds to it; a trade among the strings culls
        // at once), and the scan is skipped.
        let scan = !settled || self.cull_in == 0;
        self.cull_in = if scan { CULL_EVERY_BLOCKS - 1 } else { self.cull_in - 1 };
        let (mut bound, mut loudest_n) = self.last_cull;
        if scan {
            (bound, loudest_n) = match self.cull_where_gathered(settled, floor_n) {
                Some(culled) => culled,
                None => {
                    self.settle();
                    self.cull_strings(floor_n)
                }
            };
            self.last_cull = (bound, loudest_n);
        }
        // The products turn freely with their strings: they are set again only
        // when the strings' motion changed otherwise (a strike, a trade, the
        // damper, a bend), or every [`PHANTOM_REFRESH_BLOCKS`] to drop the faded.
        // While a string is played its loudest is unknown (infinite): they wait
        // for the strike to end.
        self.phantom_age += 1;
        let refresh =
            self.phantom_stale || self.phantom_age >= PHANTOM_REFRESH_BLOCKS || self.phantom_level != self.phantom_set;
        if refresh && self.phantom.is_some() {
            // (Read from the strings, and set anew: back from the gathering.)
            self.settle();
        }
        if self.phantom_fading && self.phantom_faded >= self.phantom_fade_len {
            // Faded in: gathered with the strings again from the next stretch.
            self.settle();
            self.phantom_fading = false;
        }
        if let Some(p) = &mut self.phantom
            && refresh
        {
            let floor = floor_n.max(crate::phantom::BELOW_LOUDEST * loudest_n);
            let was_on = self.phantom_on;
            self.phantom_on = p.start_block(&self.strings, self.phantom_level, floor);
            if self.phantom_on && !was_on {
                let fs = self.strings.first().map_or(0.0, StruckString::sample_rate_hz);
                self.phantom_fading = true;
                self.phantom_faded = 0;
                self.phantom_fade_len = ((PHANTOM_FADE_S * fs).round() as usize).max(1);
            }
            self.phantom_stale = !floor.is_finite();
            self.phantom_age = 0;
            self.phantom_set = self.phantom_level;
        }
        // A string still being played reports an infinite loudest: no relative culling next time.
        self.loudest_n = if loudest_n.is_finite() { loudest_n } else { 0.0 };
        if (self.strike_gain - self.strike_gain_to).abs() < 1e-6 * self.strike_gain_to {
            self.strike_gain = self.strike_gain_to;
        }
        self.level = bound * self.gain_per_n * self.fade * self.strike_gain.max(self.strike_gain_to);
        self.driven = self.driven.saturating_sub(1);
        // A tangent held on its strings keeps pressing on the bridge: the key
        // stays sounding (silencing it would drop that force at once, a thump).
        let pressing = self.held != 0 && self.stays_on_strings();
        if settled && self.level < silence && self.driven == 0 && !pressing {
            self.silence();
            return true;
        }
        false
    }

    /// Every string culled ([`StruckString::cull`]): their bound summed and
    /// the loudest mode.
    fn cull_strings(&mut self, floor_n: f64) -> (f64, f64) {
        let (mut bound, mut loudest_n) = (0.0, 0.0f64);
        for s in &mut self.strings {
            let (string_bound, string_loudest) = s.cull(floor_n);
            bound += string_bound;
            loudest_n = loudest_n.max(string_loudest);
        }
        (bound, loudest_n)
    }

    /// [`Self::cull_strings`] without handing the strings back from the
    /// gathering (and gathering them again next stretch: a quarter of the
    /// keys' control blocks did), the gathered strings culled where they run:
    /// the same bound and loudest mode, the same modes put to rest. Only
    /// while every string is settled, and only if no string's running modes
    /// would shrink (the gathering would hold modes no longer run); else
    /// `None`, and the strings are culled after the settling (the modes put
    /// to rest here are at rest there: the same again).
    fn cull_where_gathered(&mut self, settled: bool, floor_n: f64) -> Option<(f64, f64)> {
        if !settled || !self.gather_live {
            return None;
        }
        let (mut bound, mut loudest_n) = (0.0, 0.0f64);
        for (i, s) in self.strings.iter_mut().enumerate() {
            let (string_bound, string_loudest) = match self.gathered[i] {
                Some(at) if at != usize::MAX => {
                    let n = s.bank().running();
                    let (b, loudest, top) = self.gather.cull(at, n, s.audio().backs(), floor_n);
                    if top < n {
                        return None;
                    }
                    (b, loudest)
                }
                _ => s.cull(floor_n),
            };
            bound += string_bound;
            loudest_n = loudest_n.max(string_loudest);
        }
        Some((bound, loudest_n))
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
        self.settle();
        self.cull_in = 0;
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
        self.phantom_stale = true;
        let (rate_s, rate_per_hz_s) = self.damper.extra_decay();
        for s in &mut self.strings {
            s.set_free_step(rate_s, rate_per_hz_s, pitch);
        }
        self.pitch_set = pitch;
        if self.bridge_coupling_s_kg > 0.0 {
            // Each string moves the bridge under the others sample by sample:
            // the loop, Y times their answers, is held under the limit (the
            // modes a bend takes past the top no longer answer).
            let loop_gain =
                self.bridge_coupling_s_kg * self.strings.iter().map(StruckString::bridge_answer_ns_m).sum::<f64>();
            self.bridge_share = if loop_gain > COURSE_LOOP_LIMIT { COURSE_LOOP_LIMIT / loop_gain } else { 1.0 };
        }
    }

    /// At rest and inactive (the notes struck are kept for [`Self::take_sounded`]).
    pub fn silence(&mut self) {
        self.settle();
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
        self.cull_in = 0;
        self.phantom_on = false;
        self.phantom_stale = true;
        self.bed_pulse = None;
        if let Some(p) = &mut self.phantom {
            p.silence();
        }
    }

    /// The key's force on the bridge over a stretch as long as `force`, at its
    /// output gain, moving its fade. The summed contact force goes to
    /// `contact` when given. [`Self::drive`] hands it to the bridge.
    pub fn sound(&mut self, force: &mut [f64], contact: Option<&mut [f32]>) {
        let scratch = force;
        scratch.fill(0.0);
        self.render(scratch, contact);
        let glide = self.strike_gain != self.strike_gain_to;
        if !glide && self.fade_step == 0.0 && self.volume_step == 0.0 {
            // Most stretches: one gain throughout.
            let (g, f, s) = (self.gain_per_n * self.volume, self.fade, self.strike_gain);
            scratch.iter_mut().for_each(|v| *v = *v * g * f * s);
        } else {
            for v in scratch.iter_mut() {
                if glide {
                    self.strike_gain += (self.strike_gain_to - self.strike_gain) * self.strike_glide;
                }
                if self.volume_step != 0.0 {
                    self.volume += self.volume_step;
                    if (self.volume - self.volume_to) * self.volume_step >= 0.0 {
                        (self.volume, self.volume_step) = (self.volume_to, 0.0);
                    }
                }
                *v = *v * self.gain_per_n * self.volume * self.fade * self.strike_gain;
                if self.fade_step != 0.0 {
                    self.fade = (self.fade + self.fade_step).clamp(0.0, 1.0);
                    if self.fade >= 1.0 && self.fade_step > 0.0 {
                        self.fade_step = 0.0;
                    }
                }
            }
        }
        self.add_key_bed(scratch);
        if self.fade <= 0.0 && self.fade_step < 0.0 {
            // Faded out: silent from the next sample; reported at the next control tick.
            self.fade_step = 0.0;
            self.fade = 0.0;
        }
    }

    /// Drive `bridge` with what [`Self::sound`] gave over its stretch.
    pub fn drive(&mut self, bridge: &mut Bridge, force: &[f64]) {
        if self.pan.is_placed() {
            bridge.drive_placed(self.bridge_point, force, &mut self.pan);
        } else {
            bridge.drive(self.bridge_point, force);
        }
    }

    /// Add the key bed's pulse, while it lasts, to `out` (at output gain).
    fn add_key_bed(&mut self, out: &mut [f64]) {
        let Some((start, speed)) = self.bed_pulse else { return };
        // The key's own volume (a note expression) takes its knock with it.
        let gain = self.gain_per_n * self.volume * self.fade * self.noise.key_bed;
        let done = self.bed.add(start, speed, gain, out);
        self.bed_pulse = (done < self.bed.len()).then_some((done, speed));
    }

    /// Add the key's summed bridge force (N) over `out.len()` samples to `out`,
    /// and the summed contact force to `contact` when given.
    fn render(&mut self, out: &mut [f64], mut contact: Option<&mut [f32]>) {
        if self.bridge_coupling_s_kg > 0.0 {
            self.render_coupled(out, contact);
            return;
        }
        // Which strings turn freely over this stretch (a resting tangent's lift
        // goes to `out`); the others step sample by sample.
        for (s, free) in self.strings.iter_mut().zip(self.free_now.iter_mut()) {
            // (A string whose hammer flies clear turns freely even while the
            // live view records: it adds no contact force, and how it is
            // stepped then never depends on where a recording ends.)
            *free = (contact.is_none() || s.coasting()) && s.free_for(out);
        }
        if self.gather_live && self.free_now.iter().zip(&self.gathered).any(|(f, at)| *f != at.is_some()) {
            self.settle();
        }
        // The free strings' modes (and the phantom products) are gathered and
        // run together, which fills `acc`; the gathering holds them until the
        // key is settled, so a control block cut into stretches runs as one.
        if !self.gather_live {
            let gather = &mut self.gather;
            gather.clear();
            for ((s, free), at) in self.strings.iter().zip(&self.free_now).zip(self.gathered.iter_mut()) {
                // (With no room, which the room made for it rules out, it runs alone.)
                *at = free.then(|| s.bank().gather_free(s.audio(), gather).unwrap_or(usize::MAX));
            }
            self.phantom_at = match (self.phantom_on && !self.phantom_fading, self.phantom.as_ref()) {
                (true, Some(p)) => Some(p.gather_free(gather).unwrap_or(usize::MAX)),
                _ => None,
            };
            self.gather_live = true;
        }
        for (s, free) in self.strings.iter_mut().zip(&self.free_now) {
            if *free {
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
        let acc = &mut self.lanes[..out.len()];
        self.gather.run_fresh(acc);
        for (s, at) in self.strings.iter_mut().zip(&self.gathered) {
            if *at == Some(usize::MAX) {
                s.accumulate_free(acc, &mut []);
            }
        }
        if let (Some(usize::MAX), Some(p)) = (self.phantom_at, self.phantom.as_mut()) {
            p.accumulate(acc);
        }
        add_lane_sums(acc, out);
        if self.phantom_fading {
            self.add_phantom(out);
        }
    }

    /// Add its strings' stretch pulling on the bridge to `out`, faded in
    /// while it is starting ([`PHANTOM_FADE_S`]).
    fn add_phantom(&mut self, out: &mut [f64]) {
        let (true, Some(p)) = (self.phantom_on, self.phantom.as_mut()) else { return };
        let acc = &mut self.lanes[..out.len()];
        acc.fill([0.0; LANES]);
        p.accumulate(acc);
        if !self.phantom_fading {
            add_lane_sums(acc, out);
            return;
        }
        let mut pull = [0.0; CONTROL_BLOCK];
        let pull = &mut pull[..out.len()];
        add_lane_sums(acc, pull);
        let len = self.phantom_fade_len as f64;
        for (t, (o, v)) in out.iter_mut().zip(pull.iter()).enumerate() {
            *o += ((self.phantom_faded + t + 1) as f64 / len).min(1.0) * v;
        }
        self.phantom_faded += out.len();
    }

    /// [`Self::render`] for a course whose strings share a bridge point: each
    /// sample the bridge moves under the strings' force, at Re Y times it, and
    /// carries every string's end with it. A string's own push on the bridge is
    /// already among its losses, so each string's end is moved by the others'
    /// force alone: with its own share that makes the whole coupling Y times the
    /// square of the summed force, which only ever takes energy out.
    ///
    /// Each string takes the bridge's move with its next sample's step (one
    /// pass over its modes instead of two), the last sample's at the end.
    fn render_coupled(&mut self, out: &mut [f64], mut contact: Option<&mut [f32]>) {
        const MOST: usize = 8;
        let y = self.bridge_coupling_s_kg * self.bridge_share;
        // Each string's bridge move still to take.
        let mut moved = [None::<f64>; MOST];
        for (t, o) in out.iter_mut().enumerate() {
            let (mut total, mut total_before) = (0.0, 0.0);
            for (i, s) in self.strings.iter_mut().enumerate() {
                let tick = match moved.get_mut(i).and_then(Option::take) {
                    Some(dv) => s.tick_moved(dv),
                    None => s.tick(),
                };
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
                let dv = y * (total - total_before - own_change);
                match moved.get_mut(i) {
                    Some(due) => *due = Some(dv),
                    None => s.move_bridge(dv),
                }
            }
            std::mem::swap(&mut self.bridge_force_n, &mut self.force_now_n);
        }
        for (s, due) in self.strings.iter_mut().zip(moved) {
            if let Some(dv) = due {
                s.move_bridge(dv);
            }
        }
        self.add_phantom(out);
    }

    /// Take over a ringing key of the same instrument whose tables were rebuilt.
    pub fn take_over(&mut self, old: &mut Key, bend: f64) {
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
        self.pressure = old.pressure;
        self.pressure_now = old.pressure_now;
        (self.bebung_cents, self.bebung) = (old.bebung_cents, old.bebung);
        (self.hammer_hardness, self.hammer_position) = (old.hammer_hardness, old.hammer_position);
        self.pan = old.pan;
        self.tune = old.tune;
        (self.volume, self.volume_to, self.volume_step) = (old.volume, old.volume_to, old.volume_step);
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

/// Whether moving a silent key's partial by `delta` (full scale: at its
/// output gain) wakes it: more than [`WAKE_OVER_SILENCE`] times `silence`.
pub(crate) fn wakes(delta: Complex64, silence: f64) -> bool {
    delta.re.abs() + delta.im.abs() >= WAKE_OVER_SILENCE * silence
}

/// A regulation's gain at touch `value` (see [`Key::regulate`]): interpolated
/// in log gain over log touch, held at the ends.
/// The partials of `modes` (a key's strings, loaded by `board` at `midi_key`'s
/// bridge point) as the other strings meet them: strings tuned alike grouped,
/// each group's partials below [`SYMPATHY_TOP_HZ`] with the first string's
/// pole. Allocates.
fn ports(board: &BoardLoad, midi_key: u8, resistive: ResistiveBridge, modes: &[StringModes]) -> Vec<Port> {
    let first = |m: &StringModes| m.modes.first().map_or(0.0, |p| p.omega_rad_s);
    let mut out = Vec::new();
    let mut grouped = 0u32;
    for (i, lead) in modes.iter().enumerate().take(8) {
        if grouped & (1 << i) != 0 {
            continue;
        }
        let strings = (i..modes.len().min(8))
            .filter(|&j| (first(&modes[j]) / first(lead) - 1.0).abs() < SAME_PITCH)
            .fold(0u8, |mask, j| mask | (1 << j));
        grouped |= strings as u32;
        let partials = (0..modes.len().min(8))
            .filter(|j| strings & (1 << j) != 0)
            .map(|j| modes[j].modes.len())
            .min()
            .unwrap_or(0);
        let reach = board.reach(resistive, lead);
        let eps = board.coupling(midi_key, resistive, lead);
        for (n, mode) in lead.modes.iter().enumerate().take(partials) {
            let f_hz = mode.omega_rad_s / std::f64::consts::TAU;
            if f_hz > SYMPATHY_TOP_HZ {
                break;
            }
            let sigma = if mode.q.is_finite() && mode.q > 0.0 { mode.omega_rad_s / (2.0 * mode.q) } else { 0.0 };
            out.push(Port {
                strings,
                partial: n,
                f_hz,
                lambda: Complex64::new(-sigma, mode.omega_rad_s),
                reach: reach[n],
                loss_s: eps[n].re.max(0.0),
            });
        }
    }
    out
}

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
