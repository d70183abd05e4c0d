//! The hammered dulcimer. Provisional: the santoor's courses; the divided courses
//! replace this.

use std::ops::RangeInclusive;

use super::{KeyDesign, TouchRange, Voicing, santoor};

pub(super) const KEYS: RangeInclusive<u8> = 52..=89;

pub(super) const TOUCH: TouchRange = santoor::TOUCH;

pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> Option<KeyDesign> {
    Some(santoor::design(voicing, midi_key, max_frequency_hz))
}
