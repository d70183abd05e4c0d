//! A course's strings trading energy: the unison's partials through the
//! body every few control blocks, and strings that share a bridge point
//! (a dulcimer's course) sample by sample.

use super::{Complex64, Key, MAX_UNISON, trade};

impl Key {
    /// A control block of the unison's strings trading energy through their
    /// bridge point (Weinreich 1977): partial by partial, the strings' mean
    /// moves the bridge and with it every string, so the mean (the strings in
    /// step) loses into the body N times as fast as one string alone, and
    /// whatever differs from it (strings out of step) not at all. Each string's
    /// own loss is in its free step; this applies the rest, exactly for the
    /// coupling over [`TRADE_BLOCKS`] blocks (the detuning turns the strings
    /// apart by hundredths of a radian in that time). Partials no string
    /// computes are left alone, and a mode at rest takes its share only if it
    /// is over `floor_n`. Allocates: no.
    pub(super) fn trade_through_bridge(&mut self, floor_n: f64) {
        self.settle();
        self.cull.due_in = 0;
        if self.unison.steps.is_empty() {
            return;
        }
        let top = self.strings.iter().map(|s| s.bank().running()).max().unwrap_or(0).min(self.unison.steps.len());
        let mut phasors = [Complex64::new(0.0, 0.0); MAX_UNISON];
        let strings = self.strings.len().min(MAX_UNISON);
        for (i, &step) in self.unison.steps[..top].iter().enumerate() {
            for (z, s) in phasors.iter_mut().zip(&self.strings) {
                *z = s.bank().phasor(i);
            }
            if phasors[..strings].iter().all(|z| z.re.abs() + z.im.abs() < floor_n.max(f64::MIN_POSITIVE)) {
                continue;
            }
            trade(step, &mut phasors[..strings]);
            for (z, s) in phasors.iter().zip(&mut self.strings) {
                // A mode at rest is woken only if what it takes would not be
                // culled at once.
                if i < s.bank().running() || z.re.abs() + z.im.abs() >= floor_n {
                    s.bank_mut().set_phasor(i, *z);
                }
            }
        }
    }

    /// [`Self::render`] for a course whose strings share a bridge point: each
    /// sample the bridge moves under the strings' force, at Re Y times it, and
    /// carries every string's end with it. A string's own push on the bridge is
    /// already among its losses, so each string's end is moved by the others'
    /// force alone: with its own share that makes the whole coupling Y times the
    /// square of the summed force, which only ever takes energy out.
    ///
    /// Each string takes the bridge's move with its next sample's step (one
    /// pass over its modes instead of two), the last sample's at the end.
    pub(super) fn render_coupled(&mut self, out: &mut [f64], mut contact: Option<&mut [f32]>) {
        const MOST: usize = 8;
        let y = self.course.coupling_s_kg * self.course.share;
        // Each string's bridge move still to take.
        let mut moved = [None::<f64>; MOST];
        for (t, o) in out.iter_mut().enumerate() {
            let (mut total, mut total_before) = (0.0, 0.0);
            for (i, s) in self.strings.iter_mut().enumerate() {
                let tick = match moved.get_mut(i).and_then(Option::take) {
                    Some(dv) => s.tick_moved(dv),
                    None => s.tick(),
                };
                self.course.force_now_n[i] = tick.bridge_force_n;
                total += tick.bridge_force_n;
                total_before += self.course.force_n[i];
                if let Some(c) = contact.as_deref_mut() {
                    c[t] += tick.contact_force_n as f32;
                }
            }
            *o += total;
            for (i, s) in self.strings.iter_mut().enumerate() {
                let own_change = self.course.force_now_n[i] - self.course.force_n[i];
                let dv = y * (total - total_before - own_change);
                match moved.get_mut(i) {
                    Some(due) => *due = Some(dv),
                    None => s.move_bridge(dv),
                }
            }
            std::mem::swap(&mut self.course.force_n, &mut self.course.force_now_n);
        }
        for (s, due) in self.strings.iter_mut().zip(moved) {
            if let Some(dv) = due {
                s.move_bridge(dv);
            }
        }
        self.phantom.add(&mut self.run.lanes, out);
    }
}

/// How [`TRADE_BLOCKS`] control blocks of the unison's trading through the
/// body move each partial: the share that differs from the strings' mean by
/// alpha, the mean by beta (empty: strings not coupled so), and the control
/// blocks since the unison last traded.
#[derive(Clone)]
pub(super) struct Unison {
    pub(super) steps: Vec<(Complex64, Complex64)>,
    pub(super) blocks_since_trade: usize,
}

/// Re Y of the shared bridge point (0: strings not coupled), the share of
/// it the strings trade at sample by sample ([`COURSE_LOOP_LIMIT`]), the
/// force each string put on it last sample, and scratch for this sample's.
#[derive(Clone)]
pub(super) struct CourseBridge {
    pub(super) coupling_s_kg: f64,
    pub(super) share: f64,
    pub(super) force_n: Vec<f64>,
    pub(super) force_now_n: Vec<f64>,
}
