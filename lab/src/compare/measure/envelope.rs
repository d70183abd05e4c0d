//! A note's envelope in time: its onset, the frame track's smoothing, decay
//! rates over a span, the noise floor and the time to fall 40 dB.

use super::{FALL_DB, FLOOR_MARGIN_DB, db, line_fit, median};

/// One frame of a partial's track.
#[derive(Clone, Copy, Debug)]
pub struct Frame {
    /// s after the onset.
    pub t: f64,
    /// The partial's level, dB.
    pub level: f64,
    /// The level of the gaps beside it, dB.
    pub floor: f64,
}

/// The median of `values[i - r..=i + r]` (clipped at the ends) for each i.
pub(super) fn running_median(values: &[f64], r: usize) -> Vec<f64> {
    (0..values.len())
        .map(|i| median(&values[i.saturating_sub(r)..(i + r + 1).min(values.len())]).unwrap_or(f64::NAN))
        .collect()
}

/// The level a median of three along the track (one frame's beat or click
/// removed), the floor a median of nine.
pub(super) fn smooth(track: &mut [Frame]) {
    let levels: Vec<f64> = track.iter().map(|f| f.level).collect();
    let floors: Vec<f64> = track.iter().map(|f| f.floor).collect();
    for ((f, l), g) in track.iter_mut().zip(running_median(&levels, 1)).zip(running_median(&floors, 4)) {
        f.level = l;
        f.floor = g;
    }
}

/// The decay rate (dB/s, positive when decaying) of a track over `span`
/// (s after the onset), stopping where the level first comes within
/// [`FLOOR_MARGIN_DB`] of the floor beside it. None when less than 40 % of
/// the span (or fewer than 5 frames) remains.
pub fn decay_rate(track: &[Frame], span: (f64, f64)) -> Option<f64> {
    let stop =
        track.iter().find(|f| f.t >= span.0 && f.level <= f.floor + FLOOR_MARGIN_DB).map_or(f64::INFINITY, |f| f.t);
    let end = span.1.min(stop);
    let points: Vec<(f64, f64)> = track.iter().filter(|f| f.t >= span.0 && f.t < end).map(|f| (f.t, f.level)).collect();
    if points.len() < 5 || end - span.0 < 0.4 * (span.1 - span.0) {
        return None;
    }
    line_fit(&points).map(|(_, slope)| -slope)
}

/// The onset: the start of the first 1-ms frame within 20 dB of the loudest
/// frame of the first three seconds.
pub fn onset(signal: &[f64], fs: f64) -> usize {
    let frame = ((0.001 * fs) as usize).max(1);
    let limit = signal.len().min((3.0 * fs) as usize);
    let energies: Vec<f64> = signal[..limit].chunks(frame).map(|c| c.iter().map(|x| x * x).sum::<f64>()).collect();
    let peak = energies.iter().copied().fold(0.0, f64::max);
    if peak <= 0.0 {
        return 0;
    }
    energies.iter().position(|&e| e >= peak * 0.01).unwrap_or(0) * frame
}

/// The level of the noise a note sits on, dB (mean square, as `levels`,
/// the level in 50-ms frames after the onset): the louder of what comes
/// before the onset (at least 5 ms of it, up to 5 ms before) and the last second's level when
/// the last two seconds are flat (under 0.5 dB/s). None found: -inf.
pub(super) fn noise_floor(signal: &[f64], onset: usize, fs: f64, levels: &[(f64, f64)]) -> f64 {
    let mut floor = f64::NEG_INFINITY;
    let before = &signal[..onset.saturating_sub((0.005 * fs) as usize)];
    if before.len() as f64 >= 0.005 * fs {
        floor = db(before.iter().map(|x| x * x).sum::<f64>() / before.len() as f64);
    }
    if let Some(last) = levels.last() {
        let tail: Vec<(f64, f64)> = levels.iter().copied().filter(|p| p.0 >= last.0 - 2.0).collect();
        if last.0 >= 3.0
            && let Some((_, slope)) = line_fit(&tail)
            && slope.abs() < 0.5
        {
            let end: Vec<f64> = tail.iter().filter(|p| p.0 >= last.0 - 1.0).map(|p| p.1).collect();
            floor = floor.max(end.iter().sum::<f64>() / end.len() as f64);
        }
    }
    floor
}

/// The time from the onset until the level (50-ms frames, every 25 ms) has
/// fallen 40 dB below its peak. When the noise floor (see [`noise_floor`])
/// or the end comes first, a line fitted to the last two seconds before the
/// level comes within 10 dB of the floor (and after it fell 10 dB) is
/// extrapolated: (s, extrapolated).
pub fn fall_time(signal: &[f64], onset: usize, fs: f64) -> Option<(f64, bool)> {
    let frame = (0.05 * fs) as usize;
    let hop = (0.025 * fs) as usize;
    let mut levels = Vec::new();
    let mut start = onset;
    while start + frame <= signal.len() {
        let e = signal[start..start + frame].iter().map(|x| x * x).sum::<f64>() / frame as f64;
        levels.push(((start - onset) as f64 / fs + 0.025, db(e)));
        start += hop;
    }
    if levels.is_empty() {
        return None;
    }
    let (peak_at, peak) =
        levels.iter().enumerate().fold((0, f64::NEG_INFINITY), |m, (i, p)| if p.1 > m.1 { (i, p.1) } else { m });
    let floor = noise_floor(signal, onset, fs, &levels);
    let stop = levels[peak_at..].iter().position(|p| p.1 <= floor + FLOOR_MARGIN_DB).map(|i| i + peak_at);
    let target = peak - FALL_DB;
    if let Some(i) = levels[peak_at..].iter().position(|p| p.1 <= target) {
        return Some((levels[i + peak_at].0, false));
    }
    // The line is fitted over the last two seconds before the floor (or the
    // end): a piano's decay is double, and the late one is what goes on.
    let first = levels[peak_at..].iter().position(|p| p.1 <= peak - 10.0)? + peak_at;
    let to = stop.unwrap_or(levels.len());
    let late = levels[..to].iter().position(|p| p.0 >= levels[to.max(1) - 1].0 - 2.0).unwrap_or(0);
    let from = first.max(late);
    if to < from + 4 {
        return None;
    }
    let (a, slope) = line_fit(&levels[from..to])?;
    (slope < 0.0).then(|| ((target - a) / slope, true))
}
