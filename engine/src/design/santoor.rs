//! The santoor: a chromatic E3-F6 (the Persian santur's compass, Naini 2007) of
//! steel courses of 4 strings, struck near the bridge by light mallets; no dampers.
//!
//! Every string is 0.5 mm music wire, the gauge of the santoor string of
//! Euphonics 12.2. Lengths are chosen for the working stress, sigma = rho (2 L f)^2:
//! 40 % of a 2 GPa breaking stress at E3 rising to 60 % at F6, so the bass
//! strings are slack enough to be long (0.97 m) and the treble strings as short as
//! a santoor's (0.14 m). A4 comes out at 0.40 m and 0.97 GPa, Woodhouse's string.
//!
//! The mallet values are Woodhouse's single-string modelling values: an
//! equivalent point mass of 3 g (bass) to 1 g (treble) per string and a linear
//! contact spring of 1e6 N/m per string (the S1 case). The design gives the
//! course's totals (4 times those), which the runtime shares among the 4 strings,
//! so each string is struck exactly as in his simulations (his point that a real
//! mallet of about 10 g on a course of 4 acts like his 1 g on one string). The
//! spring is the same in bass and treble: a player uses one pair of mallets.

use std::ops::RangeInclusive;

use super::common::{
    Level, Losses, STEEL_DENSITY_KG_M3, STEEL_MODULUS_PA, Table, detuned_hz, flexible_tension_n, pan, struck_peak_n,
    unison_cents, voiced_law, voiced_position, wire_mass_per_length_kg_m, with_losses,
};
use super::{ExciterDesign, KeyDesign, TouchRange, VelocityCurve, Voicing, key_frequency_hz};
use crate::exciter::hammer::contact::ContactLaw;
use crate::string::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

pub(super) const KEYS: RangeInclusive<u8> = 52..=89;

/// Mallet speeds from a soft touch to a hard stroke, m/s (Woodhouse's examples
/// use 1 m/s; a wrist stroke with a light mallet reaches a few m/s).
pub(crate) const TOUCH: TouchRange =
    TouchRange::Speed { min_m_s: 0.3, max_m_s: TOP_SPEED_M_S, curve: VelocityCurve::LogPower(1.0) };
/// The hardest touch: the fastest the exciter meets the string, m/s.
const TOP_SPEED_M_S: f64 = 4.0;

const STRINGS: usize = 4;
const WIRE_DIAMETER_M: f64 = 0.5e-3;
/// Breaking stress of music wire, Pa, and the fraction of it each string works at.
const BREAKING_STRESS_PA: f64 = 2.0e9;
const STRESS_FRACTION: Table = Table(&[(52, 0.40), (89, 0.60)]);
/// Strike position from the bridge: about a tenth of the length (Euphonics 12.2),
/// a little further in the bass.
const STRIKE_POSITION: Table = Table(&[(52, 0.13), (89, 0.10)]);
/// Equivalent point mass per string, kg.
const MALLET_MASS_PER_STRING_KG: Table = Table(&[(52, 3.0e-3), (89, 1.0e-3)]);
/// Contact spring per string, N/m (alpha = 1).
const MALLET_STIFFNESS_PER_STRING_N_M: f64 = 1.0e6;

/// Steel's internal friction and a bridge of Re Y = 1e-3 s/kg on a thin
/// soundboard (the engine's default; an A4 string's fundamental gets Q near 2000,
/// a 60 dB decay of about 10 s, as a santoor rings on).
const LOSSES: Losses = Losses { internal_loss_factor: 3.0e-4, bridge_admittance_s_kg: 1.0e-3, tangent: None };

/// Widest detuning in a course, cents.
const UNISON_SPREAD_CENTS: f64 = 2.0;

/// Output level (see [`Level`]). The ringing at the level touch (velocity 0.7) is aimed at -26 dBFS.
/// Up to A4 the loudest touch peaks 22 to 23 dB above that ringing, so the middle
/// could ring some 1.5 dB louder before meeting the peak ceiling, but the capped
/// treble would then fall out of 3 dB of it three keys sooner.
///
/// Relative to the peak, the ringing falls from -20 dB at E3 to -25 dB at E5 and
/// -33 dB at F6 (in steps of about 1.5 dB every third key above A4, which the fit
/// smooths over, within 0.9 dB), as the short treble strings ring off faster.
/// From D5 up the peak ceiling caps the gain and the ringing falls short of the
/// target: -28.5 dBFS at E5, -30 at G5, -32 at A#5, -34 at C6, -36 from D#6.
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -26.0,
    ring_db: Table(&[(52, -19.8), (60, -20.4), (68, -21.9), (76, -24.9), (84, -29.6), (89, -32.6)]),
    peak_excess_db: Table(&[(52, 0.4), (72, 0.3), (89, 0.0)]),
};

/// Speaking length, m.
fn length_m(midi_key: u8) -> f64 {
    let stress_pa = STRESS_FRACTION.linear(midi_key) * BREAKING_STRESS_PA;
    (stress_pa / STEEL_DENSITY_KG_M3).sqrt() / (2.0 * key_frequency_hz(midi_key))
}

pub(crate) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let length_m = length_m(midi_key);
    let specs = unison_cents(midi_key, STRINGS, UNISON_SPREAD_CENTS, voicing)
        .into_iter()
        .map(|cents| {
            let spec = StringSpec {
                length_m,
                tuning: Tuning::FirstPartialHz(detuned_hz(midi_key, cents)),
                mass: Mass::SolidWire { diameter_m: WIRE_DIAMETER_M, density_kg_m3: STEEL_DENSITY_KG_M3 },
                stiffness: Stiffness::YoungsModulus {
                    modulus_pa: STEEL_MODULUS_PA,
                    bending_diameter_m: WIRE_DIAMETER_M,
                },
                damping: Damping::UniformQ(1.0), // replaced by with_losses
                max_frequency_hz,
                outer_diameter_m: None,
            };
            with_losses(spec, &LOSSES, voicing.damping)
        })
        .collect();

    let n = STRINGS as f64;
    let mu = wire_mass_per_length_kg_m(WIRE_DIAMETER_M, STEEL_DENSITY_KG_M3);
    let tension_n = flexible_tension_n(length_m, mu, key_frequency_hz(midi_key));
    let mallet_mass_kg = n * MALLET_MASS_PER_STRING_KG.log(midi_key);
    let position = STRIKE_POSITION.linear(midi_key);
    let peak_n =
        struck_peak_n(n * (tension_n * mu).sqrt(), n * tension_n, length_m, position, mallet_mass_kg, TOP_SPEED_M_S);
    let law = ContactLaw { stiffness: n * MALLET_STIFFNESS_PER_STRING_N_M, exponent: 1.0 };
    KeyDesign {
        midi_key,
        strings: specs,
        struck: 0..STRINGS,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        resistive_bridge: LOSSES.resistive_bridge(voicing),
        losses: LOSSES,
        exciter: ExciterDesign::Hammer {
            mass_kg: mallet_mass_kg * voicing.hammer_mass,
            law: voiced_law(law, voicing),
            position: voiced_position(position, voicing),
        },
        damper: None,
        gain_per_n: LEVEL.gain_per_n(midi_key, peak_n, pan(midi_key, KEYS)),
        ring_gain_per_n: LEVEL.ring_gain_per_n(midi_key, peak_n),
        pan: pan(midi_key, KEYS),
        // Bare wooden mallets on steel: wood's loss per stroke is far below felt's
        // (the linear spring above is Woodhouse's elastic mallet), so none.
        hammer_hysteresis: None,
        strike_shares: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a4_is_woodhouses_string() {
        let d = design(&Voicing::default(), 69, 20_000.0);
        assert_eq!(d.strings.len(), 4);
        let s = d.strings[0].build().unwrap();
        assert!((s.length_m - 0.4).abs() < 0.01, "{}", s.length_m);
        assert!((s.tension_n - 191.0).abs() < 6.0, "{}", s.tension_n);
        assert!(d.damper.is_none());
    }

    #[test]
    fn stress_stays_within_40_to_60_percent_of_breaking() {
        for key in KEYS {
            let s = design(&Voicing::default(), key, 20_000.0).strings[1].build().unwrap();
            let stress = s.tension_n / (std::f64::consts::PI * WIRE_DIAMETER_M * WIRE_DIAMETER_M / 4.0);
            assert!((0.39..0.61).contains(&(stress / BREAKING_STRESS_PA)), "{key}: {stress}");
        }
    }

    #[test]
    fn mallets_are_3_g_to_1_g_per_string_on_a_linear_spring() {
        let mass = |key, voicing: &Voicing| match design(voicing, key, 20_000.0).exciter {
            ExciterDesign::Hammer { mass_kg, law, .. } => {
                assert_eq!(law.exponent, 1.0);
                assert!((law.stiffness - 4.0e6).abs() < 1e-6);
                mass_kg / 4.0
            }
            _ => panic!("not a mallet"),
        };
        assert!((mass(52, &Voicing::default()) - 3.0e-3).abs() < 1e-12);
        assert!((mass(89, &Voicing::default()) - 1.0e-3).abs() < 1e-12);
        assert!((mass(89, &Voicing { hammer_mass: 2.0, ..Voicing::default() }) - 2.0e-3).abs() < 1e-12);
    }
}
