//! A key: its strings, its exciter, its damper, and whether it is sounding.

use crate::contact::ContactLaw;
use crate::hammer::HammerSpec;
use crate::instrument::{DamperDesign, ExciterDesign, KeyDesign};
use crate::pluck::PluckSpec;
use crate::string::StringError;
use crate::struck_string::{DEFAULT_SUBSTEPS, StruckString};
use crate::tangent::TangentSpec;

/// Time constant of a tangent falling back from the strings when the key comes up, s.
const TANGENT_LIFT_S: f64 = 0.002;
/// A hammer that has left the strings this far, moving away, this long after
/// the strike, will not come back: the strings go free (the fast path). Chosen
/// above a mallet's repeated bounces (a few ms) and a string's swing (below 0.5 mm).
const HAMMER_GONE_GAP_M: f64 = 0.5e-3;
const HAMMER_GONE_AFTER_S: f64 = 0.03;
/// Una corda: the hammer meets the strings with its less worn, softer felt. The
/// factor on K is our assumption (the physics reference has no measurement of it).
const UNA_CORDA_STIFFNESS: f64 = 0.5;

pub(super) struct Key {
    pub midi_key: u8,
    pub strings: Vec<StruckString>,
    exciter: ExciterDesign,
    damper: Option<DamperDesign>,
    pub gain_per_n: f64,
    /// Constant-power pan gains.
    pub pan_left: f64,
    pub pan_right: f64,
    // What the player is doing with it.
    pub active: bool,
    pub down: bool,
    /// Held up by the sostenuto pedal.
    pub sostenuto: bool,
    /// Damper engagement 0 (lifted) .. 1 (fully on the strings), and the values the poles were last set for.
    damper_now: f64,
    damper_set: f64,
    bend_set: f64,
    /// Output gain for stealing and resets: `fade` moves by `fade_step` per sample, within 0..=1.
    pub fade: f64,
    pub fade_step: f64,
    /// Upper bound on the key's output at the last control tick (full scale = 1).
    pub level: f64,
}

impl Key {
    /// Build every table the key will need. Allocates; off the audio thread.
    pub fn build(design: KeyDesign, sample_rate_hz: f64) -> Result<Self, StringError> {
        let mut strings = Vec::with_capacity(design.strings.len());
        for spec in &design.strings {
            let mut s = StruckString::new(spec.build()?, sample_rate_hz, DEFAULT_SUBSTEPS);
            match design.exciter {
                ExciterDesign::Hammer { position, .. } => s.prepare_hammer(position),
                ExciterDesign::Tangent { .. } => s.prepare_tangent(),
                ExciterDesign::Pluck { position } => s.prepare_pluck(position),
            }
            strings.push(s);
        }
        let angle = (design.pan.clamp(-1.0, 1.0) + 1.0) * std::f64::consts::FRAC_PI_4;
        Ok(Self {
            midi_key: design.midi_key,
            strings,
            exciter: design.exciter,
            damper: design.damper,
            gain_per_n: design.gain_per_n,
            pan_left: angle.cos() * std::f64::consts::SQRT_2,
            pan_right: angle.sin() * std::f64::consts::SQRT_2,
            active: false,
            down: false,
            sostenuto: false,
            damper_now: 0.0,
            damper_set: 0.0,
            bend_set: 1.0,
            fade: 1.0,
            fade_step: 0.0,
            level: 0.0,
        })
    }

    /// The string the live view shows: the last of the course, which the hammer
    /// strikes even under una corda.
    pub fn watched_string(&self) -> &StruckString {
        self.strings.last().expect("a key has at least one string")
    }

    /// The key goes down at exciter speed (or pluck height) `touch`.
    pub fn press(&mut self, touch: f64, una_corda: bool, bend: f64) {
        self.active = true;
        self.down = true;
        if self.fade < 1.0 || self.fade_step < 0.0 {
            self.fade_step = self.fade_step.abs().max(1e-4);
        }
        // The damper leaves the strings before the hammer arrives.
        self.damper_now = 0.0;
        self.set_poles(bend);
        match self.exciter {
            ExciterDesign::Hammer { mass_kg, law, position } => {
                let n = self.strings.len();
                // Una corda shifts the action: the first string of a unison is missed.
                let skip = usize::from(una_corda && n >= 2);
                let struck = (n - skip) as f64;
                let stiffness = law.stiffness * if una_corda { UNA_CORDA_STIFFNESS } else { 1.0 };
                for s in &mut self.strings[skip..] {
                    s.strike(HammerSpec {
                        mass_kg: mass_kg / struck,
                        law: ContactLaw { stiffness: stiffness / struck, exponent: law.exponent },
                        speed_m_s: touch,
                        position,
                    });
                }
            }
            ExciterDesign::Tangent { displacement_m, .. } => {
                for s in &mut self.strings {
                    s.press_tangent(TangentSpec { speed_m_s: touch, displacement_m });
                }
            }
            ExciterDesign::Pluck { position } => {
                for s in &mut self.strings {
                    s.pluck(PluckSpec { displacement_m: touch * 1e-3, position });
                    s.release_exciter();
                }
            }
        }
    }

    /// The key comes up.
    pub fn release(&mut self) {
        self.down = false;
        if let ExciterDesign::Tangent { .. } = self.exciter {
            for s in &mut self.strings {
                s.lift_tangent(TANGENT_LIFT_S);
            }
        }
    }

    /// Where the damper is headed, given the pedals.
    fn damper_target(&self, sustain: f64) -> f64 {
        match self.damper {
            None => 0.0,
            Some(_) if self.down || self.sostenuto => 0.0,
            Some(_) => (1.0 - sustain).clamp(0.0, 1.0),
        }
    }

    /// Once per control block: move the damper, retune for a bend, let go of
    /// hammers that have flown off, and notice silence. Returns true when the key
    /// has just fallen silent (it is then inactive and at rest).
    pub fn control(&mut self, block_s: f64, sustain: f64, bend: f64, silence: f64) -> bool {
        if self.fade <= 0.0 {
            // Faded out (stolen, reset, or its instrument replaced).
            self.silence();
            return true;
        }
        if let Some(d) = self.damper {
            let target = self.damper_target(sustain);
            let step = block_s / d.travel_s.max(block_s);
            self.damper_now += (target - self.damper_now).clamp(-step, step);
        }
        if self.damper_now != self.damper_set || bend != self.bend_set {
            self.set_poles(bend);
        }
        let mut settled = true;
        let mut bound = 0.0;
        for s in &mut self.strings {
            if s.hammer_gone(HAMMER_GONE_GAP_M, HAMMER_GONE_AFTER_S) {
                s.release_exciter();
            }
            settled &= s.is_settled();
            bound += s.amplitude_bound_n();
        }
        self.level = bound * self.gain_per_n * self.fade;
        if settled && self.level < silence {
            self.silence();
            return true;
        }
        false
    }

    /// Set every string's free step for the damper's present engagement and `bend`.
    pub fn set_poles(&mut self, bend: f64) {
        let (rate_s, rate_per_hz_s) = match self.damper {
            Some(d) => (d.rate_s * self.damper_now, d.rate_per_hz_s * self.damper_now),
            None => (0.0, 0.0),
        };
        for s in &mut self.strings {
            s.set_free_step(rate_s, rate_per_hz_s, bend);
        }
        self.damper_set = self.damper_now;
        self.bend_set = bend;
    }

    /// At rest and inactive.
    pub fn silence(&mut self) {
        for s in &mut self.strings {
            s.silence();
        }
        self.active = false;
        self.down = false;
        self.sostenuto = false;
        self.fade = 1.0;
        self.fade_step = 0.0;
        self.level = 0.0;
    }

    /// Add the key's summed bridge force (N) over `out.len()` samples to `out`,
    /// and the summed contact force to `contact` when given.
    pub fn render(&mut self, out: &mut [f64], mut contact: Option<&mut [f32]>) {
        for s in &mut self.strings {
            if contact.is_none() && s.process_free(out) {
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
    }

    /// Take over a ringing key of the same instrument whose tables were rebuilt.
    pub fn take_over(&mut self, old: &mut Key, bend: f64) {
        for (new, old) in self.strings.iter_mut().zip(old.strings.iter_mut()) {
            new.take_motion_from(old);
        }
        self.active = old.active;
        self.down = old.down;
        self.sostenuto = old.sostenuto;
        self.damper_now = old.damper_now;
        self.fade = old.fade;
        self.fade_step = old.fade_step;
        self.level = old.level;
        self.set_poles(bend);
        old.silence();
    }
}
