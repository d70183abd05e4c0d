//! Scala scales (`.scl`) and keyboard mappings (`.kbm`).
//!
//! The `.scl` and `.kbm` formats are Manuel Op de Coul's (the Scala program's
//! "scale file format" and "keyboard mappings" pages). Without a `.kbm` the
//! scale is mapped as Scala maps it by default: linearly, degree 0 on key 60
//! (C4), which sounds at its equal-tempered frequency from A4 = `a4_hz`
//! (261.626 Hz at 440), so a 12-tone equal scale gives equal temperament. With a
//! `.kbm`, its reference key and frequency set the pitch and `a4_hz` is not used.
//! Keys a mapping leaves out (an `x`, or outside its first..last key) keep equal
//! temperament from `a4_hz`. `root` does not apply to a scale: a mapping's
//! middle key says where degree 0 falls.
//!

use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};

use super::{FieldError, ratio_cents};

/// Most pitches a scale may have (the Scala format allows a reader to set a limit).
pub const MAX_SCALE_DEGREES: usize = 4096;
/// Largest pattern a keyboard mapping may have, keys.
pub const MAX_MAP_SIZE: usize = 4096;
/// Largest pitch a scale degree may name, cents either way (a hundred octaves:
/// no real scale comes near; this keeps the arithmetic finite).
pub const MAX_DEGREE_CENTS: f64 = 120_000.0;
/// A tuning file is read only up to this size, bytes.
pub const MAX_FILE_BYTES: u64 = 1 << 20;
/// Longest description a scale keeps, characters (a `.scl` file's longer
/// description line is cut there): it is the scale's name, and it goes into
/// every preset that holds the scale.
pub const MAX_DESCRIPTION_CHARS: usize = 1000;
/// The frequencies a keyboard mapping's reference key may be tuned to, Hz:
/// MIDI's key 0 sounds at 8.2 Hz and key 127 at 12.5 kHz in equal
/// temperament; a reference far outside leaves every key silent or beyond
/// hearing.
pub const REFERENCE_RANGE_HZ: std::ops::RangeInclusive<f64> = 1.0..=25_000.0;

/// A scale in the Scala `.scl` format: degree 0 is 1/1, `degrees_cents` the rest;
/// the last degree is the period the scale repeats at (usually the octave).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct ScalaScale {
    /// The file's description line (often the scale's name).
    #[serde(default)]
    pub description: String,
    /// Degrees 1..=n, cents above degree 0.
    pub degrees_cents: Vec<f64>,
    /// Where the degrees go on the keys (a `.kbm`); None: Scala's default, degree 0
    /// on C4 at its equal-tempered pitch, one degree per key.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub keyboard_mapping: Option<KeyboardMapping>,
}

/// Where a scale's degrees fall on the keys, in the Scala `.kbm` format.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct KeyboardMapping {
    /// Keys in one repetition of the pattern; 0: linear, one degree per key.
    pub map_size: usize,
    /// The keys retuned; the others keep equal temperament.
    pub first_key: u8,
    pub last_key: u8,
    /// The key the pattern's first entry falls on.
    pub middle_key: u8,
    /// The key tuned to `reference_hz`.
    pub reference_key: u8,
    pub reference_hz: f64,
    /// The degree one repetition of the pattern rises by; 0: the scale's period.
    pub octave_degree: usize,
    /// Each key's degree from `middle_key` up, `map_size` at most (None: `x`,
    /// not mapped; keys past the end of a short list are not mapped either).
    pub map: Vec<Option<usize>>,
}

/// Why a tuning file was refused: one line naming the line and the reason
/// (what it quotes of the file shown with its control characters escaped).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TuningError {
    #[error("line {line}: {}", crate::printable(.reason))]
    Line { line: usize, reason: String },
    #[error("{} (the file ends at line {lines})", crate::printable(.reason))]
    Ended { lines: usize, reason: String },
}

/// A tuning file that could not be read or was refused; names the file.
#[derive(Debug, thiserror::Error)]
pub enum TuningFileError {
    #[error("{}: cannot read: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{}: {reason}", path.display())]
    Refused { path: PathBuf, reason: String },
    #[error("{}: {source}", path.display())]
    Malformed { path: PathBuf, source: TuningError },
}

/// The non-comment lines of a Scala file with their 1-based numbers.
struct ScalaLines<'a> {
    lines: std::iter::Enumerate<std::str::Lines<'a>>,
    count: usize,
}

impl<'a> ScalaLines<'a> {
    fn new(text: &'a str) -> Self {
        let text = text.strip_prefix('\u{feff}').unwrap_or(text);
        Self { lines: text.lines().enumerate(), count: text.lines().count() }
    }

    /// The next line that is not a comment.
    fn next_line(&mut self) -> Option<(usize, &'a str)> {
        self.lines.by_ref().map(|(i, l)| (i + 1, l)).find(|(_, l)| !l.starts_with('!'))
    }

    /// The first word of the next line that is neither a comment nor blank.
    fn next_word(&mut self) -> Option<(usize, &'a str)> {
        loop {
            let (n, line) = self.next_line()?;
            if let Some(word) = line.split_whitespace().next() {
                return Some((n, word));
            }
        }
    }

    fn ended(&self, reason: impl Into<String>) -> TuningError {
        TuningError::Ended { lines: self.count, reason: reason.into() }
    }
}

fn at(line: usize, reason: impl Into<String>) -> TuningError {
    TuningError::Line { line, reason: reason.into() }
}

/// One pitch of a `.scl`: cents if it has a '.', else a ratio n/d or a whole number n.
fn parse_pitch(word: &str) -> Result<f64, String> {
    if word.contains('.') {
        return match word.parse::<f64>() {
            Ok(c) if c.is_finite() && c.abs() <= MAX_DEGREE_CENTS => Ok(c),
            Ok(_) => Err(format!("\"{word}\" is too far from 1/1 (at most {MAX_DEGREE_CENTS} cents either way)")),
            Err(_) => Err(format!("\"{word}\" is not a number of cents")),
        };
    }
    let (numerator, denominator) = word.split_once('/').unwrap_or((word, "1"));
    let whole = |part: &str| part.parse::<i64>().ok();
    let (Some(n), Some(d)) = (whole(numerator), whole(denominator)) else {
        return Err(format!("\"{word}\" is not a ratio or a number of cents"));
    };
    let reason = if d == 0 {
        "denominator 0"
    } else if n < 0 || d < 0 {
        "negative"
    } else if n == 0 {
        "zero"
    } else {
        let c = ratio_cents(n as f64 / d as f64);
        return if c.abs() <= MAX_DEGREE_CENTS {
            Ok(c)
        } else {
            Err(format!("\"{word}\" is too far from 1/1 (at most {MAX_DEGREE_CENTS} cents either way)"))
        };
    };
    Err(format!("\"{word}\" is not a ratio ({reason})"))
}

/// A whole number from a `.kbm` header line.
fn parse_whole(line: usize, word: &str, what: &str, max: usize) -> Result<usize, TuningError> {
    match word.parse::<usize>() {
        Ok(v) if v <= max => Ok(v),
        Ok(v) => Err(at(line, format!("{what} must be from 0 to {max} (got {v})"))),
        Err(_) => Err(at(line, format!("\"{word}\" is not a {what} (a whole number from 0 to {max})"))),
    }
}

/// Text of a tuning file: UTF-8, or else Latin-1 (Scala's own character set).
fn decode(bytes: Vec<u8>) -> String {
    String::from_utf8(bytes).unwrap_or_else(|e| e.into_bytes().iter().map(|&b| char::from(b)).collect())
}

fn read_file(path: &Path) -> Result<String, TuningFileError> {
    use crate::input::{ReadError, read_regular};
    match read_regular(path, MAX_FILE_BYTES) {
        Ok(bytes) => Ok(decode(bytes)),
        Err(ReadError::Io(source)) => Err(TuningFileError::Read { path: path.to_path_buf(), source }),
        Err(e) => Err(TuningFileError::Refused { path: path.to_path_buf(), reason: e.to_string() }),
    }
}

impl ScalaScale {
    /// Read a `.scl` file's text. Lines starting with '!' are comments; then a
    /// description line, the number of pitches, and the pitches one a line (cents
    /// if they contain a '.', else a ratio n/d or a whole number n/1; anything after
    /// the first word is ignored). The pitches must all be there, no more than the
    /// count, and the last (the period) must be above 1/1.
    pub fn parse(text: &str) -> Result<Self, TuningError> {
        let mut lines = ScalaLines::new(text);
        let Some((_, description)) = lines.next_line() else {
            return Err(lines.ended("no description line"));
        };
        let Some((count_line, count_word)) = lines.next_word() else {
            return Err(lines.ended("no count of pitches after the description"));
        };
        let count = match count_word.parse::<usize>() {
            Ok(0) => return Err(at(count_line, "a scale needs at least one pitch (its period, e.g. 2/1)")),
            Ok(n) if n <= MAX_SCALE_DEGREES => n,
            Ok(n) => return Err(at(count_line, format!("{n} pitches is too many (at most {MAX_SCALE_DEGREES})"))),
            Err(_) => return Err(at(count_line, format!("\"{count_word}\" is not a count of pitches"))),
        };
        let mut degrees_cents = Vec::with_capacity(count);
        let mut last_line = count_line;
        while degrees_cents.len() < count {
            let Some((n, word)) = lines.next_word() else {
                return Err(lines.ended(format!("{} of the {count} pitches are missing", count - degrees_cents.len())));
            };
            degrees_cents.push(parse_pitch(word).map_err(|reason| at(n, reason))?);
            last_line = n;
        }
        if let Some((n, word)) = lines.next_word() {
            return Err(at(n, format!("\"{word}\" is one pitch more than the count of {count} on line {count_line}")));
        }
        let period = degrees_cents[count - 1];
        if !(period > 0.0) {
            return Err(at(
                last_line,
                format!("the last pitch is the period and must be above 1/1 (got {} cents)", crate::readable(period)),
            ));
        }
        let description = description.trim().chars().take(MAX_DESCRIPTION_CHARS).collect();
        Ok(Self { description, degrees_cents, keyboard_mapping: None })
    }

    /// Read a `.scl` file; the error names the file.
    pub fn load(path: &Path) -> Result<Self, TuningFileError> {
        Self::parse(&read_file(path)?).map_err(|source| TuningFileError::Malformed { path: path.to_path_buf(), source })
    }

    /// The period: the last degree, cents.
    pub fn period_cents(&self) -> f64 {
        self.degrees_cents.last().copied().unwrap_or(1200.0)
    }

    /// Cents above degree 0 of any degree, the scale repeating at its period.
    pub fn degree_cents(&self, degree: i64) -> f64 {
        let n = self.degrees_cents.len().max(1) as i64;
        let (periods, step) = (degree.div_euclid(n), degree.rem_euclid(n));
        let within = if step == 0 { 0.0 } else { self.degrees_cents.get(step as usize - 1).copied().unwrap_or(0.0) };
        periods as f64 * self.period_cents() + within
    }

    pub(super) fn validate(&self) -> Result<(), FieldError> {
        if self.description.chars().count() > MAX_DESCRIPTION_CHARS {
            return Err(FieldError::new("description", format!("must be at most {MAX_DESCRIPTION_CHARS} characters")));
        }
        let n = self.degrees_cents.len();
        if n == 0 || n > MAX_SCALE_DEGREES {
            return Err(FieldError::new(
                "degrees_cents",
                format!("must hold 1 to {MAX_SCALE_DEGREES} pitches (got {n})"),
            ));
        }
        for (i, &c) in self.degrees_cents.iter().enumerate() {
            if !(c.is_finite() && c.abs() <= MAX_DEGREE_CENTS) {
                return Err(FieldError::new(
                    format!("degrees_cents[{i}]"),
                    format!("must be within {MAX_DEGREE_CENTS} cents of 1/1 (got {})", crate::readable(c)),
                ));
            }
        }
        if !(self.period_cents() > 0.0) {
            return Err(FieldError::new(
                format!("degrees_cents[{}]", n - 1),
                format!(
                    "the last pitch is the period and must be above 0 cents (got {})",
                    crate::readable(self.period_cents())
                ),
            ));
        }
        if let Some(mapping) = &self.keyboard_mapping {
            mapping.validate().map_err(|e| e.within("keyboard_mapping"))?;
        }
        Ok(())
    }
}

impl KeyboardMapping {
    /// One degree per key, degree 0 on `middle_key`, which sounds at `reference_hz`.
    pub fn linear(middle_key: u8, reference_hz: f64) -> Self {
        Self {
            map_size: 0,
            first_key: 0,
            last_key: 127,
            middle_key,
            reference_key: middle_key,
            reference_hz,
            octave_degree: 0,
            map: Vec::new(),
        }
    }

    /// Read a `.kbm` file's text: after comments ('!'), seven numbers one a line
    /// (the pattern's size in keys, 0 for linear; the first and last keys
    /// retuned; the middle key, where the pattern's first entry falls; the
    /// reference key and its frequency in Hz; the degree the pattern repeats at,
    /// 0 for the scale's period), then up to `size` entries, each a degree or `x`
    /// for a key left unmapped (missing entries at the end are unmapped too).
    pub fn parse(text: &str) -> Result<Self, TuningError> {
        let mut lines = ScalaLines::new(text);
        let mut next = |what: &str| lines.next_word().ok_or_else(|| lines.ended(format!("no {what} line")));
        let key = |(line, word): (usize, &str), what: &str| parse_whole(line, word, what, 127).map(|k| k as u8);
        let (line, word) = next("size of the map")?;
        let map_size = parse_whole(line, word, "size of the map", MAX_MAP_SIZE)?;
        let first_key = key(next("first key")?, "first key to retune")?;
        let last = next("last key")?;
        let last_key = key(last, "last key to retune")?;
        if first_key > last_key {
            return Err(at(last.0, format!("the last key {last_key} is below the first key {first_key}")));
        }
        let middle_key = key(next("middle key")?, "middle key")?;
        let reference = next("reference key")?;
        let reference_key = key(reference, "reference key")?;
        let (hz_line, hz_word) = next("reference frequency")?;
        let reference_hz = match hz_word.parse::<f64>() {
            Ok(hz) if REFERENCE_RANGE_HZ.contains(&hz) => hz,
            Ok(hz) if hz.is_finite() && hz > 0.0 => {
                let (low, high) = (REFERENCE_RANGE_HZ.start(), REFERENCE_RANGE_HZ.end());
                return Err(at(
                    hz_line,
                    format!("the reference frequency {hz_word} Hz is not from {low} to {high} Hz"),
                ));
            }
            _ => return Err(at(hz_line, format!("\"{hz_word}\" is not a frequency (a positive number of Hz)"))),
        };
        let (line, word) = next("octave degree")?;
        let octave_degree = parse_whole(line, word, "octave degree", MAX_SCALE_DEGREES * 1024)?;
        let mut map = Vec::new();
        while let Some((n, word)) = lines.next_word() {
            if map.len() == map_size {
                return Err(at(
                    n,
                    if map_size == 0 {
                        format!("\"{word}\": a linear map (size 0) has no entries")
                    } else {
                        format!("\"{word}\" is one entry more than the size of the map, {map_size}")
                    },
                ));
            }
            map.push(if word.eq_ignore_ascii_case("x") {
                None
            } else {
                match word.parse::<usize>() {
                    Ok(d) if d <= MAX_SCALE_DEGREES * 1024 => Some(d),
                    _ => return Err(at(n, format!("\"{word}\" is not a scale degree (a whole number, or x)"))),
                }
            });
        }
        let mapping =
            Self { map_size, first_key, last_key, middle_key, reference_key, reference_hz, octave_degree, map };
        if !mapping.maps(reference_key) {
            return Err(at(
                reference.0,
                format!("the reference key {reference_key} is not mapped (its entry is x or missing)"),
            ));
        }
        Ok(mapping)
    }

    /// Read a `.kbm` file; the error names the file.
    pub fn load(path: &Path) -> Result<Self, TuningFileError> {
        Self::parse(&read_file(path)?).map_err(|source| TuningFileError::Malformed { path: path.to_path_buf(), source })
    }

    /// The pattern's entry for `key`: (repetitions from the middle key, entry).
    fn entry(&self, key: u8) -> Option<(i64, i64)> {
        let offset = i64::from(key) - i64::from(self.middle_key);
        if self.map_size == 0 {
            return Some((0, offset));
        }
        let size = self.map_size as i64;
        let degree = (*self.map.get(offset.rem_euclid(size) as usize)?)?;
        Some((offset.div_euclid(size), degree as i64))
    }

    /// Whether the pattern gives `key` a degree (whatever the retuned range).
    fn maps(&self, key: u8) -> bool {
        self.entry(key).is_some()
    }

    /// Cents above degree 0 of `key` in `scale`; None when the key is not mapped
    /// (or, with `in_range`, outside the retuned keys).
    pub fn key_cents(&self, scale: &ScalaScale, key: u8, in_range: bool) -> Option<f64> {
        if in_range && !(self.first_key..=self.last_key).contains(&key) {
            return None;
        }
        let (repetitions, degree) = self.entry(key)?;
        let octave =
            if self.octave_degree == 0 { scale.period_cents() } else { scale.degree_cents(self.octave_degree as i64) };
        Some(scale.degree_cents(degree) + repetitions as f64 * octave)
    }

    pub(super) fn validate(&self) -> Result<(), FieldError> {
        if self.map_size > MAX_MAP_SIZE {
            return Err(FieldError::new(
                "map_size",
                format!("must be from 0 to {MAX_MAP_SIZE} (got {})", self.map_size),
            ));
        }
        if self.map.len() > self.map_size {
            return Err(FieldError::new(
                "map",
                format!("has {} entries, more than map_size {}", self.map.len(), self.map_size),
            ));
        }
        for (field, key) in [
            ("first_key", self.first_key),
            ("last_key", self.last_key),
            ("middle_key", self.middle_key),
            ("reference_key", self.reference_key),
        ] {
            if key > 127 {
                return Err(FieldError::new(field, format!("must be a MIDI key from 0 to 127 (got {key})")));
            }
        }
        if self.first_key > self.last_key {
            return Err(FieldError::new("last_key", format!("is below first_key {}", self.first_key)));
        }
        if !REFERENCE_RANGE_HZ.contains(&self.reference_hz) {
            let (low, high) = (REFERENCE_RANGE_HZ.start(), REFERENCE_RANGE_HZ.end());
            return Err(FieldError::new(
                "reference_hz",
                format!("must be a frequency from {low} to {high} Hz (got {})", crate::readable(self.reference_hz)),
            ));
        }
        let max_degree = MAX_SCALE_DEGREES * 1024;
        if self.octave_degree > max_degree {
            return Err(FieldError::new("octave_degree", format!("must be at most {max_degree}")));
        }
        if let Some(i) = self.map.iter().position(|d| d.is_some_and(|d| d > max_degree)) {
            return Err(FieldError::new(format!("map[{i}]"), format!("must be at most {max_degree}")));
        }
        if !self.maps(self.reference_key) {
            return Err(FieldError::new("reference_key", format!("key {} is not mapped", self.reference_key)));
        }
        Ok(())
    }
}
