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
//!
//! Holding the string's end at W stretches the string on both sides of the
//! tangent: the speaking length L2 (to the bridge) and the damped length L1
//! (through the listing felt to the hitch pin). Each becomes longer by about
//! W^2 / (2 L), and as the string slides over the tangent the tension evens out
//! over L1 + L2:
//!
//!   dT / T = E A (1 / (2 L1) + 1 / (2 L2)) W^2 / ((L1 + L2) T),
//!
//! which raises the pitch by the factor sqrt(1 + dT / T): quadratic in W, a few
//! cents at W = 2 mm (physics reference 1.6; the seed's Fig. 29, after Thwaites &
//! Fletcher 1981).

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

/// The tension's rise per square metre of tangent displacement, 1/m^2: the
/// tension becomes T (1 + s W^2) when the tangent holds the end at W. For a wire
/// of Young's modulus `modulus_pa` and cross-section `area_m2` at `tension_n`,
/// speaking over `speaking_length_m` and damped over `damped_length_m`.
pub fn stretch_per_m2(
    modulus_pa: f64,
    area_m2: f64,
    tension_n: f64,
    speaking_length_m: f64,
    damped_length_m: f64,
) -> f64 {
    let (l1, l2) = (damped_length_m, speaking_length_m);
    modulus_pa * area_m2 * (0.5 / l1 + 0.5 / l2) / ((l1 + l2) * tension_n)
}

/// The factor a press of `displacement_m` raises the pitch by, sqrt(1 + s W^2),
/// for a string whose tension rises by `stretch_per_m2` (bending stiffness, which
/// does not change with the tension, is left out: it moves the first partial by
/// well under 0.01 of this).
pub fn stretched_pitch_ratio(stretch_per_m2: f64, displacement_m: f64) -> f64 {
    (1.0 + stretch_per_m2 * displacement_m * displacement_m).sqrt()
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

    fn cents(ratio: f64) -> f64 {
        1200.0 * ratio.log2()
    }

    /// Brass (E = 100 GPa, rho = 8500 kg/m^3) of `diameter_m` sounding `f_hz` over
    /// `speaking_m`, damped over `damped_m`: the rise in cents at `w_m`.
    fn brass_rise_cents(diameter_m: f64, f_hz: f64, speaking_m: f64, damped_m: f64, w_m: f64) -> f64 {
        let area = PI * diameter_m * diameter_m / 4.0;
        let tension = 4.0 * speaking_m * speaking_m * 8500.0 * area * f_hz * f_hz;
        cents(stretched_pitch_ratio(stretch_per_m2(1.0e11, area, tension, speaking_m, damped_m), w_m))
    }

    #[test]
    fn stretching_reproduces_the_worked_examples() {
        // Physics reference 1.6: 0.35 mm brass, L2 = 0.40 m, L1 = 0.10 m, 330 Hz
        // (working stress 590 MPa): 1.8 cents at 1 mm, 7.3 cents at 2 mm.
        let rise = |w| brass_rise_cents(0.35e-3, 330.0, 0.40, 0.10, w);
        assert!((rise(1e-3) - 1.8).abs() < 0.05, "{}", rise(1e-3));
        assert!((rise(2e-3) - 7.3).abs() < 0.05, "{}", rise(2e-3));
        // 0.30 mm, L2 = 0.30 m, 440 Hz (the same L1): 2.4 and 9.7 cents.
        let rise = |w| brass_rise_cents(0.30e-3, 440.0, 0.30, 0.10, w);
        assert!((rise(1e-3) - 2.4).abs() < 0.05, "{}", rise(1e-3));
        assert!((rise(2e-3) - 9.7).abs() < 0.05, "{}", rise(2e-3));
    }

    #[test]
    fn the_rise_is_quadratic_in_the_displacement_and_set_by_the_stress() {
        let s = stretch_per_m2(1.0e11, 1.0e-7, 50.0, 0.5, 0.3);
        for w in [0.25e-3, 0.5e-3, 1e-3] {
            let (one, two) = (stretched_pitch_ratio(s, w) - 1.0, stretched_pitch_ratio(s, 2.0 * w) - 1.0);
            // sqrt(1 + x) - 1 = x / 2 - x^2 / 8 ...: the ratio is 4 to within the square term.
            assert!((two / one - 4.0).abs() < 4.0 * 2.0 * s * w * w, "{w}: {}", two / one);
        }
        // Only the stress T / A matters: twice the area at twice the tension is the same string.
        assert!((stretch_per_m2(1.0e11, 2.0e-7, 100.0, 0.5, 0.3) / s - 1.0).abs() < 1e-12);
        assert_eq!(stretched_pitch_ratio(s, 0.0), 1.0);
    }
}
