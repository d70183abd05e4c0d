//! The clavichord tangent: a brass blade that strikes the string and stays,
//! becoming one end of the vibrating length (Euphonics 12.2.3).
//!
//! Following Thwaites & Fletcher (1981), the tangent's speed falls exponentially
//! from V0 so that it comes to rest a distance D from where it met the string:
//!
//!   z(t) = D (1 - exp(-t V0 / D)),  z'(t) = V0 exp(-t V0 / D).
//!
//! The end x = L follows z(t). Writing y = z x / L + w, with w pinned at both
//! ends, the modes of w are driven by the distributed load -mu z'' x / L: a modal
//! acceleration 2 (-1)^n z'' / (n pi). The jump of the tangent's speed from 0 to V0
//! at t = 0 starts each mode with the velocity 2 (-1)^n V0 / (n pi). The straight
//! line z x / L adds T z / L to the force at both ends.
//!
//! Holding the string's end at W stretches the string on both sides of the
//! tangent: the speaking length L2 (to the bridge) and the damped length L1
//! (through the listing felt to the hitch pin). Each becomes longer by about
//! W^2 / (2 L), and as the string slides over the tangent the tension evens out
//! over L1 + L2:
//!
//!   dT / T = E A (1 / (2 L1) + 1 / (2 L2)) W^2 / ((L1 + L2) T),
//!
//! which raises the pitch by the factor sqrt(1 + dT / T): quadratic in W, a few
//! cents at W = 2 mm (Euphonics 12.2.3; the seed's Fig. 29, after Thwaites &
//! Fletcher 1981).

use std::f64::consts::PI;

use crate::exciter::{Tick, drive_table};
use crate::modal_bank::{DriveTable, Hold, ModalBank, StepTable};
use crate::string::{StringModes, residual};

/// How the tangent is played.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentSpec {
    /// V0, the tangent's speed when it meets the string, m/s.
    pub speed_m_s: f64,
    /// D, how far it finally lifts the string's end, m.
    pub displacement_m: f64,
}

impl TangentSpec {
    /// The time constant D / V0 of the tangent's approach, s.
    pub fn time_constant_s(&self) -> f64 {
        self.displacement_m / self.speed_m_s
    }

    /// The stroke from rest: from 0 toward D with time constant D / V0.
    pub fn motion(&self) -> TangentMotion {
        TangentMotion { from_m: 0.0, to_m: self.displacement_m, time_constant_s: self.time_constant_s() }
    }

    /// z(t), m.
    pub fn position_m(&self, t_s: f64) -> f64 {
        let motion = self.motion();
        motion.position_m(motion.remaining(t_s))
    }

    /// Modal acceleration of mode n per unit z'' (and modal velocity per unit jump in z').
    pub fn modal_gain(mode_number: usize) -> f64 {
        let sign = if mode_number.is_multiple_of(2) { 1.0 } else { -1.0 };
        2.0 * sign / (mode_number as f64 * PI)
    }
}

/// The tangent's motion law: from `from_m` toward `to_m`, slowing exponentially
/// with time constant tau (Thwaites & Fletcher 1981). With r = exp(-t / tau) the
/// share of the way still to go,
///
///   z = to + (from - to) r,  z' = -(from - to) r / tau,  z'' = (from - to) r / tau^2.
///
/// A press (from the string's end where it is, toward the tangent's depth) and a
/// lift (back to 0) are both this law; the synth advances r by a constant factor
/// per sample.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentMotion {
    pub from_m: f64,
    pub to_m: f64,
    pub time_constant_s: f64,
}

impl TangentMotion {
    /// r at `t_s` after the motion began.
    pub fn remaining(&self, t_s: f64) -> f64 {
        (-t_s / self.time_constant_s).exp()
    }

    /// z with `remaining` = r of the way still to go, m.
    pub fn position_m(&self, remaining: f64) -> f64 {
        self.to_m + (self.from_m - self.to_m) * remaining
    }

    /// z', m/s.
    pub fn velocity_m_s(&self, remaining: f64) -> f64 {
        -(self.from_m - self.to_m) * remaining / self.time_constant_s
    }

    /// z'' (for t > 0: the jump of z' at t = 0 is an impulse, given to the modes as
    /// velocities), m/s^2.
    pub fn acceleration_m_s2(&self, remaining: f64) -> f64 {
        (self.from_m - self.to_m) * remaining / (self.time_constant_s * self.time_constant_s)
    }
}

/// What a tangent at the string's far end needs.
#[derive(Clone)]
struct TangentTables {
    /// [`TangentSpec::modal_gain`] of every mode.
    gains: Vec<f64>,
    drive: DriveTable,
    /// Omitted modes' static share of the force at the tangent and at the bridge, per unit z''.
    residual_tangent_kg: f64,
    residual_bridge_kg: f64,
}

/// A tangent on the string: its motion and how far along it is.
#[derive(Clone, Copy)]
pub struct TangentState {
    motion: TangentMotion,
    /// r now, advanced by `decay_per_sample` each sample (zero once negligible).
    remaining: f64,
    decay_per_sample: f64,
    /// z'' held at the end of the last step (carried into the next pass), m/s^2.
    acceleration_m_s2: f64,
}

impl TangentState {
    fn position_m(&self) -> f64 {
        self.motion.position_m(self.remaining)
    }
}

/// A tangent's tables at the string's far end, and its state while it is on the string.
#[derive(Clone)]
pub struct TangentRig {
    tables: TangentTables,
    state: Option<TangentState>,
}

impl TangentRig {
    /// The tables for a tangent at the far end of `string` (stepped by `bank`). Allocates.
    pub fn new(string: &StringModes, bank: &ModalBank, audio: &StepTable) -> Self {
        let gains: Vec<f64> = string.modes.iter().map(|m| TangentSpec::modal_gain(m.number)).collect();
        let weights = bank.weights().to_vec();
        let sign = |i: usize| if string.modes[i].number.is_multiple_of(2) { 1.0 } else { -1.0 };
        let drive = drive_table(bank, audio, Hold::Linear, |i| gains[i], |i| sign(i) * weights[i]);
        let (residual_tangent_kg, residual_bridge_kg) = residual::omitted_tangent_shares_kg(string);
        Self { tables: TangentTables { gains, drive, residual_tangent_kg, residual_bridge_kg }, state: None }
    }

    /// Whether the tangent is on the string.
    pub fn in_play(&self) -> bool {
        self.state.is_some()
    }

    /// Whether nothing but free decay lies ahead: off the string, or at rest on it.
    pub fn is_settled(&self) -> bool {
        self.state.is_none_or(|s| s.remaining == 0.0)
    }

    /// Where the tangent holds the string's end now, m (0 off the string).
    pub fn position_m(&self) -> f64 {
        self.state.map_or(0.0, |s| s.position_m())
    }

    /// The tangent's state, while it is on the string.
    pub fn state(&self) -> Option<TangentState> {
        self.state
    }

    /// Where a tangent at rest holds the end, m (None while it moves or is off).
    pub fn resting_at_m(&self) -> Option<f64> {
        self.state.filter(|s| s.remaining == 0.0).map(|s| s.motion.to_m)
    }

    /// Drop the tangent where it is: the bank gets back its "input applied" form.
    /// Allocates: no.
    pub fn release(&mut self, bank: &mut ModalBank) {
        if let Some(state) = self.state.take() {
            bank.apply_ramp(&self.tables.drive, state.acceleration_m_s2);
        }
    }

    /// Forget the tangent without touching the modes (they were reset or replaced).
    pub fn forget(&mut self) {
        self.state = None;
    }

    /// Move the string's end along `motion` from now on (its velocity was
    /// `old_velocity_m_s`; the modes, measured from the straight line through the
    /// moving end, take the opposite jump), stepped at `step_s`. The tangent must
    /// have been released. Allocates: no.
    pub fn start(&mut self, bank: &mut ModalBank, motion: TangentMotion, old_velocity_m_s: f64, step_s: f64) {
        debug_assert!(self.state.is_none(), "a tangent in play is released before it moves anew");
        let mut state = TangentState {
            motion,
            remaining: 1.0,
            decay_per_sample: (-step_s / motion.time_constant_s).exp(),
            acceleration_m_s2: 0.0,
        };
        let jump = motion.velocity_m_s(state.remaining) - old_velocity_m_s;
        for (i, g) in self.tables.gains.iter().enumerate() {
            bank.add_velocity(i, g * jump);
        }
        state.acceleration_m_s2 = motion.acceleration_m_s2(state.remaining);
        bank.apply_ramp(&self.tables.drive, -state.acceleration_m_s2);
        self.state = Some(state);
    }

    /// Carry on `state` (a tangent of a string this one replaces, whose modes were
    /// copied), stepped at `step_s`. Allocates: no.
    pub fn take_over(&mut self, bank: &mut ModalBank, mut state: TangentState, step_s: f64) {
        state.decay_per_sample = (-step_s / state.motion.time_constant_s).exp();
        bank.apply_ramp(&self.tables.drive, -state.acceleration_m_s2);
        self.state = Some(state);
    }

    /// The present state without stepping (the tangent on the string of `string`).
    pub fn current(&self, bank: &ModalBank, string: &StringModes) -> Option<Tick> {
        let d = self.state.as_ref()?;
        let t = &self.tables;
        let a = d.acceleration_m_s2;
        let z = d.position_m();
        let line = string.tension_n * z / string.length_m;
        Some(Tick {
            contact_force_n: bank.observe(&t.drive) + (t.drive.observe_per_input + t.residual_tangent_kg) * a + line,
            bridge_force_n: bank.bridge_force_n() + (t.drive.bridge_per_input + t.residual_bridge_kg) * a + line,
            exciter_position_m: Some(z),
            string_position_m: z,
        })
    }

    /// Advance one sample with the tangent on the string; None (nothing done) when
    /// it is off. Allocates: no.
    pub fn tick(&mut self, bank: &mut ModalBank, audio: &StepTable, string: &StringModes) -> Option<Tick> {
        let t = &self.tables;
        let d = self.state.as_mut()?;
        let (end_hat, bridge_hat) = bank.step_driven(audio, &t.drive, d.acceleration_m_s2);
        // Below 1e-17 the tangent has arrived: stop before denormals.
        d.remaining = if d.remaining > 1e-17 { d.remaining * d.decay_per_sample } else { 0.0 };
        let a = d.motion.acceleration_m_s2(d.remaining);
        d.acceleration_m_s2 = a;
        let z = d.position_m();
        let line = string.tension_n * z / string.length_m;
        Some(Tick {
            contact_force_n: end_hat + (t.drive.observe_per_input + t.residual_tangent_kg) * a + line,
            bridge_force_n: bridge_hat + (t.drive.bridge_per_input + t.residual_bridge_kg) * a + line,
            exciter_position_m: Some(z),
            string_position_m: z,
        })
    }

    /// The tangent's velocity now, m/s (0 off the string).
    pub fn velocity_m_s(&self) -> f64 {
        self.state.map_or(0.0, |s| s.motion.velocity_m_s(s.remaining))
    }
}

/// The tension's rise per square metre of tangent displacement, 1/m^2: the
/// tension becomes T (1 + s W^2) when the tangent holds the end at W. For a wire
/// of Young's modulus `modulus_pa` and cross-section `area_m2` at `tension_n`,
/// speaking over `speaking_length_m` and damped over `damped_length_m`.
pub fn stretch_per_m2(
    modulus_pa: f64,
    area_m2: f64,
    tension_n: f64,
    speaking_length_m: f64,
    damped_length_m: f64,
) -> f64 {
    let (l1, l2) = (damped_length_m, speaking_length_m);
    modulus_pa * area_m2 * (0.5 / l1 + 0.5 / l2) / ((l1 + l2) * tension_n)
}

/// The factor a press of `displacement_m` raises the pitch by, sqrt(1 + s W^2),
/// for a string whose tension rises by `stretch_per_m2` (bending stiffness, which
/// does not change with the tension, is left out: it moves the first partial by
/// well under 0.01 of this).
pub fn stretched_pitch_ratio(stretch_per_m2: f64, displacement_m: f64) -> f64 {
    (1.0 + stretch_per_m2 * displacement_m * displacement_m).sqrt()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_comes_to_rest_at_d() {
        // Euphonics 12.2.3: W(inf) = V0 / alpha = D, whatever the speed.
        for &v0 in &[0.05, 0.5, 2.0] {
            let t = TangentSpec { speed_m_s: v0, displacement_m: 0.002 };
            assert!((t.position_m(40.0 * t.time_constant_s()) - 0.002).abs() < 1e-15);
            // z' = V0 e^(-t/tau): a numerical derivative agrees.
            let (a, b) = (t.position_m(1e-3), t.position_m(1e-3 + 1e-9));
            assert!(((b - a) / 1e-9 / (v0 * (-1e-3 / t.time_constant_s()).exp()) - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn modal_gain_projects_the_straight_line() {
        // 2/L * integral of (x/L) sin(n pi x / L) = 2 (-1)^(n+1) / (n pi); the load is -z'' times it.
        for n in 1..6 {
            let steps = 200_000;
            let integral: f64 = (0..steps)
                .map(|i| {
                    let x = (i as f64 + 0.5) / steps as f64;
                    x * (n as f64 * PI * x).sin() / steps as f64
                })
                .sum();
            assert!((-2.0 * integral - TangentSpec::modal_gain(n)).abs() < 1e-9);
        }
    }

    fn cents(ratio: f64) -> f64 {
        1200.0 * ratio.log2()
    }

    /// Brass (E = 100 GPa, rho = 8500 kg/m^3) of `diameter_m` sounding `f_hz` over
    /// `speaking_m`, damped over `damped_m`: the rise in cents at `w_m`.
    fn brass_rise_cents(diameter_m: f64, f_hz: f64, speaking_m: f64, damped_m: f64, w_m: f64) -> f64 {
        let area = PI * diameter_m * diameter_m / 4.0;
        let tension = 4.0 * speaking_m * speaking_m * 8500.0 * area * f_hz * f_hz;
        cents(stretched_pitch_ratio(stretch_per_m2(1.0e11, area, tension, speaking_m, damped_m), w_m))
    }

    #[test]
    fn stretching_reproduces_the_worked_examples() {
        // Physics reference 1.6: 0.35 mm brass, L2 = 0.40 m, L1 = 0.10 m, 330 Hz
        // (working stress 590 MPa): 1.8 cents at 1 mm, 7.3 cents at 2 mm.
        let rise = |w| brass_rise_cents(0.35e-3, 330.0, 0.40, 0.10, w);
        assert!((rise(1e-3) - 1.8).abs() < 0.05, "{}", rise(1e-3));
        assert!((rise(2e-3) - 7.3).abs() < 0.05, "{}", rise(2e-3));
        // 0.30 mm, L2 = 0.30 m, 440 Hz (the same L1): 2.4 and 9.7 cents.
        let rise = |w| brass_rise_cents(0.30e-3, 440.0, 0.30, 0.10, w);
        assert!((rise(1e-3) - 2.4).abs() < 0.05, "{}", rise(1e-3));
        assert!((rise(2e-3) - 9.7).abs() < 0.05, "{}", rise(2e-3));
    }

    #[test]
    fn the_rise_is_quadratic_in_the_displacement_and_set_by_the_stress() {
        let s = stretch_per_m2(1.0e11, 1.0e-7, 50.0, 0.5, 0.3);
        for w in [0.25e-3, 0.5e-3, 1e-3] {
            let (one, two) = (stretched_pitch_ratio(s, w) - 1.0, stretched_pitch_ratio(s, 2.0 * w) - 1.0);
            // sqrt(1 + x) - 1 = x / 2 - x^2 / 8 ...: the ratio is 4 to within the square term.
            assert!((two / one - 4.0).abs() < 4.0 * 2.0 * s * w * w, "{w}: {}", two / one);
        }
        // Only the stress T / A matters: twice the area at twice the tension is the same string.
        assert!((stretch_per_m2(1.0e11, 2.0e-7, 100.0, 0.5, 0.3) / s - 1.0).abs() < 1e-12);
        assert_eq!(stretched_pitch_ratio(s, 0.0), 1.0);
    }
}
