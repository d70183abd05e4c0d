//! Tuning: the frequency every MIDI key's strings are tuned to.
//!
//! A key's frequency is that of its strings' first partial f_1 = f0 sqrt(1 + B)
//! (what [`crate::string::Tuning::FirstPartialHz`] sets), built in two steps:
//!
//! 1. **The temperament**: equal temperament from A4; a historical temperament
//!    laid from a chosen pitch class; or a Scala scale (`.scl`) placed on the keys
//!    by a keyboard mapping (`.kbm`).
//! 2. **The stretch**: octaves widened the way a tuner widens them on a stiff
//!    string, from each instrument's own inharmonicity B.
//!
//! The rooms: [`temperament`] (equal and the historical ones), [`stretch`] (the
//! octaves widened from the strings' inharmonicity), [`scala`] (`.scl` scales
//! and `.kbm` keyboard mappings).
//!
//! Nothing here runs on the audio thread: the frequencies are worked out when an
//! instrument is built.

pub mod scala;
pub mod stretch;
pub mod temperament;

use serde::{Deserialize, Serialize};

pub use scala::{
    KeyboardMapping, MAX_DEGREE_CENTS, MAX_DESCRIPTION_CHARS, MAX_FILE_BYTES, MAX_MAP_SIZE, MAX_SCALE_DEGREES,
    ScalaScale, TuningError, TuningFileError,
};
pub use stretch::stretch_cents;
pub use temperament::Temperament;

/// The A4 references accepted, Hz (from low Baroque pitch to well above modern).
pub const A4_RANGE_HZ: std::ops::RangeInclusive<f64> = 380.0..=480.0;

/// How the instrument is tuned.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TuningSettings {
    /// Frequency of A4 (MIDI key 69), Hz, within [`A4_RANGE_HZ`].
    pub a4_hz: f64,
    pub temperament: Temperament,
    /// Pitch class a historical temperament is laid from, 0 (C) to 11 (B).
    pub root: u8,
    /// Share of the inharmonic stretch applied, 0 (none) to 1 (octaves beatless
    /// on the lower key's second partial). 1 by default: a tuner tunes by ear,
    /// octaves beatless, so a tuned piano's treble sits sharp and its bass flat
    /// (the Railsback curve); 0 puts every key's first partial on its tempered
    /// pitch.
    pub stretch: f64,
    /// The scale the `scala` temperament plays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<ScalaScale>,
}

impl Default for TuningSettings {
    fn default() -> Self {
        Self { a4_hz: 440.0, temperament: Temperament::Equal, root: 0, stretch: 1.0, scale: None }
    }
}

/// A setting out of range; displays as `field: reason`.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{field}: {reason}")]
pub struct FieldError {
    /// The field's path, e.g. `scale.degrees_cents[3]`.
    pub field: String,
    pub reason: String,
}

impl FieldError {
    fn new(field: impl Into<String>, reason: impl Into<String>) -> Self {
        Self { field: field.into(), reason: reason.into() }
    }

    /// The same error with its field under `parent` (`parent.field`).
    pub fn within(mut self, parent: &str) -> Self {
        self.field = format!("{parent}.{}", self.field);
        self
    }
}

impl TuningSettings {
    /// Check every field (as [`ScalaScale::parse`] and [`KeyboardMapping::parse`]
    /// check theirs): the error names the field and the reason.
    pub fn validate(&self) -> Result<(), FieldError> {
        if !A4_RANGE_HZ.contains(&self.a4_hz) {
            return Err(FieldError::new(
                "a4_hz",
                format!(
                    "must be from {} to {} Hz (got {})",
                    A4_RANGE_HZ.start(),
                    A4_RANGE_HZ.end(),
                    crate::readable(self.a4_hz)
                ),
            ));
        }
        if self.root > 11 {
            return Err(FieldError::new(
                "root",
                format!("must be a pitch class from 0 (C) to 11 (B) (got {})", self.root),
            ));
        }
        if !(0.0..=1.0).contains(&self.stretch) {
            return Err(FieldError::new(
                "stretch",
                format!("must be from 0 to 1 (got {})", crate::readable(self.stretch)),
            ));
        }
        if let Some(scale) = &self.scale {
            scale.validate().map_err(|e| e.within("scale"))?;
        } else if self.temperament == Temperament::Scala {
            return Err(FieldError::new("temperament", "scala needs a scale"));
        }
        Ok(())
    }

    /// A short description, e.g. "Werckmeister III from D, A4 = 415 Hz, stretch 0.5".
    pub fn describe(&self) -> String {
        let mut text = match (self.temperament, &self.scale) {
            (Temperament::Scala, Some(scale)) if !scale.description.is_empty() => {
                format!("scale \"{}\"", scale.description)
            }
            (Temperament::Scala, _) => "a Scala scale".to_string(),
            (Temperament::Equal, _) => Temperament::Equal.label().to_string(),
            (t, _) if self.root == 0 => t.label().to_string(),
            (t, _) => format!("{} from {}", t.label(), pitch_class_name(self.root)),
        };
        let mapped =
            self.temperament == Temperament::Scala && self.scale.as_ref().is_some_and(|s| s.keyboard_mapping.is_some());
        if !mapped {
            text.push_str(&format!(", A4 = {} Hz", self.a4_hz));
        }
        // A tuner's full stretch is the norm, and goes unsaid.
        if self.stretch == 0.0 {
            text.push_str(", unstretched");
        } else if self.stretch != 1.0 {
            text.push_str(&format!(", stretch {}", self.stretch));
        }
        text
    }

    /// The first-partial frequency of every MIDI key, Hz. `inharmonicity` gives a
    /// key's B (None where the instrument has no such key), for the stretch.
    ///
    /// Out-of-range settings are clamped into range (use [`Self::validate`] to refuse
    /// them); a key whose scale pitch is not a positive finite frequency keeps equal
    /// temperament. Allocates (a little, for the stretch): not for the audio thread.
    pub fn frequencies_hz(&self, inharmonicity: &dyn Fn(u8) -> Option<f64>) -> [f64; 128] {
        let a4_hz =
            if self.a4_hz.is_finite() { self.a4_hz.clamp(*A4_RANGE_HZ.start(), *A4_RANGE_HZ.end()) } else { 440.0 };
        let equal = |k: usize| a4_hz * 2f64.powf((k as f64 - 69.0) / 12.0);
        let mut frequencies: [f64; 128] = std::array::from_fn(equal);

        match (self.temperament, &self.scale, self.temperament.pattern_cents()) {
            (_, _, Some(pattern)) => {
                let root = usize::from(self.root % 12);
                let deviation = |pitch_class: usize| {
                    let step = (pitch_class + 12 - root) % 12;
                    pattern[step] - 100.0 * step as f64
                };
                let a_deviation = deviation(9);
                for (k, f) in frequencies.iter_mut().enumerate() {
                    *f *= cents_ratio(deviation(k % 12) - a_deviation);
                }
            }
            (Temperament::Scala, Some(scale), None) => {
                let default_mapping;
                let mapping = match &scale.keyboard_mapping {
                    Some(m) => m,
                    None => {
                        default_mapping = KeyboardMapping::linear(60, equal(60));
                        &default_mapping
                    }
                };
                if let Some(reference_cents) = mapping.key_cents(scale, mapping.reference_key, false) {
                    for (k, f) in frequencies.iter_mut().enumerate() {
                        let Some(key_cents) = mapping.key_cents(scale, k as u8, true) else { continue };
                        let hz = mapping.reference_hz * cents_ratio(key_cents - reference_cents);
                        if hz.is_finite() && hz > 0.0 {
                            *f = hz;
                        }
                    }
                }
            }
            _ => {}
        }

        let stretch = if self.stretch.is_finite() { self.stretch.clamp(0.0, 1.0) } else { 0.0 };
        if stretch > 0.0 {
            let cents = stretch_cents(inharmonicity);
            // The reference key keeps its frequency: A4, or a keyboard mapping's own.
            let anchor = match (self.temperament, &self.scale) {
                (Temperament::Scala, Some(ScalaScale { keyboard_mapping: Some(m), .. })) => m.reference_key,
                _ => 69,
            };
            let anchor_cents = cents[usize::from(anchor.min(127))];
            for (f, c) in frequencies.iter_mut().zip(cents) {
                *f *= cents_ratio(stretch * (c - anchor_cents));
            }
        }
        frequencies
    }
}

/// Cents of a frequency ratio.
pub fn ratio_cents(ratio: f64) -> f64 {
    1200.0 * ratio.log2()
}

/// Frequency ratio of an interval in cents.
pub fn cents_ratio(cents: f64) -> f64 {
    2f64.powf(cents / 1200.0)
}

/// "C", "C#", ... "B".
pub fn pitch_class_name(pitch_class: u8) -> &'static str {
    ["C", "C#", "D", "Eb", "E", "F", "F#", "G", "G#", "A", "Bb", "B"][usize::from(pitch_class % 12)]
}

#[cfg(test)]
mod tests {
    use super::*;

    fn no_b(_: u8) -> Option<f64> {
        None
    }

    fn cents_between(f: f64, reference: f64) -> f64 {
        ratio_cents(f / reference)
    }

    fn with(temperament: Temperament) -> TuningSettings {
        TuningSettings { temperament, ..Default::default() }
    }

    #[test]
    fn equal_temperament_from_a4() {
        let f = TuningSettings::default().frequencies_hz(&no_b);
        assert!((f[69] - 440.0).abs() < 1e-9);
        assert!((f[60] - 261.625_565).abs() < 1e-5, "C4 {}", f[60]);
        assert!((f[81] - 880.0).abs() < 1e-9);
        assert!((f[21] - 27.5).abs() < 1e-9);
        let low = TuningSettings { a4_hz: 415.0, ..Default::default() }.frequencies_hz(&no_b);
        assert!((low[69] - 415.0).abs() < 1e-9);
        assert!((cents_between(low[60], f[60]) - ratio_cents(415.0 / 440.0)).abs() < 1e-9);
    }

    /// Quarter-comma meantone: fifths of 696.578 c, pure major thirds (386.314 c),
    /// and the wolf G#-Eb; A4 stays at the reference.
    #[test]
    fn meantone_fifths_and_thirds() {
        let f = with(Temperament::Meantone).frequencies_hz(&no_b);
        assert!((f[69] - 440.0).abs() < 1e-9);
        let fifth = |a: usize| cents_between(f[a + 7], f[a]);
        for k in [60, 67, 62, 69, 64, 71, 66, 61, 65, 70, 63] {
            assert!((fifth(k) - 696.578).abs() < 0.001, "fifth on {k}: {:.3}", fifth(k));
        }
        assert!((cents_between(f[63 + 12], f[68]) - 737.637).abs() < 0.001, "wolf G#-Eb");
        assert!((cents_between(f[64], f[60]) - ratio_cents(1.25)).abs() < 1e-6, "C-E pure");
        // C4 lies 10.26 c above its equal-tempered pitch when A4 is the reference.
        assert!((cents_between(f[60], 261.625_565_3) - 10.265).abs() < 0.01);
    }

    /// Deviations from equal temperament per pitch class (C, C#, .. B) with A at 0,
    /// as the tuning literature tabulates them (e.g. tunableapp.com's tables).
    #[test]
    fn well_temperaments_match_published_offsets() {
        let published: [(Temperament, [f64; 12]); 2] = [
            (Temperament::Werckmeister3, [11.73, 1.96, 3.91, 5.87, 1.96, 9.78, 0.0, 7.82, 3.91, 0.0, 7.82, 3.91]),
            (Temperament::Vallotti, [5.87, 0.0, 1.96, 3.91, -1.96, 7.82, -1.96, 3.91, 1.96, 0.0, 5.87, -3.91]),
        ];
        let equal = TuningSettings::default().frequencies_hz(&no_b);
        for (temperament, offsets) in published {
            let f = with(temperament).frequencies_hz(&no_b);
            for k in 60..72 {
                let got = cents_between(f[k], equal[k]);
                assert!((got - offsets[k - 60]).abs() < 0.006, "{temperament} pitch class {}: {got:.3}", k - 60);
                assert!((cents_between(f[k + 24], f[k]) - 2400.0).abs() < 1e-9, "octaves pure");
            }
        }
    }

    /// Laid from D, Werckmeister III does on D what it did on C; A4 still sounds at a4_hz.
    #[test]
    fn root_transposes_the_pattern() {
        let from_c = with(Temperament::Werckmeister3).frequencies_hz(&no_b);
        let from_d = TuningSettings { root: 2, a4_hz: 415.0, ..with(Temperament::Werckmeister3) }.frequencies_hz(&no_b);
        assert!((from_d[69] - 415.0).abs() < 1e-9);
        for k in 60..72 {
            let interval_c = cents_between(from_c[k + 7], from_c[k]);
            let interval_d = cents_between(from_d[k + 9], from_d[k + 2]);
            assert!((interval_c - interval_d).abs() < 1e-9, "fifth on pitch class {}", k - 60);
        }
    }

    const TWELVE_EQUAL: &str = concat!(
        "! 12-edo.scl\n!\n12 equal divisions of the octave\n 12\n!\n",
        "100.0\n200.\n300.0\n400.0\n500.0\n600.0\n700.0 cents\n800.0\n900.0\n1000.0\n1100.0\n2/1\n",
    );

    fn scala(text: &str, kbm: Option<&str>) -> TuningSettings {
        let mut scale = ScalaScale::parse(text).unwrap();
        scale.keyboard_mapping = kbm.map(|k| KeyboardMapping::parse(k).unwrap());
        TuningSettings { temperament: Temperament::Scala, scale: Some(scale), ..Default::default() }
    }

    #[test]
    fn a_twelve_equal_scale_is_equal_temperament() {
        let settings = scala(TWELVE_EQUAL, None);
        assert_eq!(settings.scale.as_ref().unwrap().description, "12 equal divisions of the octave");
        settings.validate().unwrap();
        for a4_hz in [440.0, 415.0] {
            let equal = TuningSettings { a4_hz, ..Default::default() }.frequencies_hz(&no_b);
            let f = TuningSettings { a4_hz, ..settings.clone() }.frequencies_hz(&no_b);
            for k in 0..128 {
                assert!((f[k] / equal[k] - 1.0).abs() < 1e-12, "key {k}: {} vs {}", f[k], equal[k]);
            }
        }
    }

    /// 19 equal steps a 2/1, mapped linearly with A4 = 440 Hz on key 69.
    #[test]
    fn nineteen_equal_with_a_mapping() {
        let mut text = String::from("19-EDO\n19\n");
        for i in 1..19 {
            text.push_str(&format!("{:.5}\n", 1200.0 * i as f64 / 19.0));
        }
        text.push_str("2/1\n");
        let kbm = "! linear, A4 = 440\n0\n0\n127\n60\n69\n440.0\n0\n";
        let f = scala(&text, Some(kbm)).frequencies_hz(&no_b);
        assert!((f[69] - 440.0).abs() < 1e-9);
        let step = 1200.0 / 19.0;
        for k in 0..127 {
            assert!((cents_between(f[k + 1], f[k]) - step).abs() < 1e-3, "key {k}");
        }
        assert!((cents_between(f[69 + 19], f[69]) - 1200.0).abs() < 1e-3);
        assert!((f[60] - 440.0 * cents_ratio(-9.0 * step)).abs() < 1e-6);
    }

    /// A just major scale on the white keys; the black keys left unmapped keep
    /// equal temperament; keys outside the retuned range too.
    #[test]
    fn just_intonation_on_the_white_keys() {
        let scl = "! just.scl\nJust major\n7\n9/8\n5/4\n4/3\n3/2\n5/3\n15/8\n2\n";
        let kbm =
            "12\n24\n108\n60\n69\n440\n7\n! C  C# D  D# E  F  F# G  G# A  A# B\n0\nx\n1\nx\n2\n3\nx\n4\nx\n5\nx\n6\n";
        let settings = scala(scl, Some(kbm));
        settings.validate().unwrap();
        let f = settings.frequencies_hz(&no_b);
        let equal = TuningSettings::default().frequencies_hz(&no_b);
        assert!((f[69] - 440.0).abs() < 1e-9, "A4 the reference");
        assert!((f[60] - 264.0).abs() < 1e-9, "C4 = 440 * 3/5: {}", f[60]);
        assert!((f[64] - 330.0).abs() < 1e-9, "E4 = C4 * 5/4");
        assert!((f[67] - 396.0).abs() < 1e-9, "G4 = C4 * 3/2");
        assert!((f[72] - 528.0).abs() < 1e-9, "C5 = 2 C4");
        assert!((f[48] - 132.0).abs() < 1e-9, "C3 = C4 / 2");
        for k in [61, 63, 66, 68, 70, 23, 109] {
            assert_eq!(f[k], equal[k], "key {k} keeps equal temperament");
        }

        // Stretched, the mapping's reference key keeps its frequency.
        let mut stretched = TuningSettings { stretch: 1.0, ..settings };
        let mapping = stretched.scale.as_mut().unwrap().keyboard_mapping.as_mut().unwrap();
        (mapping.reference_key, mapping.reference_hz) = (60, 264.0);
        let f = stretched.frequencies_hz(&|_| Some(1e-3));
        assert!((f[60] - 264.0).abs() < 1e-9, "C4 {}", f[60]);
        assert!(f[72] > 528.1 && f[48] < 131.95, "octaves widened: C3 {}, C5 {}", f[48], f[72]);
    }

    #[test]
    fn malformed_scales_name_the_line() {
        for (text, expected) in [
            ("! c\nbad\n3\n9/8\n3/0\n2/1\n", r#"line 5: "3/0" is not a ratio (denominator 0)"#),
            ("bad\n2\n-3/2\n2/1\n", r#"line 3: "-3/2" is not a ratio (negative)"#),
            ("bad\n2\n0/5\n2/1\n", r#"line 3: "0/5" is not a ratio (zero)"#),
            ("bad\n2\nabc\n2/1\n", r#"line 3: "abc" is not a ratio or a number of cents"#),
            ("bad\n2\n1.2.3\n2/1\n", r#"line 3: "1.2.3" is not a number of cents"#),
            ("bad\ntwelve\n", r#"line 2: "twelve" is not a count of pitches"#),
            ("bad\n-3\n", r#"line 2: "-3" is not a count of pitches"#),
            ("bad\n0\n", "line 2: a scale needs at least one pitch (its period, e.g. 2/1)"),
            ("bad\n3\n9/8\n5/4\n", "1 of the 3 pitches are missing (the file ends at line 4)"),
            ("bad\n1\n2/1\n3/1\n", r#"line 4: "3/1" is one pitch more than the count of 1 on line 2"#),
            ("bad\n2\n9/8\n-100.0\n", "line 4: the last pitch is the period and must be above 1/1 (got -100 cents)"),
            ("! only comments\n", "no description line (the file ends at line 1)"),
            ("", "no description line (the file ends at line 0)"),
            ("description\n", "no count of pitches after the description (the file ends at line 1)"),
        ] {
            let e = ScalaScale::parse(text).unwrap_err().to_string();
            assert_eq!(e, expected, "{text:?}");
            assert_eq!(e.lines().count(), 1);
        }
    }

    #[test]
    fn malformed_mappings_name_the_line() {
        for (text, expected) in [
            ("12\n0\n127\n60\n69\n", "no reference frequency line (the file ends at line 5)"),
            ("12\n0\n127\n60\n69\n-440\n12\n", r#"line 6: "-440" is not a frequency (a positive number of Hz)"#),
            ("12\n0\n127\n60\n69\n1e-30\n12\n", "line 6: the reference frequency 1e-30 Hz is not from 1 to 25000 Hz"),
            ("12\n0\n127\n60\n69\n1e300\n12\n", "line 6: the reference frequency 1e300 Hz is not from 1 to 25000 Hz"),
            ("12\n0\n200\n60\n69\n440\n12\n", "line 3: last key to retune must be from 0 to 127 (got 200)"),
            ("12\n100\n20\n60\n69\n440\n12\n", "line 3: the last key 20 is below the first key 100"),
            ("2\n0\n127\n60\n60\n440\n12\n0\n1\n2\n", r#"line 10: "2" is one entry more than the size of the map, 2"#),
            ("0\n0\n127\n60\n60\n440\n0\n0\n", r#"line 8: "0": a linear map (size 0) has no entries"#),
            (
                "2\n0\n127\n60\n61\n440\n12\n0\nx\n",
                "line 5: the reference key 61 is not mapped (its entry is x or missing)",
            ),
            ("2\n0\n127\n60\n60\n440\n12\n0\ny\n", r#"line 9: "y" is not a scale degree (a whole number, or x)"#),
            ("size\n", r#"line 1: "size" is not a size of the map (a whole number from 0 to 4096)"#),
        ] {
            let e = KeyboardMapping::parse(text).unwrap_err().to_string();
            assert_eq!(e, expected, "{text:?}");
        }
    }

    #[test]
    fn settings_are_checked_by_field() {
        assert!(TuningSettings::default().validate().is_ok());
        for (settings, field) in [
            (TuningSettings { a4_hz: 500.0, ..Default::default() }, "a4_hz"),
            (TuningSettings { a4_hz: f64::NAN, ..Default::default() }, "a4_hz"),
            (TuningSettings { stretch: 1.5, ..Default::default() }, "stretch"),
            (TuningSettings { root: 12, ..Default::default() }, "root"),
            (with(Temperament::Scala), "temperament"),
        ] {
            assert_eq!(settings.validate().unwrap_err().field, field);
        }
        let mut bad = scala(TWELVE_EQUAL, None);
        bad.scale.as_mut().unwrap().degrees_cents[3] = f64::INFINITY;
        assert_eq!(bad.validate().unwrap_err().field, "scale.degrees_cents[3]");
        let mut bad = scala(TWELVE_EQUAL, Some("1\n0\n127\n60\n60\n261.6\n0\n0\n"));
        bad.scale.as_mut().unwrap().keyboard_mapping.as_mut().unwrap().reference_hz = 0.0;
        assert_eq!(
            bad.validate().unwrap_err().to_string(),
            "scale.keyboard_mapping.reference_hz: must be a frequency from 1 to 25000 Hz (got 0)"
        );
        bad.scale.as_mut().unwrap().keyboard_mapping.as_mut().unwrap().reference_hz = 1e300;
        assert_eq!(
            bad.validate().unwrap_err().to_string(),
            "scale.keyboard_mapping.reference_hz: must be a frequency from 1 to 25000 Hz (got 1e300)"
        );
    }

    /// The settings survive JSON both ways, a scale and its mapping included.
    #[test]
    fn settings_round_trip_through_json() {
        let mut settings = scala("! j\nJust\n3\n5/4\n3/2\n2/1\n", Some("3\n0\n127\n60\n69\n440\n0\n0\nx\n2\n"));
        settings.stretch = 0.5;
        let text = serde_json::to_string(&settings).unwrap();
        assert_eq!(serde_json::from_str::<TuningSettings>(&text).unwrap(), settings);
        let partial: TuningSettings = serde_json::from_str(r#"{"temperament": "werckmeister3"}"#).unwrap();
        assert_eq!(partial, with(Temperament::Werckmeister3));
        assert!(serde_json::from_str::<TuningSettings>(r#"{"stetch": 1}"#).is_err());
    }

    /// B = 0: nothing to stretch.
    #[test]
    fn no_inharmonicity_no_stretch() {
        let full = TuningSettings { stretch: 1.0, ..Default::default() };
        let f = full.frequencies_hz(&|_| Some(0.0));
        let equal = TuningSettings::default().frequencies_hz(&no_b);
        assert_eq!(f, equal);
        assert_eq!(full.frequencies_hz(&no_b), equal, "no key has a B");
    }

    /// A piano-like B (Young 1952: about 1e-4 at C2 rising to about 1e-2 at the
    /// top, with a rise again in the low bass): octaves widen, the stretch is
    /// monotone, and half the setting gives half the stretch.
    #[test]
    fn piano_inharmonicity_widens_the_octaves() {
        let b = |k: u8| {
            let k = f64::from(k);
            (21.0..=108.0)
                .contains(&k)
                .then(|| 1.1e-4 * 2f64.powf((k - 36.0) / 14.0).max(1.0) + 4e-4 * 2f64.powf((33.0 - k) / 6.0))
        };
        let full = TuningSettings { stretch: 1.0, ..Default::default() }.frequencies_hz(&b);
        let half = TuningSettings { stretch: 0.5, ..Default::default() }.frequencies_hz(&b);
        let equal = TuningSettings::default().frequencies_hz(&no_b);
        assert!((full[69] - 440.0).abs() < 1e-9, "A4 is the reference");
        let octave = cents_between(full[81], full[69]) - 1200.0;
        assert!(octave > 0.5 && octave < 5.0, "A4-A5 is {octave:.2} c wide");
        let b69 = b(69).unwrap();
        let beatless = 600.0 * ((1.0 + 4.0 * b69) / (1.0 + b69)).log2();
        assert!(
            (octave / beatless - 1.0).abs() < 0.05,
            "{octave:.3} c, beatless on the second partial {beatless:.3} c"
        );
        let stretch: Vec<f64> = (21..=108).map(|k| cents_between(full[k], equal[k])).collect();
        assert!(stretch.windows(2).all(|w| w[1] > w[0]), "monotone: {stretch:?}");
        assert!(stretch[0] < -3.0 && stretch[87] > 5.0, "A0 {:.1} c, C8 {:.1} c", stretch[0], stretch[87]);
        for k in 21..=108 {
            let halfway = cents_between(half[k], equal[k]);
            assert!((halfway - 0.5 * stretch[k - 21]).abs() < 1e-9);
        }
    }

    /// The stretch from the engine's own piano, as the synth asks for it.
    #[test]
    fn the_piano_is_stretched_by_its_own_strings() {
        use crate::design::{InstrumentKind, Voicing, key_design};
        let b = |k: u8| {
            let d = key_design(InstrumentKind::Piano, &Voicing::default(), k, 20_000.0)?;
            d.strings[d.struck.start].build().ok().map(|s| s.inharmonicity)
        };
        let full = TuningSettings { stretch: 1.0, ..Default::default() }.frequencies_hz(&b);
        let equal = TuningSettings::default().frequencies_hz(&no_b);
        let octave = cents_between(full[81], full[69]) - 1200.0;
        assert!(octave > 0.3 && octave < 5.0, "A4-A5 {octave:.2} c wide");
        let stretch: Vec<f64> = (21..=108).map(|k| cents_between(full[k], equal[k])).collect();
        assert!(stretch.windows(2).all(|w| w[1] >= w[0]), "monotone: {stretch:?}");
    }

    /// Keys without a B of their own (a gap, the ends) take their neighbours'.
    #[test]
    fn keys_without_inharmonicity_follow_their_neighbours() {
        let b = |k: u8| (50..=90).contains(&k).then_some(1e-3).filter(|_| k != 70);
        let with_gap = stretch_cents(&b);
        let whole = stretch_cents(&|k| (50..=90).contains(&k).then_some(1e-3));
        assert!((with_gap[70] - whole[70]).abs() < 1e-12);
        assert!(with_gap.windows(2).all(|w| w[1] > w[0]));
    }

    #[test]
    fn latin_1_files_are_read() {
        let dir = std::env::temp_dir().join(format!("struck-tuning-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let path = dir.join("latin.scl");
        std::fs::write(&path, b"Gamme de Rameau \xe9gale\n1\n2/1\n").unwrap();
        assert_eq!(ScalaScale::load(&path).unwrap().description, "Gamme de Rameau égale");
        let e = ScalaScale::load(&dir.join("missing.scl")).unwrap_err().to_string();
        assert!(e.contains("missing.scl: cannot read"), "{e}");
        std::fs::write(&path, "x\n1\n0/1\n").unwrap();
        let e = ScalaScale::load(&path).unwrap_err().to_string();
        assert!(e.ends_with(r#"latin.scl: line 3: "0/1" is not a ratio (zero)"#), "{e}");
        std::fs::remove_dir_all(&dir).unwrap();
    }
}
