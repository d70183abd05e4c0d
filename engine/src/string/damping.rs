//! Losses of a string's modes: a Q for every mode, a list per mode, or a physical
//! default summing three mechanisms (Euphonics 5.4, 5.1.2 and 7.2.2):
//!
//! - air viscosity (Valette 1995): resistance per length
//!   R = 2 pi eta_air + 2 pi d sqrt(pi eta_air rho_air f), loss factor R / (2 pi f mu);
//! - internal friction from a complex Young's modulus E (1 + i eta_E): only the
//!   bending share of a mode's potential energy is lossy, so by Rayleigh's
//!   principle eta = eta_E B n^2 / (1 + B n^2), which rises as B n^2 while the
//!   bending share is small;
//! - loss into the bridge through its admittance Y: the wave loses 4 Z0 Re Y of its
//!   energy at each reflection, i.e. eta = 2 Z0 Re(Y) / (n pi), Z0 = sqrt(T mu).
//!
//! Q_n = 1 / (sum of the loss factors).

use std::f64::consts::PI;

/// Dynamic viscosity of air at room temperature, Pa s.
pub const AIR_VISCOSITY_PA_S: f64 = 1.8e-5;
/// Density of air at room temperature, kg/m^3.
pub const AIR_DENSITY_KG_M3: f64 = 1.2;
/// Density of steel, kg/m^3: used to estimate a diameter for air drag when only
/// the mass per length is known.
pub const STEEL_DENSITY_KG_M3: f64 = 7850.0;

/// Default internal loss factor of music wire. The literature puts steel between
/// 1e-4 and 1e-3 (Woodhouse, Euphonics 5.4 and 7.2.2; not confirmed); this sits in the middle.
pub const DEFAULT_INTERNAL_LOSS_FACTOR: f64 = 3.0e-4;
/// Default real part of the bridge admittance, s/kg: a generic wooden bridge on a
/// soundboard (impedance of order 1e3 N s/m). Gives a santoor string a
/// fundamental Q near 2000 and a piano bass string a few seconds of decay.
pub const DEFAULT_BRIDGE_ADMITTANCE_S_KG: f64 = 1.0e-3;

/// How the Q of each mode is set.
#[derive(Clone, Debug, PartialEq)]
pub enum Damping {
    /// The same Q for every mode (Woodhouse's simple simulations: 1000 for the
    /// santoor, 2000 for the piano). May be infinite for a lossless string.
    UniformQ(f64),
    /// Q for mode 1, 2, ...; the last value holds for all higher modes.
    PerModeQ(Vec<f64>),
    /// The sum of air, internal and bridge losses.
    Physical(PhysicalLoss),
}

/// Parameters of the physical loss model.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PhysicalLoss {
    /// eta_E of the wire's material.
    pub internal_loss_factor: f64,
    /// Re Y of the bridge, s/kg.
    pub bridge_admittance_s_kg: f64,
}

impl Default for PhysicalLoss {
    fn default() -> Self {
        Self {
            internal_loss_factor: DEFAULT_INTERNAL_LOSS_FACTOR,
            bridge_admittance_s_kg: DEFAULT_BRIDGE_ADMITTANCE_S_KG,
        }
    }
}

/// What the physical loss model needs to know about the string.
#[derive(Clone, Copy, Debug)]
pub struct LossModel {
    pub length_m: f64,
    pub tension_n: f64,
    pub mass_per_length_kg_m: f64,
    pub inharmonicity: f64,
    pub outer_diameter_m: Option<f64>,
}

impl LossModel {
    /// Loss factor from air viscosity at frequency `f_hz`.
    pub fn air_loss_factor(&self, f_hz: f64) -> f64 {
        let mu = self.mass_per_length_kg_m;
        let d = self.outer_diameter_m.unwrap_or_else(|| (4.0 * mu / (PI * STEEL_DENSITY_KG_M3)).sqrt());
        let resistance =
            2.0 * PI * AIR_VISCOSITY_PA_S + 2.0 * PI * d * (PI * AIR_VISCOSITY_PA_S * AIR_DENSITY_KG_M3 * f_hz).sqrt();
        resistance / (2.0 * PI * f_hz * mu)
    }

    /// Loss factor from internal friction for mode n.
    pub fn internal_loss_factor(&self, n: usize, eta_e: f64) -> f64 {
        let bn2 = self.inharmonicity * (n * n) as f64;
        eta_e * bn2 / (1.0 + bn2)
    }

    /// Loss factor into the bridge for mode n.
    pub fn bridge_loss_factor(&self, n: usize, admittance_s_kg: f64) -> f64 {
        let z0 = (self.tension_n * self.mass_per_length_kg_m).sqrt();
        2.0 * z0 * admittance_s_kg / (n as f64 * PI)
    }
}

impl Damping {
    /// Q of mode `n` (from 1), whose frequency is `f_hz`.
    pub fn q(&self, n: usize, f_hz: f64, string: &LossModel) -> f64 {
        match self {
            Damping::UniformQ(q) => *q,
            Damping::PerModeQ(list) => match list.get(n - 1).or(list.last()) {
                Some(q) => *q,
                None => f64::NAN,
            },
            Damping::Physical(p) => {
                let eta = string.air_loss_factor(f_hz)
                    + string.internal_loss_factor(n, p.internal_loss_factor)
                    + string.bridge_loss_factor(n, p.bridge_admittance_s_kg);
                1.0 / eta
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn santoor() -> LossModel {
        // 0.5 mm steel, 0.4 m, 440 Hz.
        LossModel {
            length_m: 0.4,
            tension_n: 191.0,
            mass_per_length_kg_m: 1.541e-3,
            inharmonicity: 2.0e-4,
            outer_diameter_m: Some(0.0005),
        }
    }

    #[test]
    fn air_damping_of_a_santoor_string_is_about_1_5e_4() {
        // Physics reference 1.4: 0.5 mm steel at 440 Hz gives eta_air of about 1.5e-4.
        let eta = santoor().air_loss_factor(440.0);
        assert!((eta - 1.54e-4).abs() < 0.05e-4, "{eta}");
    }

    #[test]
    fn internal_loss_rises_as_b_n_squared_then_saturates() {
        let s = santoor();
        let a = s.internal_loss_factor(1, 1e-3);
        let b = s.internal_loss_factor(10, 1e-3);
        assert!((b / a - 100.0 * (1.0 + 2e-4) / (1.0 + 2e-2)).abs() < 1e-9);
        assert!(s.internal_loss_factor(10_000, 1e-3) < 1e-3);
    }

    #[test]
    fn bridge_loss_falls_as_one_over_n() {
        let s = santoor();
        let z0 = (191.0f64 * 1.541e-3).sqrt();
        assert!((s.bridge_loss_factor(1, 1e-3) - 2.0 * z0 * 1e-3 / PI).abs() < 1e-15);
        assert!((s.bridge_loss_factor(1, 1e-3) / s.bridge_loss_factor(4, 1e-3) - 4.0).abs() < 1e-12);
    }

    #[test]
    fn physical_q_sums_the_three_loss_factors() {
        let s = santoor();
        let p = PhysicalLoss::default();
        let q = Damping::Physical(p).q(3, 1320.0, &s);
        let eta = s.air_loss_factor(1320.0)
            + s.internal_loss_factor(3, p.internal_loss_factor)
            + s.bridge_loss_factor(3, p.bridge_admittance_s_kg);
        assert!((q * eta - 1.0).abs() < 1e-12);
        // The santoor string's fundamental lands in the 1000-3000 range.
        let q1 = Damping::Physical(p).q(1, 440.0, &s);
        assert!((1000.0..3000.0).contains(&q1), "{q1}");
    }

    #[test]
    fn per_mode_list_holds_its_last_value() {
        let d = Damping::PerModeQ(vec![300.0, 400.0]);
        let s = santoor();
        assert_eq!(d.q(1, 1.0, &s), 300.0);
        assert_eq!(d.q(2, 1.0, &s), 400.0);
        assert_eq!(d.q(9, 1.0, &s), 400.0);
    }
}
