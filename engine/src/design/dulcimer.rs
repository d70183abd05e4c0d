//! The hammered dulcimer: an American-style instrument made chromatic, D3-D6
//! (Peterson's compass), strung in pairs, struck near the bridges by light wooden
//! hammers; no dampers.
//!
//! Layout. Twelve bass courses, D3-C#4, cross the bass bridge and are played on
//! its left, as one speaking length each. Eighteen treble courses cross the treble
//! bridge, which divides each 3:2 (Peterson 1994): the long side, 3/5 of the course,
//! sounds the course's note N (D4-G5); the short side, the same wire at the same
//! tension over 2/3 of the length, sounds the fifth above, N + 7. Up to C5 that
//! fifth is also the long side of a higher course, which plays it; the short
//! side still rings with its own course. From G#5 to D6 the short sides of the
//! C#5-G5 courses are played. Thirty courses: the size of a 16/15.
//!
//! The treble bridge stands where one tension gives both sides their
//! equal-tempered pitches, 0.1 % short of 2/5 of the course (0.4 mm on a 0.6 m
//! course, within a maker's placing): the pure 3:2 would put the short side 2
//! cents sharp. The long side's third partial and the short side's second, the
//! same wave on the same wire, lie the tempered fifth's 2 cents apart.
//!
//! Both sides press on one point of the treble bridge: each side's force on it
//! moves the other side's end, so striking one side sets the other ringing, and
//! where their partials meet (every third of the long side, every second of the
//! short) the two beat slowly (Peterson 1994).
//!
//! Wire, after a 17/16 kit's stringing (Musicmakers: music wire of 0.016" to
//! 0.022" and wound strings of 0.024" and 0.032" for the lowest six courses):
//! D3-D#3 wound 0.032" (a 0.018" steel core under 0.007" bronze), E3-G3 wound
//! 0.024" (0.016" core, 0.004" wrap), G#3-C#4 plain 0.022", and the treble 0.020"
//! (D4-G4), 0.018" (G#4-C#5) and 0.016" (D5-G5). The cores are our assumption (no
//! wound-string schedule was found), chosen to work at 40-50 % of a 2.6 GPa
//! breaking stress. Bass lengths fall linearly from 0.78 m (D3) to 0.62 m
//! (C#4), a trapezoid's; treble long sides come from a working stress rising from
//! 0.86 GPa at D4 to 1.35 GPa at G5 (C5 at 0.37 m and 1.15 GPa, close to the top
//! bass C5 of a 16/15 that Dulcimer Heaven reckons: 0.38 m at 47 % of breaking,
//! 16 kg on gauge 6).
//!
//! The hammer is one light wooden hammer for the whole instrument: an equivalent
//! point mass of 3 g on a course, 1.5 g per string (within Woodhouse's 1 g to 3 g
//! per string; by his reckoning a real hammer of about 9 g), on his linear
//! contact spring of 1e6 N/m per string, striking a tenth of the length from the
//! bridge (a little further in the bass). It stays on the strings 1.5 to 2.7 ms.

use std::f64::consts::PI;
use std::ops::RangeInclusive;

use super::common::{
    COPPER_DENSITY_KG_M3, Level, Losses, STEEL_DENSITY_KG_M3, STEEL_MODULUS_PA, Table, detuned_hz, pan, struck_peak_n,
    unison_cents, voiced_law, voiced_position, wire_mass_per_length_kg_m, with_losses, wound_mass_per_length_kg_m,
};
use super::{ExciterDesign, KeyDesign, SharedKey, TouchRange, VelocityCurve, Voicing, key_frequency_hz};
use crate::exciter::hammer::contact::ContactLaw;
use crate::string::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

pub(super) const KEYS: RangeInclusive<u8> = 50..=86;

/// Hammer speeds from a soft touch to a hard stroke, m/s (the santoor's: the same
/// light hammers and wrist strokes).
pub(super) const TOUCH: TouchRange =
    TouchRange::Speed { min_m_s: 0.3, max_m_s: TOP_SPEED_M_S, curve: VelocityCurve::LogPower(1.0) };
/// The hardest touch: the fastest the exciter meets the string, m/s.
const TOP_SPEED_M_S: f64 = 4.0;

const STRINGS: usize = 2;
/// The highest bass course, and the highest long side of a treble course.
const LAST_BASS_KEY: u8 = 61;
const LAST_LONG_SIDE_KEY: u8 = 79;
/// The treble bridge's interval, semitones.
const FIFTH: u8 = 7;

const INCH_M: f64 = 0.0254;
/// Breaking stress of the music wire, Pa (ASTM A228 near 0.5 mm; with it the
/// 16/15's top bass C5 above works at 47 %).
const BREAKING_STRESS_PA: f64 = 2.6e9;
/// Speaking lengths of the bass courses, m.
const BASS_LENGTH_M: Table = Table(&[(50, 0.78), (61, 0.62)]);
/// Working stress of the treble long sides, as a fraction of the breaking stress.
const TREBLE_STRESS_FRACTION: Table = Table(&[(62, 0.33), (79, 0.52)]);
/// Strike position from the bridge, a fraction of the side's length.
const STRIKE_POSITION: Table = Table(&[(50, 0.12), (62, 0.10)]);
/// Equivalent point mass of the hammer on a course, kg.
const HAMMER_MASS_KG: f64 = 3.0e-3;
/// Contact spring per string, N/m (alpha = 1).
const HAMMER_STIFFNESS_PER_STRING_N_M: f64 = 1.0e6;

/// The santoor's losses: steel's internal friction and Re Y = 1e-3 s/kg, a thin
/// soundboard (a dulcimer rings for many seconds; its makers have worked to
/// shorten it, Peterson et al. 1994). A fundamental dies by 60 dB in about 21 s at
/// D3, 11 s at A4 (the santoor's 10 s) and 5 s at D6.
const LOSSES: Losses = Losses { internal_loss_factor: 3.0e-4, bridge_admittance_s_kg: 1.0e-3, tangent: None };

/// Re Y of the treble bridge point both sides of a course press on, s/kg: the
/// loss model's bridge admittance, since it is the same point of the same bridge
/// (each side's own push on it is already in its losses; the other side's moves
/// it as much).
const BRIDGE_COUPLING_S_KG: f64 = LOSSES.bridge_admittance_s_kg;

/// Widest detuning in a course, cents (a dulcimer's courses are rarely in perfect
/// unison; the chorus is part of its sound).
const UNISON_SPREAD_CENTS: f64 = 3.0;

/// Output level (see [`Level`]). The ringing at the level touch (velocity 0.7) is aimed at -26 dBFS,
/// the santoor's. A course played from both sides (C#5-G5 with G#5-D6) has one
/// gain: the mean of the two sides' (each then misses the target by half their
/// difference), capped where either side's loudest touch would peak above the
/// ceiling (the short side's, always). Ringing is measured with the course's
/// other side ringing along.
///
/// Relative to the peak, the ringing is -23 dB in the bass, -22 dB at D4 and -25
/// dB at C5, then falls away as the hammer outweighs the shorter strings more and
/// more: -29 dB at D5 (from there the thinner 0.016" wire), -35 dB at G5, and on
/// the short sides -32 dB at G#5 to -40 dB at D6. From B4 up the peak ceiling caps
/// the gain, and from C#5 the ringing falls short of the target: -29 dBFS at C#5,
/// -33 at D5, -39 at G5, and -33 at G#5, -38 to -42 from A5 to D6. The fits hold
/// every key within 0.8 dB of its measured ringing and 0.25 dB of its peak.
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -26.0,
    ring_db: Table(&[
        (50, -20.3),
        (68, -21.8),
        (72, -23.6),
        (73, -25.5),
        (74, -29.3),
        (79, -34.6),
        (80, -30.0),
        (81, -34.6),
        (86, -37.6),
    ]),
    peak_excess_db: Table(&[
        (50, 0.6),
        (53, 0.1),
        (61, 0.3),
        (64, -0.1),
        (72, -0.2),
        (73, -2.0),
        (79, -1.7),
        (80, 0.0),
        (86, 0.0),
    ]),
};

/// A course's wire: a steel core, bare or wound with one layer of bronze.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Wire {
    core_m: f64,
    /// Diameter of the wrapping wire, m (0: a plain string).
    wrap_m: f64,
}

impl Wire {
    fn of(midi_key: u8) -> Self {
        let (core_in, wrap_in) = match midi_key {
            ..=51 => (0.018, 0.007),
            52..=55 => (0.016, 0.004),
            56..=61 => (0.022, 0.0),
            62..=67 => (0.020, 0.0),
            68..=73 => (0.018, 0.0),
            _ => (0.016, 0.0),
        };
        Self { core_m: core_in * INCH_M, wrap_m: wrap_in * INCH_M }
    }

    fn mass_per_length_kg_m(&self) -> f64 {
        if self.wrap_m > 0.0 {
            wound_mass_per_length_kg_m(self.core_m, self.wrap_m, COPPER_DENSITY_KG_M3)
        } else {
            wire_mass_per_length_kg_m(self.core_m, STEEL_DENSITY_KG_M3)
        }
    }

    /// Bending stiffness EI of the core, N m^2 (a wrapping adds mass, not stiffness).
    fn bending_stiffness_n_m2(&self) -> f64 {
        STEEL_MODULUS_PA * PI * self.core_m.powi(4) / 64.0
    }

    /// A string of this wire over `length_m`, its first partial at `f_hz`.
    fn string(&self, length_m: f64, f_hz: f64, max_frequency_hz: f64, voicing: &Voicing) -> StringSpec {
        let (mass, outer_diameter_m) = if self.wrap_m > 0.0 {
            (Mass::PerLengthKgM(self.mass_per_length_kg_m()), Some(self.core_m + 2.0 * self.wrap_m))
        } else {
            (Mass::SolidWire { diameter_m: self.core_m, density_kg_m3: STEEL_DENSITY_KG_M3 }, None)
        };
        let spec = StringSpec {
            length_m,
            tuning: Tuning::FirstPartialHz(f_hz),
            mass,
            stiffness: Stiffness::YoungsModulus { modulus_pa: STEEL_MODULUS_PA, bending_diameter_m: self.core_m },
            damping: Damping::UniformQ(1.0), // replaced by with_losses
            max_frequency_hz,
            outer_diameter_m,
        };
        with_losses(spec, &LOSSES, voicing.damping)
    }

    /// Tension that gives a stiff string of `length_m` its first partial at `f_hz`,
    /// T = 4 L^2 mu f^2 - EI pi^2 / L^2, N.
    fn tension_n(&self, length_m: f64, f_hz: f64) -> f64 {
        let l2 = length_m * length_m;
        4.0 * l2 * self.mass_per_length_kg_m() * f_hz * f_hz - self.bending_stiffness_n_m2() * PI * PI / l2
    }

    /// First partial of a stiff string of `length_m` at `tension_n`, Hz.
    fn first_partial_hz(&self, length_m: f64, tension_n: f64) -> f64 {
        let l2 = length_m * length_m;
        ((tension_n + self.bending_stiffness_n_m2() * PI * PI / l2) / (4.0 * l2 * self.mass_per_length_kg_m())).sqrt()
    }

    /// Length at which `tension_n` gives the first partial `f_hz`, m: the root of
    /// 4 mu f^2 L^4 - T L^2 - EI pi^2 = 0.
    fn length_m(&self, tension_n: f64, f_hz: f64) -> f64 {
        let a = 4.0 * self.mass_per_length_kg_m() * f_hz * f_hz;
        let c = self.bending_stiffness_n_m2() * PI * PI;
        ((tension_n + (tension_n * tension_n + 4.0 * a * c).sqrt()) / (2.0 * a)).sqrt()
    }
}

/// Speaking length of the course's own note (a treble course's long side), m.
fn length_m(midi_key: u8) -> f64 {
    if midi_key <= LAST_BASS_KEY {
        BASS_LENGTH_M.linear(midi_key)
    } else {
        (TREBLE_STRESS_FRACTION.linear(midi_key) * BREAKING_STRESS_PA / STEEL_DENSITY_KG_M3).sqrt()
            / (2.0 * key_frequency_hz(midi_key))
    }
}

/// The hammer as the player holds it, striking a side at `position`.
fn hammer(voicing: &Voicing, position: f64) -> ExciterDesign {
    let law = ContactLaw { stiffness: STRINGS as f64 * HAMMER_STIFFNESS_PER_STRING_N_M, exponent: 1.0 };
    ExciterDesign::Hammer {
        mass_kg: HAMMER_MASS_KG * voicing.hammer_mass,
        law: voiced_law(law, voicing),
        position: voiced_position(position, voicing),
    }
}

/// The course `midi_key` is the note of: a bass course, or a treble course's long
/// side with its short side; None for G#5-D6, the short sides of C#5-G5.
pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> Option<KeyDesign> {
    if midi_key > LAST_LONG_SIDE_KEY {
        return None;
    }
    let wire = Wire::of(midi_key);
    let long_m = length_m(midi_key);
    let cents = unison_cents(midi_key, STRINGS, UNISON_SPREAD_CENTS, voicing);
    let mut strings: Vec<StringSpec> =
        cents.iter().map(|&c| wire.string(long_m, detuned_hz(midi_key, c), max_frequency_hz, voicing)).collect();

    let n = STRINGS as f64;
    let mu = wire.mass_per_length_kg_m();
    let tension_n = wire.tension_n(long_m, key_frequency_hz(midi_key));
    let z = n * (tension_n * mu).sqrt();
    let position = STRIKE_POSITION.linear(midi_key);
    let mut peak_n = struck_peak_n(z, n * tension_n, long_m, position, HAMMER_MASS_KG, TOP_SPEED_M_S);
    let pan = pan(midi_key, *KEYS.start()..=LAST_LONG_SIDE_KEY);
    let mut shared = Vec::new();
    let mut bridge_coupling_s_kg = 0.0;

    if midi_key > LAST_BASS_KEY {
        // The short side: each wire carries its long side's tension on past the bridge.
        let fifth = midi_key + FIFTH;
        let short_m = wire.length_m(tension_n, key_frequency_hz(fifth));
        let short: Vec<StringSpec> = cents
            .iter()
            .map(|&c| {
                let t = wire.tension_n(long_m, detuned_hz(midi_key, c));
                wire.string(short_m, wire.first_partial_hz(short_m, t), max_frequency_hz, voicing)
            })
            .collect();
        strings.extend(short);
        // The voicing's damping scales the bridge loss with the rest, so the coupling too.
        bridge_coupling_s_kg = BRIDGE_COUPLING_S_KG * voicing.damping.max(0.0);
        if KEYS.contains(&fifth) && fifth > LAST_LONG_SIDE_KEY {
            let position = STRIKE_POSITION.linear(fifth);
            let short_peak_n = struck_peak_n(z, n * tension_n, short_m, position, HAMMER_MASS_KG, TOP_SPEED_M_S);
            peak_n = peak_n.max(short_peak_n);
            shared.push(SharedKey {
                midi_key: fifth,
                struck: STRINGS..2 * STRINGS,
                exciter: hammer(voicing, position),
                pitch_ratio: 1.0,
            });
        }
    }
    let played: Vec<u8> = std::iter::once(midi_key).chain(shared.iter().map(|s| s.midi_key)).collect();

    Some(KeyDesign {
        midi_key,
        strings,
        exciter: hammer(voicing, position),
        struck: 0..STRINGS,
        shared,
        bridge_coupling_s_kg,
        resistive_bridge: LOSSES.resistive_bridge(voicing),
        losses: LOSSES,
        damper: None,
        gain_per_n: LEVEL.course_gain_per_n(&played, peak_n, pan),
        ring_gain_per_n: LEVEL.course_ring_gain_per_n(&played, peak_n),
        pan,
        // A bare wooden hammer: elastic, as the santoor's mallet.
        hammer_hysteresis: None,
        strike_shares: Vec::new(),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::InstrumentKind;
    use crate::synth::{Controls, Event, Instrument, Synth, TimedEvent, default_settings};

    fn build(spec: &StringSpec) -> crate::string::StringModes {
        spec.build().unwrap()
    }

    #[test]
    fn every_key_is_one_side_of_one_course() {
        let voicing = Voicing::default();
        let mut owner = [0u8; 128];
        for key in KEYS {
            let Some(d) = design(&voicing, key, 20_000.0) else { continue };
            owner[key as usize] += 1;
            for s in &d.shared {
                owner[s.midi_key as usize] += 1;
                assert_eq!(s.midi_key, key + FIFTH);
                assert_eq!(s.struck, 2..4);
                assert_eq!(s.pitch_ratio, 1.0);
            }
            let expected = if key <= LAST_BASS_KEY { 2 } else { 4 };
            assert_eq!(d.strings.len(), expected, "key {key}");
            assert_eq!(d.struck, 0..2);
            assert_eq!(d.shared.len(), usize::from((73..=79).contains(&key)), "key {key}");
            assert!(d.damper.is_none());
        }
        for key in 0..128u8 {
            assert_eq!(owner[key as usize], u8::from(KEYS.contains(&key)), "key {key}");
        }
    }

    #[test]
    fn both_sides_of_the_bridge_carry_one_tension_and_divide_the_course_3_to_2() {
        for key in 62..=LAST_LONG_SIDE_KEY {
            let d = design(&Voicing::default(), key, 20_000.0).unwrap();
            let s: Vec<_> = d.strings.iter().map(build).collect();
            for i in 0..2 {
                let (long, short) = (&s[i], &s[i + 2]);
                assert!((short.tension_n / long.tension_n - 1.0).abs() < 1e-9, "key {key}");
                assert_eq!(short.mass_per_length_kg_m, long.mass_per_length_kg_m);
                let share = short.length_m / (long.length_m + short.length_m);
                assert!((share - 0.4).abs() < 0.4 * 2e-3, "key {key}: short side {share}");
                // The long side's third partial meets the short side's second within
                // the tempered fifth's 2 cents.
                let cents = 1200.0 * (short.partial_hz(2) / long.partial_hz(3)).log2();
                assert!((-2.3..-1.8).contains(&cents), "key {key}: {cents} cents");
            }
            assert_eq!(d.bridge_coupling_s_kg, LOSSES.bridge_admittance_s_kg);
            let livelier = design(&Voicing { damping: 2.0, ..Voicing::default() }, key, 20_000.0).unwrap();
            assert_eq!(livelier.bridge_coupling_s_kg, 2.0 * LOSSES.bridge_admittance_s_kg);
        }
    }

    #[test]
    fn wire_works_at_a_quarter_to_three_fifths_of_its_breaking_stress() {
        for key in KEYS.filter(|&k| k <= LAST_LONG_SIDE_KEY) {
            let wire = Wire::of(key);
            let s = build(&design(&Voicing::default(), key, 20_000.0).unwrap().strings[0]);
            let stress = s.tension_n / (PI * wire.core_m * wire.core_m / 4.0);
            assert!((0.24..0.6).contains(&(stress / BREAKING_STRESS_PA)), "key {key}: {stress}");
            // Bass 0.62 to 0.78 m; treble courses 0.44 to 0.94 m side bridge to side bridge.
            let course_m = if key <= LAST_BASS_KEY { s.length_m } else { 5.0 * s.length_m / 3.0 };
            assert!((0.43..0.95).contains(&course_m), "key {key}: {course_m} m");
        }
    }

    #[test]
    fn wound_bass_strings_weigh_their_core_and_wrap() {
        // 0.032": a 0.018" core (1.29 g/m) under 0.007" bronze (2.48 g/m).
        let wire = Wire::of(50);
        let core = 7850.0 * PI * (0.018 * INCH_M).powi(2) / 4.0;
        let annulus = 8900.0 * PI * ((0.032 * INCH_M).powi(2) - (0.018 * INCH_M).powi(2)) / 4.0;
        assert!((wire.mass_per_length_kg_m() - core - PI / 4.0 * annulus).abs() < 1e-9);
        assert!((wire.mass_per_length_kg_m() - 3.77e-3).abs() < 0.01e-3, "{}", wire.mass_per_length_kg_m());
    }

    /// Amplitude of `x` (sampled at `fs`) at `f_hz`, dB (Hann window).
    fn spectrum_db(x: &[f32], f_hz: f64, fs: f64) -> f64 {
        let n = x.len() as f64;
        let (mut re, mut im) = (0.0, 0.0);
        for (k, v) in x.iter().enumerate() {
            let w = 0.5 - 0.5 * (2.0 * PI * k as f64 / n).cos();
            let phase = 2.0 * PI * f_hz * k as f64 / fs;
            re += w * *v as f64 * phase.cos();
            im += w * *v as f64 * phase.sin();
        }
        20.0 * (4.0 * (re * re + im * im).sqrt() / n).log10()
    }

    /// The strongest amplitude within 2 Hz of `f_hz`, dB.
    fn level_db(x: &[f32], f_hz: f64, fs: f64) -> f64 {
        (-8..=8).map(|i| spectrum_db(x, f_hz + 0.25 * i as f64, fs)).fold(f64::MIN, f64::max)
    }

    /// `key` struck alone at velocity 0.7, let go after 0.1 s if `let_go`: the
    /// output's channel mean from 0.1 to 1.1 s.
    fn ringing(key: u8, let_go: bool) -> Vec<f32> {
        ringing_for(key, let_go, 1.1)
    }

    /// The same over `seconds`, from 0.1 s.
    fn ringing_for(key: u8, let_go: bool, seconds: f64) -> Vec<f32> {
        let fs = 48_000.0;
        // Unstretched: the design's own frequencies.
        let mut settings = default_settings(InstrumentKind::Dulcimer, fs);
        settings.tuning.stretch = 0.0;
        let instrument = Instrument::build(&settings).unwrap();
        let (mut synth, _) = Synth::new(Box::new(instrument));
        // The course alone: the other courses tuned to its sides' partials
        // would take their share through the body too (sympathetic strings,
        // measured in the coupling tests).
        synth.set_controls(Controls { sympathy: 0.0, ..Controls::default() });
        let n = (seconds * fs) as usize;
        let (mut left, mut right) = (vec![0.0f32; n], vec![0.0f32; n]);
        let mut events = vec![TimedEvent::new(0, Event::NoteOn { key, velocity: 0.7 })];
        if let_go {
            events.push(TimedEvent::new((0.1 * fs) as u32, Event::NoteOff { key, velocity: 0.5 }));
        }
        synth.process(&events, &mut left, &mut right);
        left.iter().zip(&right).skip((0.1 * fs) as usize).map(|(l, r)| 0.5 * (l + r)).collect()
    }

    #[test]
    fn a_short_sides_note_off_changes_nothing() {
        let (held, released) = (ringing(80, false), ringing(80, true));
        assert!(held.iter().zip(&released).all(|(a, b)| a.to_bits() == b.to_bits()));
    }

    #[test]
    fn striking_one_side_sets_the_other_ringing() {
        // The other side's fundamental is no partial of the struck side (a fifth
        // above or below it): without the bridge it is absent, at the level of
        // frequencies where neither side has a partial (measured: 80 to 100 dB
        // lower). Through the bridge it rings 46 to 58 dB below the struck side's
        // fundamental.
        let fs = 48_000.0;
        for (struck, other) in [(62, 69), (73, 80), (80, 73)] {
            let x = ringing(struck, false);
            let f = key_frequency_hz(struck);
            let own = level_db(&x, f, fs);
            let sympathetic = level_db(&x, key_frequency_hz(other), fs);
            let floor = level_db(&x, 1.25 * f, fs).max(level_db(&x, 1.75 * f, fs));
            let what = format!("{struck} -> {other}: own {own:.1} dB, other {sympathetic:.1} dB, floor {floor:.1} dB");
            assert!(sympathetic > floor + 40.0, "{what}");
            assert!((own - 65.0..own - 40.0).contains(&sympathetic), "{what}");
        }
    }

    #[test]
    fn the_long_sides_third_partial_sets_the_short_sides_second_ringing() {
        // Struck on its long side, a course rings at the long side's third partials
        // (one per string) and, through the bridge, at the short side's second,
        // 2 cents flatter (the tempered fifth; 1 Hz at D4, 2 Hz at C#5): a slow beat.
        // Measured over 5 s the short side's partial lies 19 to 27 dB below its
        // partner, and far above the empty spectrum as far again below it.
        let fs = 48_000.0;
        for key in [62, 73] {
            let d = design(&Voicing::default(), key, 20_000.0).unwrap();
            let (long, short) = (build(&d.strings[0]).partial_hz(3), build(&d.strings[2]).partial_hz(2));
            let x = ringing_for(key, false, 5.1);
            let x = &x[(0.4 * fs) as usize..];
            let level = |f: f64| (-5..=5).map(|i| spectrum_db(x, f + 0.02 * i as f64, fs)).fold(f64::MIN, f64::max);
            let (at_long, at_short, empty) = (level(long), level(short), level(2.0 * short - long));
            let what =
                format!("key {key}: {long:.2} Hz {at_long:.1} dB, {short:.2} Hz {at_short:.1} dB, {empty:.1} dB");
            assert!((1.8..2.3).contains(&(1200.0 * (long / short).log2())), "{what}");
            assert!((at_long - 30.0..at_long - 15.0).contains(&at_short), "{what}");
            assert!(at_short > empty + 15.0, "{what}");
        }
    }

    #[test]
    fn one_hammer_of_3_g_on_a_linear_spring_strikes_near_the_bridge() {
        for key in KEYS.filter(|&k| k <= LAST_LONG_SIDE_KEY) {
            let d = design(&Voicing::default(), key, 20_000.0).unwrap();
            let exciters = std::iter::once(d.exciter).chain(d.shared.iter().map(|s| s.exciter));
            for e in exciters {
                let ExciterDesign::Hammer { mass_kg, law, position } = e else { panic!("not a hammer") };
                assert_eq!(mass_kg, 3.0e-3);
                assert_eq!(law, ContactLaw { stiffness: 2.0e6, exponent: 1.0 });
                assert!((0.1..=0.12).contains(&position), "key {key}: {position}");
            }
        }
    }
}
