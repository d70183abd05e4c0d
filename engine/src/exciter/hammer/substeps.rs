//! How finely a strike must be sub-stepped, whatever the string: the error
//! budget, the sub-step counts a strike may be given, and the count an error
//! calls for. The string's side, measuring a key's strikes against the budget
//! when the key is built, is [`crate::struck_string::substeps`].
//!
//! A contact is stepped with its force held over each sub-step and the modes
//! advanced exactly. The error this leaves in the strike falls with the square
//! of the sub-step: each halving takes 12 dB off (checked from 1 to 16
//! sub-steps over the piano's keys and touch). So one pair of runs tells all:
//! if x_N is a strike at N sub-steps and e_N its error, x_2 - x_4 = e_2 (1 - 1/4),
//! and e_N = e_2 (2 / N)^2 (Richardson).
//!
//! Allocates: no.

/// A strike may differ from a converged one by this much (RMS over its modes, a
/// fraction of the strike's own): -54 dB, 0.2 %, a tenth of the closest
/// tolerance of the reference cases (2 % on contact times; they are run at a
/// fixed [`crate::struck_string::DEFAULT_SUBSTEPS`]) and far below what a
/// listener hears.
pub const ERROR_BUDGET: f64 = 2e-3;
/// The most sub-steps per sample a strike is given, whatever its error.
pub const MAX_SUBSTEPS: usize = 32;
/// The sub-step counts a strike may be given, each at most a third over the one
/// before from 3 on: a strike gets the first that keeps it within the budget,
/// so it takes at most a third more sub-steps than the budget needs (with
/// powers of two it could take twice as many: a fortissimo chord's treble
/// strikes that need 8.1 to 9.9 took 16). Each count is a table per string.
pub const COUNTS: [usize; 13] = [1, 2, 3, 4, 5, 6, 8, 10, 12, 16, 20, 24, MAX_SUBSTEPS];

/// The fewest of [`COUNTS`] (at most [`MAX_SUBSTEPS`]) for a strike whose error
/// at 2 sub-steps is `error_at_two`: e_2 (2 / N)^2 <= budget.
pub fn substeps_for(error_at_two: f64) -> usize {
    let needed = 2.0 * (error_at_two / ERROR_BUDGET).sqrt();
    COUNTS.iter().copied().find(|&n| n as f64 >= needed).unwrap_or(MAX_SUBSTEPS)
}
