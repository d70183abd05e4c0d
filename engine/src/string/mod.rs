//! The stiff string: geometry, tuning, mass, bending stiffness, and its modes.
//!
//! A string of length L, mass per length mu, tension T and bending stiffness EI,
//! pinned at both ends with x = 0 at the bridge. Its modes are
//! phi_n(x) = sin(k_n x), k_n = n pi / L, with modal mass mu L / 2 and
//!
//!   omega_n^2 = (T k_n^2 + EI k_n^4) / mu,  i.e.  f_n = n f0 sqrt(1 + B n^2),
//!   f0 = sqrt(T / mu) / (2 L),  B = pi^2 EI / (T L^2) = pi^3 E d^4 / (64 T L^2)
//!
//! (Fletcher 1964; Euphonics 5.4.3). When a string is tuned by its pitch, it is
//! the first partial f_1 = f0 sqrt(1 + B) that sits on the target. Each mode
//! carries its own quality factor Q_n (see [`crate::string::damping`]).
//!
//! Everything here is computed once, when a note is set up; nothing here runs
//! on the audio thread.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod damping;
pub mod residual;

use std::f64::consts::PI;

use crate::string::damping::{Damping, LossModel};

/// How the string is tuned: by the frequency of its first partial or by its tension.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Tuning {
    /// The first partial f_1 = f0 sqrt(1 + B), inharmonicity included.
    FirstPartialHz(f64),
    /// The tension in newtons.
    TensionN(f64),
}

/// How the mass of the string is given.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Mass {
    /// Mass per unit length, kg/m (for a wound string: core and wrapping together).
    PerLengthKgM(f64),
    /// A solid round wire: mu = rho pi d^2 / 4.
    SolidWire { diameter_m: f64, density_kg_m3: f64 },
}

/// Where the bending stiffness comes from.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Stiffness {
    /// An ideal flexible string (B = 0).
    Flexible,
    /// The inharmonicity coefficient B directly.
    Inharmonicity(f64),
    /// Young's modulus and the diameter that carries the bending: the wire's
    /// diameter, or the core's for a wound string (the wrapping adds mass, not
    /// stiffness; Euphonics 12.2.1).
    YoungsModulus { modulus_pa: f64, bending_diameter_m: f64 },
}

/// The physical description of one string, in SI units.
#[derive(Clone, Debug, PartialEq)]
pub struct StringSpec {
    pub length_m: f64,
    pub tuning: Tuning,
    pub mass: Mass,
    pub stiffness: Stiffness,
    pub damping: Damping,
    /// Modes above this frequency are left out (their static share is kept; see
    /// [`crate::string::residual`]).
    pub max_frequency_hz: f64,
    /// Outer diameter, when known; only air damping uses it.
    pub outer_diameter_m: Option<f64>,
}

/// Why a string description cannot be built.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StringError {
    #[error("the string is too stiff to be tuned to {f1_hz} Hz: its bending alone gives a higher first partial")]
    TooStiffToTune { f1_hz: f64 },
    #[error("no mode lies below {max_frequency_hz} Hz (the first partial is {f1_hz} Hz)")]
    NoModes { max_frequency_hz: f64, f1_hz: f64 },
    #[error("a mode's Q must be greater than 0.5 (mode {mode} has {q})")]
    Overdamped { mode: usize, q: f64 },
    #[error("{0} must be a positive finite number")]
    NotPositive(&'static str),
}

/// Upper bound on the number of modes of one string: a C1 string at 192 kHz
/// with the lab's 0.45 fs cut-off needs about 400, so this only catches nonsense.
pub const MAX_MODES: usize = 16_384;

/// A string with everything derived: tension, mass, stiffness and its mode table.
#[derive(Clone, Debug)]
pub struct StringModes {
    pub length_m: f64,
    pub tension_n: f64,
    pub mass_per_length_kg_m: f64,
    /// Bending stiffness EI, N m^2.
    pub bending_stiffness_n_m2: f64,
    /// Inharmonicity coefficient B.
    pub inharmonicity: f64,
    /// Fundamental of the flexible string with this tension and mass, sqrt(T/mu)/(2L).
    pub f0_hz: f64,
    /// Per mode n = 1..=N (index n - 1).
    pub modes: Vec<Mode>,
}

/// One mode of the string.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Mode {
    /// Mode number, from 1.
    pub number: usize,
    /// Wavenumber k_n = n pi / L, rad/m.
    pub wavenumber_rad_m: f64,
    /// Undamped angular frequency omega_n, rad/s.
    pub omega_rad_s: f64,
    /// Quality factor Q_n (may be infinite: no loss).
    pub q: f64,
}

impl Mode {
    /// Decay rate of the amplitude, sigma_n = omega_n / (2 Q_n), 1/s.
    pub fn decay_rate_s(&self) -> f64 {
        self.omega_rad_s / (2.0 * self.q)
    }

    /// Damped angular frequency sqrt(omega^2 - sigma^2), rad/s.
    pub fn damped_omega_rad_s(&self) -> f64 {
        let sigma = self.decay_rate_s();
        (self.omega_rad_s * self.omega_rad_s - sigma * sigma).sqrt()
    }

    pub fn frequency_hz(&self) -> f64 {
        self.omega_rad_s / (2.0 * PI)
    }
}

fn positive(value: f64, what: &'static str) -> Result<f64, StringError> {
    if value.is_finite() && value > 0.0 { Ok(value) } else { Err(StringError::NotPositive(what)) }
}

impl StringSpec {
    /// Derive tension, mass, stiffness and the mode table up to `max_frequency_hz`.
    pub fn build(&self) -> Result<StringModes, StringError> {
        let length_m = positive(self.length_m, "length")?;
        let mu = match self.mass {
            Mass::PerLengthKgM(mu) => positive(mu, "mass per length")?,
            Mass::SolidWire { diameter_m, density_kg_m3 } => {
                positive(density_kg_m3, "density")? * PI * positive(diameter_m, "diameter")?.powi(2) / 4.0
            }
        };
        // The bending stiffness, when it is given as material and diameter,
        // is fixed whatever the tension: EI = E pi d^4 / 64 (0 when it is not).
        let material_ei = match self.stiffness {
            Stiffness::YoungsModulus { modulus_pa, bending_diameter_m } => {
                positive(modulus_pa, "Young's modulus")? * PI * positive(bending_diameter_m, "diameter")?.powi(4) / 64.0
            }
            _ => 0.0,
        };
        let tension_n = match (self.tuning, self.stiffness) {
            (Tuning::TensionN(t), _) => positive(t, "tension")?,
            // f_1^2 = (T + EI pi^2 / L^2) / (4 L^2 mu) for the stiff pinned string.
            (Tuning::FirstPartialHz(f1), Stiffness::YoungsModulus { .. }) => {
                let f1 = positive(f1, "first-partial frequency")?;
                let ei = material_ei;
                let t = 4.0 * length_m * length_m * mu * f1 * f1 - ei * PI * PI / (length_m * length_m);
                if !(t > 0.0) {
                    return Err(StringError::TooStiffToTune { f1_hz: f1 });
                }
                t
            }
            (Tuning::FirstPartialHz(f1), Stiffness::Inharmonicity(b)) => {
                let f0 = positive(f1, "first-partial frequency")? / (1.0 + b).sqrt();
                4.0 * length_m * length_m * mu * f0 * f0
            }
            (Tuning::FirstPartialHz(f1), Stiffness::Flexible) => {
                let f1 = positive(f1, "first-partial frequency")?;
                4.0 * length_m * length_m * mu * f1 * f1
            }
        };
        let ei = match self.stiffness {
            Stiffness::Flexible => 0.0,
            Stiffness::Inharmonicity(b) => {
                if !(b.is_finite() && b >= 0.0) {
                    return Err(StringError::NotPositive("inharmonicity"));
                }
                b * tension_n * length_m * length_m / (PI * PI)
            }
            Stiffness::YoungsModulus { .. } => material_ei,
        };
        let inharmonicity = PI * PI * ei / (tension_n * length_m * length_m);
        let f0_hz = (tension_n / mu).sqrt() / (2.0 * length_m);
        let max_frequency_hz = positive(self.max_frequency_hz, "maximum frequency")?;

        let f1_hz = f0_hz * (1.0 + inharmonicity).sqrt();
        if f1_hz > max_frequency_hz {
            return Err(StringError::NoModes { max_frequency_hz, f1_hz });
        }
        let outer_diameter_m = self.outer_diameter_m.or(match self.mass {
            Mass::SolidWire { diameter_m, .. } => Some(diameter_m),
            Mass::PerLengthKgM(_) => None,
        });
        let loss = LossModel { length_m, tension_n, mass_per_length_kg_m: mu, inharmonicity, outer_diameter_m };
        let mut modes = Vec::new();
        for n in 1..=MAX_MODES {
            let f = n as f64 * f0_hz * (1.0 + inharmonicity * (n * n) as f64).sqrt();
            if f > max_frequency_hz {
                break;
            }
            let q = self.damping.q(n, f, &loss);
            if !(q > 0.5) {
                return Err(StringError::Overdamped { mode: n, q });
            }
            modes.push(Mode { number: n, wavenumber_rad_m: n as f64 * PI / length_m, omega_rad_s: 2.0 * PI * f, q });
        }
        Ok(StringModes {
            length_m,
            tension_n,
            mass_per_length_kg_m: mu,
            bending_stiffness_n_m2: ei,
            inharmonicity,
            f0_hz,
            modes,
        })
    }
}

impl StringModes {
    /// Modal mass mu L / 2 (the same for every mode with phi_n = sin(k_n x)).
    pub fn modal_mass_kg(&self) -> f64 {
        self.mass_per_length_kg_m * self.length_m / 2.0
    }

    /// Wave impedance sqrt(T mu), N s/m.
    pub fn impedance_ns_m(&self) -> f64 {
        (self.tension_n * self.mass_per_length_kg_m).sqrt()
    }

    /// Frequency of partial n from the formula, f_n = n f0 sqrt(1 + B n^2) (any n,
    /// kept or not).
    pub fn partial_hz(&self, n: usize) -> f64 {
        let n = n as f64;
        n * self.f0_hz * (1.0 + self.inharmonicity * n * n).sqrt()
    }

    /// The transverse force that mode n at unit amplitude exerts on the bridge at x = 0:
    /// T phi_n'(0) - EI phi_n'''(0) = T k_n + EI k_n^3 = mu omega_n^2 / k_n.
    pub fn bridge_weight(&self, mode: &Mode) -> f64 {
        let k = mode.wavenumber_rad_m;
        self.tension_n * k + self.bending_stiffness_n_m2 * k * k * k
    }

    /// Mode shape phi_n(x) = sin(k_n x) at a fraction `position` of the length from the bridge.
    pub fn shape_at(&self, mode: &Mode, position: f64) -> f64 {
        (mode.number as f64 * PI * position).sin()
    }

    pub fn mode_count(&self) -> usize {
        self.modes.len()
    }
}

/// A treble-like plain string for the crate's tests: 0.4 m at 191 N and
/// 1.54 g/m (about 440 Hz), inharmonicity `b` (0: flexible), Q 1000, modes
/// up to `max_hz`.
#[cfg(test)]
pub(crate) fn test_string(b: f64, max_hz: f64) -> StringModes {
    StringSpec {
        length_m: 0.4,
        tuning: Tuning::TensionN(191.0),
        mass: Mass::PerLengthKgM(1.54e-3),
        stiffness: if b > 0.0 { Stiffness::Inharmonicity(b) } else { Stiffness::Flexible },
        damping: damping::Damping::UniformQ(1000.0),
        max_frequency_hz: max_hz,
        outer_diameter_m: None,
    }
    .build()
    .unwrap()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn santoor(stiffness: Stiffness, tuning: Tuning) -> StringSpec {
        StringSpec {
            length_m: 0.4,
            tuning,
            mass: Mass::SolidWire { diameter_m: 0.0005, density_kg_m3: 7850.0 },
            stiffness,
            damping: Damping::UniformQ(1000.0),
            max_frequency_hz: 20_000.0,
            outer_diameter_m: None,
        }
    }

    #[test]
    fn tuned_by_first_partial_with_youngs_modulus_hits_the_pitch() {
        let s = santoor(
            Stiffness::YoungsModulus { modulus_pa: 2.0e11, bending_diameter_m: 0.0005 },
            Tuning::FirstPartialHz(440.0),
        )
        .build()
        .unwrap();
        assert!((s.partial_hz(1) - 440.0).abs() < 1e-9);
        assert!((s.modes[0].frequency_hz() - 440.0).abs() < 1e-9);
        // Euphonics' santoor string: T about 191 N, B about 2.0e-4.
        assert!((s.tension_n - 191.0).abs() < 1.0, "{}", s.tension_n);
        assert!((s.inharmonicity - 1.98e-4).abs() < 0.02e-4, "{}", s.inharmonicity);
        // B = pi^3 E d^4 / (64 T L^2).
        let b = PI.powi(3) * 2.0e11 * 0.0005f64.powi(4) / (64.0 * s.tension_n * 0.16);
        assert!((s.inharmonicity / b - 1.0).abs() < 1e-12);
    }

    #[test]
    fn modes_follow_the_stiff_string_formula_up_to_the_cut_off() {
        let s = santoor(Stiffness::Inharmonicity(2.0e-4), Tuning::TensionN(191.0)).build().unwrap();
        for m in &s.modes {
            let n = m.number as f64;
            let f = n * s.f0_hz * (1.0 + 2.0e-4 * n * n).sqrt();
            assert!((m.frequency_hz() / f - 1.0).abs() < 1e-13);
        }
        let last = s.modes.last().unwrap();
        assert!(last.frequency_hz() <= 20_000.0);
        assert!(s.partial_hz(last.number + 1) > 20_000.0);
        // Bridge weight identity T k + EI k^3 = mu omega^2 / k.
        for m in &s.modes {
            let w = s.mass_per_length_kg_m * m.omega_rad_s.powi(2) / m.wavenumber_rad_m;
            assert!((s.bridge_weight(m) / w - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn refuses_impossible_strings() {
        let too_stiff = santoor(
            Stiffness::YoungsModulus { modulus_pa: 2.0e11, bending_diameter_m: 0.02 },
            Tuning::FirstPartialHz(30.0),
        );
        assert!(matches!(too_stiff.build(), Err(StringError::TooStiffToTune { .. })));
        let mut no_modes = santoor(Stiffness::Flexible, Tuning::FirstPartialHz(440.0));
        no_modes.max_frequency_hz = 400.0;
        assert!(matches!(no_modes.build(), Err(StringError::NoModes { .. })));
        let mut overdamped = santoor(Stiffness::Flexible, Tuning::FirstPartialHz(440.0));
        overdamped.damping = Damping::PerModeQ(vec![1000.0, 0.4]);
        assert!(matches!(overdamped.build(), Err(StringError::Overdamped { mode: 2, .. })));
    }
}
