//! Spectra of a strike: partial levels, the spectral centroid, and partial
//! tracking (frequency and decay rate of one partial).

use std::cell::RefCell;
use std::f64::consts::PI;

use num_complex::Complex64;
use realfft::RealFftPlanner;

/// Levels below this are reported at it (an exact zero has no decibel value), dB re 1 N.
pub const LEVEL_FLOOR_DB: f64 = -400.0;

thread_local! {
    /// Each thread keeps its FFT plans: planning (the twiddle factors) costs more
    /// than the transform itself, and the lab's sweeps ask for the same lengths
    /// thousands of times.
    static PLANNER: RefCell<RealFftPlanner<f64>> = RefCell::new(RealFftPlanner::new());
}

/// Magnitude spectrum |X(f)| of `signal` (bins 0..=N/2), multiplied by `window` if given.
pub fn magnitude_spectrum(signal: &[f64], window: Option<&[f64]>) -> Vec<f64> {
    let mut input: Vec<f64> = match window {
        Some(w) => signal.iter().zip(w).map(|(x, w)| x * w).collect(),
        None => signal.to_vec(),
    };
    if input.is_empty() {
        return Vec::new();
    }
    let fft = PLANNER.with_borrow_mut(|planner| planner.plan_fft_forward(input.len()));
    let mut spectrum = fft.make_output_vec();
    fft.process(&mut input, &mut spectrum).expect("buffer sizes come from the plan");
    spectrum.iter().map(|c| c.norm()).collect()
}

/// Periodic Hann window of length n.
pub fn hann(n: usize) -> Vec<f64> {
    (0..n).map(|i| 0.5 - 0.5 * (2.0 * PI * i as f64 / n as f64).cos()).collect()
}

/// |X(f)| of `signal` at any frequency (not only on a bin), by Goertzel's recurrence.
pub fn dtft_magnitude(signal: &[f64], frequency_hz: f64, sample_rate_hz: f64) -> f64 {
    let w = 2.0 * PI * frequency_hz / sample_rate_hz;
    let coefficient = 2.0 * w.cos();
    let (mut s1, mut s2) = (0.0, 0.0);
    for &x in signal {
        let s0 = x + coefficient * s1 - s2;
        s2 = s1;
        s1 = s0;
    }
    // X = s1 - e^{-iw} s2 (up to a phase factor).
    let (re, im) = (s1 - w.cos() * s2, w.sin() * s2);
    (re * re + im * im).sqrt()
}

/// The highest value of |X(f)| within [lo, hi] Hz of an already windowed signal,
/// found from the best FFT bin and then refined on the continuous spectrum
/// (a golden-section search over the bin on either side).
fn peak_magnitude(
    windowed: &[f64],
    spectrum: &[f64],
    bin_hz: f64,
    sample_rate_hz: f64,
    lo: f64,
    hi: f64,
) -> Option<f64> {
    let first = (lo / bin_hz).ceil().max(0.0) as usize;
    let last = ((hi / bin_hz).floor() as usize).min(spectrum.len().saturating_sub(1));
    if first > last || first >= spectrum.len() {
        return None;
    }
    let best = (first..=last).max_by(|&a, &b| spectrum[a].total_cmp(&spectrum[b]))?;
    let magnitude = |f: f64| dtft_magnitude(windowed, f, sample_rate_hz);
    let (mut a, mut b) = (((best as f64 - 1.0) * bin_hz).max(lo), ((best as f64 + 1.0) * bin_hz).min(hi));
    let ratio = (5f64.sqrt() - 1.0) / 2.0;
    let (mut c, mut d) = (b - ratio * (b - a), a + ratio * (b - a));
    let (mut fc, mut fd) = (magnitude(c), magnitude(d));
    while b - a > 1e-6 * bin_hz {
        if fc > fd {
            (b, d, fd) = (d, c, fc);
            c = b - ratio * (b - a);
            fc = magnitude(c);
        } else {
            (a, c, fc) = (c, d, fd);
            d = a + ratio * (b - a);
            fd = magnitude(d);
        }
    }
    Some(spectrum[best].max(fc).max(fd))
}

/// Level of each predicted partial in `signal` (the first `window_s` seconds,
/// Hann-windowed): the peak of the windowed spectrum (continuous in frequency,
/// not only its bins) within 0.3 partial spacings of the prediction, as a
/// sinusoid's amplitude 2 |X| / sum(w), in dB re 1 unit. `None` where the search
/// range lies beyond Nyquist.
pub fn partial_levels_db(signal: &[f64], sample_rate_hz: f64, window_s: f64, predicted_hz: &[f64]) -> Vec<Option<f64>> {
    let n = ((window_s * sample_rate_hz).round() as usize).min(signal.len());
    let window = hann(n);
    let windowed: Vec<f64> = signal[..n].iter().zip(&window).map(|(x, w)| x * w).collect();
    let spectrum = magnitude_spectrum(&windowed, None);
    let window_sum: f64 = window.iter().sum();
    let bin_hz = sample_rate_hz / n as f64;
    predicted_hz
        .iter()
        .enumerate()
        .map(|(i, &f)| {
            let below = if i == 0 { f } else { f - predicted_hz[i - 1] };
            let above = predicted_hz.get(i + 1).map_or(below, |g| g - f);
            let (lo, hi) = (f - 0.3 * below, (f + 0.3 * above).min(sample_rate_hz / 2.0));
            let peak = peak_magnitude(&windowed, &spectrum, bin_hz, sample_rate_hz, lo, hi)?;
            let amplitude = 2.0 * peak / window_sum;
            Some((20.0 * amplitude.log10()).max(LEVEL_FLOOR_DB))
        })
        .collect()
}

/// Centroid of the magnitude spectrum, sum f |X(f)| / sum |X(f)| over 0..fs/2;
/// `None` for a signal that is zero throughout.
pub fn spectral_centroid_hz(signal: &[f64], sample_rate_hz: f64) -> Option<f64> {
    spectral_centroid_padded_hz(signal, sample_rate_hz, signal.len())
}

/// [`spectral_centroid_hz`] of `signal` followed by zeros up to `length` samples
/// (no padding when `length` is shorter than the signal): the same centroid as
/// of a longer record whose tail is silent, read on bins fs / length apart.
pub fn spectral_centroid_padded_hz(signal: &[f64], sample_rate_hz: f64, length: usize) -> Option<f64> {
    let mut padded = signal.to_vec();
    padded.resize(length.max(signal.len()), 0.0);
    let spectrum = magnitude_spectrum(&padded, None);
    let bin_hz = sample_rate_hz / padded.len() as f64;
    let total: f64 = spectrum.iter().sum();
    if total.is_nan() || total <= 0.0 {
        return None;
    }
    Some(spectrum.iter().enumerate().map(|(k, m)| k as f64 * bin_hz * m).sum::<f64>() / total)
}

/// One partial as tracked in a signal.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TrackedPartial {
    pub frequency_hz: f64,
    /// Amplitude decay rate sigma (the partial goes as exp(-sigma t)), 1/s.
    pub decay_rate_s: f64,
}

/// Frequency and decay rate of the partial near `guess_hz`, from `start_s` on.
///
/// The signal is demodulated at the guess and summed in Hann-windowed frames of
/// `frame_s` (long enough to separate the partial from its neighbours); a damped
/// sinusoid gives frames whose phase advances by 2 pi (f - guess) per second and
/// whose log magnitude falls by sigma per second, and a least-squares line through
/// each gives f and sigma. Frames advance by half their length.
pub fn track_partial(signal: &[f64], sample_rate_hz: f64, guess_hz: f64, start_s: f64, frame_s: f64) -> TrackedPartial {
    let frame = (frame_s * sample_rate_hz).round() as usize;
    let hop = frame / 2;
    let window = hann(frame);
    let start = (start_s * sample_rate_hz).round() as usize;
    let w = 2.0 * PI * guess_hz / sample_rate_hz;
    let mut times = Vec::new();
    let mut phases = Vec::new();
    let mut logs = Vec::new();
    let mut begin = start;
    while begin + frame <= signal.len() {
        let sum: Complex64 = (0..frame)
            .map(|i| {
                let k = begin + i;
                Complex64::from_polar(signal[k] * window[i], -w * k as f64)
            })
            .sum();
        times.push((begin as f64 + frame as f64 / 2.0) / sample_rate_hz);
        let mut phase = sum.arg();
        if let Some(&prev) = phases.last() {
            while phase - prev > PI {
                phase -= 2.0 * PI;
            }
            while phase - prev < -PI {
                phase += 2.0 * PI;
            }
        }
        phases.push(phase);
        logs.push(sum.norm().ln());
        begin += hop;
    }
    TrackedPartial { frequency_hz: guess_hz + slope(&times, &phases) / (2.0 * PI), decay_rate_s: -slope(&times, &logs) }
}

fn slope(x: &[f64], y: &[f64]) -> f64 {
    let n = x.len() as f64;
    let (mx, my) = (x.iter().sum::<f64>() / n, y.iter().sum::<f64>() / n);
    let sxy: f64 = x.iter().zip(y).map(|(a, b)| (a - mx) * (b - my)).sum();
    let sxx: f64 = x.iter().map(|a| (a - mx) * (a - mx)).sum();
    sxy / sxx
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn partial_level_of_a_pure_tone_on_a_bin() {
        let fs = 96_000.0;
        // 0.5 s window: 2 Hz bins; 440 Hz sits on a bin; amplitude 0.25 -> -12.04 dB.
        let x: Vec<f64> = (0..48_000).map(|i| 0.25 * (2.0 * PI * 440.0 * i as f64 / fs).cos()).collect();
        let levels = partial_levels_db(&x, fs, 0.5, &[440.0, 880.0]);
        assert!((levels[0].unwrap() - 20.0 * 0.25f64.log10()).abs() < 1e-6);
        assert!(levels[1].unwrap() < -100.0);
    }

    #[test]
    fn partial_level_between_bins_is_read_at_its_true_peak() {
        // 441 Hz lies half a bin off: the best bin alone would read 1.42 dB low.
        let fs = 96_000.0;
        let x: Vec<f64> = (0..48_000).map(|i| 0.25 * (2.0 * PI * 441.0 * i as f64 / fs).cos()).collect();
        let level = partial_levels_db(&x, fs, 0.5, &[441.0])[0].unwrap();
        assert!((level - 20.0 * 0.25f64.log10()).abs() < 1e-3, "{level}");
    }

    #[test]
    fn goertzel_matches_the_fft_on_a_bin() {
        let x: Vec<f64> = (0..1000).map(|i| ((i * 7919) % 113) as f64 - 56.0).collect();
        let spectrum = magnitude_spectrum(&x, None);
        for k in [0usize, 3, 77, 500] {
            let g = dtft_magnitude(&x, k as f64, 1000.0);
            assert!((g - spectrum[k]).abs() < 1e-9 * spectrum[k].max(1.0), "{k}");
        }
    }

    #[test]
    fn centroid_of_two_tones() {
        let fs = 1000.0;
        let x: Vec<f64> = (0..1000)
            .map(|i| {
                let t = i as f64 / fs;
                (2.0 * PI * 100.0 * t).sin() + 3.0 * (2.0 * PI * 300.0 * t).sin()
            })
            .collect();
        assert!((spectral_centroid_hz(&x, fs).unwrap() - 250.0).abs() < 1e-6);
        assert_eq!(spectral_centroid_hz(&[0.0; 16], fs), None);
    }

    #[test]
    fn tracks_a_damped_partial_among_neighbours() {
        let fs = 44_100.0;
        let (f, sigma) = (32.713, 0.37);
        let x: Vec<f64> = (0..(4.0 * fs) as usize)
            .map(|i| {
                let t = i as f64 / fs;
                (-sigma * t).exp() * (2.0 * PI * f * t + 0.3).cos()
                    + 0.8 * (-1.1 * t).exp() * (2.0 * PI * 65.43 * t).cos()
                    + 0.5 * (2.0 * PI * 98.2 * t).sin()
            })
            .collect();
        let p = track_partial(&x, fs, 32.7, 0.0, 0.5);
        assert!((p.frequency_hz - f).abs() < 1e-5, "{}", p.frequency_hz);
        assert!((p.decay_rate_s - sigma).abs() < 1e-4, "{}", p.decay_rate_s);
    }
}
