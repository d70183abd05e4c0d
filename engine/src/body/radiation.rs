//! How a body mode reaches a microphone: the far field of a baffled plate
//! vibrating in one mode (Rayleigh's integral).
//!
//! A plate whose normal acceleration is `a(t) sin(m pi x / L) sin(n pi y / W)`
//! radiates, far away in the direction (kx, ky)/k from its centre,
//!
//! p = rho e^{-i k r} / (2 pi r) · I_m(kx) I_n(ky) · a,
//!
//! with I_m(beta) the integral of sin(m pi x / L) e^{i beta x} over the side,
//! measured from the centre. Below the plate's coincidence the lobes of a mode
//! cancel each other: a mode with an odd number of half-waves both ways keeps a
//! net volume and radiates as a small piston, the others barely; above it every
//! mode radiates into the directions its wavelength allows. Two microphones in
//! different directions therefore hear each mode with its own weight and phase,
//! which is what makes the pair's image wide and its correlation fall with
//! frequency, as over a real soundboard.

use std::f64::consts::PI;

use num_complex::Complex64;

use super::boards::SOUND_SPEED_M_S;
use super::plate::{BodyMode, Plate};
use crate::string::damping::AIR_DENSITY_KG_M3;

/// A microphone's position: metres from the board's corner along the grain (x)
/// and across it (y), and its height above the board.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct MicPosition {
    pub x_m: f64,
    pub y_m: f64,
    pub height_m: f64,
}

/// The integral of sin(m pi x / side) e^{i beta x} over 0..side, with x
/// measured from the side's middle (a phase e^{-i beta side / 2}).
fn side_integral(m: u32, side_m: f64, beta: f64) -> Complex64 {
    let alpha = f64::from(m) * PI / side_m;
    let sign = if m.is_multiple_of(2) { 1.0 } else { -1.0 };
    let mut denominator = alpha * alpha - beta * beta;
    // At beta = +-alpha the integral is finite (side / 2 in size); step off the pole.
    if denominator.abs() < 1e-9 * alpha * alpha {
        denominator = 1e-9 * alpha * alpha;
    }
    let from_corner =
        alpha * (Complex64::new(1.0, 0.0) - sign * Complex64::from_polar(1.0, beta * side_m)) / denominator;
    from_corner * Complex64::from_polar(1.0, -beta * side_m / 2.0)
}

/// Sound pressure at `mic` per unit modal acceleration (m/s^2 at the shape's
/// peak) of `mode`, Pa s^2/m, near the mode's own frequency. The air mode of a
/// box radiates through its holes as the volume its top's (1, 1) shape
/// displaces.
///
/// Measured from the board's middle, a shape with an odd number of half-waves
/// along a side is even about it and its lobe integral is real; with an even
/// number it is odd, and the integral imaginary: i times an odd function of
/// the direction, which in time is a derivative, a dipole. The weight keeps the
/// sign and size and leaves that quarter period out, so that a microphone
/// hears a real multiple of the mode's acceleration: exact for the volume
/// modes, and never more sound below a mode's resonance than its acceleration
/// gives (a complex weight on the mode's complex state would let a quadrature
/// share through that falls only 6 dB an octave below it). The travel time
/// from the board's middle is the same for both microphones of a symmetric pair
/// and is left out.
pub fn pressure_per_acceleration(plate: &Plate, mode: &BodyMode, mic: MicPosition) -> f64 {
    let (m, n) = if mode.is_air() { (1, 1) } else { (mode.m, mode.n) };
    let dx = mic.x_m - plate.length_m / 2.0;
    let dy = mic.y_m - plate.width_m / 2.0;
    let r = (dx * dx + dy * dy + mic.height_m * mic.height_m).sqrt().max(0.05);
    let k = 2.0 * PI * mode.frequency_hz / SOUND_SPEED_M_S;
    let lobes = side_integral(m, plate.length_m, k * dx / r) * side_integral(n, plate.width_m, k * dy / r);
    AIR_DENSITY_KG_M3 / (2.0 * PI * r) * (lobes.re + lobes.im)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::boards::design;
    use crate::design::InstrumentKind;

    #[test]
    fn the_side_integral_matches_a_sum() {
        for (m, beta) in [(1, 0.0), (2, 3.0), (3, 12.0), (4, 25.0), (5, -7.0)] {
            let side = 0.8;
            let steps = 20_000;
            let mut sum = Complex64::new(0.0, 0.0);
            for i in 0..steps {
                let x = (i as f64 + 0.5) * side / steps as f64;
                let shape = (f64::from(m) * PI * x / side).sin();
                sum += shape * Complex64::from_polar(1.0, beta * (x - side / 2.0)) * (side / steps as f64);
            }
            let exact = side_integral(m, side, beta);
            assert!((exact - sum).norm() < 1e-6 * (1.0 + sum.norm()), "m {m} beta {beta}: {exact} against {sum}");
        }
    }

    #[test]
    fn a_low_volume_mode_outradiates_a_low_mode_without_net_volume() {
        let board = design(InstrumentKind::Piano);
        let modes = board.modes(400.0);
        let mic = MicPosition { x_m: 0.75, y_m: 0.5, height_m: 2.0 };
        let odd = modes.iter().find(|m| m.m == 1 && m.n == 1).unwrap();
        let even = modes.iter().find(|m| m.m == 2 && m.n == 1).unwrap();
        let (p_odd, p_even) = (
            pressure_per_acceleration(&board.plate, odd, mic).abs(),
            pressure_per_acceleration(&board.plate, even, mic).abs(),
        );
        // The piston's pressure: rho V / (2 pi r) with V = L W 4 / pi^2.
        let piston = 1.2 * board.plate.area_m2() * 4.0 / (PI * PI) / (2.0 * PI * 2.0);
        assert!((p_odd / piston - 1.0).abs() < 0.1, "{p_odd} against {piston}");
        assert!(p_even < 0.2 * p_odd, "{p_even} against {p_odd}");
    }
}
