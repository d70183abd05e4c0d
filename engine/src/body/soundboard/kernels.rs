//! The body's inner loops: its modes run over a control block in groups
//! of lanes, and the lanes' halves paired up into the microphones' samples.

use super::{CONTROL_BLOCK, LANES, Lanes, MAX_ZONES, STATE_FLOOR, modal_bank, multiversion};

/// Each sample's two halves of lanes added in double precision.
pub(super) fn pair_up(acc: &[Lanes], pairs: &mut [[f64; modal_bank::LANES]]) {
    #[cfg(target_arch = "x86_64")]
    if is_x86_feature_detected!("avx512f") {
        // SAFETY: the processor has AVX-512F (checked just above).
        unsafe { pair_up_avx512(acc, pairs) };
        return;
    }
    pair_up_portable(acc, pairs);
}

/// [`pair_up`] lane by lane.
pub(super) fn pair_up_portable(acc: &[Lanes], pairs: &mut [[f64; modal_bank::LANES]]) {
    for (p, a) in pairs.iter_mut().zip(acc) {
        let (low, high) = a.split_at(modal_bank::LANES);
        for ((p, &x), &y) in p.iter_mut().zip(low).zip(high) {
            *p = f64::from(x) + f64::from(y);
        }
    }
}

/// [`pair_up`] with AVX-512: a sample's halves widened and added in one
/// register each (the compiler's own version gathers across samples).
#[cfg(target_arch = "x86_64")]
#[target_feature(enable = "avx512f")]
pub(super) fn pair_up_avx512(acc: &[Lanes], pairs: &mut [[f64; modal_bank::LANES]]) {
    use std::arch::x86_64::{_mm256_loadu_ps, _mm512_add_pd, _mm512_cvtps_pd, _mm512_storeu_pd};
    for (p, a) in pairs.iter_mut().zip(acc) {
        // SAFETY: a is 16 f32 (two unaligned loads of 8), p is 8 f64 (one store).
        unsafe {
            let (low, high) = (_mm256_loadu_ps(a.as_ptr()), _mm256_loadu_ps(a.as_ptr().add(8)));
            _mm512_storeu_pd(p.as_mut_ptr(), _mm512_add_pd(_mm512_cvtps_pd(low), _mm512_cvtps_pd(high)));
        }
    }
}

/// Every state under [`STATE_FLOOR`] set to zero.
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
pub(super) fn floor_states(state: &mut [Lanes]) {
    for v in state.as_flattened_mut() {
        if v.abs() < STATE_FLOOR {
            *v = 0.0;
        }
    }
}

/// The second half's lanes added to the first's, sample by sample.
#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
pub(super) fn add_halves(acc: &mut [Lanes], half: &[Lanes]) {
    for (a, b) in acc.as_flattened_mut().iter_mut().zip(half.as_flattened()) {
        *a += b;
    }
}

/// The running body's modes, by groups of LANES.
pub(super) struct Modes<'a> {
    pub(super) re: &'a mut [Lanes],
    pub(super) im: &'a mut [Lanes],
    pub(super) pole_re: &'a [Lanes],
    pub(super) pole_im: &'a [Lanes],
    pub(super) held_re: &'a [Lanes],
    pub(super) held_im: &'a [Lanes],
    pub(super) shape: &'a [[Lanes; MAX_ZONES]],
    pub(super) out: [&'a [Lanes]; 4],
}

/// Groups stepped side by side (their chains of dependent operations overlap).
pub(super) const BODY_CHAIN: usize = 2;

// The kernel wraps a sample index into the block with a mask.
const _: () = assert!(CONTROL_BLOCK.is_power_of_two());

#[multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
pub(super) fn run_block(
    mut modes: Modes,
    pushes: &[[f32; CONTROL_BLOCK]; MAX_ZONES],
    active: &[usize],
    heard: bool,
    acc_l: &mut [Lanes],
    acc_r: &mut [Lanes],
) {
    // One kernel per number of zones pushed on, so that its loop is unrolled
    // (and one that only moves the modes, for a ring weighed from them).
    match (active.len(), heard) {
        (0, true) => run_groups::<0, true>(&mut modes, pushes, active, acc_l, acc_r),
        (1, true) => run_groups::<1, true>(&mut modes, pushes, active, acc_l, acc_r),
        (2, true) => run_groups::<2, true>(&mut modes, pushes, active, acc_l, acc_r),
        (3, true) => run_groups::<3, true>(&mut modes, pushes, active, acc_l, acc_r),
        (4, true) => run_groups::<4, true>(&mut modes, pushes, active, acc_l, acc_r),
        (5, true) => run_groups::<5, true>(&mut modes, pushes, active, acc_l, acc_r),
        (6, true) => run_groups::<6, true>(&mut modes, pushes, active, acc_l, acc_r),
        (7, true) => run_groups::<7, true>(&mut modes, pushes, active, acc_l, acc_r),
        (_, true) => run_groups::<MAX_ZONES, true>(&mut modes, pushes, active, acc_l, acc_r),
        (0, false) => run_groups::<0, false>(&mut modes, pushes, active, acc_l, acc_r),
        (1, false) => run_groups::<1, false>(&mut modes, pushes, active, acc_l, acc_r),
        (2, false) => run_groups::<2, false>(&mut modes, pushes, active, acc_l, acc_r),
        (3, false) => run_groups::<3, false>(&mut modes, pushes, active, acc_l, acc_r),
        (_, false) => run_groups::<MAX_ZONES, false>(&mut modes, pushes, active, acc_l, acc_r),
    }
}

/// Every group, `BODY_CHAIN` at a time, with `Z` zones pushed on, the
/// microphones summed into `acc_l` and `acc_r` if `HEARD` (else only their
/// length, the block's, is read).
#[inline(always)]
pub(super) fn run_groups<const Z: usize, const HEARD: bool>(
    modes: &mut Modes,
    pushes: &[[f32; CONTROL_BLOCK]; MAX_ZONES],
    active: &[usize],
    acc_l: &mut [Lanes],
    acc_r: &mut [Lanes],
) {
    let groups = modes.re.len();
    let mut g = 0;
    while g + BODY_CHAIN <= groups {
        run_chain::<BODY_CHAIN, Z, HEARD>(modes, g, pushes, active, acc_l, acc_r);
        g += BODY_CHAIN;
    }
    while g < groups {
        run_chain::<1, Z, HEARD>(modes, g, pushes, active, acc_l, acc_r);
        g += 1;
    }
}

/// `G` groups from `first` over a block with `Z` zones pushed on, state in registers.
#[inline(always)]
pub(super) fn run_chain<const G: usize, const Z: usize, const HEARD: bool>(
    modes: &mut Modes,
    first: usize,
    pushes: &[[f32; CONTROL_BLOCK]; MAX_ZONES],
    active: &[usize],
    acc_l: &mut [Lanes],
    acc_r: &mut [Lanes],
) {
    let [lr, li, rr, ri] = modes.out;
    let mut zr = [[0.0; LANES]; G];
    let mut zi = [[0.0; LANES]; G];
    let mut shape = [[[0.0; LANES]; Z]; G];
    // Poles, drives and weights held in registers over the block: [pr, pi, hr, hi, lr, li, rr, ri].
    let mut k8 = [[[0.0; LANES]; 8]; G];
    for c in 0..G {
        let g = first + c;
        zr[c] = modes.re[g];
        zi[c] = modes.im[g];
        for (k, &z) in active.iter().enumerate().take(Z) {
            shape[c][k] = modes.shape[g][z];
        }
        k8[c] = [modes.pole_re[g], modes.pole_im[g], modes.held_re[g], modes.held_im[g], lr[g], li[g], rr[g], ri[g]];
    }
    for (t, (al, ar)) in acc_l.iter_mut().zip(acc_r.iter_mut()).enumerate() {
        let mut f = [0.0; Z];
        for (f, push) in f.iter_mut().zip(pushes) {
            *f = push[t & (CONTROL_BLOCK - 1)];
        }
        let (mut sum_l, mut sum_r) = ([0.0; LANES], [0.0; LANES]);
        for c in 0..G {
            let mut s = [0.0; LANES];
            for k in 0..Z {
                for l in 0..LANES {
                    s[l] = shape[c][k][l].mul_add(f[k], s[l]);
                }
            }
            let [pr, pi, hr, hi, olr, oli, orr, ori] = &k8[c];
            for l in 0..LANES {
                let r = pr[l].mul_add(zr[c][l], hr[l].mul_add(s[l], -(pi[l] * zi[c][l])));
                let i = pr[l].mul_add(zi[c][l], hi[l].mul_add(s[l], pi[l] * zr[c][l]));
                zr[c][l] = r;
                zi[c][l] = i;
                if HEARD {
                    sum_l[l] = olr[l].mul_add(r, oli[l].mul_add(-i, sum_l[l]));
                    sum_r[l] = orr[l].mul_add(r, ori[l].mul_add(-i, sum_r[l]));
                }
            }
        }
        if HEARD {
            for l in 0..LANES {
                al[l] += sum_l[l];
                ar[l] += sum_r[l];
            }
        }
    }
    modes.re[first..first + G].copy_from_slice(&zr);
    modes.im[first..first + G].copy_from_slice(&zi);
}
