//! The concert cimbalom (Schunda, Budapest, 1874): chromatic C2-E6 (C to e''',
//! four octaves and a major third), treble courses of 4 steel strings and bass
//! courses of 3 copper-wound ones, struck near the bridge by spoon-shaped beaters
//! with covered heads, under a damper bar that only the pedal lifts.
//!
//! Compass: Schunda's, MIDI 36-88 (Grove gives D2 as the usual lowest note; C2
//! keeps his four octaves and a third).
//!
//! Stringing. C2-D#3 in 16 courses of 3 wound strings, 48 in all: a Hungarian
//! concert instrument's count (Feraru: about 80 steel and 48 wound strings), so
//! the break falls between D#3 and E3. E3-E6 in courses of 4 steel strings. The
//! real instrument gets its 37 treble notes from some 20 steel courses divided by
//! bridges (3:2, Grove); here every note has an undivided course of its own.
//!
//! Steel: 0.6 mm music wire (our assumption: no gauges were found; a little
//! heavier than the santoor's 0.5 mm, for an instrument with a cast-iron frame) at
//! a working stress of 1.0 GPa at E3 rising to 1.5 GPa at E6, which makes its
//! strings longer than the santoor's: E3 1.08 m, A4 0.45 m (the santoor's 0.40 m),
//! E6 0.17 m, within a body 1.4 m wide. Wound bass (also our assumption): a steel
//! core of 0.80 mm (C2) to 0.60 mm (D#3) under copper wire of 0.45 to 0.12 mm,
//! over 1.20 to 0.95 m: the core works at 0.8 to 1.3 GPa and the course's
//! impedance runs on smoothly into the steel's (3.6 N s/m at D#3, 3.2 at E3).
//!
//! Beaters: one pair for the whole compass. Their equivalent point mass on a
//! course falls from 16 g at C2 to 6 g at E6 (per string 5.3 g on the heavy wound
//! C2, 3 g at E3, 2.1 g at A4, 1.5 g at E6): the long cane handle is flexible, and
//! the shorter the contact (it shortens up the compass) the less of it takes part. From E3 up that is heavier than the
//! santoor's mallets (8.6 g against 7.2 g a course at A4, 6 g against 4 g at the
//! top), the same below. Their heads are covered in leather or cotton; no
//! measurement of such a head was found, so it is our assumption: a mildly
//! hardening felt, F = K C^2 with K = 1e9 N/m^2 on a course, which on a rigid stop
//! would hold a 1 m/s stroke for 0.6 to 0.8 ms. On the strings the contact lasts
//! longer, from 1 ms at E6 to 4 ms in the bass (measured with the engine, see the
//! tests): struck near the bridge, a beater many times heavier than the string
//! near it rides the string for about pi sqrt(M beta (1 - beta) L / T), whatever
//! its head, and the head only shapes the stroke when it is much softer (the mod
//! wheel). Strike position as the santoor's, about a tenth of the length.
//!
//! Damper bar: felt along the whole compass, on the strings unless the pedal
//! holds it off ([`DamperDesign::pedal_only`]); with it on, a note dies by 60 dB in
//! 0.4 s.

use std::ops::RangeInclusive;

use super::common::{
    COPPER_DENSITY_KG_M3, Level, Losses, STEEL_DENSITY_KG_M3, STEEL_MODULUS_PA, Table, damper, detuned_hz,
    flexible_tension_n, pan, struck_peak_n, unison_cents, voiced_law, voiced_position, wire_mass_per_length_kg_m,
    with_losses, wound_mass_per_length_kg_m,
};
use super::{DamperDesign, ExciterDesign, KeyDesign, TouchRange, VelocityCurve, Voicing, key_frequency_hz};
use crate::exciter::hammer::Hysteresis;
use crate::exciter::hammer::contact::ContactLaw;
use crate::string::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

pub(super) const KEYS: RangeInclusive<u8> = 36..=88;

/// Beater speeds from a soft touch to a hard stroke, m/s (the santoor's range).
pub(super) const TOUCH: TouchRange =
    TouchRange::Speed { min_m_s: 0.3, max_m_s: TOP_SPEED_M_S, curve: VelocityCurve::LogPower(1.0) };
/// The hardest touch: the fastest the exciter meets the string, m/s.
const TOP_SPEED_M_S: f64 = 4.0;

/// The highest wound course.
const LAST_WOUND_KEY: u8 = 51;
const WOUND_STRINGS: usize = 3;
const STEEL_STRINGS: usize = 4;

/// Plain steel wire, m.
const STEEL_DIAMETER_M: f64 = 0.6e-3;
/// Working stress of the steel courses, Pa.
const STEEL_STRESS_PA: Table = Table(&[(52, 1.0e9), (88, 1.5e9)]);
/// Wound courses: speaking length, core and wrapping wire, m.
const WOUND_LENGTH_M: Table = Table(&[(36, 1.20), (51, 0.95)]);
const CORE_DIAMETER_M: Table = Table(&[(36, 0.80e-3), (51, 0.60e-3)]);
const WRAP_DIAMETER_M: Table = Table(&[(36, 0.45e-3), (51, 0.12e-3)]);

/// Strike position from the bridge (the santoor's).
const STRIKE_POSITION: Table = Table(&[(52, 0.13), (89, 0.10)]);
/// Equivalent point mass of a beater on a course, kg (log-linear in key).
const BEATER_MASS_KG: Table = Table(&[(36, 16.0e-3), (88, 6.0e-3)]);
/// The covered head's law on a whole course: F = K C^alpha.
const HEAD: ContactLaw = ContactLaw { stiffness: 1.0e9, exponent: 2.0 };
/// The head's hysteresis: a thin leather or cotton wrap over wood has far less
/// compressible wool than a piano hammer, so the low end of the felt's range
/// (eps 0.06 against the felt's 0.2, the same tau; see
/// [`super::common::FELT_HYSTERESIS`]).
const HEAD_HYSTERESIS: Hysteresis = Hysteresis { epsilon: 0.06, tau_s: 1.0e-5 };

/// Steel's internal friction and Re Y = 5e-4 s/kg, a piano's order: a heavier
/// soundboard under a cast-iron frame, which rings long enough to need its damper
/// bar (an assumption; no admittance was found). With the pedal down a fundamental
/// dies by 60 dB in about 36 s at C2, 28 s at E3, 12 s at A4 and 4 s at E6.
const LOSSES: Losses = Losses { internal_loss_factor: 3.0e-4, bridge_admittance_s_kg: 5.0e-4, tangent: None };

/// The damper bar: a 60 dB decay in 0.4 s at the fundamental, faster above (felt
/// takes short waves better), 30 ms to settle or lift.
const DAMPER_DECAY_S: f64 = 0.4;
const DAMPER_RATE_PER_HZ_S: f64 = 2.0e-3;
const DAMPER_TRAVEL_S: f64 = 0.03;

/// Widest detuning in a course, cents.
const UNISON_SPREAD_CENTS: f64 = 2.0;

/// Output level (see [`Level`]), measured with the pedal down (the damper bar
/// lifted): the ringing at the level touch (velocity 0.7) is aimed at -26 dBFS, the santoor's.
///
/// Relative to the peak, the ringing is -22 dB at C2, -20 dB from E3 to C4 and -22
/// dB at A4, then falls as the beater outweighs the shorter strings: -25 dB at
/// D#5, -28 at G5, -33 at C6, -37 at E6. From D#5 up the peak ceiling caps the
/// gain and the ringing falls short of the target: -27.5 dBFS at E5, -30 at G5,
/// -35 at C6, -38.5 at E6. The fits hold every key within 0.8 dB of its measured
/// ringing and 0.3 dB of its peak.
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -26.0,
    ring_db: Table(&[
        (36, -19.7),
        (54, -19.0),
        (73, -22.3),
        (83, -29.6),
        (84, -31.9),
        (86, -32.5),
        (87, -35.1),
        (88, -35.5),
    ]),
    peak_excess_db: Table(&[(36, 0.1), (49, 0.3), (88, -1.1)]),
};

/// A course's wire: a steel core, bare or wound with one layer of copper.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Wire {
    core_m: f64,
    /// Diameter of the wrapping wire, m (0: plain steel).
    wrap_m: f64,
}

impl Wire {
    fn of(midi_key: u8) -> Self {
        if midi_key <= LAST_WOUND_KEY {
            Self { core_m: CORE_DIAMETER_M.log(midi_key), wrap_m: WRAP_DIAMETER_M.log(midi_key) }
        } else {
            Self { core_m: STEEL_DIAMETER_M, wrap_m: 0.0 }
        }
    }

    fn mass_per_length_kg_m(&self) -> f64 {
        if self.wrap_m > 0.0 {
            wound_mass_per_length_kg_m(self.core_m, self.wrap_m, COPPER_DENSITY_KG_M3)
        } else {
            wire_mass_per_length_kg_m(self.core_m, STEEL_DENSITY_KG_M3)
        }
    }
}

/// Number of strings of a course.
fn strings_per_course(midi_key: u8) -> usize {
    if midi_key <= LAST_WOUND_KEY { WOUND_STRINGS } else { STEEL_STRINGS }
}

/// Speaking length, m.
fn length_m(midi_key: u8) -> f64 {
    if midi_key <= LAST_WOUND_KEY {
        WOUND_LENGTH_M.linear(midi_key)
    } else {
        (STEEL_STRESS_PA.linear(midi_key) / STEEL_DENSITY_KG_M3).sqrt() / (2.0 * key_frequency_hz(midi_key))
    }
}

/// The damper bar on a course whose fundamental is `f1_hz`.
fn damper_bar(f1_hz: f64) -> DamperDesign {
    DamperDesign { pedal_only: true, ..damper(DAMPER_DECAY_S, DAMPER_RATE_PER_HZ_S, f1_hz, DAMPER_TRAVEL_S) }
}

pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let wire = Wire::of(midi_key);
    let strings = strings_per_course(midi_key);
    let length_m = length_m(midi_key);
    let (mass, outer_diameter_m) = if wire.wrap_m > 0.0 {
        (Mass::PerLengthKgM(wire.mass_per_length_kg_m()), Some(wire.core_m + 2.0 * wire.wrap_m))
    } else {
        (Mass::SolidWire { diameter_m: wire.core_m, density_kg_m3: STEEL_DENSITY_KG_M3 }, None)
    };
    let specs = unison_cents(midi_key, strings, UNISON_SPREAD_CENTS, voicing)
        .into_iter()
        .map(|cents| {
            let spec = StringSpec {
                length_m,
                tuning: Tuning::FirstPartialHz(detuned_hz(midi_key, cents)),
                mass,
                stiffness: Stiffness::YoungsModulus { modulus_pa: STEEL_MODULUS_PA, bending_diameter_m: wire.core_m },
                damping: Damping::UniformQ(1.0), // replaced by with_losses
                max_frequency_hz,
                outer_diameter_m,
            };
            with_losses(spec, &LOSSES, voicing.damping)
        })
        .collect();

    let n = strings as f64;
    let mu = wire.mass_per_length_kg_m();
    let f1_hz = key_frequency_hz(midi_key);
    let tension_n = flexible_tension_n(length_m, mu, f1_hz);
    let position = STRIKE_POSITION.linear(midi_key);
    let peak_n = struck_peak_n(
        n * (tension_n * mu).sqrt(),
        n * tension_n,
        length_m,
        position,
        BEATER_MASS_KG.log(midi_key),
        TOP_SPEED_M_S,
    );
    KeyDesign {
        midi_key,
        strings: specs,
        struck: 0..strings,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        resistive_bridge: LOSSES.resistive_bridge(voicing),
        losses: LOSSES,
        exciter: ExciterDesign::Hammer {
            mass_kg: BEATER_MASS_KG.log(midi_key) * voicing.hammer_mass,
            law: voiced_law(HEAD, voicing),
            position: voiced_position(position, voicing),
        },
        damper: Some(damper_bar(f1_hz)),
        gain_per_n: LEVEL.gain_per_n(midi_key, peak_n, pan(midi_key, KEYS)),
        ring_gain_per_n: LEVEL.ring_gain_per_n(midi_key, peak_n),
        pan: pan(midi_key, KEYS),
        hammer_hysteresis: Some(HEAD_HYSTERESIS),
        strike_shares: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use std::f64::consts::PI;

    use super::super::common::DECAY_60_DB;
    use super::*;
    use crate::exciter::hammer::{Hammer, HammerSpec};
    use crate::struck_string::{DEFAULT_SUBSTEPS, StruckString};

    #[test]
    fn wound_courses_of_3_below_e3_and_steel_courses_of_4_from_it() {
        let count = |keys: RangeInclusive<u8>| -> usize {
            keys.map(|k| design(&Voicing::default(), k, 20_000.0).strings.len()).sum()
        };
        assert_eq!(count(36..=51), 48);
        assert_eq!(count(52..=88), 4 * 37);
        for key in KEYS {
            let d = design(&Voicing::default(), key, 20_000.0);
            let wound = matches!(d.strings[0].mass, Mass::PerLengthKgM(_));
            assert_eq!(wound, key <= LAST_WOUND_KEY, "key {key}");
            assert_eq!(d.strings.len(), if wound { 3 } else { 4 });
        }
    }

    #[test]
    fn a_wound_string_weighs_its_core_and_its_copper() {
        // C2: a 0.80 mm core (3.95 g/m) under 0.45 mm copper (pi / 4 of the annulus
        // out to 1.70 mm, 12.4 g/m).
        let d = design(&Voicing::default(), 36, 20_000.0);
        let s = d.strings[0].build().unwrap();
        let core = 7850.0 * PI * 0.8e-3f64.powi(2) / 4.0;
        let annulus = 8900.0 * PI * (1.7e-3f64.powi(2) - 0.8e-3f64.powi(2)) / 4.0;
        assert!((s.mass_per_length_kg_m - (core + PI / 4.0 * annulus)).abs() < 1e-9);
        assert!((s.mass_per_length_kg_m - 16.3e-3).abs() < 0.1e-3, "{}", s.mass_per_length_kg_m);
        assert!((d.strings[0].outer_diameter_m.unwrap() - 1.7e-3).abs() < 1e-12);
        // Its bending stiffness is the core's alone.
        let ei = STEEL_MODULUS_PA * PI * 0.8e-3f64.powi(4) / 64.0;
        assert!((s.bending_stiffness_n_m2 / ei - 1.0).abs() < 1e-12);
    }

    #[test]
    fn cores_work_at_0_8_to_1_5_gpa_and_strings_are_longer_than_the_santoors() {
        for key in KEYS {
            let wire = Wire::of(key);
            let s = design(&Voicing::default(), key, 20_000.0).strings[0].build().unwrap();
            let stress = s.tension_n / (PI * wire.core_m * wire.core_m / 4.0);
            assert!((0.78e9..1.52e9).contains(&stress), "key {key}: {stress}");
            assert!((0.16..1.21).contains(&s.length_m), "key {key}: {} m", s.length_m);
        }
        let a4 = design(&Voicing::default(), 69, 20_000.0).strings[0].build().unwrap();
        assert!((a4.length_m - 0.45).abs() < 0.01, "{}", a4.length_m);
    }

    /// The beater of `key` as designed, and the share of it one string takes.
    fn beater(key: u8) -> (KeyDesign, HammerSpec) {
        let d = design(&Voicing::default(), key, 20_000.0);
        let ExciterDesign::Hammer { mass_kg, law, position } = d.exciter else { panic!("not a beater") };
        let hammer = HammerSpec::one_of(d.strings.len(), mass_kg, law, 1.0, position);
        (d, hammer)
    }

    #[test]
    fn the_covered_head_holds_a_mezzo_forte_stroke_for_0_6_to_0_8_ms_on_a_rigid_stop() {
        // The engine's own contact solve, the beater against an immovable surface.
        let h = 1.0e-7;
        for key in [36, 52, 69, 88] {
            let (_, spec) = beater(key);
            let law = spec.law;
            assert_eq!(law.exponent, 2.0);
            let mut beater = Hammer::thrown(spec, 0.0);
            let mut steps = 0;
            loop {
                let predicted = beater.predict_m(h);
                let step = law.solve(beater.position_m, predicted, beater.compliance_m_n(h));
                beater.commit(h, predicted, step.step_force_n);
                steps += 1;
                if beater.position_m <= 0.0 {
                    break;
                }
            }
            let contact_ms = steps as f64 * h * 1e3;
            assert!((0.55..0.85).contains(&contact_ms), "key {key}: {contact_ms} ms");
        }
    }

    #[test]
    fn on_the_strings_the_beater_rides_them_for_1_to_4_ms() {
        // Near the bridge the string is stiff and the beater heavy against it: the
        // contact lasts about pi sqrt(M beta (1 - beta) L / T), not the head's time
        // (which adds to it at the top, where the two are alike).
        let fs = 192_000.0;
        for key in [36, 52, 60, 69, 88] {
            let (d, spec) = beater(key);
            let s = d.strings[0].build().unwrap();
            let n = d.strings.len() as f64;
            let beta = spec.position;
            let estimate_ms = 1e3 * PI * (spec.mass_kg * beta * (1.0 - beta) * s.length_m / s.tension_n).sqrt();
            let mut string = StruckString::new(s, fs, DEFAULT_SUBSTEPS);
            string.prepare_hammer(spec.position);
            string.strike(spec);
            let samples = (0..(0.02 * fs) as usize).take_while(|_| string.tick().contact_force_n > 0.0).count();
            let contact_ms = samples as f64 / fs * 1e3;
            assert!((0.9..4.5).contains(&contact_ms), "key {key}: {contact_ms} ms");
            assert!((0.8..1.5).contains(&(contact_ms / estimate_ms)), "key {key}: {contact_ms} ms, {estimate_ms} ms");
            assert!(n >= 3.0);
        }
    }

    #[test]
    fn the_damper_bar_answers_the_pedal_alone() {
        for key in KEYS {
            let d = design(&Voicing::default(), key, 20_000.0).damper.unwrap();
            assert!(d.pedal_only);
            // 60 dB at the fundamental in 0.4 s.
            let rate = d.rate_s + d.rate_per_hz_s * key_frequency_hz(key);
            assert!((rate * DAMPER_DECAY_S - DECAY_60_DB).abs() < 1e-9, "key {key}");
        }
    }
}
