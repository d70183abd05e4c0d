//! Voicing each key through the body: how loud the microphones hear a key's
//! partials, and how much louder (or softer) than the bridge-force output the
//! key must then bear on the body to ring where the instrument's level scale
//! puts it. Off the audio thread, when an instrument is built.

use crate::body::boards::{BodyDesign, MAX_ZONES};
use crate::body::soundboard::{HeardModes, Soundboard};
use crate::design::Touch;
use crate::key::Key;
use crate::CONTROL_BLOCK;

/// How loud a key's partials come through the body, Pa/N: the pressure per
/// newton where the key bears on the bridge, power-averaged over both
/// microphones and over a whole tone around each of its first six partials
/// (where they sound, give or take their stretch and the unison's spread), the
/// partials weighted 1/n^4, as the ring of a struck string's bridge force
/// falls off. A key is voiced by it as a technician voices one by ear.
pub(super) fn heard_pa_per_n(board: &BodyDesign, heard: &HeardModes, midi_key: u8, f1_hz: f64) -> f64 {
    // The running body hears a key through the two zones it bears between.
    let points = board.share_points(midi_key);
    let (mut power, mut weights) = (0.0, 0.0);
    for n in 1..=6 {
        let weight = 1.0 / (n * n * n * n) as f64;
        let steps = 8;
        let band = (0..steps)
            .map(|i| {
                let f = n as f64 * f1_hz * 2f64.powf((i as f64 / (steps - 1) as f64 - 0.5) / 6.0);
                let [l, r] = heard.transfer_spread_pa_per_n(&points, f);
                0.5 * (l.norm_sqr() + r.norm_sqr())
            })
            .sum::<f64>()
            / steps as f64;
        power += weight * band;
        weights += weight;
    }
    (power / weights).sqrt()
}

/// The loudest touch's peak through the microphones is held at or below this,
/// dBFS: the -1 dBFS the instruments promise, less a dB for what the short probe
/// of each key misses (a later peak of its tone).
const MIC_PEAK_CEILING_DBFS: f64 = -2.0;

/// How long a key's strikes are played when it is voiced, s: the hammer has
/// left every string by then, and the loudest strike's peak has passed.
const PROBE_S: f64 = 0.02;

/// The window the level scale measures a key's ringing over, s after the
/// note-on (`design`'s `Level`).
const RING_FROM_S: f64 = 0.05;
const RING_TO_S: f64 = 0.3;

/// The most partials of a key weighed through the body when it is voiced.
const PROBE_PARTIALS: usize = 40;

/// How much louder the body hears `key` than the bridge-force output does: a
/// strike at `ringing` (the touch the level scale is measured at) is played
/// alone, and what its strings then ring with,
/// partial by partial, is weighed through the body (the ring 50-300 ms after
/// the strike, each partial decaying at its own rate, the strings of a unison
/// adding in power) against what the bridge-force output would ring with at
/// the key's ringing gain: so each key rings through the microphones where the
/// instrument's level scale puts it, whatever the body does at its partials.
/// Then, if its `loudest` strike's first milliseconds through the body would
/// peak above
/// [`MIC_PEAK_CEILING_DBFS`], the key is turned down until they do not (the
/// hammer's push on the bridge, which the bridge-force output caps, reaches the
/// microphones only through the body's response to it).
pub(super) fn voice_through_body(
    key: &mut Key,
    midi_key: u8,
    ringing: Touch,
    loudest: Touch,
    board: &BodyDesign,
    heard_modes: &HeardModes,
    soundboard: &mut Soundboard,
) -> f64 {
    let fs = 1.0 / soundboard.step_s();
    let mut force = vec![0.0; (PROBE_S * fs) as usize];
    // A felt hammer's spectrum changes with the touch (a hard treble strike can
    // all but miss the fundamental a mezzo-forte one rings with): the ring is
    // weighed at the touch the level scale is set at, the peak at the loudest.
    let partials = key.probe(ringing, &mut force);
    key.probe(loudest, &mut force);
    let share = board.zone_share(midi_key);
    let points = board.share_points(midi_key);
    // Mean of exp(-2 sigma t) over the ring's window, t from the probe's end.
    let (from, to) = (RING_FROM_S - PROBE_S, RING_TO_S - PROBE_S);
    let held = |sigma: f64| {
        if sigma * (to - from) < 1e-9 { 1.0 } else { ((-2.0 * sigma * from).exp() - (-2.0 * sigma * to).exp()) / (2.0 * sigma * (to - from)) }
    };
    // The partials by their share of the bridge force's ring.
    let mut ring: Vec<(f64, f64)> =
        partials.iter().filter(|p| p.2 > 0.0).map(|&(a, sigma, f)| (0.5 * a * a * held(sigma), f)).collect();
    ring.sort_by(|a, b| b.0.total_cmp(&a.0));
    // A partial too weak to count in the bridge force may still be what the
    // microphones hear most (on a resonance of the board): none is left out for
    // being weak, only for being beyond the strongest PROBE_PARTIALS.
    let (mut bridge, mut heard) = (0.0, 0.0);
    for &(power, f_hz) in ring.iter().take(PROBE_PARTIALS) {
        bridge += power;
        let [l, r] = heard_modes.transfer_spread_pa_per_n(&points, f_hz);
        heard += power * 0.5 * (l.norm_sqr() + r.norm_sqr()) * soundboard.gain().powi(2);
    }
    let mut voicing = if heard > 0.0 && bridge > 0.0 { key.body_boost() * (bridge / heard).sqrt() } else { 1.0 };
    // The strike's first milliseconds through the body, at that voicing.
    soundboard.silence();
    let mut zone_forces = [[0.0; CONTROL_BLOCK]; MAX_ZONES];
    let (mut left, mut right) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
    let mut peak = 0.0f64;
    for chunk in force.chunks(CONTROL_BLOCK) {
        for zone in &mut zone_forces {
            zone.fill(0.0);
        }
        for (&z, w) in share.zones.iter().zip(share.weights) {
            for (t, f) in chunk.iter().enumerate() {
                zone_forces[z.min(MAX_ZONES - 1)][t] += f * w * voicing;
            }
        }
        let n = chunk.len();
        soundboard.process(&zone_forces, &mut left[..n], &mut right[..n]);
        peak = left[..n].iter().chain(&right[..n]).fold(peak, |m, v| m.max(v.abs()));
    }
    soundboard.silence();
    let ceiling = 10f64.powf(MIC_PEAK_CEILING_DBFS / 20.0);
    if peak > ceiling {
        voicing *= ceiling / peak;
    }
    voicing
}

