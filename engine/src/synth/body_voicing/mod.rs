//! Voicing each key through the body: how loud the microphones hear a key's
//! partials, and how much louder (or softer) than the bridge-force output the
//! key must then bear on the body to ring where the instrument's level scale
//! puts it. Off the audio thread, when an instrument is built.

use std::cell::RefCell;
use std::collections::HashMap;
use std::f64::consts::PI;

use num_complex::Complex64;

use crate::CONTROL_BLOCK;
use crate::body::boards::{BodyDesign, MAX_ZONES, ZoneShare};
use crate::body::load::trade;
use crate::body::soundboard::{HeardModes, Soundboard};
use crate::design::{Touch, TouchRange};
use crate::key::{Key, SYMPATHY_BLOCKS, TRADE_BLOCKS, regulated, wakes};
use crate::performance::PerformanceState;
use crate::synth::SILENCE;
use crate::synth::sympathy::Sympathy;

mod regulation;
pub(super) use regulation::even_out;
use regulation::*;

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

/// How loud `key` rings through the body after a strike at `touch`, alone,
/// and how loud the same ring is as the bridge force has it: the mean power
/// over the ring's window, (full scale)^2 at the key's bridge-force gain, the
/// body heard `gain` times louder; `force` is left holding the strike's first
/// [`PROBE_S`] as the bridge gets it. The bridge force's ring and the
/// strike's peak through the body are weighed only as `asked` (a regulation
/// compares what the microphones hear alone).
///
/// What the strings ring with is followed partial by partial, each decaying
/// at its own rate and heard through the body at its own frequency; partials
/// close in frequency (a unison's strings, struck together and so in phase at
/// first) add as waves, with their beating over the window. Then the board
/// rings on from the strike's push (what a soft treble strike rings with
/// most), its modes taken from where the probe leaves them.
fn ring_through_body(key: &mut Key, touch: Touch, body: Body, gain: f64, force: &mut [f64], asked: Asked) -> Weighed {
    if key.stays_on_strings() {
        return ring_played_through_body(key, touch, body, gain, force);
    }
    let Body { heard, shapes, share, soundboard, partners } = body;
    let (from, to) = (RING_FROM_S - PROBE_S, RING_TO_S - PROBE_S);
    let strings = key.probe(touch, force);
    // (What the microphones hear of the free partials alone is their whole
    // ring only for a single string with no partners.)
    let alone_heard = key.unison().is_empty() && partners.is_empty();
    let weigh = Weigh { mics: alone_heard, bridge: asked.bridge };
    let (free_mics, bridge) = free_ring(strings.iter().flatten().copied().collect(), heard, shapes, gain, weigh);
    // A unison whose strings trade through the body rings less in the window
    // (its prompt sound is N times as fast): what it is voiced against stays
    // the ring its strings would have on their own, so that the level scale
    // holds however strongly the body couples them. What the key sets ringing
    // in the strings that ring free beside it is heard with it.
    let ring = Ring { heard, shapes, partners, step_s: soundboard.step_s(), gain };
    let mut mics = if !key.unison().is_empty() {
        ring.traded(&strings, key.unison(), &|_| true)
    } else if partners.is_empty() {
        free_mics
    } else {
        let trades = |i: usize| partners.iter().any(|p| p.partial == i);
        let alone: Vec<(Complex64, Complex64)> =
            strings.iter().flat_map(|s| s.iter().enumerate().filter(|&(i, _)| !trades(i)).map(|(_, &p)| p)).collect();
        let weigh = Weigh { mics: true, bridge: false };
        free_ring(alone, heard, shapes, gain, weigh).0 + ring.traded(&strings, &[], &trades)
    };
    let scale = gain / soundboard.gain();
    let peak = if asked.peak {
        Some(run_board(soundboard, share, force, scale))
    } else {
        play_board(soundboard, share, force, scale, None);
        None
    };
    mics += soundboard.ring_power(from, to);
    soundboard.silence();
    Weighed { mics: mics.max(0.0), bridge: bridge.max(0.0), peak_per_scale: peak.map(|p| p / scale) }
}

/// What [`ring_through_body`] weighs besides the ring through the
/// microphones: the ring in the bridge force, the strike's peak through the
/// body.
#[derive(Clone, Copy)]
struct Asked {
    bridge: bool,
    peak: bool,
}

/// What [`ring_through_body`] weighed of a strike: the ring's mean power
/// through the microphones and in the bridge force (0 unless asked), and
/// the strike's largest sample over the probe through the body, in either
/// microphone, per unit of the key's force on it ([`run_board`]'s scale;
/// None unless asked).
#[derive(Clone, Copy, Debug)]
struct Weighed {
    mics: f64,
    bridge: f64,
    peak_per_scale: Option<f64>,
}

/// Which of a ring's powers [`free_ring`] weighs (one not weighed is 0).
#[derive(Clone, Copy)]
struct Weigh {
    mics: bool,
    bridge: bool,
}

/// The ring's mean power (microphones, bridge force) of free `partials`
/// (each string's modes on their own), those `weigh` asks for: see
/// [`ring_through_body`].
fn free_ring(
    mut partials: Vec<(Complex64, Complex64)>,
    heard: &Heard,
    shapes: &[f64],
    gain: f64,
    weigh: Weigh,
) -> (f64, f64) {
    if !weigh.mics && !weigh.bridge {
        return (0.0, 0.0);
    }
    let (from, to) = (RING_FROM_S - PROBE_S, RING_TO_S - PROBE_S);
    partials.retain(|(_, lambda)| lambda.im > 0.0);
    // The strongest PROBE_PARTIALS by their own ring in the bridge force: a
    // partial too weak to count there may still be what the microphones hear
    // most (on a resonance of the board), so none is left out for being weak.
    let alone = |(z, lambda): &(Complex64, Complex64)| z.norm_sqr() * window_mean(2.0 * lambda.re, from, to);
    let partials = strongest(partials.iter().map(alone).collect(), PROBE_PARTIALS)
        .into_iter()
        .map(|i| partials[i])
        .collect::<Vec<_>>();
    let heard: Vec<[Complex64; 2]> = if weigh.mics {
        partials
            .iter()
            .map(|(z, lambda)| heard.transfer(shapes, lambda.im / (2.0 * PI)).map(|t| z * t * gain))
            .collect()
    } else {
        Vec::new()
    };
    let (mut bridge, mut mics) = (0.0, 0.0);
    for (j, (zj, lj)) in partials.iter().enumerate() {
        for (k, (zk, lk)) in partials.iter().enumerate() {
            if (lj.im - lk.im).abs() > COHERENT_WITHIN * lj.im.abs().max(lk.im.abs()) {
                continue;
            }
            let over = window_integral(lj + lk.conj(), from, to);
            bridge += 0.5 * (zj * zk.conj() * over).re;
            if let (Some(hj), Some(hk)) = (heard.get(j), heard.get(k)) {
                for (hj, hk) in hj.iter().zip(hk) {
                    mics += 0.25 * (hj * hk.conj() * over).re;
                }
            }
        }
    }
    (if weigh.mics { mics } else { 0.0 }, if weigh.bridge { bridge } else { 0.0 })
}

/// A partial of another key that rings free when this key is struck alone (it
/// has no damper, or none down with the pedal up), trading with one of this
/// key's partials through the body ([`Sympathy::pairs_of`]): a technician
/// voicing the key by ear hears it ring too.
pub(super) struct Partner<'a> {
    /// This key's partial, and its strings (bit i: string i) that trade.
    partial: usize,
    strings: u8,
    /// How many of the other key's strings sound its partial, that partial's
    /// pole (s^-1), what a unison trade's interval keeps of their sum in step
    /// (its strings move alike), and the body's modes' shapes where it bears.
    count: f64,
    lambda: Complex64,
    in_step: Complex64,
    shapes: &'a [f64],
    /// What one sympathetic interval adds to each of this key's strings per
    /// unit of the other's sum, and to each of the other's per unit of this
    /// key's (in this key's units: heard as the physics has it).
    into_mine: Complex64,
    into_theirs: Complex64,
}

/// Every partner of `midi_key`'s partials among `keys` ([`Partner`]), the
/// body's shapes where each key bears given by `shapes` (by MIDI key).
/// Allocates; when an instrument is built.
pub(super) fn partners<'a>(
    sympathy: &Sympathy,
    keys: &[Option<Key>],
    midi_key: u8,
    shapes: &'a [Vec<f64>],
) -> Vec<Partner<'a>> {
    sympathy
        .pairs_of(midi_key)
        .into_iter()
        .filter_map(|pair| {
            let other = keys.get(pair.other as usize)?.as_ref()?;
            if !other.rings_free(&PerformanceState::default()) {
                return None;
            }
            let in_step = other.unison().get(pair.other_partial).map_or(Complex64::new(1.0, 0.0), |u| u.1);
            Some(Partner {
                partial: pair.partial,
                strings: pair.strings,
                count: f64::from(pair.other_strings.count_ones()),
                lambda: pair.other_pole,
                in_step,
                shapes: shapes.get(pair.other as usize)?,
                into_mine: pair.into_mine,
                into_theirs: pair.into_theirs,
            })
        })
        .collect()
}

/// How the microphones weigh what a key's strings ring with: the body's
/// modes and their shapes where the key bears, the free strings it sets
/// ringing, a control block's length (s) and the gain the key is heard at.
struct Ring<'a> {
    heard: &'a Heard<'a>,
    shapes: &'a [f64],
    partners: &'a [Partner<'a>],
    step_s: f64,
    gain: f64,
}

/// Sympathetic intervals in a unison trade's.
const SYMPATHY_STEPS: usize = TRADE_BLOCKS / SYMPATHY_BLOCKS;
const _: () = assert!(SYMPATHY_STEPS * SYMPATHY_BLOCKS == TRADE_BLOCKS);

impl Ring<'_> {
    /// The ring's mean power through the microphones of the `chosen` partials
    /// of `strings`, followed interval by interval over the ring's window: a
    /// unison's strings (`unison`, per [`TRADE_BLOCKS`] control blocks; none
    /// for a single string) each turning by its own pole and then trading, so
    /// the prompt sound, the aftersound and their beating are all in what is
    /// weighed; and a partial's free partners, set ringing from the strike on
    /// and trading with it every [`SYMPATHY_BLOCKS`] blocks as the synth's
    /// sympathetic strings do, heard where they bear and added as waves.
    fn traded(
        &self,
        strings: &[Vec<(Complex64, Complex64)>],
        unison: &[(Complex64, Complex64)],
        chosen: &dyn Fn(usize) -> bool,
    ) -> f64 {
        let Ring { heard: heard_through, shapes, partners, step_s, gain } = *self;
        let (from, to) = (RING_FROM_S - PROBE_S, RING_TO_S - PROBE_S);
        let h = (TRADE_BLOCKS * CONTROL_BLOCK) as f64 * step_s;
        let mut partials = strings.iter().map(Vec::len).min().unwrap_or(0);
        if !unison.is_empty() {
            partials = partials.min(unison.len());
        }
        // The strongest PROBE_PARTIALS partials by their strings' own ring.
        let alone =
            |i: usize| strings.iter().map(|s| s[i].0.norm_sqr() * window_mean(2.0 * s[i].1.re, from, to)).sum::<f64>();
        let candidates: Vec<usize> =
            (0..partials).filter(|&i| chosen(i) && strings.iter().all(|s| s[i].1.im > 0.0)).collect();
        let order: Vec<usize> = strongest(candidates.iter().map(|&i| alone(i)).collect(), PROBE_PARTIALS)
            .into_iter()
            .map(|j| candidates[j])
            .collect();
        let (first, last) = ((from / h).ceil() as usize, (to / h).floor() as usize);
        let blocks = (last + 1).saturating_sub(first).max(1) as f64;
        let mut mics = 0.0;
        for i in order {
            let own: Vec<&Partner> = partners.iter().filter(|p| p.partial == i).collect();
            // Without partners the interval is the unison's; with them, the
            // sympathetic strings' (SYMPATHY_STEPS of them to a unison trade).
            let steps = if own.is_empty() { 1 } else { SYMPATHY_STEPS };
            let dt = h / steps as f64;
            let turn: Vec<Complex64> = strings.iter().map(|s| (s[i].1 * dt).exp()).collect();
            let mut zeta: Vec<Complex64> = strings.iter().map(|s| s[i].0).collect();
            let [l, r] = heard_through.transfer(shapes, strings[0][i].1.im / (2.0 * PI));
            let heard: Vec<[Complex64; 2]> =
                own.iter().map(|p| heard_through.transfer(p.shapes, p.lambda.im / (2.0 * PI))).collect();
            let their_turn: Vec<Complex64> = own.iter().map(|p| (p.lambda * dt).exp()).collect();
            let mut theirs: Vec<Complex64> = own.iter().map(|p| p.since_strike(strings, i, dt, h)).collect();
            // A partner rings (and gives back) once what it was given would
            // wake it, as the synth wakes a silent key (the probe's units are
            // full scale; the two keys' gains onto the body taken alike).
            let mut awake: Vec<bool> = own.iter().zip(&theirs).map(|(p, z)| wakes(z / p.count, SILENCE)).collect();
            let mut given = vec![Complex64::new(0.0, 0.0); zeta.len()];
            for step in 1..=last * steps {
                zeta.iter_mut().zip(&turn).for_each(|(z, t)| *z *= t);
                theirs.iter_mut().zip(&their_turn).for_each(|(z, t)| *z *= t);
                // What each side gave the other over the interval, all read
                // before any is moved.
                given.fill(Complex64::new(0.0, 0.0));
                for ((p, their), awake) in own.iter().zip(theirs.iter_mut()).zip(awake.iter_mut()) {
                    let sum: Complex64 =
                        zeta.iter().enumerate().filter(|&(s, _)| p.strings & (1 << s) != 0).map(|(_, z)| z).sum();
                    if *awake {
                        for (_, g) in given.iter_mut().enumerate().filter(|&(s, _)| p.strings & (1 << s) != 0) {
                            *g += p.into_mine * *their;
                        }
                    }
                    *their += p.count * p.into_theirs * sum;
                    *awake = *awake || wakes(*their / p.count, SILENCE);
                }
                zeta.iter_mut().zip(&given).for_each(|(z, g)| *z += g);
                if step % steps != 0 {
                    continue;
                }
                if !unison.is_empty() {
                    trade(unison[i], &mut zeta);
                }
                theirs.iter_mut().zip(&own).for_each(|(z, p)| *z *= p.in_step);
                if step / steps >= first {
                    let sum = zeta.iter().sum::<Complex64>();
                    let (mut pl, mut pr) = (l * sum, r * sum);
                    for ((t, z), _) in heard.iter().zip(&theirs).zip(&awake).filter(|(_, a)| **a) {
                        pl += t[0] * z;
                        pr += t[1] * z;
                    }
                    mics += 0.25 * (pl.norm_sqr() + pr.norm_sqr()) * gain * gain / blocks;
                }
            }
        }
        mics
    }
}

impl Partner<'_> {
    /// Its sum at the end of the probe, moved from rest at the strike by
    /// partial `i` of `strings` (as they stand then, run back to the strike as
    /// free modes) over [`PROBE_S`]: the forced answer of its strings in step
    /// (their pole moved by their unison's trade over `h`) to what one
    /// interval of `dt` gives them per second.
    fn since_strike(&self, strings: &[Vec<(Complex64, Complex64)>], i: usize, dt: f64, h: f64) -> Complex64 {
        let in_step = self.lambda + self.in_step.ln() / h;
        let rate = self.count * self.into_theirs / dt;
        strings
            .iter()
            .enumerate()
            .filter(|&(s, _)| self.strings & (1 << s) != 0)
            .map(|(_, s)| {
                let (z, lambda) = s[i];
                let d = lambda - in_step;
                // (e^(lambda P) - e^(in_step P)) / d from z at the strike, z e^(-lambda P).
                let answer = if d.norm() * PROBE_S < 1e-9 {
                    Complex64::new(PROBE_S, 0.0)
                } else {
                    (1.0 - (-d * PROBE_S).exp()) / d
                };
                rate * z * answer
            })
            .sum()
    }
}

/// [`ring_through_body`] for a key whose exciter stays on its strings (a
/// tangent, which shortens them to their speaking length): the strike is
/// played through the whole ring's window and through the running body, and
/// the ring measured on what comes out.
fn ring_played_through_body(key: &mut Key, touch: Touch, body: Body, gain: f64, force: &mut [f64]) -> Weighed {
    let Body { share, soundboard, .. } = body;
    let fs = 1.0 / soundboard.step_s();
    let mut played = vec![0.0; (RING_TO_S * fs) as usize];
    key.probe(touch, &mut played);
    let from = (RING_FROM_S * fs) as usize;
    let n = force.len().min(played.len());
    force[..n].copy_from_slice(&played[..n]);
    let window = &played[from.min(played.len())..];
    // The tangent's held push is a static force the output's DC blocker takes
    // out (and the body does not radiate): the ring is what moves about it.
    let mean = window.iter().sum::<f64>() / window.len().max(1) as f64;
    let bridge = window.iter().map(|f| (f - mean) * (f - mean)).sum::<f64>() / window.len().max(1) as f64;
    let (mut heard, mut counted, mut peak) = (0.0, 0usize, 0.0f64);
    let scale = gain / soundboard.gain();
    let mut listen = |t: usize, l: f64, r: f64| {
        if t < n {
            peak = peak.max(l.abs()).max(r.abs());
        }
        if t >= from {
            heard += 0.5 * (l * l + r * r);
            counted += 1;
        }
    };
    play_board(soundboard, share, &played, scale, Some(&mut listen));
    soundboard.silence();
    Weighed { mics: heard / counted.max(1) as f64, bridge, peak_per_scale: Some(peak / scale) }
}

/// Partials closer than this fraction of their frequency (5 cents: the same
/// partial on the strings of a unison) add as waves; others are taken to add
/// in power over the ring's window (their cross term averages out, and where
/// a tangent holds the string its free modes do not say how they beat).
const COHERENT_WITHIN: f64 = 0.003;

/// The mean of e^(mu t) over `from`..`to`, for a complex rate `mu` (1/s).
fn window_integral(mu: Complex64, from: f64, to: f64) -> Complex64 {
    if mu.norm() * (to - from) < 1e-9 {
        return Complex64::new(1.0, 0.0);
    }
    ((mu * to).exp() - (mu * from).exp()) / (mu * (to - from))
}

/// The indices of the `most` largest of `weights`, largest first (equal ones
/// in their order): each weight worked out once, not at every comparison.
fn strongest(weights: Vec<f64>, most: usize) -> Vec<usize> {
    let mut order: Vec<usize> = (0..weights.len()).collect();
    order.sort_by(|&a, &b| weights[b].total_cmp(&weights[a]));
    order.truncate(most);
    order
}

/// The mean of e^(rate t) over `from`..`to` for a real rate.
fn window_mean(rate: f64, from: f64, to: f64) -> f64 {
    window_integral(Complex64::new(rate, 0.0), from, to).re
}

/// What the body is to one key: the modes it is heard through, the points it
/// bears on and its share of them, and the running body.
struct Body<'a, 'b> {
    heard: &'a Heard<'a>,
    /// The body's modes' shapes where the key bears ([`HeardModes::shapes`]).
    shapes: &'a [f64],
    share: ZoneShare,
    soundboard: &'b mut Soundboard,
    /// The free strings the key sets ringing.
    partners: &'a [Partner<'a>],
}

impl Body<'_, '_> {
    fn reborrow(&mut self) -> Body<'_, '_> {
        Body {
            heard: self.heard,
            shapes: self.shapes,
            share: self.share,
            soundboard: self.soundboard,
            partners: self.partners,
        }
    }
}

/// The body's modes as one key's voicing hears through them: the
/// microphones' transfer at a partial's frequency where a key bears (its
/// own, or a free partner's) is worked out once for all the key's strikes
/// (its strings' partials sound at the same frequencies each time).
struct Heard<'a> {
    modes: &'a HeardModes,
    /// By where the shapes lie and how many (the key's own, or a
    /// partner's), and the frequency's bits.
    found: RefCell<HashMap<(usize, usize, u64), [Complex64; 2]>>,
}

impl<'a> Heard<'a> {
    fn new(modes: &'a HeardModes) -> Self {
        Self { modes, found: RefCell::new(HashMap::new()) }
    }

    /// [`HeardModes::transfer_shaped_pa_per_n`], remembered.
    fn transfer(&self, shapes: &[f64], f_hz: f64) -> [Complex64; 2] {
        *self
            .found
            .borrow_mut()
            .entry((shapes.as_ptr() as usize, shapes.len(), f_hz.to_bits()))
            .or_insert_with(|| self.modes.transfer_shaped_pa_per_n(shapes, f_hz))
    }
}

/// Run the board from rest under `force` spread over `share`'s zones times
/// `scale`, handing `heard` each sample's index and what the two microphones
/// hear then; with no one to hear, the modes only move (as they would).
fn play_board(
    soundboard: &mut Soundboard,
    share: ZoneShare,
    force: &[f64],
    scale: f64,
    mut heard: Option<&mut dyn FnMut(usize, f64, f64)>,
) {
    soundboard.silence();
    let mut zone_forces = [[0.0; CONTROL_BLOCK]; MAX_ZONES];
    let (mut left, mut right) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
    for (c, chunk) in force.chunks(CONTROL_BLOCK).enumerate() {
        for zone in &mut zone_forces {
            zone.fill(0.0);
        }
        for (&z, w) in share.zones.iter().zip(share.weights) {
            for (t, f) in chunk.iter().enumerate() {
                zone_forces[z.min(MAX_ZONES - 1)][t] += f * w * scale;
            }
        }
        let n = chunk.len();
        let Some(heard) = heard.as_mut() else {
            soundboard.drive(&zone_forces, n);
            continue;
        };
        soundboard.process(&zone_forces, &mut left[..n], &mut right[..n]);
        for t in 0..n {
            heard(c * CONTROL_BLOCK + t, left[t], right[t]);
        }
    }
}

/// [`play_board`]'s largest sample in either microphone.
fn run_board(soundboard: &mut Soundboard, share: ZoneShare, force: &[f64], scale: f64) -> f64 {
    let mut peak = 0.0f64;
    play_board(soundboard, share, force, scale, Some(&mut |_, l: f64, r: f64| peak = peak.max(l.abs()).max(r.abs())));
    peak
}

/// The regulation's touches, log-spaced over the instrument's range: a
/// crescendo in velocity steps of 8, its step the unit of
/// [`REGULATION_RISE_DB`]. A key is struck first at every other one (steps
/// of 16), then closer where its ring asks for it.
const REGULATION_TOUCHES: usize = 17;
// (The touches struck first, every other one, end at the hardest.)
const _: () = assert!(REGULATION_TOUCHES % 2 == 1);

/// How many times the touches are halved (from velocity steps of 16 down to
/// steps of one) where the ring between two of them strays by more than
/// [`REGULATION_CLOSER_DB`] from the key's own rise (its median, in
/// proportion to the touches' spacing): a hard strike's spectrum swinging
/// through a partial, not the crescendo's steady climb.
const REGULATION_REFINEMENTS: usize = 4;
const REGULATION_CLOSER_DB: f64 = 1.5;

/// The least rise of the ring from one regulated touch to the next, dB: a
/// margin for what the estimate of the ring from a short probe misses (up to
/// about 2 dB on the top keys, against renders; at 0.75 dB, once the
/// estimate weighed the free strings too, A#7's crescendo fell 0.6 dB from
/// velocity 104 to 112).
const REGULATION_RISE_DB: f64 = 1.0;

/// How an instrument's keys are voiced through its body.
pub(super) struct Voicer<'a> {
    pub board: &'a BodyDesign,
    pub heard_modes: &'a HeardModes,
    /// The body's modes' shapes where each key bears ([`HeardModes::shapes`]),
    /// and each key's free partners ([`partners`]), by MIDI key.
    pub shapes: &'a [Vec<f64>],
    pub partners: &'a [Vec<Partner<'a>>],
    /// The instrument's touches, and the one its level scale is set at.
    pub range: TouchRange,
    pub ringing: Touch,
    /// Whether keys are regulated (not for the bridge-force output).
    pub regulate: bool,
}

impl Voicer<'_> {
    /// Voice `key` (listed under `midi_key`) with `soundboard`, a copy of the
    /// instrument's body: regulate it and return how much louder than its
    /// bridge-force gain it bears on the body ([`voice_through_body`]).
    pub fn voice(&self, key: &mut Key, midi_key: u8, soundboard: &mut Soundboard) -> Voiced {
        let Voicer { board, heard_modes, shapes, partners, range, ringing, regulate } = *self;
        fn at<T>(table: &[Vec<T>], key: u8) -> &[T] {
            table.get(key as usize).map_or(&[], Vec::as_slice)
        }
        let (shapes, partners) = (at(shapes, midi_key), at(partners, midi_key));
        voice_through_body(
            key,
            midi_key,
            (range, ringing),
            (board, heard_modes, shapes, partners),
            soundboard,
            regulate,
        )
    }
}

/// How much louder the body hears `key` than the bridge-force output does, and
/// its regulation. The key is first regulated (see [`regulation`]; only if
/// `regulate`, as the bridge-force output is not); then a
/// strike at `ringing` (the touch the level scale is measured at) is weighed
/// through the body against the ring the bridge-force output would have at the
/// key's ringing gain: so each key rings through the microphones where the
/// instrument's level scale puts it, whatever the body does at its partials.
/// Then its `loudest` strike's first milliseconds through the body (at its
/// regulation) give the cut that would keep them under
/// [`MIC_PEAK_CEILING_DBFS`] (the hammer's push on the bridge, which the
/// bridge-force output caps, reaches the microphones only through the body's
/// response to it); the instrument's [`headroom`] decides from every key's.
fn voice_through_body(
    key: &mut Key,
    midi_key: u8,
    (range, ringing): (TouchRange, Touch),
    (board, heard_modes, shapes, partners): (&BodyDesign, &HeardModes, &[f64], &[Partner]),
    soundboard: &mut Soundboard,
    regulate: bool,
) -> Voiced {
    let fs = 1.0 / soundboard.step_s();
    let mut force = vec![0.0; (PROBE_S * fs) as usize];
    let gain = soundboard.gain();
    let heard = Heard::new(heard_modes);
    let mut body = Body { heard: &heard, shapes, share: board.zone_share(midi_key), soundboard, partners };
    let loudest = range.max();
    let mut top_gain = 1.0;
    let mut rings = Vec::new();
    let mut loudest_peak = None;
    if regulate && !key.stays_on_strings() {
        let Regulation { table, rings: weighed, loudest_peak_per_scale } =
            regulation(key, range, ringing, &mut body, &mut force);
        top_gain = regulated(&table, loudest.value());
        key.regulate(table);
        rings = weighed;
        loudest_peak = loudest_peak_per_scale;
    }
    // (The last strike: the key is left as it leaves it, its regulation's
    // gain 1, which a key the others wake before it is struck rings at.)
    let Weighed { mics: heard, bridge, .. } =
        ring_through_body(key, ringing, body.reborrow(), gain, &mut force, Asked { bridge: true, peak: false });
    let voicing = if heard > 0.0 && bridge > 0.0 { key.body_boost() * (bridge / heard).sqrt() } else { 1.0 };
    let voicing = voicing.clamp(VOICING_RANGE.0, VOICING_RANGE.1);
    // The loudest strike's first milliseconds through the body, at that
    // voicing: as the regulation struck it (the body is linear), or struck here.
    let peak_per_scale = loudest_peak.unwrap_or_else(|| {
        key.probe(loudest, &mut force);
        let peak = run_board(body.soundboard, body.share, &force, 1.0);
        body.soundboard.silence();
        peak
    });
    Voiced { level: voicing, peak: peak_per_scale * voicing * top_gain, rings }
}

/// A key voiced through the body: how much louder than its bridge-force gain
/// it must bear on the body to ring where the level scale puts it, and how
/// loud its loudest strike then peaks there ([`Voiced::peak_cut`]).
#[derive(Clone, Debug)]
pub(super) struct Voiced {
    pub level: f64,
    /// The loudest strike's peak through the body at `level`, full scale.
    pub peak: f64,
    /// Its ring power through the body by touch, before its regulation
    /// (empty: not regulated).
    pub rings: Vec<(f64, f64)>,
}

impl Voiced {
    /// What its peak allows of its level: the cut that keeps the loudest
    /// strike under [`MIC_PEAK_CEILING_DBFS`] (1: all of it).
    pub fn peak_cut(&self) -> f64 {
        let ceiling = 10f64.powf(MIC_PEAK_CEILING_DBFS / 20.0);
        if self.peak > ceiling { ceiling / self.peak } else { 1.0 }
    }

    /// Bear on the body at `level` instead (its peak scales with it).
    pub fn relevel(&mut self, level: f64) {
        self.peak *= level / self.level.max(f64::MIN_POSITIVE);
        self.level = level;
    }
}

/// The share of keys whose peak sets the instrument's headroom: the rest are
/// turned down further, each by its own peak.
const HEADROOM_QUANTILE: f64 = 0.85;

/// The instrument's headroom through the body, as a gain (at most 1): the
/// cut that [`HEADROOM_QUANTILE`] of its keys need no more than. A recording
/// engineer sets one gain for the instrument so that its loud keys fit; every
/// key is turned down by it, so that keys whose loudest strike peaks higher
/// than their ring would suggest (a hard strike's knock) do not stand out
/// below their neighbours. The few whose peak needs more are turned down by
/// their own (the top octave's knock).
pub(super) fn headroom(cuts: &[f64]) -> f64 {
    let mut cuts = cuts.to_vec();
    cuts.sort_by(f64::total_cmp);
    // Sorted from the deepest cut: the quantile's key from the shallow end.
    let index = ((1.0 - HEADROOM_QUANTILE) * cuts.len() as f64).floor() as usize;
    cuts.get(index.min(cuts.len().saturating_sub(1))).copied().unwrap_or(1.0).min(1.0)
}
