//! The free modes of several banks gathered into one run ([`FreeGather`]), and
//! that run: each mode in real form, a two-term recursion on its bridge force,
//! with as many groups of modes in flight as the target's vector registers hold.

use num_complex::Complex64;

use super::kernels::{lane_sum, simd_versions};
use super::{LANES, padded};

/// Modes' poles as a [`FreeGather`] takes them: each pole and its inverse
/// ([`inverse`](super::inverse)).
pub struct Poles<'a> {
    pub re: &'a [f64],
    pub im: &'a [f64],
    pub back_re: &'a [f64],
    pub back_im: &'a [f64],
}

/// The free modes of several banks gathered into one run of the free loop,
/// so that a key's few-mode treble strings fill its chains together (each
/// bank alone would leave the multiply-add units waiting on one short chain).
///
/// A gathered mode runs in real form: the real part x of its phasor z obeys
/// x_(n+1) = 2 Re(p) x_n - |p|^2 x_(n-1), one multiply and one multiply-add a
/// step where turning z by p takes two of each, and x is what the bridge
/// feels. It is taken as (x_n, x_(n-1)) = (Re z, Re(z / p)) and given back as
/// z = x_n + i (x_n Re(1/p) - x_(n-1)) / Im(1/p), exact but for rounding
/// (relative 1e-16 over the sine of the pole's angle: 3e-14 for the lowest
/// piano string, each control block).
/// Holds room for a fixed number of modes: nothing allocates once made.
#[derive(Clone, Debug, Default)]
pub struct FreeGather {
    /// x_n and x_(n-1) of each mode, and its recursion's 2 Re(p) and -|p|^2.
    now: Vec<f64>,
    before: Vec<f64>,
    twice_re: Vec<f64>,
    minus_norm: Vec<f64>,
    len: usize,
}

impl FreeGather {
    /// Room for `modes` modes (each bank's padded count). Allocates.
    pub fn with_room(modes: usize) -> Self {
        let n = padded(modes);
        Self { now: vec![0.0; n], before: vec![0.0; n], twice_re: vec![0.0; n], minus_norm: vec![0.0; n], len: 0 }
    }

    /// Start a new gathering.
    pub fn clear(&mut self) {
        self.len = 0;
    }

    /// Add the modes with phasors `re` + i `im` (as many as a multiple of
    /// [`LANES`]) turning by `poles`; returns where they lie, or None when
    /// there is no room (nothing taken).
    pub fn take(&mut self, re: &[f64], im: &[f64], poles: Poles) -> Option<usize> {
        let (at, n) = (self.len, re.len());
        debug_assert_eq!(n % LANES, 0);
        if at + n > self.now.len() {
            return None;
        }
        let to = at..at + n;
        self.now[to.clone()].copy_from_slice(re);
        to_real_form(
            (&mut self.before[to.clone()], &mut self.twice_re[to.clone()], &mut self.minus_norm[to]),
            re,
            im,
            &poles,
        );
        self.len = at + n;
        Some(at)
    }

    /// Write the phasors of the modes taken at `at` as they stand now into
    /// `re` + i `im`, with their poles' `back_re` and `back_inv` ([`inverse`](super::inverse)).
    pub fn give_back(&self, at: usize, re: &mut [f64], im: &mut [f64], back_re: &[f64], back_inv: &[f64]) {
        let n = re.len();
        let (now, before) = (&self.now[at..at + n], &self.before[at..at + n]);
        re.copy_from_slice(now);
        from_real_form(im, now, before, back_re, back_inv);
    }

    /// The phasor of the mode taken at `i` as it stands now, with its pole's
    /// `back_re` and `back_inv` ([`inverse`](super::inverse)): what [`Self::give_back`] would give.
    #[inline]
    pub fn phasor(&self, i: usize, back_re: f64, back_inv: f64) -> Complex64 {
        let (x, y) = (self.now[i], self.before[i]);
        Complex64::new(x, (x * back_re - y) * back_inv)
    }

    /// [`ModalBank::cull`](super::ModalBank::cull) on the `n` modes taken from `at` where they run,
    /// with their poles' `back_re` and `back_inv` ([`StepTable::backs`](super::StepTable::backs)):
    /// each mode under `floor_n` put to rest, the same bound and loudest
    /// mode, and how many of the modes would still run (modes up to the last
    /// group of [`LANES`] with one left in it). Allocates: no.
    pub fn cull(&mut self, at: usize, n: usize, backs: (&[f64], &[f64]), floor_n: f64) -> (f64, f64, usize) {
        cull_real_form((&mut self.now[at..at + n], &mut self.before[at..at + n]), backs, floor_n)
    }

    /// Add the phasors of the modes taken from `at` on to `sums`, one each,
    /// with their poles' `back_re` and `back_inv` as [`StepTable::backs`](super::StepTable::backs)
    /// gives them: what [`Self::phasor`] gives, mode by mode.
    #[inline]
    pub fn add_phasors(&self, at: usize, (back_re, back_inv): (&[f64], &[f64]), sums: &mut [Complex64]) {
        let n = sums.len();
        let (now, before) = (&self.now[at..at + n], &self.before[at..at + n]);
        for ((((sum, &x), &y), &qr), &inv) in
            sums.iter_mut().zip(now).zip(before).zip(&back_re[..n]).zip(&back_inv[..n])
        {
            sum.re += x;
            sum.im += (x * qr - y) * inv;
        }
    }

    /// Move the phasor of the mode taken at `i` by `delta`, with its pole's
    /// `back_re` and `back_im` ([`inverse`](super::inverse)): x_n by Re delta, x_(n-1) by Re(delta / p).
    #[inline]
    pub fn nudge(&mut self, i: usize, delta: Complex64, back_re: f64, back_im: f64) {
        self.now[i] += delta.re;
        self.before[i] += delta.re * back_re - delta.im * back_im;
    }

    /// Advance every gathered mode over `acc.len()` samples, adding the bridge
    /// force to `acc` by lane. The order of the gathering sets the order of the
    /// sums: the same gathering gives the same bits. (The synth writes with
    /// [`Self::run_fresh`]; this is what it is checked against.)
    #[cfg(test)]
    pub fn run(&mut self, acc: &mut [[f64; LANES]]) {
        self.run_into(acc, false);
    }

    /// [`Self::run`], writing `acc` (zeros if nothing was gathered) instead of
    /// adding to it.
    pub fn run_fresh(&mut self, acc: &mut [[f64; LANES]]) {
        self.run_into(acc, true);
    }

    fn run_into(&mut self, acc: &mut [[f64; LANES]], fresh: bool) {
        let n = self.len;
        let (now, before) = (&mut self.now[..n], &mut self.before[..n]);
        real_block_into(now, before, &self.twice_re[..n], &self.minus_norm[..n], acc, fresh);
    }
}

simd_versions! {
    /// The older sample and the recursion's coefficients of modes with phasors
    /// `re` + i `im` turning by `poles` ([`FreeGather::take`]).
    fn to_real_form(
        (before, twice_re, minus_norm): (&mut [f64], &mut [f64], &mut [f64]),
        re: &[f64],
        im: &[f64],
        poles: &Poles,
    ) {
        let rows = before.iter_mut().zip(twice_re.iter_mut()).zip(minus_norm.iter_mut());
        let from = re.iter().zip(im).zip(poles.re).zip(poles.im).zip(poles.back_re).zip(poles.back_im);
        for (((b, t), m), (((((&r, &i), &pr), &pi), &qr), &qi)) in rows.zip(from) {
            *b = r * qr - i * qi;
            *t = 2.0 * pr;
            *m = -(pr * pr + pi * pi);
        }
    }
}

simd_versions! {
    /// The imaginary parts of phasors in real form ([`FreeGather::give_back`]).
    fn from_real_form(im: &mut [f64], now: &[f64], before: &[f64], back_re: &[f64], back_inv: &[f64]) {
        for ((((i, &x), &y), &qr), &inv) in im.iter_mut().zip(now).zip(before).zip(back_re).zip(back_inv) {
            *i = (x * qr - y) * inv;
        }
    }
}

simd_versions! {
    /// [`FreeGather::cull`] on modes in real form (`now`, `before`), their
    /// poles' inverses as [`StepTable::backs`](super::StepTable::backs) gives them. Without a branch on
    /// a mode: a mode put to rest adds a zero to the bound (never -0, a sum of
    /// magnitudes from +0) and to the loudest, the same sums and maximum.
    fn cull_real_form(
        (now, before): (&mut [f64], &mut [f64]),
        (back_re, back_inv): (&[f64], &[f64]),
        floor_n: f64,
    ) -> (f64, f64, usize) {
        let n = now.len();
        let (now, _) = now.as_chunks_mut::<LANES>();
        let (before, _) = before[..n].as_chunks_mut::<LANES>();
        let (qr, _) = back_re[..n].as_chunks::<LANES>();
        let (inv, _) = back_inv[..n].as_chunks::<LANES>();
        let mut bound = [0.0; LANES];
        let mut loudest = [0.0f64; LANES];
        let mut top = 0;
        for (g, (((x, y), qr), inv)) in now.iter_mut().zip(before.iter_mut()).zip(qr).zip(inv).enumerate() {
            let mut kept = false;
            for l in 0..LANES {
                // (The phasor as `give_back` would hand it back.)
                let im = (x[l] * qr[l] - y[l]) * inv[l];
                let magnitude = x[l].abs() + im.abs();
                let rest = magnitude < floor_n;
                let left = if rest { 0.0 } else { magnitude };
                x[l] = if rest { 0.0 } else { x[l] };
                y[l] = if rest { 0.0 } else { y[l] };
                bound[l] += left;
                loudest[l] = loudest[l].max(left);
                kept |= !rest;
            }
            if kept {
                top = g + 1;
            }
        }
        (lane_sum(&bound), loudest.iter().fold(0.0f64, |m, &v| m.max(v)), top * LANES)
    }
}

simd_versions! {
    /// Gathered modes in real form ([`FreeGather`]) over `acc.len()` samples,
    /// adding (or, if `fresh`, writing) each sample's bridge force to `acc` by lane.
    /// As many groups run together as the target's vector registers hold: with
    /// AVX-512's 32, [`REAL_CHAIN`] with their recursions' coefficients kept in
    /// registers too; elsewhere [`REAL_CHAIN_NARROW`], the coefficients read from
    /// memory by each step. The sums are the same bits either way.
    fn real_block_into(
        now: &mut [f64],
        before: &mut [f64],
        twice_re: &[f64],
        minus_norm: &[f64],
        acc: &mut [[f64; LANES]],
        fresh: bool,
    ) {
        if multiversion::target::target_cfg_f!(target_feature = "avx512f") {
            real_block_chains::<REAL_CHAIN, false>(now, before, twice_re, minus_norm, acc, fresh);
        } else {
            real_block_chains::<REAL_CHAIN_NARROW, true>(now, before, twice_re, minus_norm, acc, fresh);
        }
    }
}

/// [`real_block_into`] `C` groups at a time (the last few fewer), inlined
/// into each version; `REFETCH` as [`real_chain`]'s.
#[inline(always)]
fn real_block_chains<const C: usize, const REFETCH: bool>(
    now: &mut [f64],
    before: &mut [f64],
    twice_re: &[f64],
    minus_norm: &[f64],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    let (now, _) = now.as_chunks_mut::<LANES>();
    let (before, _) = before.as_chunks_mut::<LANES>();
    let (a, _) = twice_re.as_chunks::<LANES>();
    let (b, _) = minus_norm.as_chunks::<LANES>();
    let whole = now.len() / C * C;
    let mut fresh = fresh;
    let mut g = 0;
    while g < whole {
        let to = g + C;
        real_groups::<C, REFETCH>(&mut now[g..to], &mut before[g..to], &a[g..to], &b[g..to], acc, fresh);
        fresh = false;
        g = to;
    }
    let (x, y, a, b) = (&mut now[whole..], &mut before[whole..], &a[whole..], &b[whole..]);
    match (x.len(), fresh) {
        (0, true) => acc.fill([0.0; LANES]),
        (0, false) => {}
        (1, _) => real_groups::<1, REFETCH>(x, y, a, b, acc, fresh),
        (2, _) => real_groups::<2, REFETCH>(x, y, a, b, acc, fresh),
        (3, _) => real_groups::<3, REFETCH>(x, y, a, b, acc, fresh),
        (4, _) => real_groups::<4, REFETCH>(x, y, a, b, acc, fresh),
        _ => real_groups::<5, REFETCH>(x, y, a, b, acc, fresh),
    }
}

/// The first `G` groups of the slices in real form over a block, writing to
/// `acc` if `fresh`, else adding to it.
#[inline(always)]
fn real_groups<const G: usize, const REFETCH: bool>(
    now: &mut [[f64; LANES]],
    before: &mut [[f64; LANES]],
    a: &[[f64; LANES]],
    b: &[[f64; LANES]],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    if let (Some(x), Some(y), Some(a), Some(b)) =
        (now.first_chunk_mut::<G>(), before.first_chunk_mut::<G>(), a.first_chunk::<G>(), b.first_chunk::<G>())
    {
        if fresh {
            real_chain::<G, true, REFETCH>(x, y, a, b, acc);
        } else {
            real_chain::<G, false, REFETCH>(x, y, a, b, acc);
        }
    }
}

/// `G` groups in real form over a block, state in registers; each group's
/// bridge force is added to its sample's accumulator in the gathering's order
/// (the first group written to it, if `WRITE`), so how the groups are cut
/// into chains changes no bit. The multiply by the older sample is off the
/// chain of dependent operations: one multiply-add a step on it. With
/// `REFETCH` the coefficients are read from memory by every step (the
/// compiler would otherwise hold them in registers and push the modes' state
/// out to the stack: with AVX2's 16 registers three groups' state takes 12).
#[inline(always)]
fn real_chain<const G: usize, const WRITE: bool, const REFETCH: bool>(
    now: &mut [[f64; LANES]; G],
    before: &mut [[f64; LANES]; G],
    twice_re: &[[f64; LANES]; G],
    minus_norm: &[[f64; LANES]; G],
    acc: &mut [[f64; LANES]],
) {
    // Two samples a round, the newer and the older sample of each mode taking
    // turns in the same two places: no copies from one to the other.
    let (mut x, mut y) = (*now, *before);
    let (pairs, last) = acc.as_chunks_mut::<2>();
    for [first, second] in pairs {
        let (twice_re, minus_norm) =
            if REFETCH { std::hint::black_box((twice_re, minus_norm)) } else { (twice_re, minus_norm) };
        real_step::<G, WRITE>(&mut y, &x, twice_re, minus_norm, first);
        real_step::<G, WRITE>(&mut x, &y, twice_re, minus_norm, second);
    }
    if let [out] = last {
        real_step::<G, WRITE>(&mut y, &x, twice_re, minus_norm, out);
        std::mem::swap(&mut x, &mut y);
    }
    *now = x;
    *before = y;
}

/// One sample of [`real_chain`]: `older` (x_(n-1) of each mode) becomes
/// x_(n+1) from `newer` (x_n), and is summed into `out` in the groups' order.
#[inline(always)]
fn real_step<const G: usize, const WRITE: bool>(
    older: &mut [[f64; LANES]; G],
    newer: &[[f64; LANES]; G],
    twice_re: &[[f64; LANES]; G],
    minus_norm: &[[f64; LANES]; G],
    out: &mut [f64; LANES],
) {
    let mut sum = if WRITE { [0.0; LANES] } else { *out };
    for g in 0..G {
        for l in 0..LANES {
            let next = twice_re[g][l].mul_add(newer[g][l], minus_norm[g][l] * older[g][l]);
            older[g][l] = next;
            sum[l] += next;
        }
    }
    *out = sum;
}

/// Groups stepped together in the real-form loop ([`FreeGather`]). A step is
/// a multiply off the chain and one multiply-add on it, so four groups keep
/// the two units exactly as busy as the chain's latency allows, and any stall
/// shows; six leave slack (the gathered loop went from 0.75 to 0.93 of the
/// FMA probe on this machine's AVX-512), eight no longer fit the registers.
pub(crate) const REAL_CHAIN: usize = 6;
/// [`REAL_CHAIN`] where a group of [`LANES`] modes takes two vector registers
/// (AVX2) or four (SSE, NEON) and there are 16 or 32: three groups, their two
/// samples in 12 of AVX2's 16 registers. Six spilled the state to the stack
/// every sample: on a Zen 3 (AVX2) the gathered loop took 0.37-0.45 ns per
/// mode-sample with six groups, 0.14-0.17 with three read this way.
pub(crate) const REAL_CHAIN_NARROW: usize = 3;
// (What is left after the whole chains, up to five groups, runs by itself.)
const _: () = assert!(REAL_CHAIN <= 6 && REAL_CHAIN_NARROW <= REAL_CHAIN);

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modal_bank::test_strings::{one_mode, treble_string};
    use crate::modal_bank::{FREE_BLOCK, ModalBank, StepTable};
    use crate::string::StringModes;
    #[test]
    fn a_gathering_of_banks_gives_their_sums_and_writes_the_same_bits_as_it_adds() {
        // Two strings gathered and run together (in real form) turn their
        // modes as each alone (turning its phasors) but for rounding, and a
        // fresh run's written accumulator is the added one.
        let (treble, other) = (treble_string(), one_mode(300.0));
        let strings = [&treble, &other];
        let steps: Vec<StepTable> = strings.iter().map(|s| StepTable::new(s, 1.0 / 48_000.0)).collect();
        let mut banks: Vec<ModalBank> = strings.iter().map(|s| ModalBank::new(s)).collect();
        for b in &mut banks {
            for i in 0..b.len() {
                b.add_velocity(i, (i as f64 + 0.5).cos());
            }
        }
        let mut alone = banks.clone();
        let mut added = vec![[0.0; LANES]; FREE_BLOCK];
        for (b, step) in alone.iter_mut().zip(&steps) {
            b.accumulate_free(step, &mut added);
        }
        let mut gather = FreeGather::with_room(banks.iter().map(|b| b.len().next_multiple_of(LANES)).sum());
        let at: Vec<usize> =
            banks.iter().zip(&steps).map(|(b, step)| b.gather_free(step, &mut gather).unwrap()).collect();
        let mut written = vec![[f64::NAN; LANES]; FREE_BLOCK];
        gather.run_fresh(&mut written);
        for (((b, at), a), step) in banks.iter_mut().zip(at).zip(&alone).zip(&steps) {
            b.scatter_free(step, &gather, at);
            let size = a.re.iter().chain(&a.im).fold(0.0f64, |m, v| m.max(v.abs()));
            for (x, y) in b.re.iter().zip(&a.re).chain(b.im.iter().zip(&a.im)) {
                assert!((x - y).abs() <= 1e-13 * size, "{x} against {y}");
            }
        }
        let sum = |acc: &[[f64; LANES]]| acc.iter().map(lane_sum).collect::<Vec<_>>();
        let (one, together) = (sum(&added), sum(&written));
        for (x, y) in one.iter().zip(&together) {
            assert!((x - y).abs() <= 1e-12 * x.abs().max(1.0), "{x} against {y}");
        }
        let mut twice = vec![[0.0; LANES]; FREE_BLOCK];
        let again = banks.clone();
        let mut g2 = FreeGather::with_room(gather.now.len());
        for (b, step) in again.iter().zip(&steps) {
            b.gather_free(step, &mut g2).unwrap();
        }
        let mut fresh = vec![[f64::NAN; LANES]; FREE_BLOCK];
        g2.clone().run_fresh(&mut fresh);
        g2.run(&mut twice);
        assert!(fresh.iter().flatten().zip(twice.iter().flatten()).all(|(x, y)| x.to_bits() == y.to_bits()));
    }

    #[test]
    fn a_gathering_culls_as_its_banks_handed_back_would_cull() {
        // Modes of every size, some under the floor: culled where they run,
        // the same bound, the same loudest mode and the same modes at rest
        // as the banks culled once handed back.
        let strings = [treble_string(), one_mode(300.0)];
        let steps: Vec<StepTable> = strings.iter().map(|s| StepTable::new(s, 1.0 / 48_000.0)).collect();
        let mut banks: Vec<ModalBank> = strings.iter().map(ModalBank::new).collect();
        for b in &mut banks {
            for i in 0..b.len() {
                b.add_velocity(i, (i as f64 + 0.5).cos() * 10f64.powi(-(i as i32 % 7)));
            }
        }
        let mut gather = FreeGather::with_room(banks.iter().map(|b| b.len().next_multiple_of(LANES)).sum());
        let at: Vec<usize> =
            banks.iter().zip(&steps).map(|(b, step)| b.gather_free(step, &mut gather).unwrap()).collect();
        let mut acc = vec![[0.0; LANES]; FREE_BLOCK];
        gather.run_fresh(&mut acc);
        for floor in [0.0, 1e-9, 1e-6, 1e-3, 1e3] {
            let mut culled = gather.clone();
            for ((b, step), &at) in banks.iter().zip(&steps).zip(&at) {
                let n = b.running();
                let (bound, loudest, top) = culled.cull(at, n, step.backs(), floor);
                let mut handed = b.clone();
                handed.scatter_free(step, &gather, at);
                let (bank_bound, bank_loudest) = handed.cull(floor);
                assert_eq!((bound.to_bits(), loudest.to_bits()), (bank_bound.to_bits(), bank_loudest.to_bits()));
                assert_eq!(top, handed.running(), "floor {floor}");
                // (Equal, and to the bit but for a mode put to rest, whose
                // imaginary part may come back as -0.)
                let mut back = b.clone();
                back.scatter_free(step, &culled, at);
                for (x, y) in
                    back.re[..top].iter().zip(&handed.re[..top]).chain(back.im[..top].iter().zip(&handed.im[..top]))
                {
                    assert!(x.to_bits() == y.to_bits() || (*x == 0.0 && *y == 0.0), "{x} against {y}");
                }
            }
        }
    }

    /// [`real_block_into`]'s signature.
    type RealBlock = fn(&mut [f64], &mut [f64], &[f64], &[f64], &mut [[f64; LANES]], bool);

    #[test]
    fn the_real_form_loop_gives_the_same_bits_however_many_groups_run_together() {
        // The wide targets' chains of six with their coefficients held, the
        // narrow ones' of three read from memory, and one group at a time:
        // every remainder, written and added, over an odd number of samples.
        for groups in 0..=2 * REAL_CHAIN + 1 {
            let n = groups * LANES;
            let wave = |k: usize, f: f64| (0..n).map(|i| ((i * 7 + k) as f64 * f).sin()).collect::<Vec<f64>>();
            let (now, before) = (wave(1, 0.37), wave(2, 0.29));
            let twice_re: Vec<f64> = wave(3, 0.11).iter().map(|v| 1.9 + 0.05 * v).collect();
            let minus_norm: Vec<f64> = wave(4, 0.13).iter().map(|v| -0.999 + 0.0005 * v).collect();
            for fresh in [true, false] {
                let run = |chains: RealBlock| {
                    let (mut x, mut y) = (now.clone(), before.clone());
                    let mut acc: Vec<[f64; LANES]> =
                        (0..FREE_BLOCK - 1).map(|s| std::array::from_fn(|l| (s * LANES + l) as f64 * 1e-3)).collect();
                    chains(&mut x, &mut y, &twice_re, &minus_norm, &mut acc, fresh);
                    let bits = |v: &[f64]| v.iter().map(|v| v.to_bits()).collect::<Vec<u64>>();
                    (bits(&x), bits(&y), bits(acc.as_flattened()))
                };
                let wide = run(real_block_chains::<REAL_CHAIN, false>);
                assert!(wide == run(real_block_chains::<REAL_CHAIN_NARROW, true>), "{groups} groups, fresh {fresh}");
                assert!(wide == run(real_block_chains::<1, false>), "{groups} groups, fresh {fresh}");
                assert!(wide == run(real_block_into), "{groups} groups, fresh {fresh}");
            }
        }
    }

    #[test]
    fn a_gathering_of_any_number_of_groups_turns_them_as_alone() {
        // Whole chains of REAL_CHAIN groups and every remainder (none gathered
        // at all: a fresh run writes zeros); each group one mode of its own Q.
        for groups in 0..=2 * REAL_CHAIN + 1 {
            let strings: Vec<StringModes> = (0..groups).map(|g| one_mode(200.0 + 37.0 * g as f64)).collect();
            let steps: Vec<StepTable> = strings.iter().map(|s| StepTable::new(s, 1.0 / 48_000.0)).collect();
            let mut banks: Vec<ModalBank> = strings.iter().map(ModalBank::new).collect();
            for (g, b) in banks.iter_mut().enumerate() {
                b.add_velocity(0, 1.0 + g as f64);
            }
            let mut added = vec![[0.0; LANES]; FREE_BLOCK];
            for (b, step) in banks.clone().iter_mut().zip(&steps) {
                b.accumulate_free(step, &mut added);
            }
            let mut gather = FreeGather::with_room((groups * LANES).max(1));
            for (b, step) in banks.iter().zip(&steps) {
                b.gather_free(step, &mut gather).unwrap();
            }
            let mut written = vec![[f64::NAN; LANES]; FREE_BLOCK];
            gather.run_fresh(&mut written);
            let peak = added.iter().map(lane_sum).fold(0.0f64, |m, v| m.max(v.abs())).max(1e-300);
            for (x, y) in added.iter().map(lane_sum).zip(written.iter().map(lane_sum)) {
                assert!((x - y).abs() <= 1e-12 * peak, "{groups} groups: {x} against {y}");
            }
        }
    }
}
