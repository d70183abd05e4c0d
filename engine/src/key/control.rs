//! A key once per control block: the damper moving, retuning for a bend or
//! a press, hammers let go, the unison's trade, the modes culled, the
//! phantom products refreshed, and silence noticed.

use super::{
    COURSE_LOOP_LIMIT, CULL_BELOW_LOUDEST, CULL_EVERY_BLOCKS, CULL_FLOOR, ExciterDesign, HAMMER_GONE_AFTER_S,
    HAMMER_GONE_GAP_M, Key, PRESSURE_SMOOTHING_S, PerformanceState, PhantomState, RETUNE_THRESHOLD, StruckString,
    TRADE_BLOCKS, tangent,
};

impl Key {
    /// Once per control block: move the damper, retune for a bend or a press, let
    /// go of hammers that have flown off, and notice silence. Returns true when the
    /// key has just fallen silent (it is then inactive and at rest).
    pub fn control(&mut self, block_s: f64, performance: &PerformanceState, silence: f64) -> bool {
        let (sustain, bend) = (performance.sustain, performance.bend);
        // The strings stay gathered over blocks that neither read nor move
        // them (handed back below where one does).
        if self.fade.gain <= 0.0 {
            // Faded out (stolen, reset, or its instrument replaced).
            self.silence();
            return true;
        }
        let held = self.down() || self.sostenuto;
        self.damper.follow(block_s, held, sustain);
        self.finger.pressure_now +=
            (self.finger.pressure - self.finger.pressure_now) * (1.0 - (-block_s / PRESSURE_SMOOTHING_S).exp());
        let pitch = self.pitch(bend);
        if self.damper.moved() || (pitch / self.pitch_set - 1.0).abs() > RETUNE_THRESHOLD {
            self.settle();
            self.set_poles(pitch);
        }
        let floor_n =
            (CULL_BELOW_LOUDEST * self.cull.loudest_n).max(CULL_FLOOR * silence / self.gain_per_n.max(1e-300));
        self.unison.blocks_since_trade += 1;
        if self.unison.blocks_since_trade >= TRADE_BLOCKS {
            self.unison.blocks_since_trade = 0;
            self.trade_through_bridge(floor_n);
        }
        let mut settled = true;
        // A hammer in play is watched on its string's modes as they stand (the
        // scan below brings them back in that case anyway).
        if self.strings.iter().any(|s| !s.is_settled()) {
            self.settle();
        }
        for s in &mut self.strings {
            s.watch_hammer();
            if s.hammer_gone(HAMMER_GONE_GAP_M, HAMMER_GONE_AFTER_S) {
                s.release_exciter();
            }
            settled &= s.is_settled();
        }
        // Free strings only fade: between cullings the last one's bound still
        // bounds them (a drive adds to it; a trade among the strings culls
        // at once), and the scan is skipped.
        let scan = !settled || self.cull.due_in == 0;
        self.cull.due_in = if scan { CULL_EVERY_BLOCKS - 1 } else { self.cull.due_in - 1 };
        let (mut bound, mut loudest_n) = self.cull.last;
        if scan {
            (bound, loudest_n) = match self.cull_where_gathered(settled, floor_n) {
                Some(culled) => culled,
                None => {
                    self.settle();
                    self.cull_strings(floor_n)
                }
            };
            self.cull.last = (bound, loudest_n);
        }
        // The products turn freely with their strings: they are set again only
        // when the strings' motion changed otherwise (a strike, a trade, the
        // damper, a bend), or every [`PHANTOM_REFRESH_BLOCKS`] to drop the faded.
        // While a string is played its loudest is unknown (infinite): they wait
        // for the strike to end.
        let refresh = self.phantom.refresh_due();
        if refresh && self.phantom.exists() {
            // (Read from the strings, and set anew: back from the gathering.)
            self.settle();
        }
        if self.phantom.faded_in() {
            // Faded in: gathered with the strings again from the next stretch.
            self.settle();
            self.phantom.end_fade();
        }
        if refresh {
            self.phantom.refresh(&self.strings, PhantomState::floor(floor_n, loudest_n));
        }
        // A string still being played reports an infinite loudest: no relative culling next time.
        self.cull.loudest_n = if loudest_n.is_finite() { loudest_n } else { 0.0 };
        if (self.regulation.gain - self.regulation.gain_to).abs() < 1e-6 * self.regulation.gain_to {
            self.regulation.gain = self.regulation.gain_to;
        }
        self.cull.level = bound * self.gain_per_n * self.fade.gain * self.regulation.gain.max(self.regulation.gain_to);
        self.driven = self.driven.saturating_sub(1);
        // A tangent held on its strings keeps pressing on the bridge: the key
        // stays sounding (silencing it would drop that force at once, a thump).
        let pressing = self.held != 0 && self.stays_on_strings();
        if settled && self.cull.level < silence && self.driven == 0 && !pressing {
            self.silence();
            return true;
        }
        false
    }

    /// Every string culled ([`StruckString::cull`]): their bound summed and
    /// the loudest mode.
    pub(super) fn cull_strings(&mut self, floor_n: f64) -> (f64, f64) {
        let (mut bound, mut loudest_n) = (0.0, 0.0f64);
        for s in &mut self.strings {
            let (string_bound, string_loudest) = s.cull(floor_n);
            bound += string_bound;
            loudest_n = loudest_n.max(string_loudest);
        }
        (bound, loudest_n)
    }

    /// [`Self::cull_strings`] without handing the strings back from the
    /// gathering (and gathering them again next stretch: a quarter of the
    /// keys' control blocks did), the gathered strings culled where they run:
    /// the same bound and loudest mode, the same modes put to rest. Only
    /// while every string is settled, and only if no string's running modes
    /// would shrink (the gathering would hold modes no longer run); else
    /// `None`, and the strings are culled after the settling (the modes put
    /// to rest here are at rest there: the same again).
    pub(super) fn cull_where_gathered(&mut self, settled: bool, floor_n: f64) -> Option<(f64, f64)> {
        if !settled || !self.run.live {
            return None;
        }
        let (mut bound, mut loudest_n) = (0.0, 0.0f64);
        for (i, s) in self.strings.iter_mut().enumerate() {
            let (string_bound, string_loudest) = match self.run.gathered[i] {
                Some(at) if at != usize::MAX => {
                    let n = s.bank().running();
                    let (b, loudest, top) = self.run.gather.cull(at, n, s.audio().backs(), floor_n);
                    if top < n {
                        return None;
                    }
                    (b, loudest)
                }
                _ => s.cull(floor_n),
            };
            bound += string_bound;
            loudest_n = loudest_n.max(string_loudest);
        }
        Some((bound, loudest_n))
    }

    /// Set every string's free step for the damper's present engagement and `pitch`.
    pub(super) fn set_poles(&mut self, pitch: f64) {
        self.phantom.mark_stale();
        let (rate_s, rate_per_hz_s) = self.damper.extra_decay();
        for s in &mut self.strings {
            s.set_free_step(rate_s, rate_per_hz_s, pitch);
        }
        self.pitch_set = pitch;
        if self.course.coupling_s_kg > 0.0 {
            // Each string moves the bridge under the others sample by sample:
            // the loop, Y times their answers, is held under the limit (the
            // modes a bend takes past the top no longer answer).
            let loop_gain =
                self.course.coupling_s_kg * self.strings.iter().map(StruckString::bridge_answer_ns_m).sum::<f64>();
            self.course.share = if loop_gain > COURSE_LOOP_LIMIT { COURSE_LOOP_LIMIT / loop_gain } else { 1.0 };
        }
    }

    /// At rest and inactive (the notes struck are kept for [`Self::take_sounded`]).
    pub fn silence(&mut self) {
        self.settle();
        for s in &mut self.strings {
            s.silence();
        }
        self.active = false;
        self.held = 0;
        self.sostenuto = false;
        self.speaking = 0;
        self.finger.pressure = 0.0;
        self.finger.pressure_now = 0.0;
        self.course.force_n.fill(0.0);
        self.fade.gain = 1.0;
        self.fade.step = 0.0;
        self.cull.level = 0.0;
        self.cull.loudest_n = 0.0;
        self.cull.due_in = 0;
        self.phantom.silence();
        self.action.bed_pulse = None;
    }

    /// Start sounding from rest without a stroke (its strings set ringing by
    /// the others): the damper where the pedal has it, the poles set for
    /// the bend.
    pub(super) fn wake(&mut self, performance: &PerformanceState) {
        self.active = true;
        self.cull.due_in = 0;
        self.fade.gain = 1.0;
        self.fade.step = 0.0;
        self.cull.loudest_n = 0.0;
        self.damper.settle(self.down() || self.sostenuto, performance.sustain);
        let pitch = self.pitch(performance.bend);
        self.set_poles(pitch);
    }

    /// The strings' pitch over their own: the bend, the speaking note's interval
    /// and, under a tangent, the stretch of the press. A tangent holding the end at
    /// W raises the tension by the factor 1 + s W^2 and the pitch by its square
    /// root. The finger's pressure presses deeper (Bebung: the depth follows
    /// the finger), at full pressure to the depth W_f whose stretch raises the
    /// pitch by the Bebung's cents over the rest press D: 1 + s W_f^2 =
    /// (1 + s D^2) 2^(cents / 600).
    pub(super) fn pitch(&self, bend: f64) -> f64 {
        let note = &self.notes[self.speaking];
        let stretch = match note.exciter {
            ExciterDesign::Tangent { stretch_per_m2, displacement_m, .. } => {
                let mut w = self.strings[note.struck.start].tangent_position_m();
                if self.finger.pressure_now > 0.0 && stretch_per_m2 > 0.0 {
                    let s = stretch_per_m2;
                    let full = (((1.0 + s * displacement_m * displacement_m) * self.finger.bebung - 1.0) / s).sqrt();
                    w += self.finger.pressure_now * (full - displacement_m);
                }
                tangent::stretched_pitch_ratio(stretch_per_m2, w)
            }
            _ => 1.0,
        };
        bend * self.trim.tune * note.pitch_ratio * stretch
    }
}

/// Upper bound on the key's output at the last control tick (full scale =
/// 1); the loudest mode of its strings then, N (0 while one is played);
/// control ticks until its strings are culled again (0: at the next), and
/// what the last culling found (their bound and loudest mode, N).
#[derive(Clone)]
pub(super) struct Cull {
    pub(super) level: f64,
    pub(super) loudest_n: f64,
    pub(super) due_in: u8,
    pub(super) last: (f64, f64),
}
