//! The concert cimbalom. Provisional: the santoor's courses under a pedal-worked
//! damper bar; its own stringing replaces this.

use std::ops::RangeInclusive;

use super::common::damper;
use super::{KeyDesign, TouchRange, Voicing, key_frequency_hz, santoor};

pub(super) const KEYS: RangeInclusive<u8> = 52..=89;

pub(super) const TOUCH: TouchRange = santoor::TOUCH;

pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let mut d = santoor::design(voicing, midi_key, max_frequency_hz);
    let mut bar = damper(0.5, 2.0e-3, key_frequency_hz(midi_key), 0.03);
    bar.pedal_only = true;
    d.damper = Some(bar);
    d
}
