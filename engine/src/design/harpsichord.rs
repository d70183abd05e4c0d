//! The harpsichord, for comparison: a single 8' register of brass strings after
//! the anonymous Italian single-manual of Naples, c. 1620 (Russell Collection,
//! University of Edinburgh), plucked as Woodhouse's "wire-break" pluck.
//!
//! The table gives string length and plucking point for c, f and a few other
//! notes. Its unnamed rows are placed by their lengths (201 mm is f'', 385.5 mm f',
//! 129 mm c''': each half the length an octave below, the Italian Pythagorean
//! scaling), so the top note (113 mm) is d''' and the compass C2-D6 chromatic; the
//! table's lowest row (a D below C, 1529 mm) belongs to a short-octave key and is
//! left out. Length and plucking point are interpolated log-linearly between rows.
//!
//! The plucking point is measured from the nut. The pluck's modal amplitudes go as
//! |sin(n pi p)|, the same for p and 1 - p, so the position handed on is the
//! distance to the nearer end (the table's top notes are plucked just past the
//! middle). Woodhouse plucks at 1/7.8 of the length, "a typical harpsichord
//! position"; the Naples instrument's own points are kept instead, from 1/10.5 of
//! the length at C2 through 1/4.6 at c' to nearly the middle at the top (a fixed
//! 1/7.8 would pluck d''' 14 mm from the nut, where the table has 63.5 mm).
//! The comparison with the clavichord (`engine/tests/seed_clavichord.rs`) plucks at
//! exactly 1/7.8.
//!
//! Gauges are the old Nuernberg sizes (#10 0.20 mm to #1 0.52 mm): the one nearest
//! to a diameter falling log-linearly from 0.52 mm at C2 to 0.20 mm at D6, which
//! gives 0.40 mm at c, 0.33 mm at c' and 0.27 mm at c''. The working stress,
//! rho (2 L f)^2, is 320 MPa at C2 and 600-670 MPa from c upward.
//!
//! Of the voicing `strike_position` (the plucking point) and `damping` apply; a
//! single string has no unison, and a plectrum no mass or felt.

use std::ops::RangeInclusive;

use super::common::{
    BRASS_DENSITY_KG_M3, BRASS_MODULUS_PA, Level, Losses, Table, damper, flexible_tension_n, pan, voiced_position,
    wire_mass_per_length_kg_m, with_losses,
};
use super::{DamperDesign, ExciterDesign, KeyDesign, TouchRange, Voicing, key_frequency_hz};
use crate::string::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

pub(super) const KEYS: RangeInclusive<u8> = 36..=86;

/// Pluck height in mm (not a speed): 2 mm at the strongest touch, the plectrum
/// displacement of Woodhouse's comparison with the clavichord (the same as the
/// tangent's), and 1.3 mm at the softest. A plectrum lets go of the string at
/// much the same height however fast the key goes down, so the touch spans only
/// 3.7 dB.
pub(super) const TOUCH: TouchRange = TouchRange::PluckHeight { min_mm: 1.3, max_mm: TOP_LIFT_MM };
/// The hardest touch: the plectrum's highest lift, mm.
const TOP_LIFT_MM: f64 = 2.0;

/// String length, m, and plucking point from the nut, m (the Naples instrument).
const LENGTH_M: Table = Table(&[
    (36, 1.480),
    (38, 1.431),
    (41, 1.412),
    (48, 1.0105),
    (53, 0.768),
    (60, 0.5175),
    (65, 0.3855),
    (72, 0.2655),
    (77, 0.201),
    (84, 0.129),
    (86, 0.113),
]);
const PLUCK_POINT_M: Table = Table(&[
    (36, 0.1415),
    (38, 0.1405),
    (41, 0.136),
    (48, 0.129),
    (53, 0.1215),
    (60, 0.112),
    (65, 0.103),
    (72, 0.090),
    (77, 0.080),
    (84, 0.067),
    (86, 0.0635),
]);

/// Old Nuernberg wire gauges, m.
const GAUGES_M: [f64; 10] = [0.20e-3, 0.23e-3, 0.25e-3, 0.27e-3, 0.30e-3, 0.33e-3, 0.36e-3, 0.40e-3, 0.46e-3, 0.52e-3];
/// The diameter the gauges are picked to follow, m.
const TARGET_DIAMETER_M: Table = Table(&[(36, 0.52e-3), (86, 0.20e-3)]);

/// Brass's internal friction (5e-4, assumed as for the clavichord) and a light,
/// lively soundboard, Re Y = 5e-3 s/kg: the D2 string's fundamental gets Q near
/// 620 (three quarters of its loss going into the bridge, the rest to air), a
/// 60 dB decay of about 18 s, and c''' about 4 s.
pub(super) const LOSSES: Losses =
    Losses { internal_loss_factor: 5.0e-4, bridge_admittance_s_kg: 5.0e-3, tangent: None };

/// Output level (see [`Level`]). The ringing at the level touch (velocity 0.7) is aimed at -24 dBFS.
///
/// Relative to the peak, the ringing rises from -14.7 dB at C2 to -9.2 dB at c''
/// and eases to -10.1 dB at d''' (within 0.2 dB of every key); the peak runs up to
/// 1 dB over the estimate at the top. The highest pluck peaks at -13 to -6.5 dBFS:
/// the cap never applies.
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -24.0,
    ring_db: Table(&[(36, -14.7), (41, -14.5), (48, -13.0), (60, -10.5), (72, -9.2), (80, -9.3), (86, -10.1)]),
    peak_excess_db: Table(&[(36, 0.2), (60, 0.3), (86, 1.1)]),
};

/// Wire diameter, m.
fn gauge_m(midi_key: u8) -> f64 {
    let target = TARGET_DIAMETER_M.log(midi_key);
    GAUGES_M.into_iter().min_by(|a, b| (a / target).ln().abs().total_cmp(&(b / target).ln().abs())).unwrap_or(target)
}

/// Plucking point as a fraction of the length from the nearer end.
fn pluck_position(midi_key: u8) -> f64 {
    let p = PLUCK_POINT_M.log(midi_key) / LENGTH_M.log(midi_key);
    p.min(1.0 - p)
}

pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let length_m = LENGTH_M.log(midi_key);
    let diameter_m = gauge_m(midi_key);
    let spec = StringSpec {
        length_m,
        tuning: Tuning::FirstPartialHz(key_frequency_hz(midi_key)),
        mass: Mass::SolidWire { diameter_m, density_kg_m3: BRASS_DENSITY_KG_M3 },
        stiffness: Stiffness::YoungsModulus { modulus_pa: BRASS_MODULUS_PA, bending_diameter_m: diameter_m },
        damping: Damping::UniformQ(1.0), // replaced by with_losses
        max_frequency_hz,
        outer_diameter_m: None,
    };
    let f1_hz = key_frequency_hz(midi_key);
    let tension_n = flexible_tension_n(length_m, wire_mass_per_length_kg_m(diameter_m, BRASS_DENSITY_KG_M3), f1_hz);
    let position = pluck_position(midi_key);
    // Released, the bridge force alternates between the tension times the slopes
    // either side of the plucking point, T h / (p L) and -T h / ((1 - p) L). As
    // stiffness dephases the partials, its peak over the first tenth of a second
    // comes to 1.3 times the two added in quadrature (fitted: within 0.5 dB on
    // every key).
    let height_m = TOP_LIFT_MM * 1e-3;
    let peak_n = 1.3 * tension_n * height_m / length_m * (position.powi(-2) + (1.0 - position).powi(-2)).sqrt();
    KeyDesign {
        midi_key,
        strings: vec![with_losses(spec, &LOSSES, voicing.damping)],
        exciter: ExciterDesign::Pluck { position: voiced_position(position, voicing) },
        struck: 0..1,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        resistive_bridge: LOSSES.resistive_bridge(voicing),
        losses: LOSSES,
        // The jack's cloth damper: 60 dB in 0.2 s.
        // A jack's cloth flag settles on the string as the jack falls onto
        // its key: only the cloth's own gram or so lands on the string.
        damper: Some(DamperDesign { head_mass_kg: 1.0e-3, ..damper(0.2, 5.0e-3, f1_hz, 0.01) }),
        gain_per_n: LEVEL.gain_per_n(midi_key, peak_n, pan(midi_key, KEYS)),
        ring_gain_per_n: LEVEL.ring_gain_per_n(midi_key, peak_n),
        pan: pan(midi_key, KEYS),
        hammer_hysteresis: None,
        strike_shares: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn strings_follow_the_naples_table() {
        for (key, length_m, pluck_m) in [(36, 1.480, 0.1415), (60, 0.5175, 0.112), (72, 0.2655, 0.090)] {
            let d = design(&Voicing::default(), key, 20_000.0);
            assert_eq!(d.strings.len(), 1);
            assert!((d.strings[0].length_m - length_m).abs() < 1e-12);
            let ExciterDesign::Pluck { position } = d.exciter else { panic!("not a pluck") };
            assert!((position - pluck_m / length_m).abs() < 1e-12);
        }
        // d''' is plucked 63.5 mm from the nut, 49.5 mm from the bridge.
        let ExciterDesign::Pluck { position } = design(&Voicing::default(), 86, 20_000.0).exciter else {
            panic!("not a pluck")
        };
        assert!((position - 0.0495 / 0.113).abs() < 1e-12);
    }

    #[test]
    fn gauges_are_nuernberg_sizes() {
        assert_eq!(gauge_m(36), 0.52e-3);
        assert_eq!(gauge_m(48), 0.40e-3);
        assert_eq!(gauge_m(60), 0.33e-3);
        assert_eq!(gauge_m(72), 0.27e-3);
        assert_eq!(gauge_m(86), 0.20e-3);
        for key in KEYS.skip(1) {
            assert!(gauge_m(key) <= gauge_m(key - 1));
        }
    }

    #[test]
    fn strike_position_voicing_moves_the_pluck() {
        let voicing = Voicing { strike_position: 0.5, ..Voicing::default() };
        let (ExciterDesign::Pluck { position: p0 }, ExciterDesign::Pluck { position: p1 }) =
            (design(&Voicing::default(), 48, 20_000.0).exciter, design(&voicing, 48, 20_000.0).exciter)
        else {
            panic!("not a pluck")
        };
        assert!((p1 / p0 - 0.5).abs() < 1e-12);
    }
}
