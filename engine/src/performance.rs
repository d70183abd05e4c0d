//! What the player is doing with the instrument as a whole: the pedals, the
//! wheels, una corda, the mallets' hardness, the bend, and each MIDI key's
//! own note shaping. The synth keeps one [`PerformanceState`] and hands it
//! whole to the keys it tells (a strike, a release, a control block, a drive
//! through the bridge); a key reads what it needs from it.

/// The dampers leave their strings over this many control blocks as the
/// pedal lifts them (10.7 ms at 48 kHz: the tray is not regulated to the
/// sample), each key at its own block.
pub(crate) const LIFT_SPREAD_BLOCKS: usize = 8;

/// A hand-held mallet's contact stiffness at full mod wheel, times as voiced: a
/// thick cloth-covered head against the bare wood of the wheel at rest. The range
/// is wide because a light mallet on a linear spring of 1e6 N/m per string is
/// stiff against the string's impedance (damping ratio sqrt(K M) / 4 Z0 near 25):
/// the head's spring only shapes the stroke once it falls below about 1e4 N/m.
pub const SOFTEST_MALLET: f64 = 1.0e-3;

/// The player's hands and feet on the instrument.
#[derive(Clone, Debug, PartialEq)]
pub struct PerformanceState {
    /// The sustain pedal, 0 (up) ..= 1 (down).
    pub(crate) sustain: f64,
    /// The sustain pedal has lifted the dampers (until it comes back up), and
    /// how far through its spread of control blocks they are leaving their
    /// strings (over `LIFT_SPREAD_BLOCKS` control blocks).
    pub(crate) dampers_lifted: bool,
    pub(crate) lifting: Option<usize>,
    /// The sostenuto pedal is down.
    pub(crate) sostenuto: bool,
    /// How far una corda shifts the action, 0..=1.
    pub(crate) una_corda: f64,
    /// Hand-held mallets' hardness from the mod wheel: a factor on the
    /// contact stiffness (a keyboard's hammers ignore it).
    pub(crate) mallet_hardness: f64,
    /// Pitch-wheel position -1..=1, and the frequency ratio it bends to.
    pub(crate) wheel: f64,
    pub(crate) bend: f64,
    /// Each MIDI key's own tuning, volume, place and hammer (its note's
    /// expressions), and which MIDI key's the strings of each course have
    /// now (by the course's home key): keys that share strings (the
    /// dulcimer's upper courses, a fretted clavichord) each keep their own.
    pub(crate) own: [OwnNote; 128],
    pub(crate) owner: [u8; 128],
}

impl Default for PerformanceState {
    fn default() -> Self {
        Self {
            sustain: 0.0,
            dampers_lifted: false,
            lifting: None,
            sostenuto: false,
            una_corda: 0.0,
            mallet_hardness: 1.0,
            wheel: 0.0,
            bend: 1.0,
            own: [OwnNote::default(); 128],
            owner: std::array::from_fn(|k| k as u8),
        }
    }
}

impl PerformanceState {
    /// No pedal but the sustain held fully down: keys let go this way are
    /// silenced, not damped (no damper lands).
    pub(crate) fn held_up() -> Self {
        Self { sustain: 1.0, ..Self::default() }
    }

    /// The sustain pedal moves to `value` (0..=1). Pressed past half way it
    /// lifts every damper off its strings at once (not again until it has come
    /// back under a quarter: a pedal held near half way does not chatter).
    pub(crate) fn pedal_to(&mut self, value: f64) {
        self.sustain = value.clamp(0.0, 1.0);
        if self.sustain >= 0.5 && !self.dampers_lifted {
            self.dampers_lifted = true;
            self.lifting = Some(0);
        } else if self.sustain < 0.25 {
            self.dampers_lifted = false;
            self.lifting = None;
        }
    }

    /// The mod wheel at `value` (0..=1): the mallets' hardness.
    pub(crate) fn mod_wheel(&mut self, value: f64) {
        self.mallet_hardness = SOFTEST_MALLET.powf(value.clamp(0.0, 1.0));
    }

    /// The pitch wheel at `value` (-1..=1), bending by up to `range_semitones`.
    pub(crate) fn pitch_wheel(&mut self, value: f64, range_semitones: f64) {
        self.wheel = value.clamp(-1.0, 1.0);
        self.rebend(range_semitones);
    }

    /// The bend again for a new range.
    pub(crate) fn rebend(&mut self, range_semitones: f64) {
        self.bend = 2f64.powf(self.wheel * range_semitones / 12.0);
    }
}

/// A MIDI key's own note shaping (its per-note expressions: tuning as a
/// ratio, volume as a gain, place -1..=1, hammer hardness and strike
/// position as factors).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct OwnNote {
    pub tune: f64,
    pub volume: f64,
    pub pan: f64,
    pub hammer: (f64, f64),
}

impl Default for OwnNote {
    fn default() -> Self {
        Self { tune: 1.0, volume: 1.0, pan: 0.0, hammer: (1.0, 1.0) }
    }
}
