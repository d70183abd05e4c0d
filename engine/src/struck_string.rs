//! One string and whatever is exciting it: the unit the lab runs and a key will own.
//!
//! Per audio sample the string advances by one exact modal step. While a hammer
//! is in or near contact, the string and hammer advance instead in `substeps`
//! equal sub-steps, each with the contact force solved implicitly
//! ([`crate::contact`]); the coefficient sets for both step sizes are built when
//! the exciter is set up. A full step that turns out to end in contact is taken
//! back ([`ModalBank::undo_free_step`]) and redone in sub-steps; sub-stepping
//! ends once no force has acted for 100 us (micro-gaps of a chattering stiff
//! contact are shorter).
//!
//! Each (sub)step is one pass over the modes. The force of a step is found after
//! that pass, so the bank keeps each step's state without the response to its
//! own force (b F) and carries it into the next pass (`p b`, see [`DriveTable`]).
//! A hammer's force is held over each step at the felt's energy-consistent mean
//! ([`crate::contact`]; [`Hold::End`]); a tangent's prescribed acceleration is
//! interpolated linearly ([`Hold::Linear`]). The string at the contact point is
//! the kept modes, y = y_hat + G F, plus the omitted modes' residual displacement
//! r, a spring R in parallel with a dashpot c ([`crate::residual`]) integrated
//! exactly over the step:
//!
//!   r(h) = a r(0) + (1 - a) R F,  a = exp(-h / (c R)).
//!
//! The bridge force is B_hat + G_b F + S r / R, S being the omitted modes' static
//! share per newton. Every joule is accounted for: what the hammer loses is in
//! the kept modes, the felt, the residual spring, or taken up by the omitted modes.
//!
//! Striking again continues from the string's present state.

use crate::contact::ContactStep;
use crate::hammer::{Hammer, HammerSpec};
use crate::modal_bank::{DriveTable, Hold, ModalBank, StepTable};
use crate::pluck::PluckSpec;
use crate::residual;
use crate::string::StringModes;
use crate::tangent::TangentSpec;

/// Sub-steps per sample while a hammer is in or near contact (engine-numerics 2).
pub const DEFAULT_SUBSTEPS: usize = 8;

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

/// The omitted modes as seen from the strike point.
struct Residual {
    /// Static compliance R, m/N.
    compliance_m_n: f64,
    /// Static share of the bridge force per newton, S.
    bridge_share: f64,
    /// exp(-h / (c R)) for a sample and for a sub-step.
    relax_audio: f64,
    relax_sub: f64,
}

impl Residual {
    fn new(string: &StringModes, position: f64, sample_s: f64, substeps: usize) -> Self {
        let compliance_m_n = residual::omitted_compliance_m_n(string, position);
        let time_constant_s = residual::omitted_damping_ns_m(string, position) * compliance_m_n;
        let relax = |h: f64| if time_constant_s > 0.0 { (-h / time_constant_s).exp() } else { 0.0 };
        Self {
            compliance_m_n,
            bridge_share: residual::omitted_bridge_share(string, position),
            relax_audio: relax(sample_s),
            relax_sub: relax(sample_s / substeps as f64),
        }
    }

    /// Static bridge force of a residual displacement, N.
    fn bridge_force_n(&self, displacement_m: f64) -> f64 {
        if self.compliance_m_n > 0.0 { self.bridge_share * displacement_m / self.compliance_m_n } else { 0.0 }
    }

    /// Energy in the residual spring, J.
    fn energy_j(&self, displacement_m: f64) -> f64 {
        if self.compliance_m_n > 0.0 { displacement_m * displacement_m / (2.0 * self.compliance_m_n) } else { 0.0 }
    }
}

struct HammerDrive {
    hammer: Hammer,
    audio: DriveTable,
    sub: DriveTable,
    residual: Residual,
    /// Displacement of the omitted modes at the strike point, m.
    residual_m: f64,
    /// Felt compression at the end of the last step, m.
    compression_m: f64,
    /// Force held over the last step (carried into the next pass), N.
    force_n: f64,
    /// Energy taken up by the omitted modes' dashpot so far, J.
    absorbed_j: f64,
    substepping: bool,
    quiet_samples: usize,
    time_s: f64,
}

struct TangentDrive {
    spec: TangentSpec,
    /// exp(-t V0 / D) now, advanced by `decay_per_sample` each sample (zero once negligible).
    remaining: f64,
    decay_per_sample: f64,
    drive: DriveTable,
    /// Omitted modes' static share of the force at the tangent and at the bridge, per unit z''.
    residual_tangent_kg: f64,
    residual_bridge_kg: f64,
    acceleration_m_s2: f64,
}

struct PluckDrive {
    drive: DriveTable,
}

enum Exciter {
    None,
    Hammer(Box<HammerDrive>),
    Tangent(Box<TangentDrive>),
    Pluck(Box<PluckDrive>),
}

/// A string with its modes, its exciter, and the coefficients for both step sizes.
pub struct StruckString {
    string: StringModes,
    bank: ModalBank,
    audio: StepTable,
    sub: StepTable,
    substeps: usize,
    hold_samples: usize,
    exciter: Exciter,
}

impl StruckString {
    /// A string at rest, stepped at `sample_rate_hz` with `substeps` sub-steps per
    /// sample during contact. Allocates.
    pub fn new(string: StringModes, sample_rate_hz: f64, substeps: usize) -> Self {
        let substeps = substeps.max(1);
        let h = 1.0 / sample_rate_hz;
        let bank = ModalBank::new(&string);
        let audio = StepTable::new(&string, h);
        let sub = StepTable::new(&string, h / substeps as f64);
        // Stay sub-stepped through force-free gaps up to 100 us: a stiff contact
        // chatters with micro-separations of tens of microseconds.
        let hold_samples = ((100e-6 * sample_rate_hz).ceil() as usize).max(2);
        Self { string, bank, audio, sub, substeps, hold_samples, exciter: Exciter::None }
    }

    pub fn string(&self) -> &StringModes {
        &self.string
    }

    pub fn bank(&self) -> &ModalBank {
        &self.bank
    }

    /// Give the bank back its "force applied" form before the exciter changes.
    fn settle_exciter(&mut self) {
        match &self.exciter {
            Exciter::Hammer(d) if d.substepping => self.bank.apply_ramp(&d.sub, d.force_n),
            Exciter::Tangent(d) => self.bank.apply_ramp(&d.drive, d.acceleration_m_s2),
            _ => {}
        }
        self.exciter = Exciter::None;
    }

    fn drive_at(
        &self,
        step: &StepTable,
        hold: Hold,
        gain: impl Fn(usize) -> f64,
        observe: impl Fn(usize) -> f64,
    ) -> DriveTable {
        let gains: Vec<f64> = (0..self.bank.len()).map(&gain).collect();
        let observes: Vec<f64> = (0..self.bank.len()).map(&observe).collect();
        DriveTable::new(step, hold, self.bank.weights(), &gains, &observes)
    }

    /// Throw a hammer at the string as it is now. Allocates (builds the drive tables).
    pub fn strike(&mut self, spec: HammerSpec) {
        self.settle_exciter();
        let s = &self.string;
        let shape: Vec<f64> = s.modes.iter().map(|m| s.shape_at(m, spec.position)).collect();
        let m = s.modal_mass_kg();
        let audio = self.drive_at(&self.audio, Hold::End, |i| shape[i] / m, |i| shape[i]);
        let sub = self.drive_at(&self.sub, Hold::End, |i| shape[i] / m, |i| shape[i]);
        let touching_at_m = self.bank.observe(&audio);
        self.exciter = Exciter::Hammer(Box::new(HammerDrive {
            hammer: Hammer::thrown(spec, touching_at_m),
            audio,
            sub,
            residual: Residual::new(s, spec.position, self.audio.step_s, self.substeps),
            residual_m: 0.0,
            compression_m: 0.0,
            force_n: 0.0,
            absorbed_j: 0.0,
            substepping: true,
            quiet_samples: 0,
            time_s: 0.0,
        }));
    }

    /// Press a tangent into the string's far end (x = L), the string at rest there.
    /// The tangent stays until another exciter replaces it; the string's end then
    /// returns to rest at once (a key's release through the felt comes with the keys).
    pub fn press_tangent(&mut self, spec: TangentSpec) {
        self.settle_exciter();
        let s = &self.string;
        let gains: Vec<f64> = s.modes.iter().map(|m| TangentSpec::modal_gain(m.number)).collect();
        let weights = self.bank.weights().to_vec();
        let sign = |i: usize| if s.modes[i].number.is_multiple_of(2) { 1.0 } else { -1.0 };
        let drive = self.drive_at(&self.audio, Hold::Linear, |i| gains[i], |i| sign(i) * weights[i]);
        for (i, g) in gains.iter().enumerate() {
            self.bank.add_velocity(i, g * spec.speed_m_s);
        }
        let acceleration_m_s2 = spec.acceleration_m_s2(0.0);
        self.bank.apply_ramp(&drive, -acceleration_m_s2);
        let (residual_tangent_kg, residual_bridge_kg) = residual::omitted_tangent_shares_kg(s);
        self.exciter = Exciter::Tangent(Box::new(TangentDrive {
            spec,
            remaining: 1.0,
            decay_per_sample: (-self.audio.step_s / spec.time_constant_s()).exp(),
            drive,
            residual_tangent_kg,
            residual_bridge_kg,
            acceleration_m_s2,
        }));
    }

    /// Pull the string aside into a triangle and let go (adds to its present state).
    pub fn pluck(&mut self, spec: PluckSpec) {
        self.settle_exciter();
        let s = &self.string;
        for (i, mode) in s.modes.iter().enumerate() {
            self.bank.add_displacement(i, spec.modal_displacement_m(mode.number));
        }
        let shape: Vec<f64> = s.modes.iter().map(|m| s.shape_at(m, spec.position)).collect();
        let drive = self.drive_at(&self.audio, Hold::Linear, |_| 0.0, |i| shape[i]);
        self.exciter = Exciter::Pluck(Box::new(PluckDrive { drive }));
    }

    /// The present state, without stepping.
    pub fn current(&self) -> Tick {
        let bridge = self.bank.bridge_force_n();
        match &self.exciter {
            Exciter::None => Tick { bridge_force_n: bridge, ..Tick::default() },
            Exciter::Hammer(d) => {
                let (drive, force) = if d.substepping { (&d.sub, d.force_n) } else { (&d.audio, 0.0) };
                Tick {
                    contact_force_n: d.hammer.spec.law.force_n(d.compression_m),
                    bridge_force_n: bridge + drive.bridge_per_input * force + d.residual.bridge_force_n(d.residual_m),
                    exciter_position_m: Some(d.hammer.position_m),
                    string_position_m: self.bank.observe(drive) + drive.observe_per_input * force + d.residual_m,
                }
            }
            Exciter::Tangent(d) => {
                let a = d.acceleration_m_s2;
                let z = d.spec.displacement_m * (1.0 - d.remaining);
                let line = self.string.tension_n * z / self.string.length_m;
                Tick {
                    contact_force_n: self.bank.observe(&d.drive)
                        + (d.drive.observe_per_input + d.residual_tangent_kg) * a
                        + line,
                    bridge_force_n: bridge + (d.drive.bridge_per_input + d.residual_bridge_kg) * a + line,
                    exciter_position_m: Some(z),
                    string_position_m: z,
                }
            }
            Exciter::Pluck(d) => Tick {
                contact_force_n: 0.0,
                bridge_force_n: bridge,
                exciter_position_m: None,
                string_position_m: self.bank.observe(&d.drive),
            },
        }
    }

    /// Advance one sample and report it.
    pub fn tick(&mut self) -> Tick {
        self.tick_observed(&mut ())
    }

    /// Advance one sample, telling `observer` about every (sub)step of a hammer.
    pub fn tick_observed(&mut self, observer: &mut impl ContactObserver) -> Tick {
        match &mut self.exciter {
            Exciter::None => {
                let mut out = [0.0];
                self.bank.process_free(&self.audio, &mut out);
                Tick { bridge_force_n: out[0], ..Tick::default() }
            }
            Exciter::Hammer(d) => {
                Self::tick_hammer(&mut self.bank, &self.audio, &self.sub, self.substeps, self.hold_samples, d, observer)
            }
            Exciter::Tangent(d) => {
                let (string, bank, step) = (&self.string, &mut self.bank, &self.audio);
                let (end_hat, bridge_hat) = bank.step_driven(step, &d.drive, d.acceleration_m_s2);
                // Below 1e-17 the tangent has arrived: stop before denormals.
                d.remaining = if d.remaining > 1e-17 { d.remaining * d.decay_per_sample } else { 0.0 };
                let a = d.spec.acceleration_m_s2(0.0) * d.remaining;
                d.acceleration_m_s2 = a;
                let z = d.spec.displacement_m * (1.0 - d.remaining);
                let line = string.tension_n * z / string.length_m;
                Tick {
                    contact_force_n: end_hat + (d.drive.observe_per_input + d.residual_tangent_kg) * a + line,
                    bridge_force_n: bridge_hat + (d.drive.bridge_per_input + d.residual_bridge_kg) * a + line,
                    exciter_position_m: Some(z),
                    string_position_m: z,
                }
            }
            Exciter::Pluck(d) => {
                let (y, bridge) = self.bank.step_driven(&self.audio, &d.drive, 0.0);
                Tick { contact_force_n: 0.0, bridge_force_n: bridge, exciter_position_m: None, string_position_m: y }
            }
        }
    }

    fn tick_hammer(
        bank: &mut ModalBank,
        audio: &StepTable,
        sub: &StepTable,
        substeps: usize,
        hold_samples: usize,
        d: &mut HammerDrive,
        observer: &mut impl ContactObserver,
    ) -> Tick {
        if !d.substepping {
            // The force is zero: a free step, unless it ends in contact.
            let h = audio.step_s;
            let (y_hat, bridge_hat) = bank.step_driven(audio, &d.audio, 0.0);
            let eta_hat = d.hammer.predict_m(h);
            let residual_m = d.residual.relax_audio * d.residual_m;
            let compression_m = eta_hat - y_hat - residual_m;
            if compression_m <= 0.0 {
                d.hammer.commit(h, eta_hat, 0.0);
                d.absorbed_j += d.residual.energy_j(d.residual_m) - d.residual.energy_j(residual_m);
                d.residual_m = residual_m;
                d.compression_m = compression_m;
                d.time_s += h;
                observer.step(d.time_s, compression_m, 0.0);
                return Tick {
                    contact_force_n: 0.0,
                    bridge_force_n: bridge_hat + d.residual.bridge_force_n(residual_m),
                    exciter_position_m: Some(eta_hat),
                    string_position_m: y_hat + residual_m,
                };
            }
            // This sample runs into the string: redo it finely.
            bank.undo_free_step(audio);
            d.substepping = true;
            d.quiet_samples = 0;
        }
        let h = sub.step_s;
        let relax = d.residual.relax_sub;
        let compliance =
            d.hammer.compliance_m_n(h) + d.sub.observe_per_input + (1.0 - relax) * d.residual.compliance_m_n;
        let mut any_force = false;
        let mut tick = Tick::default();
        for _ in 0..substeps {
            let (y_hat, bridge_hat) = bank.step_driven(sub, &d.sub, d.force_n);
            let eta_hat = d.hammer.predict_m(h);
            let c_hat = eta_hat - y_hat - relax * d.residual_m;
            let ContactStep { compression_m, step_force_n: force, .. } =
                d.hammer.spec.law.solve(d.compression_m, c_hat, compliance);
            d.hammer.commit(h, eta_hat, force);
            let residual_m = relax * d.residual_m + (1.0 - relax) * d.residual.compliance_m_n * force;
            // Work done on the residual, less what its spring now holds, went into its dashpot.
            d.absorbed_j += force * (residual_m - d.residual_m) - d.residual.energy_j(residual_m)
                + d.residual.energy_j(d.residual_m);
            d.residual_m = residual_m;
            d.compression_m = compression_m;
            d.force_n = force;
            d.time_s += h;
            any_force |= force > 0.0;
            let felt_force_n = d.hammer.spec.law.force_n(compression_m);
            observer.step(d.time_s, compression_m, felt_force_n);
            tick = Tick {
                contact_force_n: felt_force_n,
                bridge_force_n: bridge_hat + d.sub.bridge_per_input * force + d.residual.bridge_force_n(residual_m),
                exciter_position_m: Some(d.hammer.position_m),
                string_position_m: y_hat + d.sub.observe_per_input * force + residual_m,
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
        tick
    }

    /// Whether a hammer is in or near contact (the string is being sub-stepped).
    pub fn in_contact(&self) -> bool {
        matches!(&self.exciter, Exciter::Hammer(d) if d.substepping)
    }

    /// The hammer, if one is in play.
    pub fn hammer(&self) -> Option<&Hammer> {
        match &self.exciter {
            Exciter::Hammer(d) => Some(&d.hammer),
            _ => None,
        }
    }

    /// Energy in the kept modes, J (exact between contacts; during contact it
    /// leaves out the response to the step's own force).
    pub fn string_energy_j(&self) -> f64 {
        self.bank.energy_j()
    }

    /// Energy the omitted modes have taken from the present hammer's contacts, J.
    pub fn absorbed_by_omitted_modes_j(&self) -> f64 {
        match &self.exciter {
            Exciter::Hammer(d) => d.absorbed_j,
            _ => 0.0,
        }
    }
}
