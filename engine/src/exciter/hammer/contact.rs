//! The implicit contact solve: felt (or a linear spring) pressed between a hammer
//! and a string.
//!
//! Contact law F = K C^alpha for compression C > 0, else 0 (Hall & Askenfelt 1988;
//! Chaigne & Askenfelt 1994, eq. 3; alpha = 1 is a linear spring, a santoor
//! mallet), with stored energy E(C) = K C^(alpha+1) / (alpha + 1).
//!
//! Over a step the force is held at one value F that acts on hammer and string
//! alike, and everything else yields to it linearly: the compression at the end of
//! the step is C1 = C_hat - W F, where C_hat is the compression had the force been
//! zero and W (m/N) sums the compliances of hammer, string and residual within
//! the step. F is the felt's discrete gradient over the step,
//!
//!   F = (E(C1) - E(C0)) / (C1 - C0)   (the mean of K C^alpha between C0 and C1),
//!
//! so the work the force does on hammer and string is exactly the energy the felt
//! stores or gives back: the solve neither creates nor destroys energy, whatever
//! the step (Gonzalez 1996; the energy-consistent collision schemes of
//! Chatziioannou & van Walstijn 2015). The equation in C1,
//!
//!   g(C1) = C1 - C_hat + W Q(C0, C1) = 0,
//!
//! has one root: Q, the mean of an increasing convex F, is increasing and convex
//! in C1, so g is too. The root lies in [C_hat - W max(F(C0), F(C_hat)), C_hat]; a
//! Newton iteration kept inside that bracket (bisecting when it would leave it)
//! finds it in a few steps even for K = 1e12, alpha = 3.
//!
//! Allocates: no. Realtime-safe.

use std::cell::Cell;

/// The felt (or spring) of a hammer or mallet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactLaw {
    /// K, in N/m^alpha.
    pub stiffness: f64,
    /// alpha >= 1.
    pub exponent: f64,
}

/// What one step's solve found.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactStep {
    /// Compression at the end of the step, m (negative: a gap).
    pub compression_m: f64,
    /// The force held over the step, N.
    pub step_force_n: f64,
    /// Newton iterations the solve took.
    pub iterations: usize,
}

/// Iterations allowed; the solve needs 2 to 4 in practice.
const MAX_ITERATIONS: usize = 100;
/// Below this relative difference of C0 and C1 the divided difference is taken
/// as the force at the midpoint (exact to (dC / C)^2 / 24; the quotient itself
/// would lose digits to cancellation).
const NEAR: f64 = 1e-6;
/// A Newton step below this fraction of the compression (and under a quarter
/// of the step's own compression change, [`CLOSE_TO_START`]) is the last one
/// taken, along the curves to third order: the force errs by about
/// alpha (alpha - 1) (alpha - 2) (alpha - 3) / 24 (step / C)^4 and the felt's
/// energy by (alpha + 1) alpha (alpha - 1) (alpha - 2) / 24 (step / C)^4 of
/// what they hold: under 1e-16 for the piano's felts (alpha up to 3.5), 4e-15
/// at alpha = 6.
const ACCEPT: f64 = 1e-4;
/// The last step's Taylor series are in step / (C - C0) too (the mean force's
/// derivatives are divided differences over C - C0): a Newton step larger than
/// this share of C - C0 is not the last (a step that barely moves the felt
/// from where it started; one sub-step in tens of thousands).
const CLOSE_TO_START: f64 = 0.25;
const SIXTH: f64 = 1.0 / 6.0;

impl ContactLaw {
    /// Force for a compression, N.
    pub fn force_n(&self, compression_m: f64) -> f64 {
        if compression_m > 0.0 { self.stiffness * power(compression_m, self.exponent) } else { 0.0 }
    }

    /// Energy stored in the felt at a compression, J.
    pub fn energy_j(&self, compression_m: f64) -> f64 {
        if compression_m > 0.0 {
            self.stiffness * power(compression_m, self.exponent + 1.0) / (self.exponent + 1.0)
        } else {
            0.0
        }
    }

    /// Force and stored energy at a compression, from one power.
    #[inline]
    fn force_and_energy(&self, compression_m: f64) -> (f64, f64) {
        if compression_m > 0.0 {
            let force = self.stiffness * power(compression_m, self.exponent);
            (force, force * compression_m / (self.exponent + 1.0))
        } else {
            (0.0, 0.0)
        }
    }

    /// Force and dF/dC at a compression, from one power.
    #[inline(always)]
    fn force_and_slope(&self, compression_m: f64) -> (f64, f64) {
        if compression_m > 0.0 {
            let slope_per_alpha = self.stiffness * power(compression_m, self.exponent - 1.0);
            (slope_per_alpha * compression_m, self.exponent * slope_per_alpha)
        } else {
            (0.0, 0.0)
        }
    }

    /// The felt at compression `compression_m`: where a step's solve starts.
    pub fn felt(&self, compression_m: f64) -> Felt {
        let (force_n, energy_j) = self.force_and_energy(compression_m);
        Felt { compression_m, force_n, energy_j }
    }

    /// Solve one step: compression `c0` at its start, `c_hat` at its end had the
    /// force been zero, `w` the compliance to the step's force.
    pub fn solve(&self, c0: f64, c_hat: f64, w: f64) -> ContactStep {
        self.step(self.felt(c0), c_hat, w, None).0
    }

    /// [`Self::solve`] from the felt as the last step left it, returning the felt
    /// at the end of this step too: a strike's steps chain without recomputing
    /// the power at each step's start. `guess`, if any, holds guesses at the
    /// step's force and end compression (extrapolated from the last steps');
    /// without one the solve starts from a Newton step at `start`.
    ///
    /// With a guess, the power is taken once, at the guessed compression, and
    /// the felt near it follows from a binomial series (`Series`). That power
    /// does not wait on `c_hat`, so a caller that works out `c_hat` meanwhile
    /// (a pass over the modes) hides it.
    ///
    /// Newton's method on g, which is increasing and convex, lands at or above the
    /// root from any start and then descends to it monotonically; so the lower end
    /// of the bracket (one more power) is only worked out if rounding ever sends
    /// an iterate outside. Once a Newton step is below `ACCEPT` of the
    /// compression it is the last: the step is taken without evaluating the
    /// felt again, along g's cubic about the last point (the force, the mean
    /// force and the felt's energy follow their Taylor series to third order,
    /// all known there from F = K C^alpha), which keeps C1 = C_hat - W F exact
    /// and errs by the fourth power of the step (see `ACCEPT`). The caller's guess
    /// lands within 1e-4 of the compression nearly always, so most sub-steps
    /// evaluate the felt once (with a first-order step, which had to wait for
    /// a step under 1e-7, most took two).
    pub fn step(&self, start: Felt, c_hat: f64, w: f64, guess: Option<Guess<'_>>) -> (ContactStep, Felt) {
        self.step_inline(start, c_hat, w, guess)
    }

    /// [`Self::step`], inlined into its caller: a strike's sub-steps
    /// ([`super::HammerRig::tick`]) are compiled for the vector extensions the
    /// machine has, and the solve with them (the same operations, so the
    /// same bits; VEX's three operands and, with AVX-512, 32 registers spare
    /// most of the copies and spills of the baseline's two-operand SSE2).
    #[inline(always)]
    pub(crate) fn step_inline(&self, start: Felt, c_hat: f64, w: f64, guess: Option<Guess<'_>>) -> (ContactStep, Felt) {
        let Felt { compression_m: c0, force_n: f0, energy_j: e0 } = start;
        if c0 <= 0.0 && c_hat <= 0.0 {
            let end = Felt { compression_m: c_hat, force_n: 0.0, energy_j: 0.0 };
            return (ContactStep { compression_m: c_hat, step_force_n: 0.0, iterations: 0 }, end);
        }
        let per_exponent = 1.0 / (self.exponent + 1.0);
        let series = match guess {
            Some(g) => Series::new(self, g.binomial, g.last_power, g.compression_m),
            None => None,
        };
        // The felt at the last point where g was evaluated away from c0.
        let mut last;
        let mut hi = c_hat;
        let mut lo = f64::NEG_INFINITY;
        let mut lo_known = false;
        let mut c = match guess {
            Some(Guess { force_n, .. }) if c0 > 0.0 => c_hat - w * force_n.max(0.0),
            // One Newton step from c0, where the mean force is F(c0).
            _ => {
                let slope0 = if c0 > 0.0 { self.exponent * f0 / c0 } else { 0.0 };
                c0 - (c0 - c_hat + w * f0) / (1.0 + 0.5 * w * slope0)
            }
        }
        .min(hi);
        let mut q;
        let mut iterations = 0;
        loop {
            iterations += 1;
            let (mean_force, dq, per_gap, felt) = self.mean_from(series.as_ref(), (c0, e0, per_exponent), c);
            q = mean_force;
            last = felt;
            let g = c - c_hat + w * q;
            // At the root (or lost): done. The bracket's ends are selected,
            // not branched on: which side of the root a guess lands is a toss
            // of a coin, and a branch on it cost a treble string's sub-step
            // 3-7 %. (Asked of g's size, not its sign, the test for the root
            // is not folded into such a branch.)
            if !(g.abs() > 0.0) {
                break;
            }
            hi = if g > 0.0 { c } else { hi };
            lo = if g < 0.0 { c } else { lo };
            let per_slope = 1.0 / (1.0 + w * dq);
            let step = g * per_slope;
            // (See ACCEPT for what the last step leaves.)
            if c > 0.0
                && step.abs() <= ACCEPT * c
                && step.abs() * per_gap.abs() <= CLOSE_TO_START
                && let Some(felt) = last.as_mut()
            {
                // The last step, taken along the curves to third order (see above).
                let per_c = 1.0 / c;
                let alpha = self.exponent;
                // F and its derivatives at c, and Q's (Q d = E - E0 differentiated:
                // Q_k d + k Q_(k-1) = F_(k-1), the k-th derivatives).
                let f = felt.force_n;
                let f1 = alpha * f * per_c;
                let f2 = (alpha - 1.0) * f1 * per_c;
                let f3 = (alpha - 2.0) * f2 * per_c;
                let q2 = (f1 - 2.0 * dq) * per_gap;
                let q3 = (f2 - 3.0 * q2) * per_gap;
                q += last_move(step, dq, 0.5 * q2, q3 * SIXTH, w, per_slope);
                // The end compression from the force, so C1 = C_hat - W Q holds exactly.
                let end = c_hat - w * q;
                let t = c - end;
                felt.energy_j += t * (-f + t * (0.5 * f1 - f2 * SIXTH * t));
                felt.force_n += t * (-f1 + t * (0.5 * f2 - f3 * SIXTH * t));
                felt.compression_m = end;
                c = end;
                break;
            }
            // Converged: the step is below what rounding lets g resolve. The divided
            // difference carries a relative error of about eps C / |C - C0|, so g
            // cannot be known better than eps (C + W Q C / |C - C0|). (Checked before
            // the bracket, which a step smaller than an ulp would seem to leave.)
            let scale = c.abs().max(c0.abs());
            let floor = 4.0 * f64::EPSILON * scale * (1.0 + w * q.abs() * per_gap.abs());
            if step.abs() <= floor || iterations == MAX_ITERATIONS {
                break;
            }
            let mut next = c - step;
            if !(lo_known || next > lo && next < hi) {
                lo = lo.max(c_hat - w * f0.max(self.force_n(c_hat)));
                lo_known = true;
            }
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            c = next;
        }
        let end = match last {
            Some(felt) if felt.compression_m == c => felt,
            _ => self.felt(c),
        };
        (ContactStep { compression_m: c, step_force_n: q, iterations }, end)
    }
}

impl ContactLaw {
    /// K c^alpha, from the felt's series about the step's anchor where it
    /// reaches, else from a power.
    #[inline(always)]
    fn force_with(&self, series: Option<&Series<'_>>, c: f64) -> f64 {
        if !(c > 0.0) {
            return 0.0;
        }
        match series.map(|s| s.force_n(c)) {
            Some(Some(f)) => f,
            _ => self.stiffness * power(c, self.exponent),
        }
    }

    /// The mean force between c0 and c (the felt at c0 holding `e0`, and
    /// `per_exponent` 1 / (alpha + 1)), its derivative with respect to c,
    /// 1 / (c - c0) (held at 1 / (NEAR c) near c0) for the last step and the
    /// convergence floor, and the felt at c (unless c is that near c0).
    #[inline(always)]
    fn mean_from(
        &self,
        series: Option<&Series<'_>>,
        (c0, e0, per_exponent): (f64, f64, f64),
        c: f64,
    ) -> (f64, f64, f64, Option<Felt>) {
        let scale = c0.abs().max(c.abs());
        if (c - c0).abs() <= NEAR * scale {
            let (f, slope) = self.force_and_slope(0.5 * (c0 + c));
            (f, 0.5 * slope, 1.0 / (NEAR * scale), None)
        } else {
            let f = self.force_with(series, c);
            let e = f * c.max(0.0) * per_exponent;
            let per_gap = 1.0 / (c - c0);
            let q = (e - e0) * per_gap;
            (q, (f - q) * per_gap, per_gap, Some(Felt { compression_m: c, force_n: f, energy_j: e }))
        }
    }
}

/// How the mean force moves over the last step, taken along g's cubic: the
/// Newton `step` from the last point, where the mean force's derivatives are
/// `dq`, `2 half_q2` and `6 sixth_q3`, the compliance `w`, and `per_slope`
/// 1 / g_1 = 1 / (1 + w dq).
///
/// g(c - s) = 0 on its cubic is s = step + a s^2 + b s^3, with a = w A / g_1
/// and b = -w B / g_1 (A = `half_q2`, B = `sixth_q3`), and the mean force moves
/// by -Q_1 s + A s^2 - B s^3. Its root's series in the step,
/// s = step + a step^2 + (2 a^2 + b) step^3 + 5 a (a^2 + b) step^4, put in,
/// gives the move as a series in the step:
///
///   -Q_1 step + (A step^2 + (2 a A - B) step^3 + 5 a (a A - B) step^4) / g_1,
///
/// leaving out under 1e-19 of the force for the piano's felts and 2e-18 at
/// the steepest exponent, 6, where it is used (a Newton step up to 1e-4 of
/// the compression, whatever the compliance and wherever the step began;
/// checked against the cubic's root at high precision). A short chain of
/// operations: solving the cubic for s first (three turns of its fixed
/// point), then moving the force, took three times as many, one after the
/// other.
#[inline(always)]
fn last_move(step: f64, dq: f64, half_q2: f64, sixth_q3: f64, w: f64, per_slope: f64) -> f64 {
    let a = w * half_q2 * per_slope;
    // a A - B
    let a_a_less_b = a * half_q2 - sixth_q3;
    let step2 = step * step;
    let bent = half_q2 + (a * half_q2 + a_a_less_b) * step + 5.0 * a * a_a_less_b * step2;
    -dq * step + per_slope * step2 * bent
}

/// Guesses at a step's force and end compression, for [`ContactLaw::step`],
/// the law's [`ContactLaw::binomial`], and where the felt's power was last
/// taken in this strike.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Guess<'a> {
    pub force_n: f64,
    pub compression_m: f64,
    pub binomial: &'a Binomial,
    pub last_power: &'a LastPower,
}

/// Where a strike's last step anchored its series ([`Series`]): the anchor,
/// its inverse, and the felt's force there. The next step's anchor is
/// usually near it (a sub-step moves the felt by a few percent at most), and
/// then the series from it gives the force at the new anchor without a power
/// (within 1e-14 of it at the edge of the series' reach, a test checks; the
/// truncation at the usual hop of a hundredth is ~1e-18), which
/// was a fifth of a fortissimo chord's contact time. Empty at a strike's start;
/// one per strike, as it holds forces of that strike's law.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct LastPower(Cell<[f64; 3]>);

/// The coefficients binom(alpha, k) of (1 + x)^alpha, k = 0 ..= [`SERIES_TERMS`].
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Binomial([f64; SERIES_TERMS + 1]);

impl ContactLaw {
    /// The binomial series of its exponent (worked out once per strike).
    pub fn binomial(&self) -> Binomial {
        let mut coefficients = [1.0; SERIES_TERMS + 1];
        for k in 1..=SERIES_TERMS {
            coefficients[k] = coefficients[k - 1] * (self.exponent - (k - 1) as f64) / k as f64;
        }
        Binomial(coefficients)
    }
}

/// Terms of `Series` after the first.
pub const SERIES_TERMS: usize = 8;
/// How far from its anchor [`Series`] is used, as a fraction of the anchor: the
/// first term left out is below 32^-9 = 3e-14 (times a binomial coefficient,
/// below 1 past the exponent).
const SERIES_REACH: f64 = 1.0 / 32.0;

/// The felt's force near a compression a: K c^alpha = K a^alpha (1 + x)^alpha
/// with x = (c - a) / a, (1 + x)^alpha = sum of binom(alpha, k) x^k.
struct Series<'a> {
    anchor_m: f64,
    per_anchor: f64,
    force_n: f64,
    coefficients: &'a [f64; SERIES_TERMS + 1],
}

impl<'a> Series<'a> {
    #[inline(always)]
    fn new(law: &ContactLaw, binomial: &'a Binomial, last: &LastPower, anchor_m: f64) -> Option<Self> {
        if !(anchor_m > 0.0 && anchor_m.is_finite()) {
            return None;
        }
        let [last_m, per_last, last_n] = last.0.get();
        let from_last = Self { anchor_m: last_m, per_anchor: per_last, force_n: last_n, coefficients: &binomial.0 };
        let force_n = match from_last.force_n(anchor_m) {
            Some(f) if last_m > 0.0 => f,
            _ => law.stiffness * power(anchor_m, law.exponent),
        };
        let per_anchor = 1.0 / anchor_m;
        last.0.set([anchor_m, per_anchor, force_n]);
        Some(Self { anchor_m, per_anchor, force_n, coefficients: &binomial.0 })
    }

    /// K c^alpha, if c is within reach of the anchor.
    #[inline(always)]
    fn force_n(&self, c: f64) -> Option<f64> {
        let x = (c - self.anchor_m) * self.per_anchor;
        if !(x.abs() <= SERIES_REACH) {
            return None;
        }
        let a = self.coefficients;
        // Estrin's scheme: pairs, then pairs of pairs (a short dependency chain).
        let x2 = x * x;
        let x4 = x2 * x2;
        // (Plain products: without FMA in the baseline target, mul_add is a call.)
        let low = (a[1] * x + a[0]) + x2 * (a[3] * x + a[2]);
        let high = (a[5] * x + a[4]) + x2 * (a[7] * x + a[6]);
        let sum = (high + x4 * a[8]) * x4 + low;
        Some(self.force_n * sum)
    }
}

/// x^y, taken only where it is asked for. The power is a pure function, so
/// the compiler may take it ahead of the branch that needs it and throw the
/// result away: inlined, a sub-step took a power whether or not the felt's
/// series had answered (as it nearly always does), a sixth of a bass
/// string's sub-step.
#[inline(never)]
fn power(x: f64, y: f64) -> f64 {
    x.powf(y)
}

/// The felt's state at one compression (force and stored energy there).
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Felt {
    pub compression_m: f64,
    pub force_n: f64,
    pub energy_j: f64,
}

#[cfg(test)]
mod tests {
    use super::*;

    fn check(law: ContactLaw, c0: f64, c_hat: f64, w: f64) -> ContactStep {
        let s = law.solve(c0, c_hat, w);
        let c1 = s.compression_m;
        // The end compression is consistent with the force...
        assert!((c1 - (c_hat - w * s.step_force_n)).abs() <= 1e-12 * c_hat.abs().max(c0.abs()), "{law:?}");
        // ...and the force is the felt's energy change over the compression change.
        if (c1 - c0).abs() > 1e-3 * c1.abs().max(c0.abs()) {
            let q = (law.energy_j(c1) - law.energy_j(c0)) / (c1 - c0);
            assert!((s.step_force_n - q).abs() <= 1e-9 * q.abs().max(1e-300), "{law:?}: {} vs {q}", s.step_force_n);
        }
        s
    }

    #[test]
    fn solves_soft_and_very_hard_felts() {
        let laws = [
            ContactLaw { stiffness: 4.0e8, exponent: 2.3 },
            ContactLaw { stiffness: 4.5e9, exponent: 2.5 },
            ContactLaw { stiffness: 1.0e12, exponent: 3.0 },
            ContactLaw { stiffness: 1.0e6, exponent: 1.0 },
            ContactLaw { stiffness: 10.0, exponent: 1.5 },
        ];
        for law in laws {
            for (c0, c_hat, w) in
                [(0.0, 1e-4, 1e-5), (2e-4, 3e-4, 2e-6), (5e-4, 1e-3, 1e-7), (1e-4, -1e-4, 1e-6), (-1e-5, 1e-9, 1e-3)]
            {
                let s = check(law, c0, c_hat, w);
                assert!(s.step_force_n >= 0.0);
                assert!(s.compression_m <= c_hat);
            }
        }
    }

    #[test]
    fn converges_in_a_few_iterations_along_a_strike() {
        // Compressions growing step by step as in a C2 strike, and a treble felt.
        for (law, w, dc) in [
            (ContactLaw { stiffness: 4.0e8, exponent: 2.3 }, 2e-8, 6.5e-6),
            (ContactLaw { stiffness: 1.0e12, exponent: 3.0 }, 1e-8, 1e-6),
            (ContactLaw { stiffness: 1.0e6, exponent: 1.0 }, 3e-7, 1e-6),
        ] {
            let mut c0 = 0.0;
            for k in 0..200 {
                let s = law.solve(c0, c0 + dc * (1.0 - k as f64 / 100.0), w);
                assert!(s.iterations <= 6, "{law:?} step {k}: {} iterations", s.iterations);
                c0 = s.compression_m;
            }
        }
    }

    #[test]
    fn chained_steps_from_a_guessed_force_stay_exact() {
        // As a strike chains them: each step starts from the felt the last one left
        // and from a force and compression extrapolated by parabolas; most end on
        // an accepted Newton step taken along the curves.
        for (law, w, dc) in [
            (ContactLaw { stiffness: 4.0e8, exponent: 2.3 }, 2e-8, 6.5e-6),
            (ContactLaw { stiffness: 1.0e12, exponent: 3.0 }, 1e-8, 1e-6),
            (ContactLaw { stiffness: 1.0e6, exponent: 1.0 }, 3e-7, 1e-6),
        ] {
            let mut felt = Felt::default();
            let mut forces = [0.0; 3];
            let mut compressions = [0.0; 3];
            let binomial = law.binomial();
            let last_power = LastPower::default();
            let mut evaluations = 0;
            for k in 0..200 {
                let c0 = felt.compression_m;
                let c_hat = c0 + dc * (1.0 - k as f64 / 100.0);
                let guess = Guess {
                    force_n: 3.0 * (forces[0] - forces[1]) + forces[2],
                    compression_m: 3.0 * (compressions[0] - compressions[1]) + compressions[2],
                    binomial: &binomial,
                    last_power: &last_power,
                };
                let (s, end) = law.step(felt, c_hat, w, Some(guess));
                evaluations += s.iterations;
                let c1 = s.compression_m;
                let miss = (c1 - (c_hat - w * s.step_force_n)).abs() / c_hat.abs().max(c0.abs());
                assert!(
                    miss <= 1e-12,
                    "{law:?} step {k}: c1 {c1} c_hat {c_hat} c0 {c0} q {} miss {miss}",
                    s.step_force_n
                );
                if c1 > 0.0 {
                    let exact = law.felt(c1);
                    let (e, f) = (exact.energy_j, exact.force_n);
                    assert!((end.force_n - f).abs() <= 1e-12 * f, "{law:?} step {k}: F {} vs {f}", end.force_n);
                    assert!((end.energy_j - e).abs() <= 1e-12 * e, "{law:?} step {k}: E {} vs {e}", end.energy_j);
                    // The force did the work the felt took in (exactly for the felt it
                    // started from, which carries the last step's rounding).
                    let work = s.step_force_n * (c1 - c0);
                    assert!((work - (end.energy_j - felt.energy_j)).abs() <= 1e-12 * e, "{law:?} step {k}");
                }
                felt = end;
                forces = [s.step_force_n, forces[0], forces[1]];
                compressions = [c1, compressions[0], compressions[1]];
            }
            // Mostly one evaluation per step.
            assert!(evaluations < 300, "{law:?}: {evaluations} evaluations in 200 steps");
        }
    }

    #[test]
    fn the_binomial_series_is_the_power_within_its_reach() {
        for exponent in [1.0, 1.5, 2.3, 2.5, 3.0, 4.7, 6.0] {
            let law = ContactLaw { stiffness: 4.0e8, exponent };
            let binomial = law.binomial();
            // The first term left out, at the edge of the reach.
            let mut next = binomial.0[SERIES_TERMS];
            next *= (exponent - SERIES_TERMS as f64) / (SERIES_TERMS + 1) as f64;
            assert!(next.abs() * SERIES_REACH.powi(SERIES_TERMS as i32 + 1) < 1e-15, "alpha {exponent}");
            let anchor = 3.7e-4;
            let series = Series::new(&law, &binomial, &LastPower::default(), anchor).unwrap();
            for i in -20..=20 {
                let c = anchor * (1.0 + 0.999 * SERIES_REACH * i as f64 / 20.0);
                let exact = law.force_n(c);
                let f = series.force_n(c).unwrap();
                assert!((f - exact).abs() <= 1e-14 * exact, "alpha {exponent}, c {c}: {f} vs {exact}");
            }
            assert!(series.force_n(anchor * (1.0 + 1.01 * SERIES_REACH)).is_none());
            assert!(series.force_n(anchor * (1.0 - 1.01 * SERIES_REACH)).is_none());
        }
    }

    #[test]
    fn anchors_reached_from_the_last_keep_the_power() {
        // A long strike's worth of anchors, each a few percent from the last
        // (and one in eleven out of the series' reach, reached by a power):
        // the force at each, reached through the series from the one before,
        // stays the power's.
        for exponent in [1.5, 2.3, 2.5, 3.0, 4.7] {
            let law = ContactLaw { stiffness: 4.0e8, exponent };
            let binomial = law.binomial();
            let last = LastPower::default();
            let mut worst: f64 = 0.0;
            let mut anchor = 1e-6;
            for k in 0..20_000 {
                // Up and down between 1 um and 1 mm, by 0.3 % to 3 % a step.
                let rate = if k % 11 == 5 { 0.05 } else { 0.003 + 0.027 * ((k as f64 * 0.37).sin() * 0.5 + 0.5) };
                anchor *= if (k / 2_000) % 2 == 0 { 1.0 + rate } else { 1.0 / (1.0 + rate) };
                anchor = anchor.clamp(1e-6, 1e-3);
                let series = Series::new(&law, &binomial, &last, anchor).unwrap();
                let exact = law.force_n(anchor);
                worst = worst.max((series.force_n - exact).abs() / exact);
            }
            assert!(worst <= 1e-13, "alpha {exponent}: {worst:e}");
        }
    }

    #[test]
    fn a_linear_spring_gets_the_trapezoidal_mean() {
        // Both ends in contact: F = K (C0 + C1) / 2 exactly.
        let law = ContactLaw { stiffness: 1e6, exponent: 1.0 };
        let s = check(law, 1e-6, 3e-6, 1e-7);
        assert!((s.step_force_n - 1e6 * (1e-6 + s.compression_m) / 2.0).abs() < 1e-9);
    }

    #[test]
    fn no_compression_no_force() {
        let law = ContactLaw { stiffness: 4.5e9, exponent: 2.5 };
        assert_eq!(law.solve(0.0, 0.0, 1e-6).step_force_n, 0.0);
        assert_eq!(law.solve(-1e-6, -1e-5, 1e-6).step_force_n, 0.0);
    }

    /// The root of a step's g, from the law's power (bisection), and the mean
    /// force there.
    fn exact_root(law: ContactLaw, c0: f64, c_hat: f64, w: f64) -> (f64, f64) {
        let mean = |c: f64| (law.energy_j(c) - law.energy_j(c0)) / (c - c0);
        let (mut lo, mut hi) = (c0 * (1.0 + 1e-9), c_hat);
        for _ in 0..200 {
            let mid = 0.5 * (lo + hi);
            if mid - c_hat + w * mean(mid) > 0.0 {
                hi = mid;
            } else {
                lo = mid;
            }
        }
        (lo, mean(lo))
    }

    #[test]
    fn the_last_step_along_the_curves_is_exact_to_the_fourth_order() {
        // One evaluation a little off the root (a guess 8e-5 of the compression
        // away), the step from there taken along the curves: the force and the
        // felt at the end are the law's to 1e-14. (A second-order step errs by
        // about (8e-5)^3 = 5e-13 here.)
        for (law, w) in [
            (ContactLaw { stiffness: 4.0e8, exponent: 2.3 }, 2e-8),
            (ContactLaw { stiffness: 4.5e9, exponent: 2.5 }, 5e-9),
            (ContactLaw { stiffness: 1.0e12, exponent: 3.0 }, 1e-9),
        ] {
            let c0 = 4e-4;
            let c_hat = 6e-4;
            let (root, q_exact) = exact_root(law, c0, c_hat, w);
            let binomial = law.binomial();
            let last_power = LastPower::default();
            for off in [8e-5, -8e-5] {
                let at = root * (1.0 + off);
                let guess = Guess {
                    force_n: (c_hat - at) / w,
                    compression_m: at,
                    binomial: &binomial,
                    last_power: &last_power,
                };
                let (s, end) = law.step(law.felt(c0), c_hat, w, Some(guess));
                assert_eq!(s.iterations, 1, "{law:?} {off}: the first step is the last");
                let exact = law.felt(end.compression_m);
                assert!((s.compression_m - root).abs() <= 1e-14 * root, "{law:?} {off}: {} vs {root}", s.compression_m);
                assert!(
                    (s.step_force_n - q_exact).abs() <= 1e-13 * q_exact,
                    "{law:?} {off}: Q {} vs {q_exact}",
                    s.step_force_n
                );
                assert!(
                    (end.force_n - exact.force_n).abs() <= 1e-14 * exact.force_n,
                    "{law:?} {off}: F {} vs {}",
                    end.force_n,
                    exact.force_n
                );
                assert!((end.energy_j - exact.energy_j).abs() <= 1e-14 * exact.energy_j, "{law:?} {off}: E");
            }
        }
    }

    #[test]
    fn the_last_move_follows_the_root_of_the_cubic() {
        // The cubic s = step + a s^2 + b s^3 solved by Newton's method, and the
        // mean force moved by s, against the series. The mean force's
        // derivatives at 1 mm and 100 N where the step starts close by,
        // compliances from soft to stiff, and steps up to a hundred times
        // what the solve takes along the curves (1e-2 of the compression), so
        // that the series' last term shows (up to about 1e-7 of the move)
        // and what it leaves out (under a fiftieth of that) does not.
        let (c, f) = (1e-3, 100.0);
        for alpha in [1.5, 2.5, 3.5] {
            let dq = alpha * f / c / 2.0;
            let half_q2 = alpha * (alpha - 1.0) * f / (c * c) / 6.0;
            let sixth_q3 = alpha * (alpha - 1.0) * (alpha - 2.0) * f / (c * c * c) / 24.0;
            for w in [0.3, 3.0, 30.0].map(|x| x / dq) {
                let per_slope = 1.0 / (1.0 + w * dq);
                let (a, b) = (w * half_q2 * per_slope, -w * sixth_q3 * per_slope);
                for step in [1e-2, -7e-3, 3e-3].map(|x| x * c) {
                    let mut s = step;
                    for _ in 0..50 {
                        s -= (s - step - a * s * s - b * s * s * s) / (1.0 - 2.0 * a * s - 3.0 * b * s * s);
                    }
                    let exact = s * (-dq + s * (half_q2 - sixth_q3 * s));
                    let series = last_move(step, dq, half_q2, sixth_q3, w, per_slope);
                    let last_term = 5.0 * a * (a * half_q2 - sixth_q3) * step.powi(4) * per_slope;
                    assert!(
                        (series - exact).abs() <= 0.05 * last_term.abs() + 1e-15 * exact.abs(),
                        "alpha {alpha}, w dq {}, step {step:e}: {series:e} vs {exact:e}, last term {last_term:e}",
                        w * dq
                    );
                }
            }
        }
    }

    #[test]
    fn a_step_that_barely_leaves_its_start_is_not_taken_along_the_curves() {
        // The guess lands 2e-6 of the compression past the start, the root 1e-4
        // past it: a Newton step fifty times the distance from the start, where
        // the mean force's Taylor series do not hold. The solve goes on, and
        // ends where the law's work matches the felt's energy.
        let law = ContactLaw { stiffness: 4.0e8, exponent: 2.3 };
        let (c0, w) = (1e-3, 2e-8);
        let root = c0 * (1.0 + 1e-4);
        let q_root = (law.energy_j(root) - law.energy_j(c0)) / (root - c0);
        let c_hat = root + w * q_root;
        let binomial = law.binomial();
        let last_power = LastPower::default();
        let at = c0 * (1.0 + 2e-6);
        let guess =
            Guess { force_n: (c_hat - at) / w, compression_m: at, binomial: &binomial, last_power: &last_power };
        let (s, end) = law.step(law.felt(c0), c_hat, w, Some(guess));
        assert!(s.iterations >= 2, "{} iterations", s.iterations);
        let c1 = s.compression_m;
        assert!((c1 - root).abs() <= 1e-12 * root, "{c1} vs {root}");
        let work = s.step_force_n * (c1 - c0);
        let stored = law.energy_j(c1) - law.energy_j(c0);
        assert!((work - stored).abs() <= 1e-12 * law.energy_j(c1), "{work} vs {stored}");
        assert!((end.force_n - law.force_n(c1)).abs() <= 1e-13 * end.force_n);
    }
}
