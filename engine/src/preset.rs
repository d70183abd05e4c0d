//! Presets: an instrument, its voicing, the player's controls and its tuning under
//! a name, kept as JSON.
//!
//! Every part of a preset is optional; what is missing is the instrument as built
//! (piano, voiced as built, default controls, equal temperament at A4 = 440 Hz):
//!
//! ```json
//! { "name": "Harpsichord — meantone",
//!   "instrument": "harpsichord",
//!   "voicing":  { "hammer_mass": 1.0, "strike_position": 1.0, "damping": 0.8, ... },
//!   "controls": { "touch_min": 0.0, "touch_max": 1.0, "polyphony": 64, ... },
//!   "tuning":   { "a4_hz": 415.0, "temperament": "meantone", "root": 0, "stretch": 0.0 } }
//! ```
//!
//! A preset is refused whole, with one line naming the field and the reason, if
//! any field is unknown, of the wrong type or out of range; nothing is then
//! changed. The factory presets ship inside the engine (`engine/presets/`); the
//! user's are files in [`user_preset_dir`], written so that a crash never leaves
//! half a file ([`save_user_preset`]).

use std::ffi::OsString;
use std::fs;
use std::io::Write;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

use serde::{Deserialize, Serialize};
use serde_json::Value;

use crate::body::soundboard::MicPlacement;
use crate::design::{InstrumentKind, Voicing};
use crate::synth::{Controls, InstrumentSettings};
use crate::tuning::{FieldError, TuningSettings};

/// Longest preset name, characters.
pub const MAX_NAME_CHARS: usize = 100;
/// A preset file is read only up to this size, bytes, as for a case or a
/// tuning file. The largest preset Struck writes, a scale of 4096 pitches
/// mapped over 4096 keys inside it, takes 188 kB (tested).
pub const MAX_FILE_BYTES: u64 = 1 << 20;

/// A named instrument, voicing, controls and tuning.
#[derive(Clone, Debug, Default, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct Preset {
    /// What the preset is called (a user preset's file is named after it).
    pub name: String,
    /// None: whatever instrument is playing (the piano when nothing else says).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub instrument: Option<InstrumentKind>,
    /// Scale factors on the instrument's own values (1 = as built).
    pub voicing: Voicing,
    /// Touch, polyphony, output gain, bend range, Bebung, sympathetic resonance,
    /// phantom partials and the action's sounds.
    pub controls: Controls,
    pub tuning: TuningSettings,
    /// Where the body's microphones listen from.
    #[serde(default)]
    pub mics: MicPlacement,
}

/// Why a preset was refused, or could not be read or written; one line.
#[derive(Debug, thiserror::Error)]
pub enum PresetError {
    /// The content: names the field and the reason (what it quotes of the
    /// text shown with its control characters escaped).
    #[error("{}", crate::printable(.0))]
    Invalid(String),
    /// A file: names it, then what went wrong.
    #[error("{}: {reason}", path.display())]
    File { path: PathBuf, reason: String },
    /// A name that cannot be a file name.
    #[error("preset name \"{}\": {reason}", crate::printable(.name))]
    Name { name: String, reason: String },
}

impl From<FieldError> for PresetError {
    fn from(e: FieldError) -> Self {
        PresetError::Invalid(e.to_string())
    }
}

impl Preset {
    /// Read and check a preset from JSON text.
    pub fn parse(text: &str) -> Result<Self, PresetError> {
        let mut value = strict_json(text).map_err(|e| PresetError::Invalid(format!("not valid JSON: {e}")))?;
        upgrade(&mut value);
        let Value::Object(top) = &value else {
            return Err(PresetError::Invalid("a preset must be a JSON object".into()));
        };
        // Voicing and Controls fill in missing fields but take unknown ones without
        // a word: a misspelt field would silently do nothing, so their keys are
        // checked against their defaults' keys.
        for (section, defaults) in [
            ("voicing", serde_json::to_value(Voicing::default())),
            ("controls", serde_json::to_value(Controls::default())),
        ] {
            if let (Some(given), Ok(defaults)) = (top.get(section), defaults) {
                known_fields(section, given, &defaults)?;
            }
        }
        let preset: Preset = serde_path_to_error::deserialize(value).map_err(|e| {
            let path = e.path().to_string();
            let reason = e.into_inner();
            PresetError::Invalid(if path == "." { reason.to_string() } else { format!("{path}: {reason}") })
        })?;
        preset.validate()?;
        Ok(preset)
    }

    /// The preset as JSON (pretty-printed; every field written).
    pub fn to_json(&self) -> String {
        serde_json::to_string_pretty(self).expect("a preset is plain data")
    }

    /// Read and check a preset file; the error names the file.
    pub fn load(path: &Path) -> Result<Self, PresetError> {
        let file_error = |reason: String| PresetError::File { path: path.to_path_buf(), reason };
        let bytes = crate::input::read_regular(path, MAX_FILE_BYTES).map_err(|e| file_error(e.to_string()))?;
        let text = String::from_utf8(bytes).map_err(|_| file_error("not UTF-8 text".into()))?;
        Self::parse(&text).map_err(|e| file_error(e.to_string()))
    }

    /// Check every number against its range; the error names the field.
    pub fn validate(&self) -> Result<(), FieldError> {
        if self.name.chars().count() > MAX_NAME_CHARS || self.name.chars().any(char::is_control) {
            return Err(field(
                "name",
                format!("must be at most {MAX_NAME_CHARS} characters, none of them control characters"),
            ));
        }
        let v = &self.voicing;
        for (name, value) in [
            ("hammer_mass", v.hammer_mass),
            ("hammer_stiffness", v.hammer_stiffness),
            ("hammer_exponent", v.hammer_exponent),
            ("strike_position", v.strike_position),
            ("damping", v.damping),
            ("tangent_depth", v.tangent_depth),
            ("board_size", v.board_size),
        ] {
            within(&format!("voicing.{name}"), value, 0.01, 100.0, "")?;
        }
        within("voicing.unison_detune", v.unison_detune, 0.0, 100.0, "")?;
        within("voicing.board_irregularity", v.board_irregularity, 0.0, 1.0, "")?;
        within("voicing.felt_hysteresis", v.felt_hysteresis, 0.0, 3.0, "")?;
        within("voicing.hammer_unevenness", v.hammer_unevenness, 0.0, 1.0, "")?;
        let c = &self.controls;
        within("controls.touch_min", c.touch_min, 0.0, 1.0, "")?;
        within("controls.touch_max", c.touch_max, 0.0, 1.0, "")?;
        within("controls.touch_shape", c.touch_shape, 0.1, 10.0, "")?;
        within("controls.output_gain", c.output_gain, 0.0, 100.0, "")?;
        within("controls.bend_range_semitones", c.bend_range_semitones, 0.0, 48.0, " semitones")?;
        within("controls.bebung_cents", c.bebung_cents, 0.0, crate::synth::MAX_BEBUNG_CENTS, " cents")?;
        within("controls.velocity_floor", c.velocity_floor, 0.0, 1.0, "")?;
        within("controls.velocity_ceiling", c.velocity_ceiling, 0.0, 1.0, "")?;
        if c.velocity_ceiling <= c.velocity_floor {
            return Err(field(
                "controls.velocity_ceiling",
                format!("must be above the floor {} (got {})", c.velocity_floor, c.velocity_ceiling),
            ));
        }
        within("controls.sympathy", c.sympathy, 0.0, 1.0, "")?;
        for (name, value) in [
            ("phantom", c.phantom),
            ("key_noise", c.key_noise),
            ("damper_noise", c.damper_noise),
            ("pedal_noise", c.pedal_noise),
        ] {
            within(&format!("controls.{name}"), value, 0.0, 4.0, "")?;
        }
        within("mics.width", self.mics.width, 0.0, 1.0, "")?;
        if !(1..=128).contains(&c.polyphony) {
            return Err(field("controls.polyphony", format!("must be from 1 to 128 keys (got {})", c.polyphony)));
        }
        self.tuning.validate().map_err(|e| e.within("tuning"))
    }

    /// What the instrument's tables are built from, at `sample_rate_hz`.
    pub fn settings(&self, sample_rate_hz: f64) -> InstrumentSettings {
        InstrumentSettings {
            kind: self.instrument.unwrap_or_default(),
            voicing: self.voicing,
            sample_rate_hz,
            tuning: self.tuning.clone(),
            mics: self.mics,
            strings_on_body: true,
        }
        .heard_through(self.controls.output)
    }
}

/// JSON text as a value, refusing an object that names a key twice (which
/// serde_json settles silently by keeping the last: a pasted line would
/// change a setting without a word). For presets and the lab's case files.
/// A byte-order mark before it (as some Windows editors save UTF-8) is
/// passed over, as it is in a Scala file.
pub fn strict_json(text: &str) -> Result<Value, serde_json::Error> {
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    use serde::de::{self, Deserializer, MapAccess, SeqAccess, Visitor};

    struct Strict(Value);
    struct Once;

    impl<'de> Deserialize<'de> for Strict {
        fn deserialize<D: Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
            d.deserialize_any(Once).map(Strict)
        }
    }

    impl<'de> Visitor<'de> for Once {
        type Value = Value;

        fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
            f.write_str("a JSON value")
        }
        fn visit_bool<E>(self, v: bool) -> Result<Value, E> {
            Ok(Value::Bool(v))
        }
        fn visit_i64<E>(self, v: i64) -> Result<Value, E> {
            Ok(Value::from(v))
        }
        fn visit_u64<E>(self, v: u64) -> Result<Value, E> {
            Ok(Value::from(v))
        }
        fn visit_f64<E>(self, v: f64) -> Result<Value, E> {
            Ok(Value::from(v))
        }
        fn visit_str<E>(self, v: &str) -> Result<Value, E> {
            Ok(Value::String(v.to_owned()))
        }
        fn visit_string<E>(self, v: String) -> Result<Value, E> {
            Ok(Value::String(v))
        }
        fn visit_unit<E>(self) -> Result<Value, E> {
            Ok(Value::Null)
        }
        fn visit_seq<A: SeqAccess<'de>>(self, mut seq: A) -> Result<Value, A::Error> {
            let mut items = Vec::new();
            while let Some(Strict(item)) = seq.next_element()? {
                items.push(item);
            }
            Ok(Value::Array(items))
        }
        fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Value, A::Error> {
            let mut object = serde_json::Map::new();
            while let Some(key) = map.next_key::<String>()? {
                if object.contains_key(&key) {
                    return Err(de::Error::custom(format!("\"{}\" is given twice", crate::printable(&key))));
                }
                let Strict(value) = map.next_value()?;
                object.insert(key, value);
            }
            Ok(Value::Object(object))
        }
    }

    serde_json::from_str::<Strict>(text).map(|s| s.0)
}

fn field(name: &str, reason: String) -> FieldError {
    FieldError { field: name.to_string(), reason }
}

fn within(name: &str, value: f64, lo: f64, hi: f64, unit: &str) -> Result<(), FieldError> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(field(name, format!("must be from {lo} to {hi}{unit} (got {})", crate::readable(value))))
    }
}

/// Bring a preset written before a field changed up to date: `controls.bebung`
/// (how much deeper full pressure pressed, a fraction of the depth: 0 to 1,
/// 0.25 the old default) becomes `bebung_cents` (how far it raises the note):
/// 80 cents times it, so the old default is the new one and a deep 0.6, 48
/// cents. A preset giving both keeps its `bebung_cents`.
fn upgrade(preset: &mut Value) {
    let Some(Value::Object(controls)) = preset.get_mut("controls") else { return };
    if let Some(old) = controls.remove("bebung")
        && !controls.contains_key("bebung_cents")
    {
        let cents = old.as_f64().map_or(old.clone(), |fraction| Value::from(OLD_BEBUNG_CENTS * fraction));
        controls.insert("bebung_cents".into(), cents);
    }
}

/// What a whole old `bebung` (full pressure twice as deep) is taken as, cents.
const OLD_BEBUNG_CENTS: f64 = 80.0;

/// Every key of `section` must be one of `defaults`' keys.
fn known_fields(name: &str, section: &Value, defaults: &Value) -> Result<(), PresetError> {
    let (Value::Object(fields), Value::Object(known)) = (section, defaults) else {
        return Err(PresetError::Invalid(format!("{name}: must be a JSON object")));
    };
    if let Some(unknown) = fields.keys().find(|k| !known.contains_key(*k)) {
        let expected: Vec<&str> = known.keys().map(String::as_str).collect();
        return Err(PresetError::Invalid(format!(
            "{name}.{unknown}: unknown field (expected one of {})",
            expected.join(", ")
        )));
    }
    Ok(())
}

/// The factory presets' JSON, in the order they are listed.
const FACTORY: [&str; 18] = [
    include_str!("../presets/piano-concert.json"),
    include_str!("../presets/piano-mellow.json"),
    include_str!("../presets/piano-bright.json"),
    include_str!("../presets/piano-stage-mono.json"),
    include_str!("../presets/fortepiano-viennese.json"),
    include_str!("../presets/fortepiano-moderator.json"),
    include_str!("../presets/santoor-classical.json"),
    include_str!("../presets/santoor-soft-mallets.json"),
    include_str!("../presets/dulcimer-bright.json"),
    include_str!("../presets/dulcimer-padded.json"),
    include_str!("../presets/cimbalom-concert.json"),
    include_str!("../presets/cimbalom-leather.json"),
    include_str!("../presets/clavichord-werckmeister.json"),
    include_str!("../presets/clavichord-deep-bebung.json"),
    include_str!("../presets/clavichord-fretted.json"),
    include_str!("../presets/harpsichord-meantone.json"),
    include_str!("../presets/harpsichord-werckmeister.json"),
    include_str!("../presets/harpsichord-vallotti-french.json"),
];

/// The presets that ship with Struck, at least two for each instrument. Allocates.
pub fn factory_presets() -> Vec<Preset> {
    FACTORY.iter().map(|text| Preset::parse(text).expect("every factory preset is checked by the tests")).collect()
}

/// Where the user's presets live: `$XDG_CONFIG_HOME/struck/presets`, else
/// `$HOME/.config/struck/presets`; None when neither variable is set.
pub fn user_preset_dir() -> Option<PathBuf> {
    preset_dir_from(std::env::var_os("XDG_CONFIG_HOME"), std::env::var_os("HOME"))
}

fn preset_dir_from(xdg_config_home: Option<OsString>, home: Option<OsString>) -> Option<PathBuf> {
    // The XDG rules: a relative XDG_CONFIG_HOME is to be ignored.
    let config = match xdg_config_home.map(PathBuf::from).filter(|p| p.is_absolute()) {
        Some(config) => config,
        None => PathBuf::from(home.filter(|h| !h.is_empty())?).join(".config"),
    };
    Some(config.join("struck").join("presets"))
}

/// Check that `name` can be a file name on any system: not empty, no longer than
/// [`MAX_NAME_CHARS`], no path separators or characters Windows refuses, no
/// control characters, no leading dot or surrounding spaces, no reserved device name.
pub fn check_name(name: &str) -> Result<(), PresetError> {
    let refuse = |reason: &str| Err(PresetError::Name { name: name.to_string(), reason: reason.to_string() });
    if name.trim().is_empty() {
        return refuse("a preset needs a name");
    }
    if name.chars().count() > MAX_NAME_CHARS {
        return refuse("longer than 100 characters");
    }
    if let Some(c) = name.chars().find(|c| "/\\:*?\"<>|".contains(*c)) {
        return Err(PresetError::Name {
            name: name.to_string(),
            reason: format!("'{c}' cannot be in a file name (nor any of / \\ : * ? \" < > |)"),
        });
    }
    if name.chars().any(char::is_control) {
        return refuse("control characters cannot be in a file name");
    }
    if name.starts_with('.') {
        return refuse("a name starting with '.' would make a hidden file");
    }
    if name.trim() != name || name.ends_with('.') {
        return refuse("a file name cannot start or end with a space, nor end with '.'");
    }
    let stem = name.split('.').next().unwrap_or(name).trim_end().to_ascii_uppercase();
    let reserved = ["CON", "PRN", "AUX", "NUL"].contains(&stem.as_str())
        || ((stem.starts_with("COM") || stem.starts_with("LPT"))
            && stem.len() == 4
            && stem.as_bytes()[3].is_ascii_digit());
    if reserved {
        return refuse("a device name on Windows, not a file name");
    }
    Ok(())
}

/// The file a user preset called `name` is kept in, within `dir`.
pub fn user_preset_path(dir: &Path, name: &str) -> PathBuf {
    dir.join(format!("{name}.json"))
}

/// Write `preset` into `dir` (created if missing) as `NAME.json`, replacing a
/// preset of the same name. The preset is checked first, and written to a
/// temporary file that is renamed into place once complete, so the file is
/// always either the old preset or the new one in full. Returns the file's path.
pub fn save_user_preset(dir: &Path, preset: &Preset) -> Result<PathBuf, PresetError> {
    static WRITES: AtomicU64 = AtomicU64::new(0);
    check_name(&preset.name)?;
    preset.validate()?;
    let path = user_preset_path(dir, &preset.name);
    let file_error = |path: &Path, what: &str, e: std::io::Error| PresetError::File {
        path: path.to_path_buf(),
        reason: format!("cannot {what}: {e}"),
    };
    fs::create_dir_all(dir).map_err(|e| file_error(dir, "create the directory", e))?;
    let temporary = dir.join(format!(
        ".{}.json.{}-{}.part",
        preset.name,
        std::process::id(),
        WRITES.fetch_add(1, Ordering::Relaxed)
    ));
    let written = (|| {
        let mut file = fs::File::create_new(&temporary)?;
        file.write_all(preset.to_json().as_bytes())?;
        file.write_all(b"\n")?;
        file.sync_all()?;
        fs::rename(&temporary, &path)
    })();
    if let Err(e) = written {
        let _ = fs::remove_file(&temporary);
        return Err(file_error(&path, "write", e));
    }
    Ok(path)
}

/// The preset files in `dir` (`*.json`, hidden and temporary files left out),
/// sorted by name; none when the directory does not exist.
pub fn list_user_presets(dir: &Path) -> Result<Vec<PathBuf>, PresetError> {
    let entries = match fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(Vec::new()),
        Err(e) => return Err(PresetError::File { path: dir.to_path_buf(), reason: format!("cannot list: {e}") }),
    };
    let mut paths: Vec<PathBuf> = entries
        .filter_map(Result::ok)
        .map(|entry| entry.path())
        .filter(|path| {
            let visible = path.file_name().and_then(|n| n.to_str()).is_some_and(|n| !n.starts_with('.'));
            visible && path.extension().is_some_and(|e| e == "json") && path.is_file()
        })
        .collect();
    paths.sort_by_key(|p| p.file_name().map(|n| n.to_string_lossy().to_lowercase()));
    Ok(paths)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::synth::{Event, Instrument, Synth, TimedEvent};
    use crate::tuning::Temperament;

    /// The largest preset there can be: the longest name, a scale of the
    /// most pitches, each as long as a number gets, with the longest
    /// description of escaped characters and a mapping of the most keys.
    fn largest() -> Preset {
        use crate::tuning::{KeyboardMapping, MAX_DESCRIPTION_CHARS, MAX_MAP_SIZE, MAX_SCALE_DEGREES, ScalaScale};
        // (Each written with 17 digits: -119999.33333333333.)
        let third = 1.0 / 3.0;
        let mut degrees: Vec<f64> = (1..MAX_SCALE_DEGREES).map(|i| -119_999.0 - third + i as f64 * 1e-9).collect();
        degrees.push(119_999.0 + third);
        let scale = ScalaScale {
            description: "\"".repeat(MAX_DESCRIPTION_CHARS),
            degrees_cents: degrees,
            keyboard_mapping: Some(KeyboardMapping {
                map_size: MAX_MAP_SIZE,
                first_key: 0,
                last_key: 127,
                middle_key: 60,
                reference_key: 69,
                reference_hz: 440.0 + third,
                octave_degree: MAX_SCALE_DEGREES,
                map: (0..MAX_MAP_SIZE).map(|i| Some(MAX_SCALE_DEGREES - 1 - i % 7)).collect(),
            }),
        };
        Preset {
            name: "\u{1F3B9}".repeat(MAX_NAME_CHARS),
            tuning: TuningSettings { temperament: Temperament::Scala, scale: Some(scale), ..TuningSettings::default() },
            ..Preset::default()
        }
    }

    #[test]
    fn the_largest_preset_fits_the_file_size_a_preset_is_read_up_to() {
        let preset = largest();
        preset.validate().unwrap();
        let json = preset.to_json();
        assert!(json.len() < 200 << 10, "{} bytes", json.len());
        assert!(json.len() as u64 <= MAX_FILE_BYTES);
        let scratch = Scratch::new("largest");
        let path = scratch.0.join("largest.json");
        fs::write(&path, &json).unwrap();
        assert_eq!(Preset::load(&path).unwrap(), preset);
        // And the cap is the one a file meets.
        let mut padded = json.into_bytes();
        padded.resize(MAX_FILE_BYTES as usize, b' ');
        fs::write(&path, &padded).unwrap();
        assert!(Preset::load(&path).is_ok());
        padded.push(b' ');
        fs::write(&path, &padded).unwrap();
        let e = Preset::load(&path).unwrap_err().to_string();
        assert!(e.contains("larger than the 1 MB"), "{e}");
    }

    #[test]
    fn a_scales_description_is_kept_to_its_length() {
        use crate::tuning::{MAX_DESCRIPTION_CHARS, ScalaScale};
        let long = format!("{}\n1\n2/1\n", "a".repeat(5000));
        let scale = ScalaScale::parse(&long).unwrap();
        assert_eq!(scale.description.chars().count(), MAX_DESCRIPTION_CHARS);
        let mut preset = largest();
        preset.tuning.scale.as_mut().unwrap().description.push('x');
        let e = preset.validate().unwrap_err();
        assert_eq!(e.field, "tuning.scale.description", "{e}");
    }

    /// A scratch directory of its own for each test.
    struct Scratch(PathBuf);

    impl Scratch {
        fn new(test: &str) -> Self {
            let dir = std::env::temp_dir().join(format!("struck-preset-{test}-{}", std::process::id()));
            let _ = fs::remove_dir_all(&dir);
            fs::create_dir_all(&dir).unwrap();
            Self(dir)
        }

        fn files(&self) -> Vec<String> {
            let mut names: Vec<String> =
                fs::read_dir(&self.0).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
            names.sort();
            names
        }
    }

    impl Drop for Scratch {
        fn drop(&mut self) {
            let _ = fs::remove_dir_all(&self.0);
        }
    }

    /// Every factory preset loads, renders a note (its instrument built from its
    /// settings, A4 played through the synth: finite, not silent), and round-trips.
    #[test]
    fn every_factory_preset_loads_renders_and_round_trips() {
        let presets = factory_presets();
        for kind in InstrumentKind::ALL {
            let count = presets.iter().filter(|p| p.instrument == Some(kind)).count();
            assert!(count >= 2, "{kind} has {count} factory presets");
        }
        let mut names: Vec<&str> = presets.iter().map(|p| p.name.as_str()).collect();
        names.sort();
        names.dedup();
        assert_eq!(names.len(), presets.len(), "names are unique");
        for preset in &presets {
            check_name(&preset.name).unwrap();
            let kind = preset.instrument.expect("a factory preset names its instrument");
            assert!(preset.name.to_lowercase().starts_with(kind.name()), "{} is a {kind} preset", preset.name);
            assert_eq!(&Preset::parse(&preset.to_json()).unwrap(), preset, "{} round-trips", preset.name);

            let instrument = Instrument::build(&preset.settings(48_000.0)).unwrap();
            let (mut synth, _scope) = Synth::new(Box::new(instrument));
            synth.set_controls(preset.controls);
            let (mut left, mut right) = (vec![0.0f32; 9600], vec![0.0f32; 9600]);
            synth.process(&[TimedEvent::new(0, Event::NoteOn { key: 69, velocity: 0.8 })], &mut left, &mut right);
            assert!(left.iter().chain(&right).all(|s| s.is_finite()), "{}: finite", preset.name);
            let peak = left.iter().chain(&right).fold(0.0f32, |m, s| m.max(s.abs()));
            assert!(peak > 1e-4, "{}: peak {peak}", preset.name);
        }
    }

    #[test]
    fn missing_parts_are_the_instrument_as_built() {
        assert_eq!(Preset::parse("{}").unwrap(), Preset::default());
        let p = Preset::parse(
            r#"{"instrument": "santoor", "voicing": {"damping": 0.5}, "controls": {"polyphony": 8},
                "tuning": {"temperament": "vallotti", "a4_hz": 430}}"#,
        )
        .unwrap();
        assert_eq!(p.instrument, Some(InstrumentKind::Santoor));
        assert_eq!(p.voicing.damping, 0.5);
        assert_eq!(p.voicing.hammer_mass, 1.0);
        assert_eq!(p.controls.polyphony, 8);
        assert_eq!(p.tuning.temperament, Temperament::Vallotti);
        assert_eq!(p.tuning.a4_hz, 430.0);
        assert_eq!(p.tuning.stretch, 1.0, "a tuner's stretch");
        // Presets written before these settings existed play them as built.
        assert_eq!(p.voicing.felt_hysteresis, 1.0);
        assert_eq!(p.voicing.hammer_unevenness, 0.0, "a level hammer");
        let c = p.controls;
        assert_eq!([c.sympathy, c.phantom, c.key_noise, c.damper_noise, c.pedal_noise], [1.0; 5]);
    }

    /// Every voicing and control field survives JSON, the newer ones (felt
    /// hysteresis, sympathy, phantom partials, the action's sounds) included.
    #[test]
    fn every_field_round_trips() {
        let preset = Preset {
            name: "Every field".into(),
            instrument: Some(InstrumentKind::Fortepiano),
            voicing: Voicing {
                felt_hysteresis: 2.5,
                board_irregularity: 0.25,
                fretted: true,
                hammer_unevenness: 0.4,
                ..Voicing::default()
            },
            controls: Controls {
                bebung_cents: 35.0,
                velocity_floor: 0.1,
                velocity_ceiling: 0.85,
                sympathy: 0.3,
                phantom: 3.5,
                key_noise: 0.0,
                damper_noise: 2.0,
                pedal_noise: 4.0,
                ..Controls::default()
            },
            ..Preset::default()
        };
        let json = preset.to_json();
        for field in [
            "felt_hysteresis",
            "hammer_unevenness",
            "sympathy",
            "phantom",
            "key_noise",
            "damper_noise",
            "pedal_noise",
            "bebung_cents",
            "velocity_floor",
            "velocity_ceiling",
        ] {
            assert!(json.contains(&format!("\"{field}\"")), "{field} is written: {json}");
        }
        assert_eq!(Preset::parse(&json).unwrap(), preset);
        let text = r#"{"voicing": {"felt_hysteresis": 0}, "controls": {"sympathy": 0, "phantom": 0.5,
                       "key_noise": 4, "damper_noise": 0.25, "pedal_noise": 0}}"#;
        let p = Preset::parse(text).unwrap();
        assert_eq!(p.voicing.felt_hysteresis, 0.0, "0: elastic felt");
        let c = p.controls;
        assert_eq!([c.sympathy, c.phantom, c.key_noise, c.damper_noise, c.pedal_noise], [0.0, 0.5, 4.0, 0.25, 0.0]);
    }

    #[test]
    fn a_preset_from_before_the_bebung_range_still_loads() {
        let old = Preset::parse(r#"{"controls": {"bebung": 0.25}}"#).unwrap();
        assert_eq!(old.controls.bebung_cents, 20.0, "the old default is the new one");
        assert_eq!(Preset::parse(r#"{"controls": {"bebung": 0.6}}"#).unwrap().controls.bebung_cents, 48.0);
        let both = Preset::parse(r#"{"controls": {"bebung": 0.6, "bebung_cents": 10}}"#).unwrap();
        assert_eq!(both.controls.bebung_cents, 10.0);
        let e = Preset::parse(r#"{"controls": {"bebung": "deep"}}"#).unwrap_err().to_string();
        assert!(e.contains("controls.bebung_cents: invalid type"), "{e}");
    }

    #[test]
    fn malformed_presets_name_the_field() {
        for (text, expected) in [
            (r#"{"voicng": {}}"#, "voicng"),
            (r#"{"voicing": {"hammer_mas": 1}}"#, "voicing.hammer_mas: unknown field"),
            (r#"{"voicing": {"damping": -1}}"#, "voicing.damping: must be from 0.01 to 100 (got -1)"),
            (r#"{"voicing": {"tangent_depth": 0}}"#, "voicing.tangent_depth"),
            (r#"{"voicing": {"fretted": 1}}"#, "voicing.fretted: invalid type"),
            (r#"{"voicing": 3}"#, "voicing: must be a JSON object"),
            (r#"{"controls": {"polyphony": "many"}}"#, "controls.polyphony: invalid type"),
            (r#"{"controls": {"polyphony": 0}}"#, "controls.polyphony: must be from 1 to 128"),
            (r#"{"controls": {"touch_max": 2}}"#, "controls.touch_max"),
            (r#"{"voicing": {"felt_hysteresis": -0.5}}"#, "voicing.felt_hysteresis: must be from 0 to 3 (got -0.5)"),
            (r#"{"controls": {"sympathy": 1.5}}"#, "controls.sympathy: must be from 0 to 1 (got 1.5)"),
            (r#"{"controls": {"phantom": 5}}"#, "controls.phantom: must be from 0 to 4 (got 5)"),
            (r#"{"controls": {"key_noise": -1}}"#, "controls.key_noise"),
            (r#"{"controls": {"damper_noise": 4.5}}"#, "controls.damper_noise"),
            (r#"{"controls": {"pedal_noise": "loud"}}"#, "controls.pedal_noise: invalid type"),
            (r#"{"controls": {"sympathetic": 1}}"#, "controls.sympathetic: unknown field"),
            (r#"{"controls": {"bebung_cents": 150}}"#, "controls.bebung_cents: must be from 0 to 100 cents (got 150)"),
            (r#"{"controls": {"velocity_floor": -0.1}}"#, "controls.velocity_floor: must be from 0 to 1"),
            (
                r#"{"controls": {"velocity_floor": 0.6, "velocity_ceiling": 0.5}}"#,
                "controls.velocity_ceiling: must be above the floor 0.6 (got 0.5)",
            ),
            (r#"{"instrument": "organ"}"#, "instrument: unknown variant `organ`"),
            (r#"{"name": 3}"#, "name: invalid type"),
            (r#"{"tuning": {"a4_hz": 500}}"#, "tuning.a4_hz: must be from 380 to 480 Hz (got 500)"),
            (r#"{"tuning": {"stetch": 1}}"#, "tuning"),
            (r#"{"tuning": {"temperament": "pythagorean"}}"#, "tuning.temperament: unknown variant"),
            (r#"{"tuning": {"temperament": "scala"}}"#, "tuning.temperament: scala needs a scale"),
            (r#"{"tuning": {"scale": {"degrees_cents": [100, "x"]}}}"#, "tuning.scale.degrees_cents[1]: invalid type"),
            (r#"{"tuning": {"scale": {"degrees_cents": [-5]}}}"#, "tuning.scale.degrees_cents[0]"),
            ("[1]", "a preset must be a JSON object"),
            ("{", "not valid JSON"),
        ] {
            let e = Preset::parse(text).unwrap_err().to_string();
            assert!(e.contains(expected), "{text}: {e}");
            assert_eq!(e.lines().count(), 1, "{e}");
        }
    }

    #[test]
    fn user_presets_are_saved_listed_and_loaded() {
        let scratch = Scratch::new("save");
        let dir = scratch.0.join("presets");
        assert!(list_user_presets(&dir).unwrap().is_empty(), "no directory yet: no presets");
        let mut preset = factory_presets().remove(0);
        preset.name = "My piano".into();
        let path = save_user_preset(&dir, &preset).unwrap();
        assert_eq!(path, dir.join("My piano.json"));
        assert_eq!(Preset::load(&path).unwrap(), preset);

        preset.controls.output_gain = 0.5;
        save_user_preset(&dir, &preset).unwrap();
        assert_eq!(Preset::load(&path).unwrap().controls.output_gain, 0.5, "replaced");
        let mut other = preset.clone();
        other.name = "another".into();
        save_user_preset(&dir, &other).unwrap();
        fs::write(dir.join("notes.txt"), "not a preset").unwrap();
        assert_eq!(list_user_presets(&dir).unwrap(), [dir.join("another.json"), dir.join("My piano.json")]);
        let files: Vec<String> =
            fs::read_dir(&dir).unwrap().map(|e| e.unwrap().file_name().into_string().unwrap()).collect();
        assert_eq!(files.len(), 3, "no temporary file left: {files:?}");
    }

    /// A bad name or a bad value is refused before anything is written; the file
    /// already there is kept whole.
    #[test]
    fn refused_presets_leave_nothing_behind() {
        let scratch = Scratch::new("refuse");
        let mut preset = Preset { name: "Keep".into(), ..Default::default() };
        let path = save_user_preset(&scratch.0, &preset).unwrap();
        let before = fs::read(&path).unwrap();
        for name in ["", "  ", "a/b", "a\\b", "what?", ".hidden", "trailing ", "CON", "lpt1.json", "tab\there"] {
            let e = save_user_preset(&scratch.0, &Preset { name: name.into(), ..Default::default() }).unwrap_err();
            assert!(matches!(e, PresetError::Name { .. }), "{name:?}: {e}");
            assert_eq!(e.to_string().lines().count(), 1);
        }
        preset.voicing.damping = f64::NAN;
        let e = save_user_preset(&scratch.0, &preset).unwrap_err().to_string();
        assert!(e.starts_with("voicing.damping"), "{e}");
        assert_eq!(fs::read(&path).unwrap(), before);
        assert_eq!(scratch.files(), ["Keep.json"]);

        fs::write(&path, r#"{"name": "Keep", "controls": {"touch_shape": 50}}"#).unwrap();
        let e = Preset::load(&path).unwrap_err().to_string();
        assert!(e.ends_with("Keep.json: controls.touch_shape: must be from 0.1 to 10 (got 50)"), "{e}");
        let e = Preset::load(&scratch.0.join("none.json")).unwrap_err().to_string();
        assert!(e.contains("none.json: cannot read"), "{e}");
    }

    #[test]
    fn the_user_directory_follows_xdg() {
        let dir = |xdg: Option<&str>, home: Option<&str>| preset_dir_from(xdg.map(Into::into), home.map(Into::into));
        assert_eq!(dir(Some("/cfg"), Some("/home/u")), Some(PathBuf::from("/cfg/struck/presets")));
        assert_eq!(dir(None, Some("/home/u")), Some(PathBuf::from("/home/u/.config/struck/presets")));
        assert_eq!(dir(Some("relative"), Some("/home/u")), Some(PathBuf::from("/home/u/.config/struck/presets")));
        assert_eq!(dir(Some(""), None), None);
    }
}
