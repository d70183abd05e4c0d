//! `cargo xtask piano-scale`: the per-key scales of the piano, the fortepiano and
//! the seed's Broadwood, written to `engine/data/piano-scale.csv`,
//! `engine/data/fortepiano-scale.csv` and `engine/data/broadwood-scale.csv`.
//!
//! The engine reads those files as data; this module is how they are made, so the
//! rules can be read, checked and changed, and the files regenerated rather than
//! edited by hand. Each file's header repeats its rules and explains its columns.
//!
//! The scales are designed the way a piano maker scales an instrument: lengths
//! first (the case decides them), then the total impedance of each note's strings,
//! which sets its loudness against the soundboard (Euphonics 12.2, Fig. 10), kept
//! smooth along the keyboard and through the breaks where the number of strings
//! per note changes; then the wire that gives that impedance, picked from the
//! sizes a maker can buy.
//!
//! Per note of frequency f with n strings of speaking length L:
//!
//! * total impedance Z (N s/m) = 2 f M, M the mass of all n strings, so each
//!   string has mass per length mu = Z / (2 n L f) and, as a flexible string,
//!   tension T = Z 2 L f / n. Through a break from n to n' strings mu and T both
//!   fall by n / n', and Z runs on.
//! * A plain wire has the diameter that gives mu, rounded to the wire step.
//! * A wound string (the piano's bass) has a steel core sized to keep the
//!   inharmonicity B = pi^3 E d^4 / (64 T L^2) on a smooth curve (log-linear
//!   through a few anchor notes), rounded to the wire step; then a copper wrap
//!   whose outer diameter D gives mu = rho_core pi d^2 / 4 + p rho_cu pi (D^2 -
//!   d^2) / 4, rounded to 0.01 mm. The packing factor p (the wrap's share of
//!   solid copper) is fitted to the Broadwood's three wound Cs.
//! * From the rounded sizes: mu, the tension of the stiff string tuned to f,
//!   T = 4 L^2 mu f^2 - pi^2 E I / L^2 (E I of the core or plain wire alone),
//!   Z = n sqrt(T mu) and B = pi^2 E I / (T L^2).
//!
//! Interpolation is in key number: log-linear (a constant ratio per key) for
//! lengths, impedances, inharmonicity and felt stiffness, linear for strike ratio,
//! hammer mass and felt exponent.
//!
//! The piano is a grand of the Yamaha C5's size (2.00 m), the instrument
//! `struck compare` holds it against. No string table of the C5 itself could be
//! found, so its lengths come from published measurements of grands around it
//! and from the working stress of its wire: A0 is a Yamaha C3's (1.86 m; about
//! 1.40 m, R. Overs, Pianotech list, 11 June 2003), C4 and C5 a Steinway M's
//! (1.70 m, 1936; P. Stewart, PTG Pianotech, 16 October 2019: 640 and 340 mm),
//! from C6 up the Broadwood's as before (a grand's treble is set by the wire's
//! strength, not the case, and grands' trebles differ little: C8 48-53 mm from a
//! Steinway B to a Yamaha C3), and the lowest plain strings are not
//! foreshortened: from C4 down to the break (D#3) they keep C4's working stress
//! rho (2 L f)^2 = 0.88 GPa, so the length doubles per octave (D#3 1.08 m), which
//! a 2 m case leaves room for (our assumption: no published tenor lengths of the
//! C5 were found). Its wound cores are sized for the inharmonicity the C5 has at
//! A0, F#1 and A2 (measured from its recordings, docs/calibration.md), rising
//! from A2 into the first plain string's, so B runs on through the break without
//! a jump. The rest is the Broadwood's: its stringing (17 single wound strings,
//! 13 wound pairs, 58 plain triplets), the total impedance of its C strings, its
//! hammers, and the Chaigne & Askenfelt (1994) felt of the C2, C4 and C7
//! hammers. Keeping the impedance keeps each note's course mass (M = Z / 2 f),
//! the hammer's mass against it and the strings' push on the bridge (n T / L =
//! 2 Z f): the longer strings change the inharmonicity and the tensions, not the
//! strike. The tensions rise with the lengths: 0.84 kN at D#3, up to 1.6 kN on
//! the single wound strings, whose 1.2 mm cores then work at up to 64 % of music
//! wire's strength (ASTM A228), more than a maker would choose; a real C5 of
//! this inharmonicity has a lighter bass, which would change the strike.
//!
//! The seed's Broadwood is Euphonics 12.2's baby grand: its C-string table
//! (Euphonics 12.2.1, Table 1) for lengths, impedances and the wound cores'
//! inharmonicity, with the same stringing, hammers and felts. The seed's lab
//! strikes its C strings and draws its stringing (Figs. 8-10); the instruments
//! do not play it. The fortepiano is a Viennese grand after Anton Walter, c.
//! 1795 (Germanisches Nationalmuseum MINe 109: compass FF-g''', knee levers,
//! triple stringing in the treble); where no measurement of it could be found
//! its rules say so.

use std::f64::consts::PI;
use std::fmt::Write as _;
use std::ops::RangeInclusive;
use std::path::Path;

use anyhow::{Context, Result};

/// Where the files go, from the workspace root.
pub const PIANO_PATH: &str = "engine/data/piano-scale.csv";
pub const FORTEPIANO_PATH: &str = "engine/data/fortepiano-scale.csv";
pub const BROADWOOD_PATH: &str = "engine/data/broadwood-scale.csv";

/// A wire's material.
#[derive(Clone, Copy, Debug, PartialEq)]
struct Material {
    name: &'static str,
    density_kg_m3: f64,
    modulus_pa: f64,
}

/// Music wire (the piano's plain strings and wound cores).
const STEEL: Material = Material { name: "steel", density_kg_m3: 7850.0, modulus_pa: 2.0e11 };
/// The fortepiano's soft iron: the density and stiffness of steel (carbon changes
/// strength, not these), a lower breaking stress.
const IRON: Material = Material { name: "iron", density_kg_m3: 7850.0, modulus_pa: 2.0e11 };
/// Yellow brass wire.
const BRASS: Material = Material { name: "brass", density_kg_m3: 8500.0, modulus_pa: 1.0e11 };
/// The copper of a wrap.
const COPPER_DENSITY_KG_M3: f64 = 8930.0;

/// Equal-tempered frequency, A4 = 440 Hz.
fn frequency_hz(midi_key: u8) -> f64 {
    440.0 * 2f64.powf((midi_key as f64 - 69.0) / 12.0)
}

fn note_name(midi_key: u8) -> String {
    const NAMES: [&str; 12] = ["C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"];
    format!("{}{}", NAMES[midi_key as usize % 12], midi_key as i32 / 12 - 1)
}

/// Interpolation through points (key, value) in key number; the end segments are
/// continued beyond the points when `extend`, else the end values are held.
fn interpolate(points: &[(u8, f64)], key: u8, log: bool, extend: bool) -> f64 {
    let i = points.iter().position(|&(k, _)| k >= key).unwrap_or(points.len() - 1).clamp(1, points.len() - 1);
    let ((k0, v0), (k1, v1)) = (points[i - 1], points[i]);
    let mut t = (key as f64 - k0 as f64) / (k1 as f64 - k0 as f64);
    if !extend {
        t = t.clamp(0.0, 1.0);
    }
    if log { v0 * (v1 / v0).powf(t) } else { v0 + (v1 - v0) * t }
}

/// `value` rounded to the nearest multiple of `step`.
fn round_to(value: f64, step: f64) -> f64 {
    (value / step).round() * step
}

fn wire_mass_per_length_kg_m(diameter_m: f64, density_kg_m3: f64) -> f64 {
    density_kg_m3 * PI * diameter_m * diameter_m / 4.0
}

/// Bending stiffness E I of a round wire, N m^2.
fn bending_stiffness_n_m2(diameter_m: f64, modulus_pa: f64) -> f64 {
    modulus_pa * PI * diameter_m.powi(4) / 64.0
}

/// Wound strings: a core wrapped in copper.
struct Wound {
    /// The last key with wound strings.
    last_key: u8,
    core: Material,
    /// The wrap's mass per length over that of solid copper filling the annulus.
    packing: f64,
    /// Inharmonicity the cores are sized for (log-linear, continued).
    inharmonicity: Vec<(u8, f64)>,
}

/// The rules of one instrument's scale.
struct Scale {
    keys: RangeInclusive<u8>,
    /// (last key, strings per note), in order up the keyboard.
    strings: &'static [(u8, usize)],
    /// (last key, material) of the plain wire, in order up the keyboard.
    plain: &'static [(u8, Material)],
    wound: Option<Wound>,
    /// Speaking length, m (log-linear, continued).
    length_m: Vec<(u8, f64)>,
    /// Total impedance of a note's strings, N s/m (log-linear, continued).
    impedance_ns_m: Vec<(u8, f64)>,
    /// Size step of the plain wire and the wound cores, m.
    wire_step_m: f64,
    /// Strike position over the speaking length (linear, held).
    strike_ratio: Vec<(u8, f64)>,
    /// Hammer mass, kg (linear, continued).
    hammer_mass_kg: Vec<(u8, f64)>,
    /// The hammer's contact law F = K C^alpha: alpha linear and log K linear, continued.
    felt_exponent: Vec<(u8, f64)>,
    felt_stiffness: Vec<(u8, f64)>,
    /// The widest string of a unison is this many cents off at C4, and the
    /// spread goes as f to this power.
    unison_cents_at_c4: f64,
    unison_exponent: f64,
}

/// The outer diameter of a wound string's wrap is rounded to this, m.
const WRAP_STEP_M: f64 = 1.0e-5;

/// Unison spread: the widest string of a unison is this many cents off at C4
/// (the Broadwood's and the fortepiano's)...
const UNISON_CENTS_AT_C4: f64 = 1.0;
/// ...and the spread goes as f^-0.2, wider in the bass where a tuner hears slow
/// beats less, narrower in the treble where the same cents beat faster (1.3 cents
/// at D2, 0.6 at C8).
const UNISON_EXPONENT: f64 = -0.2;

/// One key of a scale, everything in SI units.
#[derive(Clone, Debug, PartialEq)]
struct Row {
    midi_key: u8,
    strings: usize,
    material: String,
    length_m: f64,
    core_diameter_m: f64,
    /// 0 for a plain wire.
    wrap_diameter_m: f64,
    core_modulus_pa: f64,
    mass_per_length_kg_m: f64,
    tension_n: f64,
    total_impedance_ns_m: f64,
    inharmonicity: f64,
    strike_ratio: f64,
    hammer_mass_kg: f64,
    felt_stiffness: f64,
    felt_exponent: f64,
    unison_spread_cents: f64,
}

impl Scale {
    fn strings(&self, key: u8) -> usize {
        self.strings.iter().find(|&&(last, _)| key <= last).expect("every key has a string count").1
    }

    fn plain_material(&self, key: u8) -> Material {
        self.plain.iter().find(|&&(last, _)| key <= last).expect("every key has a material").1
    }

    fn row(&self, key: u8) -> Row {
        let f = frequency_hz(key);
        let n = self.strings(key);
        let length_m = interpolate(&self.length_m, key, true, true);
        let impedance = interpolate(&self.impedance_ns_m, key, true, true);
        let target_mu = impedance / (2.0 * n as f64 * length_m * f);
        let flexible_tension_n = impedance * 2.0 * length_m * f / n as f64;

        let (material, core, wrap_m, mu) = match &self.wound {
            Some(w) if key <= w.last_key => {
                let b = interpolate(&w.inharmonicity, key, true, true);
                let core_m =
                    (64.0 * flexible_tension_n * length_m * length_m * b / (PI.powi(3) * w.core.modulus_pa)).powf(0.25);
                let core_m = round_to(core_m, self.wire_step_m);
                let core_mu = wire_mass_per_length_kg_m(core_m, w.core.density_kg_m3);
                let copper = w.packing * COPPER_DENSITY_KG_M3 * PI / 4.0;
                let wrap_m = round_to(((target_mu - core_mu) / copper + core_m * core_m).sqrt(), WRAP_STEP_M);
                let mu = core_mu + copper * (wrap_m * wrap_m - core_m * core_m);
                (format!("{}+copper", w.core.name), (w.core, core_m), wrap_m, mu)
            }
            _ => {
                let m = self.plain_material(key);
                let d = round_to((4.0 * target_mu / (PI * m.density_kg_m3)).sqrt(), self.wire_step_m);
                (m.name.to_string(), (m, d), 0.0, wire_mass_per_length_kg_m(d, m.density_kg_m3))
            }
        };
        let (core_material, core_m) = core;
        let ei = bending_stiffness_n_m2(core_m, core_material.modulus_pa);
        let tension_n = 4.0 * length_m * length_m * mu * f * f - PI * PI * ei / (length_m * length_m);
        let unison_spread_cents =
            if n > 1 { self.unison_cents_at_c4 * (f / frequency_hz(60)).powf(self.unison_exponent) } else { 0.0 };
        Row {
            midi_key: key,
            strings: n,
            material,
            length_m,
            core_diameter_m: core_m,
            wrap_diameter_m: wrap_m,
            core_modulus_pa: core_material.modulus_pa,
            mass_per_length_kg_m: mu,
            tension_n,
            total_impedance_ns_m: n as f64 * (tension_n * mu).sqrt(),
            inharmonicity: PI * PI * ei / (tension_n * length_m * length_m),
            strike_ratio: interpolate(&self.strike_ratio, key, false, false),
            hammer_mass_kg: interpolate(&self.hammer_mass_kg, key, false, true),
            felt_stiffness: interpolate(&self.felt_stiffness, key, true, true),
            felt_exponent: interpolate(&self.felt_exponent, key, false, true),
            unison_spread_cents,
        }
    }

    fn rows(&self) -> Vec<Row> {
        self.keys.clone().map(|k| self.row(k)).collect()
    }
}

/// The columns, in order, with their units.
const COLUMNS: &str = "\
#   midi_key              MIDI key number (A0 = 21)
#   note                  note name, C4 = middle C
#   strings               strings per note
#   material              wire: steel, iron, brass; steel+copper = steel core, copper wrap
#   length_m              speaking length, m
#   core_diameter_m       diameter of the plain wire, or of a wound string's core, m
#   wrap_diameter_m       outer diameter of a wound string's wrap, m (0 = plain wire)
#   core_modulus_pa       Young's modulus of the plain wire or core, Pa (the wrap adds no stiffness)
#   mass_per_length_kg_m  mass per length of one string, kg/m (core and wrap together)
#   tension_n             tension of one string, N (the stiff string tuned to the note)
#   total_impedance_ns_m  wave impedance of all the note's strings, n sqrt(T mu), N s/m
#   inharmonicity         B = pi^2 E I / (T L^2) of one string
#   strike_ratio          strike point over the speaking length, from the near end
#   hammer_mass_kg        hammer mass, kg (the whole hammer, for all the note's strings)
#   felt_stiffness        K of the contact law F = K C^alpha (C compression, m), N/m^alpha
#   felt_exponent         alpha of the contact law
#   unison_spread_cents   detuning of a unison's widest string, cents (0: one string)
";

const HEADER_LINE: &str = "midi_key,note,strings,material,length_m,core_diameter_m,wrap_diameter_m,core_modulus_pa,\
mass_per_length_kg_m,tension_n,total_impedance_ns_m,inharmonicity,strike_ratio,hammer_mass_kg,felt_stiffness,\
felt_exponent,unison_spread_cents";

fn csv(title_and_rules: &str, rows: &[Row]) -> String {
    let mut out = String::new();
    for line in title_and_rules.lines() {
        out.push_str(if line.is_empty() { "#" } else { "# " });
        out.push_str(line);
        out.push('\n');
    }
    out.push_str("#\n# Columns:\n");
    out.push_str(COLUMNS);
    out.push_str(HEADER_LINE);
    out.push('\n');
    for r in rows {
        writeln!(
            out,
            "{},{},{},{},{:.5},{:.6},{:.6},{:.3e},{:.5e},{:.2},{:.4},{:.4e},{:.4},{:.6},{:.5e},{:.4},{:.3}",
            r.midi_key,
            note_name(r.midi_key),
            r.strings,
            r.material,
            r.length_m,
            r.core_diameter_m,
            r.wrap_diameter_m,
            r.core_modulus_pa,
            r.mass_per_length_kg_m,
            r.tension_n,
            r.total_impedance_ns_m,
            r.inharmonicity,
            r.strike_ratio,
            r.hammer_mass_kg,
            r.felt_stiffness,
            r.felt_exponent,
            r.unison_spread_cents,
        )
        .expect("writing to a String");
    }
    out
}

/// A C string of the Broadwood (Euphonics 12.2.1, Table 1).
struct BroadwoodC {
    midi_key: u8,
    length_m: f64,
    strings: usize,
    core_diameter_m: f64,
    /// 0 for a plain wire.
    wrap_diameter_m: f64,
    /// Mass of all the note's strings, kg.
    course_mass_kg: f64,
    strike_ratio: f64,
    hammer_mass_kg: f64,
}

impl BroadwoodC {
    /// Mass per length of one string, kg/m.
    fn mass_per_length_kg_m(&self) -> f64 {
        self.course_mass_kg / (self.strings as f64 * self.length_m)
    }

    /// Total impedance, 2 f M, N s/m.
    fn impedance_ns_m(&self) -> f64 {
        2.0 * frequency_hz(self.midi_key) * self.course_mass_kg
    }

    /// The flexible string's tension, T = Z 2 L f / n, N.
    fn tension_n(&self) -> f64 {
        self.impedance_ns_m() * 2.0 * self.length_m * frequency_hz(self.midi_key) / self.strings as f64
    }
}

const BROADWOOD: [BroadwoodC; 8] = [
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
fn broadwood_packing() -> f64 {
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
const CHAIGNE_ASKENFELT: [(u8, f64, f64); 3] = [(36, 4.0e8, 2.3), (60, 4.5e9, 2.5), (96, 1.0e12, 3.0)];

/// The Broadwood's scale: its C-string table for lengths, impedances and the
/// wound cores' inharmonicity.
fn broadwood() -> Scale {
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
fn broadwood_stringing_and_hammers() -> Scale {
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
const YAMAHA_C3_A0_LENGTH_M: f64 = 1.40;

/// The piano's lengths at C4 and C5, m: a Steinway M's (1.70 m; speaking
/// lengths of a 1936 M measured by P. Stewart, PTG Pianotech list, 16 October
/// 2019).
const STEINWAY_M_LENGTHS_M: [(u8, f64); 2] = [(60, 0.640), (72, 0.340)];

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
const BROADWOOD_TOP_FROM_KEY: u8 = 84;

/// The first plain key; from it up to C4 the strings keep C4's working stress.
const FIRST_PLAIN_KEY: u8 = 51;

/// The inharmonicity the Yamaha C5 has at A0, F#1 and A2: its lowest note, where
/// its B stops falling and where it starts to rise into the tenor, as `struck
/// compare` measures them on its recordings at velocity 92 (docs/calibration.md).
/// The piano's wound cores are sized for these, and for the first plain
/// string's above them.
const C5_WOUND_INHARMONICITY: [(u8, f64); 3] = [(21, 2.58e-4), (30, 0.98e-4), (45, 0.80e-4)];

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
const PIANO_UNISON_CENTS_AT_C4: f64 = 0.2;
/// ...and the piano's spread widens as f^0.5 up the treble (0.1 cent at D2,
/// 0.5 at G6, 0.8 at C8): a tuning pin turned by the same small angle moves
/// a short string's pitch by more cents (the strain it changes is a larger
/// share of the string's), and the treble's unisons are the hardest to set
/// and to keep (our assumption: no measured spread by register was at
/// hand). Held a fifth of a cent all the way up, the treble's strings ring
/// on a C4 played staccato 13 dB more faintly than tuned this way (-83
/// against -64 dB at velocity 38), and the top octave's held notes, all
/// prompt sound, fall 40 dB in 0.2-0.5 of the recording's time.
const PIANO_UNISON_EXPONENT: f64 = 0.5;

/// The piano: a 2 m grand (see the module doc).
fn piano() -> Scale {
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
fn anchors(points: &[(u8, f64)], value: impl Fn(f64) -> String) -> String {
    points.iter().map(|&(k, v)| format!("{} {}", note_name(k), value(v))).collect::<Vec<_>>().join(", ")
}

/// The rules both pianos share, from the impedance on, with the scale's
/// unison spread.
fn piano_common_rules(unison_cents_at_c4: f64, unison_exponent: f64) -> String {
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

fn piano_rules() -> String {
    let scale = piano();
    let b = anchors(&scale.wound.as_ref().expect("the piano has wound strings").inharmonicity, |b| format!("{b:.2e}"));
    let lengths = anchors(&scale.length_m, |l| format!("{:.0} mm", l * 1e3));
    format!(
        "\
Struck: the piano's scale, key by key. Written by `cargo xtask piano-scale`
(xtask/src/piano_scale.rs, whose module doc gives the rules in full): edit the
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

fn broadwood_rules() -> String {
    let scale = broadwood();
    let b =
        anchors(&scale.wound.as_ref().expect("the Broadwood has wound strings").inharmonicity, |b| format!("{b:.2e}"));
    format!(
        "\
Struck: the seed's Broadwood baby grand, key by key: the strings the seed's lab
(`struck demo`) strikes at its Cs and draws in Figs. 8-10; the piano instrument
does not play it. Written by `cargo xtask piano-scale` (xtask/src/piano_scale.rs,
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
const FORTEPIANO_GAUGES: [(u8, Material, f64); 5] =
    [(29, BRASS, 0.80e-3), (47, BRASS, 0.53e-3), (60, IRON, 0.47e-3), (72, IRON, 0.38e-3), (91, IRON, 0.27e-3)];

/// The leather's contact law matches the C7 felt's force at this compression, m;
/// beyond it the steeper leather is the harder (an assumption, see the rules).
const LEATHER_CROSSOVER_M: f64 = 1.0e-4;
/// The leather's exponent at the lowest and the highest key (an assumption).
const LEATHER_EXPONENT: [(u8, f64); 2] = [(29, 3.3), (91, 3.7)];

fn fortepiano() -> Scale {
    let mut scale = Scale {
        keys: 29..=91,
        strings: &[(76, 2), (91, 3)],
        plain: &[(47, BRASS), (91, IRON)],
        wound: None,
        length_m: vec![
            (29, 1.65),
            (36, 1.45),
            (41, 1.25),
            (48, 0.97),
            (53, 0.76),
            (60, 0.55),
            (72, 0.275),
            (84, 0.1375),
            (91, 0.0917),
        ],
        impedance_ns_m: Vec::new(),
        wire_step_m: 0.01e-3,
        strike_ratio: vec![(29, 0.125), (60, 0.115), (91, 0.09)],
        hammer_mass_kg: vec![(29, 3.0e-3), (91, 1.2e-3)],
        felt_exponent: LEATHER_EXPONENT.to_vec(),
        felt_stiffness: Vec::new(),
        unison_cents_at_c4: UNISON_CENTS_AT_C4,
        unison_exponent: UNISON_EXPONENT,
    };
    let (c7_stiffness, c7_exponent) = (CHAIGNE_ASKENFELT[2].1, CHAIGNE_ASKENFELT[2].2);
    scale.felt_stiffness = LEATHER_EXPONENT
        .iter()
        .map(|&(k, alpha)| (k, c7_stiffness * LEATHER_CROSSOVER_M.powf(c7_exponent - alpha)))
        .collect();
    scale.impedance_ns_m = FORTEPIANO_GAUGES
        .iter()
        .map(|&(k, m, d)| {
            let length_m = interpolate(&scale.length_m, k, true, true);
            let mu = wire_mass_per_length_kg_m(d, m.density_kg_m3);
            (k, scale.strings(k) as f64 * 2.0 * length_m * frequency_hz(k) * mu)
        })
        .collect();
    scale
}

fn fortepiano_rules() -> String {
    let scale = fortepiano();
    let gauges: Vec<String> =
        FORTEPIANO_GAUGES.iter().map(|(k, m, d)| format!("{} {} {:.2} mm", note_name(*k), m.name, d * 1e3)).collect();
    format!(
        "\
Struck: the fortepiano's scale, key by key. Written by `cargo xtask piano-scale`
(xtask/src/piano_scale.rs, whose module doc gives the rules in full): edit the
rules there and regenerate, do not edit this file.

A Viennese grand after Anton Walter, c. 1795 (Germanisches Nationalmuseum MINe
109, as described by its copyist D. Wraight: compass FF-g''' = F1-G6, knee levers
for the dampers and the moderator, triple stringing in the treble; case 2.21 m
long). Walter strung the bass in plain brass (no wound strings), the rest in soft
iron; hammers are wood covered with layers of sheepskin leather. Tuned here at
A4 = 440 Hz. No measured string table, hammer masses or leather law of this
instrument could be found: every number below marked (assumed) is a choice made
to fit what is known, not a measurement.

Rules, per note of frequency f with n strings; interpolation is in key number,
log-linear unless said otherwise:
- Strings: pairs F1-E5, triplets F5-G6 (where the triplets begin: assumed).
  Brass F1-B2, iron C3-G6 (the break: assumed, where the bass scale's
  foreshortening would overstress brass).
- Length (assumed): iron at C5 275 mm, halving each octave from C4 up
  (Pythagorean), so iron works at 650 MPa, about two-thirds of soft iron's
  breaking stress; foreshortened below C4 to 1.65 m at F1 (a 2.2 m case). Brass
  works at 180 MPa at F1 rising to 520 MPa at B2, iron at 500-650 MPa.
- Total impedance Z: through the impedances that assumed gauges give on these
  lengths, {g},
  smooth through the brass-iron and 2-3 string breaks. Per string
  mu = Z/(2 n L f); plain wire giving mu, rounded to 0.01 mm (the reproduction
  wire makers' step).
- From the rounded sizes: mu, T of the stiff string tuned to f
  (4 L^2 mu f^2 - pi^2 E I/L^2), Z = n sqrt(T mu), B = pi^2 E I/(T L^2).
- Strike ratio (assumed): 1/8 at F1, 0.115 at C4, 0.09 at G6, linear.
- Hammer mass (assumed): linear from 3 g at F1 to 1.2 g at G6, a small block of
  wood under a few layers of leather on a light shank: a quarter to a fifth of
  the modern piano's hammer at the same key.
- Leather (assumed): F = K C^alpha steeper than the C7 felt's alpha = 3.0, as the
  seed says (Euphonics 12.2: leather's nonlinearity is even more extreme);
  alpha linear from {a0} at F1 to {a1} at G6 (the piano hammers Hall & Askenfelt
  measured ranged from 1.5 to 3.5), and K such that the leather's force equals
  the C7 felt's (K 1e12, alpha 3.0) at {c} mm compression, the thin, soft grain
  surface: past it the leather is the harder. Hence log K linear in key.
- Unison spread: {u:.1} cent at C4, times (f/f_C4)^{e}.",
        g = gauges.chunks(3).map(|c| c.join(", ")).collect::<Vec<_>>().join(",\n  "),
        a0 = LEATHER_EXPONENT[0].1,
        a1 = LEATHER_EXPONENT[1].1,
        c = LEATHER_CROSSOVER_M * 1e3,
        u = scale.unison_cents_at_c4,
        e = scale.unison_exponent,
    )
}

/// The fortepiano's file.
pub fn fortepiano_csv() -> String {
    csv(&fortepiano_rules(), &fortepiano().rows())
}

/// The largest change of total impedance between neighbouring keys, as a fraction,
/// and the upper key of that pair.
fn largest_impedance_step(rows: &[Row]) -> (f64, u8) {
    rows.windows(2)
        .map(|w| ((w[1].total_impedance_ns_m / w[0].total_impedance_ns_m - 1.0).abs(), w[1].midi_key))
        .fold((0.0, 0), |a, b| if b.0 > a.0 { b } else { a })
}

/// Writes `text` to `path` through a temporary file, so a failure leaves no
/// half-written file.
fn write_atomically(path: &Path, text: &str) -> Result<()> {
    let temporary = path.with_extension("csv.tmp");
    std::fs::write(&temporary, text).with_context(|| format!("could not write {}", temporary.display()))?;
    std::fs::rename(&temporary, path).with_context(|| format!("could not replace {}", path.display()))
}

/// `cargo xtask piano-scale`, run from the workspace root.
pub fn run() -> Result<()> {
    for (path, text, rows) in [
        (PIANO_PATH, piano_csv(), piano().rows()),
        (FORTEPIANO_PATH, fortepiano_csv(), fortepiano().rows()),
        (BROADWOOD_PATH, broadwood_csv(), broadwood().rows()),
    ] {
        write_atomically(Path::new(path), &text)?;
        let (step, key) = largest_impedance_step(&rows);
        println!(
            "wrote {path}: {} keys, largest neighbour step in total impedance {:.1} % (at {})",
            rows.len(),
            step * 100.0,
            note_name(key)
        );
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    fn committed(path: &str) -> String {
        let file = Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask/ has a parent").join(path);
        std::fs::read_to_string(&file).unwrap_or_else(|e| panic!("{}: {e}", file.display()))
    }

    #[test]
    fn the_committed_scales_are_what_the_rules_give() {
        for (path, text) in
            [(PIANO_PATH, piano_csv()), (FORTEPIANO_PATH, fortepiano_csv()), (BROADWOOD_PATH, broadwood_csv())]
        {
            assert!(committed(path) == text, "{path} is out of date: run `cargo xtask piano-scale`");
        }
    }

    #[test]
    fn the_packing_factor_gives_the_broadwood_wound_masses() {
        let p = broadwood_packing();
        assert!((0.77..0.80).contains(&p), "{p}");
        for c in BROADWOOD.iter().filter(|c| c.wrap_diameter_m > 0.0) {
            let core = wire_mass_per_length_kg_m(c.core_diameter_m, STEEL.density_kg_m3);
            let wrap = p * COPPER_DENSITY_KG_M3 * PI / 4.0 * (c.wrap_diameter_m.powi(2) - c.core_diameter_m.powi(2));
            let error = (core + wrap) / c.mass_per_length_kg_m() - 1.0;
            assert!(error.abs() < 0.01, "{}: {error}", note_name(c.midi_key));
        }
    }

    #[test]
    fn interpolation_holds_or_continues() {
        let points = [(24, 1.0), (36, 2.0)];
        assert!((interpolate(&points, 30, true, false) - 2f64.sqrt()).abs() < 1e-12);
        assert_eq!(interpolate(&points, 12, false, false), 1.0);
        assert!((interpolate(&points, 12, true, true) - 0.5).abs() < 1e-12);
        assert_eq!(note_name(21), "A0");
        assert_eq!(note_name(61), "C#4");
    }
}
