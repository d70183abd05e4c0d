//! How a body mode reaches a microphone: Rayleigh's integral over a baffled
//! plate vibrating in one mode, summed at the microphone itself.
//!
//! A plate whose normal acceleration is `a(t) sin(m pi x / L) sin(n pi y / W)`
//! gives, at a point R(x, y) away from each of its elements,
//!
//! p = rho / (2 pi) · a · ∫∫ sin(m pi x / L) sin(n pi y / W) e^{-i k R} / R dx dy.
//!
//! Below the plate's coincidence the lobes of a mode cancel each other: a
//! mode with an odd number of half-waves both ways keeps a net volume and
//! radiates as a small piston, the others barely; above it every mode
//! radiates into the directions its wavelength allows. Two microphones in
//! different places therefore hear each mode with its own weight and phase,
//! which is what makes the pair's image wide and its correlation fall with
//! frequency, as over a real soundboard.
//!
//! The microphones sit within a board's length of it, far inside its Fresnel
//! distance (L^2 / lambda: 10 m for a 1.5 m board at 1.5 kHz), so the sum is
//! taken at the microphone, not in the far field's directions: there the
//! lobes nearest the microphone outweigh the far ones, and a 1.5 kHz mode of
//! the piano's board is heard 15 dB louder from 0.7 m above its middle than
//! the far field's formula says, while its (1, 1) piston is heard alike
//! (this file's tests).

use std::collections::BTreeMap;
use std::f64::consts::PI;
use std::sync::Mutex;

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
/// peak) of `mode`, Pa s^2/m, near the mode's own frequency. A box's coupled
/// top-and-air mode radiates its net volume (the top's and the holes' air,
/// taken together as the (1, 1) shape's small piston, times `net_volume`).
///
/// The sum is taken on a grid fine enough for the shape's half-waves and the
/// sound's wavelength (a quarter of either per cell, midpoint rule). The
/// travel time from the board's middle is the same for both microphones of a
/// symmetric pair and is taken out; the weight is the size of what is left,
/// with the sign of its in-phase and quadrature parts' sum, so that a
/// microphone hears a real multiple of the mode's acceleration (in the far
/// field a volume mode's pressure is real and a mode with an even number of
/// half-waves imaginary: i times an odd function of the direction, which in
/// time is a derivative, a dipole; the weight keeps the sign and size and
/// leaves that quarter period out, never more sound below a mode's resonance
/// than its acceleration gives).
pub fn pressure_per_acceleration(plate: &Plate, mode: &BodyMode, mic: MicPosition) -> f64 {
    let key = [
        plate.length_m,
        plate.width_m,
        mode.frequency_hz,
        f64::from(mode.m),
        f64::from(mode.n),
        mic.x_m,
        mic.y_m,
        mic.height_m,
    ];
    HEARD.get_or(key, || rayleigh_sum(plate, mode, mic)) * mode.net_volume
}

/// The board cut into cells for Rayleigh's integral over `mode` of wave
/// number `k`: fine enough for the mode's shape (four cells a half wave) and
/// for the sound's wavelength (four cells a wavelength).
struct Cells {
    dx: f64,
    dy: f64,
    ny: usize,
    /// Each column's centre across the length, and the mode's shape there.
    shape_x: Vec<(f64, f64)>,
    n: u32,
    width: f64,
}

impl Cells {
    fn new(plate: &Plate, mode: &BodyMode, k: f64) -> Self {
        let (m, n) = (mode.m, mode.n);
        let (length, width) = (plate.length_m, plate.width_m);
        let cells = |side: f64, half_waves: u32| {
            let by_shape = 4.0 * f64::from(half_waves);
            let by_sound = 4.0 * side * k / (2.0 * PI);
            (by_shape.max(by_sound).max(MIN_CELLS).ceil() as usize).min(MAX_CELLS)
        };
        let (nx, ny) = (cells(length, m), cells(width, n));
        let (dx, dy) = (length / nx as f64, width / ny as f64);
        let shape_x = (0..nx)
            .map(|i| {
                let x = (i as f64 + 0.5) * dx;
                (x, (f64::from(m) * PI * x / length).sin())
            })
            .collect();
        Self { dx, dy, ny, shape_x, n, width }
    }

    /// Each row's centre across the width, and the mode's shape there.
    fn rows(&self) -> impl Iterator<Item = (f64, f64)> + '_ {
        (0..self.ny).map(|j| {
            let y = (j as f64 + 0.5) * self.dy;
            (y, (f64::from(self.n) * PI * y / self.width).sin())
        })
    }
}

/// [`pressure_per_acceleration`], summed.
fn rayleigh_sum(plate: &Plate, mode: &BodyMode, mic: MicPosition) -> f64 {
    let k = 2.0 * PI * mode.frequency_hz / SOUND_SPEED_M_S;
    let (length, width) = (plate.length_m, plate.width_m);
    let grid = Cells::new(plate, mode, k);
    let (dx, dy, shape_x) = (grid.dx, grid.dy, &grid.shape_x);
    let mut sum = Complex64::new(0.0, 0.0);
    for (y, shape_y) in grid.rows() {
        let (ry, h2) = (y - mic.y_m, mic.height_m * mic.height_m);
        for &(x, shape) in shape_x {
            let rx = x - mic.x_m;
            let r = (rx * rx + ry * ry + h2).sqrt().max(MIN_DISTANCE_M);
            sum += Complex64::from_polar(shape * shape_y / r, -k * r);
        }
    }
    let (cx, cy) = (mic.x_m - length / 2.0, mic.y_m - width / 2.0);
    let from_middle = (cx * cx + cy * cy + mic.height_m * mic.height_m).sqrt();
    let p = sum * (AIR_DENSITY_KG_M3 / (2.0 * PI) * dx * dy) * Complex64::from_polar(1.0, k * from_middle);
    p.norm() * (p.re + p.im).signum()
}

/// What a pair of microphones hears of the body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum MicPair {
    /// Two pressure (omnidirectional) microphones apart, left then right.
    Spaced([MicPosition; 2]),
    /// Mid-side from one point (Blumlein's coincident pair): an
    /// omnidirectional capsule, the mid, and a figure-8 across it facing
    /// `left` (a unit vector in the board's plane, metres per metre along x
    /// and y), the side, at `side_gain` of the mid's sensitivity; left is mid
    /// plus side, right mid minus side. Their sum is the mid alone, so nothing
    /// comb-filters in mono.
    MidSide { at: MicPosition, left: (f64, f64), side_gain: f64 },
}

impl MicPair {
    /// Sound pressure (or the figure-8's output, in pascals of a sound from
    /// straight ahead of it) at the left and right outputs per unit modal
    /// acceleration of `mode` (see [`pressure_per_acceleration`]).
    pub fn weights(&self, plate: &Plate, mode: &BodyMode) -> [f64; 2] {
        match *self {
            MicPair::Spaced(mics) => mics.map(|mic| pressure_per_acceleration(plate, mode, mic)),
            MicPair::MidSide { at, left, side_gain } => {
                let mid = pressure_per_acceleration(plate, mode, at);
                let side = side_gain * figure_8_per_acceleration(plate, mode, at, left);
                [mid + side, mid - side]
            }
        }
    }
}

/// A figure-8 (pressure-gradient) capsule's output at `mic`, facing `toward`
/// (a unit vector in the board's plane), per unit modal acceleration of
/// `mode`, Pa s^2/m: the gradient of Rayleigh's integral along `toward`
/// divided by i k, so that a plane wave from straight ahead gives its pressure
/// and one from an angle theta off the axis cos(theta) of it, as a ribbon's or
/// a double-diaphragm capsule's output does (Olson, *Acoustical Engineering*,
/// 1957, ch. 8). Close to the board the gradient's 1 / (i k R) term is the
/// capsule's proximity effect, the bass lift every figure-8 has near its
/// source. The output is taken to the real weight by the same quarter-period
/// turn as the pressure at the same point ([`pressure_per_acceleration`]),
/// so that the side keeps its phase against the mid.
pub fn figure_8_per_acceleration(plate: &Plate, mode: &BodyMode, mic: MicPosition, toward: (f64, f64)) -> f64 {
    let key = [
        plate.length_m,
        plate.width_m,
        mode.frequency_hz,
        f64::from(mode.m),
        f64::from(mode.n),
        mic.x_m,
        mic.y_m,
        mic.height_m,
        toward.0,
        toward.1,
    ];
    FIGURE_8.get_or(key, || {
        let (p, gradient) = rayleigh_sums(plate, mode, mic, toward);
        let k = 2.0 * PI * mode.frequency_hz / SOUND_SPEED_M_S;
        let s = gradient / Complex64::new(0.0, k.max(1e-9));
        // The pressure's own turn to a real weight (its sign with it).
        let turn = if p.norm() > 0.0 { p.conj() / p.norm() * (p.re + p.im).signum() } else { Complex64::new(1.0, 0.0) };
        let turned = s * turn;
        s.norm() * if turned.re < 0.0 { -1.0 } else { 1.0 }
    }) * mode.net_volume
}

/// Rayleigh's integral at `mic` and its gradient along `toward`, both with
/// the travel time from the board's middle taken out, as [`rayleigh_sum`]
/// takes them: d/du (e^{-i k R} / R) = -(i k + 1 / R) (R_u / R) e^{-i k R} / R.
fn rayleigh_sums(plate: &Plate, mode: &BodyMode, mic: MicPosition, toward: (f64, f64)) -> (Complex64, Complex64) {
    let k = 2.0 * PI * mode.frequency_hz / SOUND_SPEED_M_S;
    let (length, width) = (plate.length_m, plate.width_m);
    let grid = Cells::new(plate, mode, k);
    let (dx, dy, shape_x) = (grid.dx, grid.dy, &grid.shape_x);
    let (mut sum, mut gradient) = (Complex64::new(0.0, 0.0), Complex64::new(0.0, 0.0));
    for (y, shape_y) in grid.rows() {
        // From the element to the microphone.
        let (ry, h2) = (mic.y_m - y, mic.height_m * mic.height_m);
        for &(x, shape) in shape_x {
            let rx = mic.x_m - x;
            let r = (rx * rx + ry * ry + h2).sqrt().max(MIN_DISTANCE_M);
            let wave = Complex64::from_polar(shape * shape_y / r, -k * r);
            sum += wave;
            let along = (rx * toward.0 + ry * toward.1) / r;
            gradient -= Complex64::new(1.0 / r, k) * along * wave;
        }
    }
    let (cx, cy) = (mic.x_m - length / 2.0, mic.y_m - width / 2.0);
    let from_middle = (cx * cx + cy * cy + mic.height_m * mic.height_m).sqrt();
    let scale = (AIR_DENSITY_KG_M3 / (2.0 * PI) * dx * dy) * Complex64::from_polar(1.0, k * from_middle);
    (sum * scale, gradient * scale)
}

/// The loss factor a plate mode adds by what it radiates from one side of its
/// baffle: eta = P / (omega E), with E = M v^2 / 2 its energy at peak velocity
/// v and P the power its far field carries through the hemisphere,
///
/// P = rho omega^2 v^2 / (8 pi^2 c) ∫ |I_m(k sin t cos f) I_n(k sin t sin f)|^2 dOmega,
///
/// so eta = rho omega / (4 pi^2 c M) ∫ |I_m I_n|^2 dOmega. A mode that keeps a
/// net volume radiates as a piston while the sound's wavelength is longer than
/// the board: the piano's (1, 1) mode at 80 Hz 0.0375, on top of the wood's
/// 0.02; the others' lobes cancel and they lose little, the (2, 1) 0.0051
/// (engine/tests/body_physics.rs). The radiation's formula hears each mode through the same
/// baffle, so a mode that rings a microphone loses the power it sends there.
/// A box's coupled top-and-air mode radiates as its net volume: times
/// `net_volume` squared.
pub fn radiation_loss_factor(plate: &Plate, mode: &BodyMode) -> f64 {
    if mode.modal_mass_kg <= 0.0 || mode.frequency_hz <= 0.0 {
        return 0.0;
    }
    let omega = 2.0 * PI * mode.frequency_hz;
    if mode.frequency_hz > INTEGRATED_BELOW_HZ {
        // Well above coincidence every mode radiates its whole area, sigma 1:
        // P = rho c S <v^2> with <v^2> = v^2 / 8 (a product of two sines).
        return AIR_DENSITY_KG_M3 * SOUND_SPEED_M_S * plate.area_m2() / (4.0 * omega * mode.modal_mass_kg)
            * mode.net_volume.powi(2);
    }
    let key =
        [plate.length_m, plate.width_m, mode.frequency_hz, mode.modal_mass_kg, f64::from(mode.m), f64::from(mode.n)];
    RADIATED.get_or(key, || {
        let k = omega / SOUND_SPEED_M_S;
        // Lobes a quarter of their width apart, at least 16 steps from the
        // pole to the horizon and as finely round it. |I(-beta)| = |I(beta)|
        // (the shapes are real), so a quarter of the way round gives the whole.
        let lobes = k * plate.length_m.max(plate.width_m) / PI + f64::from(mode.m.max(mode.n));
        let steps = ((4.0 * lobes).ceil() as usize).clamp(16, MAX_RADIATION_STEPS);
        let round = steps.div_ceil(2);
        let (dt, df) = (0.5 * PI / steps as f64, 0.5 * PI / round as f64);
        let mut integral = 0.0;
        for i in 0..steps {
            let sin_t = ((i as f64 + 0.5) * dt).sin();
            let ring: f64 = (0..round)
                .map(|j| {
                    let (sin_f, cos_f) = ((j as f64 + 0.5) * df).sin_cos();
                    (side_integral(mode.m, plate.length_m, k * sin_t * cos_f)
                        * side_integral(mode.n, plate.width_m, k * sin_t * sin_f))
                    .norm_sqr()
                })
                .sum();
            integral += 4.0 * ring * sin_t * dt * df;
        }
        AIR_DENSITY_KG_M3 * omega / (4.0 * PI * PI * SOUND_SPEED_M_S * mode.modal_mass_kg) * integral
    }) * mode.net_volume.powi(2)
}

/// Above this a mode's radiation is taken as its whole area's (sigma 1),
/// below it is integrated over the hemisphere, Hz.
pub const INTEGRATED_BELOW_HZ: f64 = 2_000.0;
/// The most steps [`radiation_loss_factor`] takes from the pole to the horizon.
const MAX_RADIATION_STEPS: usize = 48;
/// Figures already worked out, by what they were worked out from: a body is
/// built several times over (its running modes, the strings' bridge, the
/// microphones' weights) and again for every rebuild of the instrument, on
/// the builder's thread, never the audio thread's.
struct Memo<const N: usize>(Mutex<BTreeMap<[u64; N], f64>>);

impl<const N: usize> Memo<N> {
    const fn new() -> Self {
        Self(Mutex::new(BTreeMap::new()))
    }

    /// The figure for `key`, worked out by `work` the first time.
    fn get_or(&self, key: [f64; N], work: impl FnOnce() -> f64) -> f64 {
        let key = key.map(f64::to_bits);
        if let Some(&value) = self.0.lock().unwrap_or_else(|poisoned| poisoned.into_inner()).get(&key) {
            return value;
        }
        let value = work();
        let mut kept = self.0.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        if kept.len() >= MEMO_KEPT {
            kept.clear();
        }
        kept.insert(key, value);
        value
    }
}

/// Each mode's radiation loss, by board and mode.
static RADIATED: Memo<6> = Memo::new();
/// Each mode's weight at a microphone, by board, mode and microphone.
static HEARD: Memo<8> = Memo::new();
/// Each mode's weight at a figure-8, by board, mode, microphone and facing.
static FIGURE_8: Memo<10> = Memo::new();
/// The most figures a memo keeps before it starts again.
const MEMO_KEPT: usize = 20_000;

/// The grid of [`pressure_per_acceleration`]'s sum: at least this many cells
/// a side, at most this many.
const MIN_CELLS: f64 = 24.0;
const MAX_CELLS: usize = 400;
/// A microphone is taken to be at least this far from any element, m.
const MIN_DISTANCE_M: f64 = 0.05;

/// The far field's pressure per unit modal acceleration in `mic`'s direction
/// from the board's middle, `r` from it (Fraunhofer: the lobe integrals in
/// closed form), for checking the sum against.
#[cfg(test)]
fn far_field_pressure_per_acceleration(plate: &Plate, mode: &BodyMode, mic: MicPosition) -> f64 {
    let (m, n) = (mode.m, mode.n);
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

    /// A plate mode of unit modal mass and net volume, (m, n) half waves at `frequency_hz`.
    fn mode(m: u32, n: u32, frequency_hz: f64) -> BodyMode {
        BodyMode { frequency_hz, loss_factor: 0.02, modal_mass_kg: 1.0, m, n, net_volume: 1.0 }
    }

    #[test]
    fn far_away_the_sum_is_the_far_fields_and_near_it_hears_the_near_lobes() {
        let board = design(InstrumentKind::Piano);
        let plate = &board.plate;
        let (a, b) = (plate.length_m, plate.width_m);
        // 30 m off, up and to one side: within 0.3 dB of Fraunhofer's lobes.
        for (m, n, f) in [(1, 1, 80.0), (3, 1, 113.0), (2, 3, 400.0), (5, 3, 1000.0), (7, 5, 1500.0)] {
            let far = MicPosition { x_m: 0.5 * a + 12.0, y_m: 0.5 * b - 7.0, height_m: 26.0 };
            let (sum, fraunhofer) = (
                pressure_per_acceleration(plate, &mode(m, n, f), far),
                far_field_pressure_per_acceleration(plate, &mode(m, n, f), far),
            );
            let db = 20.0 * (sum / fraunhofer).abs().log10();
            assert!(db.abs() < 0.3 && sum * fraunhofer > 0.0, "({m}, {n}) at {f} Hz: {sum} against {fraunhofer}");
        }
        // 0.7 m above the middle: the piston alike, a 1.5 kHz mode far louder.
        let near = MicPosition { x_m: 0.5 * a, y_m: 0.5 * b, height_m: 0.7 };
        let gain = |m, n, f| {
            let mode = mode(m, n, f);
            20.0 * (pressure_per_acceleration(plate, &mode, near)
                / far_field_pressure_per_acceleration(plate, &mode, near))
            .abs()
            .log10()
        };
        let (piston, high) = (gain(1, 1, 80.0), gain(7, 5, 1500.0));
        assert!(piston.abs() < 2.0, "the (1, 1) piston near: {piston:.1} dB off the far field's");
        assert!(high > 10.0, "a 1.5 kHz mode near: {high:.1} dB over the far field's");
    }

    /// Far away a figure-8 hears the pressure times the cosine of the angle
    /// between its axis and the board (within 0.3 dB, the same sign), and
    /// nothing square to it; over the board's middle it hears a mode odd both
    /// ways (no gradient there) not at all.
    #[test]
    fn a_figure_8_hears_the_cosine_of_the_pressure_far_away() {
        let board = design(InstrumentKind::Piano);
        let plate = &board.plate;
        let (a, b) = (plate.length_m, plate.width_m);
        let far = MicPosition { x_m: 0.5 * a + 12.0, y_m: 0.5 * b - 7.0, height_m: 26.0 };
        let r = (12.0f64 * 12.0 + 7.0 * 7.0 + 26.0 * 26.0).sqrt();
        for (m, n, f) in [(1, 1, 80.0), (3, 1, 113.0), (2, 3, 400.0), (5, 3, 1000.0)] {
            let mode = mode(m, n, f);
            let p = pressure_per_acceleration(plate, &mode, far);
            // Facing the board along x: the board lies 12 m that way.
            let toward = figure_8_per_acceleration(plate, &mode, far, (-1.0, 0.0));
            let want = 12.0 / r * p;
            let db = 20.0 * (toward / want).abs().log10();
            assert!(db.abs() < 0.3 && toward * want > 0.0, "({m}, {n}) at {f} Hz: {toward} against {want}");
            let away = figure_8_per_acceleration(plate, &mode, far, (1.0, 0.0));
            assert!((away + toward).abs() < 1e-9 * toward.abs().max(1e-30), "({m}, {n}): facing away");
        }
        let middle = MicPosition { x_m: 0.5 * a, y_m: 0.5 * b, height_m: 0.7 };
        let piston = mode(1, 1, 80.0);
        let side = figure_8_per_acceleration(plate, &piston, middle, (1.0, 0.0));
        assert!(side.abs() < 1e-6 * pressure_per_acceleration(plate, &piston, middle).abs());
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
