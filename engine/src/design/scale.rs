//! A keyboard instrument's scale: every key's strings and hammer, read from a data
//! file in `engine/data/` (compiled in). The files are written by `cargo xtask
//! piano-scale` from documented rules (its module doc, and each file's header);
//! the engine only reads them.
//!
//! A string's mass per length is taken as given (for a wound string, core and
//! wrap together); its bending stiffness is the core's or plain wire's alone,
//! E pi d^4 / 64 (the wrap adds mass, not stiffness; Euphonics 12.2.1); its outer
//! diameter sets the air damping. The tension, total impedance and inharmonicity
//! in the file are the derivation's results, for checking: the engine derives
//! its own from the string it builds.

use std::fmt;

use super::common::{Losses, detuned_hz, struck_peak_n, unison_cents, voiced_law, voiced_position, with_losses};
use super::{ExciterDesign, Voicing, key_frequency_hz};
use crate::exciter::hammer::contact::ContactLaw;
use crate::string::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

/// One key of a scale, in SI units (see the file's header for the columns).
#[derive(Clone, Debug, PartialEq)]
pub(super) struct ScaleRow {
    pub midi_key: u8,
    pub note: String,
    pub strings: usize,
    /// steel, iron, brass, or steel+copper (a wound string).
    pub material: String,
    pub length_m: f64,
    pub core_diameter_m: f64,
    /// 0 for a plain wire.
    pub wrap_diameter_m: f64,
    pub core_modulus_pa: f64,
    pub mass_per_length_kg_m: f64,
    pub tension_n: f64,
    pub total_impedance_ns_m: f64,
    pub inharmonicity: f64,
    pub strike_ratio: f64,
    pub hammer_mass_kg: f64,
    pub felt_stiffness: f64,
    pub felt_exponent: f64,
    pub unison_spread_cents: f64,
}

/// Why a scale file cannot be read.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub(super) enum ScaleError {
    #[error("no header line (the first line not starting with #)")]
    NoHeader,
    #[error("the header has no column \"{0}\"")]
    MissingColumn(&'static str),
    #[error("line {line}: {reason}")]
    BadLine { line: usize, reason: String },
    #[error("keys must run one by one upward: key {found} follows key {previous}")]
    NotConsecutive { previous: u8, found: u8 },
    #[error("no keys")]
    Empty,
}

/// A whole scale: one row per key, lowest key first, no gaps.
#[derive(Clone, Debug, PartialEq)]
pub(super) struct Scale {
    rows: Vec<ScaleRow>,
}

const COLUMNS: [&str; 17] = [
    "midi_key",
    "note",
    "strings",
    "material",
    "length_m",
    "core_diameter_m",
    "wrap_diameter_m",
    "core_modulus_pa",
    "mass_per_length_kg_m",
    "tension_n",
    "total_impedance_ns_m",
    "inharmonicity",
    "strike_ratio",
    "hammer_mass_kg",
    "felt_stiffness",
    "felt_exponent",
    "unison_spread_cents",
];

/// A field that must be a finite number, positive unless `zero_allowed`.
fn number(field: &str, column: &str, zero_allowed: bool) -> Result<f64, String> {
    let value: f64 = field.trim().parse().map_err(|_| format!("{column} \"{field}\" is not a number"))?;
    if !value.is_finite() || value < 0.0 || (value == 0.0 && !zero_allowed) {
        return Err(format!("{column} {value} is out of range"));
    }
    Ok(value)
}

impl Scale {
    /// Parse a scale file: '#' comment lines, a header line naming the columns
    /// (in any order), then one line per key.
    pub(super) fn parse(text: &str) -> Result<Scale, ScaleError> {
        let mut lines = text.lines().enumerate().filter(|(_, l)| !l.starts_with('#') && !l.trim().is_empty());
        let (_, header) = lines.next().ok_or(ScaleError::NoHeader)?;
        let names: Vec<&str> = header.split(',').map(str::trim).collect();
        let mut index = [0usize; COLUMNS.len()];
        for (slot, column) in index.iter_mut().zip(COLUMNS) {
            *slot = names.iter().position(|n| *n == column).ok_or(ScaleError::MissingColumn(column))?;
        }
        let mut rows: Vec<ScaleRow> = Vec::new();
        for (number_from_0, line) in lines {
            let row = Self::parse_row(line, &index, names.len())
                .map_err(|reason| ScaleError::BadLine { line: number_from_0 + 1, reason })?;
            if let Some(previous) = rows.last()
                && row.midi_key != previous.midi_key + 1
            {
                return Err(ScaleError::NotConsecutive { previous: previous.midi_key, found: row.midi_key });
            }
            rows.push(row);
        }
        if rows.is_empty() {
            return Err(ScaleError::Empty);
        }
        Ok(Scale { rows })
    }

    fn parse_row(line: &str, index: &[usize; COLUMNS.len()], width: usize) -> Result<ScaleRow, String> {
        let fields: Vec<&str> = line.split(',').map(str::trim).collect();
        if fields.len() != width {
            return Err(format!("{} fields, the header has {width}", fields.len()));
        }
        let get = |i: usize| fields[index[i]];
        let num = |i: usize| number(get(i), COLUMNS[i], false);
        let midi_key =
            get(0).parse::<u8>().ok().filter(|k| *k < 128).ok_or_else(|| format!("bad key \"{}\"", get(0)))?;
        let strings = get(2).parse::<usize>().ok().filter(|n| (1..=4).contains(n)).ok_or("strings must be 1 to 4")?;
        Ok(ScaleRow {
            midi_key,
            note: get(1).to_string(),
            strings,
            material: get(3).to_string(),
            length_m: num(4)?,
            core_diameter_m: num(5)?,
            wrap_diameter_m: number(get(6), COLUMNS[6], true)?,
            core_modulus_pa: num(7)?,
            mass_per_length_kg_m: num(8)?,
            tension_n: num(9)?,
            total_impedance_ns_m: num(10)?,
            inharmonicity: num(11)?,
            strike_ratio: num(12)?,
            hammer_mass_kg: num(13)?,
            felt_stiffness: num(14)?,
            felt_exponent: num(15)?,
            unison_spread_cents: number(get(16), COLUMNS[16], true)?,
        })
    }

    /// Parse a compiled-in scale, panicking with the file's name if it is
    /// malformed (a build error, caught by the instrument's tests).
    pub(super) fn compiled_in(name: &str, text: &str) -> Scale {
        Scale::parse(text).unwrap_or_else(|e| panic!("{name}: {e}"))
    }

    #[cfg(test)]
    pub(super) fn keys(&self) -> std::ops::RangeInclusive<u8> {
        self.rows[0].midi_key..=self.rows[self.rows.len() - 1].midi_key
    }

    #[cfg(test)]
    pub(super) fn rows(&self) -> &[ScaleRow] {
        &self.rows
    }

    /// The row of `midi_key`; None outside the scale.
    pub(super) fn row(&self, midi_key: u8) -> Option<&ScaleRow> {
        let first = self.rows[0].midi_key;
        midi_key.checked_sub(first).and_then(|i| self.rows.get(i as usize))
    }
}

impl ScaleRow {
    pub(super) fn is_wound(&self) -> bool {
        self.wrap_diameter_m > 0.0
    }

    /// The diameter the air sees, m.
    pub(super) fn outer_diameter_m(&self) -> f64 {
        if self.is_wound() { self.wrap_diameter_m } else { self.core_diameter_m }
    }

    /// The hammer's contact law as built, before voicing.
    pub(super) fn contact_law(&self) -> ContactLaw {
        ContactLaw { stiffness: self.felt_stiffness, exponent: self.felt_exponent }
    }

    /// The key's strings, each detuned by its share of the unison spread (times the
    /// voicing's `unison_detune`), with losses from `losses` (times the voicing's
    /// `damping`), modes up to `max_frequency_hz`.
    pub(super) fn string_specs(&self, voicing: &Voicing, losses: &Losses, max_frequency_hz: f64) -> Vec<StringSpec> {
        unison_cents(self.midi_key, self.strings, self.unison_spread_cents, voicing)
            .into_iter()
            .map(|cents| {
                let spec = StringSpec {
                    length_m: self.length_m,
                    tuning: Tuning::FirstPartialHz(detuned_hz(self.midi_key, cents)),
                    mass: Mass::PerLengthKgM(self.mass_per_length_kg_m),
                    stiffness: Stiffness::YoungsModulus {
                        modulus_pa: self.core_modulus_pa,
                        bending_diameter_m: self.core_diameter_m,
                    },
                    damping: Damping::UniformQ(1.0), // replaced by with_losses
                    max_frequency_hz,
                    outer_diameter_m: Some(self.outer_diameter_m()),
                };
                with_losses(spec, losses, voicing.damping)
            })
            .collect()
    }

    /// The key's hammer with the voicing applied.
    pub(super) fn hammer(&self, voicing: &Voicing) -> ExciterDesign {
        ExciterDesign::Hammer {
            mass_kg: self.hammer_mass_kg * voicing.hammer_mass,
            law: voiced_law(self.contact_law(), voicing),
            position: voiced_position(self.strike_ratio, voicing),
        }
    }

    /// The estimated peak bridge force of the unvoiced hammer striking the
    /// strings at `speed_m_s`, N (see [`struck_peak_n`]).
    pub(super) fn struck_peak_n(&self, speed_m_s: f64) -> f64 {
        let n = self.strings as f64;
        let tension_n = self.tuned_tension_n();
        struck_peak_n(
            n * (tension_n * self.mass_per_length_kg_m).sqrt(),
            n * tension_n,
            self.length_m,
            self.strike_ratio,
            self.hammer_mass_kg,
            speed_m_s,
        )
    }

    /// The tension of one string tuned exactly to the key (no detuning), N.
    pub(super) fn tuned_tension_n(&self) -> f64 {
        let (l, f) = (self.length_m, key_frequency_hz(self.midi_key));
        let ei = self.core_modulus_pa * std::f64::consts::PI * self.core_diameter_m.powi(4) / 64.0;
        4.0 * l * l * self.mass_per_length_kg_m * f * f - std::f64::consts::PI.powi(2) * ei / (l * l)
    }
}

impl fmt::Display for ScaleRow {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} ({})", self.note, self.midi_key)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const HEADER: &str = "midi_key,note,strings,material,length_m,core_diameter_m,wrap_diameter_m,core_modulus_pa,\
mass_per_length_kg_m,tension_n,total_impedance_ns_m,inharmonicity,strike_ratio,hammer_mass_kg,felt_stiffness,\
felt_exponent,unison_spread_cents";
    const ROW_60: &str = "60,C4,3,steel,0.63900,0.001000,0.000000,2.000e11,6.16538e-3,689.00,6.1830,3.4400e-4,\
0.1250,0.009000,4.50000e9,2.5000,1.000";
    const ROW_61: &str = "61,C#4,3,steel,0.60380,0.001000,0.000000,2.000e11,6.16538e-3,690.60,6.1900,3.8500e-4,\
0.1246,0.008917,4.98000e9,2.5083,0.990";

    #[test]
    fn a_scale_parses_with_comments_and_any_column_order() {
        let text = format!("# a comment\n#\n{HEADER}\n{ROW_60}\n{ROW_61}\n");
        let scale = Scale::parse(&text).unwrap();
        assert_eq!(scale.keys(), 60..=61);
        let c4 = scale.row(60).unwrap();
        assert_eq!((c4.note.as_str(), c4.strings, c4.material.as_str()), ("C4", 3, "steel"));
        assert_eq!(c4.length_m, 0.639);
        assert!(!c4.is_wound() && c4.outer_diameter_m() == 0.001);
        assert!(scale.row(59).is_none() && scale.row(62).is_none());

        // Columns found by name: swap the first two everywhere.
        let swap = |l: &str| {
            let mut f: Vec<&str> = l.split(',').collect();
            f.swap(0, 1);
            f.join(",")
        };
        let swapped = format!("{}\n{}\n", swap(HEADER), swap(ROW_60));
        assert_eq!(Scale::parse(&swapped).unwrap().row(60), Some(c4));
    }

    #[test]
    fn malformed_scales_are_refused_with_the_reason() {
        assert_eq!(Scale::parse("# only comments\n"), Err(ScaleError::NoHeader));
        assert_eq!(Scale::parse(&format!("{HEADER}\n")), Err(ScaleError::Empty));
        let no_note = HEADER.replace("note,", "name,");
        assert_eq!(Scale::parse(&format!("{no_note}\n{ROW_60}\n")), Err(ScaleError::MissingColumn("note")));
        assert_eq!(
            Scale::parse(&format!("{HEADER}\n{ROW_61}\n{ROW_60}\n")),
            Err(ScaleError::NotConsecutive { previous: 61, found: 60 })
        );
        let negative = ROW_60.replace("0.63900", "-0.63900");
        let Err(ScaleError::BadLine { line: 2, reason }) = Scale::parse(&format!("{HEADER}\n{negative}\n")) else {
            panic!("a negative length was taken")
        };
        assert!(reason.contains("length_m"), "{reason}");
        let short = ROW_60.rsplit_once(',').unwrap().0;
        assert!(matches!(Scale::parse(&format!("{HEADER}\n{short}\n")), Err(ScaleError::BadLine { line: 2, .. })));
    }
}
