//! Where the strings' force goes: the bridge, and what it drives.
//!
//! Today the bridge is rigid and resistive, and the body is the seed's
//! surrogate: a key's bridge force (scaled to full scale by its gain) is the
//! sound, placed in the stereo field by where the key sits on the keyboard. A
//! key hands its force to the [`Bridge`] at its [`BridgePoint`], never to the
//! mix, so the instrument's body joins here: a point becomes the body's mode
//! shapes at the string's end, and the bridge the modes radiating to two
//! microphones.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use crate::CONTROL_BLOCK;

/// Where a key's strings bear on the bridge, as the output hears it: a
/// constant-power pan (0 dB at the centre in each channel's sum).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BridgePoint {
    left: f64,
    right: f64,
}

impl BridgePoint {
    /// A point heard at `pan`, -1 (left) ..= 1 (right).
    pub fn panned(pan: f64) -> Self {
        let angle = (pan.clamp(-1.0, 1.0) + 1.0) * std::f64::consts::FRAC_PI_4;
        Self { left: angle.cos() * std::f64::consts::SQRT_2, right: angle.sin() * std::f64::consts::SQRT_2 }
    }
}

/// What every sounding key drives during one stretch of at most a control
/// block, and what comes out of it, left and right. Real-time safe.
pub struct Bridge {
    out: [[f64; CONTROL_BLOCK]; 2],
    len: usize,
}

impl Default for Bridge {
    fn default() -> Self {
        Self { out: [[0.0; CONTROL_BLOCK]; 2], len: 0 }
    }
}

impl Bridge {
    /// Begin a stretch of `len` samples (at most a control block) with nothing driving.
    pub fn start(&mut self, len: usize) {
        self.len = len.min(CONTROL_BLOCK);
        for channel in &mut self.out {
            channel[..self.len].fill(0.0);
        }
    }

    /// A key pushes with `force` (already at its output gain) at `at`, for the
    /// stretch's samples.
    pub fn drive(&mut self, at: BridgePoint, force: &[f64]) {
        let [left, right] = &mut self.out;
        for ((l, r), f) in left[..self.len].iter_mut().zip(&mut right[..self.len]).zip(force) {
            *l += f * at.left;
            *r += f * at.right;
        }
    }

    /// The stretch's sound, left and right.
    pub fn radiated(&self) -> (&[f64], &[f64]) {
        let [left, right] = &self.out;
        (&left[..self.len], &right[..self.len])
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_centred_point_sounds_equally_in_both_channels_and_the_sides_in_one() {
        let mut bridge = Bridge::default();
        bridge.start(4);
        bridge.drive(BridgePoint::panned(0.0), &[1.0, 2.0, 0.0, -1.0]);
        let (l, r) = bridge.radiated();
        assert!(l.iter().zip(r).all(|(l, r)| (l - r).abs() < 1e-12), "{l:?} {r:?}");
        assert!((l[1] - 2.0).abs() < 1e-12, "{l:?}");
        bridge.start(2);
        bridge.drive(BridgePoint::panned(-1.0), &[1.0, 1.0]);
        bridge.drive(BridgePoint::panned(1.0), &[0.5, 0.5]);
        let (l, r) = bridge.radiated();
        assert!((l[0] - std::f64::consts::SQRT_2).abs() < 1e-12, "{l:?}");
        assert!((r[0] - 0.5 * std::f64::consts::SQRT_2).abs() < 1e-12, "{r:?}");
        assert_eq!(l.len(), 2);
    }
}
