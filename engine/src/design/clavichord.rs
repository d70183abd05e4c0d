//! The clavichord: a Hubert-type instrument, C2-E6, double-strung in brass, its
//! strings struck and held by brass tangents (Euphonics 12.2.3; physics
//! reference 1.6, 1.7 and 4).
//!
//! Compass: the Way & Ducornet copy of a Hubert that Fletcher & Beebe describe
//! starts at C2; the 2001 Hubert stringing schedule runs to e''' (its BB, a
//! short-octave string, is left out), so C2-E6 chromatic.
//!
//! Strings (brass, rho = 8500 kg/m^3, E = 1.0e11 Pa), gauges from that schedule:
//! red brass 0.65 mm at C2 and 0.56 mm at C#2-D2, then yellow brass 0.52, 0.44,
//! 0.40, 0.36, 0.30 and 0.27 mm in steps of about half an octave (the schedule
//! names the gauges but not where each one starts), and 0.25 mm from c#'' to e'''.
//! Speaking lengths (tangent to bridge): c'' = 270 mm halving every octave above
//! (a brass c'' scaling, 680 MPa), foreshortened below through c' = 0.50 m,
//! c = 0.70 m and C = 0.82 m, which puts D2 at 0.80 m as in the lab's K2 case.
//!
//! The non-speaking length L1, from the tangent through the listing cloth to the
//! hitch pin, is derived, not measured: the strings of a fretted Hubert run the
//! width of the case, from hitch pins at its left end to the bridge near its right
//! end, so their complete length (hitch pin to bridge) varies far less than the
//! speaking length. Fletcher & Beebe give up to about 1.3 m for the Way & Ducornet
//! copy; 1.2 m is taken for every key, so L1 = 1.2 m - L2 runs from 0.38 m at C2 to
//! 1.09 m at E6. Pressing the tangent in by W stretches both lengths (see
//! [`crate::exciter::tangent`]): 4.6 cents at 2 mm on D2, the seed's "about 5 cents near
//! 2 mm" (its Fig. 29). As the working stress rises, from 117 MPa at D2 to
//! 580 MPa at c', the rise at 2 mm falls to 0.85 cents there, then climbs again to
//! 2.2 cents at E6 as the speaking length shortens.
//!
//! The tangent comes to rest 2 mm into the D2 string (Thwaites & Fletcher via
//! Woodhouse). The short treble strings are stiffer to push, T (1 / L1 + 1 / L2)
//! rising from about 220 N/m for the D2 pair to 680 N/m at E6, so the same finger
//! sinks their tangent less far: the depth falls as 2 mm x sqrt(L2 / 0.8 m), but
//! to no less than 1 mm (between equal depth and equal force, which would give
//! 0.6 mm at E6). The voicing's `tangent_depth` scales it.
//!
//! Of the voicing `damping`, `unison_detune` and `tangent_depth` apply: a tangent
//! has no mass, felt or position to voice (it always becomes the string's end).

use std::ops::RangeInclusive;

use super::common::{
    BRASS_DENSITY_KG_M3, BRASS_MODULUS_PA, Level, Losses, Table, TangentLeak, damper, detuned_hz, flexible_tension_n,
    pan, unison_cents, wire_mass_per_length_kg_m, with_losses,
};
use super::{ExciterDesign, KeyDesign, SharedKey, TouchRange, VelocityCurve, Voicing, key_frequency_hz};
use crate::exciter::tangent;
use crate::string::damping::Damping;
use crate::string::{Mass, Stiffness, StringSpec, Tuning};

pub(super) const KEYS: RangeInclusive<u8> = 36..=88;

/// Tangent speeds from the softest to the strongest touch, m/s: the extremes that
/// Woodhouse draws in Fig. 30 after Thwaites & Fletcher (0.5 m/s being his
/// typical stroke). His text gives their time-scales rather than their speeds: the
/// slowest tangent is "still not complete after 50 ms" (about 3 periods of D2),
/// the fastest "more or less complete in 5 ms". The tangent closes on its 2 mm as
/// 1 - exp(-t V0 / D), so 0.1 m/s (the quiet note of the comparison in
/// `engine/tests/seed_clavichord.rs`) is 92 % of the way after 50 ms, and 1 m/s
/// is as far after 5 ms.
pub(super) const TOUCH: TouchRange =
    TouchRange::Speed { min_m_s: 0.1, max_m_s: TOP_SPEED_M_S, curve: VelocityCurve::LogPower(1.0) };
/// The hardest touch: the fastest the exciter meets the string, m/s.
const TOP_SPEED_M_S: f64 = 1.0;

const STRINGS: usize = 2;

/// Speaking length, m.
const LENGTH_M: Table = Table(&[(36, 0.82), (48, 0.70), (60, 0.50), (72, 0.27), (88, 0.107_16)]);

/// Hitch pin to bridge, m, the same for every key (derived; see the module doc).
const COMPLETE_LENGTH_M: f64 = 1.2;

/// Final tangent displacement on a 0.8 m string, m, and its bounds.
const TANGENT_DISPLACEMENT_M: f64 = 2.0e-3;
const MIN_TANGENT_DISPLACEMENT_M: f64 = 1.0e-3;
/// The range the voicing's `tangent_depth` is held to.
const TANGENT_DEPTH_RANGE: (f64, f64) = (0.25, 2.0);

/// Brass is lossier than steel inside (eta_E 5e-4, an assumption: no figure was
/// found); the small soundboard is a lively bridge, Re Y = 5e-3 s/kg: the
/// harpsichord's losses. On top of those, the tangent, key and finger seen by
/// each string, 40 g on 70 N s/m (80 g and 140 N s/m for the pair; Woodhouse's
/// own values could not be read), let waves leak into the felted part. On the D2
/// string the fundamental's Q falls from 865 to 310 (the K2 case starts at 300)
/// and the 3rd partial's to half, while from 1 kHz up, where the mass reflects,
/// every Q stays within 7 % of the harpsichord-style one: the pattern of
/// Euphonics Fig. 31.
const LOSSES: Losses = Losses {
    internal_loss_factor: 5.0e-4,
    bridge_admittance_s_kg: 5.0e-3,
    tangent: Some(TangentLeak { mass_kg: 0.04, resistance_ns_m: 70.0 }),
};

/// Widest detuning of the pair, cents.
const UNISON_SPREAD_CENTS: f64 = 1.0;

/// When the key comes up the tangent leaves the strings and the listing cloth
/// damps the whole length, hitch pin to bridge. Taken to take 20 dB from a wave
/// each time it goes through the cloth and back (an assumption: no measurement
/// was found), 60 dB in three round trips of the complete length: 67 ms at C2,
/// 61 ms at D2, 27 ms at c', 25 ms at E6, "within a few tens of ms".
const DAMPING_ROUND_TRIPS: f64 = 3.0;
/// Higher partials die faster under the cloth, 1/s per Hz.
const DAMPER_RATE_PER_HZ_S: f64 = 1.0e-2;
/// The cloth acts as soon as the tangent has left (the synth lifts it in 2 ms), s.
const DAMPER_TRAVEL_S: f64 = 0.002;

/// Output level (see [`Level`]). The clavichord is the quietest of the four: its
/// ringing at the level touch (velocity 0.7) is aimed at -30 dBFS, 2 to 6 dB under the others'.
///
/// Relative to the peak, the ringing lies near -18 dB from C2 to A2 and falls to
/// -25.9 dB at E6 (within 0.3 dB of every key); the peak runs 0.1 dB (bass) to
/// 2 dB (treble) under the estimate. The loudest touch peaks at -11.7 to
/// -3.9 dBFS: the cap never applies.
pub(super) const LEVEL: Level = Level {
    ring_target_dbfs: -30.0,
    ring_db: Table(&[(36, -18.0), (45, -17.8), (60, -19.5), (72, -21.0), (81, -23.1), (88, -25.9)]),
    peak_excess_db: Table(&[(36, -0.1), (44, -0.5), (62, -1.5), (78, -1.95), (88, -1.9)]),
};

/// The gauges, mm, each with the last key it is strung on.
const GAUGES: [(u8, f64); 9] =
    [(36, 0.65), (38, 0.56), (44, 0.52), (50, 0.44), (56, 0.40), (62, 0.36), (68, 0.30), (72, 0.27), (88, 0.25)];

/// Wire diameter, m.
fn gauge_m(midi_key: u8) -> f64 {
    let (_, mm) = GAUGES.into_iter().find(|&(last, _)| midi_key <= last).unwrap_or(GAUGES[GAUGES.len() - 1]);
    mm * 1e-3
}

/// The tangent's rise in tension per square metre of its displacement, 1/m^2
/// ([`tangent::stretch_per_m2`] with the key's brass wire, its tension at pitch,
/// and its speaking and damped lengths).
fn stretch_per_m2(midi_key: u8) -> f64 {
    let length_m = LENGTH_M.log_extended(midi_key);
    let diameter_m = gauge_m(midi_key);
    let mu = wire_mass_per_length_kg_m(diameter_m, BRASS_DENSITY_KG_M3);
    let tension_n = flexible_tension_n(length_m, mu, key_frequency_hz(midi_key));
    let area_m2 = mu / BRASS_DENSITY_KG_M3;
    tangent::stretch_per_m2(BRASS_MODULUS_PA, area_m2, tension_n, length_m, COMPLETE_LENGTH_M - length_m)
}

/// How many cents sharp `midi_key` sounds with its tangent holding the strings
/// `displacement_m` in: 1200 log2 sqrt(1 + s W^2) ([`ExciterDesign::Tangent`]'s
/// `stretch_per_m2` is that s).
pub(super) fn pitch_rise_cents(midi_key: u8, displacement_m: f64) -> f64 {
    1200.0 * tangent::stretched_pitch_ratio(stretch_per_m2(midi_key), displacement_m).log2()
}

/// Where the key's tangent comes to rest, m, before the voicing: 2 mm at D2.
fn built_displacement_m(length_m: f64) -> f64 {
    (TANGENT_DISPLACEMENT_M * (length_m / 0.8).sqrt()).clamp(MIN_TANGENT_DISPLACEMENT_M, TANGENT_DISPLACEMENT_M)
}

/// The last key of the unfretted bass: C2-F#2 have strings of their own on the
/// fretted instrument (as on the Way & Ducornet Hubert copy, Fletcher & Beebe).
const LAST_FREE_BASS_KEY: u8 = 42;

/// On the fretted instrument ("double-fretted", the common 18th-century
/// arrangement): whether `midi_key` shares its strings with the key a semitone
/// above (and plays them from the longer end). D and A keep strings of their own;
/// the other naturals pair with the semitone above: C-C#, D#-E, F-F#, G-G#, A#-B.
fn fretted_below_partner(midi_key: u8) -> bool {
    midi_key > LAST_FREE_BASS_KEY && matches!(midi_key % 12, 0 | 3 | 5 | 7 | 10) && midi_key < *KEYS.end()
}

/// The design of `midi_key`; None when, fretted, it plays the strings of the key
/// below it (listed there as a [`SharedKey`]).
pub(super) fn design(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> Option<KeyDesign> {
    if !voicing.fretted {
        return Some(course(voicing, midi_key, max_frequency_hz));
    }
    if midi_key > *KEYS.start() && fretted_below_partner(midi_key - 1) {
        return None;
    }
    let mut design = course(voicing, midi_key, max_frequency_hz);
    if fretted_below_partner(midi_key) {
        // The upper key's tangent meets the same strings nearer the bridge: a
        // semitone higher, pressed and stretched as that key's own would be.
        let upper = midi_key + 1;
        let (d_low, s_low) = tangent_of(voicing, midi_key);
        let (d_up, s_up) = tangent_of(voicing, upper);
        // The strings are tuned for the lower tangent pressed, and the upper tangent
        // stands where its own press brings it to its semitone: over the strings
        // at rest its interval is the semitone times the lower press's rise, less
        // its own (which the synth adds as it presses).
        let interval = key_frequency_hz(upper) / key_frequency_hz(midi_key);
        let (pressed_low, pressed_up) =
            (tangent::stretched_pitch_ratio(s_low, d_low), tangent::stretched_pitch_ratio(s_up, d_up));
        design.shared.push(SharedKey {
            midi_key: upper,
            struck: design.struck.clone(),
            exciter: ExciterDesign::Tangent {
                displacement_m: d_up,
                stretch_per_m2: s_up,
                return_s: return_s(LENGTH_M.log_extended(upper), STRINGS, tension_of(midi_key)),
            },
            pitch_ratio: interval * pressed_low / pressed_up,
        });
    }
    Some(design)
}

/// The tension of each of `midi_key`'s strings, N (flexible, tuned to its key).
fn tension_of(midi_key: u8) -> f64 {
    let length_m = LENGTH_M.log_extended(midi_key);
    flexible_tension_n(
        length_m,
        wire_mass_per_length_kg_m(gauge_m(midi_key), BRASS_DENSITY_KG_M3),
        key_frequency_hz(midi_key),
    )
}

/// How fast a tangent let go falls back from its strings, s: the time constant
/// sqrt(M / k) of the tangent and key (the leak's mass M, [`LOSSES`]) on the
/// spring of `strings` strings of tension `tension_n` held aside at the end of
/// a speaking length `length_m`, k = N T (1 / L + 1 / (L_whole - L)) (both
/// sides of the tangent pulled straight; every speaking length, 0.82 m at
/// most, lies well inside the whole 1.2 m). About 10 ms at C4: a key let go
/// at once still leaves its strings over some milliseconds, and the bridge's
/// static load comes off as smoothly.
fn return_s(length_m: f64, strings: usize, tension_n: f64) -> f64 {
    let mass_kg = LOSSES.tangent.map_or(0.0, |t| t.mass_kg);
    let listed_m = COMPLETE_LENGTH_M - length_m;
    let stiffness_n_m = strings as f64 * tension_n * (1.0 / length_m + 1.0 / listed_m);
    (mass_kg / stiffness_n_m).sqrt()
}

/// The tangent of `midi_key` with the voicing's depth: where it comes to rest, m,
/// and the stretch it makes, per m^2 ([`ExciterDesign::Tangent`]).
fn tangent_of(voicing: &Voicing, midi_key: u8) -> (f64, f64) {
    let depth = voicing.tangent_depth.clamp(TANGENT_DEPTH_RANGE.0, TANGENT_DEPTH_RANGE.1);
    (built_displacement_m(LENGTH_M.log_extended(midi_key)) * depth, stretch_per_m2(midi_key))
}

/// One key with its own pair of strings. The strings are tuned, as a clavichord
/// is, with the key down: at rest they sit flat by the rise of the as-built press.
fn course(voicing: &Voicing, midi_key: u8, max_frequency_hz: f64) -> KeyDesign {
    let length_m = LENGTH_M.log_extended(midi_key);
    let diameter_m = gauge_m(midi_key);
    let pressed = tangent::stretched_pitch_ratio(stretch_per_m2(midi_key), built_displacement_m(length_m));
    let specs = unison_cents(midi_key, STRINGS, UNISON_SPREAD_CENTS, voicing)
        .into_iter()
        .map(|cents| {
            let spec = StringSpec {
                length_m,
                tuning: Tuning::FirstPartialHz(detuned_hz(midi_key, cents) / pressed),
                mass: Mass::SolidWire { diameter_m, density_kg_m3: BRASS_DENSITY_KG_M3 },
                stiffness: Stiffness::YoungsModulus { modulus_pa: BRASS_MODULUS_PA, bending_diameter_m: diameter_m },
                damping: Damping::UniformQ(1.0), // replaced by with_losses
                max_frequency_hz,
                outer_diameter_m: None,
            };
            with_losses(spec, &LOSSES, voicing.damping)
        })
        .collect();

    let built_m = built_displacement_m(length_m);
    let (displacement_m, stretch) = tangent_of(voicing, midi_key);
    let f1_hz = key_frequency_hz(midi_key);
    let mu = wire_mass_per_length_kg_m(diameter_m, BRASS_DENSITY_KG_M3);
    let tension_n = tension_of(midi_key);
    // The tangent's step to V0 reaches the bridge as a wave of force Z0 V0, doubled
    // by the reflection there, and the string's final tilt adds T D / L. The
    // tangent's quick deceleration and the string's dispersion smear that step:
    // the peak comes out at 0.72 of the sum on every key (fitted). The gain
    // follows the instrument as built, not the voiced depth.
    let peak_per_string_n = 0.72 * (2.0 * (tension_n * mu).sqrt() * TOP_SPEED_M_S + tension_n * built_m / length_m);
    // Three round trips of a wave over the whole length, hitch pin to bridge.
    let wave_speed_m_s = 2.0 * length_m * f1_hz;
    let damped_60_db_s = DAMPING_ROUND_TRIPS * 2.0 * COMPLETE_LENGTH_M / wave_speed_m_s;
    KeyDesign {
        midi_key,
        strings: specs,
        struck: 0..STRINGS,
        shared: Vec::new(),
        bridge_coupling_s_kg: 0.0,
        resistive_bridge: LOSSES.resistive_bridge(voicing),
        losses: LOSSES,
        exciter: ExciterDesign::Tangent {
            displacement_m,
            stretch_per_m2: stretch,
            return_s: return_s(length_m, STRINGS, tension_n),
        },
        damper: Some(damper(damped_60_db_s, DAMPER_RATE_PER_HZ_S, f1_hz, DAMPER_TRAVEL_S)),
        gain_per_n: LEVEL.gain_per_n(midi_key, STRINGS as f64 * peak_per_string_n, pan(midi_key, KEYS)),
        ring_gain_per_n: LEVEL.ring_gain_per_n(midi_key, STRINGS as f64 * peak_per_string_n),
        pan: pan(midi_key, KEYS),
        hammer_hysteresis: None,
        strike_shares: Vec::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::super::common::DECAY_60_DB;
    use super::super::harpsichord;
    use super::*;

    #[test]
    fn fretted_keys_share_strings_and_d_and_a_keep_their_own() {
        let fretted = Voicing { fretted: true, ..Voicing::default() };
        let homes: Vec<u8> = KEYS.filter(|&k| design(&fretted, k, 20_000.0).is_some()).collect();
        // The bass C2-F#2 and every D and A have their own strings.
        for key in (36..=42).chain(KEYS.filter(|k| matches!(k % 12, 2 | 9))) {
            assert!(homes.contains(&key), "key {key} lost its strings");
        }
        // C-C#, D#-E, F-F#, G-G#, A#-B share above the bass.
        for (low, high) in [(43, 44), (46, 47), (48, 49), (51, 52), (53, 54), (84, 85), (87, 88)] {
            let d = design(&fretted, low, 20_000.0).unwrap();
            assert!(design(&fretted, high, 20_000.0).is_none(), "{high} should be fretted to {low}");
            assert_eq!(d.shared.len(), 1);
            let upper = &d.shared[0];
            assert_eq!((upper.midi_key, upper.struck.clone()), (high, d.struck.clone()));
            // Pressed, each tangent sounds its own key: the semitone over the strings at
            // rest is the lower press's rise more, the upper press's less.
            let (
                ExciterDesign::Tangent { displacement_m: d0, stretch_per_m2: s0, .. },
                ExciterDesign::Tangent { displacement_m: d1, stretch_per_m2: s1, .. },
            ) = (d.exciter, upper.exciter)
            else {
                panic!("not tangents")
            };
            let sounding =
                upper.pitch_ratio * tangent::stretched_pitch_ratio(s1, d1) / tangent::stretched_pitch_ratio(s0, d0);
            assert!((1200.0 * sounding.log2() - 100.0).abs() < 1e-9, "{low}: {sounding}");
        }
        // 53 keys on 34 courses: 19 pairs share.
        assert_eq!(homes.len(), 34, "{homes:?}");
        // Unfretted, every key is its own course.
        assert!(KEYS.clone().all(|k| design(&Voicing::default(), k, 20_000.0).is_some_and(|d| d.shared.is_empty())));
    }

    fn tangent(d: &KeyDesign) -> (f64, f64) {
        let ExciterDesign::Tangent { displacement_m, stretch_per_m2, .. } = d.exciter else { panic!("not a tangent") };
        (displacement_m, stretch_per_m2)
    }

    #[test]
    fn a_tangent_let_go_falls_back_in_milliseconds_faster_where_the_strings_are_short() {
        let back = |d: &ExciterDesign| match *d {
            ExciterDesign::Tangent { return_s, .. } => return_s,
            _ => panic!("not a tangent"),
        };
        let at = |key: u8| back(&course(&Voicing::default(), key, 20_000.0).exciter);
        // C4: two 0.5 m strings of about 56 N held aside, 0.7 m of felted length
        // beyond: k = 2 T (1/0.5 + 1/0.7), under 40 g.
        let c4 = at(60);
        let k = 2.0 * tension_of(60) * (1.0 / 0.5 + 1.0 / 0.7);
        assert!((c4 - (0.04 / k).sqrt()).abs() < 1e-12 && (0.005..0.02).contains(&c4), "{c4}");
        assert!(at(84) < c4 && at(38) > 0.001, "{} {}", at(84), at(38));
        // A fretted pair's upper tangent meets the strings nearer the bridge.
        let fretted = Voicing { fretted: true, ..Voicing::default() };
        let d = design(&fretted, 60, 20_000.0).unwrap();
        assert!(back(&d.shared[0].exciter) < back(&d.exciter));
    }

    #[test]
    fn d2_is_the_k2_string_with_a_low_q_fundamental() {
        let d = course(&Voicing::default(), 38, 20_000.0);
        assert_eq!(d.strings.len(), 2);
        let s = d.strings[0].build().unwrap();
        assert!((s.length_m - 0.8).abs() < 0.01);
        // K2 starts at Q = 300.
        assert!((250.0..400.0).contains(&s.modes[0].q), "{}", s.modes[0].q);
        // The leak fades with frequency: partials above 500 Hz are many times less damped.
        let high = s.modes.iter().find(|m| m.frequency_hz() > 500.0).unwrap();
        assert!(high.q > 8.0 * s.modes[0].q, "{}", high.q);
        assert!((tangent(&d).0 - 2.0e-3).abs() < 0.02e-3);
    }

    /// Euphonics Fig. 31: the same string with and without the leak past the tangent.
    #[test]
    fn the_leak_damps_the_lowest_partials_and_spares_those_above_1_khz() {
        // The harpsichord's damping is the clavichord's without the tangent.
        assert_eq!(Losses { tangent: None, ..LOSSES }, harpsichord::LOSSES);
        for key in [36, 38, 43] {
            let spec = course(&Voicing::default(), key, 20_000.0).strings[0].clone();
            let leaky = with_losses(spec.clone(), &LOSSES, 1.0).build().unwrap();
            let plain = with_losses(spec, &harpsichord::LOSSES, 1.0).build().unwrap();
            for (a, b) in leaky.modes.iter().zip(&plain.modes) {
                let ratio = a.q / b.q;
                let f = a.frequency_hz();
                if a.number <= 3 {
                    assert!(ratio <= 0.7, "key {key} partial {} at {f:.0} Hz: Q ratio {ratio:.3}", a.number);
                }
                if f > 1000.0 {
                    assert!(ratio >= 0.9, "key {key} partial {} at {f:.0} Hz: Q ratio {ratio:.3}", a.number);
                }
                assert!(ratio <= 1.0 && ratio > 0.0);
            }
        }
    }

    #[test]
    fn brass_is_not_overstressed_and_the_felt_damps_within_tens_of_ms() {
        for key in KEYS {
            let d = course(&Voicing::default(), key, 20_000.0);
            let s = d.strings[0].build().unwrap();
            let stress_pa = s.tension_n / (std::f64::consts::PI * gauge_m(key).powi(2) / 4.0);
            assert!((50e6..720e6).contains(&stress_pa), "{key}: {stress_pa}");
            let damper = d.damper.unwrap();
            let rate = damper.rate_s + damper.rate_per_hz_s * key_frequency_hz(key);
            let decay_60_db_s = DECAY_60_DB / rate;
            assert!((0.02..0.07).contains(&decay_60_db_s), "{key}: {decay_60_db_s} s");
            assert!(damper.travel_s <= 0.005 && !damper.pedal_only);
        }
    }

    #[test]
    fn a_2_mm_press_sounds_a_few_cents_sharp() {
        // The seed's Fig. 29: about 5 cents near 2 mm for its (D2-like) string.
        let d2 = pitch_rise_cents(38, 2.0e-3);
        assert!((4.0..6.0).contains(&d2), "D2: {d2:.2} cents");
        // Quadratic in the depth.
        assert!((pitch_rise_cents(38, 1.0e-3) / d2 - 0.25).abs() < 0.002);
        for key in KEYS {
            let c = pitch_rise_cents(key, 2.0e-3);
            assert!((0.5..7.0).contains(&c), "key {key}: {c:.2} cents at 2 mm");
            // The design carries the same stretch.
            let (_, s) = tangent(&course(&Voicing::default(), key, 20_000.0));
            let ratio = tangent::stretched_pitch_ratio(s, 2.0e-3);
            assert!((1200.0 * ratio.log2() - c).abs() < 1e-12);
        }
    }

    #[test]
    fn tangent_depth_scales_the_displacement_not_the_gain() {
        let plain = course(&Voicing::default(), 60, 20_000.0);
        let deeper = course(&Voicing { tangent_depth: 1.5, ..Voicing::default() }, 60, 20_000.0);
        assert!((tangent(&deeper).0 / tangent(&plain).0 - 1.5).abs() < 1e-12);
        assert_eq!(tangent(&deeper).1, tangent(&plain).1);
        assert_eq!(deeper.gain_per_n, plain.gain_per_n);
        // Held to a range: no tangent that never reaches the string.
        let none = course(&Voicing { tangent_depth: 0.0, ..Voicing::default() }, 60, 20_000.0);
        assert!((tangent(&none).0 / tangent(&plain).0 - TANGENT_DEPTH_RANGE.0).abs() < 1e-12);
    }

    #[test]
    fn the_touch_spans_the_seeds_extremes() {
        // Fastest: the 2 mm is more or less covered in 5 ms; slowest: not yet after 50 ms.
        let covered = |speed_m_s: f64, t_s: f64| 1.0 - (-t_s * speed_m_s / TANGENT_DISPLACEMENT_M).exp();
        assert!(covered(TOP_SPEED_M_S, 5e-3) > 0.9);
        assert!(covered(TOUCH.bounds().0, 50e-3) < 0.95);
        assert!(covered(TOUCH.bounds().0, 50e-3) > 0.5);
    }
}
