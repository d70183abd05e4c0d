//! One string and whatever is exciting it: the unit the lab runs and a key owns.
//!
//! Per audio sample the string advances by one exact modal step
//! ([`crate::modal_bank`]). Its [`Exciter`] (hammer, tangent or pluck) owns
//! the tables it needs at its point and the state of the stroke in play, and
//! steps the string itself while it acts: a hammer sub-steps it through the
//! contact ([`crate::exciter::hammer`]), a tangent moves its far end
//! ([`crate::exciter::tangent`]). A string can keep sub-step tables for several
//! sub-step counts and a strike picks one (a key picks the fewest that keep the
//! strike within its error budget, [`substeps`]).
//!
//! Striking again continues from the string's present state.

// The audio thread steps every string: nothing here may panic.
#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod substeps;

use crate::exciter::Exciter;
use crate::exciter::hammer::{Hammer, HammerRig, HammerSpec, Substep};
use crate::exciter::pluck::{PluckRig, PluckSpec};
use crate::exciter::tangent::{TangentMotion, TangentRig, TangentSpec};
pub use crate::exciter::{ContactObserver, Tick};
use crate::modal_bank::{FreeGather, LANES, ModalBank, SavedPoles, StepTable};
use crate::string::StringModes;

/// Sub-steps per sample while a hammer is in or near contact.
pub const DEFAULT_SUBSTEPS: usize = 8;

/// A bend takes no mode past this fraction of the sample rate (the highest
/// an instrument is built with, `synth::MAX_MODE_FREQUENCY_HZ` aside).
pub const BENT_TOP: f64 = 0.45;

/// A string with its modes, its exciter, and the coefficients for every step size.
///
/// The tables an exciter needs at a given point are built by the `prepare_*`
/// methods (allocating); once prepared, striking, pressing and plucking there
/// allocate nothing, so a key can be played from the audio thread.
#[derive(Clone)]
pub struct StruckString {
    string: StringModes,
    bank: ModalBank,
    audio: StepTable,
    /// Sub-step sizes, fewest sub-steps first.
    fine: Vec<Substep>,
    hold_samples: usize,
    exciter: Exciter,
    /// [`ModalBank::kick`] factors for a motion of the bridge end (empty until prepared).
    bridge_kick: Vec<f64>,
    /// How many of its modes (the lowest) lie under [`BENT_TOP`] of the
    /// sample rate at the pitch it is bent to, and that pitch: only those
    /// (the others are dying) take a motion of the bridge
    /// ([`Self::move_bridge`]), and they take it over the pitch. (A bend
    /// turns the modes faster and keeps their losses; the others' force then
    /// changes as many times faster a sample, and moving the bridge by that
    /// in full, a course bent up 18 semitones pulled its unison harder than
    /// its losses allow, and grew.)
    under_top: (usize, f64),
    /// The free step's poles with nothing added to the modes' losses (no
    /// damper on), at this pitch ratio: what a strike asks for nearly always
    /// (the damper lifts), put back instead of worked out again. A chord's
    /// keys spent a tenth of its first block on their poles' sines and cosines.
    lifted: (f64, SavedPoles),
    /// The player's damping over the built one: a factor on every mode's own
    /// decay rate in the free step ([`Self::set_loss_scale`]).
    loss_scale: f64,
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
            .map(|substeps| Substep { substeps, step: StepTable::new(&string, h / substeps as f64) })
            .collect();
        // Stay sub-stepped through force-free gaps up to 100 us: a stiff contact
        // chatters with micro-separations of tens of microseconds.
        let hold_samples = ((100e-6 * sample_rate_hz).ceil() as usize).max(2);
        // The tables are built with no losses added, at the string's own pitch.
        let lifted = (1.0, audio.save_poles());
        Self {
            string,
            bank,
            audio,
            fine,
            hold_samples,
            exciter: Exciter::None,
            bridge_kick: Vec::new(),
            under_top: (usize::MAX, 1.0),
            lifted,
            loss_scale: 1.0,
        }
    }

    pub fn string(&self) -> &StringModes {
        &self.string
    }

    pub fn bank(&self) -> &ModalBank {
        &self.bank
    }

    /// The string and its modes' state, to be changed between samples.
    pub fn string_and_bank_mut(&mut self) -> (&StringModes, &mut ModalBank) {
        (&self.string, &mut self.bank)
    }

    /// The modes' state, to be changed between samples (a unison's strings
    /// trading energy through their bridge point).
    pub fn bank_mut(&mut self) -> &mut ModalBank {
        &mut self.bank
    }

    /// Mode `index`'s free step: its phasor turns by this each sample.
    pub fn pole(&self, index: usize) -> num_complex::Complex64 {
        self.audio.pole(index)
    }

    pub fn sample_rate_hz(&self) -> f64 {
        1.0 / self.audio.step_s
    }

    /// Give the bank back its "force applied" form and let the exciter go.
    /// A tangent is dropped where it is (see [`Self::lift_tangent`] for a gentle release).
    ///
    /// Allocates: no.
    pub fn release_exciter(&mut self) {
        self.exciter.release(&mut self.bank);
    }

    /// Build the tables for a hammer striking at `position` (fraction of the length),
    /// letting go of any exciter in play. Allocates.
    pub fn prepare_hammer(&mut self, position: f64) {
        self.release_exciter();
        self.exciter = Exciter::Hammer(HammerRig::new(&self.string, &self.bank, &self.audio, &self.fine, position));
    }

    /// Build the tables for a tangent at the far end, letting go of any exciter in
    /// play. Allocates.
    pub fn prepare_tangent(&mut self) {
        self.release_exciter();
        self.exciter = Exciter::Tangent(TangentRig::new(&self.string, &self.bank, &self.audio));
    }

    /// Build the tables for plucking at `position`, letting go of any exciter in
    /// play. Allocates.
    pub fn prepare_pluck(&mut self, position: f64) {
        self.release_exciter();
        self.exciter = Exciter::Pluck(PluckRig::new(&self.string, &self.bank, &self.audio, position));
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
    /// last sample (pushed by other strings): every mode under [`BENT_TOP`]
    /// of the sample rate takes its share of the jump, over the pitch the
    /// string is bent to. Needs [`Self::prepare_bridge_drive`] first (does
    /// nothing otherwise).
    ///
    /// Allocates: no.
    pub fn move_bridge(&mut self, dv_m_s: f64) {
        let n = self.under_top.0.min(self.bridge_kick.len());
        self.bank.kick(&self.bridge_kick[..n], dv_m_s / self.under_top.1);
    }

    /// How much the string's bridge force changes over the next sample per
    /// m/s its bridge end is moved by ([`Self::move_bridge`]), N s/m: about
    /// its impedance sqrt(T mu), as the wave the motion launches says (a
    /// bend turns its modes faster, and keeps their losses and their answer
    /// to the bridge as built). Allocates: no.
    pub fn bridge_answer_ns_m(&self) -> f64 {
        let n = self.under_top.0.min(self.bridge_kick.len());
        let turned: f64 = self.bridge_kick[..n].iter().enumerate().map(|(i, k)| self.audio.pole(i).im * k).sum();
        (turned / self.under_top.1).abs()
    }

    /// [`Self::move_bridge`] by `dv_m_s`, then [`Self::tick`], to the bit: a
    /// string no stroke is in play on (whose tick is a free step) takes the
    /// kick with its step, in one pass.
    ///
    /// Allocates: no.
    pub fn tick_moved(&mut self, dv_m_s: f64) -> Tick {
        if self.exciter.in_play() {
            self.move_bridge(dv_m_s);
            return self.tick();
        }
        Tick {
            bridge_force_n: self.bank.process_free_kicked(
                &self.audio,
                &self.bridge_kick[..self.under_top.0.min(self.bridge_kick.len())],
                dv_m_s / self.under_top.1,
            ),
            ..Tick::default()
        }
    }

    /// Throw a hammer at the string as it is now, sub-stepped as finely as the
    /// string has tables for. Allocates only when the string has no hammer
    /// tables yet (a new strike point rebuilds them in place).
    pub fn strike(&mut self, spec: HammerSpec) {
        self.strike_substepped(spec, usize::MAX);
    }

    /// [`Self::strike`] with the fewest sub-steps per sample of at least
    /// `substeps` the string has tables for (the most it has, if none reach it).
    pub fn strike_substepped(&mut self, spec: HammerSpec, substeps: usize) {
        self.release_exciter();
        let fine = self.fine.iter().position(|f| f.substeps >= substeps).unwrap_or(self.fine.len() - 1);
        let mut rig = match std::mem::replace(&mut self.exciter, Exciter::None) {
            Exciter::Hammer(mut rig) => {
                rig.move_to(&self.string, &self.bank, &self.audio, &self.fine, spec.position);
                rig
            }
            _ => HammerRig::new(&self.string, &self.bank, &self.audio, &self.fine, spec.position),
        };
        rig.throw(&self.bank, spec, fine, self.fine[fine].step.step_s, self.audio.step_s);
        self.exciter = Exciter::Hammer(rig);
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
        if let Exciter::Tangent(rig) = &self.exciter
            && rig.in_play()
        {
            self.move_tangent(0.0, time_constant_s);
        }
    }

    /// Where the tangent holds the string's end now, m (0 without a tangent).
    pub fn tangent_position_m(&self) -> f64 {
        match &self.exciter {
            Exciter::Tangent(rig) => rig.position_m(),
            _ => 0.0,
        }
    }

    /// Move the string's end from where a tangent holds it now toward `to_m`.
    fn move_tangent(&mut self, to_m: f64, time_constant_s: f64) {
        let (from_m, old_velocity_m_s) = match &self.exciter {
            Exciter::Tangent(rig) => (rig.position_m(), rig.velocity_m_s()),
            _ => (0.0, 0.0),
        };
        self.release_exciter();
        let mut rig = match std::mem::replace(&mut self.exciter, Exciter::None) {
            Exciter::Tangent(rig) => rig,
            _ => TangentRig::new(&self.string, &self.bank, &self.audio),
        };
        let motion = TangentMotion { from_m, to_m, time_constant_s };
        rig.start(&mut self.bank, motion, old_velocity_m_s, self.audio.step_s);
        self.exciter = Exciter::Tangent(rig);
    }

    /// Pull the string aside into a triangle and let go (adds to its present state).
    /// Allocates only when the string has no pluck tables yet (a new plucking
    /// point rebuilds them in place).
    pub fn pluck(&mut self, spec: PluckSpec) {
        self.release_exciter();
        let mut rig = match std::mem::replace(&mut self.exciter, Exciter::None) {
            Exciter::Pluck(mut rig) => {
                rig.move_to(&self.string, &self.bank, &self.audio, spec.position);
                rig
            }
            _ => PluckRig::new(&self.string, &self.bank, &self.audio, spec.position),
        };
        rig.pluck(&mut self.bank, &self.string, spec);
        self.exciter = Exciter::Pluck(rig);
    }

    /// Whether a hammer is in play but has left the string: flying away, at
    /// least `gap_m` below it, for at least `after_s` since the strike.
    pub fn hammer_gone(&self, gap_m: f64, after_s: f64) -> bool {
        matches!(&self.exciter, Exciter::Hammer(rig) if rig.gone(gap_m, after_s))
    }

    /// Whether a hammer in play flies clear of it ([`Self::watch_hammer`]).
    pub fn coasting(&self) -> bool {
        matches!(&self.exciter, Exciter::Hammer(rig) if rig.coasting())
    }

    /// At a control tick, or after its modes were kicked (its modes back
    /// from any gathering): whether a hammer in play flies clear of the
    /// string, which then turns freely ([`Self::free_for`]) until the hammer
    /// is let go. Allocates: no.
    pub fn watch_hammer(&mut self) {
        if let Exciter::Hammer(rig) = &mut self.exciter {
            rig.watch(&self.bank);
        }
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
        matches!(&self.exciter, Exciter::Hammer(rig) if rig.clear(&self.bank))
    }

    /// Every mode to rest, the exciter gone. Allocates: no.
    pub fn silence(&mut self) {
        self.exciter.forget();
        self.bank.clear();
    }

    /// Move the free step's poles: every mode's decay rate raised by
    /// `extra_decay_s + extra_decay_per_hz_s * f_n` (a damper) and every frequency
    /// scaled by `pitch_ratio` (a bend). Sub-steps keep the string's own poles.
    /// A mode bent past [`BENT_TOP`] of the sample rate dies within a few
    /// samples, as the string's build leaves out a mode there: its step
    /// turns by nearly half a cycle a sample, and the gathering, which
    /// divides by the sine of that turn to undo it, could no longer (a key
    /// bent up by four octaves sent its partials there, and read them back
    /// 1e40 times too large).
    ///
    /// Allocates: no. One exp and one sin/cos per mode, but for a lifted
    /// damper at the pitch last asked for with it: those poles are put back.
    pub fn set_free_step(&mut self, extra_decay_s: f64, extra_decay_per_hz_s: f64, pitch_ratio: f64) {
        let loss_scale = self.loss_scale;
        let top_rad_s = BENT_TOP * std::f64::consts::TAU / self.audio.step_s;
        if pitch_ratio != self.under_top.1 {
            let under = self.string.modes.iter().take_while(|m| pitch_ratio * m.damped_omega_rad_s() < top_rad_s);
            self.under_top = (under.count(), pitch_ratio);
        }
        let lifted = extra_decay_s == 0.0 && extra_decay_per_hz_s == 0.0;
        if lifted && pitch_ratio == self.lifted.0 {
            self.audio.restore_poles(&self.lifted.1);
            return;
        }
        for (i, mode) in self.string.modes.iter().enumerate() {
            let sigma = loss_scale * mode.decay_rate_s() + extra_decay_s + extra_decay_per_hz_s * mode.frequency_hz();
            let omega_rad_s = pitch_ratio * mode.damped_omega_rad_s();
            if omega_rad_s < top_rad_s {
                self.audio.set_pole(i, sigma, omega_rad_s);
            } else {
                // Held at the top, it falls by 1/e a sample (a pole of 0 would
                // stop it at once, but a step taken back divides by the pole).
                self.audio.set_pole(i, sigma.max(1.0 / self.audio.step_s), top_rad_s);
            }
        }
        if lifted {
            self.lifted.0 = pitch_ratio;
            self.audio.save_poles_into(&mut self.lifted.1);
        }
    }

    /// Scale every mode's own decay rate by `scale` from the next
    /// [`Self::set_free_step`] on (the player's damping, moved while the
    /// string plays; 1: as built). Allocates: no.
    pub fn set_loss_scale(&mut self, scale: f64) {
        let scale = if scale.is_finite() && scale > 0.0 { scale } else { 1.0 };
        if scale != self.loss_scale {
            self.loss_scale = scale;
            // The lifted damper's poles saved were worked out at the old losses.
            self.lifted.0 = f64::NAN;
        }
    }

    /// Take over `old`'s motion (a rebuild of this string's tables while it rings):
    /// the modes it shares, and a pressed tangent. `old` lets go of its exciter.
    ///
    /// Allocates: no.
    pub fn take_motion_from(&mut self, old: &mut StruckString) {
        let tangent = match &old.exciter {
            Exciter::Tangent(rig) => rig.state(),
            _ => None,
        };
        old.release_exciter();
        self.exciter.forget();
        self.bank.copy_motion_from(&old.bank);
        if let (Some(state), Exciter::Tangent(rig)) = (tangent, &mut self.exciter) {
            rig.take_over(&mut self.bank, state, self.audio.step_s);
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
        self.exciter.is_settled()
    }

    /// The string's displacement at `points.len()` equally spaced points from the
    /// bridge (x = 0) to the far end (x = L), the tangent's lift included, m.
    ///
    /// Allocates: no.
    pub fn shape_m(&self, points: &mut [f32]) {
        self.shape_with(self.tangent_position_m(), |i| self.bank.displacement(i), points);
    }

    /// Its modes' displacements now, as many as `out` holds (the lowest), m,
    /// and where a tangent holds its end: what [`Self::shape_of`] draws later.
    /// Returns how many modes were written. Allocates: no.
    pub fn displacements(&self, out: &mut [f64]) -> (usize, f64) {
        let n = out.len().min(self.string.modes.len());
        for (i, d) in out[..n].iter_mut().enumerate() {
            *d = self.bank.displacement(i);
        }
        (n, self.tangent_position_m())
    }

    /// [`Self::shape_m`] of this string as it stood when [`Self::displacements`]
    /// gave `displacements` and `end_m` (modes past them left out).
    pub fn shape_of(&self, displacements: &[f64], end_m: f64, points: &mut [f32]) {
        self.shape_with(end_m, |i| displacements.get(i).copied().unwrap_or(0.0), points);
    }

    fn shape_with(&self, end_m: f64, displacement: impl Fn(usize) -> f64, points: &mut [f32]) {
        let count = points.len();
        // The points' angles theta = pi x, turned from one point to the next
        // (no cosine and sine per point: the live view draws two shapes a
        // frame, in the audio thread; the turning's rounding is far below a
        // pixel).
        let (turn_sin, turn_cos) = (std::f64::consts::PI / count.saturating_sub(1).max(1) as f64).sin_cos();
        let (mut cos, mut sin) = if count > 1 { (1.0, 0.0) } else { (0.0, 1.0) };
        for (j, p) in points.iter_mut().enumerate() {
            let x = if count > 1 { j as f64 / (count - 1) as f64 } else { 0.5 };
            // sin(n theta) by the recurrence s_{n+1} = 2 cos(theta) s_n - s_{n-1}.
            let two_cos = 2.0 * cos;
            let (mut s_prev, mut s_now) = (0.0, sin);
            (cos, sin) = (cos * turn_cos - sin * turn_sin, sin * turn_cos + cos * turn_sin);
            let mut y = end_m * x;
            for (i, mode) in self.string.modes.iter().enumerate() {
                debug_assert_eq!(mode.number, i + 1);
                y += displacement(i) * s_now;
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
    /// static lift or a coasting hammer's share to `out` (`acc` and `out` the same
    /// length). Returns false (doing nothing) when an exciter is otherwise in play.
    ///
    /// Allocates: no.
    pub fn accumulate_free(&mut self, acc: &mut [[f64; LANES]], out: &mut [f64]) -> bool {
        if !self.free_for(out) {
            return false;
        }
        self.bank.accumulate_free(&self.audio, acc);
        true
    }

    /// Whether its modes turn freely over `out.len()` samples (no exciter in
    /// play, a hammer flying clear of it, or a tangent resting on it), adding a
    /// coasting hammer's share or a resting tangent's static lift to `out`:
    /// then [`Self::accumulate_free`] without it, or a gathering
    /// ([`ModalBank::gather_free`] with [`Self::audio`]), advances them.
    pub fn free_for(&mut self, out: &mut [f64]) -> bool {
        if let Exciter::Hammer(rig) = &mut self.exciter
            && rig.coasting()
        {
            rig.coast(self.audio.step_s, out);
            return true;
        }
        if let Exciter::Tangent(rig) = &self.exciter
            && let Some(to_m) = rig.resting_at_m()
        {
            let line = self.string.tension_n * to_m / self.string.length_m;
            out.iter_mut().for_each(|o| *o += line);
            return true;
        }
        !self.exciter.in_play()
    }

    /// Take back its modes' state from `gather`, where they were gathered at
    /// `at` with [`Self::audio`] ([`ModalBank::scatter_free`]).
    pub fn scatter_free(&mut self, gather: &FreeGather, at: usize) {
        self.bank.scatter_free(&self.audio, gather, at);
    }

    /// The audio rate's step of its modes.
    pub fn audio(&self) -> &StepTable {
        &self.audio
    }

    /// The present state, without stepping.
    pub fn current(&self) -> Tick {
        let played = match &self.exciter {
            Exciter::None => None,
            Exciter::Hammer(rig) => rig.current(&self.bank),
            Exciter::Tangent(rig) => rig.current(&self.bank, &self.string),
            Exciter::Pluck(rig) => rig.current(&self.bank),
        };
        played.unwrap_or_else(|| Tick { bridge_force_n: self.bank.bridge_force_n(), ..Tick::default() })
    }

    /// Advance one sample and report it.
    pub fn tick(&mut self) -> Tick {
        self.tick_observed(&mut ())
    }

    /// Advance one sample, telling `observer` about every (sub)step of a hammer.
    ///
    /// Allocates: no.
    pub fn tick_observed(&mut self, observer: &mut impl ContactObserver) -> Tick {
        let played = match &mut self.exciter {
            Exciter::None => None,
            Exciter::Hammer(rig) => rig.tick(&mut self.bank, &self.audio, &self.fine, self.hold_samples, observer),
            Exciter::Tangent(rig) => rig.tick(&mut self.bank, &self.audio, &self.string),
            Exciter::Pluck(rig) => rig.tick(&mut self.bank, &self.audio),
        };
        played.unwrap_or_else(|| {
            let mut out = [0.0];
            self.bank.process_free(&self.audio, &mut out);
            Tick { bridge_force_n: out[0], ..Tick::default() }
        })
    }

    /// [`Self::tick`] with a hammer's sub-steps in the baseline's build, or
    /// (`avx2`) in AVX2's, whatever the machine would choose (tests compare
    /// them with the dispatched one; AVX2's only where the machine has it).
    #[cfg(test)]
    fn tick_built_for(&mut self, avx2: bool) -> Tick {
        let (bank, audio, fine, hold) = (&mut self.bank, &self.audio, &self.fine, self.hold_samples);
        let ticked = match &mut self.exciter {
            #[cfg(target_arch = "x86_64")]
            Exciter::Hammer(rig) if avx2 => {
                assert!(is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"));
                // SAFETY: the features were checked just above.
                unsafe { rig.tick_avx2(bank, audio, fine, hold, &mut ()) }
            }
            Exciter::Hammer(rig) => {
                rig.tick_inline(crate::modal_bank::Kernel::detected(), bank, audio, fine, hold, &mut ())
            }
            _ => None,
        };
        ticked.unwrap_or_else(|| self.tick())
    }

    /// Whether a hammer is in or near contact (the string is being sub-stepped).
    pub fn in_contact(&self) -> bool {
        matches!(&self.exciter, Exciter::Hammer(rig) if rig.in_contact())
    }

    /// The hammer, if one is in play.
    pub fn hammer(&self) -> Option<&Hammer> {
        match &self.exciter {
            Exciter::Hammer(rig) => rig.hammer(),
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
            Exciter::Hammer(rig) => rig.absorbed_j(),
            _ => 0.0,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::exciter::hammer::contact::ContactLaw;

    /// The poles put back for a lifted damper are the ones worked out for it,
    /// at the string's own pitch and at a bent one.
    #[test]
    fn lifted_poles_are_put_back_as_worked_out() {
        let string = || StruckString::new(crate::string::test_string(3e-4, 12_000.0), 48_000.0, 4);
        let worked_out = |pitch: f64| {
            // (Damped first, so the lifted poles are worked out, not put back.)
            let mut s = string();
            s.set_free_step(5.0, 1e-3, pitch);
            for (i, mode) in s.string.modes.iter().enumerate() {
                s.audio.set_pole(i, mode.decay_rate_s(), pitch * mode.damped_omega_rad_s());
            }
            s.audio.save_poles()
        };
        let mut s = string();
        assert_eq!(s.audio.save_poles(), worked_out(1.0));
        s.set_free_step(5.0, 1e-3, 1.0);
        assert_ne!(s.audio.save_poles(), worked_out(1.0));
        s.set_free_step(0.0, 0.0, 1.0);
        assert_eq!(s.audio.save_poles(), worked_out(1.0));
        // A bend: worked out, then put back after a damper.
        s.set_free_step(0.0, 0.0, 1.03);
        assert_eq!(s.audio.save_poles(), worked_out(1.03));
        s.set_free_step(2.0, 0.0, 1.03);
        s.set_free_step(0.0, 0.0, 1.03);
        assert_eq!(s.audio.save_poles(), worked_out(1.03));
        s.set_free_step(0.0, 0.0, 1.0);
        assert_eq!(s.audio.save_poles(), worked_out(1.0));
    }

    /// Once its hammer flies clear (checked at each 64-sample tick), a string
    /// turns freely in blocks while the hammer stays in play; it plays what the
    /// string stepped sample by sample plays, but for rounding, and its hammer
    /// flies the same.
    #[test]
    fn a_string_turns_freely_once_its_hammer_flies_clear() {
        let spec = HammerSpec::one_of(1, 0.006, ContactLaw { stiffness: 1e9, exponent: 2.5 }, 2.0, 0.12);
        let string = || {
            let mut s = StruckString::new(crate::string::test_string(3e-4, 12_000.0), 48_000.0, 4);
            s.strike(spec);
            s
        };
        const BLOCK: usize = 64;
        let (mut stepped, mut coasting) = (string(), string());
        let (mut a, mut b) = (vec![0.0; 40 * BLOCK], vec![0.0; 40 * BLOCK]);
        for o in a.iter_mut() {
            *o = stepped.tick().bridge_force_n;
        }
        let mut free_blocks = 0;
        for block in b.chunks_mut(BLOCK) {
            coasting.watch_hammer();
            let mut acc = [[0.0; LANES]; BLOCK];
            if coasting.accumulate_free(&mut acc, block) {
                free_blocks += 1;
                for (o, lanes) in block.iter_mut().zip(&acc) {
                    *o += crate::modal_bank::lane_sum(lanes);
                }
            } else {
                for o in block.iter_mut() {
                    *o = coasting.tick().bridge_force_n;
                }
            }
        }
        // Clear within a few milliseconds of the strike, and in play throughout.
        assert!(free_blocks >= 35, "{free_blocks} blocks free of 40");
        assert!(coasting.hammer().is_some() && !coasting.is_settled());
        let peak = a.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let worst = a.iter().zip(&b).fold(0.0f64, |m, (x, y)| m.max((x - y).abs()));
        assert!(worst <= 1e-12 * peak, "{worst} against {peak}");
        let (ha, hb) = (stepped.hammer().unwrap(), coasting.hammer().unwrap());
        assert!((ha.position_m - hb.position_m).abs() <= 1e-15 && ha.velocity_m_s == hb.velocity_m_s);
    }

    /// The live view's shape of a string is the sum of its modes' shapes at
    /// every point (the points' angles turned one to the next: to f32's
    /// rounding), its ends at rest.
    #[test]
    fn the_drawn_shape_is_the_modes_sum() {
        let spec = HammerSpec::one_of(1, 0.008, ContactLaw { stiffness: 1e9, exponent: 2.5 }, 3.0, 0.12);
        let mut s = StruckString::new(crate::string::test_string(3e-4, 12_000.0), 48_000.0, 4);
        s.strike(spec);
        for _ in 0..40 {
            s.tick();
        }
        let mut peak = 0.0f64;
        for count in [257, 65, 3] {
            let mut points = vec![0.0f32; count];
            s.shape_m(&mut points);
            let exact: Vec<f64> = (0..count)
                .map(|j| {
                    let x = j as f64 / (count - 1) as f64;
                    let modes = s.string.modes.iter().enumerate();
                    modes
                        .map(|(i, m)| s.bank.displacement(i) * (m.number as f64 * std::f64::consts::PI * x).sin())
                        .sum()
                })
                .collect();
            // (The string's peak, from the finest drawing.)
            peak = exact.iter().fold(peak, |m, y| m.max(y.abs()));
            assert!(peak > 0.0);
            for (j, (p, y)) in points.iter().zip(&exact).enumerate() {
                assert!((f64::from(*p) - y).abs() <= 1e-6 * peak, "{count} points, point {j}: {p} against {y}");
            }
        }
    }

    /// A hammer's sub-steps give the same bits in every build the machine may
    /// run them in (AVX-512, AVX2 with FMA, the baseline): a hard and a soft
    /// felt, elastic and with hysteresis, struck twice into the ringing string.
    #[test]
    fn a_strike_steps_the_same_bits_in_every_build() {
        let felts = [
            (ContactLaw { stiffness: 4e9, exponent: 3.0 }, None),
            (
                ContactLaw { stiffness: 2e8, exponent: 2.3 },
                Some(crate::exciter::hammer::Hysteresis { epsilon: 0.2, tau_s: 1e-5 }),
            ),
        ];
        for (law, hysteresis) in felts {
            let spec = HammerSpec::one_of(1, 0.008, law, 4.0, 0.12).with_hysteresis(hysteresis);
            #[cfg(target_arch = "x86_64")]
            let avx2 = is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma");
            #[cfg(not(target_arch = "x86_64"))]
            let avx2 = false;
            let mut strings =
                [(); 3].map(|_| StruckString::new(crate::string::test_string(3e-4, 12_000.0), 48_000.0, 6));
            let mut sub_stepped = 0;
            for _ in 0..2 {
                strings.iter_mut().for_each(|s| s.strike(spec));
                for t in 0..1500 {
                    sub_stepped += usize::from(strings[0].in_contact());
                    let (a, b) = (strings[0].tick(), strings[1].tick_built_for(false));
                    let c = if avx2 { strings[2].tick_built_for(true) } else { a };
                    let bits = |t: Tick| {
                        [t.contact_force_n, t.bridge_force_n, t.exciter_position_m.unwrap_or(-1.0), t.string_position_m]
                            .map(f64::to_bits)
                    };
                    assert_eq!(bits(a), bits(b), "sample {t}: the baseline's");
                    assert_eq!(bits(a), bits(c), "sample {t}: AVX2's");
                }
            }
            assert!(sub_stepped > 100, "{sub_stepped} samples sub-stepped");
            let (a, b) = (strings[0].hammer().unwrap(), strings[1].hammer().unwrap());
            assert_eq!(
                (a.position_m.to_bits(), a.velocity_m_s.to_bits()),
                (b.position_m.to_bits(), b.velocity_m_s.to_bits())
            );
        }
    }

    /// A strike or pluck at a new point moves the string's tables there in
    /// place: they are, to the bit, the tables built there afresh, and back
    /// again the ones it had.
    #[test]
    fn tables_moved_in_place_are_the_ones_built_there() {
        let at = |position: f64, pluck: bool| {
            let mut s =
                StruckString::with_substep_counts(crate::string::test_string(3e-4, 12_000.0), 48_000.0, &[2, 8]);
            if pluck {
                s.prepare_pluck(position)
            } else {
                s.prepare_hammer(position)
            }
            s
        };
        for pluck in [false, true] {
            let (mut moved, there, home) = (at(0.12, pluck), at(0.31, pluck), at(0.12, pluck));
            for (to, expected) in [(0.31, &there), (0.12, &home)] {
                let StruckString { string, bank, audio, fine, exciter, .. } = &mut moved;
                match (exciter, &expected.exciter) {
                    (Exciter::Hammer(rig), Exciter::Hammer(built)) => {
                        rig.move_to(string, bank, audio, fine, to);
                        assert!(rig.same_tables(built), "the hammer's tables at {to}");
                    }
                    (Exciter::Pluck(rig), Exciter::Pluck(built)) => {
                        rig.move_to(string, bank, audio, to);
                        assert!(*rig == *built, "the plectrum's tables at {to}");
                    }
                    _ => panic!("no rig"),
                }
            }
        }
    }
}
