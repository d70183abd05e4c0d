//! A key's phantom products as they play: whether they sound, when they are
//! set again from the strings, and their fade-in when they start
//! ([`crate::phantom`] computes them).

use crate::CONTROL_BLOCK;
use crate::modal_bank::{FreeGather, LANES, add_lane_sums};
use crate::phantom::{BELOW_LOUDEST, Phantom};
use crate::struck_string::StruckString;

/// The phantom products fade in over this long when they start, s. They wait
/// for a strike to end (while the hammer plays the strings their loudest is
/// not known), so they start at the level the strings' motion gives them
/// then: at once, a step in the bridge force (A0 at velocity 127: 0.02 of
/// full scale in one sample, 35 ms in).
const PHANTOM_FADE_S: f64 = 0.005;

/// The phantom products are set again from the strings at least this often,
/// control blocks (to drop those that have faded under the floor).
const PHANTOM_REFRESH_BLOCKS: usize = 16;

/// The products of one key's strings (none above the last phantom key or off
/// the body), and their state.
#[derive(Clone)]
pub(super) struct PhantomState {
    products: Option<Phantom>,
    /// Whether any product is over the cull floor this block.
    on: bool,
    /// The products must be set again from the strings (their motion changed
    /// other than freely), and blocks since they were.
    stale: bool,
    age: usize,
    /// The level asked for (1: the physics), and the level the products in
    /// play were set at.
    level: f64,
    set: f64,
    /// Fading in since they started (run apart from the gathering
    /// meanwhile), samples of the fade done, and its length.
    fading: bool,
    faded: usize,
    fade_len: usize,
    /// Where the products lie in the key's gathering while they run there
    /// (`usize::MAX`: run alone).
    at: Option<usize>,
}

impl PhantomState {
    pub(super) fn new(products: Option<Phantom>) -> Self {
        Self {
            products,
            on: false,
            stale: true,
            age: 0,
            level: 1.0,
            set: 1.0,
            fading: false,
            faded: 0,
            fade_len: 1,
            at: None,
        }
    }

    /// How loud they are against the physics (0: none).
    pub(super) fn set_level(&mut self, level: f64) {
        self.level = level;
    }

    /// The strings' motion changed other than freely: set them again.
    pub(super) fn mark_stale(&mut self) {
        self.stale = true;
    }

    /// A control block begins: whether the products are set again from the
    /// strings in it (stale, old, or a new level). The strings must then be
    /// handed back from the gathering.
    pub(super) fn refresh_due(&mut self) -> bool {
        self.age += 1;
        self.stale || self.age >= PHANTOM_REFRESH_BLOCKS || self.level != self.set
    }

    /// Whether there are products at all.
    pub(super) fn exists(&self) -> bool {
        self.products.is_some()
    }

    /// Whether the fade-in has run its length (the products then join the
    /// gathering again, from the next stretch).
    pub(super) fn faded_in(&self) -> bool {
        self.fading && self.faded >= self.fade_len
    }

    pub(super) fn end_fade(&mut self) {
        self.fading = false;
    }

    /// Set them again from `strings`, dropping those under `floor` (N).
    pub(super) fn refresh(&mut self, strings: &[StruckString], floor: f64) {
        let Some(p) = &mut self.products else { return };
        let was_on = self.on;
        self.on = p.start_block(strings, self.level, floor);
        if self.on && !was_on {
            let fs = strings.first().map_or(0.0, StruckString::sample_rate_hz);
            self.fading = true;
            self.faded = 0;
            self.fade_len = ((PHANTOM_FADE_S * fs).round() as usize).max(1);
        }
        self.stale = !floor.is_finite();
        self.age = 0;
        self.set = self.level;
    }

    /// The floor below which products are dropped, given the strings' cull
    /// floor and loudest mode (N).
    pub(super) fn floor(floor_n: f64, loudest_n: f64) -> f64 {
        floor_n.max(BELOW_LOUDEST * loudest_n)
    }

    /// Gather them with the free strings (when sounding and not fading in).
    pub(super) fn gather(&mut self, gather: &mut FreeGather) {
        self.at = match (self.on && !self.fading, self.products.as_ref()) {
            (true, Some(p)) => Some(p.gather_free(gather).unwrap_or(usize::MAX)),
            _ => None,
        };
    }

    /// Hand their state back from `gather`.
    pub(super) fn scatter(&mut self, gather: &FreeGather) {
        if let (Some(at), Some(p)) = (self.at, self.products.as_mut())
            && at != usize::MAX
        {
            p.scatter_free(gather, at);
        }
    }

    /// Add them to `acc` where the gathering had no room for them.
    pub(super) fn accumulate_alone(&mut self, acc: &mut [[f64; LANES]]) {
        if let (Some(usize::MAX), Some(p)) = (self.at, self.products.as_mut()) {
            p.accumulate(acc);
        }
    }

    pub(super) fn is_fading(&self) -> bool {
        self.fading
    }

    /// Add the strings' stretch pulling on the bridge to `out`, faded in
    /// while it is starting ([`PHANTOM_FADE_S`]); `lanes` is scratch.
    pub(super) fn add(&mut self, lanes: &mut [[f64; LANES]; CONTROL_BLOCK], out: &mut [f64]) {
        let (true, Some(p)) = (self.on, self.products.as_mut()) else { return };
        let acc = &mut lanes[..out.len()];
        acc.fill([0.0; LANES]);
        p.accumulate(acc);
        if !self.fading {
            add_lane_sums(acc, out);
            return;
        }
        let mut pull = [0.0; CONTROL_BLOCK];
        let pull = &mut pull[..out.len()];
        add_lane_sums(acc, pull);
        let len = self.fade_len as f64;
        for (t, (o, v)) in out.iter_mut().zip(pull.iter()).enumerate() {
            *o += ((self.faded + t + 1) as f64 / len).min(1.0) * v;
        }
        self.faded += out.len();
    }

    /// At rest.
    pub(super) fn silence(&mut self) {
        self.on = false;
        self.stale = true;
        if let Some(p) = &mut self.products {
            p.silence();
        }
    }
}
