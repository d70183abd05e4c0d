//! The seed's Broadwood: its C strings as Euphonics 12.2.1's Table 1 lists
//! them, the notes between scaled through them, and its hammers.

use super::{
    BRASS, COPPER_DENSITY_KG_M3, IRON, Material, PI, STEEL, Scale, UNISON_CENTS_AT_C4, UNISON_EXPONENT, Wound,
    bending_stiffness_n_m2, csv, frequency_hz, note_name, wire_mass_per_length_kg_m,
};

/// A C string of the Broadwood (Euphonics 12.2.1, Table 1).
pub(super) struct BroadwoodC {
    pub(super) midi_key: u8,
    pub(super) length_m: f64,
    pub(super) strings: usize,
    pub(super) core_diameter_m: f64,
    /// 0 for a plain wire.
    pub(super) wrap_diameter_m: f64,
    /// Mass of all the note's strings, kg.
    pub(super) course_mass_kg: f64,
    pub(super) strike_ratio: f64,
    pub(super) hammer_mass_kg: f64,
}

impl BroadwoodC {
    /// Mass per length of one string, kg/m.
    pub(super) fn mass_per_length_kg_m(&self) -> f64 {
        self.course_mass_kg / (self.strings as f64 * self.length_m)
    }

    /// Total impedance, 2 f M, N s/m.
    pub(super) fn impedance_ns_m(&self) -> f64 {
        2.0 * frequency_hz(self.midi_key) * self.course_mass_kg
    }

    /// The flexible string's tension, T = Z 2 L f / n, N.
    pub(super) fn tension_n(&self) -> f64 {
        self.impedance_ns_m() * 2.0 * self.length_m * frequency_hz(self.midi_key) / self.strings as f64
    }
}

pub(super) const BROADWOOD: [BroadwoodC; 8] = [
    BroadwoodC {
        midi_key: 24,
        length_m: 1.013,
        strings: 1,
        core_diameter_m: 1.21e-3,
        wrap_diameter_m: 5.80e-3,
        course_mass_kg: 0.189,
        strike_ratio: 0.135,
        hammer_mass_kg: 12.0e-3,
    },
    BroadwoodC {
        midi_key: 36,
        length_m: 0.925,
        strings: 1,
        core_diameter_m: 1.21e-3,
        wrap_diameter_m: 3.76e-3,
        course_mass_kg: 0.073,
        strike_ratio: 0.135,
        hammer_mass_kg: 11.0e-3,
    },
    BroadwoodC {
        midi_key: 48,
        length_m: 0.830,
        strings: 2,
        core_diameter_m: 1.08e-3,
        wrap_diameter_m: 1.80e-3,
        course_mass_kg: 0.0307,
        strike_ratio: 0.130,
        hammer_mass_kg: 10.0e-3,
    },
    BroadwoodC {
        midi_key: 60,
        length_m: 0.639,
        strings: 3,
        core_diameter_m: 1.00e-3,
        wrap_diameter_m: 0.0,
        course_mass_kg: 0.0117,
        strike_ratio: 0.125,
        hammer_mass_kg: 9.0e-3,
    },
    BroadwoodC {
        midi_key: 72,
        length_m: 0.324,
        strings: 3,
        core_diameter_m: 0.94e-3,
        wrap_diameter_m: 0.0,
        course_mass_kg: 0.0053,
        strike_ratio: 0.12,
        hammer_mass_kg: 8.0e-3,
    },
    BroadwoodC {
        midi_key: 84,
        length_m: 0.181,
        strings: 3,
        core_diameter_m: 0.85e-3,
        wrap_diameter_m: 0.0,
        course_mass_kg: 0.0024,
        strike_ratio: 0.10,
        hammer_mass_kg: 7.0e-3,
    },
    BroadwoodC {
        midi_key: 96,
        length_m: 0.096,
        strings: 3,
        core_diameter_m: 0.82e-3,
        wrap_diameter_m: 0.0,
        course_mass_kg: 0.00115,
        strike_ratio: 0.09,
        hammer_mass_kg: 6.0e-3,
    },
    BroadwoodC {
        midi_key: 108,
        length_m: 0.051,
        strings: 3,
        core_diameter_m: 0.76e-3,
        wrap_diameter_m: 0.0,
        course_mass_kg: 0.00054,
        strike_ratio: 0.08,
        hammer_mass_kg: 5.0e-3,
    },
];

/// The packing factor that best reproduces the mass of the Broadwood's wound
/// strings from their core and wrap diameters (least squares in relative error).
pub(super) fn broadwood_packing() -> f64 {
    let (mut num, mut den) = (0.0, 0.0);
    for c in BROADWOOD.iter().filter(|c| c.wrap_diameter_m > 0.0) {
        let mu = c.mass_per_length_kg_m();
        let core = wire_mass_per_length_kg_m(c.core_diameter_m, STEEL.density_kg_m3);
        let copper = COPPER_DENSITY_KG_M3 * PI / 4.0 * (c.wrap_diameter_m.powi(2) - c.core_diameter_m.powi(2));
        num += (mu - core) * copper / (mu * mu);
        den += copper * copper / (mu * mu);
    }
    num / den
}

/// The Chaigne & Askenfelt (1994) hammers: (key, K N/m^alpha, alpha) of C2, C4, C7.
pub(super) const CHAIGNE_ASKENFELT: [(u8, f64, f64); 3] = [(36, 4.0e8, 2.3), (60, 4.5e9, 2.5), (96, 1.0e12, 3.0)];

/// The Broadwood's scale: its C-string table for lengths, impedances and the
/// wound cores' inharmonicity.
pub(super) fn broadwood() -> Scale {
    let wound_cs: Vec<&BroadwoodC> = BROADWOOD.iter().filter(|c| c.wrap_diameter_m > 0.0).collect();
    Scale {
        wound: Some(Wound {
            last_key: 50,
            core: STEEL,
            packing: broadwood_packing(),
            inharmonicity: wound_cs
                .iter()
                .map(|c| {
                    let ei = bending_stiffness_n_m2(c.core_diameter_m, STEEL.modulus_pa);
                    (c.midi_key, PI * PI * ei / (c.tension_n() * c.length_m * c.length_m))
                })
                .collect(),
        }),
        length_m: BROADWOOD.iter().map(|c| (c.midi_key, c.length_m)).collect(),
        ..broadwood_stringing_and_hammers()
    }
}

/// What the piano keeps of the Broadwood: its compass, stringing, total
/// impedance, wire step, hammers and felts. Lengths and wound cores are
/// each scale's own (left empty here).
pub(super) fn broadwood_stringing_and_hammers() -> Scale {
    Scale {
        keys: 21..=108,
        strings: &[(37, 1), (50, 2), (108, 3)],
        plain: &[(108, STEEL)],
        wound: None,
        length_m: Vec::new(),
        impedance_ns_m: BROADWOOD.iter().map(|c| (c.midi_key, c.impedance_ns_m())).collect(),
        wire_step_m: 0.025e-3,
        strike_ratio: BROADWOOD.iter().map(|c| (c.midi_key, c.strike_ratio)).collect(),
        hammer_mass_kg: BROADWOOD.iter().map(|c| (c.midi_key, c.hammer_mass_kg)).collect(),
        felt_exponent: CHAIGNE_ASKENFELT.iter().map(|&(k, _, a)| (k, a)).collect(),
        felt_stiffness: CHAIGNE_ASKENFELT.iter().map(|&(k, s, _)| (k, s)).collect(),
        unison_cents_at_c4: UNISON_CENTS_AT_C4,
        unison_exponent: UNISON_EXPONENT,
    }
}

/// A0's speaking length on the piano, m: a Yamaha C3's (1.86 m long, the C5's
/// smaller sister), "around 140 cm" (R. Overs, Pianotech list, 11 June 2003).
pub(super) const YAMAHA_C3_A0_LENGTH_M: f64 = 1.40;

/// The piano's lengths at C4 and C5, m: a Steinway M's (1.70 m; speaking
/// lengths of a 1936 M measured by P. Stewart, PTG Pianotech list, 16 October
/// 2019).
pub(super) const STEINWAY_M_LENGTHS_M: [(u8, f64); 2] = [(60, 0.640), (72, 0.340)];

/// From this key (C6) up the lengths are the Broadwood's (C6 181 mm, C7 96, C8
/// 51). A plain string's working stress is rho (2 L f)^2 whatever its gauge, so
/// the treble's lengths are set by what the wire bears, not by the case, and
/// grands' trebles differ little: C6 is 176 mm on the M above; C8 about 48 mm on
/// a Steinway B (J. Delacour, Pianotech list, 2 April 2007), 50 mm on the M, 53
/// mm on a Yamaha C3 (the North Bennet Street School's scale file quoted by T.
/// Parsons, PTG, March 2026). So the undamped top (G6 up), whose strings ring
/// with every key, keeps the strings its voicing (level table, regulation) was
/// measured on; it is where the model is most fragile (with the M's C6-C8 a top
/// key's ring moved by up to 4 dB, and A#7's crescendo dipped).
pub(super) const BROADWOOD_TOP_FROM_KEY: u8 = 84;

/// The first plain key; from it up to C4 the strings keep C4's working stress.
pub(super) const FIRST_PLAIN_KEY: u8 = 51;

/// The inharmonicity the Yamaha C5 has at A0, F#1 and A2: its lowest note, where
/// its B stops falling and where it starts to rise into the tenor, as `struck
/// compare` measures them on its recordings at velocity 92 (docs/calibration.md).
/// The piano's wound cores are sized for these, and for the first plain
/// string's above them.
pub(super) const C5_WOUND_INHARMONICITY: [(u8, f64); 3] = [(21, 2.58e-4), (30, 0.98e-4), (45, 0.80e-4)];

/// The piano's unison spread at C4, cents: a fifth of the Broadwood's.
/// Tuners leave unisons within about 1-2 cents (R. E. Kirk, JASA 31, 1959,
/// 1644-1648), but the Yamaha C5's recorded partials fall without beating
/// (2 of 629 fits over 0.3-2 s grow, `struck compare`): its unisons sit
/// where the bridge holds a unison's strings together (G. Weinreich, JASA
/// 62, 1977, 1474-1484: below a mistuning of about 2 Re(eps), one pitch and
/// a double decay instead of beats; 1-2 cents at the fundamentals from the
/// tenor up, less on the upper partials). At the Broadwood's full cent the
/// model's partials 4-7 from F#2 to C4 beat to silence within half a second
/// and swell back (117 of 705 fits grew); docs/calibration.md has the sweep.
pub(super) const PIANO_UNISON_CENTS_AT_C4: f64 = 0.2;
/// ...and the piano's spread widens as f^0.5 up the treble (0.1 cent at D2,
/// 0.5 at G6, 0.8 at C8): a tuning pin turned by the same small angle moves
/// a short string's pitch by more cents (the strain it changes is a larger
/// share of the string's), and the treble's unisons are the hardest to set
/// and to keep (our assumption: no measured spread by register was at
/// hand). Held a fifth of a cent all the way up, the treble's strings ring
/// on a C4 played staccato 13 dB more faintly than tuned this way (-83
/// against -64 dB at velocity 38), and the top octave's held notes, all
/// prompt sound, fall 40 dB in 0.2-0.5 of the recording's time.
pub(super) const PIANO_UNISON_EXPONENT: f64 = 0.5;

/// The piano: a 2 m grand (see the module doc).
pub(super) fn piano() -> Scale {
    let c4_length_m = STEINWAY_M_LENGTHS_M[0].1;
    let mut length_m = vec![
        (21, YAMAHA_C3_A0_LENGTH_M),
        (FIRST_PLAIN_KEY, c4_length_m * 2f64.powf((60 - FIRST_PLAIN_KEY) as f64 / 12.0)),
    ];
    length_m.extend(STEINWAY_M_LENGTHS_M);
    length_m
        .extend(BROADWOOD.iter().filter(|c| c.midi_key >= BROADWOOD_TOP_FROM_KEY).map(|c| (c.midi_key, c.length_m)));
    let mut scale = Scale {
        wound: Some(Wound {
            last_key: FIRST_PLAIN_KEY - 1,
            core: STEEL,
            packing: broadwood_packing(),
            inharmonicity: C5_WOUND_INHARMONICITY.to_vec(),
        }),
        length_m,
        unison_cents_at_c4: PIANO_UNISON_CENTS_AT_C4,
        unison_exponent: PIANO_UNISON_EXPONENT,
        ..broadwood_stringing_and_hammers()
    };
    // The cores run into the first plain string's inharmonicity (the plain
    // strings' rules do not depend on the wound ones).
    let first_plain = scale.row(FIRST_PLAIN_KEY).inharmonicity;
    scale.wound.as_mut().expect("the piano has wound strings").inharmonicity.push((FIRST_PLAIN_KEY, first_plain));
    scale
}

/// The lines of a rule's anchors, "NOTE value" joined by ", ".
pub(super) fn anchors(points: &[(u8, f64)], value: impl Fn(f64) -> String) -> String {
    points.iter().map(|&(k, v)| format!("{} {}", note_name(k), value(v))).collect::<Vec<_>>().join(", ")
}

/// The rules both pianos share, from the impedance on, with the scale's
/// unison spread.
pub(super) fn piano_common_rules(unison_cents_at_c4: f64, unison_exponent: f64) -> String {
    let z: Vec<String> = BROADWOOD.iter().map(|c| format!("{:.2}", c.impedance_ns_m())).collect();
    format!(
        "\
- Total impedance Z = 2 f (mass of the note's strings) through the Broadwood's
  C strings (Euphonics 12.2.1, Table 1),
  {z} N s/m,
  smooth through the 1-2 and 2-3 string breaks as a designer makes it
  (Euphonics 12.2 Figs. 8-10): per string mu = Z/(2 n L f), T = 2 Z L f/n.
- Wound strings: a steel core d = (64 T L^2 B/(pi^3 E))^(1/4) for the B above,
  rounded to 0.025 mm; a copper wrap whose outer diameter gives mu with
  packing factor p = {p:.4} (fitted to the Broadwood's three wound Cs), rounded
  to 0.01 mm.
- Plain strings: steel wire giving mu, rounded to 0.025 mm (music-wire half sizes).
- From the rounded sizes: mu, T of the stiff string tuned to f
  (4 L^2 mu f^2 - pi^2 E I/L^2), Z = n sqrt(T mu), B = pi^2 E I/(T L^2).
- Strike ratio: the Broadwood table's, linear between its Cs.
- Hammer mass: the Broadwood table's, linear (12 g at C1 to 5 g at C8),
  continued to A0.
- Felt: Chaigne & Askenfelt's C2 (K 4e8, alpha 2.3), C4 (4.5e9, 2.5) and C7
  (1e12, 3.0) hammers; alpha linear and log K linear, continued beyond C2 and C7.
- Unison spread: {u:.2} cent at C4, times (f/f_C4)^{e}.",
        z = z.join(", "),
        p = broadwood_packing(),
        u = unison_cents_at_c4,
        e = unison_exponent,
    )
}

pub(super) fn piano_rules() -> String {
    let scale = piano();
    let b = anchors(&scale.wound.as_ref().expect("the piano has wound strings").inharmonicity, |b| format!("{b:.2e}"));
    let lengths = anchors(&scale.length_m, |l| format!("{:.0} mm", l * 1e3));
    format!(
        "\
Struck: the piano's scale, key by key. Written by `cargo xtask piano-scale`
(xtask/src/piano_scale/, whose module doc gives the rules in full): edit the
rules there and regenerate, do not edit this file.

A grand of the Yamaha C5's size (2.00 m) with the stringing of Euphonics 12.2's
Broadwood: A0-C#2 single wound strings (17), D2-D3 wound pairs (13), D#3-C8
plain steel triplets (58).

Rules, per note of frequency f (A4 = 440 Hz) with n strings; interpolation is in
key number, log-linear unless said otherwise:
- Length L through
  {lengths}
  (continued beyond): A0 a Yamaha C3's (R. Overs, Pianotech list, 2003),
  C4-C5 a Steinway M's (P. Stewart, PTG Pianotech, 2019), C6-C8 the
  Broadwood's (Euphonics 12.2.1, Table 1; grands' trebles differ little),
  and from C4 down to the
  break the lengths double per octave, keeping C4's working stress
  rho (2 L f)^2 = {stress:.2} GPa in the lowest plain strings (our assumption: no
  published tenor lengths of the C5 were found).
- Wound strings' inharmonicity B through
  {b}:
  the Yamaha C5's at A0, F#1 and A2 (from its recordings), then the first plain
  string's, so B runs on through the break.
{common}",
        stress = STEEL.density_kg_m3 * (2.0 * STEINWAY_M_LENGTHS_M[0].1 * frequency_hz(60)).powi(2) / 1e9,
        common = piano_common_rules(scale.unison_cents_at_c4, scale.unison_exponent),
    )
}

/// The piano's file.
pub fn piano_csv() -> String {
    csv(&piano_rules(), &piano().rows())
}

pub(super) fn broadwood_rules() -> String {
    let scale = broadwood();
    let b =
        anchors(&scale.wound.as_ref().expect("the Broadwood has wound strings").inharmonicity, |b| format!("{b:.2e}"));
    format!(
        "\
Struck: the seed's Broadwood baby grand, key by key: the strings the seed's lab
(`struck demo`) strikes at its Cs and draws in Figs. 8-10; the piano instrument
does not play it. Written by `cargo xtask piano-scale` (xtask/src/piano_scale/,
whose module doc gives the rules in full): edit the rules there and regenerate,
do not edit this file.

The Broadwood baby grand of Euphonics 12.2, from its C strings (Euphonics 12.2.1,
Table 1: length, core and wrap diameters, course mass, strike ratio, hammer mass)
and its stringing (Euphonics 12.2): A0-C#2 single wound strings (17), D2-D3 wound
pairs (13), D#3-C8 plain steel triplets (58).

Rules, per note of frequency f (A4 = 440 Hz) with n strings; interpolation is in
key number, log-linear unless said otherwise:
- Length L through the table's C1..C8, the C1-C2 segment continued below C1.
- Wound strings' inharmonicity B through the table's wound Cs ({b}),
  which the cores keep smooth.
{common}",
        common = piano_common_rules(scale.unison_cents_at_c4, scale.unison_exponent),
    )
}

/// The seed's Broadwood file.
pub fn broadwood_csv() -> String {
    csv(&broadwood_rules(), &broadwood().rows())
}

/// The fortepiano's wire sizes at a few keys (assumed, see the rules): key,
/// material, diameter m. The total impedance these give is the target between them.
pub(super) const FORTEPIANO_GAUGES: [(u8, Material, f64); 5] =
    [(29, BRASS, 0.80e-3), (47, BRASS, 0.53e-3), (60, IRON, 0.47e-3), (72, IRON, 0.38e-3), (91, IRON, 0.27e-3)];

/// The leather's contact law matches the C7 felt's force at this compression, m;
/// beyond it the steeper leather is the harder (an assumption, see the rules).
pub(super) const LEATHER_CROSSOVER_M: f64 = 1.0e-4;
/// The leather's exponent at the lowest and the highest key (an assumption).
pub(super) const LEATHER_EXPONENT: [(u8, f64); 2] = [(29, 3.3), (91, 3.7)];
