//! The instruments: what every key of a piano, santoor, clavichord or harpsichord
//! is made of, as plain physical descriptions ([`KeyDesign`]).
//!
//! Nothing here runs on the audio thread. [`design`] answers "what strings and
//! what exciter does key k have, given the player's voicing"; the real-time layer
//! ([`crate::synth`]) turns every key's design into precomputed tables once, off
//! the audio thread.

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use crate::contact::ContactLaw;
use crate::string::StringSpec;

mod clavichord;
mod common;
mod harpsichord;
mod piano;
mod santoor;

/// The instruments Struck plays.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum InstrumentKind {
    #[default]
    Piano,
    Santoor,
    Clavichord,
    Harpsichord,
}

impl InstrumentKind {
    pub const ALL: [InstrumentKind; 4] =
        [InstrumentKind::Piano, InstrumentKind::Santoor, InstrumentKind::Clavichord, InstrumentKind::Harpsichord];

    pub fn name(self) -> &'static str {
        match self {
            InstrumentKind::Piano => "piano",
            InstrumentKind::Santoor => "santoor",
            InstrumentKind::Clavichord => "clavichord",
            InstrumentKind::Harpsichord => "harpsichord",
        }
    }

    /// The MIDI keys the instrument has (others are silent).
    pub fn key_range(self) -> std::ops::RangeInclusive<u8> {
        match self {
            InstrumentKind::Piano => piano::KEYS,
            InstrumentKind::Santoor => santoor::KEYS,
            InstrumentKind::Clavichord => clavichord::KEYS,
            InstrumentKind::Harpsichord => harpsichord::KEYS,
        }
    }

    /// Exciter speeds (or pluck heights) that velocity 1 and 127 map to by default.
    pub fn touch_range(self) -> TouchRange {
        match self {
            InstrumentKind::Piano => piano::TOUCH,
            InstrumentKind::Santoor => santoor::TOUCH,
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
            .ok_or_else(|| format!("unknown instrument \"{s}\" (expected piano, santoor, clavichord or harpsichord)"))
    }
}

/// The range of exciter speeds velocity maps onto, m/s (for a pluck: the pluck
/// height in mm, so the same curve shapes it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TouchRange {
    pub min: f64,
    pub max: f64,
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
        }
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
    Tangent { displacement_m: f64 },
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
}

/// Everything one key is made of.
#[derive(Clone, Debug, PartialEq)]
pub struct KeyDesign {
    pub midi_key: u8,
    /// The strings of the course, each already detuned.
    pub strings: Vec<StringSpec>,
    pub exciter: ExciterDesign,
    /// None: no damper (santoor).
    pub damper: Option<DamperDesign>,
    /// Output gain from bridge force (N) to a full-scale sample.
    pub gain_per_n: f64,
    /// Stereo position, -1 (left) to 1 (right).
    pub pan: f64,
}

/// The design of `midi_key` on `kind` with `voicing`, for modes up to
/// `max_frequency_hz`; None when the instrument has no such key.
pub fn design(kind: InstrumentKind, voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> Option<KeyDesign> {
    if !kind.key_range().contains(&midi_key) {
        return None;
    }
    let key = match kind {
        InstrumentKind::Piano => piano::design(voicing, midi_key, max_frequency_hz),
        InstrumentKind::Santoor => santoor::design(voicing, midi_key, max_frequency_hz),
        InstrumentKind::Clavichord => clavichord::design(voicing, midi_key, max_frequency_hz),
        InstrumentKind::Harpsichord => harpsichord::design(voicing, midi_key, max_frequency_hz),
    };
    Some(key)
}

/// Equal-tempered frequency of a MIDI key, A4 = 440 Hz.
pub fn key_frequency_hz(midi_key: u8) -> f64 {
    440.0 * 2f64.powf((midi_key as f64 - 69.0) / 12.0)
}
