//! The features `struck compare` measures on one note, whatever made it: a
//! recording of the real grand, a Struck render, a yardstick's render.
//!
//! Every measurement works on the mono sum of the channels from the note's
//! onset, below a band edge (the recording's lossy codec cuts everything
//! above 6-15 kHz, so every source is measured below the recording's own
//! cutoff) and before a usable end (the recordings fade out over their last
//! second). Partials are found on a long spectrum and fitted to the stiff
//! string's series f_n = n f0 sqrt(1 + B n^2); their levels are followed in
//! short frames, as band energies around each partial, so that a unison's
//! detuned strings count as one partial.

use std::f64::consts::PI;
use std::sync::Arc;

mod envelope;

use envelope::*;
pub use envelope::{Frame, decay_rate, fall_time, onset};

use realfft::{RealFftPlanner, RealToComplex};
use serde::Serialize;

/// Partials whose decay is fitted (F2).
pub const DECAY_PARTIALS: usize = 8;
/// Partials of the spectral envelope (F3).
pub const ENVELOPE_PARTIALS: usize = 12;
/// The early and late spans of the decay fits, s after the onset.
pub const EARLY_SPAN_S: (f64, f64) = (0.3, 2.0);
pub const LATE_SPAN_S: (f64, f64) = (2.0, 6.0);
/// The spectral envelope's window, s after the onset.
pub const ENVELOPE_SPAN_S: (f64, f64) = (0.05, 0.3);
/// The early centroid's window, s after the onset.
pub const CENTROID_SPAN_S: f64 = 0.2;
/// The attack window: from a little before the onset to 30 ms after it.
pub const ATTACK_SPAN_S: (f64, f64) = (-0.005, 0.030);
/// The window of the loudness figure (F5, F6), s after the onset.
pub const LEVEL_SPAN_S: f64 = 0.5;
/// The "boom" window, s after the onset.
pub const BOOM_SPAN_S: f64 = 0.3;
/// A decay fit stops where the partial comes within this of its floor, dB.
pub const FLOOR_MARGIN_DB: f64 = 10.0;
/// Decay rates are taken as at least this (a flat or growing partial), dB/s,
/// so that a ratio of rates stays finite.
pub const MIN_DECAY_DB_S: f64 = 0.2;
/// The fall the decay time is measured for (F7), dB.
pub const FALL_DB: f64 = 40.0;
/// How far from its nominal pitch f0 is searched for, semitones.
pub const F0_SEARCH_SEMITONES: f64 = 1.5;
/// Partials at most fitted for B.
const MAX_FIT_PARTIALS: usize = 25;
/// Highest partial frequency fitted for B, Hz (above, the bridge's and the
/// longitudinal modes' influence shift partials off the stiff-string series).
const MAX_FIT_HZ: f64 = 8_000.0;
/// Largest B a fit may give (a piano's top strings reach a few hundredths;
/// three partials found in noise can give anything).
const MAX_B: f64 = 0.05;
/// A spectral peak counts as a partial this far above its neighbourhood, dB.
const PEAK_PROMINENCE_DB: f64 = 10.0;

/// What is known of a note before it is measured.
#[derive(Clone, Copy, Debug)]
pub struct Context {
    /// The note's equal-tempered pitch, Hz.
    pub nominal_hz: f64,
    /// Everything is measured below this, Hz.
    pub band_hz: f64,
    /// Samples after this (s from the file's start) are not used.
    pub usable_end_s: f64,
}

/// A note's features (see the module's doc and docs/comparison.md).
#[derive(Clone, Debug, Default, Serialize)]
pub struct Features {
    /// Onset, s from the file's start.
    pub onset_s: f64,
    /// The codec's cutoff found in this file, Hz (the Nyquist frequency when none).
    pub cutoff_hz: f64,
    /// The fitted fundamental, Hz.
    pub f0_hz: Option<f64>,
    /// The fitted inharmonicity coefficient (F1).
    pub inharmonicity: Option<f64>,
    /// Partials the fit used.
    pub fitted_partials: usize,
    /// Partials 1..=12 where they were found or predicted, Hz.
    pub partial_hz: Vec<f64>,
    /// Decay rates of partials 1..=8 over 0.3-2 s (F2a), dB/s (positive: decaying).
    pub decay_early_db_s: Vec<Option<f64>>,
    /// The same over 2-6 s (F2b).
    pub decay_late_db_s: Vec<Option<f64>>,
    /// How many of the early fits grow.
    pub growing_early: usize,
    /// Partials 1..=12, dB re the strongest, 0.05-0.3 s (F3); None above the band.
    pub envelope_db: Vec<Option<f64>>,
    /// Spectral centroid over the first 0.2 s (F4a), Hz.
    pub centroid_hz: Option<f64>,
    /// Level over the first 0.5 s (F5, F6), dB re full scale (the sum of the channels).
    pub level_db: f64,
    /// Time to fall 40 dB from the peak (F7), s.
    pub fall_time_s: Option<f64>,
    /// Whether [`Self::fall_time_s`] was extrapolated from a fit (the floor came first).
    pub fall_extrapolated: bool,
    /// Energy off the partials in the attack (F8), dB re the total; None where
    /// the partials lie too close for the window to tell them apart.
    pub attack_noise_db: Option<f64>,
    /// Share of the energy below 0.8 f0 over the first 0.3 s.
    pub boom_share: f64,
}

/// The measurements' FFTs, planned once.
pub struct Analyzer {
    planner: RealFftPlanner<f64>,
}

impl Default for Analyzer {
    fn default() -> Self {
        Self::new()
    }
}

/// A power spectrum: bin k is at k * `bin_hz`.
struct Spectrum {
    power: Vec<f64>,
    bin_hz: f64,
}

impl Spectrum {
    fn bin(&self, hz: f64) -> usize {
        ((hz / self.bin_hz).round().max(0.0) as usize).min(self.power.len() - 1)
    }

    /// Energy in [lo, hi] Hz.
    fn band(&self, lo_hz: f64, hi_hz: f64) -> f64 {
        if hi_hz < lo_hz {
            return 0.0;
        }
        let (a, b) = (self.bin(lo_hz), self.bin(hi_hz));
        self.power[a..=b].iter().sum()
    }

    fn db(&self, k: usize) -> f64 {
        10.0 * (self.power[k] + 1e-300).log10()
    }
}

fn db(power: f64) -> f64 {
    10.0 * (power + 1e-300).log10()
}

fn hann(n: usize) -> Vec<f64> {
    (0..n).map(|i| 0.5 - 0.5 * (2.0 * PI * (i as f64 + 0.5) / n as f64).cos()).collect()
}

/// Mono sum of interleaved channels.
pub fn mono_sum(interleaved: &[f32], channels: usize) -> Vec<f64> {
    interleaved.chunks_exact(channels.max(1)).map(|frame| frame.iter().map(|&s| f64::from(s)).sum()).collect()
}

/// Least-squares line y = a + b x: (a, b).
fn line_fit(points: &[(f64, f64)]) -> Option<(f64, f64)> {
    let n = points.len() as f64;
    if points.len() < 2 {
        return None;
    }
    let mx = points.iter().map(|p| p.0).sum::<f64>() / n;
    let my = points.iter().map(|p| p.1).sum::<f64>() / n;
    let sxx: f64 = points.iter().map(|p| (p.0 - mx).powi(2)).sum();
    if sxx <= 0.0 {
        return None;
    }
    let sxy: f64 = points.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum();
    let b = sxy / sxx;
    Some((my - b * mx, b))
}

/// The frequency of partial `n` of a stiff string.
pub fn stiff_partial_hz(n: usize, f0_hz: f64, b: f64) -> f64 {
    let n = n as f64;
    n * f0_hz * (1.0 + b * n * n).sqrt()
}

/// The median of `values` (None when empty).
pub fn median(values: &[f64]) -> Option<f64> {
    quantile(values, 0.5)
}

/// The `q` quantile of `values`, linearly interpolated (None when empty).
pub fn quantile(values: &[f64], q: f64) -> Option<f64> {
    let mut v: Vec<f64> = values.iter().copied().filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return None;
    }
    v.sort_by(f64::total_cmp);
    let at = q.clamp(0.0, 1.0) * (v.len() - 1) as f64;
    let (lo, hi) = (at.floor() as usize, at.ceil() as usize);
    Some(v[lo] + (v[hi] - v[lo]) * (at - lo as f64))
}

impl Analyzer {
    pub fn new() -> Self {
        Self { planner: RealFftPlanner::new() }
    }

    fn plan(&mut self, n: usize) -> Arc<dyn RealToComplex<f64>> {
        self.planner.plan_fft_forward(n)
    }

    /// The power spectrum of `segment` times `window`, zero-padded to `n_fft`.
    fn spectrum(&mut self, segment: &[f64], window: &[f64], n_fft: usize, fs: f64) -> Spectrum {
        let fft = self.plan(n_fft);
        let mut input = fft.make_input_vec();
        for (i, (s, w)) in segment.iter().zip(window).enumerate().take(n_fft) {
            input[i] = s * w;
        }
        let mut output = fft.make_output_vec();
        // (The lengths are the plan's own: it cannot fail.)
        let _ = fft.process(&mut input, &mut output);
        Spectrum { power: output.iter().map(|c| c.norm_sqr()).collect(), bin_hz: fs / n_fft as f64 }
    }

    /// The spectrum of `signal` over [start, end) samples, Hann-windowed,
    /// zero-padded `pad` times (to a power of two).
    fn hann_spectrum(&mut self, signal: &[f64], start: usize, end: usize, pad: usize, fs: f64) -> Spectrum {
        let end = end.min(signal.len());
        let start = start.min(end);
        let segment = &signal[start..end];
        let n_fft = (segment.len().max(16) * pad).next_power_of_two();
        self.spectrum(segment, &hann(segment.len()), n_fft, fs)
    }

    /// Measure every feature of one note.
    pub fn measure(&mut self, signal: &[f64], fs: f64, ctx: &Context) -> Features {
        let usable = ((ctx.usable_end_s * fs) as usize).min(signal.len());
        let signal = &signal[..usable];
        let onset = onset(signal, fs);
        let at = |s: f64| onset.saturating_add_signed((s * fs).round() as isize).min(signal.len());
        let cutoff_hz = self.cutoff(signal, onset, fs);
        let band = ctx.band_hz.min(0.5 * fs);

        let fit = self.fit_partials(signal, onset, fs, ctx.nominal_hz, band);
        let f0 = fit.f0_hz;
        let partial_hz: Vec<f64> = (1..=ENVELOPE_PARTIALS).map(|n| stiff_partial_hz(n, f0, fit.b)).collect();

        let tracks: Vec<Vec<Frame>> =
            partial_hz[..DECAY_PARTIALS].iter().map(|&hz| self.track(signal, onset, fs, hz, f0, band)).collect();
        let decay = |span: (f64, f64)| -> Vec<Option<f64>> { tracks.iter().map(|t| decay_rate(t, span)).collect() };
        let decay_early_db_s = decay(EARLY_SPAN_S);
        let decay_late_db_s = decay(LATE_SPAN_S);
        let growing_early = decay_early_db_s.iter().flatten().filter(|&&r| r < 0.0).count();

        let envelope_db =
            self.envelope(signal, at(ENVELOPE_SPAN_S.0), at(ENVELOPE_SPAN_S.1), fs, &partial_hz, f0, band);
        let centroid_hz = self.centroid(signal, onset, at(CENTROID_SPAN_S), fs, band);
        let level_db =
            db(signal[onset..at(LEVEL_SPAN_S)].iter().map(|x| x * x).sum::<f64>() / (LEVEL_SPAN_S * fs).max(1.0));
        let (fall_time_s, fall_extrapolated) = match fall_time(signal, onset, fs) {
            Some((t, e)) => (Some(t), e),
            None => (None, false),
        };
        // The attack's window has the same length whatever the onset: what
        // would come before the file's start is silence.
        let attack: Vec<f64> = {
            let from = onset as isize + (ATTACK_SPAN_S.0 * fs).round() as isize;
            let len = ((ATTACK_SPAN_S.1 - ATTACK_SPAN_S.0) * fs).round() as isize;
            (from..from + len)
                .map(|i| usize::try_from(i).ok().and_then(|i| signal.get(i)).copied().unwrap_or(0.0))
                .collect()
        };
        let attack_noise_db = self.attack_noise(&attack, 0, attack.len(), fs, f0, fit.b, band);
        let boom_share = {
            let s = self.hann_spectrum(signal, onset, at(BOOM_SPAN_S), 4, fs);
            let total = s.band(10.0, band);
            if total > 0.0 { s.band(10.0, 0.8 * f0) / total } else { 0.0 }
        };
        Features {
            onset_s: onset as f64 / fs,
            cutoff_hz,
            f0_hz: fit.found.then_some(f0),
            inharmonicity: fit.b_fitted.then_some(fit.b),
            fitted_partials: fit.used,
            partial_hz,
            decay_early_db_s,
            decay_late_db_s,
            growing_early,
            envelope_db,
            centroid_hz,
            level_db,
            fall_time_s,
            fall_extrapolated,
            attack_noise_db,
            boom_share,
        }
    }

    /// Where a lossy codec cut the spectrum: the top of the highest 100-Hz
    /// band standing 40 dB above the quietest band, over the first second.
    /// The Nyquist frequency when the spectrum reaches it.
    pub fn cutoff(&mut self, signal: &[f64], onset: usize, fs: f64) -> f64 {
        let n = 8192usize;
        let end = (onset + fs as usize).min(signal.len());
        if end < onset + n {
            return 0.5 * fs;
        }
        let window = hann(n);
        let mut sum = vec![0.0; n / 2 + 1];
        let mut frames = 0;
        let mut start = onset;
        while start + n <= end {
            let s = self.spectrum(&signal[start..start + n], &window, n, fs);
            for (a, p) in sum.iter_mut().zip(&s.power) {
                *a += p;
            }
            frames += 1;
            start += n / 2;
        }
        let spectrum = Spectrum { power: sum.iter().map(|p| p / frames as f64).collect(), bin_hz: fs / n as f64 };
        let band_hz = 100.0;
        let bands: Vec<f64> = (0..(0.5 * fs / band_hz) as usize)
            .map(|i| db(spectrum.band(i as f64 * band_hz, (i + 1) as f64 * band_hz - spectrum.bin_hz)))
            .collect();
        let floor = bands.iter().copied().fold(f64::INFINITY, f64::min);
        match bands.iter().rposition(|&b| b > floor + 40.0) {
            Some(i) if i + 3 < bands.len() => (i + 1) as f64 * band_hz,
            _ => 0.5 * fs,
        }
    }

    /// Find f0 (near nominal) and B on a long spectrum: a grid search for the
    /// series that lands on the most prominent peaks, then peaks picked near
    /// its partials and a least-squares fit of f_n^2 / n^2 = f0^2 + f0^2 B n^2.
    fn fit_partials(&mut self, signal: &[f64], onset: usize, fs: f64, nominal_hz: f64, band_hz: f64) -> PartialFit {
        let start = onset + (0.01 * fs) as usize;
        let len = ((3.0 * fs) as usize).min(signal.len().saturating_sub(start));
        let fallback = PartialFit { f0_hz: nominal_hz, b: 0.0, b_fitted: false, found: false, used: 0 };
        if len < (0.1 * fs) as usize {
            return fallback;
        }
        let s = self.hann_spectrum(signal, start, start + len, 4, fs);
        let top_hz = band_hz.min(MAX_FIT_HZ).min(0.45 * fs);
        // A bin scores when it stands out of its neighbourhood's floor (the
        // 30th percentile of each stretch of nominal_hz), by how near it
        // comes to the neighbourhood's strongest peak: a partial scores up
        // to 30, a sideband or a body's resonance 30 dB under it nothing.
        let (floor, top) = local_floor(&s, nominal_hz);
        let score = |k: usize| {
            if s.db(k) - floor[k] < PEAK_PROMINENCE_DB { 0.0 } else { (30.0 + s.db(k) - top[k]).clamp(0.0, 30.0) }
        };
        // Each bin scored by the best within a tolerance of it.
        let tolerance = ((0.04 * nominal_hz / s.bin_hz).round() as usize).max(1);
        let raw: Vec<f64> = (0..s.power.len()).map(score).collect();
        let smeared = running_max(&raw, tolerance);

        let max_n = ((top_hz / nominal_hz) as usize).clamp(1, MAX_FIT_PARTIALS);
        let ratio = 2f64.powf(F0_SEARCH_SEMITONES / 12.0);
        let (f_lo, f_hi) = (nominal_hz / ratio, nominal_hz * ratio);
        let f_steps = (1200.0 * (f_hi / f_lo).log2() / 2.0).ceil() as usize;
        let b_values: Vec<f64> =
            std::iter::once(0.0).chain((0..).map(|i| 1e-6 * 1.05f64.powi(i)).take_while(|&b| b <= 0.1)).collect();
        let mut best = (f64::NEG_INFINITY, nominal_hz, 0.0);
        for i in 0..=f_steps {
            let f0 = f_lo * (f_hi / f_lo).powf(i as f64 / f_steps as f64);
            for &b in &b_values {
                let mut score = 0.0;
                for n in 1..=max_n {
                    let hz = stiff_partial_hz(n, f0, b);
                    if hz >= top_hz {
                        break;
                    }
                    score += smeared[s.bin(hz)];
                }
                if score > best.0 {
                    best = (score, f0, b);
                }
            }
        }
        if best.0 <= 0.0 {
            return fallback;
        }
        let (mut f0, mut b) = (best.1, best.2);
        let mut used = 0;
        let mut b_fitted = false;
        for pass in 0..3 {
            let width = if pass == 0 { 0.1 } else { 0.05 };
            let mut peaks: Vec<(usize, f64)> = Vec::new();
            for n in 1..=max_n {
                let hz = stiff_partial_hz(n, f0, b);
                if hz >= top_hz {
                    break;
                }
                let (a, z) = (s.bin(hz - width * f0), s.bin(hz + width * f0));
                let Some(k) = (a..=z).max_by(|&x, &y| s.power[x].total_cmp(&s.power[y])) else { continue };
                if k == 0 || k + 1 >= s.power.len() || k == a || k == z || s.db(k) - floor[k] < PEAK_PROMINENCE_DB {
                    continue;
                }
                // Parabolic interpolation on dB.
                let (l, c, r) = (s.db(k - 1), s.db(k), s.db(k + 1));
                let den = l - 2.0 * c + r;
                let delta = if den.abs() > 1e-12 { (0.5 * (l - r) / den).clamp(-0.5, 0.5) } else { 0.0 };
                peaks.push((n, (k as f64 + delta) * s.bin_hz));
            }
            let fitted = fit_stiff_series(&peaks);
            match fitted {
                Some((f, bb, u)) if (-1e-3..=MAX_B).contains(&bb) && (f_lo..=f_hi).contains(&f) => {
                    f0 = f;
                    b = bb.max(0.0);
                    used = u;
                    b_fitted = true;
                }
                _ => {
                    // Too few partials: f0 from the first partial found, if any.
                    if let Some(&(n, hz)) = peaks.first() {
                        f0 = hz / (n as f64 * (1.0 + b * (n * n) as f64).sqrt());
                    }
                    used = peaks.len();
                    b_fitted = false;
                    break;
                }
            }
        }
        let found = (f_lo..=f_hi).contains(&f0);
        if !found {
            return fallback;
        }
        PartialFit { f0_hz: f0, b, b_fitted, found, used }
    }

    /// Band level of the partial at `hz` in short frames, and the level of
    /// the gaps beside it (half way to the next partials, as wide together
    /// as the partial's band: noise and the floor): (s after onset, dB, dB).
    fn track(&mut self, signal: &[f64], onset: usize, fs: f64, hz: f64, f0: f64, band_hz: f64) -> Vec<Frame> {
        if hz >= band_hz {
            return Vec::new();
        }
        let frame = ((6.0 / f0).clamp(0.05, 0.25) * fs) as usize;
        let hop = (0.025 * fs) as usize;
        let n_fft = (frame * 2).next_power_of_two();
        let window = hann(frame);
        let fft = self.plan(n_fft);
        let mut input = fft.make_input_vec();
        let mut output = fft.make_output_vec();
        let bin_hz = fs / n_fft as f64;
        let (a, b) =
            (((hz - 0.3 * f0) / bin_hz).round().max(0.0) as usize, ((hz + 0.3 * f0) / bin_hz).round() as usize);
        let b = b.min(n_fft / 2);
        let bin = |f: f64| ((f / bin_hz).round().max(0.0) as usize).min(n_fft / 2);
        let gaps = [(bin(hz - 0.65 * f0), bin(hz - 0.35 * f0)), (bin(hz + 0.35 * f0), bin(hz + 0.65 * f0))];
        let mut out: Vec<Frame> = Vec::new();
        let mut start = onset;
        while start + frame <= signal.len() {
            input.iter_mut().for_each(|x| *x = 0.0);
            for (i, (x, w)) in signal[start..start + frame].iter().zip(&window).enumerate() {
                input[i] = x * w;
            }
            let _ = fft.process(&mut input, &mut output);
            let energy: f64 = output[a..=b].iter().map(|c| c.norm_sqr()).sum();
            let gap: f64 = gaps.iter().map(|&(x, y)| output[x..=y].iter().map(|c| c.norm_sqr()).sum::<f64>()).sum();
            out.push(Frame {
                t: (start - onset) as f64 / fs + 0.5 * frame as f64 / fs,
                level: db(energy),
                floor: db(gap),
            });
            start += hop;
        }
        smooth(&mut out);
        out
    }

    #[allow(clippy::too_many_arguments)]
    fn envelope(
        &mut self,
        signal: &[f64],
        start: usize,
        end: usize,
        fs: f64,
        partial_hz: &[f64],
        f0: f64,
        band_hz: f64,
    ) -> Vec<Option<f64>> {
        if end <= start + 16 {
            return vec![None; partial_hz.len()];
        }
        let s = self.hann_spectrum(signal, start, end, 4, fs);
        let levels: Vec<Option<f64>> = partial_hz
            .iter()
            .map(|&hz| (hz + 0.3 * f0 < band_hz).then(|| db(s.band(hz - 0.3 * f0, hz + 0.3 * f0))))
            .collect();
        let strongest = levels.iter().flatten().copied().fold(f64::NEG_INFINITY, f64::max);
        levels.into_iter().map(|l| l.map(|l| (l - strongest).max(-60.0))).collect()
    }

    /// Magnitude-weighted centroid of [start, end) (ends tapered over 2 ms), 20 Hz to the band.
    fn centroid(&mut self, signal: &[f64], start: usize, end: usize, fs: f64, band_hz: f64) -> Option<f64> {
        if end <= start + 16 {
            return None;
        }
        let len = end - start;
        let taper = ((0.002 * fs) as usize).min(len / 4).max(1);
        let window: Vec<f64> = (0..len)
            .map(|i| {
                let e = i.min(len - 1 - i);
                if e < taper { 0.5 - 0.5 * (PI * (e as f64 + 0.5) / taper as f64).cos() } else { 1.0 }
            })
            .collect();
        let s = self.spectrum(&signal[start..end], &window, (len * 2).next_power_of_two(), fs);
        let (a, b) = (s.bin(20.0), s.bin(band_hz));
        let (mut num, mut den) = (0.0, 0.0);
        for k in a..=b {
            let m = s.power[k].sqrt();
            num += k as f64 * s.bin_hz * m;
            den += m;
        }
        (den > 0.0).then(|| num / den)
    }

    /// Energy more than a main lobe away from every partial, dB re all
    /// energy from 20 Hz to the band, over [start, end) (Hann). None when the
    /// partials lie closer than three main lobes (low notes).
    #[allow(clippy::too_many_arguments)]
    fn attack_noise(
        &mut self,
        signal: &[f64],
        start: usize,
        end: usize,
        fs: f64,
        f0: f64,
        b: f64,
        band_hz: f64,
    ) -> Option<f64> {
        let len = end.checked_sub(start)?;
        let lobe_hz = 2.0 * fs / len.max(1) as f64;
        if f0 < 3.0 * lobe_hz || len < 16 {
            return None;
        }
        let s = self.hann_spectrum(signal, start, end, 4, fs);
        let (a, z) = (s.bin(20.0), s.bin(band_hz));
        let mut partials = Vec::new();
        for n in 1.. {
            let hz = stiff_partial_hz(n, f0, b);
            if hz > band_hz + lobe_hz {
                break;
            }
            partials.push(hz);
        }
        let (mut off, mut total) = (0.0, 0.0);
        let mut next = 0;
        for k in a..=z {
            let hz = k as f64 * s.bin_hz;
            while next + 1 < partials.len() && partials[next + 1] <= hz {
                next += 1;
            }
            let near = partials[next.saturating_sub(1)..(next + 2).min(partials.len())]
                .iter()
                .any(|&p| (p - hz).abs() <= lobe_hz);
            total += s.power[k];
            if !near {
                off += s.power[k];
            }
        }
        (total > 0.0).then(|| db(off / total))
    }
}

struct PartialFit {
    f0_hz: f64,
    b: f64,
    b_fitted: bool,
    /// Whether a series was found at all.
    found: bool,
    used: usize,
}

/// Fit (n, f_n) to f_n^2 / n^2 = f0^2 (1 + B n^2), dropping outliers
/// (more than 3 median deviations and 2 cents off): (f0, B, partials used).
/// At least three partials are needed.
fn fit_stiff_series(peaks: &[(usize, f64)]) -> Option<(f64, f64, usize)> {
    let mut points: Vec<(usize, f64)> = peaks.to_vec();
    for _ in 0..4 {
        if points.len() < 3 {
            return None;
        }
        let xy: Vec<(f64, f64)> = points.iter().map(|&(n, hz)| ((n * n) as f64, hz * hz / (n * n) as f64)).collect();
        let (a, c) = line_fit(&xy)?;
        if a <= 0.0 {
            return None;
        }
        let (f0, b) = (a.sqrt(), c / a);
        let cents: Vec<f64> = points
            .iter()
            .map(|&(n, hz)| 1200.0 * (hz / stiff_partial_hz(n, f0, b.max(-0.5 / (n * n) as f64))).log2())
            .collect();
        let abs: Vec<f64> = cents.iter().map(|c| c.abs()).collect();
        let mad = median(&abs).unwrap_or(0.0);
        let limit = (3.0 * mad).max(2.0);
        let kept: Vec<(usize, f64)> =
            points.iter().zip(&cents).filter(|(_, c)| c.abs() <= limit).map(|(p, _)| *p).collect();
        if kept.len() == points.len() {
            return Some((f0, b, points.len()));
        }
        points = kept;
    }
    None
}

/// The 30th percentile of the spectrum's dB in stretches of `width_hz`
/// (a partial's neighbourhood level), and the highest dB in its stretch
/// and the two beside it, per bin.
fn local_floor(s: &Spectrum, width_hz: f64) -> (Vec<f64>, Vec<f64>) {
    let chunk = ((width_hz / s.bin_hz) as usize).max(8);
    let mut floor = vec![0.0; s.power.len()];
    let mut highest = Vec::new();
    for (c, out) in floor.chunks_mut(chunk).enumerate() {
        let from = c * chunk;
        let values: Vec<f64> = (from..from + out.len()).map(|k| s.db(k)).collect();
        let level = quantile(&values, 0.3).unwrap_or(-300.0);
        out.iter_mut().for_each(|x| *x = level);
        highest.push(values.iter().copied().fold(f64::NEG_INFINITY, f64::max));
    }
    let top = (0..s.power.len())
        .map(|k| {
            let c = k / chunk;
            highest[c.saturating_sub(1)..(c + 2).min(highest.len())].iter().copied().fold(f64::NEG_INFINITY, f64::max)
        })
        .collect();
    (floor, top)
}

/// The maximum of `values` within `radius` of each index.
fn running_max(values: &[f64], radius: usize) -> Vec<f64> {
    let n = values.len();
    // Two passes of a van Herk / Gil-Werman-like block max would be faster;
    // a deque keeps it O(n) and simple.
    let mut out = vec![0.0; n];
    let mut deque: std::collections::VecDeque<usize> = std::collections::VecDeque::new();
    let mut next = 0;
    for (i, o) in out.iter_mut().enumerate() {
        while next < n && next <= i + radius {
            while deque.back().is_some_and(|&j| values[j] <= values[next]) {
                deque.pop_back();
            }
            deque.push_back(next);
            next += 1;
        }
        while deque.front().is_some_and(|&j| j + radius < i) {
            deque.pop_front();
        }
        *o = deque.front().map_or(0.0, |&j| values[j]);
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f64 = 48_000.0;

    /// A struck stiff string's sound: partial n at n f0 sqrt(1 + B n^2),
    /// amplitude 1/n, decaying at `rate(n)` dB/s, starting at `onset_s`.
    fn stiff_note(f0: f64, b: f64, seconds: f64, onset_s: f64, rate: impl Fn(usize) -> f64) -> Vec<f64> {
        let n_samples = (seconds * FS) as usize;
        let start = (onset_s * FS) as usize;
        let mut x = vec![0.0; n_samples];
        for n in 1..=40 {
            let hz = stiff_partial_hz(n, f0, b);
            if hz > 0.45 * FS {
                break;
            }
            let decay = rate(n) / 20.0 * std::f64::consts::LN_10;
            let phase = 0.37 * n as f64;
            for (i, s) in x[start..].iter_mut().enumerate() {
                let t = i as f64 / FS;
                *s += 0.05 / n as f64 * (-decay * t).exp() * (2.0 * PI * hz * t + phase).sin();
            }
        }
        x
    }

    /// A deterministic white noise in [-a, a].
    fn noise(n: usize, a: f64, seed: u64) -> Vec<f64> {
        let mut state = seed.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
        (0..n)
            .map(|_| {
                state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
                a * (((state >> 11) as f64 / (1u64 << 53) as f64) * 2.0 - 1.0)
            })
            .collect()
    }

    fn context(nominal_hz: f64, seconds: f64) -> Context {
        Context { nominal_hz, band_hz: 20_000.0, usable_end_s: seconds }
    }

    #[test]
    fn inharmonicity_and_pitch_are_found() {
        for (nominal, f0, b) in
            [(110.0, 110.0, 4e-4), (27.5, 27.6, 2.5e-4), (1046.5, 1050.0, 2e-3), (261.6, 266.0, 1e-5)]
        {
            let x = stiff_note(f0, b, 3.0, 0.02, |n| 2.0 + 0.5 * n as f64);
            let f = Analyzer::new().measure(&x, FS, &context(nominal, 3.0));
            let found = f.f0_hz.unwrap();
            assert!((found / f0 - 1.0).abs() < 3e-4, "f0 {f0}: {found}");
            let fb = f.inharmonicity.unwrap();
            let tolerance = if b < 1e-4 { 0.3 } else { 0.03 };
            assert!((fb / b - 1.0).abs() < tolerance, "B {b} at {f0} Hz: {fb}");
            assert!(f.fitted_partials >= 3, "{}", f.fitted_partials);
        }
    }

    #[test]
    fn a_pitch_outside_the_search_is_not_taken() {
        // Two semitones sharp: the series found is not the note's.
        let x = stiff_note(440.0 * 2f64.powf(2.0 / 12.0), 5e-4, 2.0, 0.0, |_| 3.0);
        let f = Analyzer::new().measure(&x, FS, &context(440.0, 2.0));
        assert!(f.f0_hz.is_none_or(|hz| (hz / 493.9 - 1.0).abs() > 0.01), "{:?}", f.f0_hz);
    }

    #[test]
    fn decay_rates_are_measured_per_partial() {
        let rate = |n: usize| 1.0 + 1.5 * n as f64;
        let x = stiff_note(220.0, 3e-4, 7.0, 0.01, rate);
        let f = Analyzer::new().measure(&x, FS, &context(220.0, 7.0));
        for n in 1..=DECAY_PARTIALS {
            let early = f.decay_early_db_s[n - 1].unwrap();
            assert!((early - rate(n)).abs() < 0.05 * rate(n), "partial {n}: {early} dB/s, not {}", rate(n));
        }
        // Late, the quickest partials reach the floor (the signal's own end: it
        // stops 10 dB above its lowest) and are fitted over what is left or not at all.
        let late = f.decay_late_db_s[0].unwrap();
        assert!((late - rate(1)).abs() < 0.05 * rate(1), "{late}");
        assert_eq!(f.growing_early, 0);
    }

    #[test]
    fn a_decay_stops_at_the_floor() {
        // 30 dB/s into a floor at -45 dB: the fit stops 10 dB above it.
        let frame = |i: usize, floor: f64| {
            let t = 0.3 + i as f64 * 0.025;
            let signal = -30.0 * t;
            Frame { t, level: 10.0 * (10f64.powf(signal / 10.0) + 10f64.powf(floor / 10.0)).log10(), floor }
        };
        let track: Vec<Frame> = (0..200).map(|i| frame(i, -45.0)).collect();
        let rate = decay_rate(&track, EARLY_SPAN_S).unwrap();
        assert!((rate - 30.0).abs() < 0.8, "{rate}");
        // Without the stop (a floor far down), the floor flattens the fit.
        let blind: Vec<Frame> = track.iter().map(|f| Frame { floor: -200.0, ..*f }).collect();
        let flattened = decay_rate(&blind, EARLY_SPAN_S).unwrap();
        assert!(flattened < 25.0, "{flattened}");
        // Into the floor from the start: no fit.
        let buried: Vec<Frame> = (0..200).map(|i| frame(i, -5.0)).collect();
        assert_eq!(decay_rate(&buried, EARLY_SPAN_S), None);
        // A growing partial gives a negative rate.
        let growing: Vec<Frame> = (0..80)
            .map(|i| Frame { t: 0.3 + i as f64 * 0.025, level: -30.0 + 2.0 * i as f64 * 0.025, floor: -100.0 })
            .collect();
        assert!((decay_rate(&growing, EARLY_SPAN_S).unwrap() + 2.0).abs() < 1e-9);
    }

    #[test]
    fn the_envelope_is_the_partials_level_re_the_strongest() {
        // Amplitudes 1/n: partial n lies 20 log10(n) dB below the first.
        let x = stiff_note(330.0, 1e-4, 1.0, 0.0, |_| 0.0);
        let f = Analyzer::new().measure(&x, FS, &context(330.0, 1.0));
        for n in 1..=ENVELOPE_PARTIALS {
            let level = f.envelope_db[n - 1].unwrap();
            let expected = -20.0 * (n as f64).log10();
            assert!((level - expected).abs() < 0.3, "partial {n}: {level} dB, not {expected}");
        }
        // Above the band, none.
        let f = Analyzer::new().measure(&x, FS, &Context { band_hz: 1_500.0, ..context(330.0, 1.0) });
        assert!(f.envelope_db[3].is_some() && f.envelope_db[4].is_none(), "{:?}", f.envelope_db);
    }

    #[test]
    fn the_centroid_of_known_partials_is_found() {
        // Two steady sines, amplitudes 1 and 3 at 500 and 2000 Hz: centroid
        // (500 + 3 * 2000) / 4 = 1625 Hz.
        let x: Vec<f64> = (0..FS as usize)
            .map(|i| {
                let t = i as f64 / FS;
                (2.0 * PI * 500.0 * t).sin() + 3.0 * (2.0 * PI * 2000.0 * t).sin()
            })
            .collect();
        let f = Analyzer::new().measure(&x, FS, &context(500.0, 1.0));
        let c = f.centroid_hz.unwrap();
        assert!((c - 1625.0).abs() < 30.0, "{c}");
    }

    #[test]
    fn the_attack_noise_share_is_measured() {
        // Harmonics of 440 Hz, with white noise of known power in the attack.
        let fs = FS;
        let n = (0.5 * fs) as usize;
        let tone = stiff_note(440.0, 0.0, 0.5, 0.0, |_| 0.0);
        let tone_power = tone.iter().map(|x| x * x).sum::<f64>() / n as f64;
        // The tone alone: what its abrupt start spreads off the partials.
        let clean = Analyzer::new().measure(&tone, fs, &context(440.0, 0.5)).attack_noise_db.unwrap();
        let clean_share = 10f64.powf(clean / 10.0);
        assert!(clean < -20.0, "{clean}");
        for noise_db in [-20.0, -10.0, 0.0] {
            let noise_power = tone_power * 10f64.powf(noise_db / 10.0);
            let a = (3.0 * noise_power).sqrt();
            let x: Vec<f64> = tone.iter().zip(noise(n, a, 7)).map(|(t, w)| t + w).collect();
            let f = Analyzer::new().measure(&x, fs, &context(440.0, 0.5));
            // Expected: the noise off the partials' main lobes, and the
            // tone's own spread, over everything.
            let window_s = ATTACK_SPAN_S.1 - ATTACK_SPAN_S.0;
            let lobe = 2.0 / window_s;
            let off_share = (1.0 - 2.0 * lobe / 440.0).max(0.0);
            let noise_off = noise_power * off_share * (20_000.0 - 20.0) / (0.5 * fs);
            let total = tone_power + noise_power * (20_000.0 - 20.0) / (0.5 * fs);
            let noise_off = noise_off + clean_share * tone_power;
            let expected = 10.0 * (noise_off / total).log10();
            let measured = f.attack_noise_db.unwrap();
            assert!((measured - expected).abs() < 1.5, "noise {noise_db} dB: {measured:.1} dB, not {expected:.1}");
        }
        // A note that starts at the file's first sample is measured over the
        // same window as one that starts later.
        let late: Vec<f64> = std::iter::repeat_n(0.0, 4800).chain(tone.iter().copied()).collect();
        let early = Analyzer::new().measure(&tone, fs, &context(440.0, 0.5)).attack_noise_db.unwrap();
        let later = Analyzer::new().measure(&late, fs, &context(440.0, 0.6)).attack_noise_db.unwrap();
        assert!((early - later).abs() < 1.0, "{early} {later}");
        let low = stiff_note(185.0, 0.0, 0.5, 0.0, |_| 0.0);
        assert!(Analyzer::new().measure(&low, fs, &context(185.0, 0.5)).attack_noise_db.is_some());
        // A note too low for the window to separate its partials has none.
        let x = stiff_note(55.0, 0.0, 0.5, 0.0, |_| 0.0);
        assert!(Analyzer::new().measure(&x, fs, &context(55.0, 0.5)).attack_noise_db.is_none());
    }

    #[test]
    fn the_fall_time_is_found_directly_or_past_a_floor() {
        // 10 dB/s: 40 dB in 4 s.
        let x = stiff_note(440.0, 0.0, 6.0, 0.0, |_| 10.0);
        let (t, extrapolated) = fall_time(&x, 0, FS).unwrap();
        assert!((t - 4.0).abs() < 0.1 && !extrapolated, "{t}");
        // The same on a floor 30 dB down: extrapolated.
        let floor = noise(x.len(), 0.05 / 2.0 * 10f64.powf(-30.0 / 20.0) * 3f64.sqrt(), 3);
        let y: Vec<f64> = x.iter().zip(&floor).map(|(a, b)| a + b).collect();
        let (t, extrapolated) = fall_time(&y, 0, FS).unwrap();
        assert!((t - 4.0).abs() < 0.3 && extrapolated, "{t}");
        // A double decay cut off before it falls 40 dB: 30 dB/s, then a
        // part 20 dB down at 4 dB/s, which falls 40 dB at 5 s.
        let fast = stiff_note(440.0, 0.0, 4.0, 0.0, |_| 30.0);
        let slow = stiff_note(523.25, 0.0, 4.0, 0.0, |_| 4.0);
        let z: Vec<f64> = fast.iter().zip(&slow).map(|(a, b)| a + 0.1 * b).collect();
        let (t, extrapolated) = fall_time(&z, 0, FS).unwrap();
        assert!((t - 5.0).abs() < 0.3 && extrapolated, "{t}");
    }

    #[test]
    fn the_boom_share_counts_what_lies_below_the_fundamental() {
        let clean = stiff_note(220.0, 0.0, 0.5, 0.0, |_| 0.0);
        let f = Analyzer::new().measure(&clean, FS, &context(220.0, 0.5));
        assert!(f.boom_share < 1e-4, "{}", f.boom_share);
        // A 60 Hz hum carrying as much power as the note: half the energy.
        let hum: Vec<f64> = clean
            .iter()
            .enumerate()
            .map(|(i, x)| {
                x + 0.05 * (1.0f64 + 0.25 + 1.0 / 9.0 + 1.0 / 16.0).sqrt() * (2.0 * PI * 60.0 * i as f64 / FS).sin()
            })
            .collect();
        let f = Analyzer::new().measure(&hum, FS, &context(220.0, 0.5));
        assert!(f.boom_share > 0.3 && f.boom_share < 0.7, "{}", f.boom_share);
    }

    #[test]
    fn a_codec_cutoff_is_found() {
        // White noise low-passed hard at 12 kHz (a brick wall in the spectrum).
        let n = 48_000;
        let w = noise(n, 0.1, 11);
        let mut planner = RealFftPlanner::<f64>::new();
        let fft = planner.plan_fft_forward(n);
        let ifft = planner.plan_fft_inverse(n);
        let mut input = w.clone();
        let mut spec = fft.make_output_vec();
        fft.process(&mut input, &mut spec).unwrap();
        for (k, c) in spec.iter_mut().enumerate() {
            if k as f64 * FS / n as f64 > 12_000.0 {
                *c = num_complex::Complex::new(0.0, 0.0);
            }
        }
        let mut out = ifft.make_output_vec();
        ifft.process(&mut spec, &mut out).unwrap();
        // (A codec leaves a floor far down, not digital zero.)
        let cut: Vec<f64> = out.iter().zip(noise(n, 1e-7, 5)).map(|(x, w)| x / n as f64 + w).collect();
        let found = Analyzer::new().cutoff(&cut, 0, FS);
        assert!((found - 12_000.0).abs() <= 200.0, "{found}");
        // Unfiltered, none.
        assert_eq!(Analyzer::new().cutoff(&w, 0, FS), 24_000.0);
    }

    #[test]
    fn the_onset_is_where_the_note_starts() {
        let x = stiff_note(440.0, 0.0, 1.0, 0.25, |_| 3.0);
        let onset = onset(&x, FS) as f64 / FS;
        assert!((onset - 0.25).abs() < 0.002, "{onset}");
    }

    #[test]
    fn quantiles_interpolate() {
        assert_eq!(median(&[3.0, 1.0, 2.0]), Some(2.0));
        assert_eq!(quantile(&[0.0, 10.0], 0.9), Some(9.0));
        assert_eq!(median(&[]), None);
    }
}
