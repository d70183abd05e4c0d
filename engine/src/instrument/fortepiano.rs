//! The fortepiano: a Viennese-action early piano with leather-covered hammers.
//!
//! Provisional: the piano's strings and hammers with a steeper leather law; the
//! instrument's own scale replaces this.

use std::ops::RangeInclusive;

use super::common::{pan, voiced_law};
use super::{ExciterDesign, KeyDesign, TouchRange, Voicing, piano};
use crate::contact::ContactLaw;

pub(super) const KEYS: RangeInclusive<u8> = 29..=91;

pub(super) const TOUCH: TouchRange = TouchRange { min: 0.1, max: 5.0 };

pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let mut d = piano::design(voicing, midi_key, max_frequency_hz);
    if let ExciterDesign::Hammer { law, .. } = &mut d.exciter {
        *law = voiced_law(ContactLaw { stiffness: 1.0e13, exponent: 3.5 }, voicing);
    }
    d.pan = pan(midi_key, KEYS);
    d
}
