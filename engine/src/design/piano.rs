//! The piano: the 88 keys of a grand of the Yamaha C5's size (2.00 m), each key's
//! strings and hammer read from its scale, `engine/data/piano-scale.csv`.
//!
//! The scale is derived by `cargo xtask piano-scale` (xtask/src/piano_scale/;
//! the file's header gives the rules). Its lengths are those of grands around
//! the C5's size (A0 a Yamaha C3's 1.40 m, C4-C5 a Steinway M's, from C6 up the
//! Broadwood's), the lowest plain strings held at C4's working stress down to
//! the break (D#3 1.08 m); its wound cores are sized for the inharmonicity the C5's
//! recordings show at A0, F#1 and A2, rising into the first plain string's. The
//! rest is Euphonics 12.2's Broadwood baby grand: the total impedance of its C
//! strings (Euphonics 12.2.1, Table 1), its stringing (17
//! single wound strings A0-C#2, 13 wound pairs D2-D3, 58 plain steel triplets
//! D#3-C8) and hammers, and the Chaigne & Askenfelt (1994) felt of the C2, C4
//! and C7 hammers. As the maker did (Euphonics 12.2, Figs. 8-10), the total
//! impedance of a note's strings runs smoothly along the keyboard and through
//! both string-count breaks: its largest step between neighbouring keys is 5.9 %
//! (a wire-size change at B7), where interpolating the strings' mass and
//! diameters alone drops it by about 35 % at D3-D#3. Wound strings take their
//! mass from core and wrap, their bending stiffness from the steel core alone.
//!
//! The Broadwood itself is kept as a scale of its own,
//! `engine/data/broadwood-scale.csv` (its C strings are Table 1's): the seed's
//! lab strikes its C strings ([`broadwood_design`]); no instrument plays it.
//!
//! What the scale does not hold is here: the losses, the dampers, the touch and
//! the output level.

use std::ops::RangeInclusive;
use std::sync::OnceLock;

use super::common::{FELT_HYSTERESIS, Level, Losses, Table, damper, pan};
use super::scale::Scale;
use super::{KeyDesign, TouchRange, VelocityCurve, Voicing, key_frequency_hz};

pub(super) const KEYS: RangeInclusive<u8> = 21..=108;

/// Hammer speeds from pianissimo to fortissimo (Boutillon 1988 measured 0.11 to
/// 6.83 m/s), m/s, and how velocity spreads over them: the speed in proportion
/// to velocity, 7 m/s at 127, never under 0.1 m/s (velocities 1 and 2).
///
/// What a velocity means is a convention between a keyboard and what it plays,
/// not a property of the piano. Grand pianos that record their players write
/// velocity as the log of the hammer's speed (Goebl's map for the Bosendorfer
/// SE, 52 + 25 log2 of the speed in m/s, and a fit to a Yamaha Disklavier's,
/// 57.96 + 71.3 log10: velocity 40 at 0.7 and 0.6 m/s, 124 at 7 and 8 m/s),
/// about 20 dB of speed between them. The recorded Yamaha C5 of `struck
/// compare` spreads its layers far less: its level is close to proportional
/// to velocity (at 12 notes from A0 to C7, re velocity 124: 13 at -20.8 dB,
/// 30 at -14.3, 40 at -10.7, 60 at -7.1, 92 at -4.6, 108 at -2.5; 20 log10
/// of the velocity ratio gives -19.6, -12.3, -9.8, -6.3, -2.6, -1.2), and so
/// is a hammer's sound to its speed (the felt's stiffening adds some 10 %).
/// The piano follows the recording, whose layers are how keyboard players
/// hear a sampled grand; the Touch controls reach a wider range.
pub(crate) const TOUCH: TouchRange =
    TouchRange::Speed { min_m_s: 0.1, max_m_s: TOP_SPEED_M_S, curve: VelocityCurve::Proportional };
/// The hardest touch: the fastest the exciter meets the string, m/s.
const TOP_SPEED_M_S: f64 = 7.0;

/// The felt as the piano's hammers are voiced: the stiffness K of the scale's
/// felts (Chaigne & Askenfelt's measured C2, C4 and C7 hammers) times this.
/// Heard against the recorded Yamaha C5 (`struck compare`, 30 notes at 4
/// velocities), the measured felts sound the partials above the fourth too
/// strongly: the early spectral centroid 1.53 times the recording's (median),
/// partials 1-12 9.9 dB off their levels. A third of the stiffness, as a
/// technician's needle softens a hammer, gives 1.20 times and 8.0 dB; the
/// felt's exponent, and so how it hardens as it is struck harder, is kept.
const FELT_VOICED: f64 = 0.3;

/// Keys above this have no damper (their strings ring short anyway).
const LAST_DAMPED_KEY: u8 = 90;

/// Losses of the strings: steel's internal friction (the engine's default) and a
/// soundboard bridge of Re Y = 5e-4 s/kg (a drive-point impedance of 2 kN s/m,
/// the order of a piano bridge's, about 10^3 N s/m at low frequencies:
/// Wogram's input impedance measurements, KTH "Five lectures"). A string's
/// fundamental then dies by 60 dB in about 19 s at A0, 11 s at C4, 4 s at C6 and
/// 1 s at C8.
const LOSSES: Losses = Losses { internal_loss_factor: 3.0e-4, bridge_admittance_s_kg: 5.0e-4, tangent: None };

/// Output level (see [`Level`]) of the bridge-force output: the ringing at
/// the level touch (1.96 m/s, velocity 36) is aimed at -28 dBFS. The loudest
/// touch peaks some 25 dB over that ringing in the middle, so the bass (panned
/// left, and peaking up to 2.6 dB higher in that channel) is held by the peak
/// ceiling a little under it, and from F#5 up the hammer's push on the bridge
/// during contact, not the tone, sets the peak and the ceiling caps the gain:
/// the ringing falls away there (-31.5 dBFS at F#5). The tables are measured
/// on every key, with the scale of engine/data/piano-scale.csv and the voiced
/// felt, by `measure_piano_level` (an ignored test in `design::common`): the
/// fit holds every key's ringing within 0.3 dB, and the peak excess lies 0 to
/// 0.3 dB over the real peak's. The microphones hear the piano as built
/// ([`super::InstrumentKind::heard_as_built`]): this evening is the
/// bridge-force output's alone.
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -28.0,
    ring_db: Table(&[
        (21, -27.4),
        (27, -25.7),
        (34, -24.7),
        (37, -24.8),
        (39, -24.1),
        (51, -23.9),
        (65, -25.5),
        (72, -27.0),
        (75, -28.3),
        (81, -32.6),
        (86, -38.1),
        (87, -40.2),
        (89, -43.3),
        (91, -47.7),
        (93, -54.2),
        (94, -64.8),
        (95, -73.1),
        (96, -63.9),
        (97, -60.9),
        (98, -59.0),
        (99, -58.0),
        (100, -58.7),
        (101, -57.7),
        (102, -58.4),
        (103, -60.9),
        (104, -62.4),
        (105, -66.0),
        (106, -68.5),
        (107, -72.1),
        (108, -78.1),
    ]),
    peak_excess_db: Table(&[
        (21, -1.04),
        (27, -0.43),
        (34, -0.37),
        (40, -0.75),
        (54, -2.04),
        (55, -1.81),
        (59, -1.48),
        (63, -1.49),
        (69, -1.81),
        (73, -1.54),
        (108, -1.30),
    ]),
};

/// The piano's scale, parsed once.
pub(super) fn scale() -> &'static Scale {
    static SCALE: OnceLock<Scale> = OnceLock::new();
    SCALE.get_or_init(|| Scale::compiled_in("engine/data/piano-scale.csv", include_str!("../../data/piano-scale.csv")))
}

/// The seed's Broadwood baby grand's scale, parsed once.
pub(super) fn broadwood_scale() -> &'static Scale {
    static SCALE: OnceLock<Scale> = OnceLock::new();
    SCALE.get_or_init(|| {
        Scale::compiled_in("engine/data/broadwood-scale.csv", include_str!("../../data/broadwood-scale.csv"))
    })
}

pub(crate) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    design_on(scale(), FELT_VOICED, voicing, midi_key, max_frequency_hz)
}

/// A key of the seed's Broadwood: the piano's design (losses, dampers, level)
/// on the Broadwood's strings and hammers, their felts as measured.
pub(crate) fn broadwood_design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    design_on(broadwood_scale(), 1.0, voicing, midi_key, max_frequency_hz)
}

/// A key on `scale`, its felts' stiffness times `felt`.
fn design_on(scale: &Scale, felt: f64, voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let row = scale.row(midi_key).expect("the piano's scales hold every key of its compass");
    let strings = row.strings;
    KeyDesign {
        midi_key,
        strings: row.string_specs(voicing, &LOSSES, max_frequency_hz),
        struck: 0..strings,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        resistive_bridge: LOSSES.resistive_bridge(voicing),
        losses: LOSSES,
        exciter: row.hammer(&Voicing { hammer_stiffness: voicing.hammer_stiffness * felt, ..*voicing }),
        damper: (midi_key <= LAST_DAMPED_KEY).then(|| {
            // 60 dB in 0.45 s at A0 shortening to 0.15 s at F#6.
            let t = (midi_key - KEYS.start()) as f64 / (LAST_DAMPED_KEY - KEYS.start()) as f64;
            damper(0.45 * (0.15f64 / 0.45).powf(t), 2.0e-3, key_frequency_hz(midi_key), 0.015)
        }),
        gain_per_n: LEVEL.gain_per_n(midi_key, row.struck_peak_n(TOP_SPEED_M_S), pan(midi_key, KEYS)),
        ring_gain_per_n: LEVEL.ring_gain_per_n(midi_key, row.struck_peak_n(TOP_SPEED_M_S)),
        pan: pan(midi_key, KEYS),
        hammer_hysteresis: Some(FELT_HYSTERESIS),
        strike_shares: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::common::DECAY_60_DB;
    use super::super::scale::ScaleRow;
    use super::*;
    use crate::design::ExciterDesign;
    use crate::string::StringModes;

    fn row(midi_key: u8) -> &'static ScaleRow {
        scale().row(midi_key).unwrap()
    }

    /// The strings a key builds (each detuned), with their tension and mass.
    fn built(midi_key: u8) -> Vec<StringModes> {
        design(&Voicing::default(), midi_key, 20_000.0).strings.iter().map(|s| s.build().unwrap()).collect()
    }

    /// The total impedance of the strings a key builds, N s/m.
    fn built_impedance_ns_m(midi_key: u8) -> f64 {
        built(midi_key).iter().map(StringModes::impedance_ns_m).sum()
    }

    /// The total impedance of the strings a key of the seed's Broadwood builds, N s/m.
    fn broadwood_impedance_ns_m(midi_key: u8) -> f64 {
        let d = broadwood_design(&Voicing::default(), midi_key, 20_000.0);
        d.strings.iter().map(|s| s.build().unwrap().impedance_ns_m()).sum()
    }

    /// Euphonics 12.2.1, Table 1: key, length m, tension per string N (T/L
    /// times L over the strings, a flexible string's), total impedance 2 f M.
    const BROADWOOD_TABLE: [(u8, f64, f64, f64); 8] = [
        (24, 1.013, 819.0, 12.36),
        (36, 0.925, 1155.0, 9.55),
        (48, 0.830, 875.0, 8.03),
        (60, 0.639, 684.0, 6.12),
        (72, 0.324, 626.0, 5.55),
        (84, 0.181, 635.0, 5.02),
        (96, 0.096, 645.0, 4.81),
        (108, 0.051, 643.0, 4.52),
    ];

    /// ASTM A228's least tensile strength of music wire of `diameter_m`, Pa:
    /// 330 ksi at 0.030 in (0.76 mm), 315 at 0.040, 303 at 0.051 and 293 at
    /// 0.063 (1.6 mm), within 0.5 % of this power law between them.
    fn music_wire_strength_pa(diameter_m: f64) -> f64 {
        330.0 * 6.894_76e6 * (diameter_m / 0.762e-3).powf(-0.16)
    }

    #[test]
    fn the_scale_files_cover_the_keyboard_with_the_broadwood_stringing() {
        for scale in [scale(), broadwood_scale()] {
            assert_eq!(scale.keys(), KEYS);
            let count = |n: usize| scale.rows().iter().filter(|r| r.strings == n).count();
            assert_eq!((count(1), count(2), count(3)), (17, 13, 58));
            for r in scale.rows() {
                let n = match r.midi_key {
                    ..=37 => 1,
                    38..=50 => 2,
                    _ => 3,
                };
                assert_eq!(r.strings, n, "{r}");
                assert_eq!(r.is_wound(), r.midi_key <= 50, "{r}");
                assert_eq!(r.material, if r.is_wound() { "steel+copper" } else { "steel" }, "{r}");
                assert_eq!(design(&Voicing::default(), r.midi_key, 20_000.0).strings.len(), n);
            }
        }
    }

    #[test]
    fn the_strings_built_are_the_strings_of_the_scale() {
        // The engine's own tension, impedance and inharmonicity agree with the
        // derivation's, for the string tuned exactly to the key.
        for r in scale().rows() {
            let mut spec = design(&Voicing::default(), r.midi_key, 20_000.0).strings[0].clone();
            spec.tuning = crate::string::Tuning::FirstPartialHz(key_frequency_hz(r.midi_key));
            let s = spec.build().unwrap();
            assert!((s.tension_n / r.tension_n - 1.0).abs() < 1e-3, "{r}: {} N", s.tension_n);
            let z = r.strings as f64 * s.impedance_ns_m();
            assert!((z / r.total_impedance_ns_m - 1.0).abs() < 1e-3, "{r}: {z} N s/m");
            assert!((s.inharmonicity / r.inharmonicity - 1.0).abs() < 1e-3, "{r}: B {}", s.inharmonicity);
        }
    }

    #[test]
    fn the_seeds_broadwood_has_the_c_strings_of_its_table() {
        // Plain wire comes in 0.025 mm steps, so the tension of a plain C string
        // is within half a step of the table's (2.5 %).
        for (key, length_m, tension_n, impedance_ns_m) in BROADWOOD_TABLE {
            let r = broadwood_scale().row(key).unwrap();
            assert!((r.length_m - length_m).abs() < 1e-4, "{r}: {} m", r.length_m);
            let f = key_frequency_hz(key);
            let flexible_tension_n = 4.0 * r.length_m * r.length_m * r.mass_per_length_kg_m * f * f;
            assert!((flexible_tension_n / tension_n - 1.0).abs() < 0.025, "{r}: {flexible_tension_n} N");
            let z = broadwood_impedance_ns_m(key);
            assert!((z / impedance_ns_m - 1.0).abs() < 0.05, "{r}: {z} N s/m");
        }
        // The wound Cs keep the table's core (to the nearest 0.025 mm) and wrap.
        for (key, core_m, wrap_m) in [(24, 1.21e-3, 5.80e-3), (36, 1.21e-3, 3.76e-3), (48, 1.08e-3, 1.80e-3)] {
            let r = broadwood_scale().row(key).unwrap();
            assert!((r.core_diameter_m - core_m).abs() <= 0.0126e-3, "{r}: core {}", r.core_diameter_m);
            assert!((r.wrap_diameter_m - wrap_m).abs() <= 0.05e-3, "{r}: wrap {}", r.wrap_diameter_m);
        }
    }

    #[test]
    fn the_piano_has_a_two_metre_grands_lengths_and_the_broadwoods_impedance() {
        // A0 a Yamaha C3's, C4-C5 a Steinway M's, from C6 up the Broadwood's,
        // string for string (the scale's header).
        for (key, length_m) in [(21, 1.40), (60, 0.640), (72, 0.340)] {
            assert!((row(key).length_m - length_m).abs() < 1e-5, "{}: {} m", row(key), row(key).length_m);
        }
        // From the break (D#3) to C4 the plain strings keep C4's working stress,
        // rho (2 L f)^2 = 0.88 GPa: D#3 is 1.08 m long, 0.30 m longer than the
        // Broadwood's.
        for key in 51..=60 {
            let (l, f) = (row(key).length_m, key_frequency_hz(key));
            let stress_pa = 7850.0 * (2.0 * l * f).powi(2);
            assert!((stress_pa / 0.880e9 - 1.0).abs() < 0.01, "{}: {stress_pa} Pa", row(key));
        }
        assert!(
            (row(51).length_m - 1.076).abs() < 1e-3
                && row(51).length_m > broadwood_scale().row(51).unwrap().length_m + 0.29
        );
        // (Its unisons are its own: tuned cleaner, see the next test.)
        for key in 84..=108 {
            let broadwood = broadwood_scale().row(key).unwrap();
            let spread = broadwood.unison_spread_cents;
            assert_eq!(&ScaleRow { unison_spread_cents: spread, ..row(key).clone() }, broadwood, "{}", row(key));
        }
        // Lengths fall all the way up.
        assert!(scale().rows().windows(2).all(|w| w[1].length_m < w[0].length_m));
        // The total impedance is still the Broadwood table's at every C (the
        // course's mass, and with it the strike, is the Broadwood's).
        for (key, _, _, impedance_ns_m) in BROADWOOD_TABLE {
            let z = built_impedance_ns_m(key);
            assert!((z / impedance_ns_m - 1.0).abs() < 0.05, "{}: {z} N s/m", row(key));
        }
    }

    #[test]
    fn inharmonicity_falls_to_a2_and_rises_through_the_break_without_a_jump() {
        let b: Vec<(u8, f64)> = scale().rows().iter().map(|r| (r.midi_key, r.inharmonicity)).collect();
        // The Yamaha C5's recordings: 2.6e-4 at A0, falling to 0.76-0.8e-4 at
        // F#2-A2, 1.3e-4 at D#3 (the first plain key here), 2.9e-4 at C4.
        assert!((2.4e-4..2.8e-4).contains(&b[0].1), "A0: {}", b[0].1);
        let (lowest_key, lowest) = b.iter().cloned().fold((0, f64::MAX), |a, x| if x.1 < a.1 { x } else { a });
        assert!((42..=45).contains(&lowest_key) && (0.7e-4..0.9e-4).contains(&lowest), "{lowest_key}: {lowest}");
        assert!((1.2e-4..1.6e-4).contains(&row(51).inharmonicity), "D#3: {}", row(51).inharmonicity);
        assert!((2.9e-4..3.6e-4).contains(&row(60).inharmonicity), "C4: {}", row(60).inharmonicity);
        // From A2 on it only rises, and no neighbour differs by more than a
        // quarter (wire steps; the Broadwood's B rises 3.3 times from its last
        // wound key to its first plain one).
        for w in b.windows(2) {
            let ratio = w[1].1 / w[0].1;
            assert!((0.8..1.25).contains(&ratio), "keys {} and {}: x{ratio:.2}", w[0].0, w[1].0);
            assert!(w[0].0 < 45 || ratio > 0.97, "keys {} and {}: x{ratio:.2}", w[0].0, w[1].0);
        }
        let broadwood = |k: u8| broadwood_scale().row(k).unwrap().inharmonicity;
        assert!(broadwood(51) / broadwood(50) > 3.0);
    }

    #[test]
    fn total_impedance_runs_smoothly_through_both_string_count_breaks() {
        // Less than 30 % between any two neighbours; the scale keeps it under 6 %.
        let z: Vec<(u8, f64)> = KEYS.map(|k| (k, built_impedance_ns_m(k))).collect();
        for w in z.windows(2) {
            let step = (w[1].1 / w[0].1 - 1.0).abs();
            assert!(step < 0.3, "keys {} and {}: {:.1} %", w[0].0, w[1].0, 100.0 * step);
            assert!(step < 0.06, "keys {} and {}: {:.1} %", w[0].0, w[1].0, 100.0 * step);
        }
        // From C1 to C8 it falls as the table's does, from 12.4 to 4.5 N s/m.
        assert!(z.windows(2).all(|w| w[1].1 < 1.02 * w[0].1));
    }

    #[test]
    fn the_strings_are_sanely_stressed() {
        // A string bears T over its steel's section (a wound string's core); a
        // plain wire's stress is rho (2 L f)^2, set by its length. Music wire
        // is scaled at up to about 70 % of its strength (a Yamaha C3's C8 runs
        // at 69 %, by the scale file that gives its length): here 27 % (A0's
        // core) to 64 % (C2's core), the plain strings 40-62 % (C8).
        for r in scale().rows() {
            let stress_pa = r.tension_n / (std::f64::consts::PI * r.core_diameter_m.powi(2) / 4.0);
            let share = stress_pa / music_wire_strength_pa(r.core_diameter_m);
            assert!((0.25..0.7).contains(&share), "{r}: {stress_pa} Pa, {:.0} % of its strength", 100.0 * share);
            if r.is_wound() {
                // Keeping the Broadwood's impedance on longer strings, the singles
                // carry 1.0 to 1.6 kN, the pairs 0.8 to 1.2 kN each.
                assert!((800.0..1650.0).contains(&r.tension_n), "{r}: {} N", r.tension_n);
            } else {
                // 615 N in the treble to 840 N at the break.
                assert!((600.0..850.0).contains(&r.tension_n), "{r}: {} N", r.tension_n);
            }
        }
    }

    #[test]
    fn c2_c4_c7_hammers_have_the_chaigne_askenfelt_felt_voiced_and_the_laws_continue_beyond() {
        for (key, stiffness, exponent) in [(36, 4.0e8, 2.3), (60, 4.5e9, 2.5), (96, 1.0e12, 3.0)] {
            assert!((row(key).contact_law().stiffness / stiffness - 1.0).abs() < 1e-5, "{key}");
            let d = design(&Voicing::default(), key, 20_000.0);
            let ExciterDesign::Hammer { law, .. } = d.exciter else { panic!("not a hammer") };
            assert!((law.stiffness / (FELT_VOICED * stiffness) - 1.0).abs() < 1e-5, "{key}: {law:?}");
            assert!((law.exponent - exponent).abs() < 1e-4, "{key}: {law:?}");
        }
        // Continued, not held: alpha falls 0.2 per 24 keys below C2 and rises 0.5
        // per 36 keys above C7; log K follows.
        let (a0, c8) = (row(21).contact_law(), row(108).contact_law());
        assert!((a0.exponent - (2.3 - 15.0 * 0.2 / 24.0)).abs() < 1e-4, "{a0:?}");
        assert!((c8.exponent - (3.0 + 12.0 * 0.5 / 36.0)).abs() < 1e-4, "{c8:?}");
        let log_slope = |k0: f64, k1: f64, keys: f64| (k1 / k0).ln() / keys;
        assert!((log_slope(a0.stiffness, 4.0e8, 15.0) / log_slope(4.0e8, 4.5e9, 24.0) - 1.0).abs() < 1e-3);
        assert!((log_slope(1.0e12, c8.stiffness, 12.0) / log_slope(4.5e9, 1.0e12, 36.0) - 1.0).abs() < 1e-3);
        // Strike ratio about 1/8, falling in the treble; hammers 12 g at C1 to 5 g at C8.
        assert_eq!((row(21).strike_ratio, row(60).strike_ratio, row(108).strike_ratio), (0.135, 0.125, 0.08));
        assert!((row(24).hammer_mass_kg - 12.0e-3).abs() < 1e-9 && (row(108).hammer_mass_kg - 5.0e-3).abs() < 1e-9);
    }

    #[test]
    fn unisons_are_tuned_close_and_singles_alone() {
        for r in scale().rows() {
            let pitches: Vec<f64> = design(&Voicing::default(), r.midi_key, 20_000.0)
                .strings
                .iter()
                .map(|s| match s.tuning {
                    crate::string::Tuning::FirstPartialHz(f) => f,
                    crate::string::Tuning::TensionN(_) => f64::NAN,
                })
                .collect();
            let spread_cents = 1200.0
                * (pitches.iter().cloned().fold(f64::MIN, f64::max) / pitches.iter().cloned().fold(f64::MAX, f64::min))
                    .log2();
            if r.strings == 1 {
                assert_eq!(spread_cents, 0.0);
            } else {
                // A fifth of a cent at C4 (a third of a cent between a
                // triplet's outer strings), widening as f^0.5 into the
                // treble: 0.1 to 1.8 cents between a unison's outer strings.
                assert!((0.08..1.8).contains(&spread_cents), "{r}: {spread_cents} cents");
            }
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
