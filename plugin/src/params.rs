//! The plugin's parameters: what a host automates and saves, and how each one
//! maps onto the engine's plain structs ([`InstrumentSettings`] with its
//! [`Voicing`], which need a rebuild, and [`Controls`], which do not).
//!
//! Ids are short and permanent: a saved project refers to them. Voicing
//! parameters are scale factors on the instrument's own per-key values (1 = as
//! built), shown as percentages; their ranges are skewed so that 100 % sits in
//! the middle of a knob's travel.

use std::sync::RwLock;

use nice_plug::prelude::*;
use struck_engine::body::Output;
use struck_engine::body::soundboard::{MicPlacement, Perspective};
use struck_engine::design::{InstrumentKind, Voicing};
use struck_engine::synth::{Controls, InstrumentSettings};
use struck_engine::tuning::{A4_RANGE_HZ, ScalaScale, Temperament, TuningSettings, pitch_class_name};

/// The instrument choice as a host parameter (ids are permanent).
#[derive(Enum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum InstrumentChoice {
    #[id = "piano"]
    Piano,
    #[id = "fortepiano"]
    Fortepiano,
    #[id = "santoor"]
    Santoor,
    #[id = "dulcimer"]
    #[name = "Hammered dulcimer"]
    Dulcimer,
    #[id = "cimbalom"]
    Cimbalom,
    #[id = "clavichord"]
    Clavichord,
    #[id = "harpsichord"]
    Harpsichord,
}

impl InstrumentChoice {
    pub fn kind(self) -> InstrumentKind {
        match self {
            InstrumentChoice::Piano => InstrumentKind::Piano,
            InstrumentChoice::Fortepiano => InstrumentKind::Fortepiano,
            InstrumentChoice::Santoor => InstrumentKind::Santoor,
            InstrumentChoice::Dulcimer => InstrumentKind::Dulcimer,
            InstrumentChoice::Cimbalom => InstrumentKind::Cimbalom,
            InstrumentChoice::Clavichord => InstrumentKind::Clavichord,
            InstrumentChoice::Harpsichord => InstrumentKind::Harpsichord,
        }
    }

    pub const ALL: [InstrumentChoice; 7] = [
        InstrumentChoice::Piano,
        InstrumentChoice::Fortepiano,
        InstrumentChoice::Santoor,
        InstrumentChoice::Dulcimer,
        InstrumentChoice::Cimbalom,
        InstrumentChoice::Clavichord,
        InstrumentChoice::Harpsichord,
    ];
}

/// The temperament as a host parameter (ids are permanent).
#[derive(Enum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum TemperamentChoice {
    #[id = "equal"]
    #[name = "Equal"]
    Equal,
    #[id = "meantone"]
    #[name = "Meantone (1/4 comma)"]
    Meantone,
    #[id = "werckmeister3"]
    #[name = "Werckmeister III"]
    Werckmeister3,
    #[id = "vallotti"]
    #[name = "Vallotti"]
    Vallotti,
    #[id = "scala"]
    #[name = "Scala file"]
    Scala,
}

impl TemperamentChoice {
    pub const ALL: [TemperamentChoice; 5] = [
        TemperamentChoice::Equal,
        TemperamentChoice::Meantone,
        TemperamentChoice::Werckmeister3,
        TemperamentChoice::Vallotti,
        TemperamentChoice::Scala,
    ];

    pub fn temperament(self) -> Temperament {
        match self {
            TemperamentChoice::Equal => Temperament::Equal,
            TemperamentChoice::Meantone => Temperament::Meantone,
            TemperamentChoice::Werckmeister3 => Temperament::Werckmeister3,
            TemperamentChoice::Vallotti => Temperament::Vallotti,
            TemperamentChoice::Scala => Temperament::Scala,
        }
    }

    pub fn of(temperament: Temperament) -> Self {
        Self::ALL.into_iter().find(|c| c.temperament() == temperament).unwrap_or(TemperamentChoice::Equal)
    }
}

/// The polyphonic modulation ids of the hammer's felt stiffness and strike position.
pub const POLY_HARDNESS: u32 = 1;
pub const POLY_POSITION: u32 = 2;

/// Version of the saved state's layout, kept with the state for future migrations.
pub const STATE_VERSION: u32 = 1;

/// Every parameter, grouped as a player thinks of them.
#[derive(Params)]
pub struct StruckParams {
    #[nested(group = "Instrument")]
    pub instrument: InstrumentParams,
    #[nested(group = "Touch")]
    pub touch: TouchParams,
    #[nested(group = "Hammer")]
    pub hammer: HammerParams,
    #[nested(group = "Strings")]
    pub strings: StringParams,
    #[nested(group = "Tangent")]
    pub tangent: TangentParams,
    #[nested(group = "Tuning")]
    pub tuning: TuningParams,
    #[nested(group = "Output")]
    pub output: OutputParams,
    #[nested(group = "Resonance")]
    pub resonance: ResonanceParams,
    #[nested(group = "Action")]
    pub action: ActionParams,
    /// The Scala scale (and keyboard mapping) loaded from the panel, kept with the project.
    #[persist = "scala-scale"]
    pub scala: RwLock<Option<ScalaScale>>,
    /// Where it came from, for the panel.
    #[persist = "scala-files"]
    pub scala_files: RwLock<String>,
    /// The layout version of the saved state ([`STATE_VERSION`]).
    #[persist = "state-version"]
    pub state_version: RwLock<u32>,
}

#[derive(Params)]
pub struct InstrumentParams {
    #[id = "inst"]
    pub kind: EnumParam<InstrumentChoice>,
}

#[derive(Params)]
pub struct TouchParams {
    /// Softest touch (velocity 1), as a fraction of the instrument's touch range on a log scale.
    #[id = "tmin"]
    pub min: FloatParam,
    /// Hardest touch (velocity 127), likewise.
    #[id = "tmax"]
    pub max: FloatParam,
    /// Velocity curve exponent: 1 even, above 1 needs a harder touch.
    #[id = "tshp"]
    pub shape: FloatParam,
    /// The player's softest and loudest MIDI velocity: they play the softest
    /// and hardest touch (a velocity learn sets them).
    #[id = "vflo"]
    pub velocity_floor: IntParam,
    #[id = "vfhi"]
    pub velocity_ceiling: IntParam,
}

#[derive(Params)]
pub struct HammerParams {
    #[id = "hmass"]
    pub mass: FloatParam,
    #[id = "hstif"]
    pub stiffness: FloatParam,
    #[id = "hexp"]
    pub exponent: FloatParam,
    #[id = "hpos"]
    pub position: FloatParam,
    /// The felt's hysteresis (Stulov), as built = 1; 0 is an elastic felt.
    #[id = "hhys"]
    pub hysteresis: FloatParam,
    /// How unevenly the hammer meets a unison's strings: 0 level (as built).
    #[id = "huev"]
    pub unevenness: FloatParam,
}

#[derive(Params)]
pub struct StringParams {
    #[id = "damp"]
    pub damping: FloatParam,
    #[id = "detn"]
    pub detune: FloatParam,
}

/// The clavichord's tangents.
#[derive(Params)]
pub struct TangentParams {
    /// How far the tangent lifts the strings (1 = as built, 2 mm on a 0.8 m string).
    #[id = "tdep"]
    pub depth: FloatParam,
    /// How far full aftertouch raises a held note, cents (Bebung: the
    /// tangent presses deeper). The id is the one the parameter had as a
    /// share of the depth (0-100 %): a saved 25 % comes back as 25 cents.
    #[id = "bebg"]
    pub bebung: FloatParam,
    /// Fretted: neighbouring keys share a pair of strings; the higher tangent wins.
    #[id = "fret"]
    pub fretted: BoolParam,
}

#[derive(Params)]
pub struct TuningParams {
    /// A4, Hz.
    #[id = "a4"]
    pub a4_hz: FloatParam,
    #[id = "temp"]
    pub temperament: EnumParam<TemperamentChoice>,
    /// The pitch class a historical temperament is laid from (0 = C).
    #[id = "root"]
    pub root: IntParam,
    /// Share of the stretch the strings' inharmonicity asks for.
    #[id = "strt"]
    pub stretch: FloatParam,
}

#[derive(Params)]
pub struct OutputParams {
    #[id = "poly"]
    pub polyphony: IntParam,
    #[id = "bend"]
    pub bend_range: IntParam,
    /// MPE: channel 1 bends every note, channels 2-16 each bend their own
    /// (off: every channel's bend is the wheel).
    #[id = "mpe"]
    pub mpe: BoolParam,
    /// How far an MPE note's own channel bends it, each way.
    #[id = "mpbr"]
    pub mpe_range: IntParam,
    /// Load smoothing: heard 128 samples at 48 kHz late (2.7 ms), so a
    /// chord's strikes spread their work over a few blocks (off: no latency,
    /// and a chord's first blocks take all its work).
    #[id = "pace"]
    pub smoothing: BoolParam,
    /// Output level, dB (the engine glides to it, so no smoother here).
    #[id = "gain"]
    pub level_db: FloatParam,
    /// What is heard: the body's microphones or the bridge force.
    #[id = "outp"]
    pub source: EnumParam<OutputChoice>,
    /// Where the microphones listen from.
    #[id = "mic"]
    pub perspective: EnumParam<PerspectiveChoice>,
    /// The pair's stereo width, 0..1 of the perspective's own spacing.
    #[id = "wdth"]
    pub width: FloatParam,
    /// The body's board: its length and width, as built = 1.
    #[id = "bsiz"]
    pub board: FloatParam,
    /// How much of the board's resonances the strings feel.
    #[id = "birr"]
    pub irregularity: FloatParam,
}

/// How the strings ring beyond their own partials (live, no rebuild).
#[derive(Params)]
pub struct ResonanceParams {
    /// How strongly the strings ring with each other through the body, 0..1 of the physics.
    #[id = "symp"]
    pub sympathy: FloatParam,
    /// How loud the phantom partials are, 0..4 times the physics.
    #[id = "phan"]
    pub phantom: FloatParam,
}

/// The action's own sounds, each 0..4 times the physics (live, no rebuild).
#[derive(Params)]
pub struct ActionParams {
    /// A key striking its bed.
    #[id = "knoi"]
    pub key_noise: FloatParam,
    /// A damper landing on its strings (louder for a faster release).
    #[id = "dnoi"]
    pub damper_noise: FloatParam,
    /// The dampers lifting together when the sustain pedal goes down.
    #[id = "pnoi"]
    pub pedal_noise: FloatParam,
}

/// The microphones' perspective as a host parameter (ids are permanent).
#[derive(Enum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum PerspectiveChoice {
    #[id = "close"]
    #[name = "Close"]
    Close,
    #[id = "player"]
    #[name = "Player"]
    Player,
    #[id = "lid"]
    #[name = "Lid"]
    Lid,
    // Appended: a saved session names the choice by its id (an older one by
    // its index), and the first three keep both.
    #[id = "coincident"]
    #[name = "Coincident"]
    Coincident,
}

impl PerspectiveChoice {
    pub const ALL: [PerspectiveChoice; 4] =
        [PerspectiveChoice::Close, PerspectiveChoice::Player, PerspectiveChoice::Lid, PerspectiveChoice::Coincident];

    pub fn perspective(self) -> Perspective {
        match self {
            PerspectiveChoice::Close => Perspective::Close,
            PerspectiveChoice::Player => Perspective::Player,
            PerspectiveChoice::Lid => Perspective::Lid,
            PerspectiveChoice::Coincident => Perspective::Coincident,
        }
    }

    pub fn of(perspective: Perspective) -> Self {
        match perspective {
            Perspective::Close => PerspectiveChoice::Close,
            Perspective::Player => PerspectiveChoice::Player,
            Perspective::Lid => PerspectiveChoice::Lid,
            Perspective::Coincident => PerspectiveChoice::Coincident,
        }
    }
}

/// The output choice as a host parameter (ids are permanent).
#[derive(Enum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum OutputChoice {
    /// The body, through a pair of microphones over the board.
    #[id = "mics"]
    #[name = "Microphones"]
    Microphones,
    /// The seed's surrogate: the strings' force on a rigid bridge.
    #[id = "bridge"]
    #[name = "Bridge force"]
    BridgeForce,
}

impl OutputChoice {
    pub fn output(self) -> Output {
        match self {
            OutputChoice::Microphones => Output::Microphones,
            OutputChoice::BridgeForce => Output::BridgeForce,
        }
    }

    pub fn of(output: Output) -> Self {
        match output {
            Output::Microphones => OutputChoice::Microphones,
            Output::BridgeForce => OutputChoice::BridgeForce,
        }
    }
}

/// Skew that puts `center` at the middle of `min..=max`'s travel.
fn centred_skew(min: f32, max: f32, center: f32) -> f32 {
    0.5f32.ln() / ((center - min) / (max - min)).ln()
}

/// A scale factor from `min` to `max` (1 = as built), shown as a percentage.
fn scale_param(name: &str, min: f32, max: f32) -> FloatParam {
    FloatParam::new(name, 1.0, FloatRange::Skewed { min, max, factor: centred_skew(min, max, 1.0) })
        .with_unit(" %")
        .with_value_to_string(formatters::v2s_f32_percentage(0))
        .with_string_to_value(formatters::s2v_f32_percentage())
}

/// A level from 0 to `max` (1 = as built, at the middle of the travel), shown as a percentage.
fn level_param(name: &str, max: f32) -> FloatParam {
    FloatParam::new(name, 1.0, FloatRange::Skewed { min: 0.0, max, factor: centred_skew(0.0, max, 1.0) })
        .with_unit(" %")
        .with_value_to_string(formatters::v2s_f32_percentage(0))
        .with_string_to_value(formatters::s2v_f32_percentage())
}

fn percent_param(name: &str, default: f32) -> FloatParam {
    FloatParam::new(name, default, FloatRange::Linear { min: 0.0, max: 1.0 })
        .with_unit(" %")
        .with_value_to_string(formatters::v2s_f32_percentage(0))
        .with_string_to_value(formatters::s2v_f32_percentage())
}

impl Default for StruckParams {
    fn default() -> Self {
        Self {
            instrument: InstrumentParams { kind: EnumParam::new("Instrument", InstrumentChoice::Piano) },
            touch: TouchParams {
                min: percent_param("Touch min", 0.0),
                max: percent_param("Touch max", 1.0),
                shape: FloatParam::new(
                    "Touch curve",
                    1.0,
                    FloatRange::Skewed { min: 0.25, max: 4.0, factor: centred_skew(0.25, 4.0, 1.0) },
                )
                .with_value_to_string(formatters::v2s_f32_rounded(2)),
                velocity_floor: IntParam::new("Softest velocity", 0, IntRange::Linear { min: 0, max: 126 }),
                velocity_ceiling: IntParam::new("Loudest velocity", 127, IntRange::Linear { min: 1, max: 127 }),
            },
            hammer: HammerParams {
                mass: scale_param("Hammer mass", 0.25, 4.0),
                stiffness: scale_param("Felt stiffness K", 0.25, 4.0).with_poly_modulation_id(POLY_HARDNESS),
                exponent: scale_param("Felt exponent alpha", 0.5, 2.0),
                position: scale_param("Strike position", 0.25, 4.0).with_poly_modulation_id(POLY_POSITION),
                hysteresis: level_param("Felt hysteresis", 3.0),
                unevenness: percent_param("Hammer unevenness", 0.0),
            },
            tangent: TangentParams {
                depth: scale_param("Tangent depth", 0.5, 2.0),
                bebung: FloatParam::new(
                    "Bebung",
                    20.0,
                    FloatRange::Linear { min: 0.0, max: struck_engine::synth::MAX_BEBUNG_CENTS as f32 },
                )
                .with_unit(" cents")
                .with_step_size(0.5)
                .with_value_to_string(formatters::v2s_f32_rounded(1)),
                fretted: BoolParam::new("Fretted", false),
            },
            strings: StringParams {
                damping: scale_param("Damping", 0.25, 4.0),
                detune: level_param("Unison detune", 4.0),
            },
            tuning: TuningParams {
                a4_hz: FloatParam::new(
                    "A4",
                    440.0,
                    FloatRange::Linear { min: *A4_RANGE_HZ.start() as f32, max: *A4_RANGE_HZ.end() as f32 },
                )
                .with_unit(" Hz")
                .with_step_size(0.1)
                .with_value_to_string(formatters::v2s_f32_rounded(1)),
                temperament: EnumParam::new("Temperament", TemperamentChoice::Equal),
                root: IntParam::new("Temperament root", 0, IntRange::Linear { min: 0, max: 11 })
                    .with_value_to_string(std::sync::Arc::new(|v| pitch_class_name(v.clamp(0, 11) as u8).to_string()))
                    .with_string_to_value(std::sync::Arc::new(|s| {
                        (0..12).find(|&p| pitch_class_name(p as u8).eq_ignore_ascii_case(s.trim()))
                    })),
                stretch: percent_param("Stretch", 1.0),
            },
            output: OutputParams {
                polyphony: IntParam::new("Polyphony", 64, IntRange::Linear { min: 1, max: 128 }).with_unit(" keys"),
                bend_range: IntParam::new("Bend range", 2, IntRange::Linear { min: 0, max: 24 }).with_unit(" st"),
                mpe: BoolParam::new("MPE", false),
                mpe_range: IntParam::new("MPE bend range", 48, IntRange::Linear { min: 1, max: 96 }).with_unit(" st"),
                smoothing: BoolParam::new("Load smoothing", crate::standalone::smoothing_at_start(true))
                    .non_automatable(),
                level_db: FloatParam::new("Level", 0.0, FloatRange::Linear { min: -60.0, max: 12.0 })
                    .with_unit(" dB")
                    .with_step_size(0.1)
                    .with_value_to_string(formatters::v2s_f32_rounded(1)),
                source: EnumParam::new("Output", OutputChoice::Microphones),
                perspective: EnumParam::new("Microphones", PerspectiveChoice::Close),
                width: percent_param("Stereo width", 1.0),
                board: scale_param("Board size", 0.5, 2.0),
                irregularity: percent_param("Board irregularity", 0.5),
            },
            resonance: ResonanceParams {
                sympathy: percent_param("Sympathetic resonance", 1.0),
                phantom: level_param("Phantom partials", 4.0),
            },
            action: ActionParams {
                key_noise: level_param("Key noise", 4.0),
                damper_noise: level_param("Damper noise", 4.0),
                pedal_noise: level_param("Pedal noise", 4.0),
            },
            state_version: RwLock::new(STATE_VERSION),
            scala: RwLock::new(None),
            scala_files: RwLock::new(String::new()),
        }
    }
}

impl StruckParams {
    pub fn kind(&self) -> InstrumentKind {
        self.instrument.kind.value().kind()
    }

    /// The player's voicing, as scale factors on the instrument's own values.
    pub fn voicing(&self) -> Voicing {
        Voicing {
            hammer_mass: self.hammer.mass.value() as f64,
            hammer_stiffness: self.hammer.stiffness.value() as f64,
            hammer_exponent: self.hammer.exponent.value() as f64,
            strike_position: self.hammer.position.value() as f64,
            damping: self.strings.damping.value() as f64,
            unison_detune: self.strings.detune.value() as f64,
            tangent_depth: self.tangent.depth.value() as f64,
            fretted: self.tangent.fretted.value(),
            board_size: self.output.board.value() as f64,
            board_irregularity: self.output.irregularity.value() as f64,
            felt_hysteresis: self.hammer.hysteresis.value() as f64,
            hammer_unevenness: self.hammer.unevenness.value() as f64,
        }
    }

    /// What the instrument is built from as the parameters stand, read from
    /// atomics only (the audio thread compares it between blocks): it changes
    /// whenever the tables must be rebuilt, except for a Scala file loaded
    /// from the panel (a file, never automated).
    pub fn build_key(&self) -> BuildKey {
        BuildKey {
            kind: self.kind(),
            voicing: self.voicing(),
            tuning: [self.tuning.a4_hz.value(), self.tuning.stretch.value()],
            temperament: self.tuning.temperament.value(),
            root: self.tuning.root.value(),
            mics: self.mics(),
            output: self.output.source.value().output(),
        }
    }

    /// What the instrument's tables are built from, at `sample_rate_hz`.
    pub fn settings(&self, sample_rate_hz: f64) -> InstrumentSettings {
        InstrumentSettings {
            kind: self.kind(),
            voicing: self.voicing(),
            sample_rate_hz,
            tuning: self.tuning(),
            mics: self.mics(),
            strings_on_body: true,
        }
        .heard_through(self.output.source.value().output())
    }

    /// Where the body's microphones listen from.
    pub fn mics(&self) -> MicPlacement {
        MicPlacement {
            perspective: self.output.perspective.value().perspective(),
            width: self.output.width.value() as f64,
        }
    }

    /// The tuning. Reads a lock (the Scala scale): not for the audio thread.
    pub fn tuning(&self) -> TuningSettings {
        let temperament = self.tuning.temperament.value().temperament();
        let scale = match temperament {
            Temperament::Scala => self.scala.read().ok().and_then(|s| s.clone()),
            _ => None,
        };
        TuningSettings {
            a4_hz: self.tuning.a4_hz.value() as f64,
            // Without a scale loaded, "Scala file" plays equal temperament.
            temperament: if scale.is_some() { temperament } else { temperament_or_equal(temperament) },
            root: self.tuning.root.value().clamp(0, 11) as u8,
            stretch: self.tuning.stretch.value() as f64,
            scale,
        }
    }

    /// A voice's hardness and strike position factors for its polyphonic
    /// modulation of the felt stiffness and strike position (normalized
    /// offsets): each the parameter's value there over its value now. Reads
    /// atomics only: real-time safe.
    pub fn hammer_modulation(&self, (hardness, position): (f32, f32)) -> (f32, f32) {
        let factor = |param: &FloatParam, offset: f32| {
            let base = param.modulated_normalized_value();
            let now = param.preview_plain(base);
            if now > 0.0 { param.preview_plain((base + offset).clamp(0.0, 1.0)) / now } else { 1.0 }
        };
        (factor(&self.hammer.stiffness, hardness), factor(&self.hammer.position, position))
    }

    /// MPE's member channels' bend range, semitones, or None with MPE off.
    /// Reads atomics only: real-time safe.
    pub fn mpe(&self) -> Option<f32> {
        self.output.mpe.value().then(|| self.output.mpe_range.value() as f32)
    }

    /// The latency load smoothing asks for at `sample_rate_hz`, samples (0
    /// with it off). Reads atomics only: real-time safe.
    pub fn latency(&self, sample_rate_hz: f64) -> usize {
        if self.output.smoothing.value() { struck_engine::synth::Paced::latency_for(sample_rate_hz) } else { 0 }
    }

    /// The per-block controls. Reads atomics only: real-time safe.
    pub fn controls(&self) -> Controls {
        Controls {
            touch_min: self.touch.min.value() as f64,
            touch_max: self.touch.max.value() as f64,
            touch_shape: self.touch.shape.value() as f64,
            polyphony: self.output.polyphony.value().clamp(1, 128) as usize,
            output_gain: 10f64.powf(self.output.level_db.value() as f64 / 20.0),
            bend_range_semitones: self.output.bend_range.value() as f64,
            bebung_cents: self.tangent.bebung.value() as f64,
            velocity_floor: self.touch.velocity_floor.value() as f64 / 127.0,
            velocity_ceiling: self.touch.velocity_ceiling.value() as f64 / 127.0,
            output: self.output.source.value().output(),
            sympathy: self.resonance.sympathy.value() as f64,
            phantom: self.resonance.phantom.value() as f64,
            key_noise: self.action.key_noise.value() as f64,
            damper_noise: self.action.damper_noise.value() as f64,
            pedal_noise: self.action.pedal_noise.value() as f64,
        }
    }
}

/// What the instrument's tables depend on among the parameters ([`StruckParams::build_key`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BuildKey {
    kind: InstrumentKind,
    voicing: Voicing,
    tuning: [f32; 2],
    temperament: TemperamentChoice,
    root: i32,
    mics: MicPlacement,
    output: struck_engine::body::Output,
}

fn temperament_or_equal(t: Temperament) -> Temperament {
    if t == Temperament::Scala { Temperament::Equal } else { t }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn defaults_are_the_instrument_as_built() {
        let p = StruckParams::default();
        assert_eq!(p.voicing(), Voicing::default());
        assert_eq!(p.controls(), Controls::default());
        assert_eq!(p.tuning(), TuningSettings::default());
        assert_eq!(p.kind(), InstrumentKind::Piano);
    }

    /// The offline path compares build keys instead of settings (which
    /// allocate): every parameter that changes what the instrument is built
    /// from must change the key. The key moves with nothing else but the
    /// Scala temperament chosen with no scale loaded (which plays equal
    /// temperament: a catch-up that builds nothing new).
    #[test]
    fn the_build_key_changes_whenever_the_settings_do() {
        let mut changed = 0;
        for (id, _, _) in StruckParams::default().param_map() {
            let p = StruckParams::default();
            let map = p.param_map();
            let (_, param, _) = map.iter().find(|(i, _, _)| *i == id).unwrap();
            let (settings, key) = (p.settings(48_000.0), p.build_key());
            // SAFETY: as a host does, from one thread, on a parameter alive for the call.
            unsafe {
                let now = param.unmodulated_normalized_value();
                param._internal_set_normalized_value(if now > 0.5 { 0.0 } else { 1.0 });
            }
            let (settings_moved, key_moved) = (p.settings(48_000.0) != settings, p.build_key() != key);
            assert!(!settings_moved || key_moved, "{id}: the settings moved, the build key did not");
            assert!(settings_moved || !key_moved || id == "temp", "{id}: the build key moved alone");
            changed += usize::from(key_moved);
        }
        assert!(changed >= 15, "only {changed} parameters move the build key");
    }

    #[test]
    fn ids_are_short_unique_and_grouped() {
        let p = StruckParams::default();
        let map = p.param_map();
        let ids: Vec<&str> = map.iter().map(|(id, _, _)| id.as_str()).collect();
        let expected =
            ["inst", "tmin", "tmax", "tshp", "vflo", "vfhi", "hmass", "hstif", "hexp", "hpos", "hhys", "huev"]
                .into_iter()
                .chain(["damp", "detn"])
                .chain(["tdep", "bebg", "fret", "a4", "temp", "root", "strt"])
                .chain(["poly", "bend", "mpe", "mpbr", "pace", "gain", "outp", "mic", "wdth", "bsiz", "birr"])
                .chain(["symp", "phan", "knoi", "dnoi", "pnoi"])
                .collect::<Vec<_>>();
        assert_eq!(ids, expected);
        let groups: Vec<&str> = map.iter().map(|(_, _, g)| g.as_str()).collect();
        let group_of = |id: &str| groups[ids.iter().position(|i| *i == id).unwrap()];
        assert_eq!(group_of("inst"), "Instrument");
        assert_eq!(group_of("hhys"), "Hammer");
        assert_eq!(group_of("huev"), "Hammer");
        assert_eq!(group_of("tdep"), "Tangent");
        assert_eq!(group_of("a4"), "Tuning");
        assert_eq!(group_of("poly"), "Output");
        assert_eq!(group_of("symp"), "Resonance");
        assert_eq!(group_of("phan"), "Resonance");
        assert_eq!(group_of("knoi"), "Action");
        assert_eq!(group_of("pnoi"), "Action");
        // The hosts' numeric ids are hashes of these (nice-plug's, for CLAP and VST3):
        // no two may meet, nor may one be more than 6 characters (where they could).
        let hash = |id: &str| id.bytes().fold(0u32, |h, b| h.wrapping_mul(31).wrapping_add(u32::from(b))) & !(1 << 31);
        let mut hashes: Vec<u32> = ids.iter().map(|id| hash(id)).collect();
        hashes.sort_unstable();
        hashes.dedup();
        assert_eq!(hashes.len(), ids.len(), "two ids hash alike");
        assert!(ids.iter().all(|id| id.len() <= 6 && id.is_ascii()), "{ids:?}");
    }

    /// The new settings reach the engine's structs, each at its own field.
    #[test]
    fn resonance_action_and_felt_map_to_controls_and_voicing() {
        let p = StruckParams::default();
        let set = |param: &FloatParam, plain: f32| {
            // SAFETY: as a host does, from one thread, on a parameter alive for the call.
            unsafe { param.as_ptr()._internal_set_normalized_value(param.preview_normalized(plain)) };
        };
        set(&p.resonance.sympathy, 0.25);
        set(&p.resonance.phantom, 3.0);
        set(&p.action.key_noise, 0.0);
        set(&p.action.damper_noise, 2.0);
        set(&p.action.pedal_noise, 4.0);
        set(&p.hammer.hysteresis, 0.0);
        let c = p.controls();
        let close = |a: f64, b: f64| (a - b).abs() < 1e-4;
        assert!(close(c.sympathy, 0.25) && close(c.phantom, 3.0), "{c:?}");
        assert!(close(c.key_noise, 0.0) && close(c.damper_noise, 2.0) && close(c.pedal_noise, 4.0), "{c:?}");
        assert!(close(p.voicing().felt_hysteresis, 0.0));
        set(&p.hammer.hysteresis, 3.0);
        assert!(close(p.voicing().felt_hysteresis, 3.0));
    }

    #[test]
    fn scale_ranges_put_as_built_at_mid_travel() {
        let p = StruckParams::default();
        for param in [
            &p.hammer.mass,
            &p.hammer.stiffness,
            &p.hammer.exponent,
            &p.hammer.hysteresis,
            &p.strings.damping,
            &p.strings.detune,
            &p.resonance.phantom,
            &p.action.key_noise,
            &p.action.damper_noise,
            &p.action.pedal_noise,
        ] {
            assert!((param.range().normalize(1.0) - 0.5).abs() < 1e-5, "{}", param.name());
            assert!((param.range().unnormalize(0.5) - 1.0).abs() < 1e-5, "{}", param.name());
        }
        assert!((p.touch.shape.range().normalize(1.0) - 0.5).abs() < 1e-5);
    }

    #[test]
    fn values_display_with_units() {
        let p = StruckParams::default();
        assert_eq!(p.hammer.mass.normalized_value_to_string(0.5, true), "100 %");
        assert_eq!(p.output.level_db.to_string(), "0.0 dB");
        assert_eq!(p.resonance.sympathy.to_string(), "100 %");
        assert_eq!(p.action.pedal_noise.normalized_value_to_string(1.0, true), "400 %");
        assert_eq!(p.hammer.hysteresis.normalized_value_to_string(0.0, true), "0 %");
        assert_eq!(p.output.polyphony.to_string(), "64 keys");
        assert_eq!(p.instrument.kind.to_string(), "Piano");
    }
}
