//! What the four instrument designs share: interpolation through scaling tables,
//! the voicing's scale factors, unison detuning, string losses, dampers and pan.
//!
//! String losses are set per mode (`Damping::PerModeQ`) from the physical model of
//! [`crate::string::damping`] (air, internal friction, the bridge; for the clavichord also
//! the leak past the tangent), with the voicing's `damping` factor multiplying
//! every mode's total loss 1/Q. `Damping::Physical` could only scale the internal
//! and bridge terms, not air drag, so the factor would not mean what it says.

use std::f64::consts::PI;
use std::ops::RangeInclusive;

use super::{DamperDesign, ResistiveBridge, Voicing, key_frequency_hz};
use crate::exciter::hammer::Hysteresis;
use crate::exciter::hammer::contact::ContactLaw;
use crate::string::damping::{Damping, LossModel, PhysicalLoss};
use crate::string::{Mass, StringSpec};

/// Compression at which a voiced exponent keeps the felt's force unchanged, m
/// (a typical forte compression of a mid-range piano hammer; Euphonics 12.2.1).
pub(crate) const REFERENCE_COMPRESSION_M: f64 = 0.5e-3;

/// ln(1000): the decay exponent for 60 dB of amplitude.
pub(super) const DECAY_60_DB: f64 = 6.907_755_278_982_137;

/// Density of music-wire steel, kg/m^3.
pub(super) const STEEL_DENSITY_KG_M3: f64 = 7850.0;
/// Young's modulus of music-wire steel, Pa.
pub(super) const STEEL_MODULUS_PA: f64 = 2.0e11;
/// Density of (yellow or red) brass wire, kg/m^3 (Euphonics 12.2.3's worked clavichord strings).
pub(super) const BRASS_DENSITY_KG_M3: f64 = 8500.0;
/// Young's modulus of brass wire, Pa (Euphonics 12.2.3's worked clavichord strings).
pub(super) const BRASS_MODULUS_PA: f64 = 1.0e11;
/// Density of the copper (or bronze) wire wrapped on a wound bass string, kg/m^3
/// (copper 8930, phosphor bronze 8860).
pub(super) const COPPER_DENSITY_KG_M3: f64 = 8900.0;

/// A scaling table: values at some keys, read between them by interpolation in
/// key number.
pub(super) struct Table(pub &'static [(u8, f64)]);

impl Table {
    /// The segment holding `key` (the end segments reach beyond the table) and the
    /// fraction along it.
    fn segment(&self, key: u8) -> ((f64, f64), (f64, f64), f64) {
        let points = self.0;
        let i = points.iter().position(|&(k, _)| k >= key).unwrap_or(points.len() - 1).clamp(1, points.len() - 1);
        let (k0, v0) = points[i - 1];
        let (k1, v1) = points[i];
        let t = (key as f64 - k0 as f64) / (k1 as f64 - k0 as f64);
        ((k0 as f64, v0), (k1 as f64, v1), t)
    }

    /// Linear in key number, held at the end values beyond the table.
    pub(super) fn linear(&self, key: u8) -> f64 {
        let ((_, v0), (_, v1), t) = self.segment(key);
        v0 + (v1 - v0) * t.clamp(0.0, 1.0)
    }

    /// Log-linear (a constant ratio per key), held at the end values beyond the table.
    pub(super) fn log(&self, key: u8) -> f64 {
        let ((_, v0), (_, v1), t) = self.segment(key);
        v0 * (v1 / v0).powf(t.clamp(0.0, 1.0))
    }

    /// Log-linear, the end segments continued beyond the table.
    pub(super) fn log_extended(&self, key: u8) -> f64 {
        let ((_, v0), (_, v1), t) = self.segment(key);
        v0 * (v1 / v0).powf(t)
    }
}

/// The felt law with the voicing applied: K times `hammer_stiffness`, then alpha
/// times `hammer_exponent` (clamped to 1..=6) with K rescaled so that the force at
/// [`REFERENCE_COMPRESSION_M`] stays what it was (a changed exponent changes the
/// felt's hardening, not its strength).
pub(super) fn voiced_law(law: ContactLaw, voicing: &Voicing) -> ContactLaw {
    let exponent = (law.exponent * voicing.hammer_exponent).clamp(1.0, 6.0);
    let stiffness = law.stiffness * voicing.hammer_stiffness * REFERENCE_COMPRESSION_M.powf(law.exponent - exponent);
    ContactLaw { stiffness, exponent }
}

/// The hammer felt's hysteresis (Stulov 1995, "Hysteretic model of the grand
/// piano hammer felt", JASA 97(4); the model as J. O. Smith gives it in Physical
/// Audio Signal Processing, "Including Hysteresis"): eps = 0.2, tau = 10 us,
/// our assumption: Stulov's fitted tables were not at hand, and these keep
/// the contact law the designs were measured with nearly whole. A design's
/// felt law is the felt relaxed (it was measured on strikes lasting far longer
/// than tau): the hammer's felt is that law over 1 - eps to an instant stroke
/// (`design::key_design`). A 10 g hammer on the C4 felt (K 4.5e9, alpha 2.5)
/// striking a 50 g, 100 Hz stop at 3 m/s loses 3.0 % of its energy to it
/// (`engine/tests/felt_hysteresis.rs`: 0.3 % at tau 1 us, 29 % at eps 0.3 and
/// tau 100 us). The voicing's `felt_hysteresis` scales eps.
pub(super) const FELT_HYSTERESIS: Hysteresis = Hysteresis { epsilon: 0.2, tau_s: 1.0e-5 };

/// A strike or pluck position with the voicing applied, kept within 0.02..=0.5.
pub(super) fn voiced_position(position: f64, voicing: &Voicing) -> f64 {
    (position * voicing.strike_position).clamp(0.02, 0.5)
}

/// Offsets in cents of the strings of a `strings`-string unison, the widest about
/// `spread_cents` (times the voicing's `unison_detune`). Each key gets its own
/// fixed scale of the pattern (0.8 to 1.2), as no two unisons are tuned alike.
pub(super) fn unison_cents(midi_key: u8, strings: usize, spread_cents: f64, voicing: &Voicing) -> Vec<f64> {
    let pattern: &[f64] = match strings {
        0 | 1 => &[0.0],
        2 => &[-0.6, 0.5],
        3 => &[-1.0, 0.0, 0.8],
        _ => &[-1.0, -0.35, 0.3, 0.9],
    };
    // A fixed scramble of the key number (Knuth's multiplicative hash) to 0..1.
    let u = (((midi_key as u32).wrapping_mul(2_654_435_761) >> 16) & 0xffff) as f64 / 65_536.0;
    let scale = spread_cents * voicing.unison_detune * (0.8 + 0.4 * u);
    (0..strings.max(1)).map(|i| pattern[i.min(pattern.len() - 1)] * scale).collect()
}

/// The frequency of `midi_key` raised by `cents`, Hz.
pub(super) fn detuned_hz(midi_key: u8, cents: f64) -> f64 {
    key_frequency_hz(midi_key) * 2f64.powf(cents / 1200.0)
}

/// Stereo position by pitch: the lowest key at -0.6, the highest at +0.6.
pub(super) fn pan(midi_key: u8, keys: RangeInclusive<u8>) -> f64 {
    let (lo, hi) = (*keys.start() as f64, *keys.end() as f64);
    0.6 * (2.0 * (midi_key as f64 - lo) / (hi - lo) - 1.0)
}

/// A damper whose felt makes a partial at `f1_hz` die by 60 dB in `decay_60_db_s`,
/// and higher partials faster by `rate_per_hz_s` (felt absorbs short waves better).
pub(super) fn damper(decay_60_db_s: f64, rate_per_hz_s: f64, f1_hz: f64, travel_s: f64) -> DamperDesign {
    let rate_s = (DECAY_60_DB / decay_60_db_s - rate_per_hz_s * f1_hz).max(0.0);
    DamperDesign { rate_s, rate_per_hz_s, travel_s, pedal_only: false, head_mass_kg: crate::action::DAMPER_MASS_KG }
}

/// Where an instrument's strings lose their energy (Euphonics 5.4, 7.2.2 and, for the clavichord's tangent, 12.2.4).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Losses {
    /// eta_E of the wire.
    pub internal_loss_factor: f64,
    /// Re Y of the bridge, s/kg.
    pub bridge_admittance_s_kg: f64,
    /// A clavichord tangent that lets waves past it into the felted part.
    pub tangent: Option<TangentLeak>,
}

/// The tangent, key and finger seen by one string: a mass on a dashpot (Euphonics
/// 12.2.4). Waves it lets through are lost in the listing felt, which mostly damps
/// the low partials (the mass reflects the high ones).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TangentLeak {
    /// The tangent, key and finger's mass, kg, and the finger's resistance, N s/m.
    pub mass_kg: f64,
    pub resistance_ns_m: f64,
}

impl TangentLeak {
    /// Loss factor of a mode at `omega_rad_s` on a string of impedance `z0` and wave
    /// speed `c` over `length_m`: the energy fraction lost per reflection,
    /// 1 - |R|^2 = 4 Z0 (d + Z0) / ((d + 2 Z0)^2 + omega^2 M^2), once per round trip.
    fn loss_factor(&self, z0: f64, c: f64, length_m: f64, omega_rad_s: f64) -> f64 {
        let (d, m) = (self.resistance_ns_m, self.mass_kg);
        let lost = 4.0 * z0 * (d + z0) / ((d + 2.0 * z0).powi(2) + (omega_rad_s * m).powi(2));
        lost * c / (2.0 * length_m * omega_rad_s)
    }
}

impl Losses {
    /// The resistive bridge these losses put under the strings, with the
    /// voicing's damping factor.
    pub(super) fn resistive_bridge(&self, voicing: &Voicing) -> ResistiveBridge {
        ResistiveBridge { admittance_s_kg: self.bridge_admittance_s_kg, loss_scale: voicing.damping.max(0.0) }
    }
}

/// `spec` with its losses set mode by mode from `losses`, every mode's 1/Q times
/// `factor`. Should the string not build (it will then be refused with the reason
/// when the key is set up), the physical model is left in with internal and bridge
/// losses scaled.
pub(crate) fn with_losses(mut spec: StringSpec, losses: &Losses, factor: f64) -> StringSpec {
    let factor = factor.max(0.0);
    spec.damping = Damping::UniformQ(1.0e3);
    let Ok(string) = spec.build() else {
        spec.damping = Damping::Physical(PhysicalLoss {
            internal_loss_factor: losses.internal_loss_factor * factor,
            bridge_admittance_s_kg: losses.bridge_admittance_s_kg * factor,
        });
        return spec;
    };
    let model = LossModel {
        length_m: string.length_m,
        tension_n: string.tension_n,
        mass_per_length_kg_m: string.mass_per_length_kg_m,
        inharmonicity: string.inharmonicity,
        outer_diameter_m: spec.outer_diameter_m.or(match spec.mass {
            Mass::SolidWire { diameter_m, .. } => Some(diameter_m),
            Mass::PerLengthKgM(_) => None,
        }),
    };
    let z0 = string.impedance_ns_m();
    let c = (string.tension_n / string.mass_per_length_kg_m).sqrt();
    let q = string
        .modes
        .iter()
        .map(|mode| {
            let n = mode.number;
            let mut eta = model.air_loss_factor(mode.frequency_hz())
                + model.internal_loss_factor(n, losses.internal_loss_factor)
                + model.bridge_loss_factor(n, losses.bridge_admittance_s_kg);
            if let Some(tangent) = losses.tangent {
                eta += tangent.loss_factor(z0, c, string.length_m, mode.omega_rad_s);
            }
            1.0 / (factor * eta)
        })
        .collect();
    spec.damping = Damping::PerModeQ(q);
    spec
}

/// The loudest touch's peak in either output channel is held at or below this,
/// dBFS: 0.5 dB under the -1 dBFS the instruments promise, for the scatter of the
/// fits below and for other sample rates (peaks rise by up to 0.4 dB from 48 to
/// 44.1 or 96 kHz).
pub(super) const PEAK_CEILING_DBFS: f64 = -1.5;

/// What sets an instrument's output gain, key by key (`gain_per_n`).
///
/// The player hears the ringing tone, so that is what is made even: every key is
/// given the gain that puts the RMS of its output from 50 to 300 ms after a note-on
/// at the range's level touch ([`super::TouchRange::level_touch`]; one key alone,
/// a damper that only the pedal lifts held off by it) at `ring_target_dbfs`. That
/// gain is the physical scaling 1 / `peak_n` (the instrument's own estimate of the
/// loudest touch's peak bridge force, N) times a smooth correction: `ring_db` is
/// the ringing such a key gives at a gain of exactly 1 / `peak_n`, dB, a
/// piecewise-linear fit through a few anchor keys of that level measured through
/// the synth on every key (within 1 dB of every key unless noted).
///
/// The gain is capped where the loudest touch (velocity 1) would otherwise peak
/// above [`PEAK_CEILING_DBFS`] in the louder of the two channels (the pan puts up
/// to 2.6 dB more into one of them): `peak_excess_db` is how far the real peak
/// lies above the estimate `peak_n` (fitted the same way, from above where the cap
/// applies: at 48 kHz no key peaks above -1.4 dBFS). Where the cap applies the key
/// rings below the target, as loud as the ceiling allows: in the treble of the
/// piano and of the instruments played with hand-held mallets, where the hammer's
/// push on the bridge during contact, not the tone, sets the peak, and in the
/// piano's bass, panned to one side. A course that several keys play (a
/// dulcimer's two sides) has one gain for all of them
/// ([`Level::course_gain_per_n`]).
pub(super) struct Level {
    pub ring_target_dbfs: f64,
    pub ring_db: Table,
    pub peak_excess_db: Table,
}

impl Level {
    /// The output gain of `midi_key`, panned at `pan`, whose loudest touch's peak
    /// bridge force is estimated at `peak_n`.
    pub(super) fn gain_per_n(&self, midi_key: u8, peak_n: f64, pan: f64) -> f64 {
        self.ringing_gain(midi_key).min(self.ceiling_gain(midi_key, pan)) / peak_n
    }

    /// The gain that puts the key's ringing at the target, with no ceiling: the
    /// microphones hear the body, whose radiation of the hammer's push on the
    /// bridge, not the push itself, sets their peak.
    pub(super) fn ring_gain_per_n(&self, midi_key: u8, peak_n: f64) -> f64 {
        self.ringing_gain(midi_key) / peak_n
    }

    /// [`Self::ring_gain_per_n`] for a course played from several keys.
    pub(super) fn course_ring_gain_per_n(&self, keys: &[u8], peak_n: f64) -> f64 {
        self.course_ringing_gain(keys) / peak_n
    }

    /// The output gain of a course played from several keys (`keys`: a divided
    /// course's two sides), panned at `pan`: the geometric mean of the gains that
    /// would put each key's ringing at the target (each then misses it by half
    /// their difference), capped where any key's loudest touch would peak above
    /// the ceiling.
    pub(super) fn course_gain_per_n(&self, keys: &[u8], peak_n: f64, pan: f64) -> f64 {
        let ceiling = keys.iter().map(|&k| self.ceiling_gain(k, pan)).fold(f64::INFINITY, f64::min);
        self.course_ringing_gain(keys).min(ceiling) / peak_n
    }

    /// How far below the peak ceiling `key`'s loudest touch lies at the gain of the
    /// course that `keys` play, dB (0 where the key's own ceiling sets the gain).
    #[cfg(test)]
    pub(super) fn headroom_db(&self, keys: &[u8], key: u8, pan: f64) -> f64 {
        20.0 * (self.ceiling_gain(key, pan) / self.course_gain_per_n(keys, 1.0, pan)).log10()
    }

    /// The geometric mean of `keys`' ringing gains.
    fn course_ringing_gain(&self, keys: &[u8]) -> f64 {
        let n = keys.len().max(1) as f64;
        (keys.iter().map(|&k| self.ringing_gain(k).ln()).sum::<f64>() / n).exp()
    }

    /// Whether the peak ceiling, not the ringing, sets the gain of the course that
    /// `keys` play (usually one key).
    #[cfg(test)]
    pub(super) fn capped(&self, keys: &[u8], pan: f64) -> bool {
        self.course_gain_per_n(keys, 1.0, pan) < self.course_ringing_gain(keys)
    }

    /// The gain times `peak_n` that puts the ringing at the target.
    fn ringing_gain(&self, midi_key: u8) -> f64 {
        db_to_amplitude(self.ring_target_dbfs - self.ring_db.linear(midi_key))
    }

    /// The gain times `peak_n` that puts the loudest touch's peak at the ceiling.
    fn ceiling_gain(&self, midi_key: u8, pan: f64) -> f64 {
        db_to_amplitude(PEAK_CEILING_DBFS - self.peak_excess_db.linear(midi_key)) / louder_channel(pan)
    }
}

/// An amplitude ratio from dB.
pub(super) fn db_to_amplitude(db: f64) -> f64 {
    10f64.powf(db / 20.0)
}

/// The gain of the louder channel for a key panned at `pan`, under the synth's
/// constant-power pan law (`sqrt 2 cos` and `sqrt 2 sin` of (pan + 1) pi / 4: 1 in
/// the centre, 1.35 at +-0.6).
pub(super) fn louder_channel(pan: f64) -> f64 {
    let angle = (pan.clamp(-1.0, 1.0) + 1.0) * PI / 4.0;
    std::f64::consts::SQRT_2 * angle.cos().max(angle.sin())
}

/// The peak bridge force of a course struck by a hammer of `mass_kg` at
/// `speed_m_s` at `position` (a fraction of `length_m`), N, estimated from two
/// limits added in quadrature: the wave the hammer launches toward the bridge,
/// Z V (Z the course's impedance), and, for a hammer heavy against the string, the
/// quasi-static push V sqrt(M k) (1 - beta) of a mass M on the string's static
/// stiffness at the strike point, k = T / (beta (1 - beta) L), felt at the bridge
/// through the lever 1 - beta (the treble "spike" of Euphonics 12.2). Against the
/// engine it holds within about 1 dB over the piano and the santoor.
pub(super) fn struck_peak_n(
    course_impedance_ns_m: f64,
    course_tension_n: f64,
    length_m: f64,
    position: f64,
    mass_kg: f64,
    speed_m_s: f64,
) -> f64 {
    let push = mass_kg * course_tension_n * (1.0 - position) / (position * length_m);
    speed_m_s * (course_impedance_ns_m.powi(2) + push).sqrt()
}

/// Tension of a flexible string of `length_m` and `mass_per_length_kg_m` at `f_hz`,
/// T = 4 L^2 mu f^2, N (bending stiffness raises the pitch by well under 1 %).
pub(super) fn flexible_tension_n(length_m: f64, mass_per_length_kg_m: f64, f_hz: f64) -> f64 {
    4.0 * length_m * length_m * mass_per_length_kg_m * f_hz * f_hz
}

/// Mass per length of a solid round wire, kg/m.
pub(super) fn wire_mass_per_length_kg_m(diameter_m: f64, density_kg_m3: f64) -> f64 {
    density_kg_m3 * PI * diameter_m * diameter_m / 4.0
}

/// Mass per length of a wound string, kg/m: a steel core of `core_m` close-wound
/// with one layer of round `wrap_wire_m` wire of `wrap_density_kg_m3`. Each turn
/// is a wire of length pi (d + w) and there are 1 / w turns per metre, so the wrap
/// adds rho_w pi^2 w (d + w) / 4: pi / 4 of the solid annulus between the core
/// and the outer diameter d + 2 w.
pub(super) fn wound_mass_per_length_kg_m(core_m: f64, wrap_wire_m: f64, wrap_density_kg_m3: f64) -> f64 {
    wire_mass_per_length_kg_m(core_m, STEEL_DENSITY_KG_M3)
        + wrap_density_kg_m3 * PI * PI * wrap_wire_m * (core_m + wrap_wire_m) / 4.0
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{
        ExciterDesign, InstrumentKind, KeyDesign, cimbalom, clavichord, dulcimer, fortepiano, harpsichord, key_design,
        piano, santoor,
    };
    use crate::string::Tuning;
    use crate::synth::{Event, Instrument, Synth, TimedEvent, default_settings};

    const SAMPLE_RATE_HZ: f64 = 48_000.0;

    /// One key played alone from silence through the synth at `velocity` (with the
    /// sustain pedal down if `pedal`): the RMS of its output (the channels' mean)
    /// from 50 to 300 ms, and the peak of either channel over 0.35 s, dBFS.
    fn ringing_and_peak_dbfs(synth: &mut Synth, key: u8, velocity: f64, pedal: bool) -> (f64, f64) {
        let n = (0.35 * SAMPLE_RATE_HZ) as usize;
        let (mut left, mut right) = (vec![0.0f32; n], vec![0.0f32; n]);
        let sustain = TimedEvent::new(0, Event::Sustain(if pedal { 1.0 } else { 0.0 }));
        synth.process(&[sustain, TimedEvent::new(0, Event::NoteOn { key, velocity })], &mut left, &mut right);
        let (a, b) = ((0.05 * SAMPLE_RATE_HZ) as usize, (0.3 * SAMPLE_RATE_HZ) as usize);
        let power = (a..b).map(|t| (0.5 * (left[t] as f64 + right[t] as f64)).powi(2)).sum::<f64>() / (b - a) as f64;
        let peak = left.iter().chain(&right).fold(0.0f64, |p, v| p.max(v.abs() as f64));
        // Silence again: the reset fades the key out within a few milliseconds.
        let (mut left, mut right) = (vec![0.0f32; 2048], vec![0.0f32; 2048]);
        synth.process(&[TimedEvent::new(0, Event::Reset)], &mut left, &mut right);
        (10.0 * power.log10(), 20.0 * peak.log10())
    }

    fn cents(ratio: f64) -> f64 {
        1200.0 * ratio.log2()
    }

    /// The course `key` plays on `kind` (its own design, or the design that lists
    /// it among its shared keys), and every key that plays that course.
    fn course(kind: InstrumentKind, key: u8) -> (KeyDesign, Vec<u8>) {
        let d = kind
            .key_range()
            .filter_map(|k| key_design(kind, &Voicing::default(), k, 20_000.0))
            .find(|d| d.midi_key == key || d.shared.iter().any(|s| s.midi_key == key))
            .unwrap_or_else(|| panic!("{kind} key {key}: on no course"));
        let keys = std::iter::once(d.midi_key).chain(d.shared.iter().map(|s| s.midi_key)).collect();
        (d, keys)
    }

    #[test]
    fn every_key_builds_in_tune_at_both_cut_offs() {
        let voicing = Voicing::default();
        for kind in InstrumentKind::ALL {
            // How many courses each MIDI key plays: exactly one within the range.
            let mut played = [0usize; 128];
            for key in kind.key_range() {
                for max_frequency_hz in [9_900.0, 20_000.0] {
                    // None: the key plays another key's course (counted there).
                    let Some(d) = key_design(kind, &voicing, key, max_frequency_hz) else { continue };
                    if max_frequency_hz == 20_000.0 {
                        for k in std::iter::once(key).chain(d.shared.iter().map(|s| s.midi_key)) {
                            played[k as usize] += 1;
                        }
                    }
                    assert_eq!(d.midi_key, key);
                    assert!((1..=4).contains(&d.strings.len()), "{kind} {key}");
                    assert!(!d.struck.is_empty() && d.struck.end <= d.strings.len(), "{kind} {key}");
                    for (i, spec) in d.strings.iter().enumerate() {
                        assert_eq!(spec.max_frequency_hz, max_frequency_hz);
                        let string = spec.build().unwrap_or_else(|e| panic!("{kind} key {key}: {e}"));
                        let f1 = string.partial_hz(1);
                        assert!(f1 < max_frequency_hz);
                        // A clavichord is tuned with its keys down: the press's stretch brings it up to pitch.
                        let pressed = match d.exciter {
                            ExciterDesign::Tangent { displacement_m, stretch_per_m2, .. } => {
                                crate::exciter::tangent::stretched_pitch_ratio(stretch_per_m2, displacement_m)
                            }
                            _ => 1.0,
                        };
                        // In tune with the note that strikes it: the key's own, or a shared
                        // key's striking it apart from the key's (a dulcimer's short side);
                        // a string no key strikes (an unplayed short side) with some note.
                        let note = d.shared.iter().find(|s| s.struck.contains(&i) && !d.struck.contains(&i));
                        let off = match note {
                            Some(s) => cents(f1 / key_frequency_hz(s.midi_key)),
                            None if d.struck.contains(&i) => cents(f1 * pressed / key_frequency_hz(key)),
                            None => {
                                assert!(d.shared.iter().all(|s| !s.struck.contains(&i)));
                                let c = cents(f1 / key_frequency_hz(key));
                                c - 100.0 * (c / 100.0).round()
                            }
                        };
                        assert!(off.abs() < 3.0, "{kind} key {key} string {i}: {off} cents");
                        let Tuning::FirstPartialHz(target) = spec.tuning else {
                            panic!("{kind} {key}: not tuned by pitch")
                        };
                        assert!((f1 / target - 1.0).abs() < 1e-9);
                        assert!(matches!(spec.damping, Damping::PerModeQ(_)));
                        assert!(string.modes.iter().all(|m| m.q > 50.0), "{kind} {key}: a mode with a low Q");
                    }
                    assert!(d.gain_per_n > 0.0 && d.gain_per_n.is_finite());
                    assert!(d.pan.abs() <= 0.6 + 1e-12);
                    for exciter in std::iter::once(d.exciter).chain(d.shared.iter().map(|s| s.exciter)) {
                        let position = match exciter {
                            ExciterDesign::Hammer { position, .. } | ExciterDesign::Pluck { position } => position,
                            ExciterDesign::Tangent { displacement_m, .. } => {
                                assert!((0.5e-3..=2.5e-3).contains(&displacement_m));
                                0.1
                            }
                        };
                        assert!((0.02..=0.5).contains(&position), "{kind} {key}: {position}");
                    }
                }
            }
            for key in 0..128u8 {
                let expected = usize::from(kind.key_range().contains(&key));
                assert_eq!(
                    played[key as usize], expected,
                    "{kind} key {key}: played by {} courses",
                    played[key as usize]
                );
            }
        }
    }

    #[test]
    fn none_outside_the_key_range() {
        for kind in InstrumentKind::ALL {
            let range = kind.key_range();
            assert!(key_design(kind, &Voicing::default(), range.start() - 1, 20_000.0).is_none());
            assert!(key_design(kind, &Voicing::default(), range.end() + 1, 20_000.0).is_none());
        }
    }

    #[test]
    fn pan_runs_from_bass_left_to_treble_right() {
        for kind in InstrumentKind::ALL {
            // Over the courses (keys that play another key's course have no design).
            let pans: Vec<f64> = kind
                .key_range()
                .filter_map(|k| key_design(kind, &Voicing::default(), k, 20_000.0))
                .map(|d| d.pan)
                .collect();
            assert!((pans[0] + 0.6).abs() < 1e-12 && (pans[pans.len() - 1] - 0.6).abs() < 1e-12);
            assert!(pans.windows(2).all(|w| w[1] > w[0]));
        }
    }

    /// Not a check: prints, key by key, what the piano's level table should
    /// hold (`cargo test --release -p struck-engine --lib measure_piano_level
    /// -- --ignored --nocapture`): the ringing at a gain of exactly 1 / peak_n,
    /// and how far the loudest touch's peak lies over the estimate.
    #[test]
    #[ignore]
    fn measure_piano_level() {
        let kind = InstrumentKind::Piano;
        let level = &piano::LEVEL;
        let settings = default_settings(kind, SAMPLE_RATE_HZ).heard_through(crate::body::Output::BridgeForce);
        let (mut synth, _) = Synth::new(Box::new(Instrument::build(&settings).unwrap()));
        synth.set_controls(crate::synth::Controls { output: crate::body::Output::BridgeForce, ..Default::default() });
        for key in kind.key_range() {
            let (d, course_keys) = course(kind, key);
            let applied = level.course_gain_per_n(&course_keys, 1.0, d.pan);
            let (ringing, _) = ringing_and_peak_dbfs(&mut synth, key, kind.touch_range().level_velocity(), false);
            let (_, peak) = ringing_and_peak_dbfs(&mut synth, key, 1.0, false);
            let gain_db = 20.0 * applied.log10();
            println!(
                "LEVEL {key} ring_db {:.2} peak_excess_db {:.2}",
                ringing - gain_db,
                peak - gain_db - 20.0 * louder_channel(d.pan).log10()
            );
        }
    }

    #[test]
    fn ringing_is_even_and_the_loudest_touch_peaks_under_minus_1_dbfs() {
        // From these keys up the ringing may fall more than 3 dB short of the
        // target, where the peak ceiling holds the gain down (Level): F#5 on the
        // piano, G5 on the santoor and the cimbalom, C5 on the fortepiano, D5 on
        // the dulcimer.
        let cases = [
            (InstrumentKind::Piano, &piano::LEVEL, 78),
            (InstrumentKind::Fortepiano, &fortepiano::LEVEL, 72),
            (InstrumentKind::Santoor, &santoor::LEVEL, 79),
            (InstrumentKind::Dulcimer, &dulcimer::LEVEL, 74),
            (InstrumentKind::Cimbalom, &cimbalom::LEVEL, 79),
            (InstrumentKind::Clavichord, &clavichord::LEVEL, u8::MAX),
            (InstrumentKind::Harpsichord, &harpsichord::LEVEL, u8::MAX),
        ];
        for (kind, level, short_from) in cases {
            let target = level.ring_target_dbfs;
            let settings = default_settings(kind, SAMPLE_RATE_HZ).heard_through(crate::body::Output::BridgeForce);
            let instrument = Instrument::build(&settings).unwrap();
            let (mut synth, _) = Synth::new(Box::new(instrument));
            // The level scale is the bridge-force output's (the body's microphones are voiced from it).
            synth.set_controls(crate::synth::Controls {
                output: crate::body::Output::BridgeForce,
                ..Default::default()
            });
            let range = kind.key_range();
            let mut keys: Vec<u8> = range.clone().step_by(3).chain([*range.end()]).collect();
            keys.dedup();
            let mut previous: Option<f64> = None;
            for key in keys {
                // A damper bar that only the pedal lifts (a cimbalom's) is held off: the
                // player hears the ringing tone with the pedal down.
                let (d, course_keys) = course(kind, key);
                let pedal = d.damper.is_some_and(|d| d.pedal_only);
                let (ringing, _) = ringing_and_peak_dbfs(&mut synth, key, kind.touch_range().level_velocity(), pedal);
                let (_, peak) = ringing_and_peak_dbfs(&mut synth, key, 1.0, pedal);
                let capped = level.capped(&course_keys, d.pan);
                let what =
                    format!("{kind} key {key}: ringing {ringing:.1} dBFS (target {target}), peak {peak:.1} dBFS");
                assert!(peak <= -1.0, "{what}");
                if capped {
                    // As loud as the ceiling allows (on a divided course, the side that
                    // meets it first), and no louder than the target.
                    let headroom = level.headroom_db(&course_keys, key, d.pan);
                    assert!(peak > PEAK_CEILING_DBFS - 1.0 - headroom && ringing < target + 1.5, "{what}");
                    assert!(ringing >= target - 3.0 || key >= short_from, "{what}");
                } else {
                    // The fits hold every key's ringing within 1 dB (and the gain with it).
                    assert!((ringing - target).abs() <= 1.5, "{what}");
                }
                // No steps between neighbours within the even range.
                let even = (ringing - target).abs() <= 3.0;
                if let (true, Some(p)) = (even, previous) {
                    assert!((ringing - p).abs() < 3.0, "{what}, {p:.1} dBFS three keys down");
                }
                previous = even.then_some(ringing);
            }
        }
    }

    #[test]
    fn damping_factor_scales_every_mode_loss() {
        for kind in InstrumentKind::ALL {
            // The middle key, or the first course above it (a key may play another's course).
            let middle = (kind.key_range().start() + kind.key_range().end()) / 2;
            let key = (middle..=*kind.key_range().end())
                .find(|&k| key_design(kind, &Voicing::default(), k, 20_000.0).is_some())
                .unwrap();
            let plain = key_design(kind, &Voicing::default(), key, 20_000.0).unwrap();
            let voicing = Voicing { damping: 2.0, ..Voicing::default() };
            let damped = key_design(kind, &voicing, key, 20_000.0).unwrap();
            let a = plain.strings[0].build().unwrap();
            let b = damped.strings[0].build().unwrap();
            assert_eq!(a.modes.len(), b.modes.len());
            for (m, n) in a.modes.iter().zip(&b.modes) {
                assert!((m.q / n.q - 2.0).abs() < 1e-9, "{kind} mode {}", m.number);
            }
        }
    }

    #[test]
    fn unison_detune_scales_the_spread() {
        for kind in [InstrumentKind::Piano, InstrumentKind::Santoor, InstrumentKind::Clavichord] {
            let key = *kind.key_range().end() - 2;
            let pitch = |voicing: &Voicing| -> Vec<f64> {
                key_design(kind, voicing, key, 20_000.0)
                    .unwrap()
                    .strings
                    .iter()
                    .map(|s| match s.tuning {
                        Tuning::FirstPartialHz(f) => cents(f / key_frequency_hz(key)),
                        Tuning::TensionN(_) => f64::NAN,
                    })
                    .collect()
            };
            let one = pitch(&Voicing::default());
            let two = pitch(&Voicing { unison_detune: 2.0, ..Voicing::default() });
            let zero = pitch(&Voicing { unison_detune: 0.0, ..Voicing::default() });
            assert!(one.len() >= 2);
            let spread = one.iter().cloned().fold(f64::MIN, f64::max) - one.iter().cloned().fold(f64::MAX, f64::min);
            assert!(spread > 0.1, "{kind}: spread {spread} cents");
            // Offsets from the undetuned course (a clavichord's sits flat at rest, for the press).
            for ((a, b), z) in one.iter().zip(&two).zip(&zero) {
                assert!((b - z - 2.0 * (a - z)).abs() < 1e-9 && (z - zero[0]).abs() < 1e-9);
            }
        }
    }

    #[test]
    fn voiced_exponent_keeps_the_force_at_half_a_millimetre() {
        let law = ContactLaw { stiffness: 4.5e9, exponent: 2.5 };
        let voicing = Voicing { hammer_exponent: 1.2, hammer_stiffness: 3.0, ..Voicing::default() };
        let v = voiced_law(law, &voicing);
        assert!((v.exponent - 3.0).abs() < 1e-12);
        let f = |l: ContactLaw| l.force_n(REFERENCE_COMPRESSION_M);
        assert!((f(v) / (3.0 * f(law)) - 1.0).abs() < 1e-12);
        let clamped = voiced_law(law, &Voicing { hammer_exponent: 10.0, ..Voicing::default() });
        assert_eq!(clamped.exponent, 6.0);
        assert_eq!(voiced_law(law, &Voicing { hammer_exponent: 0.1, ..Voicing::default() }).exponent, 1.0);
    }

    #[test]
    fn tables_interpolate_and_extend() {
        let t = Table(&[(24, 1.0), (36, 2.0), (48, 8.0)]);
        assert_eq!(t.linear(30), 1.5);
        assert_eq!(t.linear(12), 1.0);
        assert_eq!(t.linear(60), 8.0);
        assert!((t.log(30) - 2f64.sqrt()).abs() < 1e-12);
        assert!((t.log_extended(12) - 0.5).abs() < 1e-12);
        assert!((t.log_extended(60) - 32.0).abs() < 1e-12);
        assert_eq!(t.linear(36), 2.0);
    }
}
