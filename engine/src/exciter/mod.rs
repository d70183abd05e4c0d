//! The exciters: what sets a string in motion.
//!
//! - [`hammer`]: a piano hammer or a dulcimer's, santoor's or cimbalom's mallet,
//!   a point mass meeting the string through felt (F = K C^alpha) or a spring
//!   (alpha = 1): one physics for both, so a mallet is a light hammer. Its
//!   contact law and implicit solve ([`hammer::contact`]) and the error budget
//!   its sub-steps keep to ([`hammer::substeps`]) sit beside it.
//! - [`tangent`]: the clavichord's brass blade, which strikes and stays, an
//!   imposed motion of the string's end.
//! - [`pluck`]: the harpsichord's plectrum, a released triangle.
//!
//! A string has one exciter ([`Exciter`]); each kind owns the tables it needs
//! at its point on the string (built off the audio thread) and the state of the
//! stroke in play, so nothing is looked up that might be missing.

// The audio thread steps every exciter: nothing here may panic.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod hammer;
pub mod pluck;
pub mod tangent;

use crate::modal_bank::{DriveTable, Hold, ModalBank, StepTable};
use hammer::HammerRig;
use pluck::PluckRig;
use tangent::TangentRig;

/// What one sample produced.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Tick {
    /// Force the exciter applies to the string, +y, N.
    pub contact_force_n: f64,
    /// Force the string applies to the bridge, +y, N.
    pub bridge_force_n: f64,
    /// Hammer or tangent position, m (none for a pluck).
    pub exciter_position_m: Option<f64>,
    /// String displacement at the exciter (its end, for a tangent), m.
    pub string_position_m: f64,
}

/// Receives every (sub)step of a hammer's motion: the lab measures contacts with it.
pub trait ContactObserver {
    /// At time `t_s` since the strike the felt's compression was `compression_m`
    /// (negative: a gap) and the force `force_n`.
    fn step(&mut self, t_s: f64, compression_m: f64, force_n: f64);
}

/// Observes nothing.
impl ContactObserver for () {
    #[inline(always)]
    fn step(&mut self, _: f64, _: f64, _: f64) {}
}

/// A string's exciter: its tables at its point, and its stroke while one is in play.
// One per string, built with it: boxing the hammer's rig would cost a pointer
// chase every sample for memory that is not scarce.
#[allow(clippy::large_enum_variant)]
#[derive(Clone)]
pub enum Exciter {
    /// None set up yet.
    None,
    Hammer(HammerRig),
    Tangent(TangentRig),
    Pluck(PluckRig),
}

impl Exciter {
    /// Whether a stroke is in play (a hammer thrown, a tangent on the string, a
    /// pluck just released).
    pub fn in_play(&self) -> bool {
        match self {
            Exciter::None => false,
            Exciter::Hammer(rig) => rig.in_play(),
            Exciter::Tangent(rig) => rig.in_play(),
            Exciter::Pluck(rig) => rig.in_play(),
        }
    }

    /// Let go of the stroke in play: the bank gets back its "input applied" form.
    /// A tangent is dropped where it is. Allocates: no.
    pub fn release(&mut self, bank: &mut ModalBank) {
        match self {
            Exciter::None => {}
            Exciter::Hammer(rig) => rig.release(bank),
            Exciter::Tangent(rig) => rig.release(bank),
            Exciter::Pluck(rig) => rig.release(),
        }
    }

    /// Forget the stroke in play without touching the modes (they were reset or
    /// replaced). Allocates: no.
    pub fn forget(&mut self) {
        match self {
            Exciter::None => {}
            Exciter::Hammer(rig) => rig.forget(),
            Exciter::Tangent(rig) => rig.forget(),
            Exciter::Pluck(rig) => rig.release(),
        }
    }

    /// Whether nothing but free decay lies ahead: no stroke, or a tangent at rest.
    pub fn is_settled(&self) -> bool {
        match self {
            Exciter::Tangent(rig) => rig.is_settled(),
            other => !other.in_play(),
        }
    }
}

/// The table through which an exciter drives `bank`'s modes over `step`: mode i
/// takes the modal acceleration `gain(i)` per unit of input, and the exciter
/// observes the sum of `observe(i)` q_i. Allocates.
pub(crate) fn drive_table(
    bank: &ModalBank,
    step: &StepTable,
    hold: Hold,
    gain: impl Fn(usize) -> f64,
    observe: impl Fn(usize) -> f64,
) -> DriveTable {
    let gains: Vec<f64> = (0..bank.len()).map(&gain).collect();
    let observes: Vec<f64> = (0..bank.len()).map(&observe).collect();
    DriveTable::new(step, hold, bank.weights(), &gains, &observes)
}
