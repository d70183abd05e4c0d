//! # Struck's engine: hammered, tangented and plucked strings from physics
//!
//! The data path from a strike to an output sample:
//!
//! 1. [`string`]: a [`string::StringSpec`] (length, tuning, mass, stiffness,
//!    damping) is turned once, when a note is set up, into a
//!    [`string::StringModes`]: tension, inharmonicity and the modes
//!    f_n = n f0 sqrt(1 + B n^2) up to a cut-off, each with its Q ([`damping`]).
//! 2. [`modal_bank`]: the modes' state, one complex number per mode scaled so
//!    that the bridge force is the sum of the real parts, advanced exactly by
//!    one complex multiply per mode and sample ([`modal_bank::StepTable`]).
//! 3. The exciters: a [`hammer`] or mallet (mass on felt, F = K C^alpha), a clavichord
//!    [`tangent`] (an imposed end motion), a [`pluck`] (a released triangle). An
//!    exciter drives the modes through a [`modal_bank::DriveTable`] and observes
//!    the string where it acts.
//! 4. [`struck_string`]: a string and its exciter stepped together. While a
//!    hammer is in or near contact the string is sub-stepped and the force is
//!    solved implicitly every sub-step ([`contact`]); the modes above the cut-off
//!    still yield statically ([`residual`]).
//! 5. The output of a string is its bridge force, T y'(0) - EI y'''(0).
//!
//! 6. [`instrument`]: what every key of a piano, fortepiano, santoor, hammered
//!    dulcimer, cimbalom, clavichord or harpsichord is made of ([`instrument::KeyDesign`]), scaled by the player's voicing,
//!    and [`tuning`]: the frequency each key is tuned to (temperament, inharmonic
//!    stretch, Scala scales).
//! 7. [`synth`]: the real-time instrument. Keys own their strings, exciter and
//!    damper; [`synth::Synth::process`] plays events sample-accurately without
//!    allocating, and a [`synth::Workshop`] thread rebuilds the tables when the
//!    settings change and hands them over through lock-free queues.
//!
//! [`preset`] keeps an instrument, voicing, controls and tuning under a name (the
//! factory presets and the user's). The lab (strike cases, analysis, speed
//! workloads, figures) is a crate of its own, `struck-lab`.
//!
//! Units are SI throughout and carried in names (`_hz`, `_m`, `_n`, `_s`).

// Checks are written `!(x > 0.0)` on purpose: a NaN must fail them.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod body;
pub(crate) mod damper;
pub mod design;
pub mod exciter;
pub(crate) mod key;
pub mod modal_bank;
pub mod preset;
pub mod rng;
pub mod string;
pub mod struck_string;
pub mod synth;
pub mod tuning;
