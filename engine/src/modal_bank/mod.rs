//! The modal bank: a string's modes as damped oscillators, stepped exactly.
//!
//! Each mode obeys q'' + 2 sigma q' + omega^2 q = u(t), where u is the modal
//! acceleration an exciter applies (phi_n(x_e) F / m_n for a point force). Its
//! free motion is q = Re(z), q' = Re(lambda z) with lambda = -sigma + i omega_d, and
//! z advances over a step h by the exact factor p = exp(lambda h): no frequency
//! warping and no numerical damping at any sample rate.
//!
//! The input is held linearly over a step (first-order hold) and integrated
//! exactly: with x = lambda h, phi1(x) = (e^x - 1) / x and phi2(x) = (e^x - 1 - x) / x^2,
//!
//!   z(h) = p z(0) + (-i / omega_d) h [ (phi1 - phi2) u(0) + phi2 u(h) ].
//!
//! The state is stored scaled by each mode's bridge weight w_n = T k_n + EI k_n^3,
//! zeta_n = w_n z_n, so that the bridge force is simply sum_n Re(zeta_n): the free
//! step is one complex multiply and one add per mode and sample.
//!
//! # Number format
//!
//! Everything here is f64. A C1 mode with Q = 2000 at 192 kHz has a pole radius
//! of 1 - 2.7e-7, and its damped rotation differs from 1 by about 1e-6; f32 has
//! a spacing of 6e-8 just below 1, so it would hold the decay rate to no better
//! than about 20 % and the pitch of the lowest partials to several cents. In f64
//! the same quantities are exact to about 1e-10.
//!
//! # Layout
//!
//! Structure of arrays, a string's modes contiguous and padded to a multiple of
//! [`LANES`] with silent modes (pole 1, state 0). The free loop runs a block of
//! samples per group of `LANES` modes with the state held in registers, adding each
//! lane's output into a small accumulator that is summed once per sample. The
//! driven loop (an exciter in play) runs one step over all modes, folding the
//! input, the observation at the exciter and the bridge sum into the same pass.
//! Both add in the same order, so a string with an idle exciter gives the same
//! bits as a free one.
//!
//! # Rooms
//!
//! - `tables`: each mode's exact step and how an exciter drives and observes
//!   the modes ([`StepTable`], [`DriveTable`]).
//! - `bank`: the state of a string's modes and what is done to it ([`ModalBank`]).
//! - `gather`: several banks' free modes run together ([`FreeGather`]).
//! - `kernels`: the inner loops, compiled once for each vector extension.
//! - `x86`: the driven step and the lane sums in x86-64 intrinsics.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

mod bank;
mod gather;
mod kernels;
mod tables;
#[cfg(target_arch = "x86_64")]
mod x86;

pub use bank::ModalBank;
pub use gather::{FreeGather, Poles};
pub(crate) use kernels::{Kernel, free_block};
pub use kernels::{add_lane_sums, lane_sum};
pub(crate) use tables::inverse;
pub use tables::{DriveTable, Hold, SavedPoles, StepTable};

/// Modes per group in the inner loops (one AVX-512 register, two AVX2 registers of f64).
pub const LANES: usize = 8;

/// Samples per pass of the free loop; the accumulator for one pass stays in L1.
pub const FREE_BLOCK: usize = 64;

fn padded(len: usize) -> usize {
    len.div_ceil(LANES) * LANES
}

/// Strings the rooms' tests run on.
#[cfg(test)]
mod test_strings {
    use crate::string::damping::Damping;
    use crate::string::{Mass, Stiffness, StringModes, StringSpec, Tuning};

    /// A stiff treble string with modes up to 20 kHz.
    pub(super) fn treble_string() -> StringModes {
        StringSpec {
            length_m: 0.62,
            tuning: Tuning::TensionN(670.0),
            mass: Mass::PerLengthKgM(0.00634),
            stiffness: Stiffness::Inharmonicity(3.8e-4),
            damping: Damping::UniformQ(2000.0),
            max_frequency_hz: 20_000.0,
            outer_diameter_m: None,
        }
        .build()
        .unwrap()
    }

    /// One mode of quality factor `q`, at 100 Hz.
    pub(super) fn one_mode(q: f64) -> StringModes {
        StringSpec {
            length_m: 1.0,
            tuning: Tuning::FirstPartialHz(100.0),
            mass: Mass::PerLengthKgM(0.01),
            stiffness: Stiffness::Flexible,
            damping: Damping::UniformQ(q),
            max_frequency_hz: 150.0,
            outer_diameter_m: None,
        }
        .build()
        .unwrap()
    }
}
