//! The output's last line: whatever the strings, the body or the player do,
//! no sample leaves the synth non-finite or above [`CEILING_DBFS`].
//!
//! Playing as the instruments are voiced (every loudest touch under -1 dBFS,
//! a pedalled fortissimo chord a few dB over) never reaches it, and then the
//! guard changes no sample, not even a bit. Past it, a limiter with no
//! look-ahead holds each sample at the ceiling at once (both channels by the
//! same gain, so the image stays) and lets go over [`RELEASE_S`]: a flood of
//! notes, a runaway arpeggiator, a key struck a thousand times. A sample that
//! is not a number, or one [`RUNAWAY_DB`] over the ceiling, means the
//! instrument's state is lost: the output drops to silence, the synth
//! silences every string and the body, and the output comes back over the
//! release. What the guard did is counted in a [`GuardReport`] that the
//! renderer prints and the plugin logs, off the audio thread.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

/// No sample leaves louder than this, dBFS.
pub const CEILING_DBFS: f64 = 6.0;

/// The ceiling as a sample's magnitude (10^(6/20)).
const CEILING: f64 = 1.995_262_314_968_879_5;

/// How long the limiter takes to let go (a time constant), s.
pub const RELEASE_S: f64 = 0.05;

/// A sample this far over the ceiling is no music (+46 dBFS): the
/// instrument is silenced, as for a sample that is not a number.
pub const RUNAWAY_DB: f64 = 40.0;
const RUNAWAY: f64 = 100.0;

/// Why the guard silenced the instrument.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Silenced {
    /// A sample was not a number (or infinite).
    NotANumber,
    /// A sample was [`RUNAWAY_DB`] over the ceiling.
    Runaway,
}

/// What the guard has done since the synth was made.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct GuardReport {
    /// Samples (per channel pair) it turned down to the ceiling.
    pub held_samples: u64,
    /// The deepest it turned them down, dB (0 when it never did).
    pub deepest_db: f64,
    /// Times it silenced the instrument, and why the last time.
    pub silenced: u32,
    pub last_reason: Option<Silenced>,
}

impl GuardReport {
    /// Whether it did anything at all.
    pub fn acted(&self) -> bool {
        self.held_samples > 0 || self.silenced > 0
    }

    /// What it did, as a clause ("the output guard held ... and silenced
    /// ..."), its samples counted at `sample_rate_hz`. Allocates: off the
    /// audio thread.
    pub fn describe(&self, sample_rate_hz: f64) -> String {
        let mut parts = Vec::new();
        if self.held_samples > 0 {
            parts.push(format!(
                "held the output under {CEILING_DBFS:+.0} dBFS for {:.3} s (down to {:.1} dB)",
                self.held_samples as f64 / sample_rate_hz,
                self.deepest_db
            ));
        }
        if self.silenced > 0 {
            let why = match self.last_reason {
                Some(Silenced::NotANumber) => "a sample that was not a number",
                Some(Silenced::Runaway) | None => "a sample 40 dB over the ceiling",
            };
            let times = if self.silenced == 1 { "once".to_string() } else { format!("{} times", self.silenced) };
            parts.push(format!("silenced the instrument {times} (the last for {why})"));
        }
        format!("the output guard {}", parts.join(" and "))
    }
}

/// The limiter and its count. Allocates: no.
#[derive(Clone, Debug)]
pub(crate) struct Guard {
    /// The gain it applies now (1: none), and how much of the way back to 1
    /// it goes each sample.
    gain: f64,
    release: f64,
    report: GuardReport,
    /// The instrument must be silenced (at the next control block).
    trip: bool,
}

impl Guard {
    pub fn new(sample_rate_hz: f64) -> Self {
        let mut guard = Self { gain: 1.0, release: 0.0, report: GuardReport::default(), trip: false };
        guard.set_rate(sample_rate_hz);
        guard
    }

    pub fn set_rate(&mut self, sample_rate_hz: f64) {
        self.release = 1.0 - (-1.0 / (RELEASE_S * sample_rate_hz)).exp();
    }

    /// One stereo sample through the guard.
    #[inline]
    pub fn run(&mut self, left: f64, right: f64) -> (f64, f64) {
        if !(left.is_finite() && right.is_finite()) {
            // Not a number: silence now, and the instrument too.
            self.silence(Silenced::NotANumber);
            return (0.0, 0.0);
        }
        let peak = left.abs().max(right.abs());
        if peak > CEILING * RUNAWAY {
            // No music: the same.
            self.silence(Silenced::Runaway);
            return (0.0, 0.0);
        }
        if self.gain < 1.0 {
            self.gain += (1.0 - self.gain) * self.release;
            // (Arrived within 1e-9, it is 1 again: no sample is then touched.)
            if 1.0 - self.gain < 1e-9 {
                self.gain = 1.0;
            }
        }
        if peak * self.gain > CEILING {
            self.gain = CEILING / peak;
            self.report.held_samples += 1;
            self.report.deepest_db = self.report.deepest_db.min(20.0 * self.gain.log10());
        } else if self.gain < 1.0 {
            self.report.held_samples += 1;
        }
        if self.gain == 1.0 { (left, right) } else { (left * self.gain, right * self.gain) }
    }

    fn silence(&mut self, why: Silenced) {
        if !self.trip {
            self.report.silenced += 1;
            self.report.last_reason = Some(why);
        }
        self.trip = true;
        self.gain = 0.0;
    }

    /// Whether the instrument must be silenced (once: it is then cleared).
    pub fn take_trip(&mut self) -> bool {
        std::mem::take(&mut self.trip)
    }

    pub fn report(&self) -> GuardReport {
        self.report
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const FS: f64 = 48_000.0;

    #[test]
    fn a_report_says_what_the_guard_did() {
        let report =
            GuardReport { held_samples: 24_000, deepest_db: -12.34, silenced: 2, last_reason: Some(Silenced::Runaway) };
        assert_eq!(
            report.describe(48_000.0),
            "the output guard held the output under +6 dBFS for 0.500 s (down to -12.3 dB) and silenced the \
             instrument 2 times (the last for a sample 40 dB over the ceiling)"
        );
    }

    #[test]
    fn the_runaway_level_is_its_decibels() {
        assert!((20.0 * RUNAWAY.log10() - RUNAWAY_DB).abs() < 1e-12);
        assert!((20.0 * CEILING.log10() - CEILING_DBFS).abs() < 1e-12);
    }

    #[test]
    fn under_the_ceiling_no_sample_changes_by_a_bit() {
        let mut guard = Guard::new(FS);
        for i in 0..10_000 {
            let x = 1.99 * (i as f64 * 0.01).sin();
            let (l, r) = guard.run(x, -0.5 * x);
            assert_eq!((l.to_bits(), r.to_bits()), (x.to_bits(), (-0.5 * x).to_bits()));
        }
        assert!(!guard.report().acted());
    }

    #[test]
    fn a_loud_stretch_is_held_at_the_ceiling_and_let_go() {
        let mut guard = Guard::new(FS);
        let mut loudest = 0.0f64;
        for i in 0..4800 {
            let x = 30.0 * (i as f64 * 0.05).sin();
            let (l, r) = guard.run(x, 0.5 * x);
            loudest = loudest.max(l.abs()).max(r.abs());
            // Both channels by the same gain.
            if x != 0.0 {
                assert!((r / l - 0.5).abs() < 1e-12);
            }
        }
        assert!(loudest <= CEILING * (1.0 + 1e-12), "{loudest}");
        let report = guard.report();
        assert!(report.held_samples > 0 && report.deepest_db < -20.0, "{report:?}");
        // Quiet again: back to no change within 25 release times (the gain
        // is 1 again once within 1e-9 of it).
        let quiet = 0.1;
        let mut last = (0.0, 0.0);
        for _ in 0..(25.0 * RELEASE_S * FS) as usize {
            last = guard.run(quiet, quiet);
        }
        assert_eq!(last, (quiet, quiet));
    }

    #[test]
    fn a_sample_that_is_not_a_number_silences_and_says_so() {
        let mut guard = Guard::new(FS);
        assert_eq!(guard.run(f64::NAN, 0.1), (0.0, 0.0));
        assert_eq!(guard.run(0.2, f64::INFINITY), (0.0, 0.0));
        assert!(guard.take_trip());
        assert!(!guard.take_trip());
        let (l, _) = guard.run(0.5, 0.5);
        assert!(l.abs() < 0.5 * 0.01, "it comes back over the release: {l}");
        let report = guard.report();
        assert_eq!((report.silenced, report.last_reason), (1, Some(Silenced::NotANumber)));
        assert_eq!(guard.run(1e10, 0.0), (0.0, 0.0));
        assert_eq!(guard.report().last_reason, Some(Silenced::Runaway));
    }
}
