//! A key's damper: the felt that lies on its strings while the key is up and
//! the pedal is not, adding to every mode's decay rate as it settles.
//!
//! Its engagement runs from 0 (lifted) to 1 (fully on the strings) and moves at
//! most one control block's share of the felt's travel time per block, so a
//! release is a short slide rather than a click. A key let up slowly (a soft
//! release velocity) lowers its damper slowly: the felt settles over a longer
//! time and the note fades out longer. A cimbalom's damper bar is worked by
//! the pedal alone: its keys (the player's mallets) never lift it.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use crate::design::DamperDesign;

/// The damper of one key (none for keys whose strings ring short anyway).
#[derive(Clone, Copy, Debug, PartialEq)]
pub(crate) struct Damper {
    design: Option<DamperDesign>,
    /// Engagement now, and the engagement the strings' poles were last set for.
    engaged: f64,
    engaged_set: f64,
    /// How long it takes to settle on the strings this time, s (the design's
    /// travel, longer after a soft release: [`Self::land`]).
    landing_s: f64,
}

/// A release velocity's landing time against the design's travel: 1 at a
/// middling release (MIDI's 64, what a keyboard without release velocity
/// sends), growing as the square of its inverse for slower ones (a key let up
/// slowly lets its felt settle gradually, the way a player half-dampens a
/// note), held within these bounds: the piano's 15 ms travel lands in 7.5 ms
/// at full speed and in up to 0.24 s. Assumed: no measurement of a damper's
/// landing time against the key's release speed was found; the square makes
/// the soft end of the range audible as a longer fade.
const LANDING_SHORTEST: f64 = 0.5;
const LANDING_LONGEST: f64 = 16.0;

/// How much longer than at a middling release (0.5, MIDI's 64) a key let up
/// at release `velocity` (0..=1; 0: none reported, taken as middling) takes
/// over what it lets go: (0.5 / velocity)^2, at most [`LANDING_LONGEST`] (the
/// damper's landing, and the clavichord's tangent leaving its strings).
pub(crate) fn release_slowness(velocity: f64) -> f64 {
    if velocity > 0.0 { (0.5 / velocity).powi(2).min(LANDING_LONGEST) } else { 1.0 }
}

impl Damper {
    pub fn new(design: Option<DamperDesign>) -> Self {
        let landing_s = design.map_or(0.0, |d| d.travel_s);
        Self { design, engaged: 0.0, engaged_set: 0.0, landing_s }
    }

    /// The key comes up at release `velocity` (0..=1; 0: none reported, taken
    /// as middling): the damper's landing takes the design's travel time times
    /// (0.5 / velocity)^2, between half and sixteen times it.
    pub fn land(&mut self, velocity: f64) {
        let Some(d) = self.design else { return };
        self.landing_s = d.travel_s * release_slowness(velocity).max(LANDING_SHORTEST);
    }

    /// A strike: the damper leaves the strings before the hammer arrives (unless
    /// only the pedal works it).
    pub fn lift_for_strike(&mut self) {
        if let Some(d) = self.design.filter(|d| !d.pedal_only) {
            self.engaged = 0.0;
            self.landing_s = d.travel_s;
        }
    }

    /// One control block of `block_s`: move toward where the key (held, or kept
    /// up by the sostenuto pedal) and the sustain pedal (0..=1 down) send it.
    pub fn follow(&mut self, block_s: f64, key_up_held: bool, sustain: f64) {
        let Some(d) = self.design else { return };
        let target = self.target(key_up_held, sustain);
        // Lifting takes the design's travel; landing, what the release set.
        let travel_s = if target > self.engaged { self.landing_s } else { d.travel_s };
        let step = block_s / travel_s.max(block_s);
        self.engaged += (target - self.engaged).clamp(-step, step);
    }

    /// Where the key (held, or kept up by the sostenuto pedal) and the sustain
    /// pedal (0..=1 down) send it: 0 lifted (or no damper), 1 on the strings.
    pub fn target(&self, key_up_held: bool, sustain: f64) -> f64 {
        match self.design {
            None => 0.0,
            Some(d) if d.pedal_only => (1.0 - sustain).clamp(0.0, 1.0),
            Some(_) if key_up_held => 0.0,
            Some(_) => (1.0 - sustain).clamp(0.0, 1.0),
        }
    }

    /// Whether the key has one.
    pub fn exists(&self) -> bool {
        self.design.is_some()
    }

    /// Whether the key works it (a cimbalom's damper bar answers the pedal alone).
    pub fn follows_key(&self) -> bool {
        self.design.is_some_and(|d| !d.pedal_only)
    }

    /// The mass that lands on the strings with it, kg (0: none).
    pub fn head_mass_kg(&self) -> f64 {
        self.design.map_or(0.0, |d| d.head_mass_kg)
    }

    /// Put it where [`Self::target`] says at once: a silent key's damper, which
    /// has not followed the pedal, when its strings start to ring with others.
    pub fn settle(&mut self, key_up_held: bool, sustain: f64) {
        self.engaged = self.target(key_up_held, sustain);
    }

    /// Whether it has moved since the strings' poles were last set.
    pub fn moved(&self) -> bool {
        self.engaged != self.engaged_set
    }

    /// The decay it adds now, (rate 1/s, rate per Hz 1/s/Hz): every mode's
    /// sigma grows by `rate + rate_per_hz * f`. Marks the poles as set for it.
    pub fn extra_decay(&mut self) -> (f64, f64) {
        self.engaged_set = self.engaged;
        match self.design {
            Some(d) => (d.rate_s * self.engaged, d.rate_per_hz_s * self.engaged),
            None => (0.0, 0.0),
        }
    }

    /// Carry over the engagement of the same key's damper in tables being replaced.
    pub fn take_over(&mut self, old: &Damper) {
        self.engaged = old.engaged;
        if let Some(d) = self.design {
            self.landing_s = old.landing_s.max(0.0).min(d.travel_s * LANDING_LONGEST);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FELT: DamperDesign =
        DamperDesign { rate_s: 10.0, rate_per_hz_s: 0.01, travel_s: 0.02, pedal_only: false, head_mass_kg: 0.015 };

    #[test]
    fn a_released_key_s_damper_settles_over_its_travel_and_the_pedal_holds_it_off() {
        let mut d = Damper::new(Some(FELT));
        d.lift_for_strike();
        d.follow(0.005, false, 0.0);
        assert!((d.extra_decay().0 - 2.5).abs() < 1e-12, "a quarter of the travel in a quarter of its time");
        for _ in 0..10 {
            d.follow(0.005, false, 0.0);
        }
        assert_eq!(d.extra_decay(), (10.0, 0.01));
        assert!(!d.moved());
        d.follow(0.005, true, 0.0);
        assert!(d.moved(), "a held key lifts it");
        let mut pedalled = Damper::new(Some(FELT));
        for _ in 0..10 {
            pedalled.follow(0.005, false, 1.0);
        }
        assert_eq!(pedalled.extra_decay(), (0.0, 0.0));
    }

    #[test]
    fn a_soft_release_lands_the_damper_slowly() {
        let settle_blocks = |velocity: f64| {
            let mut d = Damper::new(Some(FELT));
            d.lift_for_strike();
            d.land(velocity);
            (1..1000).find(|_| {
                d.follow(0.001, false, 0.0);
                d.extra_decay().0 >= FELT.rate_s * (1.0 - 1e-9)
            })
        };
        // 20 ms travel: 10 ms at full speed, 20 at a middling one (and when
        // none is reported), 80 at a quarter, 320 at most.
        assert_eq!(settle_blocks(1.0), Some(10));
        assert_eq!(settle_blocks(0.5), Some(20));
        assert_eq!(settle_blocks(0.0), Some(20));
        assert_eq!(settle_blocks(0.25), Some(80));
        assert_eq!(settle_blocks(0.001), Some(320));
    }

    #[test]
    fn a_pedal_only_damper_ignores_the_keys() {
        let mut bar = Damper::new(Some(DamperDesign { pedal_only: true, ..FELT }));
        for _ in 0..10 {
            bar.follow(0.005, true, 0.0);
        }
        bar.lift_for_strike();
        assert_eq!(bar.extra_decay().0, 10.0, "neither a held key nor a strike lifts a damper bar");
        assert_eq!(Damper::new(None).extra_decay(), (0.0, 0.0));
    }
}
