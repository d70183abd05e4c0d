//! # Struck's engine: hammered, tangented and plucked strings from physics
//!
//! Real-time code only: no plots, no FFT, no thread pools (the lab, `struck-lab`,
//! has those). A note walks down the folders in order and never turns back:
//!
//! ```text
//! synth ──> key ──> struck_string ──> exciter ──> string + modal_bank
//!  │         │       (hammer, tangent, pluck)
//!  │         ├──> damper, action, phantom
//!  │         └──> body (the bridge: where every key's force goes)
//!  └──> performance (the pedals and wheels, handed to the keys)
//! design + tuning: what each key is built from, off the audio thread
//! ```
//!
//! The walk of one note, as the code runs it:
//!
//! ```text
//! a host's note, or a MIDI file's (synth::midi_velocity)
//!   │ Event::NoteOn { key, velocity: f64 }
//!   v
//! Synth::process: cut at events and every CONTROL_BLOCK            synth/mod.rs
//!   │ velocity ──> Controls::touch ──> Touch (m/s, or a lift in mm)  synth/settings.rs
//!   │ key ──> the course that plays it, and which of its notes       synth/instrument.rs
//!   v
//! Key::press(note, touch, &PerformanceState)                         key/strike.rs
//!   │ una corda, the hammer's share of each string, the regulation
//!   v
//! StruckString::strike_substepped: string and hammer stepped         struck_string.rs
//!   │ together, the contact force F = K C^alpha solved implicitly     exciter/hammer/
//!   v
//! the string's modes, one complex multiply a mode and sample         modal_bank/
//!   │ (once the hammer has gone: gathered with the key's other
//!   │ free strings and run as one bank)                               key/render.rs
//!   v
//! Key::sound ──> Key::drive ──> Bridge ──> Soundboard ──> microphones  body/
//!   v
//! Outlet: DC block, output gain ──> the host's two channels          synth/output.rs
//! ```
//!
//! Once per control block each sounding key moves its damper, retunes, trades
//! its unison's energy through the body, culls its faded modes and notices
//! silence (key/control.rs); the sympathetic strings trade between keys
//! (synth/sympathy.rs).
//!
//! 1. [`string`]: a [`string::StringSpec`] (length, tuning, mass, stiffness,
//!    damping) is turned once, when a key is built, into a
//!    [`string::StringModes`]: tension, inharmonicity and the modes
//!    f_n = n f0 sqrt(1 + B n^2) up to a cut-off, each with its Q
//!    ([`string::damping`]); the modes above the cut-off still yield statically
//!    ([`string::residual`]).
//! 2. [`modal_bank`]: the modes' state, one complex number per mode scaled so
//!    that the bridge force is the sum of the real parts, advanced exactly by
//!    one complex multiply per mode and sample ([`modal_bank::StepTable`]).
//! 3. [`exciter`]: one room per way of setting a string going, each variant of
//!    [`exciter::Exciter`] owning its tables and its stroke: the
//!    [`exciter::hammer`] or mallet (mass on felt, F = K C^alpha, solved
//!    implicitly and sub-stepped as finely as the strike needs), the
//!    clavichord's [`exciter::tangent`] (an imposed end motion) and the
//!    [`exciter::pluck`] (a released triangle). An exciter drives the modes
//!    through a [`modal_bank::DriveTable`] and observes the string where it acts.
//! 4. [`struck_string`]: a string and its exciter stepped together; its output
//!    is its bridge force, T y'(0) - EI y'''(0).
//! 5. The key (crate-private): a course of strings, the exciter that plays each
//!    of its notes, its damper, its fade and voice stealing. It hands its force
//!    to the [`body::Bridge`] at its [`body::BridgePoint`], never to the mix.
//! 6. [`body`]: what the bridge drives and what reaches the output.
//! 7. [`performance`]: what the player is doing with the instrument as a
//!    whole (pedals, wheels, una corda, each MIDI key's own shaping), kept by
//!    the synth and handed whole to the keys.
//! 8. [`synth`]: the real-time instrument: [`synth::Synth::process`] plays
//!    events sample-accurately without allocating, and a [`synth::Workshop`]
//!    thread rebuilds the tables when the settings change and hands them over
//!    through lock-free queues.
//!
//! Off the audio thread: [`design`], what every key of a piano, fortepiano,
//! santoor, hammered dulcimer, cimbalom, clavichord or harpsichord is made of
//! ([`design::KeyDesign`]), scaled by the player's voicing; [`tuning`], the
//! frequency each key is tuned to (temperaments, inharmonic stretch and Scala
//! files, each a room); [`preset`], an instrument, voicing, controls and tuning
//! under a name.
//!
//! Units are SI throughout and carried in names (`_hz`, `_m`, `_n`, `_s`); a
//! velocity's [`design::Touch`] is a speed or a plectrum's lift, never a bare
//! number. The rooms the audio thread runs deny `unwrap`, `expect` and `panic`.

// Checks are written `!(x > 0.0)` on purpose: a NaN must fail them.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

/// Samples between control updates: a key's damper, pitch and culling move once
/// a block, and the keys drive the bridge in stretches of at most one.
pub const CONTROL_BLOCK: usize = 64;

/// `text` with its control characters escaped (a line break as `\n`, an escape
/// as `\u{1b}`): a message that quotes what a file holds stays one line and
/// cannot move the terminal's cursor or change its colours.
pub fn printable(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        if c.is_control() {
            out.extend(c.escape_debug());
        } else {
            out.push(c);
        }
    }
    out
}

/// `value` as a message quotes it: as written for everyday sizes, in exponent
/// form beyond them (a 1e300 read from a file is not shown three hundred
/// digits long).
pub fn readable(value: f64) -> String {
    if value != 0.0 && value.is_finite() && !(1e-6..1e9).contains(&value.abs()) {
        format!("{value:e}")
    } else {
        format!("{value}")
    }
}

#[cfg(test)]
mod tests {
    #[test]
    fn numbers_read_short_at_any_size() {
        assert_eq!(super::readable(440.0), "440");
        assert_eq!(super::readable(-0.25), "-0.25");
        assert_eq!(super::readable(1e300), "1e300");
        assert_eq!(super::readable(-2.5e-30), "-2.5e-30");
        assert_eq!(super::readable(f64::NAN), "NaN");
        assert_eq!(super::readable(0.0), "0");
    }
}

pub mod action;
pub mod body;
mod cores;
pub(crate) mod damper;
pub mod design;
pub mod exciter;
pub mod input;
pub(crate) mod key;
pub mod modal_bank;
pub mod performance;
pub mod phantom;
pub mod preset;
pub mod rng;
pub mod string;
pub mod struck_string;
pub mod synth;
pub mod tuning;
