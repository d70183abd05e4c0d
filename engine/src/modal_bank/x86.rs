//! The driven step written with x86-64 vector intrinsics (AVX-512F, and AVX2 with
//! FMA), chosen at run time by [`super::ModalBank::step_driven`]. The compiler's
//! own vectorisation of this loop (seven streams, two sums) interleaves lanes
//! badly; here each group of [`LANES`] modes is one AVX-512 register or two AVX2
//! registers. Lane by lane the arithmetic and its order are those of the portable
//! loop (and of the free loop's bridge sum), so results agree to the bit.

use std::arch::x86_64::*;

use super::LANES;
use super::kernels::{CHAIN, lane_sum};

/// The slices of one driven step: state, pole, carry and observation weights,
/// all the same length, a multiple of [`LANES`].
pub(super) struct Driven<'a> {
    pub re: &'a mut [f64],
    pub im: &'a mut [f64],
    pub pole_re: &'a [f64],
    pub pole_im: &'a [f64],
    pub carry_re: &'a [f64],
    pub carry_im: &'a [f64],
    pub observe: &'a [f64],
}

impl<'a> Driven<'a> {
    /// A bank's state (`re`, `im`) with the tables of one driven step.
    pub fn of(re: &'a mut [f64], im: &'a mut [f64], step: &'a super::StepTable, drive: &'a super::DriveTable) -> Self {
        Self {
            re,
            im,
            pole_re: &step.pole_re,
            pole_im: &step.pole_im,
            carry_re: &drive.carry_re,
            carry_im: &drive.carry_im,
            observe: &drive.observe,
        }
    }

    fn groups(&self) -> Option<usize> {
        let n = self.re.len();
        let same = [self.im.len(), self.pole_re.len(), self.pole_im.len(), self.carry_re.len(), self.carry_im.len()]
            .iter()
            .chain(std::iter::once(&self.observe.len()))
            .all(|&len| len == n);
        (same && n.is_multiple_of(LANES)).then_some(n / LANES)
    }
}

macro_rules! driven_kernel {
    ($name:ident, $features:literal, $vector:ty, $width:literal,
     $load:ident, $store:ident, $zero:ident, $splat:ident, $add:ident, $mul:ident, $fmadd:ident, $fmsub:ident) => {
        /// One driven step (see [`super::ModalBank::step_driven`]); `None` when the
        /// slices do not fit together.
        #[target_feature(enable = $features)]
        pub(super) fn $name(d: Driven<'_>, input: f64) -> Option<(f64, f64)> {
            const HALVES: usize = LANES / $width;
            let groups = d.groups()?;
            let input_v = $splat(input);
            let mut obs: [[$vector; HALVES]; CHAIN] = [[$zero(); HALVES]; CHAIN];
            let mut bridge: [$vector; HALVES] = [$zero(); HALVES];
            let mut g = 0;
            while g < groups {
                let chain = (groups - g).min(CHAIN);
                let mut sum: [$vector; HALVES] = [$zero(); HALVES];
                for k in 0..chain {
                    for h in 0..HALVES {
                        let at = (g + k) * LANES + h * $width;
                        // SAFETY: at + $width <= groups * LANES, the length of every slice (checked by groups()).
                        unsafe {
                            let zr = $load(d.re.as_ptr().add(at));
                            let zi = $load(d.im.as_ptr().add(at));
                            let pr = $load(d.pole_re.as_ptr().add(at));
                            let pi = $load(d.pole_im.as_ptr().add(at));
                            let er = $load(d.carry_re.as_ptr().add(at));
                            let ei = $load(d.carry_im.as_ptr().add(at));
                            let c = $load(d.observe.as_ptr().add(at));
                            // nr = er u + (pr zr - pi zi), ni = ei u + (pr zi + pi zr), as the portable loop.
                            let nr = $fmadd(er, input_v, $fmsub(pr, zr, $mul(pi, zi)));
                            let ni = $fmadd(ei, input_v, $fmadd(pr, zi, $mul(pi, zr)));
                            $store(d.re.as_mut_ptr().add(at), nr);
                            $store(d.im.as_mut_ptr().add(at), ni);
                            sum[h] = $add(sum[h], nr);
                            obs[k][h] = $fmadd(c, nr, obs[k][h]);
                        }
                    }
                }
                for h in 0..HALVES {
                    bridge[h] = $add(bridge[h], sum[h]);
                }
                g += chain;
            }
            let mut observed = [0.0; LANES];
            let mut bridged = [0.0; LANES];
            for h in 0..HALVES {
                let mut total = obs[0][h];
                for o in &obs[1..] {
                    total = $add(total, o[h]);
                }
                // SAFETY: each half is $width lanes of the LANES-long arrays.
                unsafe {
                    $store(observed.as_mut_ptr().add(h * $width), total);
                    $store(bridged.as_mut_ptr().add(h * $width), bridge[h]);
                }
            }
            Some((lane_sum(&observed), lane_sum(&bridged)))
        }
    };
}

driven_kernel!(
    driven_avx512,
    "avx512f",
    __m512d,
    8,
    _mm512_loadu_pd,
    _mm512_storeu_pd,
    _mm512_setzero_pd,
    _mm512_set1_pd,
    _mm512_add_pd,
    _mm512_mul_pd,
    _mm512_fmadd_pd,
    _mm512_fmsub_pd
);

driven_kernel!(
    driven_avx2,
    "avx2,fma",
    __m256d,
    4,
    _mm256_loadu_pd,
    _mm256_storeu_pd,
    _mm256_setzero_pd,
    _mm256_set1_pd,
    _mm256_add_pd,
    _mm256_mul_pd,
    _mm256_fmadd_pd,
    _mm256_fmsub_pd
);

/// [`super::add_lane_sums`] with AVX-512, eight samples at a time: their
/// lanes are added in [`lane_sum`]'s order while transposed across registers
/// (halves, then neighbours, then pairs), so the bits are the portable loop's;
/// the last few samples go through [`add_lane_sums_avx`].
#[target_feature(enable = "avx512f")]
pub(super) fn add_lane_sums_avx512(acc: &[[f64; LANES]], out: &mut [f64]) {
    let n = acc.len().min(out.len());
    let whole = n / 8 * 8;
    // Each sample's halves added: [a0+a4, a1+a5, a2+a6, a3+a7] of samples s and t side by side.
    let halves = |s: __m512d, t: __m512d| {
        _mm512_add_pd(_mm512_shuffle_f64x2::<0b01_00_01_00>(s, t), _mm512_shuffle_f64x2::<0b11_10_11_10>(s, t))
    };
    for (a, o) in acc[..whole].chunks_exact(8).zip(out[..whole].chunks_exact_mut(8)) {
        // SAFETY: a holds 8 samples of LANES = 8 f64, o 8 f64: unaligned loads and stores within them.
        unsafe {
            let v: [__m512d; 8] = std::array::from_fn(|s| _mm512_loadu_pd(a[s].as_ptr()));
            // [B0 | B1], [B2 | B3], [B4 | B5], [B6 | B7], each B = [b0, b1, b2, b3].
            let (c01, c23, c45, c67) = (halves(v[0], v[1]), halves(v[2], v[3]), halves(v[4], v[5]), halves(v[6], v[7]));
            // [B0 b0+b1, B2 b0+b1, B0 b2+b3, B2 b2+b3, B1 .., B3 .., B1 .., B3 ..] and the same for 4..7.
            let e0 = _mm512_add_pd(_mm512_unpacklo_pd(c01, c23), _mm512_unpackhi_pd(c01, c23));
            let e1 = _mm512_add_pd(_mm512_unpacklo_pd(c45, c67), _mm512_unpackhi_pd(c45, c67));
            // (b0+b1) + (b2+b3): [S0, S2, _, _, S1, S3, _, _] and [S4, S6, _, _, S5, S7, _, _].
            let h0 = _mm512_add_pd(e0, _mm512_permutex_pd::<0b01_00_11_10>(e0));
            let h1 = _mm512_add_pd(e1, _mm512_permutex_pd::<0b01_00_11_10>(e1));
            // [S0 .. S7]: picked from h0 (indices 0..7) and h1 (8..15).
            let order = _mm512_set_epi64(13, 9, 12, 8, 5, 1, 4, 0);
            let sums = _mm512_permutex2var_pd(h0, order, h1);
            _mm512_storeu_pd(o.as_mut_ptr(), _mm512_add_pd(_mm512_loadu_pd(o.as_ptr()), sums));
        }
    }
    // (AVX-512F implies AVX: no further check.)
    add_lane_sums_avx(&acc[whole..n], &mut out[whole..n]);
}

/// [`super::add_lane_sums`] with AVX: each sample's lanes summed in registers
/// in [`lane_sum`]'s order, ((a0 + a4) + (a1 + a5)) + ((a2 + a6) + (a3 + a7)),
/// so the bits are the portable loop's: four samples at a time transposed
/// across registers (halves, then neighbours, then pairs), the last few one
/// by one. (The compiler's own version of that loop transposes the lanes with
/// gathers, several times slower; one sample at a time, horizontally, takes
/// twice the instructions.)
#[target_feature(enable = "avx")]
pub(super) fn add_lane_sums_avx(acc: &[[f64; LANES]], out: &mut [f64]) {
    let n = acc.len().min(out.len());
    let whole = n / 4 * 4;
    for (a, o) in acc[..whole].chunks_exact(4).zip(out[..whole].chunks_exact_mut(4)) {
        // SAFETY: a holds 4 samples of LANES = 8 f64, o 4 f64: unaligned loads and stores within them.
        unsafe {
            // Each sample's halves added: [a0+a4, a1+a5, a2+a6, a3+a7] = [b0, b1, b2, b3].
            let h: [__m256d; 4] = std::array::from_fn(|s| {
                _mm256_add_pd(_mm256_loadu_pd(a[s].as_ptr()), _mm256_loadu_pd(a[s].as_ptr().add(4)))
            });
            // [S0 b0+b1, S1 b0+b1, S0 b2+b3, S1 b2+b3], and the same for samples 2 and 3.
            let t01 = _mm256_hadd_pd(h[0], h[1]);
            let t23 = _mm256_hadd_pd(h[2], h[3]);
            // (b0+b1) + (b2+b3) of samples 0..3.
            let sums =
                _mm256_add_pd(_mm256_permute2f128_pd::<0x20>(t01, t23), _mm256_permute2f128_pd::<0x31>(t01, t23));
            _mm256_storeu_pd(o.as_mut_ptr(), _mm256_add_pd(_mm256_loadu_pd(o.as_ptr()), sums));
        }
    }
    for (o, a) in out[whole..n].iter_mut().zip(&acc[whole..n]) {
        // SAFETY: a is LANES = 8 f64 long: two unaligned loads of 4.
        let lanes = unsafe { _mm256_add_pd(_mm256_loadu_pd(a.as_ptr()), _mm256_loadu_pd(a.as_ptr().add(4))) };
        let pairs = _mm_hadd_pd(_mm256_castpd256_pd128(lanes), _mm256_extractf128_pd::<1>(lanes));
        *o += _mm_cvtsd_f64(_mm_add_sd(pairs, _mm_unpackhi_pd(pairs, pairs)));
    }
}
