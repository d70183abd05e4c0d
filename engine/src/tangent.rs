//! The clavichord tangent: a brass blade that strikes the string and stays,
//! becoming one end of the vibrating length (Euphonics 12.2.3).
//!
//! Following Thwaites & Fletcher (1981), the tangent's speed falls exponentially
//! from V0 so that it comes to rest a distance D from where it met the string:
//!
//!   z(t) = D (1 - exp(-t V0 / D)),  z'(t) = V0 exp(-t V0 / D).
//!
//! The end x = L follows z(t). Writing y = z x / L + w, with w pinned at both
//! ends, the modes of w are driven by the distributed load -mu z'' x / L: a modal
//! acceleration 2 (-1)^n z'' / (n pi). The jump of the tangent's speed from 0 to V0
//! at t = 0 starts each mode with the velocity 2 (-1)^n V0 / (n pi). The straight
//! line z x / L adds T z / L to the force at both ends.

use std::f64::consts::PI;

/// How the tangent is played.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentSpec {
    /// V0, the tangent's speed when it meets the string, m/s.
    pub speed_m_s: f64,
    /// D, how far it finally lifts the string's end, m.
    pub displacement_m: f64,
}

impl TangentSpec {
    /// The time constant D / V0 of the tangent's approach, s.
    pub fn time_constant_s(&self) -> f64 {
        self.displacement_m / self.speed_m_s
    }

    /// z(t), m.
    pub fn position_m(&self, t_s: f64) -> f64 {
        -self.displacement_m * (-t_s / self.time_constant_s()).exp_m1()
    }

    /// z''(t) for t > 0, m/s^2 (the impulse at t = 0 is handled as initial velocities).
    pub fn acceleration_m_s2(&self, t_s: f64) -> f64 {
        let tau = self.time_constant_s();
        -(self.speed_m_s / tau) * (-t_s / tau).exp()
    }

    /// Modal acceleration of mode n per unit z'' (and modal velocity per unit jump in z').
    pub fn modal_gain(mode_number: usize) -> f64 {
        let sign = if mode_number.is_multiple_of(2) { 1.0 } else { -1.0 };
        2.0 * sign / (mode_number as f64 * PI)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tangent_comes_to_rest_at_d() {
        // Euphonics 12.2.3: W(inf) = V0 / alpha = D, whatever the speed.
        for &v0 in &[0.05, 0.5, 2.0] {
            let t = TangentSpec { speed_m_s: v0, displacement_m: 0.002 };
            assert!((t.position_m(40.0 * t.time_constant_s()) - 0.002).abs() < 1e-15);
            // z' = V0 e^(-t/tau): a numerical derivative agrees.
            let (a, b) = (t.position_m(1e-3), t.position_m(1e-3 + 1e-9));
            assert!(((b - a) / 1e-9 / (v0 * (-1e-3 / t.time_constant_s()).exp()) - 1.0).abs() < 1e-5);
        }
    }

    #[test]
    fn modal_gain_projects_the_straight_line() {
        // 2/L * integral of (x/L) sin(n pi x / L) = 2 (-1)^(n+1) / (n pi); the load is -z'' times it.
        for n in 1..6 {
            let steps = 200_000;
            let integral: f64 = (0..steps)
                .map(|i| {
                    let x = (i as f64 + 0.5) / steps as f64;
                    x * (n as f64 * PI * x).sin() / steps as f64
                })
                .sum();
            assert!((-2.0 * integral - TangentSpec::modal_gain(n)).abs() < 1e-9);
        }
    }
}
