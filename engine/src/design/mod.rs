//! The instruments: what every key of a piano, fortepiano, santoor, hammered
//! dulcimer, cimbalom, clavichord or harpsichord is made of, as plain physical
//! descriptions ([`KeyDesign`]).
//!
//! Nothing here runs on the audio thread. [`key_design`] answers "what strings and
//! what exciter does key k have, given the player's voicing"; the real-time layer
//! ([`crate::synth`]) turns every key's design into precomputed tables once, off
//! the audio thread.

use std::fmt;
use std::ops::Range;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::exciter::hammer::Hysteresis;
use crate::exciter::hammer::contact::ContactLaw;
use crate::string::{StringSpec, Tuning};

mod cimbalom;
mod clavichord;
mod common;
mod dulcimer;
mod fortepiano;
mod harpsichord;
mod piano;
mod santoor;
mod scale;

pub use common::{Losses, TangentLeak};

/// The instruments Struck plays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InstrumentKind {
    #[default]
    Piano,
    Fortepiano,
    Santoor,
    Dulcimer,
    Cimbalom,
    Clavichord,
    Harpsichord,
}

impl InstrumentKind {
    pub const ALL: [InstrumentKind; 7] = [
        InstrumentKind::Piano,
        InstrumentKind::Fortepiano,
        InstrumentKind::Santoor,
        InstrumentKind::Dulcimer,
        InstrumentKind::Cimbalom,
        InstrumentKind::Clavichord,
        InstrumentKind::Harpsichord,
    ];

    pub fn name(self) -> &'static str {
        match self {
            InstrumentKind::Piano => "piano",
            InstrumentKind::Fortepiano => "fortepiano",
            InstrumentKind::Santoor => "santoor",
            InstrumentKind::Dulcimer => "dulcimer",
            InstrumentKind::Cimbalom => "cimbalom",
            InstrumentKind::Clavichord => "clavichord",
            InstrumentKind::Harpsichord => "harpsichord",
        }
    }

    /// The MIDI keys the instrument has (others are silent).
    pub fn key_range(self) -> std::ops::RangeInclusive<u8> {
        match self {
            InstrumentKind::Piano => piano::KEYS,
            InstrumentKind::Fortepiano => fortepiano::KEYS,
            InstrumentKind::Santoor => santoor::KEYS,
            InstrumentKind::Dulcimer => dulcimer::KEYS,
            InstrumentKind::Cimbalom => cimbalom::KEYS,
            InstrumentKind::Clavichord => clavichord::KEYS,
            InstrumentKind::Harpsichord => harpsichord::KEYS,
        }
    }

    /// Whether it is played with hand-held mallets (the mod wheel covers their heads).
    pub fn hand_mallets(self) -> bool {
        matches!(self, InstrumentKind::Santoor | InstrumentKind::Dulcimer | InstrumentKind::Cimbalom)
    }

    /// Whether the microphones hear the keyboard's balance as the strings and
    /// the body make it (every key bearing on the body with one gain per
    /// newton), rather than each key voiced to ring at the instrument's level
    /// scale. The piano, measured against a recorded grand whose level falls
    /// some 18 dB from the bass to the top, is heard as built.
    pub fn heard_as_built(self) -> bool {
        matches!(self, InstrumentKind::Piano)
    }

    /// Exciter speeds (or pluck heights) that velocity 1 and 127 map to by default.
    pub fn touch_range(self) -> TouchRange {
        match self {
            InstrumentKind::Piano => piano::TOUCH,
            InstrumentKind::Fortepiano => fortepiano::TOUCH,
            InstrumentKind::Santoor => santoor::TOUCH,
            InstrumentKind::Dulcimer => dulcimer::TOUCH,
            InstrumentKind::Cimbalom => cimbalom::TOUCH,
            InstrumentKind::Clavichord => clavichord::TOUCH,
            InstrumentKind::Harpsichord => harpsichord::TOUCH,
        }
    }
}

impl fmt::Display for InstrumentKind {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for InstrumentKind {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL
            .into_iter()
            .find(|k| k.name().eq_ignore_ascii_case(s))
            .ok_or_else(|| format!("unknown instrument \"{s}\" (expected piano, fortepiano, santoor, dulcimer, cimbalom, clavichord or harpsichord)"))
    }
}

/// What a key's velocity sets: how fast a hammer, mallet or tangent meets the
/// string, or how far a plectrum lifts it before letting go. One enum so the two
/// units never share a bare number.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Touch {
    /// Exciter speed toward the string, m/s.
    Speed { m_s: f64 },
    /// Plectrum lift at the pluck point, mm.
    PluckHeight { mm: f64 },
}

impl Touch {
    /// The number in its own unit (see [`Touch::unit`]).
    pub fn value(self) -> f64 {
        match self {
            Touch::Speed { m_s } => m_s,
            Touch::PluckHeight { mm } => mm,
        }
    }

    /// `"m/s"` or `"mm"`.
    pub fn unit(self) -> &'static str {
        match self {
            Touch::Speed { .. } => "m/s",
            Touch::PluckHeight { .. } => "mm",
        }
    }

    /// The exciter speed, if this is one.
    pub fn speed_m_s(self) -> Option<f64> {
        match self {
            Touch::Speed { m_s } => Some(m_s),
            Touch::PluckHeight { .. } => None,
        }
    }
}

/// The softest and hardest touch velocity maps onto (velocity 1 and 127 at the
/// default curve), in the unit the instrument's exciter is played in, and how
/// the velocities between spread over it ([`VelocityCurve`]; the player's own
/// curve, `Controls::touch_shape`, raises velocity to its power first).
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TouchRange {
    /// Exciter speeds, m/s.
    Speed { min_m_s: f64, max_m_s: f64, curve: VelocityCurve },
    /// Plectrum lifts, mm (an even log scale).
    PluckHeight { min_mm: f64, max_mm: f64 },
}

/// How a velocity v (0..=1) is spread over a touch range from min to max.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum VelocityCurve {
    /// min (max / min)^(v^exponent): even steps in the log of the speed for an
    /// exponent of 1, the middle velocities raised toward the hard end under 1.
    LogPower(f64),
    /// max v: the speed in proportion to velocity, never under min (which the
    /// softest velocities all play).
    Proportional,
}

impl VelocityCurve {
    /// How far up a range whose max / min is e^`span` velocity `v` plays, on
    /// the range's log scale (0 at min, 1 at max).
    pub fn share(self, v: f64, span: f64) -> f64 {
        let v = v.clamp(0.0, 1.0);
        match self {
            VelocityCurve::LogPower(exponent) => v.powf(exponent),
            VelocityCurve::Proportional if v <= 0.0 => 0.0,
            VelocityCurve::Proportional => (1.0 + v.ln() / span.max(f64::MIN_POSITIVE)).clamp(0.0, 1.0),
        }
    }

    /// The velocity that plays `share` of the way up (the inverse of
    /// [`Self::share`]).
    pub fn velocity(self, share: f64, span: f64) -> f64 {
        let share = share.clamp(0.0, 1.0);
        match self {
            VelocityCurve::LogPower(exponent) => share.powf(1.0 / exponent),
            VelocityCurve::Proportional => ((share - 1.0) * span).exp(),
        }
    }
}

/// Where an instrument's level scale is measured: this share of the way up its
/// touch range, on the range's log scale (the touch the default controls played
/// at velocity 0.7 while every range was an even log scale).
pub const LEVEL_SHARE: f64 = 0.7;

impl TouchRange {
    /// How velocity spreads over the range.
    pub fn curve(self) -> VelocityCurve {
        match self {
            TouchRange::Speed { curve, .. } => curve,
            TouchRange::PluckHeight { .. } => VelocityCurve::LogPower(1.0),
        }
    }

    /// The natural log of max / min.
    pub fn span(self) -> f64 {
        let (min, max) = self.bounds();
        (max / min).ln()
    }

    /// How far up the range's log scale velocity `v` (0..=1) plays.
    pub fn share(self, v: f64) -> f64 {
        self.curve().share(v, self.span())
    }

    /// The touch each key's ringing is evened at ([`LEVEL_SHARE`] of the way up).
    pub fn level_touch(self) -> Touch {
        let (min, max) = self.bounds();
        self.with(min * (max / min).powf(LEVEL_SHARE))
    }

    /// The velocity (0..=1) that plays [`Self::level_touch`] at the default controls.
    pub fn level_velocity(self) -> f64 {
        self.curve().velocity(LEVEL_SHARE, self.span())
    }

    /// The softest touch.
    pub fn min(self) -> Touch {
        self.with(self.bounds().0)
    }

    /// The hardest touch.
    pub fn max(self) -> Touch {
        self.with(self.bounds().1)
    }

    /// Softest and hardest as bare numbers in the range's unit.
    pub fn bounds(self) -> (f64, f64) {
        match self {
            TouchRange::Speed { min_m_s, max_m_s, .. } => (min_m_s, max_m_s),
            TouchRange::PluckHeight { min_mm, max_mm } => (min_mm, max_mm),
        }
    }

    /// A touch of `value` in the range's unit.
    pub fn with(self, value: f64) -> Touch {
        match self {
            TouchRange::Speed { .. } => Touch::Speed { m_s: value },
            TouchRange::PluckHeight { .. } => Touch::PluckHeight { mm: value },
        }
    }

    /// The fastest exciter speed, if the range is of speeds (hammer tables are
    /// built for it).
    pub fn top_speed_m_s(self) -> Option<f64> {
        self.max().speed_m_s()
    }
}

/// The player's voicing: scale factors on the instrument's own per-key values
/// (1 = as built). These change tables, so they are applied off the audio thread.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct Voicing {
    /// Hammer or mallet mass.
    pub hammer_mass: f64,
    /// Felt stiffness K.
    pub hammer_stiffness: f64,
    /// Felt exponent alpha (clamped to 1..=6 after scaling).
    pub hammer_exponent: f64,
    /// Strike (or pluck) position along the string.
    pub strike_position: f64,
    /// String losses (every mode's 1/Q).
    pub damping: f64,
    /// Spread of the unison detuning.
    pub unison_detune: f64,
    /// Clavichord: how far the tangent goes into the string (1 = as built: 2 mm on
    /// the 0.8 m D2 string, down to 1 mm on the short treble strings; held to 0.25..=2).
    pub tangent_depth: f64,
    /// Clavichord: fretted, several keys sharing one pair of strings (the higher tangent wins).
    pub fretted: bool,
    /// The body's board: its length and width (held to 0.5..=2); a larger board
    /// is heavier and rings lower.
    pub board_size: f64,
    /// How much of the board's resonances the strings feel (0..=1): 0 loads them
    /// with the board's smooth mean, 1 with every resonance (partials on one die
    /// fast). The radiated sound keeps every resonance either way.
    pub board_irregularity: f64,
    /// The felt's hysteresis (Stulov): a factor on the share of its force its
    /// memory takes back (0: elastic felt; held so the share stays under 0.9).
    pub felt_hysteresis: f64,
    /// How unevenly a hammer or mallet meets the strings of a unison (0: level,
    /// every string taking an equal share; 1: the most unevenly met string of
    /// the course takes half again its share, or half of it). Held to 0..=1.
    pub hammer_unevenness: f64,
}

impl Default for Voicing {
    fn default() -> Self {
        Self {
            hammer_mass: 1.0,
            hammer_stiffness: 1.0,
            hammer_exponent: 1.0,
            strike_position: 1.0,
            damping: 1.0,
            unison_detune: 1.0,
            tangent_depth: 1.0,
            fretted: false,
            board_size: 1.0,
            board_irregularity: 0.5,
            felt_hysteresis: 1.0,
            hammer_unevenness: 0.0,
        }
    }
}

/// What a playing instrument takes of a new voicing without new tables: the
/// strings' losses (every free mode's decay rate), and the hammer's mass,
/// felt stiffness and exponent, hysteresis and strike point (each met at the
/// next strike), as factors on what the instrument was built with (1: as
/// built). A key's regulation and voicing through the body stay as built
/// until the instrument is built again with the new voicing (a felt built
/// elastic stays so until then).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct LiveVoicing {
    pub damping: f64,
    pub hammer_mass: f64,
    pub hammer_stiffness: f64,
    pub hammer_exponent: f64,
    pub strike_position: f64,
    pub felt_hysteresis: f64,
}

impl Default for LiveVoicing {
    fn default() -> Self {
        Self {
            damping: 1.0,
            hammer_mass: 1.0,
            hammer_stiffness: 1.0,
            hammer_exponent: 1.0,
            strike_position: 1.0,
            felt_hysteresis: 1.0,
        }
    }
}

impl LiveVoicing {
    /// `now` over `built`, field by field (1 where either is not a positive
    /// number).
    pub fn between(built: &Voicing, now: &Voicing) -> Self {
        let ratio = |now: f64, built: f64| {
            let r = now / built;
            if now > 0.0 && built > 0.0 && r.is_finite() { r } else { 1.0 }
        };
        Self {
            damping: ratio(now.damping, built.damping),
            hammer_mass: ratio(now.hammer_mass, built.hammer_mass),
            hammer_stiffness: ratio(now.hammer_stiffness, built.hammer_stiffness),
            hammer_exponent: ratio(now.hammer_exponent, built.hammer_exponent),
            strike_position: ratio(now.strike_position, built.strike_position),
            felt_hysteresis: ratio(now.felt_hysteresis, built.felt_hysteresis),
        }
    }

    /// The felt law `law` (as built) moved by these factors: the exponent
    /// times its factor (held to 1..=6), the stiffness times its factor and
    /// rescaled so the force at the reference compression stays, as the
    /// voicing does it at build time.
    pub fn felt(&self, law: ContactLaw) -> ContactLaw {
        if self.hammer_exponent == 1.0 && self.hammer_stiffness == 1.0 {
            return law;
        }
        let exponent = (law.exponent * self.hammer_exponent).clamp(1.0, 6.0);
        let stiffness =
            law.stiffness * self.hammer_stiffness * common::REFERENCE_COMPRESSION_M.powf(law.exponent - exponent);
        ContactLaw { stiffness, exponent }
    }

    /// The felt's hysteresis `felt` (as built) with eps times its factor,
    /// held under the most a voiced felt may take back.
    pub fn hysteresis(&self, felt: Option<Hysteresis>) -> Option<Hysteresis> {
        if self.felt_hysteresis == 1.0 {
            return felt;
        }
        felt.map(|h| Hysteresis { epsilon: (h.epsilon * self.felt_hysteresis).min(MOST_HYSTERESIS), ..h })
    }
}

/// What sets a key's strings in motion.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExciterDesign {
    /// A hammer or mallet thrown at the course: one mass, one felt law for the
    /// whole course (each string takes an equal share of mass and stiffness).
    Hammer {
        mass_kg: f64,
        law: ContactLaw,
        /// Fraction of the length from the bridge end.
        position: f64,
    },
    /// A clavichord tangent pressing the far end of the strings by `displacement_m`.
    /// Pressing by W stretches the string: its tension rises by the factor
    /// 1 + `stretch_per_m2` W^2 (speaking and non-speaking lengths both stretched).
    /// Let go, it falls back from the strings with the time constant `return_s`
    /// (their push against the tangent's and key's mass), or more slowly when
    /// the key is let up slowly.
    Tangent { displacement_m: f64, stretch_per_m2: f64, return_s: f64 },
    /// A harpsichord plectrum releasing the string at `position`.
    Pluck { position: f64 },
}

/// How a key's damper acts when it is down on the strings.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct DamperDesign {
    /// Extra decay rate the damper adds to every mode, 1/s (sigma += rate_s + rate_per_hz_s * f).
    pub rate_s: f64,
    pub rate_per_hz_s: f64,
    /// Time for the damper felt to settle on (or lift off) the strings, s.
    pub travel_s: f64,
    /// The damper is worked by the pedal alone (a cimbalom's damper bar): keys do
    /// not lift it, so a note-off changes nothing.
    pub pedal_only: bool,
    /// The mass that lands on the strings with the damper as the key comes
    /// up, kg (its momentum there is the damper's thud, [`crate::action`]).
    pub head_mass_kg: f64,
}

/// Another key that plays the same strings as the key it is listed under: the
/// other side of a dulcimer course, a fretted clavichord's neighbouring tangent.
#[derive(Clone, Debug, PartialEq)]
pub struct SharedKey {
    pub midi_key: u8,
    /// Which of the course's strings its exciter reaches.
    pub struck: Range<usize>,
    pub exciter: ExciterDesign,
    /// Its pitch over the course's own (a tangent nearer the bridge shortens the speaking length).
    pub pitch_ratio: f64,
}

/// The resistive bridge a design set its strings' losses with, and the
/// voicing's factor on every loss: what the body's admittance takes the place
/// of when the strings bear on the body (`body::load`).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ResistiveBridge {
    /// Re Y, s/kg.
    pub admittance_s_kg: f64,
    /// The voicing's damping: every mode's loss times this.
    pub loss_scale: f64,
}

/// Everything one key is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyDesign {
    pub midi_key: u8,
    /// The strings of the course, each already detuned.
    pub strings: Vec<StringSpec>,
    pub exciter: ExciterDesign,
    /// Which of `strings` the key's own exciter reaches (usually all of them).
    pub struck: Range<usize>,
    /// Other keys played on these strings; they have no design of their own.
    pub shared: Vec<SharedKey>,
    /// Re Y of the bridge point the strings share, s/kg: the bridge moves under
    /// their summed force and carries every string's end with it (0: the strings
    /// are not coupled).
    pub bridge_coupling_s_kg: f64,
    /// The resistive bridge its strings' losses were set with: what the body's
    /// admittance takes the place of when the strings bear on the body.
    pub resistive_bridge: ResistiveBridge,
    /// What its strings lose their energy to: their losses are set from it,
    /// mode by mode, for the tension they are tuned to ([`KeyDesign::retuned`]).
    pub losses: Losses,
    /// None: no damper (santoor, dulcimer).
    pub damper: Option<DamperDesign>,
    /// Output gain from bridge force (N) to a full-scale sample.
    pub gain_per_n: f64,
    /// The same without the cap the bridge-force output's peak needs (see
    /// `Level`): the gain the body's microphones hear the key through.
    pub ring_gain_per_n: f64,
    /// Stereo position, -1 (left) to 1 (right).
    pub pan: f64,
    /// The hysteresis of the felt (or head) of every hammer that plays these
    /// strings, the key's own and its shared keys' (None: elastic, or no hammer).
    pub hammer_hysteresis: Option<Hysteresis>,
    /// How much of a hammer each string of the course meets, over an even
    /// share (mean 1 over the strings a hammer reaches; empty: all even).
    pub strike_shares: Vec<f64>,
}

impl KeyDesign {
    /// This design (in equal temperament at 440 Hz) retuned to
    /// `frequencies_hz`: every string turned to its key's frequency, as a
    /// tuner turns the pins, its losses set again for the tension it is then
    /// at (a string pulled tighter loses more into the bridge each cycle:
    /// kept at the old Q, one tuned far up would lose less than its bridge
    /// takes from it). Strings a shared key strikes apart from the key's own
    /// (the other side of a dulcimer course) follow that key; a shared key
    /// on the same strings (a fretted clavichord's tangent) is moved to its
    /// own key's tuned pitch.
    pub fn retuned(mut self, frequencies_hz: &[f64; 128]) -> Self {
        let ratio = |k: u8| frequencies_hz[k as usize] / key_frequency_hz(k);
        let home = ratio(self.midi_key);
        for (i, spec) in self.strings.iter_mut().enumerate() {
            let owner = self
                .shared
                .iter()
                .find(|s| s.struck.contains(&i) && !self.struck.contains(&i))
                .map_or(home, |s| ratio(s.midi_key));
            spec.tuning = match spec.tuning {
                Tuning::FirstPartialHz(f) => Tuning::FirstPartialHz(f * owner),
                Tuning::TensionN(t) => Tuning::TensionN(t * owner * owner),
            };
            if owner != 1.0 {
                *spec = common::with_losses(spec.clone(), &self.losses, self.resistive_bridge.loss_scale);
            }
        }
        for shared in &mut self.shared {
            if shared.struck.start < self.struck.end && self.struck.start < shared.struck.end {
                shared.pitch_ratio *= ratio(shared.midi_key) / home;
            }
        }
        self
    }
}

/// The design of `midi_key` on `kind` with `voicing`, in equal temperament at
/// A4 = 440 Hz, for modes up to `max_frequency_hz`; None when the instrument has
/// no such key, or when the key plays another key's strings ([`KeyDesign::shared`]).
pub fn key_design(kind: InstrumentKind, voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> Option<KeyDesign> {
    if !kind.key_range().contains(&midi_key) {
        return None;
    }
    let key = match kind {
        InstrumentKind::Piano => piano::design(voicing, midi_key, max_frequency_hz),
        InstrumentKind::Fortepiano => fortepiano::design(voicing, midi_key, max_frequency_hz),
        InstrumentKind::Santoor => santoor::design(voicing, midi_key, max_frequency_hz),
        InstrumentKind::Dulcimer => dulcimer::design(voicing, midi_key, max_frequency_hz)?,
        InstrumentKind::Cimbalom => cimbalom::design(voicing, midi_key, max_frequency_hz),
        InstrumentKind::Clavichord => clavichord::design(voicing, midi_key, max_frequency_hz)?,
        InstrumentKind::Harpsichord => harpsichord::design(voicing, midi_key, max_frequency_hz),
    };
    Some(voiced(key, voicing))
}

/// A key of the seed's Broadwood baby grand (Euphonics 12.2's piano, whose C
/// strings the seed's lab strikes) with `voicing`: the piano's design on the
/// Broadwood's own scale, `engine/data/broadwood-scale.csv`. No instrument plays
/// it. None outside the piano's compass.
pub fn broadwood_key_design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> Option<KeyDesign> {
    InstrumentKind::Piano
        .key_range()
        .contains(&midi_key)
        .then(|| voiced(piano::broadwood_design(voicing, midi_key, max_frequency_hz), voicing))
}

/// A designed key with what `voicing` does to every instrument's hammers: the
/// strings' shares of an uneven hammer and the felt's hysteresis.
fn voiced(key: KeyDesign, voicing: &Voicing) -> KeyDesign {
    let strike_shares = uneven_shares(&key, voicing);
    let mut key =
        KeyDesign { hammer_hysteresis: voiced_hysteresis(key.hammer_hysteresis, voicing), strike_shares, ..key };
    if let Some(h) = key.hammer_hysteresis {
        // The designs' felt laws are measured on strikes, which last far
        // longer than the felt's memory: they are the relaxed felt, (1 - eps)
        // times its stiffness to an instant stroke.
        let fast = |e: &mut ExciterDesign| {
            if let ExciterDesign::Hammer { law, .. } = e {
                law.stiffness /= 1.0 - h.epsilon;
            }
        };
        fast(&mut key.exciter);
        key.shared.iter_mut().for_each(|s| fast(&mut s.exciter));
    }
    key
}

/// How unevenly each string of a course's unisons is met, at the voicing's
/// `hammer_unevenness` of 1: a fixed pattern over the strings a hammer
/// reaches (its mean 0, its widest +-0.5), as a hammer's crown filed or worn
/// out of level meets one string first and hardest. Each key takes the
/// pattern in its own order, as no two hammers wear alike (no instrument has
/// more than four strings under one hammer; a longer course would take the
/// four's pattern and even shares on the rest, its mean still even); a mallet held
/// in the player's hand turns it by a string at each stroke (`Key::press`).
/// The pattern and its size are our assumption: no measurement of how level
/// hammers are voiced was at hand (a fraction of an even share, unitless).
const UNEVEN: [&[f64]; 3] = [&[-0.5, 0.5], &[-0.5, 0.1, 0.4], &[-0.5, -0.1, 0.2, 0.4]];
/// Where the keys' orders of [`UNEVEN`] start (any fixed number would do).
const UNEVEN_SEED: u64 = 0x5eed_0000;

/// The strings' shares of a hammer ([`KeyDesign::strike_shares`]) for the
/// voicing's `hammer_unevenness`: empty when level, or when no hammer plays
/// a unison.
fn uneven_shares(key: &KeyDesign, voicing: &Voicing) -> Vec<f64> {
    let u = if voicing.hammer_unevenness.is_finite() { voicing.hammer_unevenness.clamp(0.0, 1.0) } else { 0.0 };
    let hammered = matches!(key.exciter, ExciterDesign::Hammer { .. });
    if u == 0.0 || !hammered || key.strings.len() < 2 {
        return Vec::new();
    }
    // Each key's own order of the pattern, fixed by its number.
    let mut rng = crate::rng::Rng::new(UNEVEN_SEED + u64::from(key.midi_key));
    let mut shares = vec![1.0; key.strings.len()];
    let mut ranges = vec![key.struck.clone()];
    ranges.extend(key.shared.iter().map(|s| s.struck.clone()));
    for range in ranges {
        let n = range.len();
        if n < 2 {
            continue;
        }
        let pattern = UNEVEN[(n - 2).min(UNEVEN.len() - 1)];
        // The pattern's places, shuffled (Fisher-Yates).
        let mut order: Vec<usize> = (0..n).collect();
        for i in (1..n).rev() {
            order.swap(i, rng.below(i as u64 + 1) as usize);
        }
        for (s, at) in range.zip(order) {
            if let Some(share) = shares.get_mut(s) {
                *share = 1.0 + u * pattern.get(at).copied().unwrap_or(0.0);
            }
        }
    }
    shares
}

/// The most of its force a voiced felt's memory may take back (eps < 1).
const MOST_HYSTERESIS: f64 = 0.9;

/// A felt's hysteresis with the voicing's `felt_hysteresis` scaling eps (held
/// under [`MOST_HYSTERESIS`]; 0: elastic).
fn voiced_hysteresis(felt: Option<Hysteresis>, voicing: &Voicing) -> Option<Hysteresis> {
    let scale = if voicing.felt_hysteresis.is_finite() { voicing.felt_hysteresis.max(0.0) } else { 1.0 };
    felt.map(|h| Hysteresis { epsilon: (h.epsilon * scale).min(MOST_HYSTERESIS), ..h }).filter(|h| h.epsilon > 0.0)
}

/// How many cents sharp the clavichord's `midi_key` sounds while its tangent holds
/// the strings `displacement_m` in: pressing stretches both the speaking and the
/// damped length (the tension factor of [`ExciterDesign::Tangent`]'s
/// `stretch_per_m2`). About 5 cents at 2 mm on D2, quadratic in the depth.
pub fn clavichord_pitch_rise_cents(midi_key: u8, displacement_m: f64) -> f64 {
    clavichord::pitch_rise_cents(midi_key, displacement_m)
}

/// Equal-tempered frequency of a MIDI key, A4 = 440 Hz.
pub fn key_frequency_hz(midi_key: u8) -> f64 {
    440.0 * 2f64.powf((midi_key as f64 - 69.0) / 12.0)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn shares(kind: InstrumentKind, key: u8, unevenness: f64) -> Vec<f64> {
        let voicing = Voicing { hammer_unevenness: unevenness, ..Voicing::default() };
        key_design(kind, &voicing, key, 20_000.0).unwrap().strike_shares
    }

    #[test]
    fn an_uneven_hammer_shares_itself_unevenly_and_whole() {
        // Level: no shares at all (the key strikes as it always has).
        assert!(shares(InstrumentKind::Piano, 60, 0.0).is_empty());
        // A plucked or tangented course, or a single string, has none to share.
        assert!(shares(InstrumentKind::Harpsichord, 60, 1.0).is_empty());
        assert!(shares(InstrumentKind::Clavichord, 60, 1.0).is_empty());
        assert!(shares(InstrumentKind::Piano, 21, 1.0).is_empty(), "A0 has one string");
        for (kind, key) in [(InstrumentKind::Piano, 60), (InstrumentKind::Santoor, 60), (InstrumentKind::Dulcimer, 73)]
        {
            for u in [0.3, 1.0] {
                let s = shares(kind, key, u);
                let d = key_design(kind, &Voicing::default(), key, 20_000.0).unwrap();
                assert_eq!(s.len(), d.strings.len());
                // Each hammer's strings: their mean share is even, the widest half again at 1.
                for range in std::iter::once(d.struck.clone()).chain(d.shared.iter().map(|s| s.struck.clone())) {
                    let part = &s[range];
                    let mean = part.iter().sum::<f64>() / part.len() as f64;
                    assert!((mean - 1.0).abs() < 1e-12, "{kind:?} {key} at {u}: {part:?}");
                    let widest = part.iter().fold(0.0f64, |m, v| m.max((v - 1.0).abs()));
                    assert!((widest - 0.5 * u).abs() < 1e-12, "{kind:?} {key} at {u}: {part:?}");
                }
            }
        }
        // Keys wear their hammers in their own order.
        assert_ne!(shares(InstrumentKind::Piano, 60, 1.0), shares(InstrumentKind::Piano, 61, 1.0));
    }
}
