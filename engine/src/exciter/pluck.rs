//! The pluck (harpsichord, and Euphonics' "wire-break" pluck): the string is
//! pulled aside at one point into a triangle of height D and released from rest
//! at t = 0.
//!
//! Projecting the triangle with its apex at beta L on sin(n pi x / L):
//!   q_n(0) = 2 D sin(n pi beta) / (n^2 pi^2 beta (1 - beta)),  q_n'(0) = 0,
//! a 1/n^2 envelope with the partials that have a node at the plucking point missing.

use std::f64::consts::PI;

/// How the string is plucked.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct PluckSpec {
    /// Height of the triangle at the plucking point, m.
    pub displacement_m: f64,
    /// Plucking point as a fraction of the length from the bridge, 0 < p < 1.
    pub position: f64,
}

impl PluckSpec {
    /// Initial displacement of mode n, m.
    pub fn modal_displacement_m(&self, mode_number: usize) -> f64 {
        let (n, beta) = (mode_number as f64, self.position);
        2.0 * self.displacement_m * (n * PI * beta).sin() / (n * n * PI * PI * beta * (1.0 - beta))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn modes_sum_back_to_the_triangle() {
        let p = PluckSpec { displacement_m: 0.002, position: 1.0 / 7.8 };
        for &x in &[0.05, p.position, 0.5, 0.9] {
            let y: f64 = (1..200_000).map(|n| p.modal_displacement_m(n) * (n as f64 * PI * x).sin()).sum();
            let triangle =
                if x <= p.position { 0.002 * x / p.position } else { 0.002 * (1.0 - x) / (1.0 - p.position) };
            assert!((y - triangle).abs() < 1e-8, "{x}: {y} vs {triangle}");
        }
    }
}
