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
//! Every [`crate::key::SYMPATHY_BLOCKS`] control blocks each pair of partials trades what
//! that drive gives over the interval, taking the other's free motion over it
//! as exact: key a's partial gains -c_a Y_ab M_b times
//! (e^((lambda_a - lambda_b) h) - 1) / (lambda_a - lambda_b), the forced
//! response of its pole to the other's. Partials far apart in pitch barely answer; only pairs within
//! [`WINDOW_HZ`] are kept, and pairs whose answer stays under [`NEGLIGIBLE`].
//! The work is spread over the interval: each block one in
//! [`crate::key::SYMPATHY_BLOCKS`] of the keys take what their sounding
//! partners' partials give them over an interval (every partial of each
//! partner summed over its strings first, a key at a time), each of
//! their partials once; a silent key takes it only if its damper is off, and
//! wakes only for a drive it would not fall silent from.
//!
//! Each key is heard at its own gain ([`Key::heard_per_n`]: its voicing on
//! the body, the regulation of its last strike), so what b hands a is
//! weighed by b's gain over a's, and what a hands b by the inverse: a partial
//! is heard in the other key as loud as the physics moves it, and the pair's
//! loop (the product of the two) is the unweighed one, as stable as before
//! (the weighing is a change of each key's unit).
//!
//! The trade is two-way (each key of a pair takes from the other at its own
//! block of the interval), so energy leaves the driving string as it should.
//! A passive board's transfer admittance is bounded by its drive-point ones
//! (|Y_ab|^2 <= Re Y_aa Re Y_bb for a single mode, and so near a resonance):
//! in the strings' energy measure each pair is held under [`PASSIVE_SHARE`]
//! of the root of what each loses into the board alone. The whole keyboard
//! struck at once with the pedal down only ever dies away (a test), and
//! halving the interval moves the measured difference the pedal makes by
//! 1.3 dB (see [`crate::key::SYMPATHY_BLOCKS`]).

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use num_complex::Complex64;

use crate::body::load::BoardLoad;
use crate::key::{Key, Port};
use crate::performance::PerformanceState;

/// Partials further apart than this are not paired, Hz (the forced answer of
/// a partial 30 Hz off is under -40 dB of the driving one's share).
const WINDOW_HZ: f64 = 30.0;

/// A pair whose per-interval answer, in the strings' energy measure, is under
/// this fraction is dropped (-50 dB). With the bridge carrying the treble's
/// motion along itself, about twice as many pairs pass -60 dB (30133 on the
/// piano against 15762), for twice the trading's work; the pedal's measured
/// difference moves by 0.9 dB between the two.
const NEGLIGIBLE: f64 = 3e-3;

/// Each partial gives the others at most this share of what it loses into the
/// board by itself over an interval.
const PASSIVE_SHARE: f64 = 0.9;

/// What a partial may take from all its partners over an interval, with what
/// it loses by itself there, in the strings' energy measure (see
/// [`hold_within_budget`]): half of the explicit step's limit of 2.
const ROW_BUDGET: f64 = 1.0;

/// A pair of partials as one of its keys meets it ([`Sympathy::pairs_of`]).
#[derive(Clone, Copy, Debug)]
pub(crate) struct PairOf {
    /// This key's partial and the strings (bit i: string i) that sound it.
    pub partial: usize,
    pub strings: u8,
    /// The other key, its partial, its strings and the partial's pole, s^-1.
    pub other: u8,
    pub other_partial: usize,
    pub other_strings: u8,
    pub other_pole: Complex64,
    /// What one interval adds to each of this key's strings per unit of the
    /// other's summed phasor, and to each of the other's per unit of this
    /// key's (both in the keys' own units: weighed by their gains as
    /// [`Sympathy::trade`] weighs them, they are heard as the physics has it).
    pub into_mine: Complex64,
    pub into_theirs: Complex64,
}

/// A pair of partials as one of its keys takes from the other.
#[derive(Clone, Copy, Debug)]
struct Link {
    /// This key's partial and the other's ([`Sympathy::slots`]).
    mine: u32,
    theirs: u32,
    /// What one interval adds to each of this partial's strings per unit of
    /// the other's summed phasor.
    into_mine: Complex64,
}

#[derive(Clone, Copy, Debug)]
struct Pair {
    /// The two partials ([`Sympathy::slots`]) and their keys.
    a: u32,
    b: u32,
    key_a: u8,
    key_b: u8,
    /// What one interval adds to each of a's strings per unit of b's summed
    /// phasor, and the other way.
    into_a: Complex64,
    into_b: Complex64,
}

/// A partial of a key's strings that trades: where it is.
#[derive(Clone, Copy, Debug)]
struct Slot {
    key: u8,
    strings: u8,
    partial: u16,
}

/// The pairs of partials that trade through the body, for each key the pairs
/// it is in, every partial's slot, and the scratch of a trade: each slot's
/// summed phasor and what it takes.
pub(crate) struct Sympathy {
    /// How many pairs there are.
    count: usize,
    /// The largest share of [`ROW_BUDGET`] a partial's pairs asked for
    /// ([`hold_within_budget`]): over 1, they were scaled down to it.
    budget_used: f64,
    /// For each key, every pair it is in as it takes from the other key (a
    /// [`Link`]), in the order of the other key: a trade reads a key's pairs
    /// one after the other (looked up through a list of indices, each pair
    /// was a miss of the cache, a fifth of a pedalled render's time).
    by_key: Vec<Vec<Link>>,
    /// For each key, its pairs grouped by the other key: (other, range in
    /// `by_key[key]`), so that the pairs with a key that is not sounding (it
    /// gives nothing) are passed over together.
    by_other: Vec<Vec<(u8, u32, u32)>>,
    slots: Vec<Slot>,
    /// Each slot's strings and partial, as [`Key::partial_sums`] reads them.
    ports: Vec<(u8, u16)>,
    sums: Vec<Complex64>,
    takes: Vec<Complex64>,
    /// Each key's slots (they lie in key order), and whether they are its
    /// strings' first partials in order, all of the same strings.
    key_slots: Vec<(u32, u32)>,
    firsts: Vec<bool>,
    /// What a silent key's partial has been given and not yet taken (too
    /// little to wake it so far), per slot, as it stands at block `given_at`;
    /// the slots holding some, and each slot's pole to carry it on with.
    held: Vec<Complex64>,
    given_at: Vec<u64>,
    holding: Vec<u32>,
    poles: Vec<Complex64>,
    /// Blocks traded so far, and a block's length, s.
    block: u64,
    block_s: f64,
}

/// A copy as it stands, with the room its list of slots holding some has
/// (what the audio thread pushes into never grows: a slot that finds it full
/// is not held, so a copy with less room would trade differently).
impl Clone for Sympathy {
    fn clone(&self) -> Self {
        let mut holding = Vec::with_capacity(self.holding.capacity());
        holding.extend_from_slice(&self.holding);
        Self {
            count: self.count,
            budget_used: self.budget_used,
            by_key: self.by_key.clone(),
            by_other: self.by_other.clone(),
            slots: self.slots.clone(),
            ports: self.ports.clone(),
            sums: self.sums.clone(),
            takes: self.takes.clone(),
            key_slots: self.key_slots.clone(),
            firsts: self.firsts.clone(),
            held: self.held.clone(),
            given_at: self.given_at.clone(),
            holding,
            poles: self.poles.clone(),
            block: self.block,
            block_s: self.block_s,
        }
    }
}

/// A key's partial, as the pairs are found.
struct Entry<'a> {
    key: u8,
    port: &'a Port,
    /// Strings that sound it.
    count: f64,
}

impl Sympathy {
    /// No trading (strings on the seed's rigid bridge).
    pub fn none() -> Self {
        Self {
            count: 0,
            budget_used: 0.0,
            by_key: vec![Vec::new(); 128],
            by_other: vec![Vec::new(); 128],
            slots: Vec::new(),
            ports: Vec::new(),
            sums: Vec::new(),
            takes: Vec::new(),
            key_slots: vec![(0, 0); 128],
            firsts: vec![false; 128],
            held: Vec::new(),
            given_at: Vec::new(),
            holding: Vec::new(),
            poles: Vec::new(),
            block: 0,
            block_s: 0.0,
        }
    }

    /// The pairs of `keys`' partials (each key's [`Key::ports`]) that trade
    /// through `load`'s board, for intervals of `step_s`. Allocates; off the
    /// audio thread.
    pub fn build(load: &BoardLoad, keys: &[Option<Key>], step_s: f64) -> Self {
        // Every partial in key order (its slot), then by pitch to pair them.
        let entries: Vec<Entry> = keys
            .iter()
            .flatten()
            .flat_map(|k| {
                k.ports().iter().map(|port| Entry { key: k.midi_key(), port, count: port.strings.count_ones() as f64 })
            })
            .collect();
        let mut by_pitch: Vec<usize> = (0..entries.len()).collect();
        by_pitch.sort_by(|&p, &q| entries[p].port.f_hz.total_cmp(&entries[q].port.f_hz));
        let shapes: Vec<Option<Vec<f64>>> =
            (0..128u8).map(|k| keys.get(k as usize).and_then(Option::as_ref).map(|_| load.shapes(k))).collect();
        // The pairs each partial makes with those above it, in pitch order;
        // stretches of partials are shared out over the cores and their
        // pairs joined in the same order.
        let pairs_above = |x: usize, pairs: &mut Vec<Pair>| {
            let ia = by_pitch[x];
            let ea = &entries[ia];
            for &ib in &by_pitch[x + 1..] {
                let eb = &entries[ib];
                if eb.port.f_hz - ea.port.f_hz > WINDOW_HZ {
                    break;
                }
                if eb.key == ea.key {
                    continue;
                }
                let (Some(Some(sa)), Some(Some(sb))) = (shapes.get(ea.key as usize), shapes.get(eb.key as usize))
                else {
                    continue;
                };
                let (pa, pb) = (ea.port, eb.port);
                let mut y_ab = load.transfer(sa, sb, (ea.key, eb.key), 0.5 * (pa.f_hz + pb.f_hz));
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
                    if d.norm() < 1e-9 {
                        Complex64::new(step_s, 0.0)
                    } else {
                        (d.exp() - 1.0) / (to.lambda - from.lambda)
                    }
                };
                let (to_a, to_b) = (answer(pb, pa), answer(pa, pb));
                if !(norm * y_ab.norm() * to_a.norm().max(to_b.norm()) > NEGLIGIBLE) {
                    continue;
                }
                pairs.push(Pair {
                    a: ia as u32,
                    b: ib as u32,
                    key_a: ea.key,
                    key_b: eb.key,
                    into_a: -to_a * y_ab * pa.reach,
                    into_b: -to_b * y_ab * pb.reach,
                });
            }
        };
        let mut pairs = crate::cores::in_stretches(by_pitch.len(), &pairs_above);
        let budget_used = hold_within_budget(&mut pairs, &entries, step_s);
        let mut by_key: Vec<Vec<u32>> = vec![Vec::new(); 128];
        for (n, p) in pairs.iter().enumerate() {
            by_key[p.key_a as usize].push(n as u32);
            by_key[p.key_b as usize].push(n as u32);
        }
        let other = |k: usize, n: u32| {
            let p = &pairs[n as usize];
            if p.key_a as usize == k { p.key_b } else { p.key_a }
        };
        let mut by_other = vec![Vec::new(); 128];
        for (k, list) in by_key.iter_mut().enumerate() {
            // Stable: each other key's pairs keep their order.
            list.sort_by_key(|&n| other(k, n));
            let mut start = 0;
            while start < list.len() {
                let o = other(k, list[start]);
                let end = start + list[start..].iter().take_while(|&&n| other(k, n) == o).count();
                by_other[k].push((o, start as u32, end as u32));
                start = end;
            }
        }
        let slots: Vec<Slot> = entries
            .iter()
            .map(|e| Slot { key: e.key, strings: e.port.strings, partial: e.port.partial as u16 })
            .collect();
        let n = slots.len();
        let by_key = by_key
            .iter()
            .enumerate()
            .map(|(k, list)| {
                let link = |p: &Pair| match p.key_a as usize == k {
                    true => Link { mine: p.a, theirs: p.b, into_mine: p.into_a },
                    false => Link { mine: p.b, theirs: p.a, into_mine: p.into_b },
                };
                list.iter().map(|&n| link(&pairs[n as usize])).collect()
            })
            .collect();
        let mut key_slots = vec![(0, 0); 128];
        for (i, slot) in slots.iter().enumerate() {
            let range: &mut (u32, u32) = &mut key_slots[slot.key as usize];
            if range.0 == range.1 {
                *range = (i as u32, i as u32);
            }
            range.1 = i as u32 + 1;
        }
        let firsts = key_slots
            .iter()
            .map(|&(from, to)| {
                let ports = &slots[from as usize..to as usize];
                ports.iter().enumerate().all(|(n, p)| p.partial as usize == n && p.strings == ports[0].strings)
            })
            .collect();
        Self {
            count: pairs.len(),
            budget_used,
            firsts,
            by_key,
            by_other,
            ports: slots.iter().map(|s| (s.strings, s.partial)).collect(),
            slots,
            sums: vec![Complex64::new(0.0, 0.0); n],
            takes: vec![Complex64::new(0.0, 0.0); n],
            key_slots,
            held: vec![Complex64::new(0.0, 0.0); n],
            given_at: vec![0; n],
            holding: Vec::with_capacity(n),
            poles: entries.iter().map(|e| e.port.lambda).collect(),
            block: 0,
            block_s: step_s / crate::key::SYMPATHY_BLOCKS as f64,
        }
    }

    /// How many pairs of partials trade.
    pub fn len(&self) -> usize {
        self.count
    }

    /// The largest share of the explicit trade's budget a partial asks for
    /// ([`hold_within_budget`]; over 1 its pairs were scaled down).
    pub fn budget_used(&self) -> f64 {
        self.budget_used
    }

    /// Every pair key `k` is in, as `k` meets it: its partial and the other's,
    /// and what one interval adds each way. Allocates; off the audio thread.
    pub fn pairs_of(&self, k: u8) -> Vec<PairOf> {
        let k = k as usize;
        let Some(links) = self.by_key.get(k) else {
            return Vec::new();
        };
        links
            .iter()
            .filter_map(|link| {
                let (mine, theirs) = (self.slots[link.mine as usize], self.slots[link.theirs as usize]);
                // The other key's side of the same pair, among its pairs with this key.
                let other = theirs.key as usize;
                let &(_, from, to) = self.by_other[other].iter().find(|&&(o, _, _)| o as usize == k)?;
                let back = self.by_key[other][from as usize..to as usize]
                    .iter()
                    .find(|l| l.mine == link.theirs && l.theirs == link.mine)?;
                Some(PairOf {
                    partial: mine.partial as usize,
                    strings: mine.strings,
                    other: theirs.key,
                    other_partial: theirs.partial as usize,
                    other_strings: theirs.strings,
                    other_pole: self.poles[link.theirs as usize],
                    into_mine: link.into_mine,
                    into_theirs: back.into_mine,
                })
            })
            .collect()
    }

    /// One block's share of the trading among `keys` at `level` (0..=1 of
    /// the physics), the pedals and the bend where `performance` has them;
    /// a silent key is woken only by what it would not fall silent from at
    /// once (`silence`, full scale). The keys whose number is `phase` modulo
    /// [`crate::key::SYMPATHY_BLOCKS`] and that may ring take what their
    /// sounding partners' partials give them over an interval (each
    /// partner's partials summed once a call, a key at a time: taken pair by
    /// pair as the pairs needed them, the reads of each string's tables
    /// were half of the trading's time), so every pair trades both ways
    /// once an interval, the work spread over its blocks, and each partial
    /// is moved once an interval. (Each pair traded both ways at once, a
    /// partial was moved by each of its partners' keys at their own blocks:
    /// up to eight times an interval, and the pedalled nocturne rendered at
    /// 8.6-11x real time against 14-16x.) Allocates: no.
    pub fn trade(
        &mut self,
        keys: &mut [Option<Key>],
        level: f64,
        performance: &PerformanceState,
        silence: f64,
        phase: usize,
    ) {
        self.block += 1;
        if level <= 0.0 || self.count == 0 {
            self.drop_held();
            return;
        }
        self.hand_on_held(keys, performance, silence);
        let level = level.min(1.0);
        // The keys due this block that may ring, and whether any key sounds.
        let mut sounding = [false; 128];
        for (k, key) in keys.iter().enumerate().take(128) {
            sounding[k] = key.as_ref().is_some_and(Key::is_sounding);
        }
        let mut taking = [false; 128];
        for k in (phase..128.min(keys.len())).step_by(crate::key::SYMPATHY_BLOCKS) {
            taking[k] = sounding[k] || keys[k].as_ref().is_some_and(|key| key.rings_free(performance));
        }
        if !sounding.contains(&true) || !taking.contains(&true) {
            return;
        }
        // What each key's newton is heard at, and its inverse.
        let mut heard = [1.0f64; 128];
        let mut unheard = [1.0f64; 128];
        for (k, key) in keys.iter().enumerate().take(128) {
            if let Some(h) = key.as_ref().map(Key::heard_per_n).filter(|h| h.is_finite() && *h > 0.0) {
                (heard[k], unheard[k]) = (h, 1.0 / h);
            }
        }
        // The summed phasors of every partial of the sounding keys that give
        // to a taking one, a key at a time...
        let mut giving = [false; 128];
        for k in (0..128).filter(|&k| taking[k]) {
            for &(other, _, _) in &self.by_other[k] {
                giving[other as usize] |= sounding[other as usize];
            }
        }
        for (k, key) in keys.iter().enumerate().take(128).filter(|&(k, _)| giving[k]) {
            let (from, to) = self.key_slots[k];
            if let Some(key) = key {
                let (ports, sums) =
                    (&self.ports[from as usize..to as usize], &mut self.sums[from as usize..to as usize]);
                key.partial_sums(ports, self.firsts[k], sums);
            }
        }
        // ...then every taking key's partials gather what they give (all
        // read before any is moved)...
        for k in (0..128).filter(|&k| taking[k]) {
            let links = &self.by_key[k];
            for &(other, from, to) in &self.by_other[k] {
                let other = other as usize;
                if !sounding[other] {
                    continue;
                }
                let weigh = heard[other] * unheard[k];
                for p in &links[from as usize..to as usize] {
                    let sum = self.sums[p.theirs as usize];
                    self.takes[p.mine as usize] += p.into_mine * (sum * weigh);
                }
            }
        }
        // ...and take it (with what they were given before and could not
        // take), cleared. A silent key too little moved to wake holds what
        // it was given, ringing on with it.
        for k in (0..128).filter(|&k| taking[k]) {
            let (from, to) = self.key_slots[k];
            let Some(Some(key)) = keys.get_mut(k) else {
                self.takes[from as usize..to as usize].fill(Complex64::new(0.0, 0.0));
                continue;
            };
            let rings = key.rings_free(performance);
            for i in from as usize..to as usize {
                let take = std::mem::take(&mut self.takes[i]);
                if take.re == 0.0 && take.im == 0.0 {
                    continue;
                }
                let drive = self.carried(i) + take * level;
                let slot = self.slots[i];
                if key.drive_partial(slot.strings, slot.partial as usize, drive, performance, silence) {
                    self.held[i] = Complex64::new(0.0, 0.0);
                } else if rings {
                    self.hold(i, drive);
                } else {
                    self.held[i] = Complex64::new(0.0, 0.0);
                }
            }
        }
    }

    /// Slot `i`'s held drive carried on to this block by its pole (as built,
    /// unbent, like the pairs' answers: the trade does not follow a bend).
    fn carried(&self, i: usize) -> Complex64 {
        let z = self.held[i];
        if z.re == 0.0 && z.im == 0.0 {
            return z;
        }
        z * (self.poles[i] * ((self.block - self.given_at[i]) as f64 * self.block_s)).exp()
    }

    fn hold(&mut self, i: usize, z: Complex64) {
        let was = self.held[i];
        if was.re == 0.0 && was.im == 0.0 && self.holding.len() < self.holding.capacity() {
            self.holding.push(i as u32);
        }
        self.held[i] = z;
        self.given_at[i] = self.block;
    }

    /// Held drives go to keys that have started sounding since (struck, or
    /// woken through another partial); those whose key's damper came down,
    /// or that have died away under a thousandth of what wakes a key, are
    /// dropped.
    fn hand_on_held(&mut self, keys: &mut [Option<Key>], performance: &PerformanceState, silence: f64) {
        let mut j = 0;
        while j < self.holding.len() {
            let i = self.holding[j] as usize;
            let z = self.carried(i);
            let slot = self.slots[i];
            let keep = match keys.get_mut(slot.key as usize) {
                Some(Some(key)) if key.is_sounding() => {
                    key.drive_partial(slot.strings, slot.partial as usize, z, performance, silence);
                    false
                }
                Some(Some(key)) => key.rings_free(performance) && key.would_wake(z * 1e3, silence),
                _ => false,
            };
            if keep && !(self.held[i].re == 0.0 && self.held[i].im == 0.0) {
                j += 1;
            } else {
                self.held[i] = Complex64::new(0.0, 0.0);
                self.holding.swap_remove(j);
            }
        }
    }

    pub(crate) fn drop_held(&mut self) {
        for &i in &self.holding {
            self.held[i as usize] = Complex64::new(0.0, 0.0);
        }
        self.holding.clear();
    }
}

/// Hold what the pairs hand each partial over an interval within what the
/// explicit trade can carry: in the strings' energy measure, what a partial
/// takes from all its partners over an interval, with what it loses there by
/// itself (its unison's mean: its own pole and the pull of its fellow
/// strings), stays under [`ROW_BUDGET`]. A passive board couples the
/// partials with a positive semi-definite matrix K; the interval's step is
/// then about 1 - h K, whose eigenvalues stay within the unit circle while
/// h K's largest, which no row's sum exceeds, stays under 2. Where several
/// keys' partials meet at one pitch (a scale with steps of a few cents puts
/// dozens of keys there) their common motion drains into the board dozens of
/// times as fast as one, faster than an interval can follow: each pair is
/// then scaled down by the smaller of its two partials' factors (the pair
/// stays symmetric, and a passive K scaled off its diagonal so stays
/// passive). Equal temperament uses at most 0.7 of the budget on every
/// instrument (a test), so its pairs are never touched.
/// Returns the largest share of the budget a partial asked for.
fn hold_within_budget(pairs: &mut [Pair], entries: &[Entry], step_s: f64) -> f64 {
    // Each pair's kicks in the energy measure: into a per unit of b's
    // summed phasor, times sqrt(N_a N_b c_b / c_a) (see the module's notes).
    let kick = |into: Complex64, to: &Entry, from: &Entry| {
        let (c_to, c_from) = (to.port.reach, from.port.reach);
        if !(c_to > 0.0 && c_from > 0.0) {
            return 0.0;
        }
        into.norm() * (to.count * from.count * c_from / c_to).sqrt()
    };
    let mut taken = vec![0.0f64; entries.len()];
    for p in pairs.iter() {
        let (a, b) = (&entries[p.a as usize], &entries[p.b as usize]);
        taken[p.a as usize] += kick(p.into_a, a, b);
        taken[p.b as usize] += kick(p.into_b, b, a);
    }
    let mut used = 0.0f64;
    let factor: Vec<f64> = entries
        .iter()
        .zip(&taken)
        .map(|(e, &taken)| {
            let kept = ((e.port.lambda.re - (e.count - 1.0) * e.port.loss_s) * step_s).exp();
            used = used.max((taken + 1.0 - kept) / ROW_BUDGET);
            let room = ROW_BUDGET - (1.0 - kept);
            if taken > room { (room / taken).max(0.0) } else { 1.0 }
        })
        .collect();
    for p in pairs.iter_mut() {
        let f = factor[p.a as usize].min(factor[p.b as usize]);
        if f < 1.0 {
            p.into_a *= f;
            p.into_b *= f;
        }
    }
    used
}

#[cfg(test)]
mod tests {
    use num_complex::Complex64;

    use crate::design::InstrumentKind;
    use crate::synth::{Event, Instrument, Synth, TimedEvent, default_settings};

    #[test]
    fn each_pair_is_met_from_both_its_keys() {
        // What a key's side of a pair says the other takes is what the
        // other's side says it takes itself.
        let instrument = Instrument::build(&default_settings(InstrumentKind::Piano, 48_000.0)).unwrap();
        let (synth, _) = Synth::new(Box::new(instrument));
        let sympathy = &synth.current.sympathy;
        let mut met = 0;
        for k in 21..=108u8 {
            for pair in sympathy.pairs_of(k) {
                let back = sympathy
                    .pairs_of(pair.other)
                    .into_iter()
                    .find(|b| b.other == k && b.partial == pair.other_partial && b.other_partial == pair.partial)
                    .unwrap();
                assert_eq!((back.into_mine, back.into_theirs), (pair.into_theirs, pair.into_mine));
                assert_eq!((back.strings, back.other_strings), (pair.other_strings, pair.strings));
                met += 1;
            }
        }
        assert_eq!(met, 2 * sympathy.len());
    }

    #[test]
    fn equal_temperament_stays_within_the_trades_budget() {
        // The budget only holds scales that crowd partials together: no
        // instrument in equal temperament comes near it.
        for kind in InstrumentKind::ALL {
            let instrument = Instrument::build(&default_settings(kind, 48_000.0)).unwrap();
            let used = instrument.sympathy.budget_used();
            assert!(used < 0.75, "{kind}: {used:.3} of the budget");
        }
    }

    #[test]
    fn a_key_a_cent_from_the_next_is_held_within_the_budget() {
        // Eighty-eight keys within 88 cents: dozens of partners at each
        // partial, asking for far more than an interval can carry.
        use crate::tuning::{ScalaScale, Temperament, TuningSettings};
        let mut settings = default_settings(InstrumentKind::Piano, 48_000.0);
        let scale = ScalaScale::parse("! c\ncents\n1\n!\n1.0\n").unwrap();
        settings.tuning =
            TuningSettings { temperament: Temperament::Scala, scale: Some(scale), ..TuningSettings::default() };
        let instrument = Instrument::build(&settings).unwrap();
        assert!(instrument.sympathy.budget_used() > 2.0, "{}", instrument.sympathy.budget_used());
    }

    #[test]
    fn a_keys_partials_sum_the_same_read_as_one_run() {
        // The trade reads a key's first partials as one run of each string's
        // modes; read one by one they are the same to the bit.
        let instrument = Instrument::build(&default_settings(InstrumentKind::Piano, 48_000.0)).unwrap();
        let (mut synth, _) = Synth::new(Box::new(instrument));
        let mut events = vec![TimedEvent::new(0, Event::Sustain(1.0))];
        events.extend((21..=108u8).step_by(5).map(|key| TimedEvent::new(0, Event::NoteOn { key, velocity: 0.8 })));
        let (mut l, mut r) = (vec![0.0f32; 4800], vec![0.0f32; 4800]);
        synth.process(&events, &mut l, &mut r);
        let current = &*synth.current;
        let sympathy = &current.sympathy;
        let mut checked = 0;
        for (k, key) in current.keys.iter().enumerate() {
            let Some(key) = key.as_ref().filter(|key| key.is_sounding()) else { continue };
            let (from, to) = sympathy.key_slots[k];
            let ports = &sympathy.ports[from as usize..to as usize];
            assert!(sympathy.firsts[k], "key {k}'s ports are its first partials");
            let (mut run, mut each) =
                (vec![Complex64::new(9.0, 9.0); ports.len()], vec![Complex64::default(); ports.len()]);
            key.partial_sums(ports, true, &mut run);
            key.partial_sums(ports, false, &mut each);
            assert!(run.iter().any(|z| z.norm() > 0.0), "key {k} rings");
            let bits = |v: &[Complex64]| v.iter().map(|z| (z.re.to_bits(), z.im.to_bits())).collect::<Vec<_>>();
            assert_eq!(bits(&run), bits(&each), "key {k}");
            checked += 1;
        }
        assert!(checked >= 17, "{checked} keys checked");
    }

    #[test]
    #[ignore = "a timing to look at"]
    fn time_a_trade() {
        let instrument = Instrument::build(&default_settings(InstrumentKind::Piano, 48_000.0)).unwrap();
        let (mut synth, _) = Synth::new(Box::new(instrument));
        let mut events = vec![TimedEvent::new(0, Event::Sustain(1.0))];
        events.extend((21..=108u8).map(|key| TimedEvent::new(0, Event::NoteOn { key, velocity: 0.8 })));
        let (mut l, mut r) = (vec![0.0f32; 48_000], vec![0.0f32; 48_000]);
        synth.process(&events, &mut l, &mut r);
        let current = &mut *synth.current;
        // The fastest of twenty rounds of one interval's blocks (a shared
        // machine interrupts some).
        let best = (0..20)
            .map(|_| {
                let t = std::time::Instant::now();
                let pedalled = crate::performance::PerformanceState::held_up();
                for i in 0..crate::key::SYMPATHY_BLOCKS {
                    current.sympathy.trade(&mut current.keys, 1.0, &pedalled, 1e-6, i);
                }
                t.elapsed().as_secs_f64() / crate::key::SYMPATHY_BLOCKS as f64
            })
            .fold(f64::INFINITY, f64::min);
        println!("{} pairs: {:.1} us per block's share", current.sympathy.len(), best * 1e6);
    }
}
