//! A hammer set up at one strike point of one string: its tables for every step
//! size, and the strike in progress, stepped together with the string's modes.
//!
//! Between contacts the string takes full exact steps with no force. A full step
//! that turns out to end in contact is taken back
//! ([`ModalBank::undo_free_step`]) and redone in sub-steps, each with the felt's
//! force solved implicitly ([`super::contact`]) and held over the sub-step at its
//! energy-consistent mean ([`Hold::End`]). The force of a sub-step is found after
//! the pass over the modes, so the bank keeps each step's state without the
//! response to its own force and carries it into the next pass ([`DriveTable`]).
//! Sub-stepping ends once no force has acted for the hold (100 us: micro-gaps of a
//! chattering stiff contact are shorter).
//!
//! The string at the strike point is the kept modes, y = y_hat + G F, plus the
//! omitted modes' residual displacement r, a spring R in parallel with a dashpot c
//! ([`crate::string::residual`]) integrated exactly over the step:
//!
//!   r(h) = a r(0) + (1 - a) R F,  a = exp(-h / (c R)).
//!
//! The bridge force is B_hat + G_b F + S r / R, S being the omitted modes' static
//! share per newton. Every joule is accounted for: what the hammer loses is in the
//! kept modes, the felt, the residual spring, or taken up by the omitted modes.

use super::contact::{Binomial, ContactStep, Felt, Guess, LastPower};
use super::hysteresis::Memory;
use super::{Hammer, HammerSpec};
use crate::exciter::{ContactObserver, Tick, drive_table};
use crate::modal_bank::{DriveTable, Hold, Kernel, ModalBank, StepTable};
use crate::string::StringModes;
use crate::string::residual::Residual;

/// A sub-step size the string is stepped at while a hammer is near: its count
/// per sample and the string's exact step over it (the string owns these; every
/// hammer on it uses them).
#[derive(Clone)]
pub struct Substep {
    pub substeps: usize,
    pub step: StepTable,
}

/// What a hammer needs for one sub-step size.
#[derive(Clone, PartialEq)]
struct FineDrive {
    drive: DriveTable,
    /// The residual's exp(-h / (c R)) over the sub-step.
    relax: f64,
}

/// What a hammer at one strike point needs, for every step size.
#[derive(Clone, PartialEq)]
struct HammerTables {
    position: f64,
    audio: DriveTable,
    /// One per entry of the string's [`Substep`]s.
    fine: Vec<FineDrive>,
    residual: Residual,
}

/// A strike in progress: the moving hammer and where its contact stands.
#[derive(Clone)]
struct Strike {
    hammer: Hammer,
    /// Displacement of the omitted modes at the strike point, m.
    residual_m: f64,
    /// Felt compression at the end of the last step, m.
    compression_m: f64,
    /// The felt there (force and energy: where the next solve starts).
    felt: Felt,
    /// Force held over the last step (carried into the next pass), N.
    force_n: f64,
    /// ... and over the four steps before it (to guess the next), N.
    earlier_force_n: [f64; 4],
    /// The compressions at the ends of the two steps before the last, m.
    earlier_compression_m: [f64; 2],
    /// The felt law's [`super::ContactLaw::binomial`].
    binomial: Binomial,
    /// Where the felt's power was last taken.
    last_power: LastPower,
    /// The felt's memory, if it has hysteresis (None: elastic).
    memory: Option<Memory>,
    /// Energy taken up by the omitted modes' dashpot so far, J.
    absorbed_j: f64,
    /// The sub-step size of this strike (an index into the string's [`Substep`]s).
    fine: usize,
    substepping: bool,
    quiet_samples: usize,
    time_s: f64,
    /// Proved unable to touch the string again ([`HammerRig::clear`]) at the
    /// last control tick: the string turns freely while the hammer flies on
    /// ([`HammerRig::coast`]).
    coasting: bool,
}

impl Strike {
    /// `samples` audio samples with nothing touching, after the hammer's
    /// flight: the omitted modes relax to `residual_m` (their dashpot taking
    /// the difference) and the felt's memory fades.
    fn relax_free(&mut self, residual: &Residual, samples: usize, residual_m: f64) {
        self.absorbed_j += residual.energy_j(self.residual_m) - residual.energy_j(residual_m);
        self.residual_m = residual_m;
        if let Some(memory) = self.memory.as_mut() {
            memory.relax_free_for(samples);
        }
    }

    /// One sample `h` of the hammer's free flight.
    fn fly(&mut self, h: f64) {
        self.hammer.commit(h, self.hammer.predict_m(h), 0.0);
        self.time_s += h;
    }
}

/// A hammer's tables at one strike point, and its strike while one is in play.
#[derive(Clone)]
pub struct HammerRig {
    tables: HammerTables,
    strike: Option<Strike>,
    /// The modes' shapes at the strike point (kept to move it without allocating).
    shape: Vec<f64>,
}

impl HammerRig {
    /// The tables for a hammer striking `string` (stepped by `bank`) at `position`
    /// (fraction of the length), for the audio step and every sub-step. Allocates.
    pub fn new(string: &StringModes, bank: &ModalBank, audio: &StepTable, fine: &[Substep], position: f64) -> Self {
        let shape: Vec<f64> = string.modes.iter().map(|m| string.shape_at(m, position)).collect();
        let m = string.modal_mass_kg();
        let audio_drive = drive_table(bank, audio, Hold::End, |i| shape[i] / m, |i| shape[i]);
        let residual = Residual::new(string, position, audio.step_s);
        let fine = fine
            .iter()
            .map(|f| FineDrive {
                drive: drive_table(bank, &f.step, Hold::End, |i| shape[i] / m, |i| shape[i]),
                relax: residual.relax(f.step.step_s),
            })
            .collect();
        Self { tables: HammerTables { position, audio: audio_drive, fine, residual }, strike: None, shape }
    }

    /// The same tables for striking at `position` instead, in place (the
    /// string, bank and step sizes those were made for). Allocates: no.
    pub fn move_to(
        &mut self,
        string: &StringModes,
        bank: &ModalBank,
        audio: &StepTable,
        fine: &[Substep],
        position: f64,
    ) {
        if position == self.tables.position {
            return;
        }
        let m = string.modal_mass_kg();
        for (s, mode) in self.shape.iter_mut().zip(&string.modes) {
            *s = string.shape_at(mode, position);
        }
        let (shape, modes) = (&self.shape, self.shape.len());
        self.tables.audio.refill(audio, Hold::End, bank.weights(), modes, |i| shape[i] / m, |i| shape[i]);
        let residual = Residual::new(string, position, audio.step_s);
        for (table, f) in self.tables.fine.iter_mut().zip(fine) {
            table.drive.refill(&f.step, Hold::End, bank.weights(), modes, |i| shape[i] / m, |i| shape[i]);
            table.relax = residual.relax(f.step.step_s);
        }
        self.tables.residual = residual;
        self.tables.position = position;
    }

    /// The strike point, as a fraction of the length from the bridge.
    pub fn position(&self) -> f64 {
        self.tables.position
    }

    /// Whether its tables are `other`'s, to the bit.
    #[cfg(test)]
    pub(crate) fn same_tables(&self, other: &Self) -> bool {
        self.tables == other.tables && self.shape == other.shape
    }

    /// Whether a strike is in play.
    pub fn in_play(&self) -> bool {
        self.strike.is_some()
    }

    /// Throw a hammer at the string as it is now, sub-stepped at the string's
    /// sub-step size `fine` (an index), which is `substep_s` long within samples
    /// of `sample_s` (the felt's memory, if any, is weighted for both). Allocates: no.
    pub fn throw(&mut self, bank: &ModalBank, spec: HammerSpec, fine: usize, substep_s: f64, sample_s: f64) {
        debug_assert_eq!(spec.position, self.tables.position);
        let touching_at_m = bank.observe(&self.tables.audio);
        self.strike = Some(Strike {
            hammer: Hammer::thrown(spec, touching_at_m),
            residual_m: 0.0,
            compression_m: 0.0,
            felt: Felt::default(),
            force_n: 0.0,
            earlier_force_n: [0.0; 4],
            earlier_compression_m: [0.0; 2],
            binomial: spec.law.binomial(),
            last_power: LastPower::default(),
            memory: Memory::new(spec.hysteresis, substep_s, sample_s),
            absorbed_j: 0.0,
            fine,
            substepping: true,
            quiet_samples: 0,
            time_s: 0.0,
            coasting: false,
        });
    }

    /// Let the hammer go: the bank gets back its "force applied" form. Allocates: no.
    pub fn release(&mut self, bank: &mut ModalBank) {
        if let Some(d) = self.strike.take()
            && d.substepping
        {
            bank.apply_ramp(&self.tables.fine[d.fine].drive, d.force_n);
        }
    }

    /// Forget the strike without touching the modes (they were reset or replaced).
    pub fn forget(&mut self) {
        self.strike = None;
    }

    /// The hammer, while a strike is in play.
    pub fn hammer(&self) -> Option<&Hammer> {
        self.strike.as_ref().map(|d| &d.hammer)
    }

    /// Whether the hammer is in or near contact (the string is being sub-stepped).
    pub fn in_contact(&self) -> bool {
        self.strike.as_ref().is_some_and(|d| d.substepping)
    }

    /// Energy the omitted modes have taken from this strike's contacts, J.
    pub fn absorbed_j(&self) -> f64 {
        self.strike.as_ref().map_or(0.0, |d| d.absorbed_j)
    }

    /// Whether the hammer has left the string: flying away, at least `gap_m` below
    /// it, for at least `after_s` since the strike.
    pub fn gone(&self, gap_m: f64, after_s: f64) -> bool {
        self.strike.as_ref().is_some_and(|h| {
            !h.substepping && h.time_s >= after_s && h.hammer.velocity_m_s < 0.0 && h.compression_m < -gap_m
        })
    }

    /// Whether the hammer can never touch the string again if both move freely
    /// (see [`crate::struck_string::StruckString::hammer_clear`]).
    pub fn clear(&self, bank: &ModalBank) -> bool {
        let Some(h) = &self.strike else { return false };
        if h.substepping || !(h.hammer.velocity_m_s < 0.0) || !(h.compression_m < 0.0) {
            return false;
        }
        let reach_m = bank.observe_bound(&self.tables.audio) + h.residual_m.abs();
        h.hammer.position_m + reach_m < 0.0
    }

    /// Whether the hammer flies clear of its string, which then turns freely
    /// ([`Self::coast`]).
    pub fn coasting(&self) -> bool {
        self.strike.as_ref().is_some_and(|d| d.coasting)
    }

    /// At a control tick, with `bank` up to date: bring a coasting strike's
    /// compression up to date, then let the string turn freely from here if
    /// the hammer can never touch it again ([`Self::clear`]), or step it
    /// sample by sample again if it can (a drive through the bridge may have
    /// moved it). The hammer stays in play until it is let go, as before: only
    /// how the string is stepped changes, not what it does. Allocates: no.
    pub fn watch(&mut self, bank: &ModalBank) {
        let t = &self.tables;
        let Some(d) = self.strike.as_mut() else { return };
        if d.coasting {
            d.compression_m = d.hammer.position_m - bank.observe(&t.audio) - d.residual_m;
            d.felt = Felt { compression_m: d.compression_m, force_n: 0.0, energy_j: 0.0 };
        }
        let clear = self.clear(bank);
        if let Some(d) = self.strike.as_mut() {
            d.coasting = clear;
        }
    }

    /// `h`-second samples, `out.len()` of them, of a coasting hammer: what
    /// [`Self::tick`] does while nothing touches, but for the string's own
    /// steps, which run freely elsewhere: the hammer flies on, the omitted
    /// modes' relaxing share of the bridge force goes to `out` while any is
    /// left, and the felt's memory fades once for the stretch. Allocates: no.
    pub fn coast(&mut self, h: f64, out: &mut [f64]) {
        let t = &self.tables;
        let Some(d) = self.strike.as_mut().filter(|d| d.coasting) else { return };
        let mut residual_m = d.residual_m;
        for o in out.iter_mut() {
            // (The flight sample by sample: where stepping the string sample
            // by sample would put the hammer, to the bit.)
            d.fly(h);
            if residual_m != 0.0 {
                residual_m *= t.residual.relax_audio;
                *o += t.residual.bridge_force_n(residual_m);
            }
        }
        d.relax_free(&t.residual, out.len(), residual_m);
    }

    /// The present state without stepping (a strike in play).
    pub fn current(&self, bank: &ModalBank) -> Option<Tick> {
        let d = self.strike.as_ref()?;
        let t = &self.tables;
        let (drive, force) = if d.substepping { (&t.fine[d.fine].drive, d.force_n) } else { (&t.audio, 0.0) };
        let elastic_n = d.hammer.spec.law.force_n(d.compression_m);
        Some(Tick {
            contact_force_n: d.memory.as_ref().map_or(elastic_n, |m| m.force_at(elastic_n)),
            bridge_force_n: bank.bridge_force_n()
                + drive.bridge_per_input * force
                + t.residual.bridge_force_n(d.residual_m),
            exciter_position_m: Some(d.hammer.position_m),
            string_position_m: bank.observe(drive) + drive.observe_per_input * force + d.residual_m,
        })
    }

    /// Advance one sample with the strike in play, telling `observer` about every
    /// (sub)step; None (nothing done) when no strike is in play.
    ///
    /// Compiled for AVX-512 and for AVX2 with FMA as well as for the baseline,
    /// the one the machine runs chosen here: the felt's solve is scalar code,
    /// one long chain of dependent operations with many values alive, and the
    /// baseline's SSE2 spends much of a sub-step copying and spilling them.
    /// The arithmetic is the same in every version (nothing fused that the
    /// source does not fuse), so are the bits.
    ///
    /// Allocates: no.
    pub fn tick(
        &mut self,
        bank: &mut ModalBank,
        audio: &StepTable,
        fine: &[Substep],
        hold_samples: usize,
        observer: &mut impl ContactObserver,
    ) -> Option<Tick> {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx512f") && is_x86_feature_detected!("avx512vl") {
                // SAFETY: the features the version is compiled for were detected just above.
                return unsafe { self.tick_avx512(bank, audio, fine, hold_samples, observer) };
            }
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                // SAFETY: as above.
                return unsafe { self.tick_avx2(bank, audio, fine, hold_samples, observer) };
            }
        }
        self.tick_inline(Kernel::detected(), bank, audio, fine, hold_samples, observer)
    }

    /// [`Self::tick`] for AVX-512 (its 32 registers).
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx512f,avx512vl,avx2,fma")]
    fn tick_avx512(
        &mut self,
        bank: &mut ModalBank,
        audio: &StepTable,
        fine: &[Substep],
        hold_samples: usize,
        observer: &mut impl ContactObserver,
    ) -> Option<Tick> {
        self.tick_inline(Kernel::Avx512, bank, audio, fine, hold_samples, observer)
    }

    /// [`Self::tick`] for AVX2 with FMA.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx2,fma")]
    pub(crate) fn tick_avx2(
        &mut self,
        bank: &mut ModalBank,
        audio: &StepTable,
        fine: &[Substep],
        hold_samples: usize,
        observer: &mut impl ContactObserver,
    ) -> Option<Tick> {
        self.tick_inline(Kernel::Avx2, bank, audio, fine, hold_samples, observer)
    }

    /// [`Self::tick`]'s body, inlined into each version, the driven step's
    /// `kernel` with it (the baseline's, for tests that compare them, with
    /// [`Kernel::detected`]).
    #[inline(always)]
    pub(crate) fn tick_inline(
        &mut self,
        kernel: Kernel,
        bank: &mut ModalBank,
        audio: &StepTable,
        fine: &[Substep],
        hold_samples: usize,
        observer: &mut impl ContactObserver,
    ) -> Option<Tick> {
        let t = &self.tables;
        let d = self.strike.as_mut()?;
        if !d.substepping {
            // The force is zero: a free step, unless it ends in contact.
            let h = audio.step_s;
            let (y_hat, bridge_hat) = bank.step_driven(audio, &t.audio, 0.0);
            let eta_hat = d.hammer.predict_m(h);
            let residual_m = t.residual.relax_audio * d.residual_m;
            let compression_m = eta_hat - y_hat - residual_m;
            if compression_m <= 0.0 {
                d.fly(h);
                d.relax_free(&t.residual, 1, residual_m);
                d.compression_m = compression_m;
                d.felt = Felt { compression_m, force_n: 0.0, energy_j: 0.0 };
                observer.step(d.time_s, compression_m, 0.0);
                return Some(Tick {
                    contact_force_n: 0.0,
                    bridge_force_n: bridge_hat + t.residual.bridge_force_n(residual_m),
                    exciter_position_m: Some(eta_hat),
                    string_position_m: y_hat + residual_m,
                });
            }
            // This sample runs into the string: redo it finely.
            bank.undo_free_step(audio);
            d.substepping = true;
            d.quiet_samples = 0;
        }
        let Substep { substeps, step: ref sub } = fine[d.fine];
        let FineDrive { drive: ref t_sub, relax } = t.fine[d.fine];
        let h = sub.step_s;
        let compliance =
            d.hammer.compliance_m_n(h) + t_sub.observe_per_input + (1.0 - relax) * t.residual.compliance_m_n;
        let mut any_force = false;
        let mut tick = Tick::default();
        for _ in 0..substeps {
            // SAFETY: `kernel` is one the machine has (see `Self::tick`).
            let (y_hat, bridge_hat) = unsafe { bank.step_driven_by(kernel, sub, t_sub, d.force_n) };
            let eta_hat = d.hammer.predict_m(h);
            let c_hat = eta_hat - y_hat - relax * d.residual_m;
            // The courses of force and compression so far, carried on by a quartic
            // through the last five forces and a parabola through the last three
            // compressions, are the solve's guesses (the compression's, where the
            // felt's series is anchored, does not wait on this pass). The force's
            // ripple from the string's high modes limits either: the quartic's
            // lands about three times nearer than a parabola's.
            let [f1, f2, f3, f4] = d.earlier_force_n;
            let [c1, c2] = d.earlier_compression_m;
            let guess = Guess {
                force_n: 5.0 * (d.force_n - f3) - 10.0 * (f1 - f2) + f4,
                compression_m: 3.0 * (d.compression_m - c1) + c2,
                binomial: &d.binomial,
                last_power: &d.last_power,
            };
            let law = &d.hammer.spec.law;
            let (ContactStep { compression_m, step_force_n: force, .. }, felt) = match d.memory.as_mut() {
                None => law.step_inline(d.felt, c_hat, compliance, Some(guess)),
                Some(memory) => memory.step(law, d.felt, c_hat, compliance, Some(guess)),
            };
            d.earlier_force_n = [d.force_n, f1, f2, f3];
            d.earlier_compression_m = [d.compression_m, c1];
            d.felt = felt;
            d.hammer.commit(h, eta_hat, force);
            let residual_m = relax * d.residual_m + (1.0 - relax) * t.residual.compliance_m_n * force;
            // Work done on the residual, less what its spring now holds, went into its dashpot.
            d.absorbed_j += force * (residual_m - d.residual_m) - t.residual.energy_j(residual_m)
                + t.residual.energy_j(d.residual_m);
            d.residual_m = residual_m;
            d.compression_m = compression_m;
            d.force_n = force;
            d.time_s += h;
            any_force |= force > 0.0;
            let felt_force_n = d.memory.as_ref().map_or(felt.force_n, |m| m.force_at(felt.force_n));
            observer.step(d.time_s, compression_m, felt_force_n);
            tick = Tick {
                contact_force_n: felt_force_n,
                bridge_force_n: bridge_hat + t_sub.bridge_per_input * force + t.residual.bridge_force_n(residual_m),
                exciter_position_m: Some(d.hammer.position_m),
                string_position_m: y_hat + t_sub.observe_per_input * force + residual_m,
            };
        }
        if any_force {
            d.quiet_samples = 0;
        } else {
            d.quiet_samples += 1;
            // No force over the whole sample: the carried force is zero, so the
            // bank's state is complete and full steps can resume.
            if d.quiet_samples >= hold_samples {
                d.substepping = false;
            }
        }
        Some(tick)
    }
}
