//! The inharmonic stretch: octaves widened as a tuner widens them on stiff strings.
//!
//! On a stiff string the partials run sharp, f_n = n f0 sqrt(1 + B n^2), so an
//! octave tuned beatless (the lower key's second partial on the upper key's
//! first) is wider than 2:1. In first-partial terms the octave from key k is
//!
//!   f_1(k + 12) = 2 f_1(k) sqrt((1 + 4 B_k) / (1 + B_k))
//!
//! (the same condition as f0(k + 12) = 2 f0(k) sqrt(1 + 4 B_k) / sqrt(1 + B_(k+12))
//! written with f0): W_k = 600 log2((1 + 4 B_k) /
//! (1 + B_k)) cents wider than 2:1. Octaves overlap, so each octave's W is spread
//! evenly over its twelve semitones and each semitone takes the mean of the
//! shares of the twelve octaves it belongs to; the semitones are then added up
//! outward from A4 (which stays at the reference). An octave is thereby widened
//! by a triangle-weighted mean of the W of the octaves starting up to eleven keys
//! either side of it: W_k itself wherever W changes evenly from key to key, and
//! smoothly across a
//! change of stringing where B jumps (the exact rule would there put a key
//! below its lower neighbour's stretch). The stretch never turns back: it only
//! rises from bass to treble. A key the instrument lacks takes a B interpolated
//! between its neighbours' (beyond the ends: the nearest key's).
//! [`super::TuningSettings::stretch`] scales all of it: 0 none, 1 the whole. The
//! reference key keeps its frequency: A4, or a keyboard mapping's reference key.
//!

/// The full inharmonic stretch of every key, cents from its tempered pitch (0 at A4).
/// All zeros when no key has a B.
pub fn stretch_cents(inharmonicity: &dyn Fn(u8) -> Option<f64>) -> [f64; 128] {
    let known: Vec<(usize, f64)> = (0..128u8)
        .filter_map(|k| inharmonicity(k).filter(|b| b.is_finite() && *b >= 0.0).map(|b| (k as usize, b)))
        .collect();
    let (Some(&(first, first_b)), Some(&(last, last_b))) = (known.first(), known.last()) else {
        return [0.0; 128];
    };
    let mut b = [0.0f64; 128];
    for (k, b) in b.iter_mut().enumerate() {
        *b = if k <= first {
            first_b
        } else if k >= last {
            last_b
        } else {
            let upper = known.partition_point(|&(key, _)| key < k);
            let (hi, b_hi) = known[upper];
            let (lo, b_lo) = known[upper - 1];
            if hi == k { b_hi } else { b_lo + (b_hi - b_lo) * (k - lo) as f64 / (hi - lo) as f64 }
        };
    }
    // The widening of the octave from key k to k + 12, cents.
    let widening: Vec<f64> = b.iter().map(|&b| 600.0 * ((1.0 + 4.0 * b) / (1.0 + b)).log2()).collect();
    // Each octave's widening spread evenly over its twelve semitones; a semitone
    // takes the mean share of the twelve octaves it belongs to.
    let semitone: Vec<f64> = (0..128)
        .map(|j: usize| (j.saturating_sub(11)..=j).map(|k| widening[k]).sum::<f64>() / (12 * (j.min(11) + 1)) as f64)
        .collect();
    let mut cents = [0.0f64; 128];
    for k in 70..128 {
        cents[k] = cents[k - 1] + semitone[k - 1];
    }
    for k in (0..69).rev() {
        cents[k] = cents[k + 1] - semitone[k];
    }
    cents
}
