//! The state of one string's modes ([`ModalBank`]) and everything done to it:
//! set and read mode by mode, kicked, culled, and stepped freely or driven by an
//! exciter through the inner loops of the kernels room.

use num_complex::Complex64;

use super::kernels::{
    Kernel, add_scaled, driven_step, free_block, free_sample_kicked, lane_sum, lane_sum_all, observe_through, undo_step,
};
#[cfg(target_arch = "x86_64")]
use super::x86;
use super::{DriveTable, FREE_BLOCK, FreeGather, LANES, Poles, StepTable, padded};
use crate::string::StringModes;

/// The state of a string's modes.
#[derive(Clone, Debug)]
pub struct ModalBank {
    len: usize,
    pub(super) re: Vec<f64>,
    pub(super) im: Vec<f64>,
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

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modal_bank::Hold;
    use crate::modal_bank::test_strings::{one_mode, treble_string};
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
}
