//! Tuning: the frequency every MIDI key's strings are tuned to.
//!
//! Provisional: equal temperament from the A4 reference; temperaments, stretch
//! and Scala files complete this module.

use serde::{Deserialize, Serialize};

/// How the instrument is tuned.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default, deny_unknown_fields)]
pub struct TuningSettings {
    /// Frequency of A4, Hz.
    pub a4_hz: f64,
}

impl Default for TuningSettings {
    fn default() -> Self {
        Self { a4_hz: 440.0 }
    }
}

impl TuningSettings {
    /// The first-partial frequency of every MIDI key, Hz. `inharmonicity` gives a
    /// key's B (None where the instrument has no such key), for stretched tunings.
    pub fn frequencies_hz(&self, _inharmonicity: &dyn Fn(u8) -> Option<f64>) -> [f64; 128] {
        std::array::from_fn(|k| self.a4_hz * 2f64.powf((k as f64 - 69.0) / 12.0))
    }
}
