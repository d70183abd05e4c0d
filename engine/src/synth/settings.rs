//! What an instrument is built from ([`InstrumentSettings`]: a rebuild when
//! they change) and what the player sets from block to block without one
//! ([`Controls`]: the touch curve, polyphony, levels, the output).

use super::{
    ActionNoise, Deserialize, InstrumentKind, MicPlacement, Output, Serialize, StringError, Touch, TouchRange,
    TuningSettings, Voicing,
};

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

pub(super) fn bear_on_body() -> bool {
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
