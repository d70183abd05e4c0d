//! The inner loops, each compiled for every vector extension the engine is
//! tuned for and picked by the machine at run time ([`simd_versions`]): the
//! free loop, the driven step, kicks, observations and lane sums. The x86
//! intrinsics beside them (the driven step and the lane sums by hand) are in
//! the `x86` room; both add in the same order, so each gives the same bits.

use super::LANES;
#[cfg(target_arch = "x86_64")]
use super::x86;

/// Compile the function item it wraps for each vector extension the inner
/// loops are tuned for (AVX-512 with FMA, AVX2 with FMA, NEON) besides the
/// baseline, and pick one by the machine at run time: the one list of targets
/// every multiversioned loop of the bank uses, so all dispatch alike.
macro_rules! simd_versions {
    ($(#[$attr:meta])* $vis:vis fn $($item:tt)*) => {
        $(#[$attr])*
        #[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
        $vis fn $($item)*
    };
}
pub(super) use simd_versions;

/// A driven step's kernel, as [`ModalBank::step_driven_by`](super::ModalBank::step_driven_by) takes it.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum Kernel {
    /// AVX-512F.
    #[cfg(target_arch = "x86_64")]
    Avx512,
    /// AVX2 with FMA.
    #[cfg(target_arch = "x86_64")]
    Avx2,
    /// The portable loop.
    Portable,
}

impl Kernel {
    /// The fastest kernel this machine has.
    pub(crate) fn detected() -> Self {
        #[cfg(target_arch = "x86_64")]
        {
            if is_x86_feature_detected!("avx512f") {
                return Self::Avx512;
            }
            if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
                return Self::Avx2;
            }
        }
        Self::Portable
    }
}

/// Sum of an accumulator's lanes in a fixed order (both loops use it, so free and
/// driven steps give the same bits).
#[inline(always)]
pub fn lane_sum(a: &[f64; LANES]) -> f64 {
    ((a[0] + a[4]) + (a[1] + a[5])) + ((a[2] + a[6]) + (a[3] + a[7]))
}

/// Add each sample's [`lane_sum`] of `acc` to `out` (the same sums, bit for
/// bit, in vector registers where the machine has AVX).
pub fn add_lane_sums(acc: &[[f64; LANES]], out: &mut [f64]) {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx512f") {
        // SAFETY: the feature the kernel is compiled for was detected just above.
        unsafe { x86::add_lane_sums_avx512(acc, out) };
        return;
    }
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx") {
        // SAFETY: the feature the kernel is compiled for was detected just above.
        unsafe { x86::add_lane_sums_avx(acc, out) };
        return;
    }
    add_lane_sums_portable(acc, out);
}

simd_versions! {
    fn add_lane_sums_portable(acc: &[[f64; LANES]], out: &mut [f64]) {
        for (o, a) in out.iter_mut().zip(acc) {
            *o += lane_sum(a);
        }
    }
}

pub(super) fn lane_sum_all(values: &[f64]) -> f64 {
    let mut acc = [0.0; LANES];
    let (chunks, _) = values.as_chunks::<LANES>();
    for c in chunks {
        for l in 0..LANES {
            acc[l] += c[l];
        }
    }
    lane_sum(&acc)
}

simd_versions! {
    /// [`ModalBank::observe`](super::ModalBank::observe): compiled for the vector extensions too, where each
    /// multiply-add is one instruction (in the baseline, a call into the maths
    /// library per mode: at each strike, every string's modes; the same bits).
    pub(super) fn observe_through(re: &[f64], observe: &[f64]) -> f64 {
        let mut acc = [0.0; LANES];
        let (re, _) = re.as_chunks::<LANES>();
        let (c, _) = observe.as_chunks::<LANES>();
        for (r, c) in re.iter().zip(c) {
            for l in 0..LANES {
                acc[l] = c[l].mul_add(r[l], acc[l]);
            }
        }
        lane_sum(&acc)
    }
}

/// Groups of [`LANES`] modes stepped together in the free loop: each mode's step
/// depends on its last, so several independent groups must be in flight to keep
/// the multiply-add units busy through their latency (4 cycles, 2 units: 8).
pub(crate) const CHAIN: usize = 4;

simd_versions! {
    /// `to[i] += by[i] * k` for as many as both have, each product rounded before
    /// its sum: [`ModalBank::kick`](super::ModalBank::kick) (a dulcimer's string with a stroke in play
    /// takes its bridge's kick so every sample).
    pub(super) fn add_scaled(to: &mut [f64], by: &[f64], k: f64) {
        add_scaled_body(to, by, k);
    }
}

/// What [`add_scaled`] runs, inlined into each of its callers' versions.
#[inline(always)]
fn add_scaled_body(to: &mut [f64], by: &[f64], k: f64) {
    for (t, b) in to.iter_mut().zip(by) {
        *t += b * k;
    }
}

/// Advance `re`/`im` by their poles over `acc.len()` samples, adding each
/// sample's bridge force to `acc` by lane.
pub(crate) fn free_block(re: &mut [f64], im: &mut [f64], pole_re: &[f64], pole_im: &[f64], acc: &mut [[f64; LANES]]) {
    free_block_into(re, im, pole_re, pole_im, acc, false);
}

simd_versions! {
    /// [`free_block`], writing `acc` instead of adding to it when `fresh` (the
    /// same bits as adding to zeros: a sum of modes is never -0).
    pub(crate) fn free_block_into(
        re: &mut [f64],
        im: &mut [f64],
        pole_re: &[f64],
        pole_im: &[f64],
        acc: &mut [[f64; LANES]],
        fresh: bool,
    ) {
        free_block_body(re, im, pole_re, pole_im, acc, fresh);
    }
}

simd_versions! {
    /// One sample of [`free_block`] after `im[i] += kick[i] * dv` (as
    /// [`add_scaled`]), in one call: that sample's [`lane_sum`]. (Summed here, in
    /// the registers the sample's lanes are in: read back from memory by the
    /// caller's code, its wide stores stalled the narrower loads.)
    pub(super) fn free_sample_kicked(
        re: &mut [f64],
        im: &mut [f64],
        (kick, dv): (&[f64], f64),
        pole_re: &[f64],
        pole_im: &[f64],
    ) -> f64 {
        add_scaled_body(im, kick, dv);
        let mut acc = [[0.0; LANES]; 1];
        free_block_body(re, im, pole_re, pole_im, &mut acc, false);
        lane_sum(&acc[0])
    }
}

/// What [`free_block_into`] runs, inlined into each of its callers' versions.
#[inline(always)]
fn free_block_body(
    re: &mut [f64],
    im: &mut [f64],
    pole_re: &[f64],
    pole_im: &[f64],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    let (re, _) = re.as_chunks_mut::<LANES>();
    let (im, _) = im.as_chunks_mut::<LANES>();
    let (pr, _) = pole_re.as_chunks::<LANES>();
    let (pi, _) = pole_im.as_chunks::<LANES>();
    let whole = re.len() / CHAIN * CHAIN;
    let (re_chains, re_rest) = re.split_at_mut(whole);
    let (im_chains, im_rest) = im.split_at_mut(whole);
    let (re_chains, _) = re_chains.as_chunks_mut::<CHAIN>();
    let (im_chains, _) = im_chains.as_chunks_mut::<CHAIN>();
    let (pr_chains, _) = pr[..whole].as_chunks::<CHAIN>();
    let (pi_chains, _) = pi[..whole].as_chunks::<CHAIN>();
    let mut fresh = fresh;
    for (((zr, zi), pr), pi) in re_chains.iter_mut().zip(im_chains.iter_mut()).zip(pr_chains).zip(pi_chains) {
        if fresh {
            free_chain::<CHAIN, true>(zr, zi, pr, pi, acc);
            fresh = false;
        } else {
            free_chain::<CHAIN, false>(zr, zi, pr, pi, acc);
        }
    }
    let (pr, pi) = (&pr[whole..], &pi[whole..]);
    match (re_rest.len(), fresh) {
        (0, true) => acc.fill([0.0; LANES]),
        (0, false) => {}
        (1, _) => free_rest::<1>(re_rest, im_rest, pr, pi, acc, fresh),
        (2, _) => free_rest::<2>(re_rest, im_rest, pr, pi, acc, fresh),
        _ => free_rest::<3>(re_rest, im_rest, pr, pi, acc, fresh),
    }
}

/// The last `G` groups of modes (fewer than a chain) over a block.
#[inline(always)]
fn free_rest<const G: usize>(
    re: &mut [[f64; LANES]],
    im: &mut [[f64; LANES]],
    pr: &[[f64; LANES]],
    pi: &[[f64; LANES]],
    acc: &mut [[f64; LANES]],
    fresh: bool,
) {
    if let (Some(zr), Some(zi), Some(pr), Some(pi)) =
        (re.first_chunk_mut::<G>(), im.first_chunk_mut::<G>(), pr.first_chunk::<G>(), pi.first_chunk::<G>())
    {
        if fresh {
            free_chain::<G, true>(zr, zi, pr, pi, acc);
        } else {
            free_chain::<G, false>(zr, zi, pr, pi, acc);
        }
    }
}

/// `G` groups of modes over a block of samples, state in registers; each sample's
/// bridge force is summed over the groups in order and then added to its
/// accumulator (written to it, if `WRITE`).
#[inline(always)]
fn free_chain<const G: usize, const WRITE: bool>(
    re: &mut [[f64; LANES]; G],
    im: &mut [[f64; LANES]; G],
    pr: &[[f64; LANES]; G],
    pi: &[[f64; LANES]; G],
    acc: &mut [[f64; LANES]],
) {
    let (mut r, mut i) = (*re, *im);
    for a in acc.iter_mut() {
        let mut sum = [0.0; LANES];
        for g in 0..G {
            for l in 0..LANES {
                let nr = pr[g][l].mul_add(r[g][l], -(pi[g][l] * i[g][l]));
                let ni = pr[g][l].mul_add(i[g][l], pi[g][l] * r[g][l]);
                r[g][l] = nr;
                i[g][l] = ni;
                sum[l] += nr;
            }
        }
        for l in 0..LANES {
            if WRITE {
                a[l] = sum[l];
            } else {
                a[l] += sum[l];
            }
        }
    }
    *re = r;
    *im = i;
}

simd_versions! {
    /// One driven step over all modes (see [`ModalBank::step_driven`](super::ModalBank::step_driven)): the
    /// portable loop the x86 kernels follow to the bit.
    #[allow(clippy::too_many_arguments)]
    pub(super) fn driven_step(
        re: &mut [f64],
        im: &mut [f64],
        pole_re: &[f64],
        pole_im: &[f64],
        carry_re: &[f64],
        carry_im: &[f64],
        observe: &[f64],
        input: f64,
    ) -> (f64, f64) {
        let (re, _) = re.as_chunks_mut::<LANES>();
        let (im, _) = im.as_chunks_mut::<LANES>();
        let (pr, _) = pole_re.as_chunks::<LANES>();
        let (pi, _) = pole_im.as_chunks::<LANES>();
        let (er, _) = carry_re.as_chunks::<LANES>();
        let (ei, _) = carry_im.as_chunks::<LANES>();
        let (c, _) = observe.as_chunks::<LANES>();
        // One observation accumulator per group of a chain (no chain of dependent
        // multiply-adds); the bridge force summed as the free loop sums it, within
        // each chain of groups first, so an idle exciter gives the same bits as none.
        // The x86 kernels follow this order exactly.
        let mut obs = [[0.0; LANES]; CHAIN];
        let mut bridge = [0.0; LANES];
        let mut sum = [0.0; LANES];
        let last = re.len().saturating_sub(1);
        let groups = re.iter_mut().zip(im.iter_mut()).zip(pr).zip(pi).zip(er).zip(ei).zip(c);
        for (g, ((((((zr, zi), pr), pi), er), ei), c)) in groups.enumerate() {
            let o = &mut obs[g % CHAIN];
            for l in 0..LANES {
                let nr = er[l].mul_add(input, pr[l].mul_add(zr[l], -(pi[l] * zi[l])));
                let ni = ei[l].mul_add(input, pr[l].mul_add(zi[l], pi[l] * zr[l]));
                zr[l] = nr;
                zi[l] = ni;
                sum[l] += nr;
                o[l] = c[l].mul_add(nr, o[l]);
            }
            if g % CHAIN == CHAIN - 1 || g == last {
                for (b, s) in bridge.iter_mut().zip(&mut sum) {
                    *b += *s;
                    *s = 0.0;
                }
            }
        }
        let mut observed = obs[0];
        for o in &obs[1..] {
            for (total, x) in observed.iter_mut().zip(o) {
                *total += x;
            }
        }
        (lane_sum(&observed), lane_sum(&bridge))
    }
}

/// Take back one free step of every mode: multiply by 1/p.
pub(super) fn undo_step(re: &mut [f64], im: &mut [f64], pole_re: &[f64], pole_im: &[f64]) {
    for (((r, i), pr), pi) in re.iter_mut().zip(im.iter_mut()).zip(pole_re).zip(pole_im) {
        let norm = pr * pr + pi * pi;
        let (nr, ni) = ((*r * pr + *i * pi) / norm, (*i * pr - *r * pi) / norm);
        *r = nr;
        *i = ni;
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::modal_bank::test_strings::treble_string;
    use crate::modal_bank::{DriveTable, Hold, ModalBank, StepTable};
    #[test]
    fn lane_sums_match_the_portable_loop_bit_for_bit() {
        // Values of every size and sign, so any change of order shows.
        let mut x = 0x2545_f491_4f6c_dd1du64;
        let mut next = || {
            x ^= x << 13;
            x ^= x >> 7;
            x ^= x << 17;
            (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5
        };
        let acc: Vec<[f64; LANES]> = (0..crate::CONTROL_BLOCK)
            .map(|i| std::array::from_fn(|l| next() * 10f64.powi((i + 3 * l) as i32 % 17 - 8)))
            .collect();
        let start: Vec<f64> = (0..crate::CONTROL_BLOCK).map(|_| next()).collect();
        // A stretch whose length is no multiple of eight, too.
        let (mut fast, mut plain) = (start[..13].to_vec(), start[..13].to_vec());
        add_lane_sums(&acc[..13], &mut fast);
        add_lane_sums_portable(&acc[..13], &mut plain);
        assert!(fast.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()), "{fast:?} against {plain:?}");
        let (mut fast, mut plain) = (start.clone(), start.clone());
        add_lane_sums(&acc, &mut fast);
        add_lane_sums_portable(&acc, &mut plain);
        assert!(fast.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()));
        // AVX's own four at a time and one by one, which AVX-512 leaves the last few samples to.
        #[cfg(target_arch = "x86_64")]
        if is_x86_feature_detected!("avx") {
            for n in [0, 3, 13, crate::CONTROL_BLOCK] {
                let mut avx = start[..n].to_vec();
                // SAFETY: AVX was detected just above.
                unsafe { x86::add_lane_sums_avx(&acc[..n], &mut avx) };
                assert!(avx.iter().zip(&plain).all(|(a, b)| a.to_bits() == b.to_bits()), "{n} samples");
            }
        }
    }

    /// Each vector kernel the machine can run gives the portable loop's bits.
    #[cfg(target_arch = "x86_64")]
    #[test]
    fn vector_driven_steps_match_the_portable_loop() {
        let string = treble_string();
        let step = StepTable::new(&string, 1.0 / 96_000.0);
        let mut start = ModalBank::new(&string);
        for i in 0..start.len() {
            start.add_velocity(i, 1.0 / (i + 1) as f64);
        }
        let gain: Vec<f64> = (0..start.len()).map(|i| (i as f64).cos()).collect();
        let drive = DriveTable::new(&step, Hold::End, start.weights(), &gain, &gain);
        type Kernel = fn(x86::Driven<'_>, f64) -> Option<(f64, f64)>;
        let kernels: [(&str, bool, Kernel); 2] = [
            ("avx512", is_x86_feature_detected!("avx512f"), |d, u| unsafe { x86::driven_avx512(d, u) }),
            ("avx2", is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma"), |d, u| unsafe {
                x86::driven_avx2(d, u)
            }),
        ];
        for (name, available, kernel) in kernels {
            if !available {
                continue;
            }
            let (mut a, mut b) = (start.clone(), start.clone());
            for k in 0..50 {
                let input = 0.1 * (k as f64).sin();
                let portable = driven_step(
                    &mut a.re,
                    &mut a.im,
                    &step.pole_re,
                    &step.pole_im,
                    &drive.carry_re,
                    &drive.carry_im,
                    &drive.observe,
                    input,
                );
                let d = x86::Driven::of(&mut b.re, &mut b.im, &step, &drive);
                let vector = kernel(d, input).expect("slices that fit");
                assert_eq!(portable.1.to_bits(), vector.1.to_bits(), "{name}: bridge force at step {k}");
                assert!((portable.0 - vector.0).abs() <= 1e-12 * portable.0.abs().max(1e-30), "{name}: observation");
            }
            assert_eq!(a.re, b.re, "{name}");
            assert_eq!(a.im, b.im, "{name}");
        }
    }
}
