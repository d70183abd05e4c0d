//! Sympathetic strings: every string on the body is moved by the bridge
//! under the others, so a partial of one key sets ringing the partials of
//! other keys near it in pitch, when their dampers are off (the pedal down,
//! the keys held, the top keys that have none, a dulcimer's or santoor's
//! courses).
//!
//! Between two keys' partials the board is a transfer admittance Y_ab(f)
//! ([`BoardLoad::transfer`]): a partial of key b with summed force phasor M_b
//! moves key a's bridge point at Y_ab M_b, which moves each of a's strings'
//! phasors for that partial by -c_a Y_ab M_b per second (c_a its reach,
//! [`BoardLoad::reach`]). Only the strings' mean is moved, and only the mean
//! moves the bridge: a unison's out-of-step strings neither drive nor are
//! driven (Weinreich's aftersound stays its own).
//!
//! Every [`TRADE_BLOCKS`] control blocks each pair of partials trades what
//! that drive gives over the interval, taking the other's free motion over it
//! as exact: key a's partial gains -c_a Y_ab M_b (e^((lambda_a - lambda_b) h)
//! - 1) / (lambda_a - lambda_b), the forced response of its pole to the
//! other's. Partials far apart in pitch barely answer; only pairs within
//! [`WINDOW_HZ`] are kept, and pairs whose answer stays under [`NEGLIGIBLE`].
//!
//! The trade is two-way, so energy leaves the driving string as it should,
//! and kept passive: in the strings' energy measure each partial gives away
//! per interval at most [`PASSIVE_SHARE`] of what it loses into the board
//! itself in that time, the coupling scaled down where it would give more
//! (diagonal dominance of the step: the keyboard's trading can only lose
//! energy, however many keys ring together).

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use num_complex::Complex64;

use crate::body::load::BoardLoad;
use crate::key::{Key, Port};

/// Partials further apart than this are not paired, Hz (the forced answer of
/// a partial 30 Hz off is under -40 dB of the driving one's share).
const WINDOW_HZ: f64 = 30.0;

/// A pair whose per-interval answer, in the strings' energy measure, is under
/// this fraction is dropped (-80 dB).
const NEGLIGIBLE: f64 = 1e-4;

/// Each partial gives the others at most this share of what it loses into the
/// board by itself over an interval.
const PASSIVE_SHARE: f64 = 0.9;

#[derive(Clone, Copy, Debug)]
struct Pair {
    a: u8,
    b: u8,
    strings_a: u8,
    strings_b: u8,
    i: u16,
    j: u16,
    /// What one interval adds to each of a's strings per unit of b's summed
    /// phasor, and the other way.
    into_a: Complex64,
    into_b: Complex64,
}

/// The pairs of partials that trade through the body, and for each key the
/// pairs it is in.
pub(crate) struct Sympathy {
    pairs: Vec<Pair>,
    by_key: Vec<Vec<u32>>,
}

/// A key's partial in the list sorted by pitch.
struct Entry<'a> {
    key: u8,
    port: &'a Port,
    /// Strings that sound it.
    count: f64,
}

impl Sympathy {
    /// No trading (strings on the seed's rigid bridge).
    pub fn none() -> Self {
        Self { pairs: Vec::new(), by_key: vec![Vec::new(); 128] }
    }

    /// The pairs of `keys`' partials (each key's [`Key::ports`]) that trade
    /// through `load`'s board, for intervals of `step_s`. Allocates; off the
    /// audio thread.
    pub fn build(load: &BoardLoad, keys: &[Option<Key>], step_s: f64) -> Self {
        let mut entries: Vec<Entry> = keys
            .iter()
            .flatten()
            .flat_map(|k| {
                k.ports().iter().map(|port| Entry { key: k.midi_key(), port, count: port.strings.count_ones() as f64 })
            })
            .collect();
        entries.sort_by(|p, q| p.port.f_hz.total_cmp(&q.port.f_hz));
        let shapes: Vec<Option<Vec<f64>>> =
            (0..128u8).map(|k| keys.get(k as usize).and_then(Option::as_ref).map(|_| load.shapes(k))).collect();
        let mut pairs = Vec::new();
        for (x, ea) in entries.iter().enumerate() {
            for eb in entries.iter().skip(x + 1) {
                if eb.port.f_hz - ea.port.f_hz > WINDOW_HZ {
                    break;
                }
                if eb.key == ea.key {
                    continue;
                }
                let (Some(Some(sa)), Some(Some(sb))) = (shapes.get(ea.key as usize), shapes.get(eb.key as usize)) else {
                    continue;
                };
                let (pa, pb) = (ea.port, eb.port);
                let mut y_ab = load.transfer(sa, sb, 0.5 * (pa.f_hz + pb.f_hz));
                // In the strings' energy measure the pair couples at
                // sqrt(N_a c_a N_b c_b) Y_ab, which a passive board holds
                // under the root of what each loses into it alone.
                let norm = (ea.count * pa.reach * eb.count * pb.reach).sqrt();
                let bound = PASSIVE_SHARE * (ea.count * pa.loss_s * eb.count * pb.loss_s).sqrt();
                if norm * y_ab.norm() > bound {
                    y_ab *= bound / (norm * y_ab.norm());
                }
                let answer = |from: &Port, to: &Port| {
                    let d = (to.lambda - from.lambda) * step_s;
                    if d.norm() < 1e-9 { Complex64::new(step_s, 0.0) } else { (d.exp() - 1.0) / (to.lambda - from.lambda) }
                };
                let (to_a, to_b) = (answer(pb, pa), answer(pa, pb));
                if !(norm * y_ab.norm() * to_a.norm().max(to_b.norm()) > NEGLIGIBLE) {
                    continue;
                }
                pairs.push(Pair {
                    a: ea.key,
                    b: eb.key,
                    strings_a: pa.strings,
                    strings_b: pb.strings,
                    i: pa.partial as u16,
                    j: pb.partial as u16,
                    into_a: -to_a * y_ab * pa.reach,
                    into_b: -to_b * y_ab * pb.reach,
                });
            }
        }
        let mut by_key = vec![Vec::new(); 128];
        for (n, p) in pairs.iter().enumerate() {
            by_key[p.a as usize].push(n as u32);
            by_key[p.b as usize].push(n as u32);
        }
        Self { pairs, by_key }
    }

    /// How many pairs of partials trade.
    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    /// One interval of trading among `keys` at `level` (0..=1 of the
    /// physics), the sustain pedal at `sustain`, the pitch bent by `bend`;
    /// a silent key is woken only by what it would not fall silent from at
    /// once (`silence`, full scale). Allocates: no.
    pub fn trade(&self, keys: &mut [Option<Key>], level: f64, sustain: f64, bend: f64, silence: f64) {
        if level <= 0.0 || self.pairs.is_empty() {
            return;
        }
        let level = level.min(1.0);
        let mut sounding = [false; 128];
        for (k, key) in keys.iter().enumerate().take(128) {
            sounding[k] = key.as_ref().is_some_and(Key::is_sounding);
        }
        for k in 0..sounding.len() {
            if !sounding[k] {
                continue;
            }
            for &n in self.by_key.get(k).map_or(&[][..], Vec::as_slice) {
                let Some(p) = self.pairs.get(n as usize) else { continue };
                // A pair of two sounding keys trades once, from its first key.
                let other = if p.a as usize == k { p.b } else { p.a } as usize;
                if sounding[other] && other < k {
                    continue;
                }
                let (lo, hi) = (p.a.min(p.b) as usize, p.a.max(p.b) as usize);
                if hi >= keys.len() {
                    continue;
                }
                let (head, tail) = keys.split_at_mut(hi);
                let (Some(Some(first)), Some(Some(second))) = (head.get_mut(lo), tail.first_mut()) else { continue };
                let (ka, kb) = if p.a < p.b { (first, second) } else { (second, first) };
                let (ma, mb) = (ka.partial_sum(p.strings_a, p.i as usize), kb.partial_sum(p.strings_b, p.j as usize));
                let (da, db) = (p.into_a * mb * level, p.into_b * ma * level);
                if da.re != 0.0 || da.im != 0.0 {
                    ka.drive_partial(p.strings_a, p.i as usize, da, sustain, bend, silence);
                }
                if db.re != 0.0 || db.im != 0.0 {
                    kb.drive_partial(p.strings_b, p.j as usize, db, sustain, bend, silence);
                }
            }
        }
    }
}
