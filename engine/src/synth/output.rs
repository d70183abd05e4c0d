//! The output stage: every instrument's mix through a DC block and the
//! output gain, gliding to its control, into the host's samples.

use super::{CONTROL_BLOCK, ScopeWriter, guard};

/// Corner of the output's DC blocker, Hz (a pressed tangent holds a static force).
pub(super) const DC_BLOCK_HZ: f64 = 5.0;

/// A sample type the synth writes.
pub(super) trait OutputSample: Copy + Send {
    fn from_f64(x: f64) -> Self;
}

impl OutputSample for f32 {
    #[inline]
    fn from_f64(x: f64) -> Self {
        x as f32
    }
}

impl OutputSample for f64 {
    #[inline]
    fn from_f64(x: f64) -> Self {
        x
    }
}

/// One-pole DC blocker.
#[derive(Clone, Copy, Default)]
pub(super) struct DcBlock {
    pub(super) x1: f64,
    pub(super) y1: f64,
}

impl DcBlock {
    /// One sample. Its decay into silence is cut off below 1e-30 (-600 dBFS): the
    /// output then reaches exact zero instead of f32 subnormals (which hosts must
    /// not be handed), and the state never becomes an f64 subnormal (slow on x86).
    #[inline]
    pub(super) fn run(&mut self, x: f64, r: f64) -> f64 {
        let mut y = x - self.x1 + r * self.y1;
        if y.abs() < 1e-30 {
            y = 0.0;
        }
        self.x1 = x;
        self.y1 = y;
        y
    }
}

/// What every instrument sounding gave, and the last stage it goes out
/// through: a DC block and the output gain, gliding to its control.
pub(super) struct Outlet {
    pub(super) mix: Box<[[f64; CONTROL_BLOCK]; 2]>,
    pub(super) gain: f64,
    pub(super) dc: [DcBlock; 2],
    pub(super) dc_r: f64,
    /// Per-sample step of the output gain's glide toward its control (about 10 ms, so automation does not click).
    pub(super) glide: f64,
    /// The last line: nothing non-finite or over +6 dBFS leaves.
    pub(super) guard: guard::Guard,
}

impl Outlet {
    pub(super) fn new(sample_rate_hz: f64) -> Self {
        let mut outlet = Self {
            mix: Box::new([[0.0; CONTROL_BLOCK]; 2]),
            gain: 1.0,
            dc: [DcBlock::default(); 2],
            dc_r: 0.0,
            glide: 0.0,
            guard: guard::Guard::new(sample_rate_hz),
        };
        outlet.set_rate(sample_rate_hz);
        outlet
    }

    pub(super) fn set_rate(&mut self, sample_rate_hz: f64) {
        self.dc_r = (-2.0 * std::f64::consts::PI * DC_BLOCK_HZ / sample_rate_hz).exp();
        self.glide = glide_step(sample_rate_hz);
        self.guard.set_rate(sample_rate_hz);
    }

    /// The mix's first `left.len()` samples through the DC block and the
    /// output gain gliding to `to`, to `left` and `right` (and the live
    /// view, `scope`).
    pub(super) fn write<T: OutputSample>(&mut self, to: f64, scope: &mut ScopeWriter, left: &mut [T], right: &mut [T]) {
        let n = left.len();
        let [mix_l, mix_r] = &*self.mix;
        let (glide, r) = (self.glide, self.dc_r);
        let mut heard = [0.0f32; CONTROL_BLOCK];
        for t in 0..n {
            // The glide arrives once within 1e-9 of its target (-180 dB): gliding on
            // toward silence for ever, the gain would make subnormal samples (and
            // become an f64 subnormal itself).
            self.gain = if (to - self.gain).abs() < 1e-9 { to } else { self.gain + (to - self.gain) * glide };
            let (l, rr) =
                self.guard.run(self.dc[0].run(mix_l[t], r) * self.gain, self.dc[1].run(mix_r[t], r) * self.gain);
            left[t] = T::from_f64(l);
            right[t] = T::from_f64(rr);
            heard[t] = 0.5 * (l + rr) as f32;
        }
        scope.samples(&heard[..n]);
    }
}

/// The output gain's per-sample glide coefficient: a 10 ms time constant.
pub(super) fn glide_step(sample_rate_hz: f64) -> f64 {
    1.0 - (-1.0 / (0.01 * sample_rate_hz)).exp()
}
