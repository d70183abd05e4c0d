//! The hammer (piano) or mallet (santoor, dulcimer, cimbalom): a point mass M
//! that meets the string through felt or a spring.
//!
//! M eta'' = -F, F = K C^alpha with C = eta - y(x_e) (Chaigne & Askenfelt 1994;
//! Euphonics 12.2.1). The hammer starts just touching the string, moving toward it
//! at the striking speed; it leaves when the string throws it off, and may come
//! back any number of times (bounces come out of the physics).
//!
//! Over a (sub)step of length h the force is held at one value F, the felt's
//! energy-consistent mean over the step ([`crate::exciter::hammer::contact`]), and the hammer
//! moves exactly under it:
//!   eta(h) = eta + v h - h^2 F / (2 M),   v(h) = v - h F / M,
//! so it yields to the step's own force with compliance h^2 / (2 M), and the
//! impulse it receives is exactly the sum of F h over the steps.

pub mod contact;
pub mod hysteresis;
mod rig;
pub mod substeps;

pub use contact::ContactLaw;
pub use hysteresis::Hysteresis;
pub use rig::{HammerRig, Substep};

/// A hammer or mallet and how it is thrown.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct HammerSpec {
    /// Equivalent point mass, kg.
    pub mass_kg: f64,
    pub law: ContactLaw,
    /// Speed toward the string at first touch, m/s (> 0).
    pub speed_m_s: f64,
    /// Where it strikes, as a fraction of the length from the bridge, 0 < p < 1.
    pub position: f64,
    /// The felt's hysteresis (Stulov); None: elastic.
    pub hysteresis: Option<Hysteresis>,
}

impl HammerSpec {
    /// One string's share of a hammer of `mass_kg` on felt `law` striking
    /// `strings` strings of a course at once: each string meets mass / n on
    /// stiffness K / n, so together they take the whole hammer's force. Its felt
    /// is elastic ([`Self::with_hysteresis`] gives it a memory).
    pub fn one_of(strings: usize, mass_kg: f64, law: ContactLaw, speed_m_s: f64, position: f64) -> Self {
        let n = strings.max(1) as f64;
        Self {
            mass_kg: mass_kg / n,
            law: ContactLaw { stiffness: law.stiffness / n, exponent: law.exponent },
            speed_m_s,
            position,
            hysteresis: None,
        }
    }

    /// The same hammer on a felt with `hysteresis` (eps and tau are the same for
    /// every string's share: the memory scales with K / n like the force).
    pub fn with_hysteresis(self, hysteresis: Option<Hysteresis>) -> Self {
        Self { hysteresis, ..self }
    }
}

/// The moving hammer.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hammer {
    pub spec: HammerSpec,
    /// Position along +y (toward and into the string), m.
    pub position_m: f64,
    /// Velocity along +y, m/s.
    pub velocity_m_s: f64,
}

impl Hammer {
    /// A hammer touching the string at `string_position_m`, moving into it.
    pub fn thrown(spec: HammerSpec, string_position_m: f64) -> Self {
        Self { spec, position_m: string_position_m, velocity_m_s: spec.speed_m_s }
    }

    /// Position after a step of `h` seconds with no force.
    pub fn predict_m(&self, h: f64) -> f64 {
        self.position_m + self.velocity_m_s * h
    }

    /// Compliance of the hammer to the step's own force, m/N.
    pub fn compliance_m_n(&self, h: f64) -> f64 {
        h * h / (2.0 * self.spec.mass_kg)
    }

    /// Finish a step: `predicted_m` from [`Hammer::predict_m`], `force_n` held over the step.
    pub fn commit(&mut self, h: f64, predicted_m: f64, force_n: f64) {
        self.position_m = predicted_m - self.compliance_m_n(h) * force_n;
        self.velocity_m_s -= h * force_n / self.spec.mass_kg;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_course_shares_the_hammer_so_its_strings_add_up_to_it() {
        let law = ContactLaw { stiffness: 4.5e9, exponent: 2.5 };
        let one = HammerSpec::one_of(3, 0.009, law, 3.0, 0.12);
        assert_eq!((one.mass_kg, one.law.stiffness, one.law.exponent), (0.009 / 3.0, 4.5e9 / 3.0, 2.5));
        assert_eq!((one.speed_m_s, one.position), (3.0, 0.12));
        // Three strings pressed alike give back the whole hammer's force.
        let c = 2e-4;
        assert!((3.0 * one.law.force_n(c) - law.force_n(c)).abs() <= 1e-12 * law.force_n(c));
    }

    #[test]
    fn held_force_moves_the_hammer_exactly() {
        let spec = HammerSpec {
            mass_kg: 0.003,
            law: ContactLaw { stiffness: 1e9, exponent: 2.5 },
            speed_m_s: 2.0,
            position: 0.12,
            hysteresis: None,
        };
        let mut h = Hammer::thrown(spec, 1e-4);
        let (dt, m) = (1e-3, 0.003);
        let predicted = h.predict_m(dt);
        h.commit(dt, predicted, 14.0);
        assert!((h.position_m - (1e-4 + 2.0 * dt - 14.0 * dt * dt / (2.0 * m))).abs() < 1e-15);
        assert!((h.velocity_m_s - (2.0 - 14.0 * dt / m)).abs() < 1e-12);
    }
}
