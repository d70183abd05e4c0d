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
//! ## Historical temperaments
//!
//! Each is a chain of twelve fifths round the circle (P = 1200 log2(3/2) =
//! 701.955 c is the pure fifth; the Pythagorean comma PC = 12 P - 7 x 1200 =
//! 23.460 c is what the twelve must give up between them):
//!
//! - quarter-comma meantone (Aaron 1523): eleven fifths of 1200 log2(5) / 4 =
//!   696.578 c, each a quarter of the syntonic comma narrow so that four of them
//!   make a pure third 5/4; the wolf G#-Eb takes what is left (737.6 c);
//! - Werckmeister III (1691): C-G, G-D, D-A and B-F# narrowed by PC / 4, the
//!   other eight pure;
//! - Vallotti: the six fifths F-C-G-D-A-E-B narrowed by PC / 6, the other six pure.
//!
//! The pattern is laid from [`TuningSettings::root`]: with root D, what the
//! temperament does on C it does on D (meantone's wolf then falls on A#-F).
//! The whole keyboard is then moved by one amount so that A4 sounds at
//! [`TuningSettings::a4_hz`]: a key of pitch class p sits
//! `dev(p) - dev(A)` cents from its equal-tempered frequency, where dev is a
//! pitch class's deviation from equal temperament in the pattern as laid.
//!
//! ## Stretch
//!
//! On a stiff string the partials run sharp, f_n = n f0 sqrt(1 + B n^2), so an
//! octave tuned beatless (the lower key's second partial on the upper key's
//! first) is wider than 2:1. In first-partial terms the octave from key k is
//!
//!   f_1(k + 12) = 2 f_1(k) sqrt((1 + 4 B_k) / (1 + B_k))
//!
//! (the same condition as f0(k + 12) = 2 f0(k) sqrt(1 + 4 B_k) / sqrt(1 + B_(k+12))
//! written with f0): W_k = 600 log2((1 + 4 B_k) /
//! (1 + B_k)) cents wider than 2:1. Octaves overlap, so each octave's W is spread
//! evenly over its twelve semitones and each semitone takes the mean of the
//! shares of the twelve octaves it belongs to; the semitones are then added up
//! outward from A4 (which stays at the reference). An octave is thereby widened
//! by a triangle-weighted mean of the W of the octaves starting up to eleven keys
//! either side of it: W_k itself wherever W changes evenly from key to key, and
//! smoothly across a
//! change of stringing where B jumps (the exact rule would there put a key
//! below its lower neighbour's stretch). The stretch never turns back: it only
//! rises from bass to treble. A key the instrument lacks takes a B interpolated
//! between its neighbours' (beyond the ends: the nearest key's).
//! [`TuningSettings::stretch`] scales all of it: 0 none, 1 the whole. The
//! reference key keeps its frequency: A4, or a keyboard mapping's reference key.
//!
//! ## Scala files
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
//! Nothing here runs on the audio thread: the frequencies are worked out when an
//! instrument is built.

use std::fmt;
use std::path::{Path, PathBuf};
use std::str::FromStr;

use serde::{Deserialize, Serialize};

/// The A4 references accepted, Hz (from low Baroque pitch to well above modern).
pub const A4_RANGE_HZ: std::ops::RangeInclusive<f64> = 380.0..=480.0;
/// Most pitches a scale may have (the Scala format allows a reader to set a limit).
pub const MAX_SCALE_DEGREES: usize = 4096;
/// Largest pattern a keyboard mapping may have, keys.
pub const MAX_MAP_SIZE: usize = 4096;
/// Largest pitch a scale degree may name, cents either way (a hundred octaves:
/// no real scale comes near; this keeps the arithmetic finite).
pub const MAX_DEGREE_CENTS: f64 = 120_000.0;
/// A tuning file is read only up to this size, bytes.
pub const MAX_FILE_BYTES: u64 = 1 << 20;

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
    /// on the lower key's second partial).
    pub stretch: f64,
    /// The scale the `scala` temperament plays.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scale: Option<ScalaScale>,
}

impl Default for TuningSettings {
    fn default() -> Self {
        Self { a4_hz: 440.0, temperament: Temperament::Equal, root: 0, stretch: 0.0, scale: None }
    }
}

/// The temperaments Struck tunes to.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Temperament {
    /// Twelve equal semitones of 100 c.
    #[default]
    Equal,
    /// Quarter-comma meantone.
    Meantone,
    /// Werckmeister III.
    Werckmeister3,
    /// Vallotti.
    Vallotti,
    /// A Scala scale ([`TuningSettings::scale`]).
    Scala,
}

impl Temperament {
    pub const ALL: [Temperament; 5] = [
        Temperament::Equal,
        Temperament::Meantone,
        Temperament::Werckmeister3,
        Temperament::Vallotti,
        Temperament::Scala,
    ];

    /// The name used in files and on the command line.
    pub fn name(self) -> &'static str {
        match self {
            Temperament::Equal => "equal",
            Temperament::Meantone => "meantone",
            Temperament::Werckmeister3 => "werckmeister3",
            Temperament::Vallotti => "vallotti",
            Temperament::Scala => "scala",
        }
    }

    /// The name for people.
    pub fn label(self) -> &'static str {
        match self {
            Temperament::Equal => "equal temperament",
            Temperament::Meantone => "quarter-comma meantone",
            Temperament::Werckmeister3 => "Werckmeister III",
            Temperament::Vallotti => "Vallotti",
            Temperament::Scala => "Scala scale",
        }
    }

    /// Cents above the pattern's first note (C when laid from C) of each of the
    /// twelve pitch classes; None for equal temperament and a scale.
    pub fn pattern_cents(self) -> Option<[f64; 12]> {
        let pure = ratio_cents(3.0 / 2.0);
        let pythagorean_comma = 12.0 * pure - 8400.0;
        // The fifths up the circle from C: C-G, G-D, D-A, A-E, E-B, B-F#, F#-C#,
        // C#-G#, G#-Eb, Eb-Bb, Bb-F, F-C.
        let fifths: [f64; 12] = match self {
            Temperament::Equal | Temperament::Scala => return None,
            Temperament::Meantone => {
                let fifth = 1200.0 * 5f64.log2() / 4.0;
                let mut f = [fifth; 12];
                f[8] = 8400.0 - 11.0 * fifth;
                f
            }
            Temperament::Werckmeister3 => {
                let mut f = [pure; 12];
                for i in [0, 1, 2, 5] {
                    f[i] -= pythagorean_comma / 4.0;
                }
                f
            }
            Temperament::Vallotti => {
                let mut f = [pure; 12];
                for i in [11, 0, 1, 2, 3, 4] {
                    f[i] -= pythagorean_comma / 6.0;
                }
                f
            }
        };
        let mut pattern = [0.0; 12];
        let mut above_c = 0.0;
        for (steps, fifth) in fifths.iter().take(11).enumerate() {
            above_c += fifth;
            pattern[(7 * (steps + 1)) % 12] = above_c.rem_euclid(1200.0);
        }
        Some(pattern)
    }
}

impl fmt::Display for Temperament {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl FromStr for Temperament {
    type Err = String;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        Self::ALL.into_iter().find(|t| t.name().eq_ignore_ascii_case(s)).ok_or_else(|| {
            format!("unknown temperament \"{s}\" (expected equal, meantone, werckmeister3, vallotti or scala)")
        })
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
                format!("must be from {} to {} Hz (got {})", A4_RANGE_HZ.start(), A4_RANGE_HZ.end(), self.a4_hz),
            ));
        }
        if self.root > 11 {
            return Err(FieldError::new(
                "root",
                format!("must be a pitch class from 0 (C) to 11 (B) (got {})", self.root),
            ));
        }
        if !(0.0..=1.0).contains(&self.stretch) {
            return Err(FieldError::new("stretch", format!("must be from 0 to 1 (got {})", self.stretch)));
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
        if self.stretch > 0.0 {
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

/// The full inharmonic stretch of every key, cents from its tempered pitch (0 at A4).
/// All zeros when no key has a B.
pub fn stretch_cents(inharmonicity: &dyn Fn(u8) -> Option<f64>) -> [f64; 128] {
    let known: Vec<(usize, f64)> = (0..128u8)
        .filter_map(|k| inharmonicity(k).filter(|b| b.is_finite() && *b >= 0.0).map(|b| (k as usize, b)))
        .collect();
    let (Some(&(first, first_b)), Some(&(last, last_b))) = (known.first(), known.last()) else {
        return [0.0; 128];
    };
    let mut b = [0.0f64; 128];
    for (k, b) in b.iter_mut().enumerate() {
        *b = if k <= first {
            first_b
        } else if k >= last {
            last_b
        } else {
            let upper = known.partition_point(|&(key, _)| key < k);
            let (hi, b_hi) = known[upper];
            let (lo, b_lo) = known[upper - 1];
            if hi == k { b_hi } else { b_lo + (b_hi - b_lo) * (k - lo) as f64 / (hi - lo) as f64 }
        };
    }
    // The widening of the octave from key k to k + 12, cents.
    let widening: Vec<f64> = b.iter().map(|&b| 600.0 * ((1.0 + 4.0 * b) / (1.0 + b)).log2()).collect();
    // Each octave's widening spread evenly over its twelve semitones; a semitone
    // takes the mean share of the twelve octaves it belongs to.
    let semitone: Vec<f64> = (0..128)
        .map(|j: usize| (j.saturating_sub(11)..=j).map(|k| widening[k]).sum::<f64>() / (12 * (j.min(11) + 1)) as f64)
        .collect();
    let mut cents = [0.0f64; 128];
    for k in 70..128 {
        cents[k] = cents[k - 1] + semitone[k - 1];
    }
    for k in (0..69).rev() {
        cents[k] = cents[k + 1] - semitone[k];
    }
    cents
}

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

/// Why a tuning file was refused: one line naming the line and the reason.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum TuningError {
    #[error("line {line}: {reason}")]
    Line { line: usize, reason: String },
    #[error("{reason} (the file ends at line {lines})")]
    Ended { lines: usize, reason: String },
}

/// A tuning file that could not be read or was refused; names the file.
#[derive(Debug, thiserror::Error)]
pub enum TuningFileError {
    #[error("{}: cannot read: {source}", path.display())]
    Read { path: PathBuf, source: std::io::Error },
    #[error("{}: {reason}", path.display())]
    TooLarge { path: PathBuf, reason: String },
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
    let read = |source| TuningFileError::Read { path: path.to_path_buf(), source };
    let size = std::fs::metadata(path).map_err(read)?.len();
    if size > MAX_FILE_BYTES {
        return Err(TuningFileError::TooLarge {
            path: path.to_path_buf(),
            reason: format!("{size} bytes is too large for a tuning file (at most {MAX_FILE_BYTES})"),
        });
    }
    Ok(decode(std::fs::read(path).map_err(read)?))
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
                format!("the last pitch is the period and must be above 1/1 (got {period} cents)"),
            ));
        }
        Ok(Self { description: description.trim().to_string(), degrees_cents, keyboard_mapping: None })
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

    fn validate(&self) -> Result<(), FieldError> {
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
                    format!("must be within {MAX_DEGREE_CENTS} cents of 1/1 (got {c})"),
                ));
            }
        }
        if !(self.period_cents() > 0.0) {
            return Err(FieldError::new(
                format!("degrees_cents[{}]", n - 1),
                format!("the last pitch is the period and must be above 0 cents (got {})", self.period_cents()),
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
            Ok(hz) if hz.is_finite() && hz > 0.0 => hz,
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

    fn validate(&self) -> Result<(), FieldError> {
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
        if !(self.reference_hz.is_finite() && self.reference_hz > 0.0) {
            return Err(FieldError::new(
                "reference_hz",
                format!("must be a positive frequency (got {})", self.reference_hz),
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
            "scale.keyboard_mapping.reference_hz: must be a positive frequency (got 0)"
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
        use crate::instrument::{InstrumentKind, Voicing, design};
        let b = |k: u8| {
            let d = design(InstrumentKind::Piano, &Voicing::default(), k, 20_000.0)?;
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
