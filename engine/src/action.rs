//! The action's sounds, computed from the parts that make them: the key
//! striking its bed, a damper's felt landing on its strings when the key comes
//! up, and the dampers leaving the strings together when the sustain pedal
//! goes down.
//!
//! - **Key bed.** A keyboard instrument's key stops on the felt of its bed as
//!   the hammer (or jack) leaves it: the key's momentum m v goes into the key
//!   frame in a raised-cosine pulse of [`KEY_BED_PULSE_S`], and a share of it
//!   ([`KEY_BED_TO_BOARD`]) reaches the board at the key's bridge point.
//!   A hand-held mallet has no key, and a clavichord's key stops on its
//!   tangent, in the string.
//! - **Damper landing.** The damper's head (felt and wire, [`DAMPER_MASS_KG`])
//!   falls onto the strings at a speed that follows the release velocity: its
//!   momentum goes into the strings at its place over the contact of its soft
//!   felt ([`DAMPER_CONTACT_S`]), which passes only the low partials: a thud,
//!   which the damper then stops.
//! - **Dampers lifting.** Each damper's weight ([`DAMPER_WEIGHT_N`]) holds its
//!   strings bent under it; lifted, they spring back from that bend and ring,
//!   all together when the pedal lifts every damper.
//!
//! The masses, speeds and shares are our assumptions, of the order of a grand
//! piano's parts (no measurement was at hand); each sound has a level control.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::f64::consts::PI;

use crate::string::StringModes;

/// The key's effective mass at its front, kg (a grand key with its lead weights).
pub const KEY_MASS_KG: f64 = 0.05;
/// The hammer moves this many times as fast as the key's front (the action's ratio).
pub const ACTION_RATIO: f64 = 5.0;
/// How long the key bed's felt takes to stop the key, s.
pub const KEY_BED_PULSE_S: f64 = 0.002;
/// The share of the key bed's force that reaches the board: the key frame
/// stands on the case, which carries the board at its rim.
pub const KEY_BED_TO_BOARD: f64 = 0.03;

/// A grand piano's damper head's mass (felt, wood and wire), kg: each
/// design's own is [`crate::design::DamperDesign::head_mass_kg`].
pub const DAMPER_MASS_KG: f64 = 0.015;
/// The damper's landing speed at the fastest release, m/s (it falls with the key).
pub const DAMPER_LANDING_M_S: f64 = 0.3;
/// How long a damper's soft felt takes to settle on the strings, s.
pub const DAMPER_CONTACT_S: f64 = 0.004;
/// The force a damper's weight (and spring) presses its strings with, N.
pub const DAMPER_WEIGHT_N: f64 = 0.2;
/// How long a damper's felt takes to let its strings go as the pedal lifts
/// it, s: they spring back over that time, which passes only low partials.
pub const DAMPER_LIFT_S: f64 = 0.01;

/// The spectrum of a raised-cosine (Hann) pulse of length `t_s` and unit area
/// at `f_hz`: 1 at 0 Hz, 0 at 2 / T and above it falling as f^-3.
pub fn pulse_spectrum(f_hz: f64, t_s: f64) -> f64 {
    let x = f_hz * t_s;
    if x < 1e-9 {
        return 1.0;
    }
    if (x - 1.0).abs() < 1e-6 {
        return 0.5;
    }
    ((PI * x).sin() / (PI * x * (1.0 - x * x))).abs()
}

/// The key bed's force at sample `n` after the key bottoms, for a hammer
/// speed `speed_m_s` at `sample_rate_hz`, N (on the board: the share that
/// reaches it); 0 once the pulse is over.
pub fn key_bed_force_n(n: usize, speed_m_s: f64, sample_rate_hz: f64) -> f64 {
    let t = n as f64 / sample_rate_hz;
    if !(t < KEY_BED_PULSE_S) {
        return 0.0;
    }
    key_bed_half_peak_n(speed_m_s) * raised_cosine(t)
}

/// Half the key bed's peak force on the board for a hammer speed
/// `speed_m_s`, N: a raised cosine of area m v peaks at 2 m v / T.
fn key_bed_half_peak_n(speed_m_s: f64) -> f64 {
    let momentum = KEY_MASS_KG * speed_m_s / ACTION_RATIO;
    let peak = 2.0 * momentum / KEY_BED_PULSE_S;
    KEY_BED_TO_BOARD * peak * 0.5
}

/// The key bed pulse's shape `t` seconds after the key bottoms,
/// 1 - cos(2 pi t / T): 0 to 2 and back over the pulse.
fn raised_cosine(t: f64) -> f64 {
    1.0 - (2.0 * PI * t / KEY_BED_PULSE_S).cos()
}

/// The key bed's pulse at one sample rate, its raised cosine worked out once:
/// [`key_bed_force_n`] to the bit, without a cosine a sample (a 20-key chord's
/// keys took some 2 % of its block on them).
#[derive(Clone, Debug, PartialEq)]
pub struct KeyBedPulse {
    /// 1 - cos(2 pi t / T) at each sample of the pulse.
    shape: Box<[f64]>,
}

impl KeyBedPulse {
    /// The pulse at `sample_rate_hz`. Allocates.
    pub fn new(sample_rate_hz: f64) -> Self {
        let fs = if sample_rate_hz.is_finite() && sample_rate_hz > 0.0 { sample_rate_hz } else { f64::NAN };
        let shape = (0..).map(|n| n as f64 / fs).take_while(|&t| t < KEY_BED_PULSE_S).map(raised_cosine).collect();
        Self { shape }
    }

    /// Samples the pulse lasts.
    pub fn len(&self) -> usize {
        self.shape.len()
    }

    /// Whether it lasts no sample at all.
    pub fn is_empty(&self) -> bool {
        self.shape.is_empty()
    }

    /// The pulse's force ([`key_bed_force_n`]) for a hammer speed
    /// `speed_m_s` from sample `start` on, to `out.len()`, each times `gain`
    /// added in: a struck key's stretch of it. Returns the sample after the
    /// stretch.
    pub fn add(&self, start: usize, speed_m_s: f64, gain: f64, out: &mut [f64]) -> usize {
        let height_n = key_bed_half_peak_n(speed_m_s);
        let shape = self.shape.get(start..).unwrap_or(&[]);
        for (o, &s) in out.iter_mut().zip(shape) {
            *o += gain * (height_n * s);
        }
        start + out.len()
    }
}

/// The velocity kick each of `string`'s modes takes from an impulse of
/// `impulse_n_s` at `position` (fraction of its length from the bridge)
/// spread over a soft contact of `contact_s`: mode n's velocity moves by
/// J sin(k_n x) / m_n times the pulse's spectrum at f_n, m/s, for each mode
/// in turn (`kick(i, dv)`).
pub fn kick_modes(
    string: &StringModes,
    position: f64,
    impulse_n_s: f64,
    contact_s: f64,
    mut kick: impl FnMut(usize, f64),
) {
    let modal_mass = 0.5 * string.mass_per_length_kg_m * string.length_m;
    for (i, mode) in string.modes.iter().enumerate() {
        let shape = (mode.wavenumber_rad_m * position * string.length_m).sin();
        let pass = pulse_spectrum(mode.frequency_hz(), contact_s);
        if pass < 1e-4 {
            continue;
        }
        kick(i, impulse_n_s * shape * pass / modal_mass);
    }
}

/// How each of `string`'s modes springs back when a damper's weight at
/// `position` lets it go: the bend it held (a triangle of peak W / k_x,
/// k_x = T / (x (1 - x) L) the string's stiffness there), released over
/// [`DAMPER_LIFT_S`] (each mode keeps the spectrum of that release at its
/// frequency), as the velocity kick omega_n q_n that rings the mode as far
/// (a kick, not a jump in displacement: the bridge force grows from where it
/// was, where a jump would click), m/s, for each mode in turn (`kick(i,
/// dv)`); only partials under `top_hz`.
pub fn damper_release(string: &StringModes, position: f64, top_hz: f64, mut kick: impl FnMut(usize, f64)) {
    let x = position.clamp(0.01, 0.99);
    let length = string.length_m;
    let stiffness = string.tension_n / (x * (1.0 - x) * length);
    let peak = DAMPER_WEIGHT_N / stiffness;
    for (i, mode) in string.modes.iter().enumerate() {
        if mode.frequency_hz() > top_hz {
            break;
        }
        // A triangle of peak d at x: q_n = 2 d sin(n pi x) / (n pi)^2 / (x (1 - x)).
        let n_pi = mode.number as f64 * PI;
        let release = pulse_spectrum(mode.frequency_hz(), DAMPER_LIFT_S);
        if release < 1e-4 {
            continue;
        }
        let bend_m = 2.0 * peak * release * (n_pi * x).sin() / (n_pi * n_pi * x * (1.0 - x));
        kick(i, -bend_m * mode.omega_rad_s);
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pulse_passes_low_frequencies_and_stops_at_twice_its_rate() {
        assert!((pulse_spectrum(0.0, 0.004) - 1.0).abs() < 1e-12);
        assert!(pulse_spectrum(500.0, 0.004) < 1e-6);
        assert!(pulse_spectrum(100.0, 0.004) > 0.8);
    }

    #[test]
    fn the_worked_out_pulse_is_the_formula_to_the_bit() {
        for fs in [44_100.0, 48_000.0, 96_000.0, 192_000.0, 8_000.0] {
            let pulse = KeyBedPulse::new(fs);
            assert_eq!(pulse.len(), (0..).take_while(|&n| (n as f64 / fs) < KEY_BED_PULSE_S).count());
            for speed in [0.1, 1.0, 3.0, 7.0] {
                let mut table = vec![0.0; pulse.len() + 10];
                assert_eq!(pulse.add(0, speed, 1.0, &mut table), table.len());
                for (n, table) in table.into_iter().enumerate() {
                    let formula = key_bed_force_n(n, speed, fs);
                    assert_eq!(table.to_bits(), formula.to_bits(), "fs {fs}, speed {speed}, sample {n}");
                }
            }
        }
        // A key's stretches of it, added in at a gain: the formula's sum, to the bit.
        let pulse = KeyBedPulse::new(48_000.0);
        for (start, len) in [(0, 64), (0, 23), (23, 64), (87, 64), (95, 1), (96, 8), (200, 4)] {
            let (gain, speed) = (0.37, 2.5);
            let mut out: Vec<f64> = (0..len).map(|t| 1e-3 * t as f64).collect();
            let mut expected = out.clone();
            assert_eq!(pulse.add(start, speed, gain, &mut out), start + len);
            for (t, e) in expected.iter_mut().enumerate() {
                if start + t < pulse.len() {
                    *e += gain * key_bed_force_n(start + t, speed, 48_000.0);
                }
            }
            assert!(out.iter().zip(&expected).all(|(a, b)| a.to_bits() == b.to_bits()), "from {start}, {len}");
        }
        assert!(KeyBedPulse::new(f64::INFINITY).is_empty());
        assert!(KeyBedPulse::new(f64::NAN).is_empty());
        assert!(KeyBedPulse::new(0.0).is_empty());
    }

    #[test]
    fn the_key_bed_pulse_carries_the_keys_momentum_into_the_board() {
        let fs = 48_000.0;
        let speed = 3.0;
        let area: f64 = (0..200).map(|n| key_bed_force_n(n, speed, fs)).sum::<f64>() / fs;
        let expected = KEY_BED_TO_BOARD * KEY_MASS_KG * speed / ACTION_RATIO;
        assert!((area / expected - 1.0).abs() < 1e-3, "{area} against {expected}");
    }
}
