//! What one step does to each mode, worked out once per string and step size:
//! the exact free step ([`StepTable`]: each mode's pole and its inverse) and how
//! an exciter's input enters the modes and what it observes of them
//! ([`DriveTable`], held linearly or at its end over the step).

use num_complex::Complex64;

use super::padded;
use crate::string::StringModes;

/// phi1(x) = (e^x - 1) / x and phi2(x) = (e^x - 1 - x) / x^2, accurate for small |x|
/// where the direct formulas cancel.
fn phi12(x: Complex64) -> (Complex64, Complex64) {
    if x.norm() < 0.5 {
        // Taylor series: phi1 = sum x^j / (j+1)!, phi2 = sum x^j / (j+2)!; 24 terms
        // leave a remainder below 0.5^24 / 26! ~ 1e-34.
        let mut phi1 = Complex64::new(0.0, 0.0);
        let mut phi2 = Complex64::new(0.0, 0.0);
        let mut term = Complex64::new(1.0, 0.0); // x^j / j!
        let mut j = 0.0;
        for _ in 0..24 {
            phi1 += term / (j + 1.0);
            phi2 += term / ((j + 1.0) * (j + 2.0));
            j += 1.0;
            term = term * x / j;
        }
        (phi1, phi2)
    } else {
        let ex = x.exp();
        ((ex - 1.0) / x, (ex - 1.0 - x) / (x * x))
    }
}

/// The exact one-step response of every mode for a step of `step_s` seconds.
#[derive(Clone, Debug)]
pub struct StepTable {
    pub step_s: f64,
    pub(super) pole_re: Vec<f64>,
    pub(super) pole_im: Vec<f64>,
    /// Each pole's inverse 1/p and the inverse of its imaginary part: how a
    /// gathering turns a phasor into two samples and back ([`FreeGather`](super::FreeGather)).
    pub(super) back_re: Vec<f64>,
    pub(super) back_im: Vec<f64>,
    pub(super) back_inv: Vec<f64>,
    /// Response of the unscaled state z to a unit modal acceleration at the start
    /// of the step falling linearly to zero at its end.
    start: Vec<Complex64>,
    /// Response to a unit modal acceleration rising linearly from zero to its end.
    end: Vec<Complex64>,
}

/// A [`StepTable`]'s poles and their inverses, saved to be put back.
#[derive(Clone, Debug, PartialEq)]
pub struct SavedPoles([Vec<f64>; 5]);

impl StepTable {
    pub fn new(string: &StringModes, step_s: f64) -> Self {
        let n = padded(string.mode_count());
        let mut table = Self {
            step_s,
            pole_re: vec![1.0; n],
            pole_im: vec![0.0; n],
            back_re: vec![1.0; n],
            back_im: vec![0.0; n],
            back_inv: vec![0.0; n],
            start: vec![Complex64::new(0.0, 0.0); n],
            end: vec![Complex64::new(0.0, 0.0); n],
        };
        for (i, mode) in string.modes.iter().enumerate() {
            let sigma = mode.decay_rate_s();
            let omega_d = mode.damped_omega_rad_s();
            let lambda = Complex64::new(-sigma, omega_d);
            let x = lambda * step_s;
            let radius = (-sigma * step_s).exp();
            let (sin, cos) = (omega_d * step_s).sin_cos();
            table.pole_re[i] = radius * cos;
            table.pole_im[i] = radius * sin;
            (table.back_re[i], table.back_im[i], table.back_inv[i]) = inverse(table.pole_re[i], table.pole_im[i]);
            let (phi1, phi2) = phi12(x);
            let to_state = Complex64::new(0.0, -1.0 / omega_d);
            table.start[i] = to_state * step_s * (phi1 - phi2);
            table.end[i] = to_state * step_s * phi2;
        }
        table
    }

    pub fn pole(&self, index: usize) -> Complex64 {
        Complex64::new(self.pole_re[index], self.pole_im[index])
    }

    /// A copy of its poles (and their inverses), to be put back with
    /// [`Self::restore_poles`]. Allocates.
    pub fn save_poles(&self) -> SavedPoles {
        SavedPoles([&self.pole_re, &self.pole_im, &self.back_re, &self.back_im, &self.back_inv].map(|v| v.clone()))
    }

    /// Copy its poles into `saved` (from this table). Allocates: no.
    pub fn save_poles_into(&self, saved: &mut SavedPoles) {
        for (to, from) in
            saved.0.iter_mut().zip([&self.pole_re, &self.pole_im, &self.back_re, &self.back_im, &self.back_inv])
        {
            to.copy_from_slice(from);
        }
    }

    /// Put back poles saved from this table. Allocates: no.
    pub fn restore_poles(&mut self, saved: &SavedPoles) {
        for (to, from) in
            [&mut self.pole_re, &mut self.pole_im, &mut self.back_re, &mut self.back_im, &mut self.back_inv]
                .into_iter()
                .zip(&saved.0)
        {
            to.copy_from_slice(from);
        }
    }

    /// Every mode's [`Self::back`] but the pole's inverse's imaginary part:
    /// its real part and the inverse of its imaginary part.
    pub fn backs(&self) -> (&[f64], &[f64]) {
        (&self.back_re, &self.back_inv)
    }

    /// Mode `index`'s pole's inverse and the inverse of its imaginary part ([`inverse`]).
    pub fn back(&self, index: usize) -> (f64, f64, f64) {
        (self.back_re[index], self.back_im[index], self.back_inv[index])
    }

    /// Replace mode `index`'s pole by exp((-sigma + i omega) h): how a damper or a
    /// pitch bend changes the free step. Only the free step uses the pole alone;
    /// drive tables built from this table keep the coefficients they were built with.
    ///
    /// Allocates: no.
    pub fn set_pole(&mut self, index: usize, decay_rate_s: f64, omega_rad_s: f64) {
        let radius = (-decay_rate_s * self.step_s).exp();
        let (sin, cos) = (omega_rad_s * self.step_s).sin_cos();
        self.pole_re[index] = radius * cos;
        self.pole_im[index] = radius * sin;
        (self.back_re[index], self.back_im[index], self.back_inv[index]) =
            inverse(self.pole_re[index], self.pole_im[index]);
    }
}

/// A pole p's inverse 1/p (re, im) and 1 / Im(1/p), as a [`FreeGather`](super::FreeGather) needs
/// them. A real pole (a padding lane's, or a product of nothing) has no
/// imaginary part to recover: 0 there, and its phasor comes back real.
pub(crate) fn inverse(pole_re: f64, pole_im: f64) -> (f64, f64, f64) {
    let norm = pole_re * pole_re + pole_im * pole_im;
    if norm == 0.0 {
        return (0.0, 0.0, 0.0);
    }
    let (re, im) = (pole_re / norm, -pole_im / norm);
    (re, im, if im == 0.0 { 0.0 } else { 1.0 / im })
}

/// How an exciter's input is held over a step.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Hold {
    /// Linear from the previous step's value to this step's (second order;
    /// exact for a smooth prescribed input such as the tangent's).
    Linear,
    /// This step's value throughout the step (first order; for an implicitly
    /// solved contact force, whose high-frequency loop it damps).
    End,
}

/// How one exciter acts on the modes and what it observes, for one step size.
///
/// The exciter supplies a scalar u (a contact force, or a tangent's acceleration);
/// mode n receives the modal acceleration `gain_n u`. It observes the scalar
/// sum_n `observe_n` q_n (the string's displacement at the contact point, or the
/// force at the tangent). Built once per string, exciter position and step size.
#[derive(Clone, Debug, PartialEq)]
pub struct DriveTable {
    /// Coefficient of the previous step's input in the one-pass update: p b1 + b0.
    pub(super) carry_re: Vec<f64>,
    pub(super) carry_im: Vec<f64>,
    /// Response of the scaled state to this step's input (the ramp), b1.
    pub(super) ramp_re: Vec<f64>,
    pub(super) ramp_im: Vec<f64>,
    /// Observation weights on the scaled state: observe_n / w_n.
    pub(super) observe: Vec<f64>,
    /// How much the observation moves within a step per unit of this step's input.
    pub observe_per_input: f64,
    /// How much the bridge force moves within a step per unit of this step's input.
    pub bridge_per_input: f64,
}

impl DriveTable {
    /// `gain[n]` and `observe[n]` are per mode (unscaled); `weight[n]` is the bridge
    /// weight of the bank the table will drive.
    pub fn new(step: &StepTable, hold: Hold, weight: &[f64], gain: &[f64], observe: &[f64]) -> Self {
        let n = step.pole_re.len();
        let mut table = Self {
            carry_re: vec![0.0; n],
            carry_im: vec![0.0; n],
            ramp_re: vec![0.0; n],
            ramp_im: vec![0.0; n],
            observe: vec![0.0; n],
            observe_per_input: 0.0,
            bridge_per_input: 0.0,
        };
        table.refill(step, hold, weight, gain.len(), |i| gain[i], |i| observe[i]);
        table
    }

    /// The same table for other gains and observations (of the first `modes`
    /// modes; the rest stay at rest), in place. Allocates: no.
    // One index runs over the step's, the weights' and the table's seven arrays.
    #[allow(clippy::needless_range_loop)]
    pub fn refill(
        &mut self,
        step: &StepTable,
        hold: Hold,
        weight: &[f64],
        modes: usize,
        gain: impl Fn(usize) -> f64,
        observe: impl Fn(usize) -> f64,
    ) {
        self.observe_per_input = 0.0;
        self.bridge_per_input = 0.0;
        for i in 0..modes.min(self.observe.len()) {
            let (start, end) = match hold {
                Hold::Linear => (step.start[i], step.end[i]),
                Hold::End => (Complex64::new(0.0, 0.0), step.start[i] + step.end[i]),
            };
            let b0 = start * (weight[i] * gain(i));
            let b1 = end * (weight[i] * gain(i));
            let carry = step.pole(i) * b1 + b0;
            self.carry_re[i] = carry.re;
            self.carry_im[i] = carry.im;
            self.ramp_re[i] = b1.re;
            self.ramp_im[i] = b1.im;
            self.observe[i] = observe(i) / weight[i];
            self.observe_per_input += self.observe[i] * b1.re;
            self.bridge_per_input += b1.re;
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    #[test]
    fn phi_functions_agree_across_the_series_switch() {
        for &x in &[Complex64::new(-0.1, 0.49), Complex64::new(0.3, -0.39), Complex64::new(-0.49, 0.01)] {
            let (a1, a2) = phi12(x);
            let ex = x.exp();
            let (b1, b2) = ((ex - 1.0) / x, (ex - 1.0 - x) / (x * x));
            assert!((a1 - b1).norm() < 1e-14 && (a2 - b2).norm() < 1e-14);
        }
        // Where the direct formulas cancel, the series still gives 1 + x/2 and 1/2 + x/6.
        let x = 1e-9;
        let (p1, p2) = phi12(Complex64::new(x, 0.0));
        assert!((p1.re - (1.0 + x / 2.0)).abs() < 1e-16 && (p2.re - (0.5 + x / 6.0)).abs() < 1e-16);
    }
}
