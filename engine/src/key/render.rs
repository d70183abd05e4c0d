//! A key's sound over a stretch: the free strings and the phantom products
//! gathered and run together, the strings still played stepped sample by
//! sample, the gains and fades, the key bed's knock.

use super::{Bridge, CONTROL_BLOCK, FreeGather, Key, LANES, add_lane_sums};

impl Key {
    /// Hand its strings' (and products') state back from the gathering they
    /// run in (see [`Self::render`]): each control block, and before anything
    /// else reads or moves them. Allocates: no.
    pub fn settle(&mut self) {
        if !self.run.live {
            return;
        }
        self.run.live = false;
        for (s, at) in self.strings.iter_mut().zip(&self.run.gathered) {
            if let Some(at) = *at
                && at != usize::MAX
            {
                s.scatter_free(&self.run.gather, at);
            }
        }
        self.phantom.scatter(&self.run.gather);
    }

    /// The key's force on the bridge over a stretch as long as `force`, at its
    /// output gain, moving its fade. The summed contact force goes to
    /// `contact` when given. [`Self::drive`] hands it to the bridge.
    pub fn sound(&mut self, force: &mut [f64], contact: Option<&mut [f32]>) {
        let scratch = force;
        scratch.fill(0.0);
        self.render(scratch, contact);
        let glide = self.regulation.gain != self.regulation.gain_to;
        if !glide && self.fade.step == 0.0 && self.trim.volume_step == 0.0 {
            // Most stretches: one gain throughout.
            let (g, f, s) = (self.gain_per_n * self.trim.volume, self.fade.gain, self.regulation.gain);
            scratch.iter_mut().for_each(|v| *v = *v * g * f * s);
        } else {
            for v in scratch.iter_mut() {
                if glide {
                    self.regulation.gain += (self.regulation.gain_to - self.regulation.gain) * self.regulation.glide;
                }
                if self.trim.volume_step != 0.0 {
                    self.trim.volume += self.trim.volume_step;
                    if (self.trim.volume - self.trim.volume_to) * self.trim.volume_step >= 0.0 {
                        (self.trim.volume, self.trim.volume_step) = (self.trim.volume_to, 0.0);
                    }
                }
                *v = *v * self.gain_per_n * self.trim.volume * self.fade.gain * self.regulation.gain;
                if self.fade.step != 0.0 {
                    self.fade.gain = (self.fade.gain + self.fade.step).clamp(0.0, 1.0);
                    if self.fade.gain >= 1.0 && self.fade.step > 0.0 {
                        self.fade.step = 0.0;
                    }
                }
            }
        }
        self.add_key_bed(scratch);
        if self.fade.gain <= 0.0 && self.fade.step < 0.0 {
            // Faded out: silent from the next sample; reported at the next control tick.
            self.fade.step = 0.0;
            self.fade.gain = 0.0;
        }
    }

    /// Drive `bridge` with what [`Self::sound`] gave over its stretch.
    pub fn drive(&mut self, bridge: &mut Bridge, force: &[f64]) {
        if self.trim.pan.is_placed() {
            bridge.drive_placed(self.bridge_point, force, &mut self.trim.pan);
        } else {
            bridge.drive(self.bridge_point, force);
        }
    }

    /// Add the key bed's pulse, while it lasts, to `out` (at output gain).
    pub(super) fn add_key_bed(&mut self, out: &mut [f64]) {
        let Some((start, speed)) = self.action.bed_pulse else { return };
        // The key's own volume (a note expression) takes its knock with it.
        let gain = self.gain_per_n * self.trim.volume * self.fade.gain * self.action.noise.key_bed;
        let done = self.action.bed.add(start, speed, gain, out);
        self.action.bed_pulse = (done < self.action.bed.len()).then_some((done, speed));
    }

    /// Add the key's summed bridge force (N) over `out.len()` samples to `out`,
    /// and the summed contact force to `contact` when given.
    pub(super) fn render(&mut self, out: &mut [f64], mut contact: Option<&mut [f32]>) {
        if self.course.coupling_s_kg > 0.0 {
            self.render_coupled(out, contact);
            return;
        }
        // Which strings turn freely over this stretch (a resting tangent's lift
        // goes to `out`); the others step sample by sample.
        for (s, free) in self.strings.iter_mut().zip(self.run.free_now.iter_mut()) {
            // (A string whose hammer flies clear turns freely even while the
            // live view records: it adds no contact force, and how it is
            // stepped then never depends on where a recording ends.)
            *free = (contact.is_none() || s.coasting()) && s.free_for(out);
        }
        if self.run.live && self.run.free_now.iter().zip(&self.run.gathered).any(|(f, at)| *f != at.is_some()) {
            self.settle();
        }
        // The free strings' modes (and the phantom products) are gathered and
        // run together, which fills `acc`; the gathering holds them until the
        // key is settled, so a control block cut into stretches runs as one.
        if !self.run.live {
            let gather = &mut self.run.gather;
            gather.clear();
            for ((s, free), at) in self.strings.iter().zip(&self.run.free_now).zip(self.run.gathered.iter_mut()) {
                // (With no room, which the room made for it rules out, it runs alone.)
                *at = free.then(|| s.bank().gather_free(s.audio(), gather).unwrap_or(usize::MAX));
            }
            self.phantom.gather(gather);
            self.run.live = true;
        }
        for (s, free) in self.strings.iter_mut().zip(&self.run.free_now) {
            if *free {
                continue;
            }
            for (t, o) in out.iter_mut().enumerate() {
                let tick = s.tick();
                *o += tick.bridge_force_n;
                if let Some(c) = contact.as_deref_mut() {
                    c[t] += tick.contact_force_n as f32;
                }
            }
        }
        let acc = &mut self.run.lanes[..out.len()];
        self.run.gather.run_fresh(acc);
        for (s, at) in self.strings.iter_mut().zip(&self.run.gathered) {
            if *at == Some(usize::MAX) {
                s.accumulate_free(acc, &mut []);
            }
        }
        self.phantom.accumulate_alone(acc);
        add_lane_sums(acc, out);
        if self.phantom.is_fading() {
            self.phantom.add(&mut self.run.lanes, out);
        }
    }
}

/// The free strings' modes and the phantom products, advanced together
/// ([`FreeGather`]), and where each string's lie in it. Whether the
/// gathering holds its free strings' (and products') state now: it is taken
/// once and run on over a control block's stretches, and handed back
/// ([`Key::settle`]) before anything else reads or moves them. Which strings
/// ran free, and their bridge force by lane.
#[derive(Clone)]
pub(super) struct FreeRun {
    pub(super) gather: FreeGather,
    pub(super) gathered: Vec<Option<usize>>,
    pub(super) live: bool,
    pub(super) free_now: Vec<bool>,
    pub(super) lanes: Box<[[f64; LANES]; CONTROL_BLOCK]>,
}
