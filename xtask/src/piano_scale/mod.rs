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

mod broadwood;
mod fortepiano;

pub use broadwood::broadwood_csv;
use broadwood::*;
pub use fortepiano::fortepiano_csv;
use fortepiano::*;

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
