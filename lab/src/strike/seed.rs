//! The experiments of the seed (Woodhouse, Euphonics 12.2) as strike cases, so
//! that its sounds, figures and animations can be redone: the santoor string
//! with its 1 g and 3 g mallets and the wire-break pluck (Sounds 1-5, Figs.
//! 2-5), the piano's C strings with the C2, C4 and C7 hammers (Sounds 6-11,
//! Figs. 12-26), and the clavichord's D2 with its tangent beside the
//! harpsichord's pluck on the same string (Sound 12, Figs. 29-35).
//!
//! A piano course (one, two or three strings in unison) is simulated as the seed
//! does: one string carrying the course's total tension and mass, struck by the
//! whole hammer. Its strings are the Broadwood's C strings, from the seed's own
//! Broadwood scale ([`struck_engine::design::broadwood_key_design`]; the piano
//! instrument is scaled as a larger grand), tuned exactly to equal temperament
//! at A4 = 440 Hz with a uniform Q of 2000, as in the seed's simulations.

use crate::strike::case::{ExciterSpec, StrikeCase};
use struck_engine::design::{
    ExciterDesign, InstrumentKind, KeyDesign, Voicing, broadwood_key_design, key_design, key_frequency_hz,
};
use struck_engine::exciter::hammer::HammerSpec;
use struck_engine::exciter::hammer::contact::ContactLaw;
use struck_engine::exciter::pluck::PluckSpec;
use struck_engine::exciter::tangent::TangentSpec;
use struck_engine::string::damping::{Damping, PhysicalLoss};
use struck_engine::string::{Mass, Stiffness, StringSpec, Tuning};

/// Mode cut-off of every seed case, Hz (the instruments' own).
pub const MAX_FREQUENCY_HZ: f64 = 20_000.0;
/// Q of every mode of the santoor string (the seed's).
pub const SANTOOR_Q: f64 = 1000.0;
/// Q of every mode of the piano strings (the seed's "somewhat arbitrary" 2000).
pub const PIANO_Q: f64 = 2000.0;
/// The santoor mallet's contact stiffness: a linear spring, N/m (the S1 reference case).
pub const SANTOOR_MALLET_STIFFNESS_N_M: f64 = 1.0e6;
/// The santoor mallet's speed, m/s.
pub const SANTOOR_MALLET_SPEED_M_S: f64 = 1.0;
/// Height of the santoor's wire-break pluck, m.
pub const SANTOOR_PLUCK_M: f64 = 1.0e-3;
/// The piano's C4 hammer speed of Sounds 6 and 10 (mezzopiano), m/s.
pub const PIANO_MEZZO_SPEED_M_S: f64 = 1.0;
/// Boutillon's measured hammer speeds, pianissimo to fortissimo, m/s: Sounds 7-9
/// play five speeds spaced evenly on a log scale between them.
pub const BOUTILLON_SPEEDS_M_S: (f64, f64) = (0.11, 6.83);
/// The hammer speed of the design charts (forte), m/s.
pub const CHART_SPEED_M_S: f64 = 2.5;
/// The clavichord note of Figs. 29-35 (D2, 73.4 Hz).
pub const CLAVICHORD_KEY: u8 = 38;
/// The tangent's final depth and the harpsichord pluck's height, m (both 2 mm).
pub const CLAVICHORD_DISPLACEMENT_M: f64 = 2.0e-3;
/// Tangent speeds of Figs. 30 and 33, m/s: a quiet note (black), a typical one
/// (blue) and a loud one (red). Coming to rest 2 mm in, the loud one has moved
/// 92 % of the way in 5 ms and the quiet one not yet all of it at 50 ms, as the
/// seed describes.
pub const CLAVICHORD_SPEEDS_M_S: [f64; 3] = [0.1, 0.5, 1.0];
/// Where the harpsichord plucks, as a fraction of the length (the seed's 1/7.8).
pub const HARPSICHORD_PLUCK_POSITION: f64 = 1.0 / 7.8;

/// The five speeds of Sounds 7-9, m/s: 0.11 to 6.83 in equal ratios.
pub fn boutillon_speeds() -> [f64; 5] {
    let (low, high) = BOUTILLON_SPEEDS_M_S;
    std::array::from_fn(|i| low * (high / low).powf(i as f64 / 4.0))
}

/// The santoor string of Sounds 1-5: steel, 0.5 mm, 0.4 m, tuned to 440 Hz,
/// Q 1000 (the S1 reference case's string).
pub fn santoor_string() -> StringSpec {
    StringSpec {
        length_m: 0.4,
        tuning: Tuning::FirstPartialHz(440.0),
        mass: Mass::SolidWire { diameter_m: 0.5e-3, density_kg_m3: 7850.0 },
        stiffness: Stiffness::YoungsModulus { modulus_pa: 2.0e11, bending_diameter_m: 0.5e-3 },
        damping: Damping::UniformQ(SANTOOR_Q),
        max_frequency_hz: MAX_FREQUENCY_HZ,
        outer_diameter_m: Some(0.5e-3),
    }
}

fn case(name: String, sample_rate_hz: f64, duration_s: f64, string: StringSpec, exciter: ExciterSpec) -> StrikeCase {
    StrikeCase { name: Some(name), sample_rate_hz, duration_s, string, exciter }
}

/// The santoor string struck by a mallet of `mass_kg` (a linear spring of 1e6
/// N/m at 1 m/s) at `position` (fraction of the length from the bridge).
pub fn santoor_mallet(mass_kg: f64, position: f64, sample_rate_hz: f64, duration_s: f64) -> StrikeCase {
    let exciter = ExciterSpec::Hammer(HammerSpec {
        mass_kg,
        law: ContactLaw { stiffness: SANTOOR_MALLET_STIFFNESS_N_M, exponent: 1.0 },
        speed_m_s: SANTOOR_MALLET_SPEED_M_S,
        position,
        hysteresis: None,
    });
    let name = format!("santoor, {:.0} g mallet at {}", mass_kg * 1e3, fraction_name(position));
    case(name, sample_rate_hz, duration_s, santoor_string(), exciter)
}

/// The santoor string released from a 1 mm triangle at `position` (the ideal
/// "wire-break" pluck).
pub fn santoor_pluck(position: f64, sample_rate_hz: f64, duration_s: f64) -> StrikeCase {
    let exciter = ExciterSpec::Pluck(PluckSpec { displacement_m: SANTOOR_PLUCK_M, position });
    let name = format!("santoor, plucked at {}", fraction_name(position));
    case(name, sample_rate_hz, duration_s, santoor_string(), exciter)
}

/// "2/5" for 0.4, "1/10" for 0.1, else the decimal.
pub fn fraction_name(position: f64) -> String {
    for den in 2..=20u32 {
        let num = (position * den as f64).round();
        if num >= 1.0 && (num / den as f64 - position).abs() < 1e-9 {
            return format!("{}/{den}", num as u32);
        }
    }
    format!("{position}")
}

/// MIDI key of the piano's C in `octave` (C1 = 24 ... C8 = 108).
pub fn piano_c_key(octave: u8) -> u8 {
    12 * (octave + 1)
}

/// A key's course as one string with the course's total tension and mass (the
/// seed's way of simulating a unison): the string's length, inharmonicity and
/// outer diameter, tuned to the key's equal-tempered pitch.
pub fn course_string(key: &KeyDesign, damping: Damping, max_frequency_hz: f64) -> Option<StringSpec> {
    let first = key.strings.first()?;
    let built = first.build().ok()?;
    let count = key.strings.len() as f64;
    Some(StringSpec {
        length_m: first.length_m,
        tuning: Tuning::FirstPartialHz(key_frequency_hz(key.midi_key)),
        mass: Mass::PerLengthKgM(built.mass_per_length_kg_m * count),
        stiffness: Stiffness::Inharmonicity(built.inharmonicity),
        damping,
        max_frequency_hz,
        outer_diameter_m: first.outer_diameter_m,
    })
}

/// The Broadwood's key as the seed plays it: its felt elastic, as the book's
/// hammers are (F = K C^alpha with the designs' measured laws).
fn piano_key(midi_key: u8) -> KeyDesign {
    let elastic = Voicing { felt_hysteresis: 0.0, ..Voicing::default() };
    broadwood_key_design(&elastic, midi_key, MAX_FREQUENCY_HZ).expect("the Broadwood has every C from C1 to C8")
}

/// The piano's C string of `octave` (1-8): the whole course as one string, Q 2000.
/// With `inharmonic` false its bending stiffness is left out (Sound 10).
pub fn piano_c_string(octave: u8, inharmonic: bool) -> StringSpec {
    let mut spec = course_string(&piano_key(piano_c_key(octave)), Damping::UniformQ(PIANO_Q), MAX_FREQUENCY_HZ)
        .expect("the piano's strings build");
    if !inharmonic {
        spec.stiffness = Stiffness::Flexible;
    }
    spec
}

/// The piano's C hammer of `octave`: its mass and felt (the Chaigne-Askenfelt
/// felt at C2, C4 and C7), thrown at `speed_m_s`. Its strike position is the one
/// the C string of `octave` has; [`piano_c_case`] moves it to the struck string's.
pub fn piano_c_hammer(octave: u8, speed_m_s: f64) -> HammerSpec {
    match piano_key(piano_c_key(octave)).exciter {
        ExciterDesign::Hammer { mass_kg, law, position } => {
            HammerSpec { mass_kg, law, speed_m_s, position, hysteresis: None }
        }
        _ => unreachable!("a piano key has a hammer"),
    }
}

/// The C string of `string_octave` struck at its own strike point by the C hammer
/// of `hammer_octave` at `speed_m_s`.
pub fn piano_c_case(
    string_octave: u8,
    hammer_octave: u8,
    speed_m_s: f64,
    inharmonic: bool,
    sample_rate_hz: f64,
    duration_s: f64,
) -> StrikeCase {
    let position = piano_c_hammer(string_octave, speed_m_s).position;
    let hammer = HammerSpec { position, ..piano_c_hammer(hammer_octave, speed_m_s) };
    let name = format!(
        "piano C{string_octave}{}, C{hammer_octave} hammer at {speed_m_s:.2} m/s",
        if inharmonic { "" } else { " without inharmonicity" }
    );
    case(name, sample_rate_hz, duration_s, piano_c_string(string_octave, inharmonic), ExciterSpec::Hammer(hammer))
}

/// Any key of any instrument as a strike case: the key's course as one string
/// (its own damping, per mode), excited by its own exciter at `speed_m_s` (a
/// hammer's or a tangent's speed; a pluck ignores it). None when the instrument
/// has no such key of its own.
pub fn key_case(
    kind: InstrumentKind,
    midi_key: u8,
    speed_m_s: f64,
    sample_rate_hz: f64,
    duration_s: f64,
) -> Option<StrikeCase> {
    let key = key_design(kind, &Voicing::default(), midi_key, MAX_FREQUENCY_HZ)?;
    let own = key.strings.first()?.build().ok()?;
    let q = own.modes.iter().map(|m| m.q).collect();
    let string = course_string(&key, Damping::PerModeQ(q), MAX_FREQUENCY_HZ)?;
    let exciter = match key.exciter {
        ExciterDesign::Hammer { mass_kg, law, position } => {
            ExciterSpec::Hammer(HammerSpec { mass_kg, law, speed_m_s, position, hysteresis: key.hammer_hysteresis })
        }
        ExciterDesign::Tangent { displacement_m, .. } => {
            ExciterSpec::Tangent(TangentSpec { speed_m_s, displacement_m })
        }
        ExciterDesign::Pluck { position } => {
            ExciterSpec::Pluck(PluckSpec { displacement_m: CLAVICHORD_DISPLACEMENT_M, position })
        }
    };
    let name = format!("{} {}", kind.name(), note_name(midi_key));
    Some(case(name, sample_rate_hz, duration_s, string, exciter))
}

/// The clavichord's D2 string with its own damping (the leak past the tangent
/// included), one string of the pair.
pub fn clavichord_string() -> StringSpec {
    key_design(InstrumentKind::Clavichord, &Voicing::default(), CLAVICHORD_KEY, MAX_FREQUENCY_HZ)
        .and_then(|k| k.strings.first().cloned())
        .expect("the clavichord has D2")
}

/// The same string with the harpsichord's damping: air, the brass's internal
/// friction (eta_E 5e-4) and the bridge (Re Y 5e-3 s/kg), and no leak.
pub fn harpsichord_damped(spec: &StringSpec) -> StringSpec {
    let damping = Damping::Physical(PhysicalLoss { internal_loss_factor: 5.0e-4, bridge_admittance_s_kg: 5.0e-3 });
    StringSpec { damping, ..spec.clone() }
}

/// The clavichord's D2 met by its tangent at `speed_m_s`, coming to rest 2 mm in.
pub fn clavichord_case(speed_m_s: f64, sample_rate_hz: f64, duration_s: f64) -> StrikeCase {
    let exciter = ExciterSpec::Tangent(TangentSpec { speed_m_s, displacement_m: CLAVICHORD_DISPLACEMENT_M });
    let name = format!("clavichord D2, tangent at {speed_m_s} m/s to 2 mm");
    case(name, sample_rate_hz, duration_s, clavichord_string(), exciter)
}

/// The same string plucked 2 mm high at 1/7.8, harpsichord-damped.
pub fn harpsichord_case(sample_rate_hz: f64, duration_s: f64) -> StrikeCase {
    let exciter = ExciterSpec::Pluck(PluckSpec {
        displacement_m: CLAVICHORD_DISPLACEMENT_M,
        position: HARPSICHORD_PLUCK_POSITION,
    });
    let name = "harpsichord pluck, 2 mm at 1/7.8, on the clavichord's D2 string".to_string();
    case(name, sample_rate_hz, duration_s, harpsichord_damped(&clavichord_string()), exciter)
}

/// "C4", "F#2": the name of a MIDI key.
pub fn note_name(midi_key: u8) -> String {
    const NAMES: [&str; 12] = ["C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"];
    format!("{}{}", NAMES[midi_key as usize % 12], midi_key as i32 / 12 - 1)
}

/// The MIDI key of a name such as "C4", "f#2", "Bb0" or a plain number ("60").
pub fn parse_note(text: &str) -> Option<u8> {
    let t = text.trim();
    if let Ok(n) = t.parse::<u8>() {
        return (n < 128).then_some(n);
    }
    let mut chars = t.chars();
    let base: i32 = match chars.next()?.to_ascii_uppercase() {
        'C' => 0,
        'D' => 2,
        'E' => 4,
        'F' => 5,
        'G' => 7,
        'A' => 9,
        'B' => 11,
        _ => return None,
    };
    let rest = chars.as_str();
    let (shift, octave) = match rest.as_bytes().first() {
        Some(b'#') => (1, &rest[1..]),
        Some(b'b') => (-1, &rest[1..]),
        _ => (0, rest),
    };
    let octave: i32 = octave.parse().ok()?;
    let key = (octave + 1) * 12 + base + shift;
    (0..128).contains(&key).then_some(key as u8)
}

/// One key's stringing, for the stringing charts (Figs. 8-10).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stringing {
    pub midi_key: u8,
    /// Strings in the course.
    pub strings: usize,
    /// Mass per length of one string, kg/m.
    pub mass_per_length_kg_m: f64,
    /// Tension of one string, N.
    pub tension_n: f64,
    /// Wave impedance of the whole course, sqrt(T mu) times the string count, N s/m.
    pub total_impedance_ns_m: f64,
}

/// The stringing of every key of `kind` that has strings of its own, lowest first.
pub fn stringing(kind: InstrumentKind) -> Vec<Stringing> {
    stringing_of(kind.key_range(), |k| key_design(kind, &Voicing::default(), k, MAX_FREQUENCY_HZ))
}

/// The stringing of the seed's Broadwood (Euphonics 12.2, Figs. 8-10), lowest first.
pub fn broadwood_stringing() -> Vec<Stringing> {
    stringing_of(InstrumentKind::Piano.key_range(), |k| broadwood_key_design(&Voicing::default(), k, MAX_FREQUENCY_HZ))
}

/// The stringing of `keys` designed by `design`, skipping keys without strings of their own.
fn stringing_of(keys: impl Iterator<Item = u8>, design: impl Fn(u8) -> Option<KeyDesign>) -> Vec<Stringing> {
    keys.filter_map(|midi_key| {
        let key = design(midi_key)?;
        let built = key.strings.first()?.build().ok()?;
        let strings = key.strings.len();
        Some(Stringing {
            midi_key,
            strings,
            mass_per_length_kg_m: built.mass_per_length_kg_m,
            tension_n: built.tension_n,
            total_impedance_ns_m: built.impedance_ns_m() * strings as f64,
        })
    })
    .collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use struck_engine::string::StringModes;

    fn built(spec: &StringSpec) -> StringModes {
        spec.build().unwrap()
    }

    #[test]
    fn the_santoor_string_is_the_reference_one() {
        // S1: 190.98 N, 1.5413 g/m, B 1.982e-4.
        let s = built(&santoor_string());
        assert!((s.tension_n / 190.979 - 1.0).abs() < 1e-3, "{}", s.tension_n);
        assert!((s.mass_per_length_kg_m / 1.5413e-3 - 1.0).abs() < 1e-3);
        assert!((s.inharmonicity / 1.9819e-4 - 1.0).abs() < 1e-3);
        assert!((s.partial_hz(1) - 440.0).abs() < 1e-9);
    }

    #[test]
    fn the_piano_cs_carry_their_courses_and_hammers() {
        // Broadwood (Euphonics 12.2.1, Table 1): total T/L 0.81 ... 37.95 kN/m,
        // course masses 189 ... 0.54 g.
        let t_over_l = [0.81, 1.25, 2.10, 3.22, 5.76, 10.53, 20.14, 37.95];
        let mass_g = [189.0, 73.0, 30.7, 11.7, 5.3, 2.4, 1.15, 0.54];
        for octave in 1..=8u8 {
            let s = built(&piano_c_string(octave, true));
            let i = octave as usize - 1;
            let kn_m = s.tension_n / s.length_m / 1e3;
            assert!((kn_m / t_over_l[i] - 1.0).abs() < 0.05, "C{octave}: T/L {kn_m:.2} kN/m");
            let grams = s.mass_per_length_kg_m * s.length_m * 1e3;
            assert!((grams / mass_g[i] - 1.0).abs() < 0.05, "C{octave}: {grams:.2} g");
            assert!((s.partial_hz(1) / key_frequency_hz(piano_c_key(octave)) - 1.0).abs() < 1e-9);
            assert!(s.modes.iter().all(|m| m.q == PIANO_Q));
        }
        let c4 = piano_c_hammer(4, 1.0);
        assert_eq!((c4.mass_kg, c4.law.stiffness, c4.law.exponent), (9.0e-3, 4.5e9, 2.5));
        let c2 = piano_c_hammer(2, 1.0);
        assert_eq!((c2.mass_kg, c2.law.stiffness, c2.law.exponent), (11.0e-3, 4.0e8, 2.3));
        let c7 = piano_c_hammer(7, 1.0);
        assert_eq!((c7.mass_kg, c7.law.stiffness, c7.law.exponent), (6.0e-3, 1.0e12, 3.0));
        // Figs. 8-10 draw the same Broadwood, every key of it.
        let rows = broadwood_stringing();
        assert_eq!(rows.len(), 88);
        for octave in 1..=8u8 {
            let row = rows.iter().find(|r| r.midi_key == piano_c_key(octave)).unwrap();
            let z = built(&piano_c_string(octave, true)).impedance_ns_m();
            assert!((row.total_impedance_ns_m / z - 1.0).abs() < 0.02, "C{octave}: {} N s/m", row.total_impedance_ns_m);
        }
        // Sound 10's strings are harmonic.
        assert_eq!(built(&piano_c_string(1, false)).inharmonicity, 0.0);
        // The C4 hammer on the C2 string strikes where C2's hammer would.
        let case = piano_c_case(2, 4, 1.0, true, 48_000.0, 0.1);
        let ExciterSpec::Hammer(h) = case.exciter else { panic!() };
        assert_eq!((h.mass_kg, h.position), (9.0e-3, c2.position));
    }

    #[test]
    fn speeds_and_names() {
        let v = boutillon_speeds();
        assert!((v[0] - 0.11).abs() < 1e-12 && (v[4] - 6.83).abs() < 1e-12);
        assert!((v[2] - (0.11f64 * 6.83).sqrt()).abs() < 1e-12);
        assert_eq!(fraction_name(0.4), "2/5");
        assert_eq!(fraction_name(0.1), "1/10");
        assert_eq!(note_name(60), "C4");
        assert_eq!(note_name(21), "A0");
        assert_eq!(parse_note("C4"), Some(60));
        assert_eq!(parse_note("f#2"), Some(42));
        assert_eq!(parse_note("Bb0"), Some(22));
        assert_eq!(parse_note("60"), Some(60));
        assert_eq!(parse_note("H2"), None);
        assert_eq!(parse_note("C99"), None);
    }

    #[test]
    fn every_instrument_key_makes_a_case_and_a_stringing_row() {
        for kind in InstrumentKind::ALL {
            let rows = stringing(kind);
            assert!(!rows.is_empty(), "{kind:?}");
            for row in &rows {
                let case = key_case(kind, row.midi_key, 1.0, 48_000.0, 0.1).expect("a key with strings");
                let s = built(&case.string);
                // The course as one string: total impedance preserved.
                assert!(
                    (s.impedance_ns_m() / row.total_impedance_ns_m - 1.0).abs() < 0.02,
                    "{kind:?} {}",
                    row.midi_key
                );
            }
        }
        let piano = stringing(InstrumentKind::Piano);
        assert_eq!(piano.len(), 88);
        // Single, double and triple courses, in that order up the keyboard.
        assert!(piano.windows(2).all(|w| w[0].strings <= w[1].strings));
        assert_eq!(piano.first().unwrap().strings, 1);
        assert_eq!(piano.last().unwrap().strings, 3);
    }

    #[test]
    fn the_clavichord_and_harpsichord_share_a_string_but_not_its_leak() {
        let clav = built(&clavichord_string());
        let harp = built(&harpsichord_case(48_000.0, 0.1).string);
        assert!((clav.partial_hz(1) - harp.partial_hz(1)).abs() < 1e-9);
        assert!(clav.modes[0].q < 0.8 * harp.modes[0].q, "{} {}", clav.modes[0].q, harp.modes[0].q);
    }
}
