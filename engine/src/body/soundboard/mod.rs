//! The body as it runs: its modes driven by the bridge's zones, heard by a pair
//! of microphones.
//!
//! Each mode is a complex one-pole like a string's: its displacement q is the
//! real part of z, z <- p z + w F, with p = exp(lambda h) and the zone forces F
//! weighted by the mode's shape at each zone over its modal mass. What a
//! microphone hears is the modes' acceleration, q'' = Re(lambda^2 z +
//! lambda g u), weighted by [`super::radiation`]: the first term runs per mode,
//! the second (the force's direct share) is summed over the modes once, per
//! zone, when the body is built. Together they vanish for a steady push (no
//! sound from a static force) and fall as the square of frequency below the
//! board's first mode, as a real board's radiation does.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::f64::consts::PI;

use multiversion::multiversion;
use num_complex::Complex64;
use serde::{Deserialize, Serialize};

use super::boards::{BodyDesign, MAX_ZONES};
use super::plate::{BodyMode, shape_at};
use super::radiation::{MicPair, MicPosition};
use crate::CONTROL_BLOCK;
use crate::modal_bank;

mod kernels;
use kernels::*;

/// Modes are carried up to this frequency (or 0.45 of the sample rate): above
/// it a string's partials reach the microphones only through the modes' mass
/// line (the direct share).
pub const BODY_TOP_HZ: f64 = 8_000.0;

/// Below this level (full scale: -120 dBFS, where a key falls silent too) with
/// no force coming in, the body is at rest. The bound summed over modes is
/// the sum of each mode's largest reach, so the body is quieter still.
const REST_LEVEL: f64 = 1e-6;

/// A mode whose state (momentum, N s) falls under this is set at rest at the
/// end of a block, 360 dB above f32's subnormals (the boards' fastest modes
/// shed about 6 dB a block). It would be heard at under -300 dBFS; left
/// alone, a mode that dies fast or was barely moved reached the subnormals,
/// which some processors step a hundred times slower, within a tenth of a
/// second of the last push.
const STATE_FLOOR: f32 = 1e-20;

/// The body's modes run in single precision, this many to a group (a vector
/// register's worth on AVX-512, two on AVX2).
const LANES: usize = 2 * modal_bank::LANES;

/// A group of modes' values.
type Lanes = [f32; LANES];

// A group's two halves pair up with a string's group of lanes (`pair_up`).
const _: () = assert!(modal_bank::LANES == 8 && LANES == 16);

/// Where the pair of microphones listens from.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub enum Perspective {
    /// Close over the board, one microphone toward each end of the bridges.
    #[default]
    Close,
    /// Where the player sits: in front of the board, head high, a pair as far
    /// apart as a listener's ears and a little more.
    Player,
    /// Above the open lid, on the far side from the player.
    Lid,
    /// A mid-side pair at one point over the board: it keeps its whole sound
    /// when the stereo pair is summed to mono (a stage's or a broadcast's
    /// mono feed), where a spaced pair comb-filters.
    Coincident,
}

impl Perspective {
    pub const ALL: [Perspective; 4] =
        [Perspective::Close, Perspective::Player, Perspective::Lid, Perspective::Coincident];

    pub fn name(self) -> &'static str {
        match self {
            Perspective::Close => "close",
            Perspective::Player => "player",
            Perspective::Lid => "lid",
            Perspective::Coincident => "coincident",
        }
    }
}

/// Where the microphones stand, relative to the board.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
#[serde(default)]
pub struct MicPlacement {
    pub perspective: Perspective,
    /// Stereo width: the pair's spacing as a fraction of the perspective's
    /// own (0: both in one place, a mono pair).
    pub width: f64,
}

impl Default for MicPlacement {
    fn default() -> Self {
        Self { perspective: Perspective::Close, width: 1.0 }
    }
}

impl MicPlacement {
    /// The pair for `board`, left toward the bass. The pair runs parallel to
    /// the bridges' run from the lowest key to the highest (u); "in front"
    /// and "beyond" lie across it (v). Close: 0.7 m over the board's middle,
    /// as far apart as the bridges' run (at least 0.4 m). Player: 0.6 m apart,
    /// 0.9 m up, half a metre in front of the board's edge. Lid: 1 m apart,
    /// 1.6 m up, 0.3 m beyond the far edge. Coincident: one point 0.7 m over
    /// the bridge where the middle key bears, its figure-8 along u (the width
    /// scales the side). Not over the board's middle: the equivalent
    /// rectangle's modes are exactly symmetric or antisymmetric about it, and
    /// an omnidirectional capsule there would hear only the modes odd both
    /// ways (at full side gain the cimbalom's A#3 lost 14 dB in mono there,
    /// 3.5 over the bridge).
    pub fn positions(&self, board: &BodyDesign) -> MicPair {
        let (lo, hi) = (*board.keys.start(), *board.keys.end());
        let (a, b) = (board.plate.length_m, board.plate.width_m);
        let (bass, treble) = (board.bridge_point(lo), board.bridge_point(hi));
        let (dx, dy) = ((treble.0 - bass.0) * a, (treble.1 - bass.1) * b);
        let run = dx.hypot(dy).max(1e-9);
        let u = (dx / run, dy / run);
        let v = (-u.1, u.0);
        // Half the board's extent across the run.
        let across = 0.5 * (a * v.0.abs() + b * v.1.abs());
        let (offset, height, spacing) = match self.perspective {
            Perspective::Close => (0.0, 0.7, run.max(PAIR_SPACING_M)),
            Perspective::Player => (-(across + 0.5), 0.9, 0.6),
            Perspective::Lid => (across + 0.3, 1.6, 1.0),
            Perspective::Coincident => {
                let (x, y) = board.bridge_point(board.middle_key());
                let at = MicPosition { x_m: x * a, y_m: y * b, height_m: COINCIDENT_HEIGHT_M };
                let side_gain = COINCIDENT_SIDE_GAIN * self.width.clamp(0.0, 1.0);
                return MicPair::MidSide { at, left: (-u.0, -u.1), side_gain };
            }
        };
        let half = 0.5 * self.width.clamp(0.0, 1.0) * spacing;
        let place = |side: f64| MicPosition {
            x_m: 0.5 * a + offset * v.0 + side * half * u.0,
            y_m: 0.5 * b + offset * v.1 + side * half * u.1,
            height_m: height,
        };
        MicPair::Spaced([place(-1.0), place(1.0)])
    }
}

/// The least distance between a close pair's microphones, m: over a small box
/// a wider pair sits beyond its ends, where the modes with a node across the
/// middle reach the two microphones in opposite phase and a note on one of them
/// all but cancels in mono (the santoor's A#4 lost 4.9 dB at 0.8 m, 2.5 at 0.4).
pub const PAIR_SPACING_M: f64 = 0.4;

/// The coincident pair's height over the board, m: the close pair's.
pub const COINCIDENT_HEIGHT_M: f64 = 0.7;
/// The coincident pair's side (figure-8) against its mid (omnidirectional)
/// at full width, -8 dB: left and right are then two wide subcardioids from
/// one point, facing the bass and the treble ends. Mono keeps a note's mid
/// and loses its side, 10 log10(1 + g^2 S^2 / M^2) dB: where a note's few
/// partials meet a weak spot of the mid's (a node of the modes that carry
/// them) its side can be five times the mid in power (the harpsichord's A#2,
/// the cimbalom's B2), and at 0.4 no note of any instrument loses more than
/// 2.5 dB (engine/tests/body.rs); a wider side would lose more there, and
/// the widest (1: two cardioids back to back) lost 7.6 dB.
pub const COINCIDENT_SIDE_GAIN: f64 = 0.4;

/// Everything the running body needs, built off the audio thread.
#[derive(Clone)]
pub struct Soundboard {
    zones: usize,
    /// Per group of LANES modes: pole, state, zone drive weights (Re and Im),
    /// and each microphone's weight on z (lambda^2 times the radiation).
    pole_re: Vec<Lanes>,
    pole_im: Vec<Lanes>,
    re: Vec<Lanes>,
    im: Vec<Lanes>,
    /// Each mode's complex step for a unit force held over a sample, and its
    /// shape at each zone: a zone's force drives the mode by held * shape.
    held_re: Vec<Lanes>,
    held_im: Vec<Lanes>,
    shape: Vec<[Lanes; MAX_ZONES]>,
    out: [[Vec<Lanes>; 2]; 2],
    /// The force's direct share per microphone and zone.
    direct: [[f64; MAX_ZONES]; 2],
    /// Largest microphone weight on a mode (for the rest test).
    largest_weight: f64,
    resting: bool,
    /// Output gain for "all sound off": `fade` moves by `fade_step` a sample.
    fade: f64,
    fade_step: f64,
    step_s: f64,
    gain: f64,
    acc: Box<[[Lanes; CONTROL_BLOCK]; 2]>,
    /// The groups from `half` on run apart from those before, into their own
    /// accumulators, added to `acc` after (the order every render's samples
    /// are summed in).
    half: usize,
    acc_half: Box<[[Lanes; CONTROL_BLOCK]; 2]>,
    modes: usize,
    /// Split: the modes as the right microphone hears them (some key placed in
    /// the stereo image of its own), run beside `re`/`im` (the left's) until
    /// both rest; and a second pair of accumulators for that run.
    split: bool,
    right_re: Vec<Lanes>,
    right_im: Vec<Lanes>,
    spare: Box<[[Lanes; CONTROL_BLOCK]; 2]>,
}

/// A body mode with everything per zone and per microphone worked out.
struct PlannedMode {
    pole: Complex64,
    held: Complex64,
    shape: [f64; MAX_ZONES],
    out: [Complex64; 2],
    direct: [[f64; MAX_ZONES]; 2],
}

impl Soundboard {
    /// Build `board`'s body at `sample_rate_hz` with its bridges cut into
    /// `zone_points` (fractions of the board's sides, at most [`MAX_ZONES`]),
    /// heard at `mics`, with `gain` full scale per pascal. Allocates.
    pub fn build(
        board: &BodyDesign,
        sample_rate_hz: f64,
        zone_points: &[(f64, f64)],
        mics: MicPair,
        gain: f64,
    ) -> Self {
        let h = 1.0 / sample_rate_hz;
        let top = BODY_TOP_HZ.min(0.45 * sample_rate_hz);
        let zones = zone_points.len().min(MAX_ZONES);
        let planned: Vec<PlannedMode> =
            board.running_modes(top).iter().map(|mode| plan(board, mode, &zone_points[..zones], mics, h)).collect();
        let groups = planned.len().div_ceil(LANES);
        let mut body = Self {
            zones,
            pole_re: vec![[1.0; LANES]; groups],
            pole_im: vec![[0.0; LANES]; groups],
            re: vec![[0.0; LANES]; groups],
            im: vec![[0.0; LANES]; groups],
            held_re: vec![[0.0; LANES]; groups],
            held_im: vec![[0.0; LANES]; groups],
            shape: vec![[[0.0; LANES]; MAX_ZONES]; groups],
            out: [
                [vec![[0.0; LANES]; groups], vec![[0.0; LANES]; groups]],
                [vec![[0.0; LANES]; groups], vec![[0.0; LANES]; groups]],
            ],
            direct: [[0.0; MAX_ZONES]; 2],
            largest_weight: 0.0,
            resting: true,
            fade: 1.0,
            fade_step: 0.0,
            step_s: h,
            gain,
            acc: Box::new([[[0.0; LANES]; CONTROL_BLOCK]; 2]),
            // Whole chains in the first half.
            half: groups / 2 / BODY_CHAIN * BODY_CHAIN,
            acc_half: Box::new([[[0.0; LANES]; CONTROL_BLOCK]; 2]),
            modes: planned.len(),
            split: false,
            right_re: vec![[0.0; LANES]; groups],
            right_im: vec![[0.0; LANES]; groups],
            spare: Box::new([[[0.0; LANES]; CONTROL_BLOCK]; 2]),
        };
        for (i, mode) in planned.iter().enumerate() {
            let (g, l) = (i / LANES, i % LANES);
            body.pole_re[g][l] = mode.pole.re as f32;
            body.pole_im[g][l] = mode.pole.im as f32;
            body.held_re[g][l] = mode.held.re as f32;
            body.held_im[g][l] = mode.held.im as f32;
            for z in 0..zones {
                body.shape[g][z][l] = mode.shape[z] as f32;
            }
            for (mic, out) in body.out.iter_mut().enumerate() {
                out[0][g][l] = (mode.out[mic].re * gain) as f32;
                out[1][g][l] = (mode.out[mic].im * gain) as f32;
                body.largest_weight = body.largest_weight.max(mode.out[mic].norm() * gain);
                for z in 0..zones {
                    body.direct[mic][z] += mode.direct[mic][z] * gain;
                }
            }
        }
        body
    }

    /// The sample step it runs at, s.
    pub fn step_s(&self) -> f64 {
        self.step_s
    }

    /// Its output gain, full scale per pascal.
    pub fn gain(&self) -> f64 {
        self.gain
    }

    /// How many modes it carries.
    pub fn mode_count(&self) -> usize {
        self.modes
    }

    /// Carry on ringing where `old` (the same body in tables being replaced) was.
    pub fn take_over(&mut self, old: &Soundboard) {
        if old.re.len() == self.re.len() && old.modes == self.modes {
            self.re.copy_from_slice(&old.re);
            self.im.copy_from_slice(&old.im);
            self.right_re.copy_from_slice(&old.right_re);
            self.right_im.copy_from_slice(&old.right_im);
            self.split = old.split;
            self.resting = old.resting;
        }
    }

    /// Whether every mode is at rest.
    pub fn is_resting(&self) -> bool {
        self.resting
    }

    /// Fade out over `seconds`, then fall silent (all sound off).
    pub fn fade_out(&mut self, seconds: f64) {
        if !self.resting {
            self.fade_step = -self.step_s / seconds.max(self.step_s);
        }
    }

    /// The microphones' mean power (over both) from `from_s` to `to_s` after
    /// now if nothing pushes from here on: each mode decaying from its state
    /// now, the modes adding in power (their frequencies differ, so over the
    /// window their cross terms average out). For voicing keys; not real time.
    pub fn ring_power(&self, from_s: f64, to_s: f64) -> f64 {
        let mut power = 0.0;
        for g in 0..self.re.len() {
            for l in 0..LANES {
                let z = Complex64::new(self.re[g][l].into(), self.im[g][l].into());
                let pole = Complex64::new(self.pole_re[g][l].into(), self.pole_im[g][l].into());
                let magnitude = pole.norm();
                if !(magnitude > 0.0 && magnitude < 1.0) {
                    continue;
                }
                let sigma = -magnitude.ln() / self.step_s;
                let held =
                    ((-2.0 * sigma * from_s).exp() - (-2.0 * sigma * to_s).exp()) / (2.0 * sigma * (to_s - from_s));
                for out in &self.out {
                    let w = Complex64::new(out[0][g][l].into(), out[1][g][l].into());
                    // A real signal Re(w z e^(lambda t)) has half its envelope's power.
                    power += 0.25 * (w * z).norm_sqr() * held;
                }
            }
        }
        power
    }

    /// Whether it runs once per microphone (see [`Self::process_split`]).
    pub fn is_split(&self) -> bool {
        self.split
    }

    /// Every mode at rest.
    pub fn silence(&mut self) {
        self.re.iter_mut().chain(self.im.iter_mut()).for_each(|g| *g = [0.0; LANES]);
        if self.split {
            self.right_re.iter_mut().chain(self.right_im.iter_mut()).for_each(|g| *g = [0.0; LANES]);
            self.split = false;
        }
        self.resting = true;
        self.fade = 1.0;
        self.fade_step = 0.0;
    }

    /// Run `left.len()` samples (at most a control block) of the zones' forces
    /// `forces[z][t]` (already at output gain), writing the microphones'
    /// signals. Real-time safe.
    pub fn process(&mut self, forces: &[[f64; CONTROL_BLOCK]; MAX_ZONES], left: &mut [f64], right: &mut [f64]) {
        if self.split {
            self.process_split(forces, forces, left, right);
            return;
        }
        let n = left.len().min(right.len()).min(CONTROL_BLOCK);
        let (active, count) = self.active_zones(forces, n);
        let pushed = count > 0;
        if !pushed && self.resting {
            left[..n].fill(0.0);
            right[..n].fill(0.0);
            return;
        }
        self.run_side(0, forces, &active[..count], n, true);
        let [acc_l, acc_r] = &*self.acc;
        heard(&acc_l[..n], &self.direct[0], forces, &active[..count], &mut left[..n]);
        heard(&acc_r[..n], &self.direct[1], forces, &active[..count], &mut right[..n]);
        self.finish(&mut left[..n], &mut right[..n], pushed);
    }

    /// [`Self::process`] for `n` samples without listening: the modes move
    /// to the same bits as there, and nothing is heard (for a ring weighed
    /// from where they are left, [`Self::ring_power`]). Real-time safe.
    pub fn drive(&mut self, forces: &[[f64; CONTROL_BLOCK]; MAX_ZONES], n: usize) {
        let n = n.min(CONTROL_BLOCK);
        if self.split || self.fade_step != 0.0 {
            // (Split, the right microphone's modes run too; fading, the fade
            // goes sample by sample.)
            let (mut left, mut right) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
            self.process(forces, &mut left[..n], &mut right[..n]);
            return;
        }
        let (active, count) = self.active_zones(forces, n);
        let pushed = count > 0;
        if !pushed && self.resting {
            return;
        }
        self.run_side(0, forces, &active[..count], n, false);
        self.finish(&mut [], &mut [], pushed);
    }

    /// [`Self::process`] with each microphone hearing the zones' forces as it
    /// is to (`left_forces`, `right_forces`: some key placed in the stereo
    /// image of its own): the modes run twice, once per microphone, from the
    /// state they shared when the split began, until both rest. Real-time safe.
    pub fn process_split(
        &mut self,
        left_forces: &[[f64; CONTROL_BLOCK]; MAX_ZONES],
        right_forces: &[[f64; CONTROL_BLOCK]; MAX_ZONES],
        left: &mut [f64],
        right: &mut [f64],
    ) {
        let n = left.len().min(right.len()).min(CONTROL_BLOCK);
        let ((active_l, count_l), (active_r, count_r)) =
            (self.active_zones(left_forces, n), self.active_zones(right_forces, n));
        let pushed = count_l + count_r > 0;
        if !pushed && self.resting {
            left[..n].fill(0.0);
            right[..n].fill(0.0);
            return;
        }
        if !self.split {
            // The right microphone's modes start where the shared ones are.
            self.right_re.copy_from_slice(&self.re);
            self.right_im.copy_from_slice(&self.im);
            self.split = true;
        }
        self.run_side(0, left_forces, &active_l[..count_l], n, true);
        self.run_side(1, right_forces, &active_r[..count_r], n, true);
        heard(&self.acc[0][..n], &self.direct[0], left_forces, &active_l[..count_l], &mut left[..n]);
        heard(&self.spare[1][..n], &self.direct[1], right_forces, &active_r[..count_r], &mut right[..n]);
        self.finish(&mut left[..n], &mut right[..n], pushed);
    }

    /// The zones some key pushes on in the next `n` samples, and how many.
    fn active_zones(&self, forces: &[[f64; CONTROL_BLOCK]; MAX_ZONES], n: usize) -> ([usize; MAX_ZONES], usize) {
        let mut active = [0usize; MAX_ZONES];
        let mut count = 0;
        for (z, f) in forces[..self.zones].iter().enumerate() {
            if f[..n].iter().any(|&v| v != 0.0) {
                active[count] = z;
                count += 1;
            }
        }
        (active, count)
    }

    /// Run `n` samples of the `active` zones' forces through the modes as
    /// the left microphone hears them (`side` 0: into `acc`) or the right (1:
    /// the split modes, into `spare`).
    /// Unless `heard`, the modes only move (the microphones' sums are left
    /// as they were).
    fn run_side(
        &mut self,
        side: usize,
        forces: &[[f64; CONTROL_BLOCK]; MAX_ZONES],
        active: &[usize],
        n: usize,
        heard: bool,
    ) {
        // The active zones' forces side by side, in single precision, for the kernel.
        let mut pushes = [[0.0f32; CONTROL_BLOCK]; MAX_ZONES];
        for (push, &z) in pushes.iter_mut().zip(active) {
            for (p, &f) in push[..n].iter_mut().zip(&forces[z][..n]) {
                *p = f as f32;
            }
        }
        let h = self.half;
        let [[lr, li], [rr, ri]] = &self.out;
        let (re, im, [acc_l, acc_r]) = if side == 0 {
            (&mut self.re, &mut self.im, &mut *self.acc)
        } else {
            (&mut self.right_re, &mut self.right_im, &mut *self.spare)
        };
        let (re, re_half) = re.split_at_mut(h);
        let (im, im_half) = im.split_at_mut(h);
        let [half_l, half_r] = &mut *self.acc_half;
        let (pole_re, pole_im, held_re, held_im, shape) =
            (&self.pole_re, &self.pole_im, &self.held_re, &self.held_im, &self.shape);
        let pushes = &pushes;
        {
            acc_l[..n].fill([0.0; LANES]);
            acc_r[..n].fill([0.0; LANES]);
            let modes = Modes {
                re,
                im,
                pole_re: &pole_re[..h],
                pole_im: &pole_im[..h],
                held_re: &held_re[..h],
                held_im: &held_im[..h],
                shape: &shape[..h],
                out: [&lr[..h], &li[..h], &rr[..h], &ri[..h]],
            };
            run_block(modes, pushes, active, heard, &mut acc_l[..n], &mut acc_r[..n]);
        }
        {
            half_l[..n].fill([0.0; LANES]);
            half_r[..n].fill([0.0; LANES]);
            let modes = Modes {
                re: re_half,
                im: im_half,
                pole_re: &pole_re[h..],
                pole_im: &pole_im[h..],
                held_re: &held_re[h..],
                held_im: &held_im[h..],
                shape: &shape[h..],
                out: [&lr[h..], &li[h..], &rr[h..], &ri[h..]],
            };
            run_block(modes, pushes, active, heard, &mut half_l[..n], &mut half_r[..n]);
        }
        if heard {
            add_halves(&mut acc_l[..n], &half_l[..n]);
            add_halves(&mut acc_r[..n], &half_r[..n]);
        }
    }

    /// After a stretch: the fade of an "all sound off", and rest once nothing
    /// pushes and the modes together could not reach [`REST_LEVEL`].
    fn finish(&mut self, left: &mut [f64], right: &mut [f64], pushed: bool) {
        let states = [&mut self.re, &mut self.im, &mut self.right_re, &mut self.right_im];
        let split = self.split;
        for state in states.into_iter().take(if split { 4 } else { 2 }) {
            floor_states(state);
        }
        if self.fade_step != 0.0 {
            for (l, r) in left.iter_mut().zip(right.iter_mut()) {
                self.fade = (self.fade + self.fade_step).max(0.0);
                *l *= self.fade;
                *r *= self.fade;
            }
            if self.fade <= 0.0 {
                self.silence();
                return;
            }
        }
        if !pushed {
            let reach = |re: &[Lanes], im: &[Lanes]| -> f64 {
                re.iter().zip(im).flat_map(|(r, i)| r.iter().zip(i)).map(|(r, i)| f64::from(r.abs() + i.abs())).sum()
            };
            let mut total = reach(&self.re, &self.im);
            if self.split {
                total += reach(&self.right_re, &self.right_im);
            }
            if total * self.largest_weight < REST_LEVEL {
                self.silence();
            }
        } else {
            self.resting = false;
        }
    }
}

/// `mode`'s pole, zone drives and microphone weights at sample step `h`.
fn plan(board: &BodyDesign, mode: &BodyMode, zone_points: &[(f64, f64)], mics: MicPair, h: f64) -> PlannedMode {
    let omega = 2.0 * PI * mode.frequency_hz;
    let sigma = 0.5 * mode.loss_factor * omega;
    let omega_d = omega * (1.0 - (0.5 * mode.loss_factor).powi(2)).sqrt();
    let lambda = Complex64::new(-sigma, omega_d);
    // z' = lambda z + g F on a unit shape (q = Re z: a unit impulse gives
    // q = Re(-i e^{lambda t} / (m omega_d))), stepped exactly for a force held
    // over each sample: z <- p z + g (p - 1) / lambda F.
    let g = Complex64::new(0.0, -1.0 / (mode.modal_mass_kg * omega_d));
    let pole = (lambda * h).exp();
    let held = g * (pole - 1.0) / lambda;
    let mut shape = [0.0; MAX_ZONES];
    for (d, &(x, y)) in shape.iter_mut().zip(zone_points) {
        *d = shape_at(mode, x, y);
    }
    let mut out = [Complex64::new(0.0, 0.0); 2];
    let mut direct = [[0.0; MAX_ZONES]; 2];
    for (mic, c) in mics.weights(&board.plate, mode).into_iter().enumerate() {
        out[mic] = c * lambda * lambda;
        // The force's direct share, Re(c lambda g) per unit shape: with the
        // state settling at -g F / lambda under a steady push, the two cancel.
        let share = (c * lambda * g).re;
        for (z, &(x, y)) in zone_points.iter().enumerate() {
            direct[mic][z] = share * shape_at(mode, x, y);
        }
    }
    // The state runs as momentum, m omega_d z (an impulse's, N s): a body's
    // displacements under newtons lie near 1e-12 m, and a mode little moved
    // fell to f32's subnormals within a tenth of a second.
    let momentum = mode.modal_mass_kg * omega_d;
    PlannedMode { pole, held: held * momentum, shape, out: out.map(|o| o / momentum), direct }
}

/// What a microphone hears over a stretch: each sample's lanes (`acc`, each
/// the sum of its modes over the groups, in single precision) summed across in
/// double precision in a fixed order, and the force's direct share (`direct`,
/// per zone) of the `active` zones.
fn heard(
    acc: &[Lanes],
    direct: &[f64; MAX_ZONES],
    forces: &[[f64; CONTROL_BLOCK]; MAX_ZONES],
    active: &[usize],
    out: &mut [f64],
) {
    // Each sample's two halves of lanes added in double precision, then
    // summed across as a string's lanes are.
    let mut pairs = [[0.0; modal_bank::LANES]; CONTROL_BLOCK];
    pair_up(acc, &mut pairs);
    out.fill(0.0);
    modal_bank::add_lane_sums(&pairs[..out.len().min(acc.len())], out);
    for &z in active {
        for (t, o) in out.iter_mut().enumerate() {
            *o += direct[z] * forces[z][t];
        }
    }
}

/// A body's modes with what each microphone hears of them: for working out,
/// off the audio thread, what the body does to a string's partial.
pub struct HeardModes {
    modes: Vec<BodyMode>,
    /// Pressure per unit modal acceleration at each microphone, per mode.
    radiation: Vec<[f64; 2]>,
}

impl HeardModes {
    /// `board`'s running modes up to `top_hz`, heard at `mics`.
    pub fn new(board: &BodyDesign, top_hz: f64, mics: MicPair) -> Self {
        let modes = board.running_modes(top_hz);
        let radiation = modes.iter().map(|m| mics.weights(&board.plate, m)).collect();
        Self { modes, radiation }
    }

    /// The pressure at each microphone per newton at `point` (fractions of
    /// the board) at `f_hz`: what the body does to a string's partial there.
    pub fn transfer_pa_per_n(&self, point: (f64, f64), f_hz: f64) -> [Complex64; 2] {
        self.transfer_spread_pa_per_n(&[(point, 1.0)], f_hz)
    }

    /// The same for a force shared between several points (point, share): how
    /// the running body hears a key that bears between two zones.
    pub fn transfer_spread_pa_per_n(&self, points: &[((f64, f64), f64)], f_hz: f64) -> [Complex64; 2] {
        self.transfer_shaped_pa_per_n(&self.shapes(points), f_hz)
    }

    /// Each mode's shape where a force shared between `points` (point, share)
    /// bears: what [`Self::transfer_shaped_pa_per_n`] takes, worked out once
    /// for a key heard at many frequencies.
    pub fn shapes(&self, points: &[((f64, f64), f64)]) -> Vec<f64> {
        self.modes.iter().map(|mode| points.iter().map(|&((x, y), share)| share * shape_at(mode, x, y)).sum()).collect()
    }

    /// [`Self::transfer_spread_pa_per_n`] with the modes' shapes at the points
    /// given ([`Self::shapes`]).
    pub fn transfer_shaped_pa_per_n(&self, shapes: &[f64], f_hz: f64) -> [Complex64; 2] {
        let omega = 2.0 * PI * f_hz;
        let mut p = [Complex64::new(0.0, 0.0); 2];
        for ((mode, radiation), &phi) in self.modes.iter().zip(&self.radiation).zip(shapes) {
            let wk = 2.0 * PI * mode.frequency_hz;
            // Modal acceleration per newton: -omega^2 phi / (m (wk^2 - omega^2 + i eta wk omega)).
            let acc = -omega * omega * phi
                / (mode.modal_mass_kg * Complex64::new(wk * wk - omega * omega, mode.loss_factor * wk * omega));
            p[0] += radiation[0] * acc;
            p[1] += radiation[1] * acc;
        }
        p
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::boards::design;
    use crate::design::InstrumentKind;

    /// The modes run in single precision: at every rate from 44.1 to 192 kHz
    /// each instrument's body keeps every mode's decay rate within 0.5 % and
    /// its pitch within 0.001 cent of the double-precision pole's (at worst
    /// 0.124 % and 0.0001 cent).
    #[test]
    fn single_precision_keeps_each_modes_decay_and_pitch() {
        for instrument in InstrumentKind::ALL {
            let board = design(instrument);
            let mics = MicPlacement::default().positions(&board);
            for fs in [44_100.0, 48_000.0, 96_000.0, 192_000.0] {
                let h = 1.0 / fs;
                let modes = board.running_modes(BODY_TOP_HZ.min(0.45 * fs));
                let body = Soundboard::build(&board, fs, &board.zone_points(), mics, 1.0);
                assert_eq!(body.mode_count(), modes.len());
                let (mut worst_decay, mut worst_cents) = (0.0f64, 0.0f64);
                for (i, mode) in modes.iter().enumerate() {
                    let (g, l) = (i / LANES, i % LANES);
                    let pole = Complex64::new(body.pole_re[g][l].into(), body.pole_im[g][l].into());
                    let omega = 2.0 * PI * mode.frequency_hz;
                    let sigma = 0.5 * mode.loss_factor * omega;
                    let omega_d = omega * (1.0 - (0.5 * mode.loss_factor).powi(2)).sqrt();
                    let (got_sigma, got_omega) = (-pole.norm().ln() / h, pole.arg() / h);
                    worst_decay = worst_decay.max((got_sigma / sigma - 1.0).abs());
                    worst_cents = worst_cents.max((1200.0 * (got_omega / omega_d).log2()).abs());
                }
                println!(
                    "{} at {fs} Hz: {} modes, decay within {:.3} %, pitch within {:.4} cent",
                    instrument.name(),
                    modes.len(),
                    100.0 * worst_decay,
                    worst_cents
                );
                assert!(worst_decay < 5e-3 && worst_cents < 1e-3, "{} at {fs} Hz", instrument.name());
            }
        }
    }

    /// The halves of each sample's lanes are paired alike with vector
    /// instructions and without, to the bit.
    #[test]
    fn lanes_pair_up_alike_on_every_path() {
        let mut x = 0x9e37_79b9_7f4a_7c15_u64;
        let acc: Vec<Lanes> = (0..CONTROL_BLOCK)
            .map(|_| {
                std::array::from_fn(|_| {
                    x ^= x << 13;
                    x ^= x >> 7;
                    x ^= x << 17;
                    ((x >> 40) as f32 - 8_388_608.0) * 1e-9
                })
            })
            .collect();
        let mut fast = [[0.0; modal_bank::LANES]; CONTROL_BLOCK];
        let mut plain = [[1.0; modal_bank::LANES]; CONTROL_BLOCK];
        pair_up(&acc, &mut fast);
        pair_up_portable(&acc, &mut plain);
        assert_eq!(fast, plain);
        assert_eq!(plain[3][5], f64::from(acc[3][5]) + f64::from(acc[3][13]));
    }

    /// A knock at one zone, heard through the running body, against the same
    /// modes' closed-form response in double precision (each mode's state
    /// p^t held shape F, heard at its weights, and the force's direct share):
    /// single precision parts from it by under -90 dB over half a second
    /// (-97 to -105 dB).
    #[test]
    fn a_knock_rings_as_the_double_precision_modes_do() {
        let fs = 48_000.0;
        for instrument in InstrumentKind::ALL {
            let board = design(instrument);
            let mics = MicPlacement::default().positions(&board);
            let zones = board.zone_points();
            let mut body = Soundboard::build(&board, fs, &zones, mics, 1.0);
            let planned: Vec<PlannedMode> =
                board.running_modes(BODY_TOP_HZ).iter().map(|m| plan(&board, m, &zones, mics, 1.0 / fs)).collect();
            let blocks = (0.5 * fs) as usize / CONTROL_BLOCK;
            let mut forces = [[0.0; CONTROL_BLOCK]; MAX_ZONES];
            forces[0][0] = 1.0;
            let (mut got, mut want) = (Vec::new(), Vec::new());
            let mut states: Vec<Complex64> = planned.iter().map(|m| m.held * m.shape[0]).collect();
            for b in 0..blocks {
                let (mut l, mut r) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
                body.process(&forces, &mut l, &mut r);
                for t in 0..CONTROL_BLOCK {
                    let f = forces[0][t];
                    for (mic, heard) in [l[t], r[t]].into_iter().enumerate() {
                        let modes: f64 = planned.iter().zip(&states).map(|(m, z)| (m.out[mic] * z).re).sum();
                        let direct: f64 = planned.iter().map(|m| m.direct[mic][0]).sum::<f64>() * f;
                        want.push(modes + direct);
                        got.push(heard);
                    }
                    for (m, z) in planned.iter().zip(states.iter_mut()) {
                        *z *= m.pole;
                    }
                }
                if b == 0 {
                    forces[0][0] = 0.0;
                }
            }
            let power = |x: &mut dyn Iterator<Item = f64>| x.map(|v| v * v).sum::<f64>();
            let off = power(&mut got.iter().zip(&want).map(|(g, w)| g - w));
            let off_db = 10.0 * (off / power(&mut want.iter().copied())).log10();
            println!("{}: {off_db:.1} dB off the double-precision modes", instrument.name());
            assert!(off_db < -90.0, "{}: {off_db:.1} dB", instrument.name());
        }
    }

    /// Driven without listening, the modes move to the same bits as when
    /// heard (a ring weighed from them is the same), over pushes on one
    /// zone, two and every zone, and over the rest that follows.
    #[test]
    fn driven_unheard_the_modes_move_as_when_heard() {
        let fs = 48_000.0;
        for instrument in InstrumentKind::ALL {
            let board = design(instrument);
            let mics = MicPlacement::default().positions(&board);
            let zones = board.zone_points();
            let mut heard = Soundboard::build(&board, fs, &zones, mics, 1.0);
            let mut unheard = heard.clone();
            let mut x = 0x9e37_79b9_7f4a_7c15_u64;
            for b in 0..40 {
                let mut forces = [[0.0; CONTROL_BLOCK]; MAX_ZONES];
                let pushed = match b % 4 {
                    0 => 1,
                    1 => 2,
                    2 => zones.len().min(MAX_ZONES),
                    _ => 0,
                };
                for zone in forces.iter_mut().take(pushed) {
                    for f in zone.iter_mut() {
                        x ^= x << 13;
                        x ^= x >> 7;
                        x ^= x << 17;
                        *f = (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
                    }
                }
                let n = if b == 39 { 17 } else { CONTROL_BLOCK };
                let (mut l, mut r) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
                heard.process(&forces, &mut l[..n], &mut r[..n]);
                unheard.drive(&forces, n);
                assert!(heard.re == unheard.re && heard.im == unheard.im, "{} block {b}", instrument.name());
                assert_eq!(heard.is_resting(), unheard.is_resting());
            }
            assert_eq!(heard.ring_power(0.03, 0.28).to_bits(), unheard.ring_power(0.03, 0.28).to_bits());
        }
    }

    /// A body left to die away after a knock never holds a subnormal state:
    /// its modes fall to zero under the floor, each instrument's board, hard
    /// and soft, until it rests.
    #[test]
    fn a_dying_body_falls_to_zero_not_to_subnormals() {
        for instrument in InstrumentKind::ALL {
            let board = design(instrument);
            let mics = MicPlacement::default().positions(&board);
            let zones = board.zone_points();
            for knock_n in [1.0, 1e-3] {
                let mut body = Soundboard::build(&board, 48_000.0, &zones, mics, 1.0);
                let mut forces = [[0.0; CONTROL_BLOCK]; MAX_ZONES];
                forces[0][0] = knock_n;
                let (mut l, mut r) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
                let mut blocks = 0;
                loop {
                    body.process(&forces, &mut l, &mut r);
                    forces[0][0] = 0.0;
                    blocks += 1;
                    let subnormal = body.re.iter().chain(&body.im).flatten().any(|v| v.is_subnormal());
                    assert!(!subnormal, "{} knocked at {knock_n} N, block {blocks}", instrument.name());
                    if body.is_resting() {
                        break;
                    }
                    assert!(blocks < 10 * 48_000 / CONTROL_BLOCK, "{} never rests", instrument.name());
                }
                assert!(blocks > 1, "{} rested at once", instrument.name());
            }
        }
    }

    /// The running body, driven by a sine at one zone, against the modal sum's
    /// transfer at that frequency: the stepped modes, their drive and the
    /// direct share together are the body's second-order modes.
    #[test]
    fn a_steady_sine_comes_out_as_the_transfer_says() {
        let fs = 48_000.0;
        let board = design(InstrumentKind::Piano);
        let mics = MicPlacement::default().positions(&board);
        let point = board.bridge_point(80);
        let mut body = Soundboard::build(&board, fs, &[point], mics, 1.0);
        let heard = HeardModes::new(&board, BODY_TOP_HZ, mics);
        let mut band_loudest = 0.0f64;
        for f in [
            20.0, 100.0, 120.0, 140.0, 150.0, 160.0, 180.0, 440.0, 1000.0, 2349.0, 5000.0, 7900.0, 8100.0, 9000.0,
            12000.0,
        ] {
            body.silence();
            let mut forces = [[0.0; CONTROL_BLOCK]; MAX_ZONES];
            let (mut sum_l, mut sum_r, mut count) = (0.0, 0.0, 0);
            let blocks = (2.0 * fs) as usize / CONTROL_BLOCK;
            for b in 0..blocks {
                for (t, force) in forces[0].iter_mut().enumerate() {
                    let time = (b * CONTROL_BLOCK + t) as f64 / fs;
                    *force = (2.0 * PI * f * time).sin();
                }
                let (mut l, mut r) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
                body.process(&forces, &mut l, &mut r);
                if b >= blocks / 2 {
                    sum_l += l.iter().map(|v| v * v).sum::<f64>();
                    sum_r += r.iter().map(|v| v * v).sum::<f64>();
                    count += CONTROL_BLOCK;
                }
            }
            let [tl, tr] = heard.transfer_pa_per_n(point, f);
            let (rms_l, rms_r) = ((sum_l / count as f64).sqrt(), (sum_r / count as f64).sqrt());
            let (want_l, want_r) = (tl.norm() / 2f64.sqrt(), tr.norm() / 2f64.sqrt());
            let off_db = |got: f64, want: f64| 20.0 * (got / want).log10();
            println!(
                "{f} Hz: left {:.2} dB, right {:.2} dB off the transfer ({:.1} dB re 1 Pa/N, got {:.1})",
                off_db(rms_l, want_l),
                off_db(rms_r, want_r),
                20.0 * want_l.max(want_r).log10(),
                20.0 * rms_l.max(rms_r).log10()
            );
            // Above a few hundred hertz the force held over each sample (and
            // the direct share, which is not held) part from the continuous modes
            // by a little: judged against the louder microphone, so that a trough
            // in one (where little comes out at all) does not count as a miss.
            let tolerance = if f <= 500.0 { 0.12 } else { 0.3 };
            let louder = want_l.max(want_r);
            if f > 1.1 * BODY_TOP_HZ {
                // Above its top mode the body has only its modes' tails, which
                // the stepped modes keep a little more of than the continuous
                // ones (9 kHz: -34.5 dB re 1 Pa/N against -47.7, with the
                // close pair's near-field weights): they stay 20 dB under the
                // band's loudest.
                assert!(rms_l.max(rms_r) < 0.1 * band_loudest, "{f} Hz: over the band's top");
                continue;
            }
            band_loudest = band_loudest.max(louder);
            assert!(
                (rms_l - want_l).abs() < tolerance * louder && (rms_r - want_r).abs() < tolerance * louder,
                "{f} Hz"
            );
        }
    }
}
