//! Property-based fuzzing of the files a user hands the engine: presets (JSON)
//! and Scala scales and keyboard mappings (`.scl`, `.kbm`).
//!
//! Inputs are valid files damaged at random (bytes flipped, cut, inserted,
//! removed, repeated; a JSON value replaced, removed or added anywhere in the
//! tree) and random text. Whatever comes in, a reader never panics; a refusal
//! is one line of text; what it accepts holds only finite numbers and gives
//! finite, positive key frequencies. `STRUCK_FUZZ_CASES` raises the number of
//! cases per property for a longer run.

mod support;

use proptest::prelude::*;
use serde_json::Value;
use struck_engine::preset::{Preset, factory_presets};
use struck_engine::tuning::{KeyboardMapping, ScalaScale, Temperament, TuningSettings};

use support::{config, mutated, one_line, tweak};

/// Cases per property by default: the file runs in about two seconds.
const CASES: u32 = 10_000;

/// Scala scales of several shapes: cents and ratios, comments, a blank
/// description, trailing words, a byte-order mark.
const SCALES: &[&str] = &[
    "! meantone.scl\n!\n1/4-comma meantone\n 12\n!\n 76.04900\n 193.15686\n 310.26471\n 5/4\n 503.42157\n \
     579.47057\n 696.57843\n 25/16\n 889.73529\n 1006.84314\n 1082.89214\n 2/1\n",
    "\n3\n1.5 cents\n3/2 fifth\n2\n",
    "\u{feff}Bohlen-Pierce\n13\n133.238\n244.971\n351.338\n466.173\n582.512\n670.590\n\
     782.492\n884.359\n1017.596\n1102.264\n1215.383\n1319.440\n3/1\n",
    "! tiny\nOne degree\n1\n1200.0\n",
];

/// Keyboard mappings: linear, a pattern with holes, one at the edges of the keys.
const MAPPINGS: &[&str] = &[
    "! linear\n0\n0\n127\n60\n69\n440.0\n0\n",
    "! seven white keys\n12\n0\n127\n60\n69\n440.0\n7\n0\nx\n1\nx\n2\n3\nx\n4\nx\n5\nx\n6\n",
    "5\n21\n108\n0\n127\n8372.02\n3\n0\n1\n2\n3\nx\n",
];

/// Field names a preset may have, for tweaks that add a field.
const PRESET_FIELDS: &[&str] = &[
    "name",
    "instrument",
    "voicing",
    "controls",
    "tuning",
    "mics",
    "hammer_mass",
    "damping",
    "fretted",
    "polyphony",
    "output_gain",
    "output",
    "a4_hz",
    "temperament",
    "root",
    "stretch",
    "scale",
    "degrees_cents",
    "keyboard_mapping",
    "map_size",
    "map",
    "reference_hz",
    "octave_degree",
    "width",
    "perspective",
];

/// The factory presets and a user preset with a mapped Scala scale, as JSON.
fn preset_seeds() -> Vec<Value> {
    let mut presets = factory_presets();
    let scale = ScalaScale {
        keyboard_mapping: Some(KeyboardMapping::parse(MAPPINGS[1]).expect("a valid mapping")),
        ..ScalaScale::parse(SCALES[0]).expect("a valid scale")
    };
    presets.push(Preset {
        name: "Mapped meantone".into(),
        tuning: TuningSettings { temperament: Temperament::Scala, scale: Some(scale), ..TuningSettings::default() },
        ..Preset::default()
    });
    presets.iter().map(|p| serde_json::from_str(&p.to_json()).expect("a preset's JSON reads back")).collect()
}

/// Every number a checked preset leads to is finite: it reads back the same
/// from its own JSON (a NaN would not), and its keys' frequencies are finite
/// and positive.
fn accepted(preset: &Preset) -> Result<(), TestCaseError> {
    prop_assert!(preset.validate().is_ok());
    let again = Preset::parse(&preset.to_json());
    prop_assert!(again.as_ref().is_ok_and(|p| p == preset), "{preset:?} does not read back: {again:?}");
    let frequencies = preset.settings(48_000.0).tuning.frequencies_hz(&|_| Some(1e-4));
    prop_assert!(frequencies.iter().all(|f| f.is_finite() && *f > 0.0), "{frequencies:?}");
    Ok(())
}

fn preset(text: &str) -> Result<(), TestCaseError> {
    match Preset::parse(text) {
        Ok(p) => accepted(&p),
        Err(e) => one_line(&e.to_string()),
    }
}

/// A scale, and the key frequencies it gives alone and with each mapping.
fn scale(text: &str) -> Result<(), TestCaseError> {
    let scale = match ScalaScale::parse(text) {
        Ok(s) => s,
        Err(e) => return one_line(&e.to_string()),
    };
    prop_assert!(scale.degrees_cents.iter().all(|c| c.is_finite()), "{scale:?}");
    let mappings = std::iter::once(None).chain(MAPPINGS.iter().map(|m| KeyboardMapping::parse(m).ok()));
    for mapping in mappings {
        let scale = ScalaScale { keyboard_mapping: mapping, ..scale.clone() };
        let tuning = TuningSettings { temperament: Temperament::Scala, scale: Some(scale), ..Default::default() };
        prop_assert!(tuning.validate().is_ok(), "{tuning:?}");
        let frequencies = tuning.frequencies_hz(&|_| Some(1e-3));
        prop_assert!(frequencies.iter().all(|f| f.is_finite() && *f > 0.0), "{frequencies:?}");
    }
    Ok(())
}

/// A mapping, and the key frequencies it gives each scale.
fn mapping(text: &str) -> Result<(), TestCaseError> {
    let mapping = match KeyboardMapping::parse(text) {
        Ok(m) => m,
        Err(e) => return one_line(&e.to_string()),
    };
    prop_assert!(mapping.reference_hz.is_finite() && mapping.reference_hz > 0.0, "{mapping:?}");
    for text in SCALES {
        let scale = ScalaScale { keyboard_mapping: Some(mapping.clone()), ..ScalaScale::parse(text).expect("valid") };
        let tuning = TuningSettings { temperament: Temperament::Scala, scale: Some(scale), ..Default::default() };
        prop_assert!(tuning.validate().is_ok(), "{tuning:?}");
        let frequencies = tuning.frequencies_hz(&|_| None);
        prop_assert!(frequencies.iter().all(|f| f.is_finite() && *f > 0.0), "{frequencies:?}");
    }
    Ok(())
}

/// Text of a tuning file's bytes as the engine reads it: UTF-8, or else Latin-1.
fn latin1(bytes: Vec<u8>) -> String {
    String::from_utf8(bytes).unwrap_or_else(|e| e.into_bytes().iter().map(|&b| char::from(b)).collect())
}

fn bytes_of(texts: &[&str]) -> Vec<Vec<u8>> {
    texts.iter().map(|t| t.as_bytes().to_vec()).collect()
}

proptest! {
    #![proptest_config(config(CASES))]

    #[test]
    fn a_damaged_preset_file_is_read_or_refused_in_one_line(
        bytes in mutated(preset_seeds().iter().map(|v| v.to_string().into_bytes()).collect())
    ) {
        preset(&String::from_utf8_lossy(&bytes))?;
    }

    #[test]
    fn a_preset_with_odd_values_is_read_or_refused_in_one_line(
        seed in proptest::sample::select(preset_seeds()),
        tweaks in proptest::collection::vec(tweak(PRESET_FIELDS), 1..6),
    ) {
        preset(&support::apply(seed, &tweaks).to_string())?;
    }

    #[test]
    fn random_text_is_never_taken_for_a_preset(text in "\\PC{0,200}") {
        preset(&text)?;
    }

    #[test]
    fn a_damaged_scale_is_read_or_refused_in_one_line(bytes in mutated(bytes_of(SCALES))) {
        scale(&latin1(bytes))?;
    }

    #[test]
    fn a_damaged_keyboard_mapping_is_read_or_refused_in_one_line(bytes in mutated(bytes_of(MAPPINGS))) {
        mapping(&latin1(bytes))?;
    }

    #[test]
    fn random_lines_are_read_or_refused_as_a_scale_or_mapping(
        lines in proptest::collection::vec(
            prop_oneof![
                "[0-9]{1,4}",
                "-?[0-9]{0,6}\\.[0-9]{0,6}",
                "[0-9]{1,20}/[0-9]{1,20}",
                "-?[0-9]{1,3}e[0-9]{1,3}",
                "[!x ]\\PC{0,10}",
                "\\PC{0,12}",
            ],
            0..24,
        )
    ) {
        let text = lines.join("\n");
        scale(&text)?;
        mapping(&text)?;
    }
}

/// Found by the fuzzing above: a field name with a line break (or any control
/// character) was quoted raw in the refusal, which then took two lines.
#[test]
fn a_preset_field_name_with_a_line_break_is_refused_in_one_line() {
    for text in [
        "{\"\\n\": 0}",
        "{\"voicing\": {\"damping\\r\\n\": 1}}",
        "{\"instrument\": \"harp\\u001b[31m\"}",
        "{\"tuning\": {\"temperament\": \"x\\ny\"}}",
    ] {
        let message = Preset::parse(text).expect_err("an unknown field or name").to_string();
        assert!(!message.contains(char::is_control), "{message:?}");
        assert!(message.contains("\\n") || message.contains("\\u{1b}"), "the name is shown escaped: {message}");
    }
}

/// Found with the rule above that a message holds no control character: a
/// scale's or mapping's word was quoted raw, so an escape sequence in the file
/// reached the terminal.
#[test]
fn a_tuning_file_word_with_an_escape_sequence_is_quoted_escaped() {
    let scale = ScalaScale::parse("Scale\n1\n2\u{1b}[2J\n").expect_err("not a ratio").to_string();
    let mapping = KeyboardMapping::parse("0\n0\n127\n60\n69\n4\u{7}40\n0\n").expect_err("not a frequency").to_string();
    for message in [scale, mapping] {
        assert!(!message.contains(char::is_control), "{message:?}");
        assert!(message.contains("\\u{1b}") || message.contains("\\u{7}"), "{message}");
    }
}
