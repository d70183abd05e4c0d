//! The fortepiano: a Viennese grand after Anton Walter, c. 1795 (Germanisches
//! Nationalmuseum MINe 109: compass FF-g''', knee levers lifting the dampers,
//! triple stringing in the treble), each key's strings and hammer read from its
//! scale, `engine/data/fortepiano-scale.csv`.
//!
//! The scale is derived by `cargo xtask piano-scale` under the same rules as the
//! piano's (xtask/src/piano_scale/; the file's header lists them): plain brass
//! in the bass (F1-B2), soft iron above, pairs of strings to E5 and triplets from
//! F5, the total impedance of a note's strings kept smooth through both breaks
//! (its largest step between neighbours is 7 %, a wire-size change). No measured
//! string table of a Walter could be found, so its lengths and gauges are
//! assumptions, flagged as such in the file: iron at C5 is 275 mm long, halving
//! each octave from C4 up, and the strings run at 37 to 116 N, a sixth to a
//! seventeenth of the piano's; a note's total impedance is 0.4 to 1.2 N s/m, about
//! a tenth of the piano's at the same key.
//!
//! The hammers are wood covered with layers of leather: 3 g in the bass to 1.2 g
//! in the treble, a quarter to a fifth of the piano's (assumed). The seed
//! (Euphonics 12.2) says only that leather's nonlinearity is "even more extreme"
//! than the C7 felt's (alpha = 3.0). No force-compression measurement of leather
//! hammers was found, so the law is an assumption: alpha from 3.3 in the bass to
//! 3.7 in the treble (the piano hammers Hall & Askenfelt measured ranged from 1.5
//! to 3.5), and K such that the leather presses as hard as the C7 felt at 0.1 mm,
//! the soft grain surface, and harder beyond (1.6 times at 0.5 mm in the bass, 3
//! times in the treble).
//!
//! Losses, dampers and touch (assumptions too): a thin, harpsichord-like
//! soundboard, its bridge admittance Re Y = 5e-3 s/kg as the harpsichord's here (a
//! drive-point impedance of 200 N s/m; the piano's is 2000), brass's internal
//! friction 5e-4 and iron's 3e-4, so that a string's fundamental dies by 60 dB in
//! about 22 s at F1, 5.5 s at C4, 3.2 s at C6 and 2.5 s at G6 (about half the
//! piano's in the middle); dampers on every key (Walter's knee lever lifts them
//! all), quicker than the piano's; hammer speeds up to 4 m/s, as the shallow, light
//! Viennese key does not throw the hammer as fast as a modern action.

use std::ops::RangeInclusive;
use std::sync::OnceLock;

use super::common::{FELT_HYSTERESIS, Level, Losses, Table, damper, pan};
use super::scale::Scale;
use super::{DamperDesign, KeyDesign, TouchRange, VelocityCurve, Voicing, key_frequency_hz};

pub(super) const KEYS: RangeInclusive<u8> = 29..=91;

/// Hammer speeds from pianissimo to fortissimo, m/s (assumed: a Viennese key
/// falls about 6 mm, against a modern key's 10, and is far lighter).
pub(super) const TOUCH: TouchRange =
    TouchRange::Speed { min_m_s: 0.1, max_m_s: TOP_SPEED_M_S, curve: VelocityCurve::LogPower(1.0) };
/// The hardest touch: the fastest the exciter meets the string, m/s.
const TOP_SPEED_M_S: f64 = 4.0;

/// A soundboard bridge of Re Y = 5e-3 s/kg, and the wire's internal friction.
const BRIDGE_ADMITTANCE_S_KG: f64 = 5.0e-3;
const BRASS_LOSSES: Losses =
    Losses { internal_loss_factor: 5.0e-4, bridge_admittance_s_kg: BRIDGE_ADMITTANCE_S_KG, tangent: None };
const IRON_LOSSES: Losses =
    Losses { internal_loss_factor: 3.0e-4, bridge_admittance_s_kg: BRIDGE_ADMITTANCE_S_KG, tangent: None };

/// Output level (see [`Level`]). The ringing at the level touch (velocity 0.7) is aimed at -28 dBFS,
/// as the piano's. Relative to the loudest touch's peak it is flat near -22.5 dB
/// from F1 to C4 (the peak 22.5 dB above, 10 dB of it the touch: velocity 1
/// strikes 3 times as fast), then falls away as the strings grow light against
/// the hammer (a C5 course weighs 0.5 g against a 1.7 g hammer): -28.4 dB at C5,
/// -41.6 at C6. From A4 up the peak ceiling caps the gain and the ringing falls
/// short of the target: -29.6 dBFS at A#4, -31.4 at C5, -46 at C6, -48 at G6.
/// Measured on every key with the scale of engine/data/fortepiano-scale.csv: the
/// fit holds the ringing of every uncapped key within 0.2 dB, and the peak excess
/// lies 0 to 0.35 dB above the real peak wherever the cap applies (loudest peaks
/// -1.5 to -1.9 dBFS).
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -28.0,
    ring_db: Table(&[
        (29, -22.7),
        (36, -22.4),
        (44, -22.1),
        (52, -22.6),
        (60, -23.6),
        (64, -24.3),
        (68, -25.2),
        (72, -28.4),
        (76, -31.8),
        (80, -35.9),
        (84, -41.6),
        (88, -45.2),
        (91, -44.3),
    ]),
    peak_excess_db: Table(&[
        (29, 0.2),
        (34, -0.05),
        (40, 0.6),
        (48, 0.4),
        (56, -0.1),
        (66, 0.05),
        (76, 0.2),
        (84, -0.05),
        (91, -0.3),
    ]),
};

/// The fortepiano's scale, parsed once.
pub(super) fn scale() -> &'static Scale {
    static SCALE: OnceLock<Scale> = OnceLock::new();
    SCALE.get_or_init(|| {
        Scale::compiled_in("engine/data/fortepiano-scale.csv", include_str!("../../data/fortepiano-scale.csv"))
    })
}

pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let row = scale().row(midi_key).expect("the fortepiano's scale holds every key of its compass");
    let losses = if row.material == "brass" { &BRASS_LOSSES } else { &IRON_LOSSES };
    let t = (midi_key - KEYS.start()) as f64 / (KEYS.end() - KEYS.start()) as f64;
    KeyDesign {
        midi_key,
        strings: row.string_specs(voicing, losses, max_frequency_hz),
        struck: 0..row.strings,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        resistive_bridge: losses.resistive_bridge(voicing),
        losses: *losses,
        exciter: row.hammer(voicing),
        // 60 dB in 0.35 s at F1 shortening to 0.12 s at G6: light, quick dampers.
        // A Viennese action's dampers are light wooden levers with a
        // leather or cloth pad: a third of a grand's head.
        damper: Some(DamperDesign {
            head_mass_kg: 5.0e-3,
            ..damper(0.35 * (0.12f64 / 0.35).powf(t), 2.0e-3, key_frequency_hz(midi_key), 0.012)
        }),
        gain_per_n: LEVEL.gain_per_n(midi_key, row.struck_peak_n(TOP_SPEED_M_S), pan(midi_key, KEYS)),
        ring_gain_per_n: LEVEL.ring_gain_per_n(midi_key, row.struck_peak_n(TOP_SPEED_M_S)),
        pan: pan(midi_key, KEYS),
        // Leather's hysteresis is unmeasured too (as its law): taken as the felt's.
        hammer_hysteresis: Some(FELT_HYSTERESIS),
        strike_shares: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::common::DECAY_60_DB;
    use super::super::{InstrumentKind, piano};
    use super::*;
    use crate::design::ExciterDesign;
    use crate::exciter::hammer::contact::ContactLaw;

    /// The C7 felt (Chaigne & Askenfelt 1994).
    const C7_FELT: ContactLaw = ContactLaw { stiffness: 1.0e12, exponent: 3.0 };

    fn law(midi_key: u8) -> ContactLaw {
        let ExciterDesign::Hammer { law, .. } = design(&Voicing::default(), midi_key, 20_000.0).exciter else {
            panic!("not a hammer")
        };
        law
    }

    #[test]
    fn the_compass_is_walters_ff_to_g3() {
        assert_eq!(KEYS, 29..=91);
        assert_eq!(InstrumentKind::Fortepiano.key_range(), KEYS);
        assert_eq!(scale().keys(), KEYS);
        let rows = scale().rows();
        assert_eq!((rows[0].note.as_str(), rows[rows.len() - 1].note.as_str()), ("F1", "G6"));
    }

    #[test]
    fn plain_brass_bass_iron_above_pairs_then_triplets() {
        for r in scale().rows() {
            assert!(!r.is_wound(), "{r}");
            assert_eq!(r.material, if r.midi_key <= 47 { "brass" } else { "iron" }, "{r}");
            assert_eq!(r.strings, if r.midi_key <= 76 { 2 } else { 3 }, "{r}");
            assert_eq!(design(&Voicing::default(), r.midi_key, 20_000.0).strings.len(), r.strings);
            // Brass below 600 MPa, iron below 700 MPa.
            let stress_pa = r.tension_n / (std::f64::consts::PI * r.core_diameter_m.powi(2) / 4.0);
            let limit_pa = if r.material == "brass" { 0.6e9 } else { 0.7e9 };
            assert!(stress_pa < limit_pa, "{r}: {stress_pa} Pa");
        }
    }

    #[test]
    fn the_leather_is_steeper_and_harder_than_the_c7_felt() {
        for key in KEYS {
            let leather = law(key);
            assert!(leather.exponent > C7_FELT.exponent + 0.25, "{key}: {leather:?}");
            // As hard as the felt at 0.1 mm, harder beyond.
            assert!((leather.force_n(1.0e-4) / C7_FELT.force_n(1.0e-4) - 1.0).abs() < 1e-3, "{key}");
            assert!(leather.force_n(0.3e-3) > 1.3 * C7_FELT.force_n(0.3e-3), "{key}");
            // And far harder than the piano's felt at the same key (15 times in
            // the bass, 3 times in the treble).
            let felt = piano::scale().row(key).unwrap().contact_law();
            assert!(leather.force_n(0.3e-3) > 2.5 * felt.force_n(0.3e-3), "{key}");
        }
        // Steeper up the keyboard, as the layers thin.
        assert!(law(91).exponent > law(29).exponent);
    }

    #[test]
    fn strings_and_hammers_are_lighter_than_the_pianos() {
        for key in KEYS {
            let (ours, theirs) = (scale().row(key).unwrap(), piano::scale().row(key).unwrap());
            assert!(ours.total_impedance_ns_m < 0.2 * theirs.total_impedance_ns_m, "{key}");
            assert!(ours.tension_n < 0.2 * theirs.tension_n, "{key}");
            assert!(ours.hammer_mass_kg < 0.3 * theirs.hammer_mass_kg, "{key}");
            assert!((1.2e-3 - 1e-9..=3.0e-3 + 1e-9).contains(&ours.hammer_mass_kg), "{key}");
        }
    }

    #[test]
    fn total_impedance_runs_smoothly() {
        let z = |k: u8| -> f64 {
            let d = design(&Voicing::default(), k, 20_000.0);
            d.strings.iter().map(|s| s.build().unwrap().impedance_ns_m()).sum()
        };
        for k in KEYS.skip(1) {
            let step = (z(k) / z(k - 1) - 1.0).abs();
            assert!(step < 0.1, "keys {} and {k}: {:.1} %", k - 1, 100.0 * step);
        }
    }

    #[test]
    fn every_key_has_a_quick_damper() {
        for key in KEYS {
            let d = design(&Voicing::default(), key, 20_000.0).damper.expect("a damper");
            let decay_60_db_s = DECAY_60_DB / (d.rate_s + d.rate_per_hz_s * key_frequency_hz(key));
            assert!(decay_60_db_s <= 0.35 + 1e-9, "{key}: {decay_60_db_s} s");
        }
    }
}
