//! What a player does, as the real-time engine receives it.

/// One performance event. Values are normalised the way MIDI 1.0 carries them.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Event {
    /// A key goes down; `velocity` in (0, 1] (MIDI velocity / 127).
    NoteOn { key: u8, velocity: f64 },
    /// A key comes up; `velocity` in [0, 1] (MIDI release velocity / 127; 0.5
    /// from a keyboard that does not measure it): how hard its damper lands.
    NoteOff { key: u8, velocity: f64 },
    /// CC64, 0 (dampers on the strings) to 1 (all dampers lifted); in between, half-pedal.
    Sustain(f32),
    /// CC66, held at or above 0.5: the keys down at that moment keep their dampers lifted.
    Sostenuto(f32),
    /// CC67, 0 to 1: una corda, how far the action shifts (at 1 the hammer
    /// misses one string of each unison; in between it meets it with less of
    /// its width).
    UnaCorda(f32),
    /// Pitch wheel, -1 to 1 (centre 0); the bend range is a control.
    PitchBend(f32),
    /// CC1, 0 to 1: the hand-held mallets' heads (santoor, dulcimer, cimbalom),
    /// from bare wood as voiced (0) to a thick cloth cover,
    /// [`super::SOFTEST_MALLET`] times the stiffness (1), for the strokes that follow.
    ModWheel(f32),
    /// The finger's pressure on a held key, 0 to 1 (polyphonic aftertouch; channel
    /// pressure and MPE pressure reach each key held on that channel this way). On
    /// a clavichord it presses the tangent deeper: Bebung.
    Pressure { key: u8, pressure: f32 },
    /// One key's own pitch offset, in semitones, on top of the pitch wheel:
    /// an MPE note's channel bend times its range, or a CLAP note's tuning
    /// expression. It holds until the next one for the key (0: none).
    KeyBend { key: u8, semitones: f32 },
    /// One key's own output gain (a CLAP note's volume expression), 1 as
    /// built; it glides there over the next stretch and holds until the next.
    KeyVolume { key: u8, gain: f32 },
    /// One key's own hammer (or mallets, or plectrum) over the instrument's
    /// voicing, for its next strikes: the felt's stiffness and the strike (or
    /// plucking) position as factors, 1 as voiced (a CLAP note's brightness expression, the hammer
    /// parameters' polyphonic modulation, MPE timbre). The strike point stays
    /// within 2 % to 50 % of the string. It holds until the next one for the key.
    KeyHammer { key: u8, hardness: f32, position: f32 },
    /// One key's own place in the stereo image (a CLAP note's pan
    /// expression), -1 (left) ..= 1 (right), 0 where the instrument puts it:
    /// each microphone (or, on the bridge-force output, each side) hears the
    /// key at a constant-power gain of its own, reached over a control block.
    /// It holds until the next one for the key.
    KeyPan { key: u8, pan: f32 },
    /// CC123: every key is released (dampers fall where the pedals allow).
    AllNotesOff,
    /// CC120 / reset: every key falls silent within a few milliseconds, pedals up, bend centred.
    Reset,
}

/// An event at a sample offset within the block being processed.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TimedEvent {
    pub time: u32,
    pub event: Event,
}

/// A MIDI velocity (0..=127) as the engine takes it, 0..=1. Normalised in 32
/// bits, as plugin hosts carry it (nice-plug hands the plugin its note
/// velocities as `f32`), so a MIDI file rendered offline plays the very
/// touch the plugin would.
pub fn midi_velocity(value: u8) -> f64 {
    f64::from(f32::from(value) / 127.0)
}

impl TimedEvent {
    pub fn new(time: u32, event: Event) -> Self {
        Self { time, event }
    }
}

/// Turns MIDI pressure into [`Event::Pressure`] per key: channel pressure reaches
/// every key held on its channel (all of them from an ordinary keyboard, one
/// note's from an MPE controller, which gives every note a channel of its own),
/// and a key pressed while its channel is under pressure starts with it.
/// Fixed size: real-time safe.
#[derive(Clone, Debug)]
pub struct PressureRouter {
    /// The channel each held key came on.
    channel_of: [Option<u8>; 128],
    /// The last channel pressure of each channel.
    channel_pressure: [f32; 16],
}

impl Default for PressureRouter {
    fn default() -> Self {
        Self { channel_of: [None; 128], channel_pressure: [0.0; 16] }
    }
}

impl PressureRouter {
    /// A key went down on `channel`: the pressure it starts under, if any.
    pub fn note_on(&mut self, key: u8, channel: u8) -> Option<Event> {
        self.channel_of[key as usize & 127] = Some(channel & 15);
        let pressure = self.channel_pressure[channel as usize & 15];
        (pressure > 0.0).then_some(Event::Pressure { key, pressure })
    }

    /// A key came up.
    pub fn note_off(&mut self, key: u8) {
        self.channel_of[key as usize & 127] = None;
    }

    /// Channel pressure on `channel`: one event per key held there, passed to `emit`.
    pub fn channel_pressure(&mut self, channel: u8, pressure: f32, mut emit: impl FnMut(Event)) {
        let channel = channel & 15;
        self.channel_pressure[channel as usize] = pressure;
        for (key, _) in self.channel_of.iter().enumerate().filter(|(_, c)| **c == Some(channel)) {
            emit(Event::Pressure { key: key as u8, pressure });
        }
    }

    /// Every key up, every channel's pressure released.
    pub fn reset(&mut self) {
        *self = Self::default();
    }
}

/// Turns pitch bends into the wheel or, from an MPE controller, into each
/// note's own bend. With MPE (its lower zone: channel 1 the master, 2-16 one
/// note each) a member channel's bend, times the member range, reaches the
/// keys held on that channel as [`Event::KeyBend`], and a key pressed on it
/// starts from the channel's bend; the master channel's bend moves the wheel
/// for every key. Without MPE every channel's bend is the wheel. A key bent
/// once is set straight when it is next pressed outside a bent channel.
/// Fixed size: real-time safe.
#[derive(Clone, Debug)]
pub struct BendRouter {
    /// The member channels' bend range, semitones; None: MPE off.
    mpe_range: Option<f32>,
    channel_of: [Option<u8>; 128],
    /// Each channel's last bend, -1..=1.
    channel_bend: [f32; 16],
    /// Keys with a bend of their own.
    bent: [bool; 128],
}

impl Default for BendRouter {
    fn default() -> Self {
        Self { mpe_range: None, channel_of: [None; 128], channel_bend: [0.0; 16], bent: [false; 128] }
    }
}

impl BendRouter {
    /// MPE on, its member channels bending over `range` semitones each way (48
    /// by the MPE specification), or off (None).
    pub fn set_mpe(&mut self, range: Option<f32>) {
        self.mpe_range = range.filter(|r| r.is_finite()).map(|r| r.clamp(0.0, 96.0));
    }

    fn member(&self, channel: u8) -> Option<f32> {
        self.mpe_range.filter(|_| channel & 15 != 0)
    }

    /// A key went down on `channel`: its own bend to start from, if it needs one.
    pub fn note_on(&mut self, key: u8, channel: u8) -> Option<Event> {
        let k = key as usize & 127;
        self.channel_of[k] = Some(channel & 15);
        let semitones = self.member(channel).map_or(0.0, |range| range * self.channel_bend[channel as usize & 15]);
        let was_bent = std::mem::replace(&mut self.bent[k], semitones != 0.0);
        (semitones != 0.0 || was_bent).then_some(Event::KeyBend { key, semitones })
    }

    /// A note's own tuning expression (semitones) for `key`.
    pub fn key_tuning(&mut self, key: u8, semitones: f32) -> Event {
        self.bent[key as usize & 127] = semitones != 0.0;
        Event::KeyBend { key, semitones }
    }

    /// A key came up (its bend stays with its ringing strings).
    pub fn note_off(&mut self, key: u8) {
        self.channel_of[key as usize & 127] = None;
    }

    /// A pitch bend (-1..=1) on `channel`: the wheel, or each held key's own
    /// on an MPE member channel, passed to `emit`.
    pub fn pitch_bend(&mut self, channel: u8, value: f32, mut emit: impl FnMut(Event)) {
        let channel = channel & 15;
        let Some(range) = self.member(channel) else {
            emit(Event::PitchBend(value));
            return;
        };
        self.channel_bend[channel as usize] = value;
        for key in 0..128 {
            if self.channel_of[key] == Some(channel) {
                self.bent[key] = true;
                emit(Event::KeyBend { key: key as u8, semitones: range * value });
            }
        }
    }

    /// Every key up, every channel centred, no key bent (the synth's reset
    /// straightens its keys).
    pub fn reset(&mut self) {
        *self = Self { mpe_range: self.mpe_range, ..Self::default() };
    }
}

/// Turns what shapes a note's own hammer into [`Event::KeyHammer`]: a CLAP
/// note's brightness expression and MPE timbre (CC74 on a member channel) set
/// its felt's hardness, [`HAMMER_SPAN`] times softer at 0 to as many times
/// harder at 1, as voiced at 0.5; the hammer parameters' polyphonic
/// modulation sets hardness and strike position factors of its own. A key
/// starts each note as voiced (or, on an MPE member channel, from the
/// channel's timbre). Fixed size: real-time safe.
#[derive(Clone, Debug)]
pub struct HammerRouter {
    mpe: bool,
    channel_of: [Option<u8>; 128],
    /// Each channel's last timbre, 0..=1 (0.5: none).
    channel_timbre: [f32; 16],
    /// Per key: its brightness (0.5 as voiced) and the modulation's hardness
    /// and position factors; and what the synth was last told.
    brightness: [f32; 128],
    modulation: [(f32, f32); 128],
    sent: [(f32, f32); 128],
}

/// How many times harder (or softer) full brightness (or none) makes a felt.
pub const HAMMER_SPAN: f32 = 4.0;

impl Default for HammerRouter {
    fn default() -> Self {
        Self {
            mpe: false,
            channel_of: [None; 128],
            channel_timbre: [0.5; 16],
            brightness: [0.5; 128],
            modulation: [(1.0, 1.0); 128],
            sent: [(1.0, 1.0); 128],
        }
    }
}

impl HammerRouter {
    /// MPE on (member channels' CC74 is their notes' timbre) or off.
    pub fn set_mpe(&mut self, on: bool) {
        self.mpe = on;
    }

    /// The key's hammer as it stands, if the synth has not been told.
    fn changed(&mut self, key: u8) -> Option<Event> {
        let k = key as usize & 127;
        let brightness = self.brightness[k].clamp(0.0, 1.0);
        let (hardness, position) = self.modulation[k];
        let now = (HAMMER_SPAN.powf(2.0 * brightness - 1.0) * hardness, position);
        (now != std::mem::replace(&mut self.sent[k], now)).then_some(Event::KeyHammer {
            key,
            hardness: now.0,
            position: now.1,
        })
    }

    /// A key went down on `channel`: the hammer it strikes with, if it differs
    /// from what the synth has.
    pub fn note_on(&mut self, key: u8, channel: u8) -> Option<Event> {
        let (k, channel) = (key as usize & 127, channel & 15);
        self.channel_of[k] = Some(channel);
        self.brightness[k] = if self.mpe && channel != 0 { self.channel_timbre[channel as usize] } else { 0.5 };
        self.modulation[k] = (1.0, 1.0);
        self.changed(key)
    }

    /// A key came up (its hammer stays until its next note).
    pub fn note_off(&mut self, key: u8) {
        self.channel_of[key as usize & 127] = None;
    }

    /// A note's brightness expression, 0..=1.
    pub fn brightness(&mut self, key: u8, brightness: f32) -> Option<Event> {
        if !brightness.is_finite() {
            return None;
        }
        self.brightness[key as usize & 127] = brightness;
        self.changed(key)
    }

    /// The hammer parameters' polyphonic modulation of `key`: hardness and
    /// strike position factors over the parameters' own values.
    pub fn modulate(&mut self, key: u8, hardness: f32, position: f32) -> Option<Event> {
        if !(hardness.is_finite() && position.is_finite() && hardness > 0.0 && position > 0.0) {
            return None;
        }
        self.modulation[key as usize & 127] = (hardness, position);
        self.changed(key)
    }

    /// CC74 (0..=1) on `channel`: with MPE, the timbre of the notes held on a
    /// member channel (and of those it plays next), passed to `emit`.
    pub fn timbre(&mut self, channel: u8, value: f32, mut emit: impl FnMut(Event)) {
        let channel = channel & 15;
        if !self.mpe || channel == 0 || !value.is_finite() {
            return;
        }
        // MIDI's 64 of 127 is the middle: as voiced.
        let steps = (value.clamp(0.0, 1.0) * 127.0).round();
        let value = if steps <= 64.0 { steps / 128.0 } else { 0.5 + (steps - 64.0) / 126.0 };
        self.channel_timbre[channel as usize] = value;
        for key in 0..128u8 {
            if self.channel_of[key as usize] == Some(channel) {
                self.brightness[key as usize] = value;
                if let Some(e) = self.changed(key) {
                    emit(e);
                }
            }
        }
    }

    /// Every key up, every channel's timbre at none, every key as voiced
    /// (the synth's reset sets its keys' hammers back too).
    pub fn reset(&mut self) {
        *self = Self { mpe: self.mpe, ..Self::default() };
    }
}

/// MIDI controllers Struck answers.
pub mod cc {
    /// MPE's timbre (its Y axis, "brightness").
    pub const TIMBRE: u8 = 74;
    pub const MOD_WHEEL: u8 = 1;
    pub const SUSTAIN: u8 = 64;
    pub const SOSTENUTO: u8 = 66;
    pub const UNA_CORDA: u8 = 67;
    pub const ALL_SOUND_OFF: u8 = 120;
    pub const RESET_ALL_CONTROLLERS: u8 = 121;
    pub const ALL_NOTES_OFF: u8 = 123;
}

impl Event {
    /// What a MIDI controller change means (value 0..=1): up to four events, for
    /// the plugin and the MIDI-file renderer alike. CC 124..=127 (mode changes)
    /// imply all notes off, as MIDI 1.0 says.
    pub fn from_controller(controller: u8, value: f32) -> [Option<Event>; 5] {
        let one = |e| [Some(e), None, None, None, None];
        match controller {
            cc::MOD_WHEEL => one(Event::ModWheel(value)),
            cc::SUSTAIN => one(Event::Sustain(value)),
            cc::SOSTENUTO => one(Event::Sostenuto(value)),
            cc::UNA_CORDA => one(Event::UnaCorda(value)),
            cc::ALL_SOUND_OFF => one(Event::Reset),
            cc::RESET_ALL_CONTROLLERS => [
                Some(Event::Sustain(0.0)),
                Some(Event::Sostenuto(0.0)),
                Some(Event::UnaCorda(0.0)),
                Some(Event::PitchBend(0.0)),
                Some(Event::ModWheel(0.0)),
            ],
            cc::ALL_NOTES_OFF..=127 => one(Event::AllNotesOff),
            _ => [None; 5],
        }
    }

    /// A 14-bit pitch-wheel value as -1..=1: 0 is -1, 8192 the centre (exactly 0), 16383 is +1.
    pub fn pitch_wheel(raw: u16) -> f32 {
        let offset = f32::from(raw.min(16_383)) - 8192.0;
        if offset < 0.0 { offset / 8192.0 } else { offset / 8191.0 }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn mpe_member_channels_bend_their_own_keys_and_the_master_bends_all() {
        let mut router = BendRouter::default();
        let mut got = Vec::new();
        // Off: every channel's bend is the wheel.
        router.note_on(60, 3);
        router.pitch_bend(3, 0.5, |e| got.push(e));
        assert_eq!(got, [Event::PitchBend(0.5)]);
        router.set_mpe(Some(48.0));
        got.clear();
        assert_eq!(router.note_on(64, 2), None);
        router.pitch_bend(2, 0.25, |e| got.push(e));
        router.pitch_bend(0, -1.0, |e| got.push(e));
        assert_eq!(got, [Event::KeyBend { key: 64, semitones: 12.0 }, Event::PitchBend(-1.0)]);
        // A key pressed on a bent channel starts bent; a bent key pressed on
        // the master channel is set straight.
        assert_eq!(router.note_on(67, 2), Some(Event::KeyBend { key: 67, semitones: 12.0 }));
        router.note_off(64);
        assert_eq!(router.note_on(64, 0), Some(Event::KeyBend { key: 64, semitones: 0.0 }));
        assert_eq!(router.note_on(64, 0), None);
    }

    #[test]
    fn channel_pressure_reaches_the_keys_held_on_its_channel() {
        let mut router = PressureRouter::default();
        assert_eq!(router.note_on(60, 0), None);
        assert_eq!(router.note_on(64, 1), None);
        let mut got = Vec::new();
        router.channel_pressure(1, 0.5, |e| got.push(e));
        assert_eq!(got, [Event::Pressure { key: 64, pressure: 0.5 }]);
        // A key pressed on a channel under pressure starts with it.
        assert_eq!(router.note_on(67, 1), Some(Event::Pressure { key: 67, pressure: 0.5 }));
        router.note_off(64);
        got.clear();
        router.channel_pressure(1, 0.25, |e| got.push(e));
        assert_eq!(got, [Event::Pressure { key: 67, pressure: 0.25 }]);
    }

    #[test]
    fn controllers_and_the_wheel() {
        assert_eq!(Event::from_controller(64, 0.5), [Some(Event::Sustain(0.5)), None, None, None, None]);
        assert_eq!(Event::from_controller(121, 1.0).iter().flatten().count(), 5);
        assert_eq!(Event::from_controller(126, 0.0)[0], Some(Event::AllNotesOff));
        assert_eq!(Event::from_controller(1, 1.0), [Some(Event::ModWheel(1.0)), None, None, None, None]);
        assert_eq!(Event::from_controller(2, 1.0), [None; 5]);
        assert_eq!(Event::pitch_wheel(0), -1.0);
        assert_eq!(Event::pitch_wheel(8192), 0.0);
        assert_eq!(Event::pitch_wheel(16383), 1.0);
    }

    #[test]
    fn a_notes_hammer_follows_brightness_timbre_and_modulation() {
        let mut h = HammerRouter::default();
        // As voiced: nothing to say.
        assert_eq!(h.note_on(60, 0), None);
        assert_eq!(h.brightness(60, 1.0), Some(Event::KeyHammer { key: 60, hardness: 4.0, position: 1.0 }));
        assert_eq!(h.brightness(60, 1.0), None, "no change, no event");
        assert_eq!(h.modulate(60, 0.5, 2.0), Some(Event::KeyHammer { key: 60, hardness: 2.0, position: 2.0 }));
        // The next note on the key starts as voiced.
        assert_eq!(h.note_on(60, 0), Some(Event::KeyHammer { key: 60, hardness: 1.0, position: 1.0 }));
        assert_eq!(h.brightness(60, 0.0), Some(Event::KeyHammer { key: 60, hardness: 0.25, position: 1.0 }));
        // MPE timbre: a member channel's CC74 reaches its notes and the next one on it.
        let mut out = Vec::new();
        h.timbre(3, 1.0, |e| out.push(e));
        assert!(out.is_empty(), "MPE off: CC74 is nothing");
        h.set_mpe(true);
        assert_eq!(h.note_on(64, 3), None);
        h.timbre(3, 1.0, |e| out.push(e));
        assert_eq!(out, [Event::KeyHammer { key: 64, hardness: 4.0, position: 1.0 }]);
        assert_eq!(h.note_on(67, 3), Some(Event::KeyHammer { key: 67, hardness: 4.0, position: 1.0 }));
        out.clear();
        h.timbre(0, 1.0, |e| out.push(e));
        assert!(out.is_empty(), "the master channel's CC74 is not a note's timbre");
        assert_eq!(h.modulate(64, f32::NAN, 1.0), None);
        // The middle of CC74 (64) is as voiced.
        h.timbre(3, 64.0 / 127.0, |e| out.push(e));
        assert_eq!(out.last(), Some(&Event::KeyHammer { key: 67, hardness: 1.0, position: 1.0 }));
    }
}
