//! Zero-phase Butterworth low-pass, the way the strike-case contract compares
//! bridge forces (an 8th-order Butterworth at 20 kHz run forward and backward).
//!
//! Design: the analogue Butterworth poles s_k = w_a exp(i pi (2k + N + 1) / (2N)),
//! prewarped w_a = 2 fs tan(pi fc / fs), mapped by the bilinear transform, paired
//! into second-order sections with their zeros at z = -1 and unit gain at DC.
//! Filtering forward and backward squares the magnitude and cancels the phase;
//! the ends are extended by odd reflection and each pass starts from the
//! steady state of its first sample, so a signal that starts at a nonzero value
//! shows no start-up transient.

use std::f64::consts::PI;

use num_complex::Complex64;

/// One second-order section: b0 + b1 z^-1 + b2 z^-2 over 1 + a1 z^-1 + a2 z^-2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Biquad {
    pub b: [f64; 3],
    pub a: [f64; 2],
}

impl Biquad {
    fn dc_gain(&self) -> f64 {
        (self.b[0] + self.b[1] + self.b[2]) / (1.0 + self.a[0] + self.a[1])
    }

    /// State (transposed direct form II) that a constant input `x` holds steady.
    fn steady_state(&self, x: f64) -> [f64; 2] {
        let y = self.dc_gain() * x;
        let s1 = self.b[2] * x - self.a[1] * y;
        let s0 = self.b[1] * x - self.a[0] * y + s1;
        [s0, s1]
    }

    fn run(&self, signal: &mut [f64], mut state: [f64; 2]) {
        for v in signal.iter_mut() {
            let x = *v;
            let y = self.b[0] * x + state[0];
            state[0] = self.b[1] * x - self.a[0] * y + state[1];
            state[1] = self.b[2] * x - self.a[1] * y;
            *v = y;
        }
    }
}

/// Second-order sections of a digital Butterworth low-pass of even `order`.
pub fn butterworth_lowpass(order: usize, cutoff_hz: f64, sample_rate_hz: f64) -> Vec<Biquad> {
    assert!(order >= 2 && order.is_multiple_of(2), "even order");
    assert!(cutoff_hz > 0.0 && cutoff_hz < sample_rate_hz / 2.0, "cut-off below Nyquist");
    let fs2 = 2.0 * sample_rate_hz;
    let warped = fs2 * (PI * cutoff_hz / sample_rate_hz).tan();
    (0..order / 2)
        .map(|k| {
            let angle = PI * (2 * k + order + 1) as f64 / (2 * order) as f64;
            let s = Complex64::from_polar(warped, angle);
            let z = (fs2 + s) / (fs2 - s);
            // Conjugate pair z, z*: denominator 1 - 2 Re z z^-1 + |z|^2 z^-2; zeros at -1.
            let a = [-2.0 * z.re, z.norm_sqr()];
            let dc = (1.0 + a[0] + a[1]) / 4.0;
            Biquad { b: [dc, 2.0 * dc, dc], a }
        })
        .collect()
}

/// Run `sections` forward then backward over `signal` (zero phase).
pub fn filtfilt(sections: &[Biquad], signal: &[f64]) -> Vec<f64> {
    let n = signal.len();
    if n == 0 {
        return Vec::new();
    }
    let edge = (3 * (2 * sections.len() + 1)).min(n - 1);
    let (first, last) = (signal[0], signal[n - 1]);
    let mut x = Vec::with_capacity(n + 2 * edge);
    x.extend((1..=edge).rev().map(|i| 2.0 * first - signal[i]));
    x.extend_from_slice(signal);
    x.extend((1..=edge).map(|i| 2.0 * last - signal[n - 1 - i]));
    run_cascade(sections, &mut x);
    x.reverse();
    run_cascade(sections, &mut x);
    x.reverse();
    x[edge..edge + n].to_vec()
}

fn run_cascade(sections: &[Biquad], x: &mut [f64]) {
    // Each section starts in the steady state of the signal's first value as it
    // reaches that section.
    let mut level = x[0];
    for s in sections {
        s.run(x, s.steady_state(level));
        level *= s.dc_gain();
    }
}

/// The contract's comparison filter: 8th-order Butterworth at 20 kHz, zero phase.
pub fn lowpass_20k(signal: &[f64], sample_rate_hz: f64) -> Vec<f64> {
    let cutoff = 20_000.0f64.min(0.45 * sample_rate_hz);
    filtfilt(&butterworth_lowpass(8, cutoff, sample_rate_hz), signal)
}

/// RMS of a signal.
pub fn rms(signal: &[f64]) -> f64 {
    if signal.is_empty() {
        return 0.0;
    }
    (signal.iter().map(|v| v * v).sum::<f64>() / signal.len() as f64).sqrt()
}

/// RMS of the difference over RMS of the reference.
pub fn relative_rms_error(signal: &[f64], reference: &[f64]) -> f64 {
    let diff: Vec<f64> = signal.iter().zip(reference).map(|(a, b)| a - b).collect();
    rms(&diff) / rms(&reference[..diff.len()])
}

#[cfg(test)]
mod tests {
    use super::*;

    fn gain_at(sections: &[Biquad], f: f64, fs: f64) -> f64 {
        let z = Complex64::from_polar(1.0, 2.0 * PI * f / fs);
        sections
            .iter()
            .map(|s| {
                let zi = z.inv();
                ((s.b[0] + s.b[1] * zi + s.b[2] * zi * zi) / (1.0 + s.a[0] * zi + s.a[1] * zi * zi)).norm()
            })
            .product()
    }

    #[test]
    fn butterworth_response() {
        let s = butterworth_lowpass(8, 20_000.0, 96_000.0);
        assert!((gain_at(&s, 1.0, 96_000.0) - 1.0).abs() < 1e-12);
        assert!((gain_at(&s, 20_000.0, 96_000.0) - 0.5f64.sqrt()).abs() < 1e-9);
        // Maximally flat: 10 kHz is still within 0.01 dB; 40 kHz is far down.
        assert!(20.0 * gain_at(&s, 10_000.0, 96_000.0).log10() > -0.01);
        assert!(20.0 * gain_at(&s, 40_000.0, 96_000.0).log10() < -60.0);
    }

    #[test]
    fn filtfilt_keeps_slow_signals_and_phase() {
        let fs = 96_000.0;
        let x: Vec<f64> = (0..4000).map(|i| 0.3 + (2.0 * PI * 500.0 * i as f64 / fs).sin()).collect();
        let y = lowpass_20k(&x, fs);
        // Interior exact to 1e-6; the ends carry the reflection's small error (as scipy's do).
        for i in 0..x.len() {
            let tolerance = if (100..x.len() - 100).contains(&i) { 1e-6 } else { 1e-3 };
            assert!((x[i] - y[i]).abs() < tolerance, "{i}");
        }
        // A 30 kHz tone is removed.
        let hf: Vec<f64> = (0..4000).map(|i| (2.0 * PI * 30_000.0 * i as f64 / fs).sin()).collect();
        assert!(rms(&lowpass_20k(&hf, fs)[200..3800]) < 1e-4);
    }
}
