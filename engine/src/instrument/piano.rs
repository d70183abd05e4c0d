//! The piano: 88 keys scaled from the Broadwood baby grand of Euphonics 12.2.1
//! (Table 1, its C strings; physics reference 1.10), with the Chaigne & Askenfelt
//! (1994) felt laws of the C2, C4 and C7 hammers.
//!
//! Between the Cs every quantity is interpolated in key number: speaking length,
//! diameters and the course's mass per length log-linearly (they change by nearly
//! constant ratios per octave), strike ratio linearly, hammer mass linearly (the
//! table's estimates fall by 1 g per octave), the felt's exponent linearly and
//! log K linearly through C2, C4 and C7, held beyond them. Below C1 the C1-C2
//! segment is continued for the strings and the hammer.
//!
//! Stringing follows the Broadwood (Euphonics 12.2): 17 single wound strings
//! (A0-C#2), 13 wound pairs (D2-D3), then 58 plain steel triplets (D#3-C8). A
//! wound string's mass per length is the course's, interpolated through the
//! table's total mass / length, divided by its strings: the total impedance
//! then runs smoothly over the 1-2 break, as the maker intended (Euphonics 12.2,
//! Fig. 10). Its bending stiffness is the steel core's alone. A plain string's
//! mass follows from its diameter.

use std::ops::RangeInclusive;

use super::common::{
    Level, Losses, STEEL_DENSITY_KG_M3, STEEL_MODULUS_PA, Table, damper, detuned_hz, flexible_tension_n, pan,
    struck_peak_n, unison_cents, voiced_law, voiced_position, wire_mass_per_length_kg_m, with_losses,
};
use super::{ExciterDesign, KeyDesign, TouchRange, Voicing, key_frequency_hz};
use crate::contact::ContactLaw;
use crate::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

pub(super) const KEYS: RangeInclusive<u8> = 21..=108;

/// Hammer speeds from pianissimo to fortissimo (Boutillon 1988 measured 0.11 to
/// 6.83 m/s), m/s.
pub(crate) const TOUCH: TouchRange = TouchRange { min: 0.1, max: 7.0 };

/// The last key with a single string, and the last with two (wound) strings.
const LAST_SINGLE_KEY: u8 = 37;
const LAST_WOUND_KEY: u8 = 50;
/// Keys above this have no damper (their strings ring short anyway).
const LAST_DAMPED_KEY: u8 = 90;

/// Speaking length at C1..C8, m.
const LENGTH_M: Table =
    Table(&[(24, 1.013), (36, 0.925), (48, 0.830), (60, 0.639), (72, 0.324), (84, 0.181), (96, 0.096), (108, 0.051)]);
/// Steel core (or plain wire) diameter at C1..C8, m.
const CORE_DIAMETER_M: Table = Table(&[
    (24, 1.21e-3),
    (36, 1.21e-3),
    (48, 1.08e-3),
    (60, 1.00e-3),
    (72, 0.94e-3),
    (84, 0.85e-3),
    (96, 0.82e-3),
    (108, 0.76e-3),
]);
/// Outer diameter of the copper wrapping at C1..C3, m.
const WRAP_DIAMETER_M: Table = Table(&[(24, 5.80e-3), (36, 3.76e-3), (48, 1.80e-3)]);
/// The course's mass per length (total mass / length) at C1..C3, kg/m.
const WOUND_COURSE_MASS_KG_M: Table = Table(&[(24, 0.189 / 1.013), (36, 0.073 / 0.925), (48, 0.0307 / 0.830)]);
/// Strike position as a fraction of the length from the near (agraffe) end.
const STRIKE_RATIO: Table =
    Table(&[(24, 0.135), (36, 0.135), (48, 0.130), (60, 0.125), (72, 0.12), (84, 0.10), (96, 0.09), (108, 0.08)]);
/// Hammer mass, kg (Broadwood estimates, 12 g at C1 to 5 g at C8).
const HAMMER_MASS_KG: Table = Table(&[(24, 12.0e-3), (108, 5.0e-3)]);
/// Felt exponent alpha and stiffness K (N/m^alpha) of the C2, C4 and C7 hammers.
const FELT_EXPONENT: Table = Table(&[(36, 2.3), (60, 2.5), (96, 3.0)]);
const FELT_STIFFNESS: Table = Table(&[(36, 4.0e8), (60, 4.5e9), (96, 1.0e12)]);

/// Losses of the strings: steel's internal friction (the engine's default) and a
/// soundboard bridge of Re Y = 5e-4 s/kg (a drive-point impedance of 2 kN s/m,
/// the order quoted for piano bridges, physics reference 6). A string's
/// fundamental then dies by 60 dB in about 19 s at A0, 11 s at C4, 4 s at C6 and
/// 1 s at C8.
const LOSSES: Losses = Losses { internal_loss_factor: 3.0e-4, bridge_admittance_s_kg: 5.0e-4, tangent: None };

/// Widest detuning in a unison, cents (tuners leave unisons within about 1-2 cents).
const UNISON_SPREAD_CENTS: f64 = 1.0;

/// Output level (see [`Level`]). The ringing at velocity 0.7 is aimed at -28 dBFS.
/// The loudest touch peaks some 24 dB above that ringing in the middle (11 dB of
/// it the touch: velocity 1 strikes 3.6 times as fast), so the middle could ring
/// at -25 dBFS at most; the bass, panned left, peaks 2 to 2.6 dB higher in that
/// channel. -28 keeps the middle near its most and the bass (capped from A0 to
/// C#2, ringing at -30.7 to -28.3 dBFS) within 3 dB of it.
///
/// Relative to the peak, the ringing is flat near -24 dB from C2 to C5 and falls
/// away in the treble (-31 dB at C6, -54 dB at C7, -67 dB at C8): the heavy
/// hammer stays on the string for more and more of a period, so its push on the
/// bridge during contact sets the peak while less and less of its energy is left
/// ringing. From C5 up the peak ceiling caps the gain and the ringing falls short
/// of the target: -29.7 dBFS at F5, -31 at G5, -35.5 at C6, -54 at C7, -59 to -73
/// above it (the fit is then rough, 12 dB off at D#7, but the cap decides). The
/// peak excess follows the real peak within 0.3 dB where the cap applies (it is
/// up to 1 dB high around the 2-3 string break, where the cap does not apply).
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -28.0,
    ring_db: Table(&[
        (21, -26.5),
        (36, -24.4),
        (48, -23.2),
        (60, -24.0),
        (72, -26.3),
        (84, -30.7),
        (96, -54.3),
        (108, -66.9),
    ]),
    peak_excess_db: Table(&[(21, -0.2), (29, 0.5), (40, 0.1), (76, -0.95), (108, -0.95)]),
};

/// Number of strings of a key.
pub(super) fn strings_per_key(midi_key: u8) -> usize {
    if midi_key <= LAST_SINGLE_KEY {
        1
    } else if midi_key <= LAST_WOUND_KEY {
        2
    } else {
        3
    }
}

/// The whole hammer's felt law as built, before voicing.
pub(super) fn felt_law(midi_key: u8) -> ContactLaw {
    ContactLaw { stiffness: FELT_STIFFNESS.log(midi_key), exponent: FELT_EXPONENT.linear(midi_key) }
}

pub(crate) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let strings = strings_per_key(midi_key);
    let length_m = LENGTH_M.log_extended(midi_key);
    let core_m = CORE_DIAMETER_M.log_extended(midi_key);
    let (mass, outer_diameter_m, mass_per_length_kg_m) = if midi_key <= LAST_WOUND_KEY {
        let mu = WOUND_COURSE_MASS_KG_M.log_extended(midi_key) / strings as f64;
        (Mass::PerLengthKgM(mu), Some(WRAP_DIAMETER_M.log_extended(midi_key)), mu)
    } else {
        let mass = Mass::SolidWire { diameter_m: core_m, density_kg_m3: STEEL_DENSITY_KG_M3 };
        (mass, None, wire_mass_per_length_kg_m(core_m, STEEL_DENSITY_KG_M3))
    };
    let specs = unison_cents(midi_key, strings, UNISON_SPREAD_CENTS, voicing)
        .into_iter()
        .map(|cents| {
            let spec = StringSpec {
                length_m,
                tuning: Tuning::FirstPartialHz(detuned_hz(midi_key, cents)),
                mass,
                stiffness: Stiffness::YoungsModulus { modulus_pa: STEEL_MODULUS_PA, bending_diameter_m: core_m },
                damping: Damping::UniformQ(1.0), // replaced by with_losses
                max_frequency_hz,
                outer_diameter_m,
            };
            with_losses(spec, &LOSSES, voicing.damping)
        })
        .collect();

    let f1_hz = key_frequency_hz(midi_key);
    let tension_n = flexible_tension_n(length_m, mass_per_length_kg_m, f1_hz);
    let n = strings as f64;
    let hammer_mass_kg = HAMMER_MASS_KG.linear_extended(midi_key);
    let strike_ratio = STRIKE_RATIO.linear(midi_key);
    let peak_n = struck_peak_n(
        n * (tension_n * mass_per_length_kg_m).sqrt(),
        n * tension_n,
        length_m,
        strike_ratio,
        hammer_mass_kg,
        TOUCH.max,
    );
    KeyDesign {
        midi_key,
        strings: specs,
        struck: 0..strings,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        exciter: ExciterDesign::Hammer {
            mass_kg: hammer_mass_kg * voicing.hammer_mass,
            law: voiced_law(felt_law(midi_key), voicing),
            position: voiced_position(strike_ratio, voicing),
        },
        damper: (midi_key <= LAST_DAMPED_KEY).then(|| {
            // 60 dB in 0.45 s at A0 shortening to 0.15 s at F#6.
            let t = (midi_key - KEYS.start()) as f64 / (LAST_DAMPED_KEY - KEYS.start()) as f64;
            damper(0.45 * (0.15f64 / 0.45).powf(t), 2.0e-3, f1_hz, 0.015)
        }),
        gain_per_n: LEVEL.gain_per_n(midi_key, peak_n, pan(midi_key, KEYS)),
        pan: pan(midi_key, KEYS),
    }
}

#[cfg(test)]
mod tests {
    use super::super::common::DECAY_60_DB;
    use super::*;

    #[test]
    fn c2_c4_c7_hammers_have_the_chaigne_askenfelt_felt() {
        for (key, stiffness, exponent) in [(36, 4.0e8, 2.3), (60, 4.5e9, 2.5), (96, 1.0e12, 3.0)] {
            let d = design(&Voicing::default(), key, 20_000.0);
            let ExciterDesign::Hammer { law, .. } = d.exciter else { panic!("not a hammer") };
            assert!((law.stiffness / stiffness - 1.0).abs() < 1e-12, "{key}: {law:?}");
            assert!((law.exponent - exponent).abs() < 1e-12, "{key}: {law:?}");
        }
        // Held beyond C2 and C7.
        assert_eq!(felt_law(21), felt_law(36));
        assert_eq!(felt_law(108), felt_law(96));
    }

    #[test]
    fn strings_per_note_follow_the_broadwood() {
        let count = |key| design(&Voicing::default(), key, 20_000.0).strings.len();
        assert_eq!(count(24), 1); // C1
        assert_eq!(count(36), 1); // C2
        assert_eq!(count(48), 2); // C3
        assert_eq!(count(60), 3); // C4
        let counts: Vec<usize> = KEYS.map(strings_per_key).collect();
        assert_eq!(counts.iter().filter(|&&n| n == 1).count(), 17);
        assert_eq!(counts.iter().filter(|&&n| n == 2).count(), 13);
        assert_eq!(counts.iter().filter(|&&n| n == 3).count(), 58);
    }

    #[test]
    fn c_strings_match_the_table() {
        // Tension per string from Table 1 (T/L times L over the strings), within 1.5 %.
        for (key, tension_n) in [(24, 819.0), (36, 1155.0), (48, 875.0), (60, 684.0), (84, 635.0), (108, 643.0)] {
            let d = design(&Voicing::default(), key, 20_000.0);
            let s = d.strings[d.strings.len() / 2].build().unwrap();
            assert!((s.tension_n / tension_n - 1.0).abs() < 0.015, "{key}: {} N", s.tension_n);
        }
    }

    #[test]
    fn voicing_scales_the_hammer() {
        let plain = design(&Voicing::default(), 60, 20_000.0);
        let voicing = Voicing { hammer_mass: 2.0, hammer_stiffness: 0.5, strike_position: 0.5, ..Voicing::default() };
        let voiced = design(&voicing, 60, 20_000.0);
        let (
            ExciterDesign::Hammer { mass_kg: m0, law: l0, position: p0 },
            ExciterDesign::Hammer { mass_kg, law, position },
        ) = (plain.exciter, voiced.exciter)
        else {
            panic!("not a hammer")
        };
        assert!((mass_kg / m0 - 2.0).abs() < 1e-12);
        assert!((law.stiffness / l0.stiffness - 0.5).abs() < 1e-12);
        assert_eq!(law.exponent, l0.exponent);
        assert!((position / p0 - 0.5).abs() < 1e-12);
        assert!((m0 - 9.0e-3).abs() < 1e-12);

        // A harder exponent keeps the force at 0.5 mm and hardens the felt beyond it.
        let voiced = design(&Voicing { hammer_exponent: 1.2, ..Voicing::default() }, 60, 20_000.0);
        let ExciterDesign::Hammer { law, .. } = voiced.exciter else { panic!("not a hammer") };
        assert!((law.exponent - 3.0).abs() < 1e-12);
        assert!((law.force_n(0.5e-3) / l0.force_n(0.5e-3) - 1.0).abs() < 1e-12);
        assert!(law.force_n(1.0e-3) > 1.1 * l0.force_n(1.0e-3));
    }

    #[test]
    fn the_top_keys_have_no_dampers() {
        assert_eq!(KEYS.filter(|&k| design(&Voicing::default(), k, 20_000.0).damper.is_none()).count(), 18);
        // A released A0 dies by 60 dB in under half a second, a released C6 faster.
        let decay_60_db_s = |key: u8| {
            let d = design(&Voicing::default(), key, 20_000.0).damper.unwrap();
            DECAY_60_DB / (d.rate_s + d.rate_per_hz_s * key_frequency_hz(key))
        };
        assert!((0.3..=0.5).contains(&decay_60_db_s(21)));
        assert!(decay_60_db_s(84) < 0.25);
    }
}
