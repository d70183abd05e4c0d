//! The felt's hysteresis: Stulov's hereditary felt (Stulov 1995, "Hysteretic
//! model of the grand piano hammer felt", JASA 97(4); J. O. Smith, Physical Audio
//! Signal Processing, "Including Hysteresis").
//!
//!   F = K [C^alpha - (eps / tau) int_0^t C(s)^alpha exp(-(t - s) / tau) ds],
//!
//! 0 <= eps < 1, tau > 0 (C^alpha meaning 0 where C <= 0), and F >= 0: the felt
//! pushes, it cannot pull. Written with the memory in newtons,
//! M = (K / tau) int_0^t C(s)^alpha exp(-(t - s) / tau) ds, the felt is its
//! elastic force less eps M, and M relaxes toward the elastic force:
//!
//!   dM/dt = (K C^alpha - M) / tau,   F = K C^alpha - eps M.
//!
//! Loaded slowly (over much more than tau) it is the elastic felt softened to
//! (1 - eps) K; struck fast, it is the elastic felt at first. Either way the force
//! when loading stands above the force when unloading, and the loop between them
//! is the energy a stroke leaves in the felt.
//!
//! Over a step the elastic part is held at the felt's discrete gradient Q
//! ([`super::contact`]), the mean of K C^alpha over the step when C moves evenly
//! through it. The memory is driven by that mean, so over a step of h it follows
//! exactly
//!
//!   M1 = a M0 + (1 - a) Q,   a = exp(-h / tau),
//!
//! and its mean over the step is g M0 + (1 - g) Q with g = (1 - a) / r, r = h / tau
//! (integrating the equation above over the step). The force held over the step
//! is the elastic one less eps times that mean:
//!
//!   F = Q - eps (g M0 + (1 - g) Q) = s Q - eps g M0,   s = 1 - eps (1 - g) > 0.
//!
//! So C1 = C_hat - W F is the elastic equation with C_hat raised by W eps g M0
//! and W scaled by s: the same increasing, convex g(C1), the same bracketed
//! Newton solve, one root. (Holding the drive at its mean keeps that so; a drive
//! moving through the step would weigh K C1^alpha against the elastic mean's
//! 1/(alpha + 1) and the equation could lose its one root.)
//!
//! The force reported at a step's end (what a [`crate::exciter::ContactObserver`]
//! sees) is K C1^alpha - eps M1' with M1' a second account of the memory, kept
//! with the drive moving evenly from K C0^alpha to K C1^alpha through each step,
//! M1' = a M0' + (g - a) K C0^alpha + (1 - g) K C1^alpha: the held drive lags
//! the step's end by half a step, which shows when tau is as short as a step.
//! The memory the steps are solved with is the held drive's.
//! If F < 0 there, the felt cannot push: F = 0 and
//! C1 = C_hat (the root of the equation with F clamped at 0, which is increasing
//! too). The elastic part keeps its energy account exactly; what the hammer and
//! string lose over a stroke is the work sum F (C1 - C0), the loop's area.
//!
//! Allocates: no. Realtime-safe.

use super::contact::{ContactLaw, ContactStep, Felt, Guess};

/// The felt's hereditary parameters.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hysteresis {
    /// eps, the share of the elastic force the memory takes back when loaded
    /// slowly, 0 <= eps < 1 (0: elastic).
    pub epsilon: f64,
    /// tau, the memory's relaxation time, s (> 0).
    pub tau_s: f64,
}

impl Hysteresis {
    /// Which parameter breaks its rule, if one does: `epsilon` outside [0, 1) or
    /// `tau_s` not positive (both must be finite).
    pub fn invalid_field(&self) -> Option<&'static str> {
        if !(self.epsilon.is_finite() && (0.0..1.0).contains(&self.epsilon)) {
            Some("epsilon")
        } else if !(self.tau_s.is_finite() && self.tau_s > 0.0) {
            Some("tau_s")
        } else {
            None
        }
    }
}

/// A stroke's memory of the felt, and the weights of its recurrence at the
/// stroke's sub-step and at the audio step.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Memory {
    epsilon: f64,
    /// a = exp(-h / tau) over a sub-step.
    relax: f64,
    /// g = (1 - a) / (h / tau) over a sub-step.
    mean_weight: f64,
    /// exp(-T / tau) over an audio sample.
    relax_audio: f64,
    /// M, N (as the held drive leaves it: what the next step is solved with).
    force_n: f64,
    /// M' at the last step's end (the drive moving through each step), N.
    at_end_n: f64,
}

impl Memory {
    /// A fresh memory for a stroke stepped at `substep_s` within samples of
    /// `sample_s`; None when `hysteresis` is absent, elastic (eps = 0) or invalid.
    pub fn new(hysteresis: Option<Hysteresis>, substep_s: f64, sample_s: f64) -> Option<Self> {
        let h = hysteresis?;
        if h.epsilon == 0.0 || h.invalid_field().is_some() || !(substep_s > 0.0) {
            return None;
        }
        let r = substep_s / h.tau_s;
        let one_less = -(-r).exp_m1();
        Some(Self {
            epsilon: h.epsilon,
            relax: 1.0 - one_less,
            mean_weight: if r > 0.0 { one_less / r } else { 1.0 },
            relax_audio: (-sample_s / h.tau_s).exp(),
            force_n: 0.0,
            at_end_n: 0.0,
        })
    }

    /// The memory M, N.
    pub fn force_n(&self) -> f64 {
        self.force_n
    }

    /// The felt's force at the end of the last step, where its elastic force is
    /// `elastic_n`: never negative.
    pub fn force_at(&self, elastic_n: f64) -> f64 {
        (elastic_n - self.epsilon * self.at_end_n).max(0.0)
    }

    /// `samples` audio samples out of contact: the memory relaxes.
    pub fn relax_free_for(&mut self, samples: usize) {
        let relax = self.relax_audio.powi(samples.min(i32::MAX as usize) as i32);
        self.force_n *= relax;
        self.at_end_n *= relax;
    }

    /// One sub-step, as [`ContactLaw::step`] (same arguments; `guess.force_n` a
    /// guess at this force, not the elastic one), and the memory moved on. The
    /// step's force is the hysteretic one.
    #[inline(always)]
    pub fn step(
        &mut self,
        law: &ContactLaw,
        start: Felt,
        c_hat: f64,
        w: f64,
        guess: Option<Guess<'_>>,
    ) -> (ContactStep, Felt) {
        if start.compression_m <= 0.0 && c_hat <= 0.0 {
            self.force_n *= self.relax;
            self.at_end_n *= self.relax;
            let end = Felt { compression_m: c_hat, force_n: 0.0, energy_j: 0.0 };
            return (ContactStep { compression_m: c_hat, step_force_n: 0.0, iterations: 0 }, end);
        }
        let scale = 1.0 - self.epsilon * (1.0 - self.mean_weight);
        let offset_n = self.epsilon * self.mean_weight * self.force_n;
        let elastic_guess = guess.map(|g| Guess { force_n: (g.force_n + offset_n) / scale, ..g });
        let (mut step, mut end) = law.step_inline(start, c_hat + w * offset_n, w * scale, elastic_guess);
        let mut force = scale * step.step_force_n - offset_n;
        if !(force >= 0.0) {
            // The felt would pull: no force, and the compression is what it would be
            // without one. The memory still sees the elastic mean over that step
            // (the felt there from the series near the guess, without a power).
            let (free, free_end) = law.step(start, c_hat, 0.0, guess);
            step = ContactStep { compression_m: c_hat, step_force_n: free.step_force_n, iterations: step.iterations };
            end = free_end;
            force = 0.0;
        }
        let (a, g) = (self.relax, self.mean_weight);
        self.at_end_n = a * self.at_end_n + (g - a) * start.force_n + (1.0 - g) * end.force_n;
        self.force_n = a * self.force_n + (1.0 - a) * step.step_force_n;
        (ContactStep { step_force_n: force, ..step }, end)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const LAW: ContactLaw = ContactLaw { stiffness: 4.5e9, exponent: 2.5 };

    #[test]
    fn the_rules_name_the_broken_parameter() {
        let ok = Hysteresis { epsilon: 0.2, tau_s: 1e-5 };
        assert_eq!(ok.invalid_field(), None);
        assert_eq!(Hysteresis { epsilon: 1.0, ..ok }.invalid_field(), Some("epsilon"));
        assert_eq!(Hysteresis { epsilon: -0.1, ..ok }.invalid_field(), Some("epsilon"));
        assert_eq!(Hysteresis { epsilon: f64::NAN, ..ok }.invalid_field(), Some("epsilon"));
        assert_eq!(Hysteresis { tau_s: 0.0, ..ok }.invalid_field(), Some("tau_s"));
        assert_eq!(Hysteresis { tau_s: f64::INFINITY, ..ok }.invalid_field(), Some("tau_s"));
        assert!(Memory::new(Some(Hysteresis { epsilon: 0.0, ..ok }), 1e-6, 2e-5).is_none());
        assert!(Memory::new(Some(Hysteresis { epsilon: 1.5, ..ok }), 1e-6, 2e-5).is_none());
        assert!(Memory::new(None, 1e-6, 2e-5).is_none());
    }

    #[test]
    fn the_step_force_solves_the_hysteretic_step() {
        // From a loaded memory: C1 = C_hat - W F with F = Q - eps (g M0 + (1 - g) Q).
        for tau_s in [1e-7, 1e-6, 1e-5, 1e-3] {
            let h = Hysteresis { epsilon: 0.6, tau_s };
            let mut m = Memory::new(Some(h), 1e-6, 2e-5).unwrap();
            let (c0, c_hat, w) = (2e-4, 2.4e-4, 2e-6);
            m.force_n = 0.5 * LAW.force_n(c0);
            let start = LAW.felt(c0);
            let m0 = m.force_n;
            let (s, end) = m.step(&LAW, start, c_hat, w, None);
            let c1 = s.compression_m;
            let q = (LAW.energy_j(c1) - LAW.energy_j(c0)) / (c1 - c0);
            let g = m.mean_weight;
            let f = q - h.epsilon * (g * m0 + (1.0 - g) * q);
            assert!(f > 0.0 && (s.step_force_n - f).abs() <= 1e-9 * f, "tau {tau_s}: {} vs {f}", s.step_force_n);
            assert!((c1 - (c_hat - w * f)).abs() <= 1e-12 * c_hat, "tau {tau_s}");
            let (a, r) = ((-1e-6 / tau_s).exp(), 1e-6 / tau_s);
            assert!((m.force_n - (a * m0 + (1.0 - a) * q)).abs() <= 1e-9 * q, "tau {tau_s}");
            let m1 = ((1.0 - a) / r - a) * LAW.force_n(c0) + (1.0 - (1.0 - a) / r) * LAW.force_n(c1);
            assert!((m.at_end_n - m1).abs() <= 1e-9 * m1, "tau {tau_s}");
            assert_eq!(end.compression_m, c1);
        }
    }

    #[test]
    fn a_felt_that_would_pull_lets_go() {
        let mut m = Memory::new(Some(Hysteresis { epsilon: 0.9, tau_s: 1e-4 }), 1e-6, 2e-5).unwrap();
        // A large memory against a small compression: no force, no yield.
        m.force_n = 500.0;
        let (s, end) = m.step(&LAW, LAW.felt(1e-5), 0.9e-5, 1e-6, None);
        assert_eq!((s.step_force_n, s.compression_m, end.compression_m), (0.0, 0.9e-5, 0.9e-5));
        assert!(m.force_n < 500.0 && m.force_n > 0.0);
        // Out of contact the memory only relaxes.
        let before = m.force_n;
        let (s, _) = m.step(&LAW, LAW.felt(-1e-6), -2e-6, 1e-6, None);
        assert_eq!(s.step_force_n, 0.0);
        assert!((m.force_n - before * (-0.01f64).exp()).abs() <= 1e-12 * before);
    }
}
