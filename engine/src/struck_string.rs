//! One string and whatever is exciting it: the unit the lab runs and a key will own.
//!
//! Per audio sample the string advances by one exact modal step. While a hammer
//! is in or near contact, the string and hammer advance instead in equal
//! sub-steps, each with the contact force solved implicitly ([`crate::exciter::hammer::contact`]).
//! A string can keep tables for several sub-step counts and a strike picks one
//! (a key picks the fewest that keep the strike within its error budget,
//! [`crate::exciter::hammer::substeps`]); the coefficient sets for every step size are built when
//! the exciter is set up. A full step that turns out to end in contact is taken
//! back ([`ModalBank::undo_free_step`]) and redone in sub-steps; sub-stepping
//! ends once no force has acted for 100 us (micro-gaps of a chattering stiff
//! contact are shorter).
//!
//! Each (sub)step is one pass over the modes. The force of a step is found after
//! that pass, so the bank keeps each step's state without the response to its
//! own force (b F) and carries it into the next pass (`p b`, see [`DriveTable`]).
//! A hammer's force is held over each step at the felt's energy-consistent mean
//! ([`crate::exciter::hammer::contact`]; [`Hold::End`]); a tangent's prescribed acceleration is
//! interpolated linearly ([`Hold::Linear`]). The string at the contact point is
//! the kept modes, y = y_hat + G F, plus the omitted modes' residual displacement
//! r, a spring R in parallel with a dashpot c ([`crate::string::residual`]) integrated
//! exactly over the step:
//!
//!   r(h) = a r(0) + (1 - a) R F,  a = exp(-h / (c R)).
//!
//! The bridge force is B_hat + G_b F + S r / R, S being the omitted modes' static
//! share per newton. Every joule is accounted for: what the hammer loses is in
//! the kept modes, the felt, the residual spring, or taken up by the omitted modes.
//!
//! Striking again continues from the string's present state.

use crate::exciter::hammer::contact::{Binomial, ContactStep, Felt, Guess};
use crate::exciter::hammer::{Hammer, HammerSpec};
use crate::exciter::pluck::PluckSpec;
use crate::exciter::tangent::TangentSpec;
use crate::modal_bank::{DriveTable, Hold, LANES, ModalBank, StepTable};
use crate::string::StringModes;
use crate::string::residual;

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
    /// Relaxation time c R, s.
    time_constant_s: f64,
    /// 1 / R, and S / R with S the static share of the bridge force per newton
    /// (both 0 without omitted modes).
    stiffness_n_m: f64,
    bridge_per_m: f64,
    /// exp(-h / (c R)) for a sample.
    relax_audio: f64,
}

impl Residual {
    fn new(string: &StringModes, position: f64, sample_s: f64) -> Self {
        let compliance_m_n = residual::omitted_compliance_m_n(string, position);
        let time_constant_s = residual::omitted_damping_ns_m(string, position) * compliance_m_n;
        let bridge_share = residual::omitted_bridge_share(string, position);
        let stiffness_n_m = if compliance_m_n > 0.0 { 1.0 / compliance_m_n } else { 0.0 };
        let mut residual = Self {
            compliance_m_n,
            time_constant_s,
            stiffness_n_m,
            bridge_per_m: bridge_share * stiffness_n_m,
            relax_audio: 0.0,
        };
        residual.relax_audio = residual.relax(sample_s);
        residual
    }

    /// exp(-h / (c R)): what is left of a displacement after `step_s` without force.
    fn relax(&self, step_s: f64) -> f64 {
        if self.time_constant_s > 0.0 { (-step_s / self.time_constant_s).exp() } else { 0.0 }
    }

    /// Static bridge force of a residual displacement, N.
    fn bridge_force_n(&self, displacement_m: f64) -> f64 {
        self.bridge_per_m * displacement_m
    }

    /// Energy in the residual spring, J.
    fn energy_j(&self, displacement_m: f64) -> f64 {
        0.5 * self.stiffness_n_m * displacement_m * displacement_m
    }
}

/// One sub-step size: its count per sample and the string's step over it.
struct Fine {
    substeps: usize,
    step: StepTable,
}

/// What a hammer needs for one sub-step size.
struct FineDrive {
    drive: DriveTable,
    /// The residual's exp(-h / (c R)) over the sub-step.
    relax: f64,
}

/// What a hammer at one strike point needs, for every step size.
struct HammerTables {
    position: f64,
    audio: DriveTable,
    /// One per entry of [`StruckString::fine`].
    fine: Vec<FineDrive>,
    residual: Residual,
}

/// The moving hammer's state.
struct HammerState {
    hammer: Hammer,
    /// Displacement of the omitted modes at the strike point, m.
    residual_m: f64,
    /// Felt compression at the end of the last step, m.
    compression_m: f64,
    /// The felt there (force and energy: where the next solve starts).
    felt: Felt,
    /// Force held over the last step (carried into the next pass), N.
    force_n: f64,
    /// ... and over the two steps before it (to guess the next), N.
    earlier_force_n: [f64; 2],
    /// The compressions at the ends of the two steps before the last, m.
    earlier_compression_m: [f64; 2],
    /// The felt law's [`ContactLaw::binomial`].
    binomial: Binomial,
    /// Energy taken up by the omitted modes' dashpot so far, J.
    absorbed_j: f64,
    /// The sub-step size of this strike (an index into [`StruckString::fine`]).
    fine: usize,
    substepping: bool,
    quiet_samples: usize,
    time_s: f64,
}

/// What a tangent at the string's far end needs.
struct TangentTables {
    gains: Vec<f64>,
    drive: DriveTable,
    /// Omitted modes' static share of the force at the tangent and at the bridge, per unit z''.
    residual_tangent_kg: f64,
    residual_bridge_kg: f64,
}

/// A tangent moving exponentially from `from_m` toward `to_m`:
/// z = to + (from - to) r, r = exp(-t / tau), so z'' = (from - to) r / tau^2.
#[derive(Clone, Copy)]
struct TangentState {
    from_m: f64,
    to_m: f64,
    time_constant_s: f64,
    /// r now, advanced by `decay_per_sample` each sample (zero once negligible).
    remaining: f64,
    decay_per_sample: f64,
    /// z'' held at the end of the last step (carried into the next pass), m/s^2.
    acceleration_m_s2: f64,
}

impl TangentState {
    fn position_m(&self) -> f64 {
        self.to_m + (self.from_m - self.to_m) * self.remaining
    }

    fn velocity_m_s(&self) -> f64 {
        -(self.from_m - self.to_m) * self.remaining / self.time_constant_s
    }

    fn acceleration_now_m_s2(&self) -> f64 {
        (self.from_m - self.to_m) * self.remaining / (self.time_constant_s * self.time_constant_s)
    }
}

/// What a plucking point needs.
struct PluckTables {
    position: f64,
    drive: DriveTable,
}

#[derive(Clone, Copy)]
enum Exciter {
    None,
    Hammer,
    Tangent,
    Pluck,
}

/// A string with its modes, its exciter, and the coefficients for both step sizes.
///
/// The tables an exciter needs at a given point are built by the `prepare_*`
/// methods (allocating); once prepared, striking, pressing and plucking there
/// allocate nothing, so a key can be played from the audio thread.
pub struct StruckString {
    string: StringModes,
    bank: ModalBank,
    audio: StepTable,
    /// Sub-step sizes, fewest sub-steps first.
    fine: Vec<Fine>,
    hold_samples: usize,
    hammer_tables: Option<HammerTables>,
    tangent_tables: Option<TangentTables>,
    pluck_tables: Option<PluckTables>,
    exciter: Exciter,
    hammer: HammerState,
    tangent: TangentState,
    /// [`ModalBank::kick`] factors for a motion of the bridge end (empty until prepared).
    bridge_kick: Vec<f64>,
}

impl StruckString {
    /// A string at rest, stepped at `sample_rate_hz` with `substeps` sub-steps per
    /// sample during contact. Allocates.
    pub fn new(string: StringModes, sample_rate_hz: f64, substeps: usize) -> Self {
        Self::with_substep_counts(string, sample_rate_hz, &[substeps])
    }

    /// A string at rest with tables for each of `counts` sub-steps per sample
    /// (none: [`DEFAULT_SUBSTEPS`]); [`Self::strike_substepped`] chooses among
    /// them. Allocates.
    pub fn with_substep_counts(string: StringModes, sample_rate_hz: f64, counts: &[usize]) -> Self {
        let h = 1.0 / sample_rate_hz;
        let bank = ModalBank::new(&string);
        let audio = StepTable::new(&string, h);
        let mut counts: Vec<usize> = counts.iter().map(|&n| n.max(1)).collect();
        if counts.is_empty() {
            counts.push(DEFAULT_SUBSTEPS);
        }
        counts.sort_unstable();
        counts.dedup();
        let fine = counts
            .into_iter()
            .map(|substeps| Fine { substeps, step: StepTable::new(&string, h / substeps as f64) })
            .collect();
        // Stay sub-stepped through force-free gaps up to 100 us: a stiff contact
        // chatters with micro-separations of tens of microseconds.
        let hold_samples = ((100e-6 * sample_rate_hz).ceil() as usize).max(2);
        let idle_hammer = HammerSpec {
            mass_kg: 1.0,
            law: crate::exciter::hammer::contact::ContactLaw { stiffness: 1.0, exponent: 1.0 },
            speed_m_s: 0.0,
            position: 0.5,
        };
        Self {
            string,
            bank,
            audio,
            fine,
            hold_samples,
            hammer_tables: None,
            tangent_tables: None,
            pluck_tables: None,
            exciter: Exciter::None,
            hammer: HammerState {
                hammer: Hammer::thrown(idle_hammer, 0.0),
                residual_m: 0.0,
                compression_m: 0.0,
                felt: Felt::default(),
                force_n: 0.0,
                earlier_force_n: [0.0; 2],
                earlier_compression_m: [0.0; 2],
                binomial: idle_hammer.law.binomial(),
                absorbed_j: 0.0,
                fine: 0,
                substepping: false,
                quiet_samples: 0,
                time_s: 0.0,
            },
            tangent: TangentState {
                from_m: 0.0,
                to_m: 0.0,
                time_constant_s: 1.0,
                remaining: 0.0,
                decay_per_sample: 0.0,
                acceleration_m_s2: 0.0,
            },
            bridge_kick: Vec::new(),
        }
    }

    pub fn string(&self) -> &StringModes {
        &self.string
    }

    pub fn bank(&self) -> &ModalBank {
        &self.bank
    }

    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / self.audio.step_s
    }

    /// Give the bank back its "force applied" form and let the exciter go.
    /// A tangent is dropped where it is (see [`Self::lift_tangent`] for a gentle release).
    ///
    /// Allocates: no.
    pub fn release_exciter(&mut self) {
        match self.exciter {
            Exciter::Hammer if self.hammer.substepping => {
                let tables = self.hammer_tables.as_ref().expect("a hammer in play has tables");
                self.bank.apply_ramp(&tables.fine[self.hammer.fine].drive, self.hammer.force_n);
            }
            Exciter::Tangent => {
                let tables = self.tangent_tables.as_ref().expect("a tangent in play has tables");
                self.bank.apply_ramp(&tables.drive, self.tangent.acceleration_m_s2);
            }
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

    /// Build the tables for a hammer striking at `position` (fraction of the length). Allocates.
    pub fn prepare_hammer(&mut self, position: f64) {
        if let Exciter::Hammer = self.exciter {
            self.release_exciter();
        }
        let s = &self.string;
        let shape: Vec<f64> = s.modes.iter().map(|m| s.shape_at(m, position)).collect();
        let m = s.modal_mass_kg();
        let audio = self.drive_at(&self.audio, Hold::End, |i| shape[i] / m, |i| shape[i]);
        let residual = Residual::new(s, position, self.audio.step_s);
        let fine = self
            .fine
            .iter()
            .map(|f| FineDrive {
                drive: self.drive_at(&f.step, Hold::End, |i| shape[i] / m, |i| shape[i]),
                relax: residual.relax(f.step.step_s),
            })
            .collect();
        self.hammer_tables = Some(HammerTables { position, audio, fine, residual });
    }

    /// Build the tables for a tangent at the far end. Allocates.
    pub fn prepare_tangent(&mut self) {
        if let Exciter::Tangent = self.exciter {
            self.release_exciter();
        }
        let s = &self.string;
        let gains: Vec<f64> = s.modes.iter().map(|m| TangentSpec::modal_gain(m.number)).collect();
        let weights = self.bank.weights().to_vec();
        let sign = |i: usize| if s.modes[i].number.is_multiple_of(2) { 1.0 } else { -1.0 };
        let drive = self.drive_at(&self.audio, Hold::Linear, |i| gains[i], |i| sign(i) * weights[i]);
        let (residual_tangent_kg, residual_bridge_kg) = residual::omitted_tangent_shares_kg(s);
        self.tangent_tables = Some(TangentTables { gains, drive, residual_tangent_kg, residual_bridge_kg });
    }

    /// Build the tables for plucking at `position`. Allocates.
    pub fn prepare_pluck(&mut self, position: f64) {
        if let Exciter::Pluck = self.exciter {
            self.release_exciter();
        }
        let s = &self.string;
        let shape: Vec<f64> = s.modes.iter().map(|m| s.shape_at(m, position)).collect();
        let drive = self.drive_at(&self.audio, Hold::Linear, |_| 0.0, |i| shape[i]);
        self.pluck_tables = Some(PluckTables { position, drive });
    }

    /// Build the table for moving the string's bridge end ([`Self::move_bridge`]). Allocates.
    pub fn prepare_bridge_drive(&mut self) {
        // The bridge end x = 0 moving by u: y = u (1 - x / L) + w, and the line's
        // load -mu u'' (1 - x / L) projects onto mode n as -2 u'' / (n pi).
        let gains: Vec<f64> =
            self.string.modes.iter().map(|m| -2.0 / (m.number as f64 * std::f64::consts::PI)).collect();
        self.bridge_kick = self.bank.kick_table(&gains);
    }

    /// The bridge under the string has changed its velocity by `dv_m_s` since the
    /// last sample (pushed by other strings): every mode takes its share of the
    /// jump. Needs [`Self::prepare_bridge_drive`] first (does nothing otherwise).
    ///
    /// Allocates: no.
    pub fn move_bridge(&mut self, dv_m_s: f64) {
        self.bank.kick(&self.bridge_kick, dv_m_s);
    }

    /// Throw a hammer at the string as it is now, sub-stepped as finely as the
    /// string has tables for. Allocates only when the hammer tables were not
    /// prepared for `spec.position`.
    pub fn strike(&mut self, spec: HammerSpec) {
        self.strike_substepped(spec, usize::MAX);
    }

    /// [`Self::strike`] with the fewest sub-steps per sample of at least
    /// `substeps` the string has tables for (the most it has, if none reach it).
    pub fn strike_substepped(&mut self, spec: HammerSpec, substeps: usize) {
        self.release_exciter();
        let fine = self.fine.iter().position(|f| f.substeps >= substeps).unwrap_or(self.fine.len() - 1);
        if self.hammer_tables.as_ref().is_none_or(|t| t.position != spec.position) {
            self.prepare_hammer(spec.position);
        }
        let tables = self.hammer_tables.as_ref().expect("prepared above");
        let touching_at_m = self.bank.observe(&tables.audio);
        self.hammer = HammerState {
            hammer: Hammer::thrown(spec, touching_at_m),
            residual_m: 0.0,
            compression_m: 0.0,
            felt: Felt::default(),
            force_n: 0.0,
            earlier_force_n: [0.0; 2],
            earlier_compression_m: [0.0; 2],
            binomial: spec.law.binomial(),
            absorbed_j: 0.0,
            fine,
            substepping: true,
            quiet_samples: 0,
            time_s: 0.0,
        };
        self.exciter = Exciter::Hammer;
    }

    /// Press a tangent into the string's far end (x = L), lifting it toward
    /// `spec.displacement_m` from wherever it is, meeting it at `spec.speed_m_s`.
    /// The tangent stays until it is lifted or another exciter replaces it.
    /// Allocates only when the tangent tables were not prepared.
    pub fn press_tangent(&mut self, spec: TangentSpec) {
        let from_m = self.tangent_position_m();
        let rise_m = (spec.displacement_m - from_m).max(spec.displacement_m * 1e-3);
        self.move_tangent(spec.displacement_m, rise_m / spec.speed_m_s);
    }

    /// Let the tangent fall back from the string over about `time_constant_s`:
    /// the string's end follows it down to rest. Allocates: no.
    pub fn lift_tangent(&mut self, time_constant_s: f64) {
        if let Exciter::Tangent = self.exciter {
            self.move_tangent(0.0, time_constant_s);
        }
    }

    /// Where the tangent holds the string's end now, m (0 without a tangent).
    pub fn tangent_position_m(&self) -> f64 {
        match self.exciter {
            Exciter::Tangent => self.tangent.position_m(),
            _ => 0.0,
        }
    }

    fn move_tangent(&mut self, to_m: f64, time_constant_s: f64) {
        let (from_m, old_velocity) = match self.exciter {
            Exciter::Tangent => (self.tangent.position_m(), self.tangent.velocity_m_s()),
            _ => (0.0, 0.0),
        };
        self.release_exciter();
        if self.tangent_tables.is_none() {
            self.prepare_tangent();
        }
        let tables = self.tangent_tables.as_ref().expect("prepared above");
        let mut state = TangentState {
            from_m,
            to_m,
            time_constant_s,
            remaining: 1.0,
            decay_per_sample: (-self.audio.step_s / time_constant_s).exp(),
            acceleration_m_s2: 0.0,
        };
        // The end's velocity jumps to the new motion's: the modes (measured from
        // the straight line through the moving end) take the opposite jump.
        let jump = state.velocity_m_s() - old_velocity;
        for (i, g) in tables.gains.iter().enumerate() {
            self.bank.add_velocity(i, g * jump);
        }
        state.acceleration_m_s2 = state.acceleration_now_m_s2();
        self.bank.apply_ramp(&tables.drive, -state.acceleration_m_s2);
        self.tangent = state;
        self.exciter = Exciter::Tangent;
    }

    /// Pull the string aside into a triangle and let go (adds to its present state).
    /// Allocates only when the pluck tables were not prepared for `spec.position`.
    pub fn pluck(&mut self, spec: PluckSpec) {
        self.release_exciter();
        if self.pluck_tables.as_ref().is_none_or(|t| t.position != spec.position) {
            self.prepare_pluck(spec.position);
        }
        for (i, mode) in self.string.modes.iter().enumerate() {
            self.bank.add_displacement(i, spec.modal_displacement_m(mode.number));
        }
        self.exciter = Exciter::Pluck;
    }

    /// Whether a hammer is in play but has left the string: flying away, at
    /// least `gap_m` below it, for at least `after_s` since the strike.
    pub fn hammer_gone(&self, gap_m: f64, after_s: f64) -> bool {
        let h = &self.hammer;
        matches!(self.exciter, Exciter::Hammer)
            && !h.substepping
            && h.time_s >= after_s
            && h.hammer.velocity_m_s < 0.0
            && h.compression_m < -gap_m
    }

    /// Whether a hammer in play can never touch the string again if both are left
    /// to move freely: it is past its contact (no force for the sub-step hold),
    /// flying away, and already further back than the string at the strike point
    /// can ever reach. The reach is bounded by [`ModalBank::observe_bound`] over the
    /// kept modes plus |r| for the omitted modes' residual, and free motion only
    /// shrinks both; the hammer moves away at a constant speed. So no bounce that
    /// would still come is ever cut off (unlike [`Self::hammer_gone`], which is a
    /// heuristic gap and delay). The bound sums every mode's amplitude, so it is
    /// reached later than the hammer is really clear (typically a few milliseconds
    /// after the last contact, longer for a slow rebound).
    ///
    /// Allocates: no. One pass over the modes.
    pub fn hammer_clear(&self) -> bool {
        let (Exciter::Hammer, Some(tables)) = (self.exciter, self.hammer_tables.as_ref()) else {
            return false;
        };
        let h = &self.hammer;
        if h.substepping || !(h.hammer.velocity_m_s < 0.0) || !(h.compression_m < 0.0) {
            return false;
        }
        let reach_m = self.bank.observe_bound(&tables.audio) + h.residual_m.abs();
        h.hammer.position_m + reach_m < 0.0
    }

    /// Every mode to rest, the exciter gone. Allocates: no.
    pub fn silence(&mut self) {
        self.exciter = Exciter::None;
        self.bank.clear();
    }

    /// Move the free step's poles: every mode's decay rate raised by
    /// `extra_decay_s + extra_decay_per_hz_s * f_n` (a damper) and every frequency
    /// scaled by `pitch_ratio` (a bend). Sub-steps keep the string's own poles.
    ///
    /// Allocates: no. One exp and one sin/cos per mode.
    pub fn set_free_step(&mut self, extra_decay_s: f64, extra_decay_per_hz_s: f64, pitch_ratio: f64) {
        for (i, mode) in self.string.modes.iter().enumerate() {
            let sigma = mode.decay_rate_s() + extra_decay_s + extra_decay_per_hz_s * mode.frequency_hz();
            self.audio.set_pole(i, sigma, pitch_ratio * mode.damped_omega_rad_s());
        }
    }

    /// Take over `old`'s motion (a rebuild of this string's tables while it rings):
    /// the modes it shares, and a pressed tangent. `old` lets go of its exciter.
    ///
    /// Allocates: no.
    pub fn take_motion_from(&mut self, old: &mut StruckString) {
        let tangent = match old.exciter {
            Exciter::Tangent => Some(old.tangent),
            _ => None,
        };
        old.release_exciter();
        self.exciter = Exciter::None;
        self.bank.copy_motion_from(&old.bank);
        if let (Some(mut state), Some(tables)) = (tangent, self.tangent_tables.as_ref()) {
            state.decay_per_sample = (-self.audio.step_s / state.time_constant_s).exp();
            self.bank.apply_ramp(&tables.drive, -state.acceleration_m_s2);
            self.tangent = state;
            self.exciter = Exciter::Tangent;
        }
    }

    /// An upper bound on the magnitude of the vibrating part of this string's
    /// bridge force from now on, if left free, N (for deciding that a key has
    /// fallen silent; a resting tangent's static lift is not vibration).
    pub fn amplitude_bound_n(&self) -> f64 {
        self.bank.amplitude_bound_n()
    }

    /// Put to rest the modes below `floor_n` once the string is free or held by a
    /// resting tangent ([`ModalBank::cull`]); returns the amplitude bound and the
    /// loudest mode's amplitude, N.
    ///
    /// Allocates: no.
    pub fn cull(&mut self, floor_n: f64) -> (f64, f64) {
        if self.is_settled() { self.bank.cull(floor_n) } else { (self.bank.amplitude_bound_n(), f64::INFINITY) }
    }

    /// Whether nothing but free decay lies ahead: no exciter, or a tangent at rest.
    pub fn is_settled(&self) -> bool {
        match self.exciter {
            Exciter::None => true,
            Exciter::Tangent => self.tangent.remaining == 0.0,
            _ => false,
        }
    }

    /// The string's displacement at `points.len()` equally spaced points from the
    /// bridge (x = 0) to the far end (x = L), the tangent's lift included, m.
    ///
    /// Allocates: no.
    pub fn shape_m(&self, points: &mut [f32]) {
        let count = points.len();
        let end_m = self.tangent_position_m();
        for (j, p) in points.iter_mut().enumerate() {
            let x = if count > 1 { j as f64 / (count - 1) as f64 } else { 0.5 };
            // sin(n theta) by the recurrence s_{n+1} = 2 cos(theta) s_n - s_{n-1}.
            let theta = std::f64::consts::PI * x;
            let two_cos = 2.0 * theta.cos();
            let (mut s_prev, mut s_now) = (0.0, theta.sin());
            let mut y = end_m * x;
            for (i, mode) in self.string.modes.iter().enumerate() {
                debug_assert_eq!(mode.number, i + 1);
                y += self.bank.displacement(i) * s_now;
                let next = two_cos * s_now - s_prev;
                s_prev = s_now;
                s_now = next;
            }
            *p = y as f32;
        }
    }

    /// Advance `out.len()` samples while the string is free (or a tangent rests on
    /// it): the modes' bridge force goes to `acc` by lane ([`ModalBank::accumulate_free`];
    /// sum the lanes with [`crate::modal_bank::lane_sum`]), a resting tangent's
    /// static lift to `out` (`acc` and `out` the same length). Returns false (doing
    /// nothing) when an exciter is in play.
    ///
    /// Allocates: no.
    pub fn accumulate_free(&mut self, acc: &mut [[f64; LANES]], out: &mut [f64]) -> bool {
        match self.exciter {
            Exciter::None => self.bank.accumulate_free(&self.audio, acc),
            Exciter::Tangent if self.tangent.remaining == 0.0 => {
                self.bank.accumulate_free(&self.audio, acc);
                let line = self.string.tension_n * self.tangent.to_m / self.string.length_m;
                out.iter_mut().for_each(|o| *o += line);
            }
            _ => return false,
        }
        true
    }

    /// The present state, without stepping.
    pub fn current(&self) -> Tick {
        let bridge = self.bank.bridge_force_n();
        match self.exciter {
            Exciter::None => Tick { bridge_force_n: bridge, ..Tick::default() },
            Exciter::Hammer => {
                let d = &self.hammer;
                let t = self.hammer_tables.as_ref().expect("a hammer in play has tables");
                let (drive, force) = if d.substepping { (&t.fine[d.fine].drive, d.force_n) } else { (&t.audio, 0.0) };
                Tick {
                    contact_force_n: d.hammer.spec.law.force_n(d.compression_m),
                    bridge_force_n: bridge + drive.bridge_per_input * force + t.residual.bridge_force_n(d.residual_m),
                    exciter_position_m: Some(d.hammer.position_m),
                    string_position_m: self.bank.observe(drive) + drive.observe_per_input * force + d.residual_m,
                }
            }
            Exciter::Tangent => {
                let t = self.tangent_tables.as_ref().expect("a tangent in play has tables");
                let a = self.tangent.acceleration_m_s2;
                let z = self.tangent.position_m();
                let line = self.string.tension_n * z / self.string.length_m;
                Tick {
                    contact_force_n: self.bank.observe(&t.drive)
                        + (t.drive.observe_per_input + t.residual_tangent_kg) * a
                        + line,
                    bridge_force_n: bridge + (t.drive.bridge_per_input + t.residual_bridge_kg) * a + line,
                    exciter_position_m: Some(z),
                    string_position_m: z,
                }
            }
            Exciter::Pluck => {
                let t = self.pluck_tables.as_ref().expect("a pluck has tables");
                Tick {
                    contact_force_n: 0.0,
                    bridge_force_n: bridge,
                    exciter_position_m: None,
                    string_position_m: self.bank.observe(&t.drive),
                }
            }
        }
    }

    /// Advance one sample and report it.
    pub fn tick(&mut self) -> Tick {
        self.tick_observed(&mut ())
    }

    /// Advance one sample, telling `observer` about every (sub)step of a hammer.
    ///
    /// Allocates: no.
    pub fn tick_observed(&mut self, observer: &mut impl ContactObserver) -> Tick {
        match self.exciter {
            Exciter::None => {
                let mut out = [0.0];
                self.bank.process_free(&self.audio, &mut out);
                Tick { bridge_force_n: out[0], ..Tick::default() }
            }
            Exciter::Hammer => {
                let tables = self.hammer_tables.as_ref().expect("a hammer in play has tables");
                Self::tick_hammer(
                    &mut self.bank,
                    &self.audio,
                    &self.fine,
                    self.hold_samples,
                    tables,
                    &mut self.hammer,
                    observer,
                )
            }
            Exciter::Tangent => {
                let t = self.tangent_tables.as_ref().expect("a tangent in play has tables");
                let d = &mut self.tangent;
                let (end_hat, bridge_hat) = self.bank.step_driven(&self.audio, &t.drive, d.acceleration_m_s2);
                // Below 1e-17 the tangent has arrived: stop before denormals.
                d.remaining = if d.remaining > 1e-17 { d.remaining * d.decay_per_sample } else { 0.0 };
                let a = d.acceleration_now_m_s2();
                d.acceleration_m_s2 = a;
                let z = d.position_m();
                let line = self.string.tension_n * z / self.string.length_m;
                Tick {
                    contact_force_n: end_hat + (t.drive.observe_per_input + t.residual_tangent_kg) * a + line,
                    bridge_force_n: bridge_hat + (t.drive.bridge_per_input + t.residual_bridge_kg) * a + line,
                    exciter_position_m: Some(z),
                    string_position_m: z,
                }
            }
            Exciter::Pluck => {
                let t = self.pluck_tables.as_ref().expect("a pluck has tables");
                let (y, bridge) = self.bank.step_driven(&self.audio, &t.drive, 0.0);
                Tick { contact_force_n: 0.0, bridge_force_n: bridge, exciter_position_m: None, string_position_m: y }
            }
        }
    }

    #[allow(clippy::too_many_arguments)]
    fn tick_hammer(
        bank: &mut ModalBank,
        audio: &StepTable,
        fine: &[Fine],
        hold_samples: usize,
        t: &HammerTables,
        d: &mut HammerState,
        observer: &mut impl ContactObserver,
    ) -> Tick {
        if !d.substepping {
            // The force is zero: a free step, unless it ends in contact.
            let h = audio.step_s;
            let (y_hat, bridge_hat) = bank.step_driven(audio, &t.audio, 0.0);
            let eta_hat = d.hammer.predict_m(h);
            let residual_m = t.residual.relax_audio * d.residual_m;
            let compression_m = eta_hat - y_hat - residual_m;
            if compression_m <= 0.0 {
                d.hammer.commit(h, eta_hat, 0.0);
                d.absorbed_j += t.residual.energy_j(d.residual_m) - t.residual.energy_j(residual_m);
                d.residual_m = residual_m;
                d.compression_m = compression_m;
                d.felt = Felt { compression_m, force_n: 0.0, energy_j: 0.0 };
                d.time_s += h;
                observer.step(d.time_s, compression_m, 0.0);
                return Tick {
                    contact_force_n: 0.0,
                    bridge_force_n: bridge_hat + t.residual.bridge_force_n(residual_m),
                    exciter_position_m: Some(eta_hat),
                    string_position_m: y_hat + residual_m,
                };
            }
            // This sample runs into the string: redo it finely.
            bank.undo_free_step(audio);
            d.substepping = true;
            d.quiet_samples = 0;
        }
        let Fine { substeps, step: ref sub } = fine[d.fine];
        let FineDrive { drive: ref t_sub, relax } = t.fine[d.fine];
        let h = sub.step_s;
        let compliance =
            d.hammer.compliance_m_n(h) + t_sub.observe_per_input + (1.0 - relax) * t.residual.compliance_m_n;
        let mut any_force = false;
        let mut tick = Tick::default();
        for _ in 0..substeps {
            let (y_hat, bridge_hat) = bank.step_driven(sub, t_sub, d.force_n);
            let eta_hat = d.hammer.predict_m(h);
            let c_hat = eta_hat - y_hat - relax * d.residual_m;
            // The courses of force and compression so far, carried on by parabolas,
            // are the solve's guesses (the compression's does not wait on this pass).
            let [f1, f2] = d.earlier_force_n;
            let [c1, c2] = d.earlier_compression_m;
            let guess = Guess {
                force_n: 3.0 * (d.force_n - f1) + f2,
                compression_m: 3.0 * (d.compression_m - c1) + c2,
                binomial: &d.binomial,
            };
            let (ContactStep { compression_m, step_force_n: force, .. }, felt) =
                d.hammer.spec.law.step(d.felt, c_hat, compliance, Some(guess));
            d.earlier_force_n = [d.force_n, f1];
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
            let felt_force_n = felt.force_n;
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
        tick
    }

    /// Whether a hammer is in or near contact (the string is being sub-stepped).
    pub fn in_contact(&self) -> bool {
        matches!(self.exciter, Exciter::Hammer) && self.hammer.substepping
    }

    /// The hammer, if one is in play.
    pub fn hammer(&self) -> Option<&Hammer> {
        match self.exciter {
            Exciter::Hammer => Some(&self.hammer.hammer),
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
        match self.exciter {
            Exciter::Hammer => self.hammer.absorbed_j,
            _ => 0.0,
        }
    }
}
