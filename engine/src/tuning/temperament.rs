//! The temperaments: how the twelve semitones of an octave are tuned.
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
//! The pattern is laid from [`super::TuningSettings::root`]: with root D, what the
//! temperament does on C it does on D (meantone's wolf then falls on A#-F).
//! The whole keyboard is then moved by one amount so that A4 sounds at
//! [`super::TuningSettings::a4_hz`]: a key of pitch class p sits
//! `dev(p) - dev(A)` cents from its equal-tempered frequency, where dev is a
//! pitch class's deviation from equal temperament in the pattern as laid.
//!

use std::fmt;
use std::str::FromStr;

use serde::{Deserialize, Serialize};

use super::ratio_cents;

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
    /// A Scala scale ([`super::TuningSettings::scale`]).
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
