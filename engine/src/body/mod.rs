//! Where the strings' force goes: the bridge, and the body it drives.
//!
//! Every instrument has a body computed from its dimensions and materials
//! ([`boards`]: the board as an orthotropic ribbed plate, [`plate`], with the
//! air mode of a box): its modes, their loss, and their shapes at every key's
//! bridge point. A key hands its force to the [`Bridge`] at its [`BridgePoint`];
//! the bridge sums it into the zones its bridges are cut into, and the
//! [`soundboard::Soundboard`] runs the body's modes under those forces and
//! radiates them ([`radiation`]) to a pair of microphones. The seed's
//! surrogate, the bridge force itself panned by where the key sits, stays as an
//! output of its own ([`Output::BridgeForce`]).

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

pub mod boards;
pub mod load;
pub mod plate;
pub mod radiation;
pub mod soundboard;

use crate::CONTROL_BLOCK;
use boards::{MAX_ZONES, ZoneShare};

/// What the output is.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, serde::Serialize, serde::Deserialize)]
pub enum Output {
    /// The body's modes as a pair of microphones over the board hears them.
    #[default]
    Microphones,
    /// The seed's surrogate: every key's bridge force, panned by its place on the
    /// keyboard (a rigid, purely resistive bridge).
    BridgeForce,
}

/// Where a key's strings bear on the bridge: between two of the body's zones,
/// and, for the bridge-force output, a constant-power pan (0 dB at the centre
/// in each channel's sum).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BridgePoint {
    pan: f64,
    left: f64,
    right: f64,
    zones: ZoneShare,
}

impl BridgePoint {
    /// A point heard at `pan`, -1 (left) ..= 1 (right), on no zone.
    pub fn panned(pan: f64) -> Self {
        let pan = pan.clamp(-1.0, 1.0);
        let angle = (pan + 1.0) * std::f64::consts::FRAC_PI_4;
        Self {
            pan,
            left: angle.cos() * std::f64::consts::SQRT_2,
            right: angle.sin() * std::f64::consts::SQRT_2,
            zones: ZoneShare { zones: [0, 0], weights: [0.0, 0.0] },
        }
    }

    /// Where the bridge-force output places it, -1 (left) ..= 1 (right).
    pub fn pan(&self) -> f64 {
        self.pan
    }

    /// The same point bearing on the body's zones as `share` says.
    pub fn on_zones(self, share: ZoneShare) -> Self {
        let zones = ZoneShare { zones: share.zones.map(|z| z.min(MAX_ZONES - 1)), weights: share.weights };
        Self { zones, ..self }
    }
}

/// What every sounding key drives during one stretch of at most a control
/// block: the force on each of the body's zones, and the panned bridge force.
/// When some key is placed in the stereo image of its own (a note's pan), the
/// zones are summed twice, once as each microphone is to hear them (`split`).
/// Real-time safe.
#[derive(Clone)]
pub struct Bridge {
    out: [[f64; CONTROL_BLOCK]; 2],
    zones: [[f64; CONTROL_BLOCK]; MAX_ZONES],
    /// The zones as the right microphone hears them, while split.
    zones_right: Box<[[f64; CONTROL_BLOCK]; MAX_ZONES]>,
    len: usize,
    /// Whether the panned bridge force is heard this stretch (else only the zones are summed).
    panned: bool,
    split: bool,
}

impl Default for Bridge {
    fn default() -> Self {
        Self {
            out: [[0.0; CONTROL_BLOCK]; 2],
            zones: [[0.0; CONTROL_BLOCK]; MAX_ZONES],
            zones_right: Box::new([[0.0; CONTROL_BLOCK]; MAX_ZONES]),
            len: 0,
            panned: true,
            split: false,
        }
    }
}

/// A key's own place in the stereo image (a note's pan expression): a gain on
/// each microphone's hearing of its push, constant power, 1 and 1 in the
/// middle; and, for the bridge-force output, the pan law's gains at its own
/// place added to where the instrument puts the key. Both are reached in even
/// steps over a control block's samples (however the blocks are cut).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct KeyPan {
    /// Microphones, then the bridge-force output: left and right each.
    gains: [f64; 4],
    to: [f64; 4],
    step: [f64; 4],
    /// Samples left to glide.
    left: usize,
    /// Whether it has a place of its own (else `gains` is for the middle).
    placed: bool,
}

impl Default for KeyPan {
    fn default() -> Self {
        Self { gains: [1.0; 4], to: [1.0; 4], step: [0.0; 4], left: 0, placed: false }
    }
}

impl KeyPan {
    /// Move to `pan`, -1 (left) ..= 1 (right), for a key at `at`, over the
    /// next control block.
    pub fn set(&mut self, pan: f64, at: BridgePoint) {
        let pan = if pan.is_finite() { pan.clamp(-1.0, 1.0) } else { 0.0 };
        let (mics, out) = (BridgePoint::panned(pan), BridgePoint::panned(at.pan + pan));
        // Exactly as built in the middle.
        self.to = if pan == 0.0 { [1.0, 1.0, at.left, at.right] } else { [mics.left, mics.right, out.left, out.right] };
        if !self.placed {
            // From where the key is heard now.
            self.gains = [1.0, 1.0, at.left, at.right];
        }
        self.placed = true;
        self.step = [0, 1, 2, 3].map(|c| (self.to[c] - self.gains[c]) / CONTROL_BLOCK as f64);
        self.left = CONTROL_BLOCK;
        if pan == 0.0 && self.gains == self.to {
            *self = Self::default();
        }
    }

    /// At `pan` at once (a key that is not sounding has nothing to glide).
    pub fn set_now(&mut self, pan: f64, at: BridgePoint) {
        self.set(pan, at);
        self.gains = self.to;
        self.left = 0;
        if pan == 0.0 || !pan.is_finite() {
            *self = Self::default();
        }
    }

    /// Whether it has a place of its own, or is moving to or from one.
    pub fn is_placed(&self) -> bool {
        self.placed
    }

    /// The gains for the next sample: microphones left and right, bridge
    /// force left and right.
    fn next(&mut self) -> [f64; 4] {
        if self.left > 0 {
            self.left -= 1;
            if self.left == 0 {
                self.gains = self.to;
                if self.to[..2] == [1.0, 1.0] {
                    // Back in the middle: as built from here on.
                    self.placed = false;
                }
            } else {
                self.gains = [0, 1, 2, 3].map(|c| self.gains[c] + self.step[c]);
            }
        }
        self.gains
    }
}

impl Bridge {
    /// Begin a stretch of `len` samples (at most a control block) with nothing
    /// driving, the panned bridge force summed only if `panned` (the zones
    /// always; twice, one sum per microphone, if `split`).
    pub fn start(&mut self, len: usize, panned: bool, split: bool) {
        self.len = len.min(CONTROL_BLOCK);
        self.panned = panned;
        self.split = split;
        for channel in self.out.iter_mut().chain(self.zones.iter_mut()) {
            channel[..self.len].fill(0.0);
        }
        if split {
            for channel in self.zones_right.iter_mut() {
                channel[..self.len].fill(0.0);
            }
        }
    }

    /// Whether the zones are summed per microphone this stretch.
    pub fn is_split(&self) -> bool {
        self.split
    }

    /// The stretch's length.
    pub fn len(&self) -> usize {
        self.len
    }

    /// Whether the stretch is empty.
    pub fn is_empty(&self) -> bool {
        self.len == 0
    }

    /// A key pushes with `force` (already at its output gain) at `at`, for the
    /// stretch's samples.
    pub fn drive(&mut self, at: BridgePoint, force: &[f64]) {
        if self.panned {
            let [left, right] = &mut self.out;
            for ((l, r), f) in left[..self.len].iter_mut().zip(&mut right[..self.len]).zip(force) {
                *l += f * at.left;
                *r += f * at.right;
            }
        }
        for (zone, weight) in at.zones.zones.into_iter().zip(at.zones.weights) {
            if weight != 0.0 {
                for (z, f) in self.zones[zone][..self.len].iter_mut().zip(force) {
                    *z += f * weight;
                }
                if self.split {
                    for (z, f) in self.zones_right[zone][..self.len].iter_mut().zip(force) {
                        *z += f * weight;
                    }
                }
            }
        }
    }

    /// A key placed at `pan` in the stereo image pushes with `force` at `at`:
    /// each side hears it at its own gain. Without a split stretch both sides
    /// hear their mean (the body is not yet run twice).
    pub fn drive_placed(&mut self, at: BridgePoint, force: &[f64], pan: &mut KeyPan) {
        for (t, f) in force[..self.len].iter().enumerate() {
            let [gl, gr, out_l, out_r] = pan.next();
            if self.panned {
                self.out[0][t] += f * out_l;
                self.out[1][t] += f * out_r;
            }
            for (zone, weight) in at.zones.zones.into_iter().zip(at.zones.weights) {
                if weight != 0.0 {
                    if self.split {
                        self.zones[zone][t] += f * weight * gl;
                        self.zones_right[zone][t] += f * weight * gr;
                    } else {
                        self.zones[zone][t] += f * weight * 0.5 * (gl + gr);
                    }
                }
            }
        }
    }

    /// The stretch's force on each zone as the right microphone hears it
    /// (the same as [`Self::zone_forces`] unless split).
    pub fn zone_forces_right(&self) -> &[[f64; CONTROL_BLOCK]; MAX_ZONES] {
        if self.split { &self.zones_right } else { &self.zones }
    }

    /// The stretch's force on each zone.
    pub fn zone_forces(&self) -> &[[f64; CONTROL_BLOCK]; MAX_ZONES] {
        &self.zones
    }

    /// The stretch's bridge force, panned, left and right.
    pub fn panned(&self) -> (&[f64], &[f64]) {
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
        bridge.start(4, true, false);
        bridge.drive(BridgePoint::panned(0.0), &[1.0, 2.0, 0.0, -1.0]);
        let (l, r) = bridge.panned();
        assert!(l.iter().zip(r).all(|(l, r)| (l - r).abs() < 1e-12), "{l:?} {r:?}");
        assert!((l[1] - 2.0).abs() < 1e-12, "{l:?}");
        bridge.start(2, true, false);
        bridge.drive(BridgePoint::panned(-1.0), &[1.0, 1.0]);
        bridge.drive(BridgePoint::panned(1.0), &[0.5, 0.5]);
        let (l, r) = bridge.panned();
        assert!((l[0] - std::f64::consts::SQRT_2).abs() < 1e-12, "{l:?}");
        assert!((r[0] - 0.5 * std::f64::consts::SQRT_2).abs() < 1e-12, "{r:?}");
        assert_eq!(l.len(), 2);
    }

    #[test]
    fn a_placed_key_is_heard_by_each_side_at_its_gain() {
        let mut bridge = Bridge::default();
        let point = BridgePoint::panned(0.0).on_zones(ZoneShare { zones: [1, 1], weights: [1.0, 0.0] });
        let mut pan = KeyPan::default();
        assert!(!pan.is_placed());
        pan.set(-1.0, point);
        assert!(pan.is_placed());
        // Over a control block it glides to hard left, then holds.
        bridge.start(CONTROL_BLOCK, true, true);
        bridge.drive_placed(point, &[1.0; CONTROL_BLOCK], &mut pan);
        bridge.start(2, true, true);
        bridge.drive_placed(point, &[1.0, 1.0], &mut pan);
        bridge.drive(point, &[0.5, 0.5]);
        let (l, r) = bridge.panned();
        assert!((l[0] - std::f64::consts::SQRT_2 - 0.5).abs() < 1e-12 && (r[0] - 0.5).abs() < 1e-12, "{l:?} {r:?}");
        assert!((bridge.zone_forces()[1][0] - std::f64::consts::SQRT_2 - 0.5).abs() < 1e-12);
        assert!((bridge.zone_forces_right()[1][0] - 0.5).abs() < 1e-12);
        // Back to the middle: exactly as built.
        pan.set(0.0, point);
        bridge.start(CONTROL_BLOCK, true, true);
        bridge.drive_placed(point, &[1.0; CONTROL_BLOCK], &mut pan);
        assert!(!pan.is_placed());
    }

    #[test]
    fn on_the_bridge_force_a_notes_pan_adds_to_the_keys_own_place() {
        // A key the instrument puts at 0.6 right, placed 0.4 further right by
        // its note: it is heard hard right, at the pan law's full gain.
        let mut bridge = Bridge::default();
        let at = BridgePoint::panned(0.6);
        let mut pan = KeyPan::default();
        pan.set_now(0.4, at);
        bridge.start(1, true, false);
        bridge.drive_placed(at, &[1.0], &mut pan);
        let (l, r) = bridge.panned();
        assert!(l[0].abs() < 1e-12 && (r[0] - std::f64::consts::SQRT_2).abs() < 1e-12, "{l:?} {r:?}");
        // Placed at -0.6, it is heard in the middle.
        pan.set_now(-0.6, at);
        bridge.start(1, true, false);
        bridge.drive_placed(at, &[1.0], &mut pan);
        let (l, r) = bridge.panned();
        assert!((l[0] - 1.0).abs() < 1e-12 && (r[0] - 1.0).abs() < 1e-12, "{l:?} {r:?}");
    }

    #[test]
    fn a_key_between_two_zones_shares_its_force_between_them() {
        let mut bridge = Bridge::default();
        bridge.start(3, true, false);
        let point = BridgePoint::panned(0.0).on_zones(ZoneShare { zones: [2, 3], weights: [0.25, 0.75] });
        bridge.drive(point, &[4.0, 0.0, -8.0]);
        let zones = bridge.zone_forces();
        assert_eq!(&zones[2][..3], &[1.0, 0.0, -2.0]);
        assert_eq!(&zones[3][..3], &[3.0, 0.0, -6.0]);
        assert!(zones[0][..3].iter().all(|&f| f == 0.0));
    }
}
