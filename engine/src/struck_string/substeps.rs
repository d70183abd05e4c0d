//! How finely a strike on this string must be sub-stepped: measured per key,
//! against the error budget of [`crate::exciter::hammer::substeps`], when the
//! key is built.
//!
//! The error of a strike is measured where it ends up: the string's modes once
//! the hammer has left, in the energy norm, relative to the strike's. (For a
//! string the energy of a mode is proportional to the square of its bridge
//! force, so this is also the RMS error of the sound that follows.)
//!
//! How hard the strike is matters most (a fast hammer compresses the felt into
//! its stiff range and its pulse sharpens), so each key is measured at its
//! instrument's top speed and at a half, a quarter, an eighth and a sixteenth
//! of it, and a strike between them is judged on the line between their errors
//! (log error over log speed); below the slowest it is judged as the slowest.
//! In the treble the error also has narrow peaks over speed (a 10 % band where it
//! rises by up to 20 dB); a strike that falls in one between two measured
//! speeds can miss the budget by that much.
//!
//! Allocates: [`SubstepPlan::measure`] (off the audio thread); the rest no.

use super::StruckString;
use crate::exciter::hammer::HammerSpec;
use crate::exciter::hammer::substeps::{COUNTS, substeps_for};
use crate::string::StringModes;

/// The speeds measured, as fractions of the top speed.
const SPEED_FRACTIONS: [f64; 5] = [1.0 / 16.0, 0.125, 0.25, 0.5, 1.0];
/// A measurement stops here if the hammer has not let go (0.1 s at 48 kHz).
const LONGEST_CONTACT_S: f64 = 0.1;

/// A key's measured strike errors, and the sub-steps they call for.
#[derive(Clone, Debug, PartialEq)]
pub struct SubstepPlan {
    /// (ln speed, ln e_2) at each measured speed, slowest first.
    points: [(f64, f64); SPEED_FRACTIONS.len()],
}

impl SubstepPlan {
    /// Measure `hammer` (its speed taken as the top one) striking `string` at
    /// `sample_rate_hz`. Allocates; a few tens of microseconds of contact per speed.
    pub fn measure(string: &StringModes, sample_rate_hz: f64, hammer: HammerSpec) -> Self {
        // One string at rest, its tables for both counts built once, struck
        // as a copy at every speed.
        let at_rest = StruckString::with_substep_counts(string.clone(), sample_rate_hz, &[2, 4]);
        let points = SPEED_FRACTIONS.map(|fraction| {
            let speed_m_s = hammer.speed_m_s * fraction;
            let error = difference_from_rest(&at_rest, sample_rate_hz, HammerSpec { speed_m_s, ..hammer }, 2, 4);
            (speed_m_s.ln(), (error * 4.0 / 3.0).max(f64::MIN_POSITIVE).ln())
        });
        Self { points }
    }

    /// The plan for the worse of two strikes (each speed's larger error):
    /// for a hammer that meets some strings harder than others.
    pub fn worse_of(self, other: Self) -> Self {
        let mut points = self.points;
        for (p, q) in points.iter_mut().zip(other.points) {
            p.1 = p.1.max(q.1);
        }
        Self { points }
    }

    /// The error of a strike at `speed_m_s` with 2 sub-steps (e_2).
    pub fn error_at_two(&self, speed_m_s: f64) -> f64 {
        let x = speed_m_s.max(f64::MIN_POSITIVE).ln();
        let p = &self.points;
        if x <= p[0].0 {
            return p[0].1.exp();
        }
        // The segment x falls in (the last one carried on above the top speed).
        let i = p.windows(2).position(|w| x <= w[1].0).unwrap_or(p.len() - 2);
        let ((x0, y0), (x1, y1)) = (p[i], p[i + 1]);
        let t = if x1 > x0 { (x - x0) / (x1 - x0) } else { 1.0 };
        (y0 + t * (y1 - y0)).exp()
    }

    /// The fewest sub-steps per sample (one of [`COUNTS`], at most
    /// [`MAX_SUBSTEPS`](crate::exciter::hammer::substeps::MAX_SUBSTEPS)) that
    /// keep a strike at `speed_m_s` within
    /// [`ERROR_BUDGET`](crate::exciter::hammer::substeps::ERROR_BUDGET).
    pub fn substeps(&self, speed_m_s: f64) -> usize {
        substeps_for(self.error_at_two(speed_m_s))
    }

    /// Every count [`Self::substeps`] can answer up to the top speed: the
    /// [`COUNTS`] up to the most any measured speed needs (between measured
    /// speeds the error is interpolated, so it never exceeds theirs).
    pub fn counts(&self) -> Vec<usize> {
        let most = self.points.iter().map(|&(_, ln_error)| substeps_for(ln_error.exp())).max().unwrap_or(1);
        COUNTS.iter().copied().take_while(|&n| n <= most).collect()
    }
}

/// The difference between strikes at `coarse` and `fine` sub-steps per sample,
/// once both have gone a sub-step hold without force: sqrt(E(x_coarse - x_fine) / E(x_fine)), E the
/// modes' energy.
pub fn strike_difference(
    string: &StringModes,
    sample_rate_hz: f64,
    hammer: HammerSpec,
    coarse: usize,
    fine: usize,
) -> f64 {
    let at_rest = StruckString::with_substep_counts(string.clone(), sample_rate_hz, &[coarse, fine]);
    difference_from_rest(&at_rest, sample_rate_hz, hammer, coarse, fine)
}

/// [`strike_difference`] on copies of `at_rest`, a string at rest with its
/// tables for both counts.
fn difference_from_rest(
    at_rest: &StruckString,
    sample_rate_hz: f64,
    hammer: HammerSpec,
    coarse: usize,
    fine: usize,
) -> f64 {
    let (mut a, mut b) = (at_rest.clone(), at_rest.clone());
    a.strike_substepped(hammer, coarse);
    b.strike_substepped(hammer, fine);
    let longest = (LONGEST_CONTACT_S * sample_rate_hz) as usize;
    for _ in 0..longest {
        a.tick();
        b.tick();
        if !a.in_contact() && !b.in_contact() {
            break;
        }
    }
    let energy_j = b.bank().energy_j();
    if energy_j > 0.0 { (a.bank().energy_of_difference_j(b.bank()) / energy_j).sqrt() } else { 0.0 }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{self, ExciterDesign, InstrumentKind, Voicing};
    use crate::exciter::hammer::substeps::ERROR_BUDGET;

    const FS: f64 = 48_000.0;

    /// A piano key's last string and its share of the hammer at `speed_m_s`.
    fn piano_key(key: u8, speed_m_s: f64) -> (StringModes, HammerSpec) {
        let d = design::key_design(InstrumentKind::Piano, &Voicing::default(), key, 20_000.0).unwrap();
        let string = d.strings[d.struck.end - 1].build().unwrap();
        let ExciterDesign::Hammer { mass_kg, law, position } = d.exciter else { panic!("a piano key has a hammer") };
        (string, HammerSpec::one_of(d.struck.len(), mass_kg, law, speed_m_s, position))
    }

    #[test]
    fn planned_strikes_keep_within_the_budget() {
        let top = InstrumentKind::Piano.touch_range().bounds().1;
        let mut most = Vec::new();
        for key in [33, 61, 85] {
            let (string, hammer) = piano_key(key, top);
            let plan = SubstepPlan::measure(&string, FS, hammer);
            for fraction in [1.0 / 16.0, 0.25, 1.0] {
                let speed_m_s = top * fraction;
                let n = plan.substeps(speed_m_s);
                // Against a strike sub-stepped more finely (its own error is (N / 32)^2
                // of N's: a sixteenth at 8, a tenth at 10, a quarter at 16).
                let error = strike_difference(&string, FS, HammerSpec { speed_m_s, ..hammer }, n, 32);
                assert!(error <= 1.25 * ERROR_BUDGET, "key {key} at {speed_m_s} m/s, {n} sub-steps: {error:.2e}");
                // And not needlessly many: the next count down would miss the budget.
                if let Some(&fewer) = COUNTS.iter().rev().find(|&&c| c < n) {
                    let coarser = strike_difference(&string, FS, HammerSpec { speed_m_s, ..hammer }, fewer, 32);
                    println!(
                        "key {key} at {speed_m_s:.2} m/s: {n} sub-steps err {error:.2e}, {fewer} err {coarser:.2e}"
                    );
                    assert!(coarser > 0.7 * ERROR_BUDGET, "key {key} at {speed_m_s} m/s: {fewer} would do");
                }
            }
            assert!(
                plan.substeps(top) >= plan.substeps(top / 16.0),
                "key {key}: a harder strike needs at least as many"
            );
            most.push(plan.substeps(top));
        }
        // The treble's hard, short contacts need the most.
        assert!(most[0] <= most[1] && most[1] < most[2], "{most:?}");
    }

    #[test]
    fn the_counts_cover_every_strike() {
        let top = InstrumentKind::Piano.touch_range().bounds().1;
        for key in [21, 60, 108] {
            let (string, hammer) = piano_key(key, top);
            let plan = SubstepPlan::measure(&string, FS, hammer);
            let counts = plan.counts();
            assert_eq!(counts[..], COUNTS[..counts.len()], "{counts:?}");
            for i in 0..=100 {
                let speed_m_s = top * 0.001f64.powf(i as f64 / 100.0);
                let n = plan.substeps(speed_m_s);
                assert!(counts.contains(&n), "key {key} at {speed_m_s} m/s: {n} not in {counts:?}");
            }
        }
    }
}
