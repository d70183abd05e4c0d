//! The implicit contact solve: felt (or a linear spring) pressed between a hammer
//! and a string.
//!
//! Contact law F = K C^alpha for compression C > 0, else 0 (Hall & Askenfelt 1988;
//! Chaigne & Askenfelt 1994, eq. 3; alpha = 1 is a linear spring, a santoor mallet).
//! Within a step the string and the hammer both yield linearly to the force they
//! share, so the compression at the end of the step is C = C_hat - W F, where C_hat
//! is the compression had the force stayed at zero and W (m/N) sums the
//! compliances of the string (its kept modes within the step plus the static
//! residual of the omitted ones) and of the hammer. The step's force solves
//!
//!   g(C) = C + W K C^alpha - C_hat = 0,   F = K C^alpha.
//!
//! g is increasing and convex on C > 0, so the root is unique. It lies in
//! [hi / 2, hi] with hi = min(C_hat, (C_hat / (W K))^(1/alpha)) (one of the two terms
//! holds at least half of C_hat at the root). Newton from hi then falls
//! monotonically onto the root; a bisection step guards against rounding.
//!
//! Allocates: no. Realtime-safe.

/// The felt (or spring) of a hammer or mallet.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ContactLaw {
    /// K, in N/m^alpha.
    pub stiffness: f64,
    /// alpha >= 1.
    pub exponent: f64,
}

/// Iterations allowed before the solve settles for its bracket; Newton from hi
/// needs fewer than 10 even for K = 1e12, alpha = 3.
const MAX_ITERATIONS: usize = 60;

impl ContactLaw {
    /// Force for a compression.
    pub fn force_n(&self, compression_m: f64) -> f64 {
        if compression_m > 0.0 {
            self.stiffness * compression_m.powf(self.exponent)
        } else {
            0.0
        }
    }

    /// Solve for the step's force given the free compression `c_hat` and the total
    /// compliance `w`. Returns (force, compression at the end of the step).
    pub fn solve(&self, c_hat: f64, w: f64) -> (f64, f64) {
        if !(c_hat > 0.0) {
            return (0.0, c_hat);
        }
        let (k, alpha) = (self.stiffness, self.exponent);
        if alpha == 1.0 {
            let c = c_hat / (1.0 + w * k);
            return (k * c, c);
        }
        let wk = w * k;
        let mut hi = c_hat.min((c_hat / wk).powf(1.0 / alpha));
        let mut lo = 0.5 * hi;
        let mut c = hi;
        for _ in 0..MAX_ITERATIONS {
            let c_pow = c.powf(alpha - 1.0);
            let g = c + wk * c_pow * c - c_hat;
            if g > 0.0 {
                hi = c;
            } else if g < 0.0 {
                lo = c;
            } else {
                break;
            }
            let slope = 1.0 + wk * alpha * c_pow;
            let mut next = c - g / slope;
            if !(next > lo && next < hi) {
                next = 0.5 * (lo + hi);
            }
            if (next - c).abs() <= 4.0 * f64::EPSILON * c {
                c = next;
                break;
            }
            c = next;
        }
        (self.force_n(c), c)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn residual(law: &ContactLaw, c_hat: f64, w: f64, f: f64) -> f64 {
        (f - law.force_n(c_hat - w * f)).abs() / f.max(1e-300)
    }

    #[test]
    fn solves_soft_and_very_hard_felts() {
        let cases = [
            (ContactLaw { stiffness: 4.0e8, exponent: 2.3 }, 1e-4, 1e-5),
            (ContactLaw { stiffness: 4.5e9, exponent: 2.5 }, 3e-4, 2e-6),
            (ContactLaw { stiffness: 1.0e12, exponent: 3.0 }, 1e-3, 1e-7),
            (ContactLaw { stiffness: 1.0e12, exponent: 3.0 }, 1e-9, 1e-3),
            (ContactLaw { stiffness: 1.0e6, exponent: 1.0 }, 1e-5, 3e-6),
            (ContactLaw { stiffness: 10.0, exponent: 1.5 }, 1e-2, 1e3),
        ];
        for (law, c_hat, w) in cases {
            let (f, c) = law.solve(c_hat, w);
            assert!(f > 0.0 && c > 0.0 && c < c_hat);
            assert!(residual(&law, c_hat, w, f) < 1e-12, "{law:?} {c_hat} {w}: {f}");
            assert!((c_hat - w * f - c).abs() <= 1e-12 * c_hat);
        }
    }

    #[test]
    fn no_compression_no_force() {
        let law = ContactLaw { stiffness: 4.5e9, exponent: 2.5 };
        assert_eq!(law.solve(0.0, 1e-6).0, 0.0);
        assert_eq!(law.solve(-1e-5, 1e-6).0, 0.0);
    }
}
