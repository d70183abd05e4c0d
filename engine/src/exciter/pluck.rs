//! The pluck (harpsichord, and Euphonics' "wire-break" pluck): the string is
//! pulled aside at one point into a triangle of height D and released from rest
//! at t = 0.
//!
//! Projecting the triangle with its apex at beta L on sin(n pi x / L):
//!   q_n(0) = 2 D sin(n pi beta) / (n^2 pi^2 beta (1 - beta)),  q_n'(0) = 0,
//! a 1/n^2 envelope with the partials that have a node at the plucking point missing.

use std::f64::consts::PI;

use crate::exciter::{Tick, drive_table};
use crate::modal_bank::{DriveTable, Hold, ModalBank, StepTable};
use crate::string::StringModes;

/// How the string is plucked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PluckSpec {
    /// Height of the triangle at the plucking point, m.
    pub displacement_m: f64,
    /// Plucking point as a fraction of the length from the bridge, 0 < p < 1.
    pub position: f64,
}

impl PluckSpec {
    /// Initial displacement of mode n, m.
    pub fn modal_displacement_m(&self, mode_number: usize) -> f64 {
        let (n, beta) = (mode_number as f64, self.position);
        2.0 * self.displacement_m * (n * PI * beta).sin() / (n * n * PI * PI * beta * (1.0 - beta))
    }
}

/// A plucking point's tables, and whether the string was just let go there.
#[derive(Clone, PartialEq)]
pub struct PluckRig {
    position: f64,
    /// Observes the string at the plucking point (it drives nothing: a pluck is an
    /// initial displacement).
    drive: DriveTable,
    plucked: bool,
}

impl PluckRig {
    /// The tables for plucking `string` (stepped by `bank`) at `position`. Allocates.
    pub fn new(string: &StringModes, bank: &ModalBank, audio: &StepTable, position: f64) -> Self {
        let shape: Vec<f64> = string.modes.iter().map(|m| string.shape_at(m, position)).collect();
        let drive = drive_table(bank, audio, Hold::Linear, |_| 0.0, |i| shape[i]);
        Self { position, drive, plucked: false }
    }

    /// The same tables for plucking at `position` instead, in place.
    /// Allocates: no.
    pub fn move_to(&mut self, string: &StringModes, bank: &ModalBank, audio: &StepTable, position: f64) {
        if position != self.position {
            let modes = string.modes.len();
            let shape = |i: usize| string.shape_at(&string.modes[i], position);
            self.drive.refill(audio, Hold::Linear, bank.weights(), modes, |_| 0.0, shape);
            self.position = position;
        }
    }

    /// The plucking point, as a fraction of the length from the bridge.
    pub fn position(&self) -> f64 {
        self.position
    }

    pub fn in_play(&self) -> bool {
        self.plucked
    }

    /// Pull the string aside into a triangle and let go: every mode of `string`
    /// takes its share (added to its present state). Allocates: no.
    pub fn pluck(&mut self, bank: &mut ModalBank, string: &StringModes, spec: PluckSpec) {
        debug_assert_eq!(spec.position, self.position);
        for (i, mode) in string.modes.iter().enumerate() {
            bank.add_displacement(i, spec.modal_displacement_m(mode.number));
        }
        self.plucked = true;
    }

    /// The plectrum has gone: nothing more to observe.
    pub fn release(&mut self) {
        self.plucked = false;
    }

    /// The present state without stepping, while just plucked.
    pub fn current(&self, bank: &ModalBank) -> Option<Tick> {
        self.plucked.then(|| Tick {
            contact_force_n: 0.0,
            bridge_force_n: bank.bridge_force_n(),
            exciter_position_m: None,
            string_position_m: bank.observe(&self.drive),
        })
    }

    /// Advance one sample watching the plucking point; None (nothing done) when
    /// not just plucked. Allocates: no.
    pub fn tick(&mut self, bank: &mut ModalBank, audio: &StepTable) -> Option<Tick> {
        if !self.plucked {
            return None;
        }
        let (y, bridge) = bank.step_driven(audio, &self.drive, 0.0);
        Some(Tick { contact_force_n: 0.0, bridge_force_n: bridge, exciter_position_m: None, string_position_m: y })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_sum_back_to_the_triangle() {
        let p = PluckSpec { displacement_m: 0.002, position: 1.0 / 7.8 };
        for &x in &[0.05, p.position, 0.5, 0.9] {
            let y: f64 = (1..200_000).map(|n| p.modal_displacement_m(n) * (n as f64 * PI * x).sin()).sum();
            let triangle =
                if x <= p.position { 0.002 * x / p.position } else { 0.002 * (1.0 - x) / (1.0 - p.position) };
            assert!((y - triangle).abs() < 1e-8, "{x}: {y} vs {triangle}");
        }
    }
}
