//! The modal bank: a string's modes as damped oscillators, stepped exactly.
//!
//! Each mode obeys q'' + 2 sigma q' + omega^2 q = u(t), where u is the modal
//! acceleration an exciter applies (phi_n(x_e) F / m_n for a point force). Its
//! free motion is q = Re(z), q' = Re(lambda z) with lambda = -sigma + i omega_d, and
//! z advances over a step h by the exact factor p = exp(lambda h): no frequency
//! warping and no numerical damping at any sample rate.
//!
//! The input is held linearly over a step (first-order hold) and integrated
//! exactly: with x = lambda h, phi1(x) = (e^x - 1) / x and phi2(x) = (e^x - 1 - x) / x^2,
//!
//!   z(h) = p z(0) + (-i / omega_d) h [ (phi1 - phi2) u(0) + phi2 u(h) ].
//!
//! The state is stored scaled by each mode's bridge weight w_n = T k_n + EI k_n^3,
//! zeta_n = w_n z_n, so that the bridge force is simply sum_n Re(zeta_n): the free
//! step is one complex multiply and one add per mode and sample.
//!
//! # Number format
//!
//! Everything here is f64. A C1 mode with Q = 2000 at 192 kHz has a pole radius
//! of 1 - 2.7e-7, and its damped rotation differs from 1 by about 1e-6; f32 has
//! a spacing of 6e-8 just below 1, so it would hold the decay rate to no better
//! than about 20 % and the pitch of the lowest partials to several cents. In f64
//! the same quantities are exact to about 1e-10.
//!
//! # Layout
//!
//! Structure of arrays, a string's modes contiguous and padded to a multiple of
//! [`LANES`] with silent modes (pole 1, state 0). The free loop runs a block of
//! samples per group of `LANES` modes with the state held in registers, adding each
//! lane's output into a small accumulator that is summed once per sample. The
//! driven loop (an exciter in play) runs one step over all modes, folding the
//! input, the observation at the exciter and the bridge sum into the same pass.
//! Both add in the same order, so a string with an idle exciter gives the same
//! bits as a free one.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use multiversion::multiversion;
use num_complex::Complex64;

use crate::string::StringModes;

#[cfg(target_arch = "x86_64")]
mod x86;

/// Modes per group in the inner loops (one AVX-512 register, two AVX2 registers of f64).
pub const LANES: usize = 8;

/// Samples per pass of the free loop; the accumulator for one pass stays in L1.
pub const FREE_BLOCK: usize = 64;

fn padded(len: usize) -> usize {
    len.div_ceil(LANES) * LANES
}

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
    pole_re: Vec<f64>,
    pole_im: Vec<f64>,
    /// Each pole's inverse 1/p and the inverse of its imaginary part: how a
    /// gathering turns a phasor into two samples and back ([`FreeGather`]).
    back_re: Vec<f64>,
    back_im: Vec<f64>,
    back_inv: Vec<f64>,
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

/// A pole p's inverse 1/p (re, im) and 1 / Im(1/p), as a [`FreeGather`] needs
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
    carry_re: Vec<f64>,
    carry_im: Vec<f64>,
    /// Response of the scaled state to this step's input (the ramp), b1.
    ramp_re: Vec<f64>,
    ramp_im: Vec<f64>,
    /// Observation weights on the scaled state: observe_n / w_n.
    observe: Vec<f64>,
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

/// The state of a string's modes.
#[derive(Clone, Debug)]
pub struct ModalBank {
    len: usize,
    re: Vec<f64>,
    im: Vec<f64>,
    /// Bridge weight w_n = T k_n + EI k_n^3 (1 for padding).
    weight: Vec<f64>,
    lambda: Vec<Complex64>,
    omega: Vec<f64>,
    modal_mass_kg: f64,
    scratch: Vec<[f64; LANES]>,
    /// Modes the free loop runs (a multiple of [`LANES`]): every mode above is at
    /// rest, left there by [`Self::cull`]. Anything that moves the modes otherwise
    /// sets it back to all of them.
    running: usize,
}

impl ModalBank {
    /// A bank at rest for `string`. Allocates.
    pub fn new(string: &StringModes) -> Self {
        let n = padded(string.mode_count());
        let mut weight = vec![1.0; n];
        let mut lambda = vec![Complex64::new(0.0, 1.0); n];
        let mut omega = vec![0.0; n];
        for (i, mode) in string.modes.iter().enumerate() {
            weight[i] = string.bridge_weight(mode);
            lambda[i] = Complex64::new(-mode.decay_rate_s(), mode.damped_omega_rad_s());
            omega[i] = mode.omega_rad_s;
        }
        Self {
            len: string.mode_count(),
            re: vec![0.0; n],
            im: vec![0.0; n],
            weight,
            lambda,
            omega,
            modal_mass_kg: string.modal_mass_kg(),
            scratch: vec![[0.0; LANES]; FREE_BLOCK],
            running: 0,
        }
    }

    /// Number of modes (without padding).
    pub fn len(&self) -> usize {
        self.len
    }

    /// Modes the free loop computes now (culled modes at the top left out; padded).
    pub fn running(&self) -> usize {
        self.running
    }

    fn run_all(&mut self) {
        self.running = self.re.len();
    }

    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// Bridge weights of the modes (padded), for building [`DriveTable`]s.
    pub fn weights(&self) -> &[f64] {
        &self.weight[..self.len]
    }

    /// Every mode to rest.
    pub fn clear(&mut self) {
        self.re.fill(0.0);
        self.im.fill(0.0);
        self.running = 0;
    }

    fn state(&self, i: usize) -> Complex64 {
        Complex64::new(self.re[i], self.im[i]) / self.weight[i]
    }

    fn set_state(&mut self, i: usize, z: Complex64) {
        self.run_all();
        let zeta = z * self.weight[i];
        self.re[i] = zeta.re;
        self.im[i] = zeta.im;
    }

    /// Mode `i`'s share of the bridge force as a phasor: the force is its real
    /// part, and it turns by the mode's pole each step.
    pub fn phasor(&self, i: usize) -> Complex64 {
        Complex64::new(self.re[i], self.im[i])
    }

    /// Add the phasors of the first `sums.len()` modes to `sums`, one each.
    #[inline]
    pub fn add_phasors(&self, sums: &mut [Complex64]) {
        let n = sums.len();
        for ((sum, &re), &im) in sums.iter_mut().zip(&self.re[..n]).zip(&self.im[..n]) {
            sum.re += re;
            sum.im += im;
        }
    }

    /// Set mode `i`'s phasor (see [`Self::phasor`]), computing it from now on
    /// if it was culled. Allocates: no.
    pub fn set_phasor(&mut self, i: usize, zeta: Complex64) {
        self.running = self.running.max((i + 1).next_multiple_of(LANES)).min(self.re.len());
        self.re[i] = zeta.re;
        self.im[i] = zeta.im;
    }

    /// Displacement q_n of mode `i` (index from 0), m.
    pub fn displacement(&self, i: usize) -> f64 {
        self.state(i).re
    }

    /// Velocity q_n' of mode `i`, m/s.
    pub fn velocity(&self, i: usize) -> f64 {
        (self.lambda[i] * self.state(i)).re
    }

    /// Add to the displacement of mode `i`, keeping its velocity.
    pub fn add_displacement(&mut self, i: usize, dq: f64) {
        // z = q - i (q' + sigma q) / omega_d, from q = Re z and q' = Re(lambda z).
        let lambda = self.lambda[i];
        let dz = Complex64::new(dq, lambda.re * dq / lambda.im);
        self.set_state(i, self.state(i) + dz);
    }

    /// Add `dq` to the displacement and `dv` to the velocity of mode `i`,
    /// computing it from now on if it was culled (the others stay culled).
    /// Allocates: no.
    pub fn nudge(&mut self, i: usize, dq: f64, dv: f64) {
        let lambda = self.lambda[i];
        let dz = Complex64::new(dq, (lambda.re * dq - dv) / lambda.im) * self.weight[i];
        self.running = self.running.max((i + 1).next_multiple_of(LANES)).min(self.re.len());
        self.re[i] += dz.re;
        self.im[i] += dz.im;
    }

    /// Add to the velocity of mode `i`, keeping its displacement.
    pub fn add_velocity(&mut self, i: usize, dv: f64) {
        let dz = Complex64::new(0.0, -dv / self.lambda[i].im);
        self.set_state(i, self.state(i) + dz);
    }

    /// Factors for [`Self::kick`]: mode `i` gains `gains[i]` times the kick's
    /// velocity. Allocates.
    pub fn kick_table(&self, gains: &[f64]) -> Vec<f64> {
        (0..self.len).map(|i| -gains[i] * self.weight[i] / self.lambda[i].im).collect()
    }

    /// Add `gains[i] * dv` to the velocity of every mode i at once, keeping the
    /// displacements (`table` from [`Self::kick_table`] for those gains). Allocates: no.
    pub fn kick(&mut self, table: &[f64], dv: f64) {
        self.run_all();
        add_scaled(&mut self.im, table, dv);
    }

    /// Add `input` times the drive's within-step response to the state: moves a
    /// stored state between its "input still to come" and "input applied" forms.
    pub fn apply_ramp(&mut self, drive: &DriveTable, input: f64) {
        self.run_all();
        for i in 0..self.len {
            self.re[i] += drive.ramp_re[i] * input;
            self.im[i] += drive.ramp_im[i] * input;
        }
    }

    /// Take over another bank's motion mode by mode (as many modes as both have),
    /// the rest at rest: how a ringing string survives a rebuild of its tables.
    ///
    /// Allocates: no.
    pub fn copy_motion_from(&mut self, other: &ModalBank) {
        let common = self.len.min(other.len);
        for i in 0..common {
            self.set_state(i, other.state(i));
        }
        self.re[common..].fill(0.0);
        self.im[common..].fill(0.0);
        self.run_all();
    }

    /// An upper bound on the bridge force this bank can ever produce freely from
    /// now on, N: sum_n |zeta_n| (free motion only shrinks each |zeta_n|).
    pub fn amplitude_bound_n(&self) -> f64 {
        let mut acc = [0.0; LANES];
        let (re, _) = self.re.as_chunks::<LANES>();
        let (im, _) = self.im.as_chunks::<LANES>();
        for (r, i) in re.iter().zip(im) {
            for l in 0..LANES {
                acc[l] += r[l].abs() + i[l].abs();
            }
        }
        lane_sum(&acc)
    }

    /// Put to rest every mode whose bridge-force amplitude |zeta_n| is below
    /// `floor_n` (N), and stop computing the modes at rest above the highest one
    /// still ringing. Returns [`Self::amplitude_bound_n`] and the largest |zeta_n|
    /// of the modes kept.
    ///
    /// Culling is how a ringing key sheds the modes that have decayed far below its
    /// loudest (high partials die first): what is dropped is below the floor, and
    /// a mode at rest costs nothing and never becomes subnormal.
    ///
    /// Allocates: no. One pass over the running modes.
    pub fn cull(&mut self, floor_n: f64) -> (f64, f64) {
        let n = self.running;
        let (re, _) = self.re[..n].as_chunks_mut::<LANES>();
        let (im, _) = self.im[..n].as_chunks_mut::<LANES>();
        let mut bound = [0.0; LANES];
        let mut loudest = 0.0f64;
        let mut top = 0;
        for (g, (r, i)) in re.iter_mut().zip(im.iter_mut()).enumerate() {
            let mut kept = false;
            for l in 0..LANES {
                let magnitude = r[l].abs() + i[l].abs();
                if magnitude < floor_n {
                    r[l] = 0.0;
                    i[l] = 0.0;
                } else {
                    bound[l] += magnitude;
                    loudest = loudest.max(magnitude);
                    kept = true;
                }
            }
            if kept {
                top = g + 1;
            }
        }
        self.running = top * LANES;
        (lane_sum(&bound), loudest)
    }

    /// An upper bound on the magnitude of the observation through `drive` (the
    /// string's displacement at an exciter, m) that this bank can ever produce
    /// freely from now on: sum_n |observe_n| |zeta_n|, since free motion only
    /// shrinks each |zeta_n| and the observation is sum_n observe_n Re(zeta_n).
    ///
    /// Allocates: no.
    pub fn observe_bound(&self, drive: &DriveTable) -> f64 {
        let mut acc = [0.0; LANES];
        let (re, _) = self.re.as_chunks::<LANES>();
        let (im, _) = self.im.as_chunks::<LANES>();
        let (c, _) = drive.observe.as_chunks::<LANES>();
        for ((r, i), c) in re.iter().zip(im).zip(c) {
            for l in 0..LANES {
                // (A mode's amplitude is far from overflow, and culled long
                // before its square could underflow: no need for `hypot`,
                // which does not vectorise and cost a chord's control blocks
                // 6 %. Plain products: without FMA in the baseline target,
                // `mul_add` is a call, which would not vectorise either.)
                acc[l] += c[l].abs() * (r[l] * r[l] + i[l] * i[l]).sqrt();
            }
        }
        lane_sum(&acc)
    }

    /// Kinetic plus potential energy of the modes, J.
    pub fn energy_j(&self) -> f64 {
        (0..self.len)
            .map(|i| {
                let (q, v) = (self.displacement(i), self.velocity(i));
                0.5 * self.modal_mass_kg * (v * v + self.omega[i] * self.omega[i] * q * q)
            })
            .sum()
    }

    /// The modes' energy as the sizes of their phasors have it, J: each
    /// 1/2 m omega^2 |zeta / w|^2, its kinetic plus potential energy for a
    /// lightly damped mode, which a free step shrinks at any pitch it is
    /// bent to ([`Self::energy_j`] reads the motion at the mode's own
    /// pitch, and swings as a bent mode turns). For checks.
    pub fn phasor_energy_j(&self) -> f64 {
        (0..self.running.min(self.len))
            .map(|i| 0.5 * self.modal_mass_kg * self.omega[i] * self.omega[i] * self.state(i).norm_sqr())
            .sum()
    }

    /// Energy of the difference between this bank's motion and `other`'s (a bank
    /// for the same string), J.
    pub fn energy_of_difference_j(&self, other: &ModalBank) -> f64 {
        (0..self.len.min(other.len))
            .map(|i| {
                let q = self.displacement(i) - other.displacement(i);
                let v = self.velocity(i) - other.velocity(i);
                0.5 * self.modal_mass_kg * (v * v + self.omega[i] * self.omega[i] * q * q)
            })
            .sum()
    }

    /// Every mode's share of the bridge force from now on, Re(z e^(lambda t)):
    /// its phasor z (N) and its pole lambda (1/s). Allocates: for setting up,
    /// not the audio thread.
    pub fn bridge_partials(&self) -> Vec<(Complex64, Complex64)> {
        (0..self.len).map(|i| (Complex64::new(self.re[i], self.im[i]), self.lambda[i])).collect()
    }

    /// Bridge force of the present state, N.
    pub fn bridge_force_n(&self) -> f64 {
        lane_sum_all(&self.re)
    }

    /// Observe the present state through a drive's observation weights.
    pub fn observe(&self, drive: &DriveTable) -> f64 {
        observe_through(&self.re, &drive.observe)
    }

    /// Advance freely (no exciter) over `out.len()` samples, adding the bridge
    /// force after each step to `out`.
    ///
    /// Allocates: no. Realtime-safe.
    pub fn process_free(&mut self, step: &StepTable, out: &mut [f64]) {
        debug_assert_eq!(step.pole_re.len(), self.re.len());
        for block in out.chunks_mut(FREE_BLOCK) {
            let acc = &mut self.scratch[..block.len()];
            acc.fill([0.0; LANES]);
            let n = self.running;
            free_block(&mut self.re[..n], &mut self.im[..n], &step.pole_re[..n], &step.pole_im[..n], acc);
            for (o, a) in block.iter_mut().zip(acc.iter()) {
                *o += lane_sum(a);
            }
        }
    }

    /// [`Self::kick`] by `table` and `dv`, then [`Self::process_free`] over one
    /// sample, in one pass: that sample's bridge force, to the bit.
    ///
    /// Allocates: no. Realtime-safe.
    pub fn process_free_kicked(&mut self, step: &StepTable, table: &[f64], dv: f64) -> f64 {
        debug_assert_eq!(step.pole_re.len(), self.re.len());
        self.run_all();
        let n = self.running;
        let (re, im) = (&mut self.re[..n], &mut self.im[..n]);
        // (As `process_free` adds it to a zero.)
        0.0 + free_sample_kicked(re, im, (table, dv), &step.pole_re[..n], &step.pole_im[..n])
    }

    /// Advance freely over `acc.len()` samples, adding each sample's bridge force
    /// to `acc` by lane (sum the lanes with [`lane_sum`]): several banks can share
    /// one accumulator and be summed once.
    ///
    /// Allocates: no. Realtime-safe.
    pub fn accumulate_free(&mut self, step: &StepTable, acc: &mut [[f64; LANES]]) {
        debug_assert_eq!(step.pole_re.len(), self.re.len());
        let n = self.running;
        free_block(&mut self.re[..n], &mut self.im[..n], &step.pole_re[..n], &step.pole_im[..n], acc);
    }

    /// Gather its running modes (with `step`'s poles) into `gather` to be
    /// advanced freely there; returns where they lie, or None without room.
    pub fn gather_free(&self, step: &StepTable, gather: &mut FreeGather) -> Option<usize> {
        let n = self.running;
        let poles = Poles {
            re: &step.pole_re[..n],
            im: &step.pole_im[..n],
            back_re: &step.back_re[..n],
            back_im: &step.back_im[..n],
        };
        gather.take(&self.re[..n], &self.im[..n], poles)
    }

    /// Take back its running modes' state from `gather`, where
    /// [`Self::gather_free`] put them with `step`, after the gathering has run.
    pub fn scatter_free(&mut self, step: &StepTable, gather: &FreeGather, at: usize) {
        let n = self.running;
        gather.give_back(at, &mut self.re[..n], &mut self.im[..n], &step.back_re[..n], &step.back_inv[..n]);
    }

    /// One driven step: every mode advances by `step` with the previous step's
    /// input `previous_input` carried through the drive (the current step's input
    /// is added later, by the caller's accounting, through `observe_per_input` and
    /// `bridge_per_input`). Returns (observation, bridge force) of the state
    /// without this step's input.
    ///
    /// Allocates: no. Realtime-safe.
    pub fn step_driven(&mut self, step: &StepTable, drive: &DriveTable, previous_input: f64) -> (f64, f64) {
        // SAFETY: the kernel is the one the machine has.
        unsafe { self.step_driven_by(Kernel::detected(), step, drive, previous_input) }
    }

    /// [`Self::step_driven`] by the kernel `kernel` names, inlined into its
    /// caller: a caller compiled for that kernel's features inlines the
    /// kernel too.
    ///
    /// # Safety
    /// The machine has the features of the kernel named (as
    /// [`Kernel::detected`] finds them).
    #[inline(always)]
    pub(crate) unsafe fn step_driven_by(
        &mut self,
        kernel: Kernel,
        step: &StepTable,
        drive: &DriveTable,
        previous_input: f64,
    ) -> (f64, f64) {
        debug_assert_eq!(drive.carry_re.len(), self.re.len());
        self.run_all();
        #[cfg(target_arch = "x86_64")]
        if kernel != Kernel::Portable {
            let slices = x86::Driven::of(&mut self.re, &mut self.im, step, drive);
            // SAFETY: the caller's machine has the kernel's features.
            let result = unsafe {
                if kernel == Kernel::Avx512 {
                    x86::driven_avx512(slices, previous_input)
                } else {
                    x86::driven_avx2(slices, previous_input)
                }
            };
            if let Some(result) = result {
                return result;
            }
        }
        driven_step(
            &mut self.re,
            &mut self.im,
            &step.pole_re,
            &step.pole_im,
            &drive.carry_re,
            &drive.carry_im,
            &drive.observe,
            previous_input,
        )
    }

    /// Take back one free step (multiply by 1/p). Exact to rounding; used when a
    /// full step turns out to have run into a contact and must be redone in sub-steps.
    pub fn undo_free_step(&mut self, step: &StepTable) {
        self.run_all();
        undo_step(&mut self.re, &mut self.im, &step.pole_re, &step.pole_im);
    }
}

/// A driven step's kernel, as [`ModalBank::step_driven_by`] takes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kernel {
    /// AVX-512F.
    #[cfg(target_arch = "x86_64")]
    Avx512,
    /// AVX2 with FMA.
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// The portable loop.
    Portable,
}

impl Kernel {
    /// The fastest kernel this machine has.
    pub(crate) fn detected() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx512f") {
                return Self::Avx512;
            }
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                return Self::Avx2;
            }
        }
        Self::Portable
    }
}

/// Sum of an accumulator's lanes in a fixed order (both loops use it, so free and
/// driven steps give the same bits).
#[inline(always)]
pub fn lane_sum(a: &[f64; LANES]) -> f64 {
    ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]))
}

/// Add each sample's [`lane_sum`] of `acc` to `out` (the same sums, bit for
/// bit, in vector registers where the machine has AVX).
pub fn add_lane_sums(acc: &[[f64; LANES]], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx512f") {
        // SAFETY: the feature the kernel is compiled for was detected just above.
        unsafe { x86::add_lane_sums_avx512(acc, out) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx") {
        // SAFETY: the feature the kernel is compiled for was detected just above.
        unsafe { x86::add_lane_sums_avx(acc, out) };
        return;
    }
    add_lane_sums_portable(acc, out);
}

#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn add_lane_sums_portable(acc: &[[f64; LANES]], out: &mut [f64]) {
    for (o, a) in out.iter_mut().zip(acc) {
        *o += lane_sum(a);
    }
}

fn lane_sum_all(values: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    let (chunks, _) = values.as_chunks::<LANES>();
    for c in chunks {
        for l in 0..LANES {
            acc[l] += c[l];
        }
    }
    lane_sum(&acc)
}

/// Modes' poles as a [`FreeGather`] takes them: each pole and its inverse
/// ([`inverse`]).
pub struct Poles<'a> {
    pub re: &'a [f64],
    pub im: &'a [f64],
    pub back_re: &'a [f64],
    pub back_im: &'a [f64],
}

/// The free modes of several banks gathered into one run of the free loop,
/// so that a key's few-mode treble strings fill its chains together (each
/// bank alone would leave the multiply-add units waiting on one short chain).
///
/// A gathered mode runs in real form: the real part x of its phasor z obeys
/// x_(n+1) = 2 Re(p) x_n - |p|^2 x_(n-1), one multiply and one multiply-add a
/// step where turning z by p takes two of each, and x is what the bridge
/// feels. It is taken as (x_n, x_(n-1)) = (Re z, Re(z / p)) and given back as
/// z = x_n + i (x_n Re(1/p) - x_(n-1)) / Im(1/p), exact but for rounding
/// (relative 1e-16 over the sine of the pole's angle: 3e-14 for the lowest
/// piano string, each control block).
/// Holds room for a fixed number of modes: nothing allocates once made.
#[derive(Clone, Debug, Default)]
pub struct FreeGather {
    /// x_n and x_(n-1) of each mode, and its recursion's 2 Re(p) and -|p|^2.
    now: Vec<f64>,
    before: Vec<f64>,
    twice_re: Vec<f64>,
    minus_norm: Vec<f64>,
    len: usize,
}

impl FreeGather {
    /// Room for `modes` modes (each bank's padded count). Allocates.
    pub fn with_room(modes: usize) -> Self {
        let n = padded(modes);
        Self { now: vec![0.0; n], before: vec![0.0; n], twice_re: vec![0.0; n], minus_norm: vec![0.0; n], len: 0 }
    }

    /// Start a new gathering.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Add the modes with phasors `re` + i `im` (as many as a multiple of
    /// [`LANES`]) turning by `poles`; returns where they lie, or None when
    /// there is no room (nothing taken).
    pub fn take(&mut self, re: &[f64], im: &[f64], poles: Poles) -> Option<usize> {
        let (at, n) = (self.len, re.len());
        debug_assert_eq!(n % LANES, 0);
        if at + n > self.now.len() {
            return None;
        }
        let to = at..at + n;
        self.now[to.clone()].copy_from_slice(re);
        to_real_form(
            (&mut self.before[to.clone()], &mut self.twice_re[to.clone()], &mut self.minus_norm[to]),
            re,
            im,
            &poles,
        );
        self.len = at + n;
        Some(at)
    }

    /// Write the phasors of the modes taken at `at` as they stand now into
    /// `re` + i `im`, with their poles' `back_re` and `back_inv` ([`inverse`]).
    pub fn give_back(&self, at: usize, re: &mut [f64], im: &mut [f64], back_re: &[f64], back_inv: &[f64]) {
        let n = re.len();
        let (now, before) = (&self.now[at..at + n], &self.before[at..at + n]);
        re.copy_from_slice(now);
        from_real_form(im, now, before, back_re, back_inv);
    }

    /// The phasor of the mode taken at `i` as it stands now, with its pole's
    /// `back_re` and `back_inv` ([`inverse`]): what [`Self::give_back`] would give.
    #[inline]
    pub fn phasor(&self, i: usize, back_re: f64, back_inv: f64) -> Complex64 {
        let (x, y) = (self.now[i], self.before[i]);
        Complex64::new(x, (x * back_re - y) * back_inv)
    }

    /// [`ModalBank::cull`] on the `n` modes taken from `at` where they run,
    /// with their poles' `back_re` and `back_inv` ([`StepTable::backs`]):
    /// each mode under `floor_n` put to rest, the same bound and loudest
    /// mode, and how many of the modes would still run (modes up to the last
    /// group of [`LANES`] with one left in it). Allocates: no.
    pub fn cull(&mut self, at: usize, n: usize, backs: (&[f64], &[f64]), floor_n: f64) -> (f64, f64, usize) {
        cull_real_form((&mut self.now[at..at + n], &mut self.before[at..at + n]), backs, floor_n)
    }

    /// Add the phasors of the modes taken from `at` on to `sums`, one each,
    /// with their poles' `back_re` and `back_inv` as [`StepTable::backs`]
    /// gives them: what [`Self::phasor`] gives, mode by mode.
    #[inline]
    pub fn add_phasors(&self, at: usize, (back_re, back_inv): (&[f64], &[f64]), sums: &mut [Complex64]) {
        let n = sums.len();
        let (now, before) = (&self.now[at..at + n], &self.before[at..at + n]);
        for ((((sum, &x), &y), &qr), &inv) in
            sums.iter_mut().zip(now).zip(before).zip(&back_re[..n]).zip(&back_inv[..n])
        {
            sum.re += x;
            sum.im += (x * qr - y) * inv;
        }
    }

    /// Move the phasor of the mode taken at `i` by `delta`, with its pole's
    /// `back_re` and `back_im` ([`inverse`]): x_n by Re delta, x_(n-1) by Re(delta / p).
    #[inline]
    pub fn nudge(&mut self, i: usize, delta: Complex64, back_re: f64, back_im: f64) {
        self.now[i] += delta.re;
        self.before[i] += delta.re * back_re - delta.im * back_im;
    }

    /// Advance every gathered mode over `acc.len()` samples, adding the bridge
    /// force to `acc` by lane. The order of the gathering sets the order of the
    /// sums: the same gathering gives the same bits. (The synth writes with
    /// [`Self::run_fresh`]; this is what it is checked against.)
    #[cfg(test)]
    pub fn run(&mut self, acc: &mut [[f64; LANES]]) {
        self.run_into(acc, false);
    }

    /// [`Self::run`], writing `acc` (zeros if nothing was gathered) instead of
    /// adding to it.
    pub fn run_fresh(&mut self, acc: &mut [[f64; LANES]]) {
        self.run_into(acc, true);
    }

    fn run_into(&mut self, acc: &mut [[f64; LANES]], fresh: bool) {
        let n = self.len;
        let (now, before) = (&mut self.now[..n], &mut self.before[..n]);
        real_block_into(now, before, &self.twice_re[..n], &self.minus_norm[..n], acc, fresh);
    }
}

/// The older sample and the recursion's coefficients of modes with phasors
/// `re` + i `im` turning by `poles` ([`FreeGather::take`]).
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn to_real_form(
    (before, twice_re, minus_norm): (&mut [f64], &mut [f64], &mut [f64]),
    re: &[f64],
    im: &[f64],
    poles: &Poles,
) {
    let rows = before.iter_mut().zip(twice_re.iter_mut()).zip(minus_norm.iter_mut());
    let from = re.iter().zip(im).zip(poles.re).zip(poles.im).zip(poles.back_re).zip(poles.back_im);
    for (((b, t), m), (((((&r, &i), &pr), &pi), &qr), &qi)) in rows.zip(from) {
        *b = r * qr - i * qi;
        *t = 2.0 * pr;
        *m = -(pr * pr + pi * pi);
    }
}

/// [`ModalBank::observe`]: compiled for the vector extensions too, where each
/// multiply-add is one instruction (in the baseline, a call into the maths
/// library per mode: at each strike, every string's modes; the same bits).
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn observe_through(re: &[f64], observe: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    let (re, _) = re.as_chunks::<LANES>();
    let (c, _) = observe.as_chunks::<LANES>();
    for (r, c) in re.iter().zip(c) {
        for l in 0..LANES {
            acc[l] = c[l].mul_add(r[l], acc[l]);
        }
    }
    lane_sum(&acc)
}

/// The imaginary parts of phasors in real form ([`FreeGather::give_back`]).
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn from_real_form(im: &mut [f64], now: &[f64], before: &[f64], back_re: &[f64], back_inv: &[f64]) {
    for ((((i, &x), &y), &qr), &inv) in im.iter_mut().zip(now).zip(before).zip(back_re).zip(back_inv) {
        *i = (x * qr - y) * inv;
    }
}

/// [`FreeGather::cull`] on modes in real form (`now`, `before`), their
/// poles' inverses as [`StepTable::backs`] gives them. Without a branch on
/// a mode: a mode put to rest adds a zero to the bound (never -0, a sum of
/// magnitudes from +0) and to the loudest, the same sums and maximum.
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn cull_real_form(
    (now, before): (&mut [f64], &mut [f64]),
    (back_re, back_inv): (&[f64], &[f64]),
    floor_n: f64,
) -> (f64, f64, usize) {
    let n = now.len();
    let (now, _) = now.as_chunks_mut::<LANES>();
    let (before, _) = before[..n].as_chunks_mut::<LANES>();
    let (qr, _) = back_re[..n].as_chunks::<LANES>();
    let (inv, _) = back_inv[..n].as_chunks::<LANES>();
    let mut bound = [0.0; LANES];
    let mut loudest = [0.0f64; LANES];
    let mut top = 0;
    for (g, (((x, y), qr), inv)) in now.iter_mut().zip(before.iter_mut()).zip(qr).zip(inv).enumerate() {
        let mut kept = false;
        for l in 0..LANES {
            // (The phasor as `give_back` would hand it back.)
            let im = (x[l] * qr[l] - y[l]) * inv[l];
            let magnitude = x[l].abs() + im.abs();
            let rest = magnitude < floor_n;
            let left = if rest { 0.0 } else { magnitude };
            x[l] = if rest { 0.0 } else { x[l] };
            y[l] = if rest { 0.0 } else { y[l] };
            bound[l] += left;
            loudest[l] = loudest[l].max(left);
            kept |= !rest;
        }
        if kept {
            top = g + 1;
        }
    }
    (lane_sum(&bound), loudest.iter().fold(0.0f64, |m, &v| m.max(v)), top * LANES)
}

/// Gathered modes in real form ([`FreeGather`]) over `acc.len()` samples,
/// adding (or, if `fresh`, writing) each sample's bridge force to `acc` by lane.
/// As many groups run together as the target's vector registers hold: with
/// AVX-512's 32, [`REAL_CHAIN`] with their recursions' coefficients kept in
/// registers too; elsewhere [`REAL_CHAIN_NARROW`], the coefficients read from
/// memory by each step. The sums are the same bits either way.
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn real_block_into(
    now: &mut [f64],
    before: &mut [f64],
    twice_re: &[f64],
    minus_norm: &[f64],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    if multiversion::target::target_cfg_f!(target_feature = "avx512f") {
        real_block_chains::<REAL_CHAIN, false>(now, before, twice_re, minus_norm, acc, fresh);
    } else {
        real_block_chains::<REAL_CHAIN_NARROW, true>(now, before, twice_re, minus_norm, acc, fresh);
    }
}

/// [`real_block_into`] `C` groups at a time (the last few fewer), inlined
/// into each version; `REFETCH` as [`real_chain`]'s.
#[inline(always)]
fn real_block_chains<const C: usize, const REFETCH: bool>(
    now: &mut [f64],
    before: &mut [f64],
    twice_re: &[f64],
    minus_norm: &[f64],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    let (now, _) = now.as_chunks_mut::<LANES>();
    let (before, _) = before.as_chunks_mut::<LANES>();
    let (a, _) = twice_re.as_chunks::<LANES>();
    let (b, _) = minus_norm.as_chunks::<LANES>();
    let whole = now.len() / C * C;
    let mut fresh = fresh;
    let mut g = 0;
    while g < whole {
        let to = g + C;
        real_groups::<C, REFETCH>(&mut now[g..to], &mut before[g..to], &a[g..to], &b[g..to], acc, fresh);
        fresh = false;
        g = to;
    }
    let (x, y, a, b) = (&mut now[whole..], &mut before[whole..], &a[whole..], &b[whole..]);
    match (x.len(), fresh) {
        (0, true) => acc.fill([0.0; LANES]),
        (0, false) => {}
        (1, _) => real_groups::<1, REFETCH>(x, y, a, b, acc, fresh),
        (2, _) => real_groups::<2, REFETCH>(x, y, a, b, acc, fresh),
        (3, _) => real_groups::<3, REFETCH>(x, y, a, b, acc, fresh),
        (4, _) => real_groups::<4, REFETCH>(x, y, a, b, acc, fresh),
        _ => real_groups::<5, REFETCH>(x, y, a, b, acc, fresh),
    }
}

/// The first `G` groups of the slices in real form over a block, writing to
/// `acc` if `fresh`, else adding to it.
#[inline(always)]
fn real_groups<const G: usize, const REFETCH: bool>(
    now: &mut [[f64; LANES]],
    before: &mut [[f64; LANES]],
    a: &[[f64; LANES]],
    b: &[[f64; LANES]],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    if let (Some(x), Some(y), Some(a), Some(b)) =
        (now.first_chunk_mut::<G>(), before.first_chunk_mut::<G>(), a.first_chunk::<G>(), b.first_chunk::<G>())
    {
        if fresh {
            real_chain::<G, true, REFETCH>(x, y, a, b, acc);
        } else {
            real_chain::<G, false, REFETCH>(x, y, a, b, acc);
        }
    }
}

/// `G` groups in real form over a block, state in registers; each group's
/// bridge force is added to its sample's accumulator in the gathering's order
/// (the first group written to it, if `WRITE`), so how the groups are cut
/// into chains changes no bit. The multiply by the older sample is off the
/// chain of dependent operations: one multiply-add a step on it. With
/// `REFETCH` the coefficients are read from memory by every step (the
/// compiler would otherwise hold them in registers and push the modes' state
/// out to the stack: with AVX2's 16 registers three groups' state takes 12).
#[inline(always)]
fn real_chain<const G: usize, const WRITE: bool, const REFETCH: bool>(
    now: &mut [[f64; LANES]; G],
    before: &mut [[f64; LANES]; G],
    twice_re: &[[f64; LANES]; G],
    minus_norm: &[[f64; LANES]; G],
    acc: &mut [[f64; LANES]],
) {
    // Two samples a round, the newer and the older sample of each mode taking
    // turns in the same two places: no copies from one to the other.
    let (mut x, mut y) = (*now, *before);
    let (pairs, last) = acc.as_chunks_mut::<2>();
    for [first, second] in pairs {
        let (twice_re, minus_norm) =
            if REFETCH { std::hint::black_box((twice_re, minus_norm)) } else { (twice_re, minus_norm) };
        real_step::<G, WRITE>(&mut y, &x, twice_re, minus_norm, first);
        real_step::<G, WRITE>(&mut x, &y, twice_re, minus_norm, second);
    }
    if let [out] = last {
        real_step::<G, WRITE>(&mut y, &x, twice_re, minus_norm, out);
        std::mem::swap(&mut x, &mut y);
    }
    *now = x;
    *before = y;
}

/// One sample of [`real_chain`]: `older` (x_(n-1) of each mode) becomes
/// x_(n+1) from `newer` (x_n), and is summed into `out` in the groups' order.
#[inline(always)]
fn real_step<const G: usize, const WRITE: bool>(
    older: &mut [[f64; LANES]; G],
    newer: &[[f64; LANES]; G],
    twice_re: &[[f64; LANES]; G],
    minus_norm: &[[f64; LANES]; G],
    out: &mut [f64; LANES],
) {
    let mut sum = if WRITE { [0.0; LANES] } else { *out };
    for g in 0..G {
        for l in 0..LANES {
            let next = twice_re[g][l].mul_add(newer[g][l], minus_norm[g][l] * older[g][l]);
            older[g][l] = next;
            sum[l] += next;
        }
    }
    *out = sum;
}

/// Groups of [`LANES`] modes stepped together in the free loop: each mode's step
/// depends on its last, so several independent groups must be in flight to keep
/// the multiply-add units busy through their latency (4 cycles, 2 units: 8).
pub(crate) const CHAIN: usize = 4;

/// Groups stepped together in the real-form loop ([`FreeGather`]). A step is
/// a multiply off the chain and one multiply-add on it, so four groups keep
/// the two units exactly as busy as the chain's latency allows, and any stall
/// shows; six leave slack (the gathered loop went from 0.75 to 0.93 of the
/// FMA probe on this machine's AVX-512), eight no longer fit the registers.
pub(crate) const REAL_CHAIN: usize = 6;
/// [`REAL_CHAIN`] where a group of [`LANES`] modes takes two vector registers
/// (AVX2) or four (SSE, NEON) and there are 16 or 32: three groups, their two
/// samples in 12 of AVX2's 16 registers. Six spilled the state to the stack
/// every sample: on a Zen 3 (AVX2) the gathered loop took 0.37-0.45 ns per
/// mode-sample with six groups, 0.14-0.17 with three read this way.
pub(crate) const REAL_CHAIN_NARROW: usize = 3;
// (What is left after the whole chains, up to five groups, runs by itself.)
const _: () = assert!(REAL_CHAIN <= 6 && REAL_CHAIN_NARROW <= REAL_CHAIN);

/// `to[i] += by[i] * k` for as many as both have, each product rounded before
/// its sum: [`ModalBank::kick`] (a dulcimer's string with a stroke in play
/// takes its bridge's kick so every sample).
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn add_scaled(to: &mut [f64], by: &[f64], k: f64) {
    add_scaled_body(to, by, k);
}

/// What [`add_scaled`] runs, inlined into each of its callers' versions.
#[inline(always)]
fn add_scaled_body(to: &mut [f64], by: &[f64], k: f64) {
    for (t, b) in to.iter_mut().zip(by) {
        *t += b * k;
    }
}

/// Advance `re`/`im` by their poles over `acc.len()` samples, adding each
/// sample's bridge force to `acc` by lane.
pub(crate) fn free_block(re: &mut [f64], im: &mut [f64], pole_re: &[f64], pole_im: &[f64], acc: &mut [[f64; LANES]]) {
    free_block_into(re, im, pole_re, pole_im, acc, false);
}

/// [`free_block`], writing `acc` instead of adding to it when `fresh` (the
/// same bits as adding to zeros: a sum of modes is never -0).
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
pub(crate) fn free_block_into(
    re: &mut [f64],
    im: &mut [f64],
    pole_re: &[f64],
    pole_im: &[f64],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    free_block_body(re, im, pole_re, pole_im, acc, fresh);
}

/// One sample of [`free_block`] after `im[i] += kick[i] * dv` (as
/// [`add_scaled`]), in one call: that sample's [`lane_sum`]. (Summed here, in
/// the registers the sample's lanes are in: read back from memory by the
/// caller's code, its wide stores stalled the narrower loads.)
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn free_sample_kicked(
    re: &mut [f64],
    im: &mut [f64],
    (kick, dv): (&[f64], f64),
    pole_re: &[f64],
    pole_im: &[f64],
) -> f64 {
    add_scaled_body(im, kick, dv);
    let mut acc = [[0.0; LANES]; 1];
    free_block_body(re, im, pole_re, pole_im, &mut acc, false);
    lane_sum(&acc[0])
}

/// What [`free_block_into`] runs, inlined into each of its callers' versions.
#[inline(always)]
fn free_block_body(
    re: &mut [f64],
    im: &mut [f64],
    pole_re: &[f64],
    pole_im: &[f64],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    let (re, _) = re.as_chunks_mut::<LANES>();
    let (im, _) = im.as_chunks_mut::<LANES>();
    let (pr, _) = pole_re.as_chunks::<LANES>();
    let (pi, _) = pole_im.as_chunks::<LANES>();
    let whole = re.len() / CHAIN * CHAIN;
    let (re_chains, re_rest) = re.split_at_mut(whole);
    let (im_chains, im_rest) = im.split_at_mut(whole);
    let (re_chains, _) = re_chains.as_chunks_mut::<CHAIN>();
    let (im_chains, _) = im_chains.as_chunks_mut::<CHAIN>();
    let (pr_chains, _) = pr[..whole].as_chunks::<CHAIN>();
    let (pi_chains, _) = pi[..whole].as_chunks::<CHAIN>();
    let mut fresh = fresh;
    for (((zr, zi), pr), pi) in re_chains.iter_mut().zip(im_chains.iter_mut()).zip(pr_chains).zip(pi_chains) {
        if fresh {
            free_chain::<CHAIN, true>(zr, zi, pr, pi, acc);
            fresh = false;
        } else {
            free_chain::<CHAIN, false>(zr, zi, pr, pi, acc);
        }
    }
    let (pr, pi) = (&pr[whole..], &pi[whole..]);
    match (re_rest.len(), fresh) {
        (0, true) => acc.fill([0.0; LANES]),
        (0, false) => {}
        (1, _) => free_rest::<1>(re_rest, im_rest, pr, pi, acc, fresh),
        (2, _) => free_rest::<2>(re_rest, im_rest, pr, pi, acc, fresh),
        _ => free_rest::<3>(re_rest, im_rest, pr, pi, acc, fresh),
    }
}

/// The last `G` groups of modes (fewer than a chain) over a block.
#[inline(always)]
fn free_rest<const G: usize>(
    re: &mut [[f64; LANES]],
    im: &mut [[f64; LANES]],
    pr: &[[f64; LANES]],
    pi: &[[f64; LANES]],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    if let (Some(zr), Some(zi), Some(pr), Some(pi)) =
        (re.first_chunk_mut::<G>(), im.first_chunk_mut::<G>(), pr.first_chunk::<G>(), pi.first_chunk::<G>())
    {
        if fresh {
            free_chain::<G, true>(zr, zi, pr, pi, acc);
        } else {
            free_chain::<G, false>(zr, zi, pr, pi, acc);
        }
    }
}

/// `G` groups of modes over a block of samples, state in registers; each sample's
/// bridge force is summed over the groups in order and then added to its
/// accumulator (written to it, if `WRITE`).
#[inline(always)]
fn free_chain<const G: usize, const WRITE: bool>(
    re: &mut [[f64; LANES]; G],
    im: &mut [[f64; LANES]; G],
    pr: &[[f64; LANES]; G],
    pi: &[[f64; LANES]; G],
    acc: &mut [[f64; LANES]],
) {
    let (mut r, mut i) = (*re, *im);
    for a in acc.iter_mut() {
        let mut sum = [0.0; LANES];
        for g in 0..G {
            for l in 0..LANES {
                let nr = pr[g][l].mul_add(r[g][l], -(pi[g][l] * i[g][l]));
                let ni = pr[g][l].mul_add(i[g][l], pi[g][l] * r[g][l]);
                r[g][l] = nr;
                i[g][l] = ni;
                sum[l] += nr;
            }
        }
        for l in 0..LANES {
            if WRITE {
                a[l] = sum[l];
            } else {
                a[l] += sum[l];
            }
        }
    }
    *re = r;
    *im = i;
}

#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
#[allow(clippy::too_many_arguments)]
fn driven_step(
    re: &mut [f64],
    im: &mut [f64],
    pole_re: &[f64],
    pole_im: &[f64],
    carry_re: &[f64],
    carry_im: &[f64],
    observe: &[f64],
    input: f64,
) -> (f64, f64) {
    let (re, _) = re.as_chunks_mut::<LANES>();
    let (im, _) = im.as_chunks_mut::<LANES>();
    let (pr, _) = pole_re.as_chunks::<LANES>();
    let (pi, _) = pole_im.as_chunks::<LANES>();
    let (er, _) = carry_re.as_chunks::<LANES>();
    let (ei, _) = carry_im.as_chunks::<LANES>();
    let (c, _) = observe.as_chunks::<LANES>();
    // One observation accumulator per group of a chain (no chain of dependent
    // multiply-adds); the bridge force summed as the free loop sums it, within
    // each chain of groups first, so an idle exciter gives the same bits as none.
    // The x86 kernels follow this order exactly.
    let mut obs = [[0.0; LANES]; CHAIN];
    let mut bridge = [0.0; LANES];
    let mut sum = [0.0; LANES];
    let last = re.len().saturating_sub(1);
    let groups = re.iter_mut().zip(im.iter_mut()).zip(pr).zip(pi).zip(er).zip(ei).zip(c);
    for (g, ((((((zr, zi), pr), pi), er), ei), c)) in groups.enumerate() {
        let o = &mut obs[g % CHAIN];
        for l in 0..LANES {
            let nr = er[l].mul_add(input, pr[l].mul_add(zr[l], -(pi[l] * zi[l])));
            let ni = ei[l].mul_add(input, pr[l].mul_add(zi[l], pi[l] * zr[l]));
            zr[l] = nr;
            zi[l] = ni;
            sum[l] += nr;
            o[l] = c[l].mul_add(nr, o[l]);
        }
        if g % CHAIN == CHAIN - 1 || g == last {
            for (b, s) in bridge.iter_mut().zip(&mut sum) {
                *b += *s;
                *s = 0.0;
            }
        }
    }
    let mut observed = obs[0];
    for o in &obs[1..] {
        for (total, x) in observed.iter_mut().zip(o) {
            *total += x;
        }
    }
    (lane_sum(&observed), lane_sum(&bridge))
}

fn undo_step(re: &mut [f64], im: &mut [f64], pole_re: &[f64], pole_im: &[f64]) {
    for (((r, i), pr), pi) in re.iter_mut().zip(im.iter_mut()).zip(pole_re).zip(pole_im) {
        let norm = pr * pr + pi * pi;
        let (nr, ni) = ((*r * pr + *i * pi) / norm, (*i * pr - *r * pi) / norm);
        *r = nr;
        *i = ni;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::string::damping::Damping;
    use crate::string::{Mass, Stiffness, StringSpec, Tuning};

    #[test]
    fn lane_sums_match_the_portable_loop_bit_for_bit() {
        // Values of every size and sign, so any change of order shows.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let acc: Vec<[f64; LANES]> = (0..crate::CONTROL_BLOCK)
            .map(|i| std::array::from_fn(|l| next() * 10f64.powi((i + 3 * l) as i32 % 17 - 8)))
            .collect();
        let start: Vec<f64> = (0..crate::CONTROL_BLOCK).map(|_| next()).collect();
        // A stretch whose length is no multiple of eight, too.
        let (mut fast, mut plain) = (start[..13].to_vec(), start[..13].to_vec());
        add_lane_sums(&acc[..13], &mut fast);
        add_lane_sums_portable(&acc[..13], &mut plain);
        assert!(fast.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()), "{fast:?} against {plain:?}");
        let (mut fast, mut plain) = (start.clone(), start.clone());
        add_lane_sums(&acc, &mut fast);
        add_lane_sums_portable(&acc, &mut plain);
        assert!(fast.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()));
        // AVX's own four at a time and one by one, which AVX-512 leaves the last few samples to.
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx") {
            for n in [0, 3, 13, crate::CONTROL_BLOCK] {
                let mut avx = start[..n].to_vec();
                // SAFETY: AVX was detected just above.
                unsafe { x86::add_lane_sums_avx(&acc[..n], &mut avx) };
                assert!(avx.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()), "{n} samples");
            }
        }
    }

    /// A stiff treble string with modes up to 20 kHz.
    fn treble_string() -> StringModes {
        StringSpec {
            length_m: 0.62,
            tuning: Tuning::TensionN(670.0),
            mass: Mass::PerLengthKgM(0.00634),
            stiffness: Stiffness::Inharmonicity(3.8e-4),
            damping: Damping::UniformQ(2000.0),
            max_frequency_hz: 20_000.0,
            outer_diameter_m: None,
        }
        .build()
        .unwrap()
    }

    fn one_mode(q: f64) -> StringModes {
        StringSpec {
            length_m: 1.0,
            tuning: Tuning::FirstPartialHz(100.0),
            mass: Mass::PerLengthKgM(0.01),
            stiffness: Stiffness::Flexible,
            damping: Damping::UniformQ(q),
            max_frequency_hz: 150.0,
            outer_diameter_m: None,
        }
        .build()
        .unwrap()
    }

    #[test]
    fn a_kick_taken_with_the_step_is_the_kick_then_the_step_to_the_bit() {
        // A treble string ringing (some modes culled), kicked and stepped a
        // sample at a time both ways: the same forces and states, bit for bit.
        let string = treble_string();
        let step = StepTable::new(&string, 1.0 / 48_000.0);
        let mut a = ModalBank::new(&string);
        for i in 0..a.len() {
            a.set_state(i, Complex64::new(1e-4 / (i + 1) as f64, -3e-5 * (i as f64).sin()));
        }
        a.cull(1e-9);
        let mut b = a.clone();
        let gains: Vec<f64> = string.modes.iter().map(|m| -2.0 / (m.number as f64 * std::f64::consts::PI)).collect();
        let table = a.kick_table(&gains);
        for k in 0..200 {
            let dv = 1e-3 * ((k as f64) * 0.37).sin();
            a.kick(&table, dv);
            let mut out = [0.0];
            a.process_free(&step, &mut out);
            let force = b.process_free_kicked(&step, &table, dv);
            assert_eq!(out[0].to_bits(), force.to_bits(), "sample {k}");
        }
        assert!(a.re.iter().zip(&b.re).chain(a.im.iter().zip(&b.im)).all(|(x, y)| x.to_bits() == y.to_bits()));
    }

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

    /// A unit modal acceleration switched on at t = 0 and then a linear ramp must
    /// follow the closed-form solutions exactly, whatever the step.
    #[test]
    fn first_order_hold_input_is_integrated_exactly() {
        let string = one_mode(50.0);
        let mode = string.modes[0];
        let (sigma, wd, w) = (mode.decay_rate_s(), mode.damped_omega_rad_s(), mode.omega_rad_s);
        for &h in &[1e-5, 1e-3, 7e-3] {
            let step = StepTable::new(&string, h);
            let mut bank = ModalBank::new(&string);
            let drive = DriveTable::new(&step, Hold::Linear, bank.weights(), &[1.0], &[1.0]);
            // Step input u = 1: previous input 1 carried, this step's input 1 added.
            let mut pending = 0.0;
            // Start with the ramp of the first step: the stored state lacks b1 u.
            bank.apply_ramp(&drive, -1.0);
            pending += 1.0;
            for k in 1..=40 {
                let (obs, _) = bank.step_driven(&step, &drive, pending);
                let q = obs + drive.observe_per_input * 1.0;
                let t = k as f64 * h;
                let exact = (1.0 - (-sigma * t).exp() * ((wd * t).cos() + sigma / wd * (wd * t).sin())) / (w * w);
                assert!((q - exact).abs() < 1e-12 * (1.0 / (w * w)), "h={h} k={k} {q} {exact}");
            }
        }
    }

    #[test]
    fn a_gathering_of_banks_gives_their_sums_and_writes_the_same_bits_as_it_adds() {
        // Two strings gathered and run together (in real form) turn their
        // modes as each alone (turning its phasors) but for rounding, and a
        // fresh run's written accumulator is the added one.
        let (treble, other) = (treble_string(), one_mode(300.0));
        let strings = [&treble, &other];
        let steps: Vec<StepTable> = strings.iter().map(|s| StepTable::new(s, 1.0 / 48_000.0)).collect();
        let mut banks: Vec<ModalBank> = strings.iter().map(|s| ModalBank::new(s)).collect();
        for b in &mut banks {
            for i in 0..b.len() {
                b.add_velocity(i, (i as f64 + 0.5).cos());
            }
        }
        let mut alone = banks.clone();
        let mut added = vec![[0.0; LANES]; FREE_BLOCK];
        for (b, step) in alone.iter_mut().zip(&steps) {
            b.accumulate_free(step, &mut added);
        }
        let mut gather = FreeGather::with_room(banks.iter().map(|b| b.len().next_multiple_of(LANES)).sum());
        let at: Vec<usize> =
            banks.iter().zip(&steps).map(|(b, step)| b.gather_free(step, &mut gather).unwrap()).collect();
        let mut written = vec![[f64::NAN; LANES]; FREE_BLOCK];
        gather.run_fresh(&mut written);
        for (((b, at), a), step) in banks.iter_mut().zip(at).zip(&alone).zip(&steps) {
            b.scatter_free(step, &gather, at);
            let size = a.re.iter().chain(&a.im).fold(0.0f64, |m, v| m.max(v.abs()));
            for (x, y) in b.re.iter().zip(&a.re).chain(b.im.iter().zip(&a.im)) {
                assert!((x - y).abs() <= 1e-13 * size, "{x} against {y}");
            }
        }
        let sum = |acc: &[[f64; LANES]]| acc.iter().map(lane_sum).collect::<Vec<_>>();
        let (one, together) = (sum(&added), sum(&written));
        for (x, y) in one.iter().zip(&together) {
            assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0), "{x} against {y}");
        }
        let mut twice = vec![[0.0; LANES]; FREE_BLOCK];
        let again = banks.clone();
        let mut g2 = FreeGather::with_room(gather.now.len());
        for (b, step) in again.iter().zip(&steps) {
            b.gather_free(step, &mut g2).unwrap();
        }
        let mut fresh = vec![[f64::NAN; LANES]; FREE_BLOCK];
        g2.clone().run_fresh(&mut fresh);
        g2.run(&mut twice);
        assert!(fresh.iter().flatten().zip(twice.iter().flatten()).all(|(x, y)| x.to_bits() == y.to_bits()));
    }

    #[test]
    fn a_gathering_culls_as_its_banks_handed_back_would_cull() {
        // Modes of every size, some under the floor: culled where they run,
        // the same bound, the same loudest mode and the same modes at rest
        // as the banks culled once handed back.
        let strings = [treble_string(), one_mode(300.0)];
        let steps: Vec<StepTable> = strings.iter().map(|s| StepTable::new(s, 1.0 / 48_000.0)).collect();
        let mut banks: Vec<ModalBank> = strings.iter().map(ModalBank::new).collect();
        for b in &mut banks {
            for i in 0..b.len() {
                b.add_velocity(i, (i as f64 + 0.5).cos() * 10f64.powi(-(i as i32 % 7)));
            }
        }
        let mut gather = FreeGather::with_room(banks.iter().map(|b| b.len().next_multiple_of(LANES)).sum());
        let at: Vec<usize> =
            banks.iter().zip(&steps).map(|(b, step)| b.gather_free(step, &mut gather).unwrap()).collect();
        let mut acc = vec![[0.0; LANES]; FREE_BLOCK];
        gather.run_fresh(&mut acc);
        for floor in [0.0, 1e-9, 1e-6, 1e-3, 1e3] {
            let mut culled = gather.clone();
            for ((b, step), &at) in banks.iter().zip(&steps).zip(&at) {
                let n = b.running();
                let (bound, loudest, top) = culled.cull(at, n, step.backs(), floor);
                let mut handed = b.clone();
                handed.scatter_free(step, &gather, at);
                let (bank_bound, bank_loudest) = handed.cull(floor);
                assert_eq!((bound.to_bits(), loudest.to_bits()), (bank_bound.to_bits(), bank_loudest.to_bits()));
                assert_eq!(top, handed.running(), "floor {floor}");
                // (Equal, and to the bit but for a mode put to rest, whose
                // imaginary part may come back as -0.)
                let mut back = b.clone();
                back.scatter_free(step, &culled, at);
                for (x, y) in
                    back.re[..top].iter().zip(&handed.re[..top]).chain(back.im[..top].iter().zip(&handed.im[..top]))
                {
                    assert!(x.to_bits() == y.to_bits() || (*x == 0.0 && *y == 0.0), "{x} against {y}");
                }
            }
        }
    }

    /// [`real_block_into`]'s signature.
    type RealBlock = fn(&mut [f64], &mut [f64], &[f64], &[f64], &mut [[f64; LANES]], bool);

    #[test]
    fn the_real_form_loop_gives_the_same_bits_however_many_groups_run_together() {
        // The wide targets' chains of six with their coefficients held, the
        // narrow ones' of three read from memory, and one group at a time:
        // every remainder, written and added, over an odd number of samples.
        for groups in 0..=2 * REAL_CHAIN + 1 {
            let n = groups * LANES;
            let wave = |k: usize, f: f64| (0..n).map(|i| ((i * 7 + k) as f64 * f).sin()).collect::<Vec<f64>>();
            let (now, before) = (wave(1, 0.37), wave(2, 0.29));
            let twice_re: Vec<f64> = wave(3, 0.11).iter().map(|v| 1.9 + 0.05 * v).collect();
            let minus_norm: Vec<f64> = wave(4, 0.13).iter().map(|v| -0.999 + 0.0005 * v).collect();
            for fresh in [true, false] {
                let run = |chains: RealBlock| {
                    let (mut x, mut y) = (now.clone(), before.clone());
                    let mut acc: Vec<[f64; LANES]> =
                        (0..FREE_BLOCK - 1).map(|s| std::array::from_fn(|l| (s * LANES + l) as f64 * 1e-3)).collect();
                    chains(&mut x, &mut y, &twice_re, &minus_norm, &mut acc, fresh);
                    let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
                    (bits(&x), bits(&y), bits(acc.as_flattened()))
                };
                let wide = run(real_block_chains::<REAL_CHAIN, false>);
                assert!(wide == run(real_block_chains::<REAL_CHAIN_NARROW, true>), "{groups} groups, fresh {fresh}");
                assert!(wide == run(real_block_chains::<1, false>), "{groups} groups, fresh {fresh}");
                assert!(wide == run(real_block_into), "{groups} groups, fresh {fresh}");
            }
        }
    }

    #[test]
    fn a_gathering_of_any_number_of_groups_turns_them_as_alone() {
        // Whole chains of REAL_CHAIN groups and every remainder (none gathered
        // at all: a fresh run writes zeros); each group one mode of its own Q.
        for groups in 0..=2 * REAL_CHAIN + 1 {
            let strings: Vec<StringModes> = (0..groups).map(|g| one_mode(200.0 + 37.0 * g as f64)).collect();
            let steps: Vec<StepTable> = strings.iter().map(|s| StepTable::new(s, 1.0 / 48_000.0)).collect();
            let mut banks: Vec<ModalBank> = strings.iter().map(ModalBank::new).collect();
            for (g, b) in banks.iter_mut().enumerate() {
                b.add_velocity(0, 1.0 + g as f64);
            }
            let mut added = vec![[0.0; LANES]; FREE_BLOCK];
            for (b, step) in banks.clone().iter_mut().zip(&steps) {
                b.accumulate_free(step, &mut added);
            }
            let mut gather = FreeGather::with_room((groups * LANES).max(1));
            for (b, step) in banks.iter().zip(&steps) {
                b.gather_free(step, &mut gather).unwrap();
            }
            let mut written = vec![[f64::NAN; LANES]; FREE_BLOCK];
            gather.run_fresh(&mut written);
            let peak = added.iter().map(lane_sum).fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            for (x, y) in added.iter().map(lane_sum).zip(written.iter().map(lane_sum)) {
                assert!((x - y).abs() <= 1e-12 * peak, "{groups} groups: {x} against {y}");
            }
        }
    }

    #[test]
    fn free_and_driven_idle_steps_give_identical_bits() {
        let string = treble_string();
        let step = StepTable::new(&string, 1.0 / 48_000.0);
        let mut a = ModalBank::new(&string);
        for i in 0..a.len() {
            a.add_velocity(i, 1.0 / (i + 1) as f64);
        }
        let mut b = a.clone();
        let gain: Vec<f64> = (0..a.len()).map(|i| (i as f64).sin()).collect();
        let drive = DriveTable::new(&step, Hold::Linear, b.weights(), &gain, &gain);
        let mut out = vec![0.0; 200];
        a.process_free(&step, &mut out);
        for o in &out {
            let (_, bridge) = b.step_driven(&step, &drive, 0.0);
            assert_eq!(bridge.to_bits(), o.to_bits());
        }
    }

    #[test]
    fn undo_takes_back_a_free_step() {
        let string = one_mode(1000.0);
        let step = StepTable::new(&string, 1.0 / 96_000.0);
        let mut bank = ModalBank::new(&string);
        bank.add_displacement(0, 1e-3);
        let before = (bank.displacement(0), bank.velocity(0));
        let mut out = [0.0];
        bank.process_free(&step, &mut out);
        bank.undo_free_step(&step);
        assert!((bank.displacement(0) - before.0).abs() < 1e-18);
        assert!((bank.velocity(0) - before.1).abs() < 1e-15);
    }

    #[test]
    fn free_decay_and_frequency_are_exact() {
        let string = one_mode(100.0);
        let mode = string.modes[0];
        let fs = 44_100.0;
        let step = StepTable::new(&string, 1.0 / fs);
        let mut bank = ModalBank::new(&string);
        bank.add_displacement(0, 1.0);
        let mut out = vec![0.0; 44_100];
        bank.process_free(&step, &mut out);
        let (sigma, wd) = (mode.decay_rate_s(), mode.damped_omega_rad_s());
        let w = string.bridge_weight(&mode);
        for (k, o) in out.iter().enumerate().step_by(997) {
            let t = (k + 1) as f64 / fs;
            let exact = w * (-sigma * t).exp() * ((wd * t).cos() + sigma / wd * (wd * t).sin());
            assert!((o - exact).abs() < 1e-11 * w, "{k}");
        }
    }

    #[test]
    fn culling_rests_quiet_modes_and_stops_computing_above_the_loudest() {
        let string = treble_string();
        let step = StepTable::new(&string, 1.0 / 48_000.0);
        let mut bank = ModalBank::new(&string);
        assert_eq!(bank.running(), 0, "a bank at rest computes nothing");
        let n = bank.len();
        assert!(n > 3 * LANES);
        // Modes 0 and 2 loud, mode 5 quiet, the rest silent.
        bank.add_velocity(0, 1.0);
        bank.add_velocity(2, 0.5);
        bank.add_velocity(5, 1e-9);
        assert_eq!(bank.running(), n.div_ceil(LANES) * LANES);
        let before = bank.amplitude_bound_n();
        let floor = 1e-6 * before;
        let (bound, loudest) = bank.cull(floor);
        assert_eq!(bank.running(), LANES, "only the first group still rings");
        assert_eq!((bank.displacement(5), bank.velocity(5)), (0.0, 0.0));
        assert!(bank.velocity(2) > 0.0);
        assert!(bound <= before && bound > 0.99 * before);
        assert!(loudest > 0.5 * bound);
        // The free loop over the running modes gives what the whole bank would.
        let mut whole = bank.clone();
        whole.run_all();
        let (mut a, mut b) = (vec![0.0; 100], vec![0.0; 100]);
        bank.process_free(&step, &mut a);
        whole.process_free(&step, &mut b);
        assert_eq!(a, b);
        // Anything that moves the modes brings them all back.
        bank.add_velocity(n - 1, 1.0);
        assert_eq!(bank.running(), n.div_ceil(LANES) * LANES);
        bank.clear();
        assert_eq!(bank.running(), 0);
    }

    /// What culling drops can never add more to the bridge force than the dropped
    /// modes' amplitudes (free motion only shrinks them): a string culled 60 dB
    /// below its loudest stays within that sum of the unculled string, sample by sample.
    #[test]
    fn culling_changes_the_output_by_at_most_what_it_dropped() {
        let string = treble_string();
        let step = StepTable::new(&string, 1.0 / 48_000.0);
        let mut whole = ModalBank::new(&string);
        for i in 0..whole.len() {
            // Partials falling off as 1/n^3: the top ones are far below the first.
            whole.add_velocity(i, 1.0 / ((i + 1) as f64).powi(3));
        }
        let before = whole.amplitude_bound_n();
        let mut culled = whole.clone();
        let (_, loudest) = culled.cull(0.0);
        let (after, _) = culled.cull(1e-3 * loudest);
        let dropped = before - after;
        assert!(dropped > 0.0 && culled.running() < whole.running(), "something is culled");
        let (mut a, mut b) = (vec![0.0; 4800], vec![0.0; 4800]);
        whole.process_free(&step, &mut a);
        culled.process_free(&step, &mut b);
        let worst = a.iter().zip(&b).map(|(x, y)| (x - y).abs()).fold(0.0, f64::max);
        assert!(worst > 0.0 && worst <= dropped * (1.0 + 1e-12), "{worst} vs {dropped}");
    }

    /// Each vector kernel the machine can run gives the portable loop's bits.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_driven_steps_match_the_portable_loop() {
        let string = treble_string();
        let step = StepTable::new(&string, 1.0 / 96_000.0);
        let mut start = ModalBank::new(&string);
        for i in 0..start.len() {
            start.add_velocity(i, 1.0 / (i + 1) as f64);
        }
        let gain: Vec<f64> = (0..start.len()).map(|i| (i as f64).cos()).collect();
        let drive = DriveTable::new(&step, Hold::End, start.weights(), &gain, &gain);
        type Kernel = fn(x86::Driven<'_>, f64) -> Option<(f64, f64)>;
        let kernels: [(&str, bool, Kernel); 2] = [
            ("avx512", is_x86_feature_detected!("avx512f"), |d, u| unsafe { x86::driven_avx512(d, u) }),
            ("avx2", is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"), |d, u| unsafe {
                x86::driven_avx2(d, u)
            }),
        ];
        for (name, available, kernel) in kernels {
            if !available {
                continue;
            }
            let (mut a, mut b) = (start.clone(), start.clone());
            for k in 0..50 {
                let input = 0.1 * (k as f64).sin();
                let portable = driven_step(
                    &mut a.re,
                    &mut a.im,
                    &step.pole_re,
                    &step.pole_im,
                    &drive.carry_re,
                    &drive.carry_im,
                    &drive.observe,
                    input,
                );
                let d = x86::Driven::of(&mut b.re, &mut b.im, &step, &drive);
                let vector = kernel(d, input).expect("slices that fit");
                assert_eq!(portable.1.to_bits(), vector.1.to_bits(), "{name}: bridge force at step {k}");
                assert!((portable.0 - vector.0).abs() <= 1e-12 * portable.0.abs().max(1e-30), "{name}: observation");
            }
            assert_eq!(a.re, b.re, "{name}");
            assert_eq!(a.im, b.im, "{name}");
        }
    }
}
