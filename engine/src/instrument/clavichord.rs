//! The clavichord: a Hubert-type instrument, C2-E6, double-strung in brass, its
//! strings struck and held by brass tangents (Euphonics 12.2.3; physics
//! reference 1.6, 1.7 and 4).
//!
//! Compass: the Way & Ducornet copy of a Hubert that Fletcher & Beebe describe
//! starts at C2; the 2001 Hubert stringing schedule runs to e''' (its BB, a
//! short-octave string, is left out), so C2-E6 chromatic.
//!
//! Strings (brass, rho = 8500 kg/m^3, E = 1.0e11 Pa), gauges from that schedule:
//! red brass 0.65 mm at C2 and 0.56 mm at C#2-D2, then yellow brass 0.52, 0.44,
//! 0.40, 0.36, 0.30 and 0.27 mm in steps of about half an octave (the schedule
//! names the gauges but not where each one starts), and 0.25 mm from c#'' to e'''.
//! Speaking lengths (tangent to bridge): c'' = 270 mm halving every octave above
//! (a brass c'' scaling, 680 MPa), foreshortened below through c' = 0.50 m,
//! c = 0.70 m and C = 0.82 m, which puts D2 at 0.80 m as in the lab's K2 case.
//!
//! The tangent comes to rest 2 mm into a 0.8 m string (Thwaites & Fletcher via
//! Woodhouse); on shorter strings it goes in by 2 mm x sqrt(L / 0.8 m), which keeps
//! the stretch D^2 / L, and so the pitch rise, the same, but never less than 1 mm.
//!
//! Of the voicing only `damping` and `unison_detune` apply: a tangent has no
//! mass, felt or position to voice (it always becomes the string's end).

use std::ops::RangeInclusive;

use super::common::{
    BRASS_DENSITY_KG_M3, BRASS_MODULUS_PA, Level, Losses, Table, TangentLeak, damper, detuned_hz, flexible_tension_n,
    pan, unison_cents, wire_mass_per_length_kg_m, with_losses,
};
use super::{ExciterDesign, KeyDesign, TouchRange, Voicing, key_frequency_hz};
use crate::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

pub(super) const KEYS: RangeInclusive<u8> = 36..=88;

/// Tangent speeds from the softest to the strongest touch, m/s: at 0.05 m/s a
/// 2 mm tangent takes some 50 ms to arrive, at 1 m/s a few ms, the extremes of
/// Woodhouse's Fig. 30 (0.5 m/s being his typical stroke).
pub(super) const TOUCH: TouchRange = TouchRange { min: 0.05, max: 1.0 };

const STRINGS: usize = 2;

/// Speaking length, m.
const LENGTH_M: Table = Table(&[(36, 0.82), (48, 0.70), (60, 0.50), (72, 0.27), (88, 0.107_16)]);

/// Final tangent displacement on a 0.8 m string, m, and its bounds.
const TANGENT_DISPLACEMENT_M: f64 = 2.0e-3;
const MIN_TANGENT_DISPLACEMENT_M: f64 = 1.0e-3;

/// Brass is lossier than steel inside (eta_E 5e-4, an assumption: no figure was
/// found); the small soundboard is a lively bridge, Re Y = 5e-3 s/kg. The
/// tangent, key and finger seen by each string, 15 g on 60 N s/m, let the low
/// partials leak into the felted part: the D2 string's fundamental gets Q
/// near 270 and its 3rd partial near 800, the low-Q bass of Euphonics Fig. 31 (and
/// the K2 case, which starts at Q = 300), while partials above about 500 Hz keep
/// the harpsichord-like Q of the other losses.
const LOSSES: Losses = Losses {
    internal_loss_factor: 5.0e-4,
    bridge_admittance_s_kg: 5.0e-3,
    tangent: Some(TangentLeak { mass_kg: 0.015, resistance_ns_m: 60.0 }),
};

/// Widest detuning of the pair, cents.
const UNISON_SPREAD_CENTS: f64 = 1.0;

/// Output level (see [`Level`]). The clavichord is the quietest of the four: its
/// ringing at velocity 0.7 is aimed at -30 dBFS, 2 to 6 dB under the others'.
///
/// Relative to the peak, the ringing falls from -19.5 dB at C2 to -27.3 dB at E6
/// (within 0.3 dB of every key); the peak runs 0.3 dB (bass) to 2.4 dB (treble)
/// under the estimate. The loudest touch peaks at -9.5 to -2.5 dBFS: the cap
/// never applies.
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -30.0,
    ring_db: Table(&[(36, -19.5), (48, -20.1), (60, -22.0), (72, -23.3), (88, -27.3)]),
    peak_excess_db: Table(&[(36, -0.3), (44, -0.5), (62, -1.6), (78, -2.1), (88, -2.3)]),
};

/// The gauges, mm, each with the last key it is strung on.
const GAUGES: [(u8, f64); 9] =
    [(36, 0.65), (38, 0.56), (44, 0.52), (50, 0.44), (56, 0.40), (62, 0.36), (68, 0.30), (72, 0.27), (88, 0.25)];

/// Wire diameter, m.
fn gauge_m(midi_key: u8) -> f64 {
    let (_, mm) = GAUGES.into_iter().find(|&(last, _)| midi_key <= last).unwrap_or(GAUGES[GAUGES.len() - 1]);
    mm * 1e-3
}

pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let length_m = LENGTH_M.log_extended(midi_key);
    let diameter_m = gauge_m(midi_key);
    let specs = unison_cents(midi_key, STRINGS, UNISON_SPREAD_CENTS, voicing)
        .into_iter()
        .map(|cents| {
            let spec = StringSpec {
                length_m,
                tuning: Tuning::FirstPartialHz(detuned_hz(midi_key, cents)),
                mass: Mass::SolidWire { diameter_m, density_kg_m3: BRASS_DENSITY_KG_M3 },
                stiffness: Stiffness::YoungsModulus { modulus_pa: BRASS_MODULUS_PA, bending_diameter_m: diameter_m },
                damping: Damping::UniformQ(1.0), // replaced by with_losses
                max_frequency_hz,
                outer_diameter_m: None,
            };
            with_losses(spec, &LOSSES, voicing.damping)
        })
        .collect();

    let displacement_m =
        (TANGENT_DISPLACEMENT_M * (length_m / 0.8).sqrt()).clamp(MIN_TANGENT_DISPLACEMENT_M, TANGENT_DISPLACEMENT_M);
    let f1_hz = key_frequency_hz(midi_key);
    let mu = wire_mass_per_length_kg_m(diameter_m, BRASS_DENSITY_KG_M3);
    let tension_n = flexible_tension_n(length_m, mu, f1_hz);
    // The tangent's step to V0 reaches the bridge as a wave of force Z0 V0, doubled
    // by the reflection there, and the string's final tilt adds T D / L. The
    // tangent's quick deceleration and the string's dispersion smear that step:
    // the peak comes out at 0.72 of the sum on every key (fitted).
    let peak_per_string_n = 0.72 * (2.0 * (tension_n * mu).sqrt() * TOUCH.max + tension_n * displacement_m / length_m);
    KeyDesign {
        midi_key,
        strings: specs,
        struck: 0..STRINGS,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        exciter: ExciterDesign::Tangent { displacement_m, stretch_per_m2: 0.0 },
        // The listing felt takes over as soon as the tangent leaves: 60 dB in 0.1 s.
        damper: Some(damper(0.1, 1.0e-2, f1_hz, 0.005)),
        gain_per_n: LEVEL.gain_per_n(midi_key, STRINGS as f64 * peak_per_string_n, pan(midi_key, KEYS)),
        pan: pan(midi_key, KEYS),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn d2_is_the_k2_string_with_a_low_q_fundamental() {
        let d = design(&Voicing::default(), 38, 20_000.0);
        assert_eq!(d.strings.len(), 2);
        let s = d.strings[0].build().unwrap();
        assert!((s.length_m - 0.8).abs() < 0.01);
        assert!((200.0..400.0).contains(&s.modes[0].q), "{}", s.modes[0].q);
        // The leak fades with frequency: partials above 500 Hz are several times less damped.
        let high = s.modes.iter().find(|m| m.frequency_hz() > 500.0).unwrap();
        assert!(high.q > 4.0 * s.modes[0].q, "{}", high.q);
        let ExciterDesign::Tangent { displacement_m, .. } = d.exciter else { panic!("not a tangent") };
        assert!((displacement_m - 2.0e-3).abs() < 0.02e-3);
    }

    #[test]
    fn brass_is_not_overstressed_and_the_damper_is_quick() {
        for key in KEYS {
            let d = design(&Voicing::default(), key, 20_000.0);
            let s = d.strings[0].build().unwrap();
            let stress_pa = s.tension_n / (std::f64::consts::PI * gauge_m(key).powi(2) / 4.0);
            assert!((50e6..720e6).contains(&stress_pa), "{key}: {stress_pa}");
            let damper = d.damper.unwrap();
            let rate = damper.rate_s + damper.rate_per_hz_s * key_frequency_hz(key);
            assert!((rate * 0.1 - super::super::common::DECAY_60_DB).abs() < 1e-9);
        }
    }
}
