//! Running a strike case: the same [`StruckString`] the instrument plays, with
//! every sample recorded and every contact measured at sub-step resolution.

use serde::Serialize;

use crate::analysis::filter::{lowpass_20k, rms};
use crate::analysis::spectrum::{partial_levels_db, spectral_centroid_hz};
use crate::strike::case::{ExciterSpec, StrikeCase};
use struck_engine::string::StringModes;
use struck_engine::struck_string::{ContactObserver, DEFAULT_SUBSTEPS, StruckString};

/// Force-free gaps shorter than this inside a contact are chatter, not bounces (s).
pub const CONTACT_MERGE_GAP_S: f64 = 50e-6;
/// How many partials the metrics list.
pub const PARTIAL_COUNT: usize = 20;
/// Length of the spectrum the partials are read from, s.
pub const PARTIAL_WINDOW_S: f64 = 0.5;

/// One sample per row.
#[derive(Clone, Debug, Default)]
pub struct Trace {
    pub sample_rate_hz: f64,
    pub contact_force_n: Vec<f64>,
    pub bridge_force_n: Vec<f64>,
    /// `None` for a pluck.
    pub exciter_position_m: Option<Vec<f64>>,
    pub string_position_m: Vec<f64>,
}

impl Trace {
    pub fn time_s(&self, row: usize) -> f64 {
        row as f64 / self.sample_rate_hz
    }

    pub fn len(&self) -> usize {
        self.bridge_force_n.len()
    }

    pub fn is_empty(&self) -> bool {
        self.bridge_force_n.is_empty()
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Serialize)]
pub struct Contact {
    pub start_s: f64,
    pub end_s: f64,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Partial {
    pub number: usize,
    pub frequency_hz: f64,
    /// `None` (left out) when the partial lies beyond Nyquist.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub level_db: Option<f64>,
}

#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct DerivedString {
    pub tension_n: f64,
    pub mass_per_length_kg_m: f64,
    pub inharmonicity: f64,
    pub f0_hz: f64,
    pub f1_hz: f64,
    pub mode_count: usize,
    pub max_mode_frequency_hz: f64,
    pub impedance_ns_m: f64,
}

/// `metrics.json`. A figure that does not apply (a pluck's contact force, a
/// tangent's rebound) is left out, never written as null.
#[derive(Clone, Debug, PartialEq, Serialize)]
pub struct Metrics {
    #[serde(skip_serializing_if = "Option::is_none")]
    pub name: Option<String>,
    pub sample_rate_hz: f64,
    pub duration_s: f64,
    pub contacts: Vec<Contact>,
    pub contact_count: usize,
    pub raw_contact_count: usize,
    pub contact_time_s: f64,
    /// Largest contact force at the engine's finest step (sub-steps during contact).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_contact_force_n: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_contact_force_time_s: Option<f64>,
    /// Largest contact force after the contract's 20 kHz zero-phase low-pass.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub peak_contact_force_lp20k_n: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub rebound_speed_m_s: Option<f64>,
    /// RMS of the bridge force over the whole duration, as computed.
    pub bridge_force_rms_n: f64,
    /// The same after the 20 kHz low-pass (how the reference results give it).
    pub bridge_force_rms_lp20k_n: f64,
    #[serde(skip_serializing_if = "Option::is_none")]
    pub spectral_centroid_hz: Option<f64>,
    pub partials: Vec<Partial>,
    pub string: DerivedString,
}

/// A finished run.
#[derive(Clone, Debug)]
pub struct LabRun {
    pub trace: Trace,
    pub metrics: Metrics,
}

/// Intervals of nonzero contact force, with start and end interpolated between
/// (sub)steps on the felt's compression.
#[derive(Default)]
pub(crate) struct ContactTracker {
    previous: (f64, f64),
    start_s: Option<f64>,
    raw: Vec<Contact>,
    peak: Option<(f64, f64)>,
}

impl ContactTracker {
    fn crossing(&self, t_s: f64, compression_m: f64) -> f64 {
        let (t0, c0) = self.previous;
        if compression_m == c0 { t0 } else { t0 + (t_s - t0) * (-c0 / (compression_m - c0)).clamp(0.0, 1.0) }
    }

    /// The raw contacts (one still open is closed at `end_s`) and the peak (force N, time s).
    pub(crate) fn finish(mut self, end_s: f64) -> (Vec<Contact>, Option<(f64, f64)>) {
        if let Some(start_s) = self.start_s.take() {
            self.raw.push(Contact { start_s, end_s });
        }
        (self.raw, self.peak)
    }
}

impl ContactObserver for ContactTracker {
    fn step(&mut self, t_s: f64, compression_m: f64, force_n: f64) {
        if force_n > self.peak.map_or(0.0, |(f, _)| f) {
            self.peak = Some((force_n, t_s));
        }
        match (self.start_s, force_n > 0.0) {
            (None, true) => self.start_s = Some(self.crossing(t_s, compression_m)),
            (Some(start_s), false) => {
                self.raw.push(Contact { start_s, end_s: self.crossing(t_s, compression_m) });
                self.start_s = None;
            }
            _ => {}
        }
        self.previous = (t_s, compression_m);
    }
}

/// Merge contacts separated by gaps shorter than `gap_s`.
pub fn merge_contacts(raw: &[Contact], gap_s: f64) -> Vec<Contact> {
    let mut merged: Vec<Contact> = Vec::new();
    for c in raw {
        match merged.last_mut() {
            Some(last) if c.start_s - last.end_s < gap_s => last.end_s = c.end_s,
            _ => merged.push(*c),
        }
    }
    merged
}

/// Simulate a case.
pub fn run(case: &StrikeCase) -> LabRun {
    let never = std::sync::atomic::AtomicBool::new(false);
    match run_stoppable(case, &never) {
        Ok(run) => run,
        Err(Stopped::Interrupted) => unreachable!("a run nothing stops finishes"),
        // As any allocation that fails.
        Err(Stopped::OutOfMemory { bytes }) => std::alloc::handle_alloc_error(
            std::alloc::Layout::from_size_align(bytes as usize, 8).unwrap_or(std::alloc::Layout::new::<f64>()),
        ),
    }
}

/// Why a run did not finish.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Stopped {
    /// The stop flag was raised.
    Interrupted,
    /// The memory for its trace could not be had: the bytes of one column.
    OutOfMemory { bytes: u64 },
}

/// A trace column with room for `rows` samples, asked for without aborting
/// when the memory is not there.
fn column(rows: usize) -> Result<Vec<f64>, Stopped> {
    let mut column = Vec::new();
    column.try_reserve_exact(rows).map_err(|_| Stopped::OutOfMemory { bytes: (rows as u64).saturating_mul(8) })?;
    Ok(column)
}

/// Bytes a run holds at its peak per sample of its trace: measured 81 (a
/// hammer case, 3.84 million samples, 313 MB peak resident), the trace's four
/// columns and the filtered copies and spectra its metrics take.
const PEAK_BYTES_PER_SAMPLE: u64 = 88;
/// Bytes the trace's four columns take per sample.
const TRACE_BYTES_PER_SAMPLE: u64 = 32;

/// Bytes a run of `case` holds in memory at its peak, about.
pub fn peak_bytes(case: &StrikeCase) -> u64 {
    case.sample_count() as u64 * PEAK_BYTES_PER_SAMPLE
}

/// [`run`], checking `stop` every few thousand samples; the trace's memory
/// is asked for first, and its lack reported rather than aborting.
pub fn run_stoppable(case: &StrikeCase, stop: &std::sync::atomic::AtomicBool) -> Result<LabRun, Stopped> {
    let string = case.build_string();
    let fs = case.sample_rate_hz;
    let rows = case.sample_count();
    let mut s = StruckString::new(string.clone(), fs, DEFAULT_SUBSTEPS);
    match case.exciter {
        ExciterSpec::Hammer(h) => s.strike(h),
        ExciterSpec::Tangent(t) => s.press_tangent(t),
        ExciterSpec::Pluck(p) => s.pluck(p),
    }
    let is_pluck = matches!(case.exciter, ExciterSpec::Pluck(_));
    let mut trace = Trace {
        sample_rate_hz: fs,
        contact_force_n: column(rows)?,
        bridge_force_n: column(rows)?,
        exciter_position_m: if is_pluck { None } else { Some(column(rows)?) },
        string_position_m: column(rows)?,
    };
    // The rest of the peak (the metrics' filtered copies and spectra) is
    // asked for too, and given back: a run that could not finish does not start.
    let rest = (rows as u64).saturating_mul(PEAK_BYTES_PER_SAMPLE - TRACE_BYTES_PER_SAMPLE);
    let mut probe: Vec<u8> = Vec::new();
    probe.try_reserve_exact(rest as usize).map_err(|_| Stopped::OutOfMemory { bytes: rest })?;
    drop(probe);
    let mut tracker = ContactTracker::default();
    let mut tick = s.current();
    for row in 0..rows {
        if row % 4096 == 0 && stop.load(std::sync::atomic::Ordering::Relaxed) {
            return Err(Stopped::Interrupted);
        }
        if row > 0 {
            tick = s.tick_observed(&mut tracker);
        }
        trace.contact_force_n.push(tick.contact_force_n);
        trace.bridge_force_n.push(tick.bridge_force_n);
        if let (Some(column), Some(x)) = (trace.exciter_position_m.as_mut(), tick.exciter_position_m) {
            column.push(x);
        }
        trace.string_position_m.push(tick.string_position_m);
    }
    let end_s = trace.time_s(rows - 1);
    let rebound = s.hammer().map(|h| -h.velocity_m_s);
    let metrics = measure(case, &string, &trace, tracker, end_s, rebound);
    Ok(LabRun { trace, metrics })
}

fn measure(
    case: &StrikeCase,
    string: &StringModes,
    trace: &Trace,
    tracker: ContactTracker,
    end_s: f64,
    rebound_speed_m_s: Option<f64>,
) -> Metrics {
    let fs = trace.sample_rate_hz;
    let (raw, peak) = match case.exciter {
        ExciterSpec::Hammer(_) => tracker.finish(end_s),
        // The tangent stays on the string throughout; its force is the sampled one.
        ExciterSpec::Tangent(_) => {
            let (i, f) = trace
                .contact_force_n
                .iter()
                .enumerate()
                .fold((0, f64::MIN), |best, (i, &f)| if f > best.1 { (i, f) } else { best });
            (vec![Contact { start_s: 0.0, end_s: case.duration_s }], Some((f, trace.time_s(i))))
        }
        ExciterSpec::Pluck(_) => (Vec::new(), None),
    };
    let contacts = merge_contacts(&raw, CONTACT_MERGE_GAP_S);
    let has_contact = !matches!(case.exciter, ExciterSpec::Pluck(_));
    let lowpassed_peak =
        has_contact.then(|| lowpass_20k(&trace.contact_force_n, fs).into_iter().fold(f64::MIN, f64::max));
    let predicted: Vec<f64> = (1..=PARTIAL_COUNT).map(|n| string.partial_hz(n)).collect();
    let levels = partial_levels_db(&trace.bridge_force_n, fs, PARTIAL_WINDOW_S, &predicted);
    let last_mode = string.modes.last().expect("a string has at least one mode");
    Metrics {
        name: case.name.clone(),
        sample_rate_hz: fs,
        duration_s: case.duration_s,
        contact_count: contacts.len(),
        raw_contact_count: raw.len(),
        contact_time_s: raw.iter().map(|c| c.end_s - c.start_s).sum(),
        contacts,
        peak_contact_force_n: peak.map(|p| p.0),
        peak_contact_force_time_s: peak.map(|p| p.1),
        peak_contact_force_lp20k_n: lowpassed_peak,
        rebound_speed_m_s,
        bridge_force_rms_n: rms(&trace.bridge_force_n),
        bridge_force_rms_lp20k_n: rms(&lowpass_20k(&trace.bridge_force_n, fs)),
        spectral_centroid_hz: spectral_centroid_hz(&trace.contact_force_n, fs),
        partials: predicted
            .iter()
            .zip(levels)
            .enumerate()
            .map(|(i, (&f, level_db))| Partial { number: i + 1, frequency_hz: f, level_db })
            .collect(),
        string: DerivedString {
            tension_n: string.tension_n,
            mass_per_length_kg_m: string.mass_per_length_kg_m,
            inharmonicity: string.inharmonicity,
            f0_hz: string.f0_hz,
            f1_hz: string.partial_hz(1),
            mode_count: string.mode_count(),
            max_mode_frequency_hz: last_mode.frequency_hz(),
            impedance_ns_m: string.impedance_ns_m(),
        },
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_trace_the_memory_cannot_hold_is_reported_not_aborted_on() {
        // (Past what any machine has: the allocator says no, the run says so.)
        assert_eq!(column(usize::MAX / 16), Err(Stopped::OutOfMemory { bytes: (usize::MAX / 16) as u64 * 8 }));
        assert_eq!(column(1000).map(|c| c.capacity()), Ok(1000));
    }

    #[test]
    fn merging_joins_only_short_gaps() {
        let raw = [
            Contact { start_s: 0.0, end_s: 1e-3 },
            Contact { start_s: 1.03e-3, end_s: 2e-3 },
            Contact { start_s: 2.2e-3, end_s: 3e-3 },
        ];
        let merged = merge_contacts(&raw, CONTACT_MERGE_GAP_S);
        assert_eq!(merged, vec![Contact { start_s: 0.0, end_s: 2e-3 }, Contact { start_s: 2.2e-3, end_s: 3e-3 }]);
    }

    #[test]
    fn tracker_interpolates_onset_and_release() {
        let mut t = ContactTracker::default();
        t.step(1.0, -1.0, 0.0);
        t.step(2.0, 3.0, 5.0); // crosses zero at 1.25
        t.step(3.0, 1.0, 1.0);
        t.step(4.0, -3.0, 0.0); // crosses zero at 3.25
        let (raw, peak) = t.finish(10.0);
        assert_eq!(raw, vec![Contact { start_s: 1.25, end_s: 3.25 }]);
        assert_eq!(peak, Some((5.0, 2.0)));
    }
}
