//! The modes above the cut-off: their quasi-static response to a force.
//!
//! A mode far above the frequencies a contact force contains follows that force
//! statically, q_n = phi_n(x_e) F / (m_n omega_n^2). Summed over the omitted modes
//! this is a compliance at the contact point and a share of the bridge force:
//!
//!   R = sum_{n > N} phi_n(x_e)^2 / (m_n omega_n^2),
//!   S = sum_{n > N} (T k_n + EI k_n^3) phi_n(x_e) / (m_n omega_n^2) = sum_{n > N} 2 sin(n pi beta) / (n pi).
//!
//! Both are found as the closed-form total for all modes minus the kept ones. The
//! total compliance is the static Green's function of the tensioned beam
//! EI y'''' - T y'' = delta(x - a), pinned at both ends: splitting
//! 1 / (T k^2 + EI k^4) = (1/T) (1/k^2 - 1/(k^2 + kappa^2)), kappa^2 = T / EI, gives
//!
//!   G(a, a) = (1/T) [ a (L - a) / L - sinh(kappa a) sinh(kappa (L - a)) / (kappa sinh(kappa L)) ].
//!
//! The total bridge share is the lever rule, 1 - beta (the Fourier series
//! sum sin(n theta) / n = (pi - theta) / 2).
//!
//! Within their own band the omitted modes do not act as a spring: a force with
//! content there sets them ringing, and the energy they take leaves the kept modes
//! for good (on the real string it runs away as waves). Averaged over the band,
//! the admittance of a string at an interior point is resistive, 1 / (2 mu c_g),
//! with c_g = d omega / d k the group velocity (the mean of phi^2 / m_n over the
//! modal density). The residual is therefore a Kelvin-Voigt element: the static
//! compliance R in parallel with a dashpot c = 2 mu c_g(omega_{N+1}), spring-like
//! below the cut-off and resistive above it; its time constant c R is a few
//! microseconds. A first-order element leaks some loss below its corner frequency
//! 1 / (2 pi c R), so c is capped to keep that corner at or above the first omitted
//! mode: there are no omitted modes below it to take energy. It matters only for stiff contacts (a santoor mallet with
//! K = 1e6 N/m sends about 1 % of its energy there); a felt hammer hardly feels it.
//!
//! The tangent drives the string with the distributed load -mu z'' x / L; its
//! omitted modes add sum 2 mu L / (n pi)^2 z'' to the force at the tangent and
//! -sum 2 mu L (-1)^(n+1) / (n pi)^2 z'' at the bridge (totals pi^2/6 and pi^2/12).

use std::f64::consts::PI;

use crate::string::StringModes;

/// Static compliance of the whole stiff string at `position` (fraction of L from the bridge), m/N.
pub fn total_compliance_m_n(string: &StringModes, position: f64) -> f64 {
    let (l, t, ei) = (string.length_m, string.tension_n, string.bending_stiffness_n_m2);
    let a = position * l;
    let flexible = a * (l - a) / l;
    if ei == 0.0 {
        return flexible / t;
    }
    let kappa = (t / ei).sqrt();
    // sinh(x) sinh(y) / sinh(x + y) = (1 - e^-2x)(1 - e^-2y) / (2 (1 - e^-2(x+y))), free of overflow.
    let (x, y) = (kappa * a, kappa * (l - a));
    let ratio = -(-2.0 * x).exp_m1() * -(-2.0 * y).exp_m1() / (2.0 * -(-2.0 * (x + y)).exp_m1());
    (flexible - ratio / kappa) / t
}

/// Compliance of the modes the string leaves out, at `position`, m/N.
pub fn omitted_compliance_m_n(string: &StringModes, position: f64) -> f64 {
    let m = string.modal_mass_kg();
    let kept: f64 = string
        .modes
        .iter()
        .map(|mode| string.shape_at(mode, position).powi(2) / (m * mode.omega_rad_s * mode.omega_rad_s))
        .sum();
    (total_compliance_m_n(string, position) - kept).max(0.0)
}

/// Static share of the bridge force per newton of contact force at `position`
/// carried by the omitted modes.
pub fn omitted_bridge_share(string: &StringModes, position: f64) -> f64 {
    let kept: f64 =
        string.modes.iter().map(|mode| 2.0 * string.shape_at(mode, position) / (mode.number as f64 * PI)).sum();
    (1.0 - position) - kept
}

/// The dashpot of the omitted modes at `position`, N s/m: 2 mu c_g at the first
/// omitted mode, but no stronger than puts the element's corner frequency
/// 1 / (2 pi c R) at that mode (the omitted modes absorb nothing below their band).
pub fn omitted_damping_ns_m(string: &StringModes, position: f64) -> f64 {
    let (t, ei, mu) = (string.tension_n, string.bending_stiffness_n_m2, string.mass_per_length_kg_m);
    let k = (string.mode_count() + 1) as f64 * PI / string.length_m;
    let omega = ((t * k * k + ei * k.powi(4)) / mu).sqrt();
    // omega^2 = (T k^2 + EI k^4) / mu, so d omega / d k = (T k + 2 EI k^3) / (mu omega).
    let group_velocity = (t * k + 2.0 * ei * k.powi(3)) / (mu * omega);
    let band_average = 2.0 * mu * group_velocity;
    let compliance = omitted_compliance_m_n(string, position);
    if compliance > 0.0 { band_average.min(1.0 / (compliance * omega)) } else { band_average }
}

/// For a tangent at x = L driven with acceleration z'': the omitted modes' static
/// share of (force at the tangent, force at the bridge) per unit z'', in kg.
pub fn omitted_tangent_shares_kg(string: &StringModes) -> (f64, f64) {
    let scale = 2.0 * string.mass_per_length_kg_m * string.length_m / (PI * PI);
    let mut at_tangent = PI * PI / 6.0;
    let mut at_bridge = PI * PI / 12.0;
    for mode in &string.modes {
        let n = mode.number as f64;
        at_tangent -= 1.0 / (n * n);
        at_bridge -= if mode.number % 2 == 1 { 1.0 } else { -1.0 } / (n * n);
    }
    (scale * at_tangent, -scale * at_bridge)
}

/// The omitted modes as seen from one strike point, for a hammer's contact: the
/// spring R and dashpot c of the Kelvin-Voigt element above, and the static share
/// of the bridge force.
#[derive(Clone, Debug, PartialEq)]
pub(crate) struct Residual {
    /// Static compliance R, m/N.
    pub compliance_m_n: f64,
    /// Relaxation time c R, s.
    time_constant_s: f64,
    /// 1 / R, and S / R with S the static share of the bridge force per newton
    /// (both 0 without omitted modes).
    stiffness_n_m: f64,
    bridge_per_m: f64,
    /// exp(-h / (c R)) for a sample.
    pub relax_audio: f64,
}

impl Residual {
    pub fn new(string: &StringModes, position: f64, sample_s: f64) -> Self {
        let compliance_m_n = omitted_compliance_m_n(string, position);
        let time_constant_s = omitted_damping_ns_m(string, position) * compliance_m_n;
        let bridge_share = omitted_bridge_share(string, position);
        let stiffness_n_m = if compliance_m_n > 0.0 { 1.0 / compliance_m_n } else { 0.0 };
        let mut residual = Self {
            compliance_m_n,
            time_constant_s,
            stiffness_n_m,
            bridge_per_m: bridge_share * stiffness_n_m,
            relax_audio: 0.0,
        };
        residual.relax_audio = residual.relax(sample_s);
        residual
    }

    /// exp(-h / (c R)): what is left of a displacement after `step_s` without force.
    pub fn relax(&self, step_s: f64) -> f64 {
        if self.time_constant_s > 0.0 { (-step_s / self.time_constant_s).exp() } else { 0.0 }
    }

    /// Static bridge force of a residual displacement, N.
    pub fn bridge_force_n(&self, displacement_m: f64) -> f64 {
        self.bridge_per_m * displacement_m
    }

    /// Energy in the residual spring, J.
    pub fn energy_j(&self, displacement_m: f64) -> f64 {
        0.5 * self.stiffness_n_m * displacement_m * displacement_m
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::string::test_string as string;

    /// Direct modal sum of phi^2 / (m omega^2) over n = 1..count.
    fn direct_sum(s: &StringModes, position: f64, count: usize) -> f64 {
        let m = s.modal_mass_kg();
        (1..=count)
            .map(|n| {
                let k = n as f64 * PI / s.length_m;
                let stiffness = s.tension_n * k * k + s.bending_stiffness_n_m2 * k.powi(4);
                (n as f64 * PI * position).sin().powi(2) / (m * stiffness / s.mass_per_length_kg_m)
            })
            .sum()
    }

    #[test]
    fn closed_form_compliance_matches_the_modal_sum() {
        // A stiff string's terms fall as n^-4: two million terms converge to 1e-15.
        for &b in &[2e-4, 2e-2] {
            let s = string(b, 20_000.0);
            for &beta in &[0.1, 0.4, 0.73] {
                let closed = total_compliance_m_n(&s, beta);
                let direct = direct_sum(&s, beta, 2_000_000);
                assert!((closed / direct - 1.0).abs() < 1e-9, "B={b} beta={beta}: {closed} vs {direct}");
            }
        }
        // The flexible string's is a (L - a) / (T L).
        let s = string(0.0, 20_000.0);
        assert!((total_compliance_m_n(&s, 0.4) - 0.16 * 0.24 / (191.0 * 0.4)).abs() < 1e-18);
    }

    #[test]
    fn omitted_compliance_is_the_tail_of_the_sum() {
        let s = string(2e-4, 20_000.0);
        let tail = direct_sum(&s, 0.4, 2_000_000) - direct_sum(&s, 0.4, s.mode_count());
        assert!((omitted_compliance_m_n(&s, 0.4) / tail - 1.0).abs() < 1e-6);
    }

    #[test]
    fn bridge_share_is_the_lever_rule_minus_the_kept_modes() {
        let s = string(2e-4, 20_000.0);
        let tail: f64 =
            (s.mode_count() + 1..=4_000_000).map(|n| 2.0 * (n as f64 * PI * 0.4).sin() / (n as f64 * PI)).sum();
        assert!((omitted_bridge_share(&s, 0.4) - tail).abs() < 1e-6);
    }

    #[test]
    fn omitted_damping_is_twice_the_impedance_for_a_flexible_string() {
        // Without stiffness c_g = c and the dashpot is 2 Z0, the infinite string's.
        let s = string(0.0, 20_000.0);
        let k = (s.mode_count() + 1) as f64 * PI / s.length_m;
        let corner_limit = 1.0 / (omitted_compliance_m_n(&s, 0.4) * k * (s.tension_n / s.mass_per_length_kg_m).sqrt());
        let expected = (2.0 * s.impedance_ns_m()).min(corner_limit);
        assert!((omitted_damping_ns_m(&s, 0.4) / expected - 1.0).abs() < 1e-12);
        // For the santoor string at 2/5 the band average is the smaller of the two.
        let stiff = string(2e-4, 43_200.0);
        assert!(omitted_damping_ns_m(&stiff, 0.4) > 2.0 * stiff.impedance_ns_m());
    }

    #[test]
    fn tangent_shares_are_the_tails_of_their_series() {
        let s = string(2e-4, 5_000.0);
        let scale = 2.0 * s.mass_per_length_kg_m * s.length_m / (PI * PI);
        let (mut t, mut b) = (0.0, 0.0);
        for n in (s.mode_count() + 1..=1_000_000).rev() {
            let n2 = (n * n) as f64;
            t += 1.0 / n2;
            b -= if n % 2 == 1 { 1.0 } else { -1.0 } / n2;
        }
        let (at_tangent, at_bridge) = omitted_tangent_shares_kg(&s);
        assert!((at_tangent / (scale * t) - 1.0).abs() < 1e-4);
        assert!((at_bridge - scale * b).abs() < 1e-9 * scale);
    }
}
