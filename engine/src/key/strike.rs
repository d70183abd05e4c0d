//! The player's hand on a key: a note going down (hammer with una corda and
//! uneven or hand-held heads, tangent, plectrum) and coming up, the damper
//! landing, the pedal lifting it, and the strike's regulation.

use super::{
    ActionNoise, ContactLaw, DEFAULT_SUBSTEPS, ExciterDesign, HammerSpec, Key, LIFT_TOP_HZ, MAX_STRIKE_POINT,
    MIN_STRIKE_POINT, MISSED, PerformanceState, PluckSpec, TangentSpec, Touch, UNA_CORDA_STIFFNESS, action,
};

impl Key {
    /// Note `note` goes down with `touch` (a speed for hammers, mallets and
    /// tangents, a lift for a plectrum), the player's hands and feet as
    /// `performance` has them (una corda, the bend, hand-held mallets'
    /// hardness). A touch in the other unit than the note's exciter is
    /// ignored. Allocates: no.
    pub fn press(&mut self, note: usize, touch: Touch, performance: &PerformanceState) {
        let (una_corda, bend) = (performance.una_corda, performance.bend);
        // The mod wheel covers hand-held mallets; a keyboard's hammers are voiced by the parameters.
        let hardness = if self.strike.hand_held { performance.mallet_hardness } else { 1.0 };
        self.settle();
        let Some(played) = self.notes.get(note) else { return };
        let fits = match played.exciter {
            ExciterDesign::Pluck { .. } => matches!(touch, Touch::PluckHeight { .. }),
            _ => matches!(touch, Touch::Speed { .. }),
        };
        if !fits {
            return;
        }
        let touch = touch.value();
        let bit = 1u32 << note;
        if !self.regulation.table.is_empty() {
            self.regulation.gain_to = regulated(&self.regulation.table, touch);
            if !self.active {
                self.regulation.gain = self.regulation.gain_to;
            }
        }
        self.active = true;
        if self.fade.gain < 1.0 || self.fade.step < 0.0 {
            self.fade.step = self.fade.step.abs().max(1e-4);
        }
        // The damper leaves the strings before the hammer arrives (a cimbalom's
        // damper bar answers the pedal alone).
        self.damper.lift_for_strike();
        if let ExciterDesign::Tangent { .. } = played.exciter {
            // The higher tangent wins: a lower one under it meets a string it does not
            // sound, and waits there in case the higher key comes up first.
            let above = self.held != 0 && self.notes[self.speaking].pitch_ratio > played.pitch_ratio;
            self.held |= bit;
            self.sounded |= bit;
            if above {
                return;
            }
            self.speaking = note;
            self.finger.pressure = 0.0;
        }
        self.held |= bit;
        self.sounded |= bit;
        // The unison's next trade comes a whole interval after the strike (the
        // trade takes its strings' motion as free over the interval).
        self.unison.blocks_since_trade = 0;
        let pitch = self.pitch(bend);
        self.set_poles(pitch);
        // Where its own strike point puts the hammer (or plectrum) built at `position`.
        let factor = self.voicing.position * self.voicing.live.strike_position;
        let own_point = |position: f64| {
            if factor == 1.0 { position } else { (position * factor).clamp(MIN_STRIKE_POINT, MAX_STRIKE_POINT) }
        };
        let played = &self.notes[note];
        let strings = &mut self.strings[played.struck.clone()];
        match played.exciter {
            ExciterDesign::Hammer { mass_kg, law, position } => {
                let (mass_kg, law) = (mass_kg * self.voicing.live.hammer_mass, self.voicing.live.felt(law));
                let hysteresis = self.voicing.live.hysteresis(played.hysteresis);
                if self.action.key_bed {
                    self.action.bed_pulse = Some((0, touch));
                }
                // Una corda shifts the action sideways by `una_corda` of the
                // way: the hammer meets the first string of a unison with that
                // much less of its width (missing it at full shift), and the
                // rest with its less worn, softer felt. Each string takes the
                // hammer's mass and felt in proportion to the width it meets,
                // which an uneven hammer makes more on some strings than on
                // others.
                let shift = if strings.len() >= 2 { una_corda.clamp(0.0, 1.0) } else { 0.0 };
                let (hardness, position) = (hardness * self.voicing.hardness, own_point(position));
                let soft = 1.0 - una_corda.clamp(0.0, 1.0) * (1.0 - UNA_CORDA_STIFFNESS);
                let shares = self.strike.shares.get(played.struck.clone()).unwrap_or(&[]);
                let turn = if self.strike.hand_held { self.strike.strokes as usize } else { 0 };
                self.strike.strokes = self.strike.strokes.wrapping_add(1);
                let share = |i: usize| match shares.len() {
                    0 => 1.0,
                    n => shares[(i + turn) % n],
                };
                // (A level hammer's width as it always was, to the bit.)
                let width = if shares.is_empty() {
                    strings.len() as f64 - shift
                } else {
                    (0..strings.len()).map(|i| share(i) * if i == 0 { 1.0 - shift } else { 1.0 }).sum()
                };
                let substeps = played.substeps.as_ref().map_or(DEFAULT_SUBSTEPS, |plan| plan.substeps(touch));
                for (i, s) in strings.iter_mut().enumerate() {
                    let met = share(i) * if i == 0 { 1.0 - shift } else { 1.0 };
                    if met < MISSED {
                        continue;
                    }
                    let felt =
                        ContactLaw { stiffness: law.stiffness * hardness * soft * met / width, exponent: law.exponent };
                    let hammer = HammerSpec::one_of(1, mass_kg * met / width, felt, touch, position);
                    s.strike_substepped(hammer.with_hysteresis(hysteresis), substeps);
                }
            }
            ExciterDesign::Tangent { displacement_m, .. } => {
                for s in strings {
                    s.press_tangent(TangentSpec { speed_m_s: touch, displacement_m });
                }
            }
            ExciterDesign::Pluck { position } => {
                // The plectrum's own point, as the hammer's.
                let position = own_point(position);
                for s in strings {
                    s.pluck(PluckSpec { displacement_m: touch * 1e-3, position });
                    s.release_exciter();
                }
            }
        }
    }

    /// Note `note` comes up at release `velocity` (0..=1), the sustain pedal
    /// where `performance` has it.
    pub fn release(&mut self, note: usize, velocity: f64, performance: &PerformanceState) {
        let sustain = performance.sustain;
        self.settle();
        let bit = 1u32 << note;
        if self.held & bit == 0 {
            return;
        }
        self.held &= !bit;
        if self.held == 0 {
            self.damper.land(velocity);
        }
        if self.held == 0 && !self.sostenuto && self.damper.target(false, sustain) >= 0.5 {
            self.land_damper(note, velocity);
        }
        let Some(ExciterDesign::Tangent { return_s, .. }) = self.notes.get(note).map(|n| n.exciter) else { return };
        if self.held == 0 {
            let struck = self.notes[note].struck.clone();
            let lift_s = tangent_lift_s(return_s, velocity);
            for s in &mut self.strings[struck] {
                s.lift_tangent(lift_s);
            }
        } else if note == self.speaking {
            // A lower tangent still down takes over the string (its pitch follows at
            // the next control tick).
            let held = self.held;
            if let Some((i, _)) = self
                .notes
                .iter()
                .enumerate()
                .filter(|(i, _)| held & (1 << i) != 0)
                .max_by(|a, b| a.1.pitch_ratio.total_cmp(&b.1.pitch_ratio))
            {
                self.speaking = i;
            }
        }
    }

    /// Every note of the course comes up, the sustain pedal where
    /// `performance` has it.
    pub fn release_all(&mut self, performance: &PerformanceState) {
        for note in 0..self.notes.len() {
            self.release(note, 0.5, performance);
        }
    }

    /// The key's damper lands on its strings as `note` comes up at release
    /// `velocity` (0..=1): its momentum goes into them at the place its note
    /// strikes, through its soft felt ([`action`]); the damper then stops
    /// them. Nothing for a key without a damper, one the pedal holds off, or
    /// a damper only the pedal works.
    pub(super) fn land_damper(&mut self, note: usize, velocity: f64) {
        let Some(position) = self.notes.get(note).and_then(|n| n.damper_position()) else { return };
        if self.action.noise.damper <= 0.0 || !self.active || !self.action.on_body || !self.damper.follows_key() {
            return;
        }
        self.phantom.mark_stale();
        self.cull.due_in = 0;
        let impulse = self.damper.head_mass_kg()
            * action::DAMPER_LANDING_M_S
            * velocity.clamp(0.0, 1.0)
            * self.action.noise.damper;
        let share = -impulse / self.strings.len().max(1) as f64;
        for s in &mut self.strings {
            let (string, bank) = s.string_and_bank_mut();
            action::kick_modes(string, position, share, action::DAMPER_CONTACT_S, |i, dv| bank.nudge(i, 0.0, dv));
            // (A hammer still in play is watched again on the kicked modes.)
            s.watch_hammer();
        }
    }

    /// The sustain pedal lifts the damper off its strings, which spring back
    /// from the bend its weight held them in ([`action`]) and ring. Nothing
    /// for a key without a damper or one already lifted (held, or kept up by
    /// the sostenuto pedal); a silent key starts to sound, its damper where
    /// `performance`'s pedal has it and its pitch bent by its wheel.
    /// Allocates: no.
    pub fn lift_damper(&mut self, performance: &PerformanceState) {
        self.settle();
        if self.action.noise.pedal <= 0.0
            || !self.action.on_body
            || !self.damper.exists()
            || self.down()
            || self.sostenuto
        {
            return;
        }
        if !self.active {
            self.wake(performance);
        }
        self.let_strings_go();
    }

    /// The damper, lifted, lets its strings go: they spring back from the bend
    /// its weight held them in.
    pub(super) fn let_strings_go(&mut self) {
        self.cull.due_in = 0;
        self.phantom.mark_stale();
        let Some(position) = self.notes.first().and_then(|n| n.damper_position()) else { return };
        let level = self.action.noise.pedal;
        for s in &mut self.strings {
            let (string, bank) = s.string_and_bank_mut();
            action::damper_release(string, position, LIFT_TOP_HZ, |i, dv| bank.nudge(i, 0.0, dv * level));
            s.watch_hammer();
        }
    }
}

/// Time constant of a tangent leaving its strings as the key comes up at
/// release `velocity` (0..=1; 0: not known, as a middling release), s: as
/// fast as the strings push it back (`return_s`) from velocity 0.5 up, more
/// slowly below as a finger lets the key up (the damper's landing law,
/// [`crate::damper::release_slowness`]). It once left them in 2 ms whatever the release, faster than
/// they can throw it: the bridge's static load came off as a step, which rang
/// the body's lowest modes louder than the dying note (a boom on every
/// release, -26 dBFS after a C4 at -39).
fn tangent_lift_s(return_s: f64, velocity: f64) -> f64 {
    return_s * crate::damper::release_slowness(velocity).max(1.0)
}

/// A regulation's gain at touch `value` (see [`Key::regulate`]): interpolated
/// in log gain over log touch, held at the ends.
pub(crate) fn regulated(table: &[(f64, f64)], value: f64) -> f64 {
    match table.iter().position(|&(t, _)| t >= value) {
        None => table.last().map_or(1.0, |p| p.1),
        Some(0) => table[0].1,
        Some(i) => {
            let ((t0, g0), (t1, g1)) = (table[i - 1], table[i]);
            let x = ((value / t0).ln() / (t1 / t0).ln()).clamp(0.0, 1.0);
            g0 * (g1 / g0).powf(x)
        }
    }
}

/// How much of a hammer each string meets, over an even share (empty:
/// even), and whether they are held in the player's hand (they meet the
/// strings differently at each stroke: the shares turn by a string), with
/// the strokes so far.
#[derive(Clone)]
pub(super) struct StrikeShares {
    pub(super) shares: Vec<f64>,
    pub(super) hand_held: bool,
    pub(super) strokes: u32,
}

/// Its regulation: the gain of a strike by its touch (empty: 1), the gain
/// now and where it glides to (the last strike's), and the glide's step a
/// sample ([`STRIKE_GAIN_GLIDE_S`]).
#[derive(Clone)]
pub(super) struct Regulation {
    pub(super) table: Vec<(f64, f64)>,
    pub(super) gain: f64,
    pub(super) gain_to: f64,
    pub(super) glide: f64,
}

/// The action's sounds: whether the key stops on a bed (a keyboard's
/// hammer key), whether its strings bear on the body (not the seed's rigid
/// bridge), the bed's pulse in play (samples since the key bottomed, hammer
/// speed), the pulse at its sample rate, and the sounds' levels.
#[derive(Clone)]
pub(super) struct ActionSounds {
    pub(super) key_bed: bool,
    pub(super) on_body: bool,
    pub(super) bed_pulse: Option<(usize, f64)>,
    pub(super) bed: action::KeyBedPulse,
    pub(super) noise: ActionNoise,
}
