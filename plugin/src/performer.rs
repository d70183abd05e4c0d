//! The performer: the audio thread's half of the plugin, a translator from the
//! host's note and MIDI events to the engine's [`Event`]s at their sample
//! positions, and back from keys that fall silent to the host's voice notices.

use std::sync::Arc;

use nice_plug::prelude::*;
use struck_engine::design::Voicing;
use struck_engine::synth::{
    BendRouter, Controls, Delivery, Event, HammerRouter, Paced, PressureRouter, Synth, TimedEvent,
};

use crate::keyboard::{KeyboardLink, PanelSeen};
use crate::params::StruckParams;

/// Engine events one `process` call gathers before rendering what it has so far
/// (an incoming event becomes at most [`MAX_EVENTS_PER_HOST_EVENT`] of them).
pub const EVENT_CAPACITY: usize = 4096;
/// Channel pressure becomes one engine event per key held on the channel.
const MAX_EVENTS_PER_HOST_EVENT: usize = 128;

/// Where the performer's events come from and where ended keys go.
pub trait EventPort<S> {
    /// The next host event, in time order.
    fn next_event(&mut self) -> Option<NoteEvent<S>>;
    /// A key fell silent at sample `time` of the block; it was last struck by `voice` on `channel`.
    fn key_ended(&mut self, time: u32, key: u8, voice: VoiceId, channel: u8);
}

/// A note id as hosts give it (CLAP note ids; none for plain MIDI).
pub type VoiceId = Option<i32>;

/// The audio thread's half: host events in, engine events and audio out.
pub struct Performer {
    /// The synth, heard as late as load smoothing asks (not at all until set).
    synth: Paced,
    delivery: Delivery,
    /// Preallocated with [`EVENT_CAPACITY`]; never grows.
    events: Vec<TimedEvent>,
    /// Who struck each key last (note id, channel), to name the voice when it
    /// ends, and who struck it before (whose end may come after the last
    /// strike was sent: later in the same block, or, with load smoothing,
    /// while the synth has not reached it).
    voices: [(VoiceId, u8); 128],
    struck_before: [(VoiceId, u8); 128],
    pressure: PressureRouter,
    bends: BendRouter,
    hammers: HammerRouter,
    /// Per key, its voice's polyphonic modulation of the hammer's hardness and
    /// strike position (normalized offsets), and the parameters they offset.
    poly_offsets: [(f32, f32); 128],
    params: Option<Arc<StruckParams>>,
    /// Keys whose volume or place a CLAP note's expression moved (set back at
    /// their next note-on).
    voiced: [bool; 128],
    placed: [bool; 128],
    /// Per channel, the low 7 bits a high-resolution velocity prefix (CC 88)
    /// gave the next note-on.
    velocity_low: [Option<u8>; 16],
    reset_pending: bool,
    /// The panel's keyboard: keys it plays, and what it shows.
    keyboard: Arc<KeyboardLink>,
    /// What the performer last took of the panel's keys.
    panel_seen: PanelSeen,
}

impl Performer {
    /// Allocates (the event list).
    pub fn new(synth: Synth, delivery: Delivery) -> Self {
        Self {
            synth: Paced::new(synth, 0),
            delivery,
            events: Vec::with_capacity(EVENT_CAPACITY),
            voices: [(None, 0); 128],
            struck_before: [(None, 0); 128],
            pressure: PressureRouter::default(),
            bends: BendRouter::default(),
            hammers: HammerRouter::default(),
            poly_offsets: [(0.0, 0.0); 128],
            params: None,
            voiced: [false; 128],
            placed: [false; 128],
            velocity_low: [None; 16],
            reset_pending: false,
            keyboard: Arc::new(KeyboardLink::default()),
            panel_seen: PanelSeen::default(),
        }
    }

    /// Take the hammer parameters' polyphonic modulation against `params`.
    pub fn with_params(self, params: Arc<StruckParams>) -> Self {
        Self { params: Some(params), ..self }
    }

    /// Play the keys the panel's keyboard strikes, and show it what is held.
    pub fn with_keyboard(self, keyboard: Arc<KeyboardLink>) -> Self {
        Self { keyboard, ..self }
    }

    pub fn synth(&self) -> &Synth {
        self.synth.synth()
    }

    /// How late the host hears the synth, samples.
    pub fn latency(&self) -> usize {
        self.synth.latency()
    }

    /// Be heard `samples` late from the next block on, the synth rendering
    /// ahead within that slack (0: as it plays). What is queued is rendered
    /// first; what is rendered and not yet heard is dropped. Real-time safe.
    pub fn set_latency(&mut self, samples: usize) {
        self.synth.set_latency(samples);
    }

    /// Keep up (`true`: render as far as the events allow in every block, as
    /// offline, so what changes between blocks lands on its sample) or spread
    /// the work within the latency (the default). Real-time safe.
    pub fn keep_up(&mut self, keep_up: bool) {
        self.synth.set_budget(if keep_up { 1.0 } else { struck_engine::synth::PACED_BUDGET });
    }

    /// MPE on, its member channels bending `range` semitones each way, or off
    /// (None). Real-time safe.
    pub fn set_mpe(&mut self, range: Option<f32>) {
        self.bends.set_mpe(range);
        self.hammers.set_mpe(range.is_some());
    }

    /// Offline only (it waits): install the instrument the settings ask for
    /// now, built at once ([`Delivery::catch_up`]). Allocates: no.
    pub fn catch_up(&mut self) -> bool {
        self.delivery.catch_up(self.synth.synth_mut())
    }

    /// The player's voicing: what the synth takes live of it, it takes now
    /// ([`Synth::set_voicing`]). Real-time safe.
    pub fn set_voicing(&mut self, voicing: &Voicing) {
        self.synth.synth_mut().set_voicing(voicing);
    }

    /// Silence everything at the start of the next block. Real-time safe.
    pub fn reset(&mut self) {
        self.reset_pending = true;
    }

    /// Render one block. Installs any instrument the workshop has finished, applies
    /// `controls`, translates the port's events at their sample positions and reports
    /// keys that fell silent. Returns whether anything still sounds (a key, or
    /// the body ringing on after its keys).
    ///
    /// Allocates: no. Locks: no.
    pub fn process<S>(
        &mut self,
        controls: Controls,
        port: &mut impl EventPort<S>,
        left: &mut [f32],
        right: &mut [f32],
    ) -> bool {
        self.delivery.exchange(self.synth.synth_mut());
        self.synth.synth_mut().set_controls(controls);
        let n = left.len().min(right.len());
        self.events.clear();
        if std::mem::take(&mut self.reset_pending) {
            self.events.push(TimedEvent::new(0, Event::Reset));
            self.pressure.reset();
            self.bends.reset();
            self.hammers.reset();
            self.poly_offsets = [(0.0, 0.0); 128];
            self.velocity_low = [None; 16];
        }
        // The panel's keys as a host's notes on channel 1 (with no note id).
        let (keyboard, mut seen) = (self.keyboard.clone(), self.panel_seen);
        keyboard.take_panel_events(&mut seen, |e| self.translate_panel(e));
        self.panel_seen = seen;
        let mut start = 0;
        let mut last = 0;
        while let Some(event) = port.next_event() {
            // Hosts send events in order; a stray one is applied no earlier than the last.
            let time = (event.timing() as usize).min(n).max(last);
            last = time;
            if self.events.len() + MAX_EVENTS_PER_HOST_EVENT > self.events.capacity() {
                self.render(start, time, left, right, port);
                start = time;
            }
            self.translate(event, time as u32);
        }
        self.render(start, n, left, right, port);
        self.synth.is_sounding()
    }

    fn render<S>(&mut self, from: usize, to: usize, left: &mut [f32], right: &mut [f32], port: &mut impl EventPort<S>) {
        for event in &mut self.events {
            event.time -= from as u32;
        }
        self.keyboard.watch(&self.events);
        self.synth.process(&self.events, &mut left[from..to], &mut right[from..to]);
        self.events.clear();
        for (ended, &restruck) in self.synth.ended_keys().iter().zip(self.synth.ended_restruck()) {
            let k = ended.key as usize & 127;
            if restruck {
                // The voice before the key's last strike fell silent.
                let (voice, channel) = std::mem::take(&mut self.struck_before[k]);
                port.key_ended(from as u32 + ended.time, ended.key, voice, channel);
                continue;
            }
            let (voice, channel) = self.voices[k];
            port.key_ended(from as u32 + ended.time, ended.key, voice, channel);
            // Its note id is done with (a host may give it to another note).
            if !self.synth.synth().key_sounding(ended.key) {
                self.voices[k].0 = None;
            }
        }
    }

    /// One host event as engine events (pushed within capacity).
    fn translate<S>(&mut self, event: NoteEvent<S>, time: u32) {
        use nice_plug::midi::Key;
        let mut push = |event: Event| self.events.push(TimedEvent::new(time, event));
        match event {
            NoteEvent::NoteOn { key: Key::Number(key), velocity, voice_id, channel, .. } if key < 128 => {
                let channel = channel.number().unwrap_or(0);
                self.struck_before[key as usize] = self.voices[key as usize];
                self.voices[key as usize] = (voice_id.id(), channel);
                let low = self.velocity_low.get_mut(channel as usize & 15).and_then(Option::take);
                // Its own bend first: the strike sounds at the note's pitch.
                self.bends.note_on(key, channel).into_iter().for_each(&mut push);
                if std::mem::take(&mut self.voiced[key as usize]) {
                    push(Event::KeyVolume { key, gain: 1.0 });
                }
                if std::mem::take(&mut self.placed[key as usize]) {
                    push(Event::KeyPan { key, pan: 0.0 });
                }
                self.poly_offsets[key as usize] = (0.0, 0.0);
                self.hammers.note_on(key, channel).into_iter().for_each(&mut push);
                push(Event::NoteOn { key, velocity: f64::from(high_resolution_velocity(velocity, low)) });
                self.pressure.note_on(key, channel).into_iter().for_each(push);
            }
            NoteEvent::NoteOff { key: Key::Number(key), velocity, .. } if key < 128 => {
                self.pressure.note_off(key);
                self.bends.note_off(key);
                self.hammers.note_off(key);
                push(Event::NoteOff { key, velocity: f64::from(velocity) });
            }
            NoteEvent::NoteOff { key: Key::Wildcard, .. } => push(Event::AllNotesOff),
            NoteEvent::PolyPressure { key: Key::Number(key), pressure, .. } if key < 128 => {
                push(Event::Pressure { key, pressure })
            }
            NoteEvent::MidiChannelPressure { pressure, .. } if is_restored_controller(pressure) => {}
            NoteEvent::MidiChannelPressure { channel, pressure, .. } => {
                self.pressure.channel_pressure(channel, pressure, push)
            }
            // The engine has no per-key choke: the key's damper falls (or it rings on
            // where it has none), as after a note-off.
            NoteEvent::Choke { key: Key::Number(key), .. } if key < 128 => {
                self.pressure.note_off(key);
                push(Event::NoteOff { key, velocity: 0.5 })
            }
            NoteEvent::Choke { key: Key::Wildcard, .. } => {
                self.pressure.reset();
                push(Event::Reset)
            }
            NoteEvent::MidiCC { value, .. } if is_restored_controller(value) => {}
            NoteEvent::MidiCC { cc: HIGH_RESOLUTION_VELOCITY, channel, value, .. } => {
                self.velocity_low[channel as usize & 15] = Some((value.clamp(0.0, 1.0) * 127.0).round() as u8);
            }
            NoteEvent::MidiCC { cc: struck_engine::synth::cc::TIMBRE, channel, value, .. } => {
                self.hammers.timbre(channel, value, push)
            }
            NoteEvent::MidiCC { cc, value, .. } => {
                Event::from_controller(cc, value).into_iter().flatten().for_each(push)
            }
            NoteEvent::MidiPitchBend { channel, value, .. } => self.bends.pitch_bend(channel, pitch_wheel(value), push),
            // A CLAP note's volume expression, a gain.
            NoteEvent::PolyVolume { key: Key::Number(key), gain, .. } if key < 128 => {
                self.voiced[key as usize] = gain != 1.0;
                push(Event::KeyVolume { key, gain })
            }
            // A CLAP note's tuning expression, semitones.
            NoteEvent::PolyTuning { key: Key::Number(key), tuning, .. } if key < 128 => {
                push(self.bends.key_tuning(key, tuning))
            }
            // A CLAP note's pan expression: its place in the stereo image.
            NoteEvent::PolyPan { key: Key::Number(key), pan, .. } if key < 128 => {
                self.placed[key as usize] = pan != 0.0;
                self.push_before_strike(time, Event::KeyPan { key, pan });
            }
            // A CLAP note's brightness expression: its hammer's hardness.
            NoteEvent::PolyBrightness { key: Key::Number(key), brightness, .. } if key < 128 => {
                if let Some(e) = self.hammers.brightness(key, brightness) {
                    self.push_before_strike(time, e);
                }
            }
            NoteEvent::PolyModulation { voice_id, poly_modulation_id, normalized_offset, .. } => {
                let Some(key) = self.voices.iter().position(|(v, _)| *v == Some(voice_id)) else { return };
                let offsets = &mut self.poly_offsets[key];
                match poly_modulation_id {
                    crate::params::POLY_HARDNESS => offsets.0 = normalized_offset,
                    crate::params::POLY_POSITION => offsets.1 = normalized_offset,
                    _ => return,
                }
                let Some(params) = self.params.as_ref() else { return };
                let (hardness, position) = params.hammer_modulation(*offsets);
                if let Some(e) = self.hammers.modulate(key as u8, hardness, position) {
                    self.push_before_strike(time, e);
                }
            }
            _ => {}
        }
    }
}

impl Performer {
    /// One of the panel's events, at the block's start.
    fn translate_panel(&mut self, event: TimedEvent) {
        use nice_plug::midi::{Channel, Key, VoiceID};
        let (voice_id, channel) = (VoiceID::Wildcard, Channel::Number(0));
        match event.event {
            Event::NoteOn { key, velocity } => self.translate(
                NoteEvent::<()>::NoteOn {
                    timing: 0,
                    voice_id,
                    channel,
                    key: Key::Number(key),
                    velocity: velocity as f32,
                },
                event.time,
            ),
            Event::NoteOff { key, velocity } => self.translate(
                NoteEvent::<()>::NoteOff {
                    timing: 0,
                    voice_id,
                    channel,
                    key: Key::Number(key),
                    velocity: velocity as f32,
                },
                event.time,
            ),
            _ => self.events.push(event),
        }
    }

    /// Push `event` (a key's own hammer or place) at `time`, ahead of that
    /// key's strike if it was struck at the same sample: a CLAP host sends a
    /// note's expressions and modulation just after its note-on, and they
    /// shape that note from its strike.
    fn push_before_strike(&mut self, time: u32, event: Event) {
        let (Event::KeyHammer { key, .. } | Event::KeyPan { key, .. }) = event else { return };
        let same_time = self.events.iter().rev().take_while(|e| e.time == time).count();
        let at = self.events[self.events.len() - same_time..]
            .iter()
            .rposition(|e| matches!(e.event, Event::NoteOn { key: k, .. } if k == key))
            .map(|i| self.events.len() - same_time + i)
            .filter(|_| self.events.len() < self.events.capacity());
        match at {
            Some(i) => self.events.insert(i, TimedEvent::new(time, event)),
            None => self.events.push(TimedEvent::new(time, event)),
        }
    }
}

/// MIDI's high-resolution velocity prefix: the low 7 bits of the next
/// note-on's velocity on its channel.
const HIGH_RESOLUTION_VELOCITY: u8 = 88;

/// A note-on's `velocity` (0..=1, a 7-bit value over 127) with the low 7 bits
/// `low` of a high-resolution velocity prefix: the 14-bit value over 16383.
/// Without a prefix, as it came.
pub fn high_resolution_velocity(velocity: f32, low: Option<u8>) -> f32 {
    match low {
        Some(low) => {
            let high = (velocity.clamp(0.0, 1.0) * 127.0).round() as u16;
            f32::from((high << 7) | u16::from(low.min(127))) / 16383.0
        }
        None => velocity,
    }
}

/// Whether a controller's value (a MIDI CC or channel pressure, 0..=1) is one
/// no MIDI controller sends, but a VST3 host restoring a session does: the
/// wrapper reports its hidden MIDI-controller parameters at 0.5 and their
/// default at 0, so a host reopening a session "restores" every controller
/// of every channel to 0.5 (all-notes-off and all-sound-off, the pedals at
/// half, a channel pressure that would press every held tangent). A 7-bit
/// controller is n / 127, never exactly 0.5; the pitch wheel's 0.5 is its
/// centre and passes.
pub fn is_restored_controller(value: f32) -> bool {
    value == 0.5
}

/// nice-plug's pitch bend (the 14-bit value / 16383) as -1..=1 with the
/// centre (8192) exactly at 0.
pub fn pitch_wheel(value: f32) -> f32 {
    Event::pitch_wheel((value.clamp(0.0, 1.0) * 16383.0).round() as u16)
}

#[cfg(test)]
mod tests {
    use std::sync::{Arc, Mutex};
    use std::time::{Duration, Instant};

    use nice_plug::midi::{Channel, Key, VoiceID};
    use struck_engine::design::InstrumentKind;
    use struck_engine::rng::Rng;
    use struck_engine::synth::{Instrument, InstrumentSettings, Workshop};

    use super::*;

    const FS: f64 = 48_000.0;

    /// Events from a preallocated list; ended keys into a preallocated list.
    struct Port {
        events: Vec<NoteEvent<()>>,
        next: usize,
        ended: Vec<(u32, u8, VoiceId, u8)>,
    }

    impl Port {
        fn new() -> Self {
            Self { events: Vec::with_capacity(8192), next: 0, ended: Vec::with_capacity(8192) }
        }

        fn load(&mut self, events: &[NoteEvent<()>]) {
            self.events.clear();
            self.events.extend_from_slice(events);
            self.next = 0;
        }
    }

    impl EventPort<()> for Port {
        fn next_event(&mut self) -> Option<NoteEvent<()>> {
            let event = self.events.get(self.next).copied();
            self.next += 1;
            event
        }

        fn key_ended(&mut self, time: u32, key: u8, voice: VoiceId, channel: u8) {
            if self.ended.len() < self.ended.capacity() {
                self.ended.push((time, key, voice, channel));
            }
        }
    }

    fn settings(kind: InstrumentKind) -> InstrumentSettings {
        struck_engine::synth::default_settings(kind, FS)
    }

    /// A performer with a workshop following `wanted`.
    fn performer(wanted: &Arc<Mutex<InstrumentSettings>>) -> (Performer, Workshop) {
        let first = wanted.lock().unwrap().clone();
        let (synth, _scope) = Synth::new(Box::new(Instrument::build(&first).unwrap()));
        let source = wanted.clone();
        let (workshop, delivery) = Workshop::spawn(first, move || Some(source.lock().unwrap().clone()));
        (Performer::new(synth, delivery), workshop)
    }

    fn note_on(timing: u32, key: u8, velocity: f32, voice: i32, channel: u8) -> NoteEvent<()> {
        NoteEvent::NoteOn {
            timing,
            voice_id: VoiceID::ID(voice),
            channel: Channel::Number(channel),
            key: Key::Number(key),
            velocity,
        }
    }

    fn note_off(timing: u32, key: u8) -> NoteEvent<()> {
        NoteEvent::NoteOff {
            timing,
            voice_id: VoiceID::Wildcard,
            channel: Channel::Number(0),
            key: Key::Number(key),
            velocity: 0.0,
        }
    }

    fn cc(timing: u32, cc: u8, value: f32) -> NoteEvent<()> {
        NoteEvent::MidiCC { timing, channel: 0, cc, value }
    }

    fn translated(event: NoteEvent<()>) -> Vec<Event> {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Santoor)));
        let (mut p, _workshop) = performer(&wanted);
        p.translate(event, 7);
        assert!(p.events.iter().all(|e| e.time == 7));
        p.events.iter().map(|e| e.event).collect()
    }

    #[test]
    fn pedals_and_controllers_become_engine_events() {
        assert_eq!(translated(cc(0, 64, 64.0 / 127.0)), [Event::Sustain(64.0 / 127.0)]);
        assert_eq!(translated(cc(0, 66, 1.0)), [Event::Sostenuto(1.0)]);
        assert_eq!(translated(cc(0, 67, 1.0)), [Event::UnaCorda(1.0)]);
        assert_eq!(translated(cc(0, 120, 0.0)), [Event::Reset]);
        assert_eq!(
            translated(cc(0, 121, 0.0)),
            [
                Event::Sustain(0.0),
                Event::Sostenuto(0.0),
                Event::UnaCorda(0.0),
                Event::PitchBend(0.0),
                Event::ModWheel(0.0)
            ]
        );
        assert_eq!(translated(cc(0, 123, 0.0)), [Event::AllNotesOff]);
        assert_eq!(translated(cc(0, 1, 0.3)), [Event::ModWheel(0.3)]);
        assert_eq!(translated(cc(0, 2, 0.3)), []);
        assert_eq!(translated(note_on(0, 60, 0.25, 3, 1)), [Event::NoteOn { key: 60, velocity: 0.25 }]);
        assert_eq!(translated(note_off(0, 60)), [Event::NoteOff { key: 60, velocity: 0.0 }]);
        let wildcard_off = NoteEvent::NoteOff {
            timing: 0,
            voice_id: VoiceID::Wildcard,
            channel: Channel::Wildcard,
            key: Key::Wildcard,
            velocity: 0.0,
        };
        assert_eq!(translated(wildcard_off), [Event::AllNotesOff]);
        let bend = NoteEvent::MidiPitchBend { timing: 0, channel: 0, value: 1.0 };
        assert_eq!(translated(bend), [Event::PitchBend(1.0)]);
    }

    #[test]
    fn pressure_reaches_the_keys_held_on_its_channel() {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Clavichord)));
        let (mut p, _workshop) = performer(&wanted);
        let channel_pressure =
            |channel, pressure| NoteEvent::<()>::MidiChannelPressure { timing: 0, channel, pressure };
        p.translate(note_on(0, 60, 0.5, 1, 0), 0);
        p.translate(note_on(0, 64, 0.5, 2, 3), 0);
        p.translate(channel_pressure(3, 0.25), 0);
        let poly = NoteEvent::<()>::PolyPressure {
            timing: 0,
            voice_id: VoiceID::Wildcard,
            channel: Channel::Number(0),
            key: Key::Number(60),
            pressure: 0.75,
        };
        p.translate(poly, 0);
        p.translate(note_off(0, 64), 0);
        p.translate(channel_pressure(3, 0.0), 0);
        let pressures: Vec<Event> =
            p.events.iter().map(|e| e.event).filter(|e| matches!(e, Event::Pressure { .. })).collect();
        assert_eq!(
            pressures,
            [Event::Pressure { key: 64, pressure: 0.25 }, Event::Pressure { key: 60, pressure: 0.75 }]
        );
    }

    /// What a VST3 host sends when it reopens a session: every hidden
    /// controller parameter of every channel at the 0.5 the wrapper reported.
    fn restore_burst(timing: u32) -> Vec<NoteEvent<()>> {
        (0..16u8)
            .flat_map(|channel| {
                (0..128u8).map(move |cc| NoteEvent::MidiCC { timing, channel, cc, value: 0.5 }).chain([
                    NoteEvent::MidiChannelPressure { timing, channel, pressure: 0.5 },
                    NoteEvent::MidiPitchBend { timing, channel, value: 0.5 },
                ])
            })
            .collect()
    }

    #[test]
    fn a_hosts_restore_burst_changes_no_sample_and_allocates_nothing() {
        // A held clavichord note (pressure would bend it) and a ringing piano
        // (all-sound-off would stop it, the pedals would move), each with and
        // without the 2080 restored controllers in the middle of the note.
        for kind in [InstrumentKind::Clavichord, InstrumentKind::Piano] {
            let render = |burst: bool| {
                let wanted = Arc::new(Mutex::new(settings(kind)));
                let (mut p, _workshop) = performer(&wanted);
                let mut port = Port::new();
                let (mut l, mut r) = (vec![0.0f32; 512], vec![0.0f32; 512]);
                let mut out = Vec::new();
                for b in 0..40 {
                    let mut events = Vec::with_capacity(4096);
                    if b == 0 {
                        events.push(note_on(0, 57, 0.7, 1, 0));
                    }
                    if burst && b == 10 {
                        events.extend(restore_burst(100));
                    }
                    port.load(&events);
                    nice_assert_no_alloc::assert_no_alloc(|| p.process(Controls::default(), &mut port, &mut l, &mut r));
                    out.extend_from_slice(&l);
                }
                out
            };
            let (plain, restored) = (render(false), render(true));
            assert!(plain.iter().any(|s| s.abs() > 1e-4), "{kind:?} sounds");
            assert!(
                plain.iter().zip(&restored).all(|(a, b)| a.to_bits() == b.to_bits()),
                "{kind:?}: the burst changed the sound"
            );
        }
        // A player's controllers still arrive: 64/127 is the sustain pedal half down.
        assert_eq!(translated(cc(0, 64, 64.0 / 127.0)), [Event::Sustain(64.0 / 127.0)]);
        assert_eq!(translated(cc(0, 120, 0.5)), []);
    }

    #[test]
    fn a_high_resolution_velocity_prefix_refines_the_next_note_on_its_channel() {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
        let (mut p, _workshop) = performer(&wanted);
        let prefix =
            |channel, low: u8| NoteEvent::<()>::MidiCC { timing: 0, channel, cc: 88, value: f32::from(low) / 127.0 };
        p.translate(prefix(2, 100), 0);
        p.translate(note_on(0, 60, 64.0 / 127.0, 1, 3), 0);
        p.translate(note_on(0, 62, 64.0 / 127.0, 2, 2), 0);
        p.translate(note_on(0, 64, 64.0 / 127.0, 3, 2), 0);
        let velocities: Vec<f32> = p
            .events
            .iter()
            .filter_map(|e| match e.event {
                Event::NoteOn { velocity, .. } => Some(velocity as f32),
                _ => None,
            })
            .collect();
        // Another channel's note is untouched; the prefixed one is 64 * 128 +
        // 100 over 16383; the prefix is used once.
        assert_eq!(velocities, [64.0 / 127.0, (64.0 * 128.0 + 100.0) / 16383.0, 64.0 / 127.0]);
        assert_eq!(high_resolution_velocity(1.0, Some(127)), 1.0);
        assert_eq!(high_resolution_velocity(0.0, Some(0)), 0.0);
        // In the output: C4 at 64 with the low bits all set is louder than
        // with none, by what the 127 steps between them move the touch.
        let level = |low: u8| {
            let (mut p, _workshop) = performer(&wanted);
            let mut port = Port::new();
            port.load(&[prefix(0, low), note_on(0, 60, 64.0 / 127.0, 1, 0)]);
            let out = run(&mut p, &mut port, 0.4, 256);
            10.0 * (out.iter().map(|v| f64::from(*v).powi(2)).sum::<f64>()).log10()
        };
        let (low, high) = (level(0), level(127));
        eprintln!("C4 at velocity 64, low bits 0: {low:.3} dB, 127: {high:.3} dB");
        assert!(high - low > 0.02 && high - low < 1.0, "{low:.3} against {high:.3} dB");
    }

    /// The strongest frequency of `x` within 3 % of `near_hz`, Hz (a fine
    /// scan of its spectrum under a Hann window).
    fn pitch_near(x: &[f32], near_hz: f64) -> f64 {
        let n = x.len() as f64;
        let power = |f: f64| {
            let (mut re, mut im) = (0.0, 0.0);
            for (i, v) in x.iter().enumerate() {
                let w = 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n).cos();
                let phase = std::f64::consts::TAU * f * i as f64 / FS;
                re += w * f64::from(*v) * phase.cos();
                im += w * f64::from(*v) * phase.sin();
            }
            re * re + im * im
        };
        let steps = 600;
        (0..=steps)
            .map(|i| near_hz * (0.97 + 0.06 * i as f64 / steps as f64))
            .max_by(|a, b| power(*a).total_cmp(&power(*b)))
            .unwrap()
    }

    #[test]
    fn mpe_channels_bend_their_own_notes_and_clap_tunes_one_note() {
        let cents = |a: f64, b: f64| 1200.0 * (a / b).log2();
        // A3 on channel 2 and E4 on channel 3, MPE on (48 semitones each way):
        // channel 2 bends up 2 semitones, then a CLAP tuning expression puts
        // E4 down a semitone.
        let play = |mpe: Option<f32>| {
            let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
            let (mut p, _workshop) = performer(&wanted);
            p.set_mpe(mpe);
            let mut port = Port::new();
            let bend =
                NoteEvent::MidiPitchBend { timing: 0, channel: 1, value: (8192.0 + 8191.0 * 2.0 / 48.0) / 16383.0 };
            port.load(&[note_on(0, 57, 0.7, 1, 1), note_on(0, 64, 0.7, 2, 2), bend]);
            let first = run(&mut p, &mut port, 1.0, 256);
            let tune = NoteEvent::PolyTuning {
                timing: 0,
                voice_id: VoiceID::ID(2),
                channel: Channel::Number(2),
                key: Key::Number(64),
                tuning: -1.0,
            };
            port.load(&[tune]);
            let second = run(&mut p, &mut port, 1.0, 256);
            (first, second)
        };
        let (a3, e4) = (220.0, 329.628);
        let (first, second) = play(Some(48.0));
        let (bent, straight) = (pitch_near(&first[24_000..], a3 * 1.1225), pitch_near(&first[24_000..], e4));
        let tuned = pitch_near(&second[24_000..], e4 / 1.0595);
        eprintln!(
            "MPE: A3 on its channel bent {:.1} cents, E4 beside it {:.1}; E4 tuned {:.1} cents",
            cents(bent, a3),
            cents(straight, e4),
            cents(tuned, e4)
        );
        assert!((cents(bent, a3) - 200.0).abs() < 4.0, "A3 at {bent} Hz");
        assert!(cents(straight, e4).abs() < 4.0, "E4 at {straight} Hz");
        assert!((cents(tuned, e4) + 100.0).abs() < 4.0, "E4 at {tuned} Hz");
        // A volume expression of 0.5 on E4 alone: the second second, E4 is 6 dB
        // down against the same without it, A3 beside it unchanged.
        let level = |with: bool| {
            let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
            let (mut p, _workshop) = performer(&wanted);
            let mut port = Port::new();
            port.load(&[note_on(0, 57, 0.7, 1, 1), note_on(0, 64, 0.7, 2, 2)]);
            run(&mut p, &mut port, 0.5, 256);
            let quieter = NoteEvent::PolyVolume {
                timing: 0,
                voice_id: VoiceID::ID(2),
                channel: Channel::Number(2),
                key: Key::Number(64),
                gain: 0.5,
            };
            let events = [quieter];
            port.load(if with { &events[..] } else { &[] });
            let out = run(&mut p, &mut port, 1.0, 256);
            let band = |f: f64| {
                let (re, im) = out[12_000..].iter().enumerate().fold((0.0, 0.0), |(re, im), (i, v)| {
                    let phase = std::f64::consts::TAU * f * i as f64 / FS;
                    (re + f64::from(*v) * phase.cos(), im + f64::from(*v) * phase.sin())
                });
                10.0 * (re * re + im * im).log10()
            };
            (band(pitch_near(&out[12_000..], a3)), band(pitch_near(&out[12_000..], e4)))
        };
        let ((a_plain, e_plain), (a_quiet, e_quiet)) = (level(false), level(true));
        eprintln!("volume 0.5 on E4: E4 {:+.2} dB, A3 {:+.2} dB", e_quiet - e_plain, a_quiet - a_plain);
        assert!((e_quiet - e_plain + 6.02).abs() < 0.5, "E4 {:+.2} dB", e_quiet - e_plain);
        assert!((a_quiet - a_plain).abs() < 0.5, "A3 {:+.2} dB", a_quiet - a_plain);
        // MPE off: channel 2's bend is the wheel (2 semitones of range): both
        // keys move by 2/48 of 200 cents.
        let (first, _) = play(None);
        let (a, e) = (pitch_near(&first[24_000..], a3), pitch_near(&first[24_000..], e4));
        eprintln!("MPE off: A3 {:.1} cents, E4 {:.1}", cents(a, a3), cents(e, e4));
        assert!((cents(a, a3) - 8.3).abs() < 3.0 && (cents(e, e4) - 8.3).abs() < 3.0, "{a} {e}");
    }

    /// The level (dB) of the strongest bin of `x` within 2 % above `hz`
    /// (a stiff string's partial runs sharp), Hann window.
    fn partial_db(x: &[f32], hz: f64) -> f64 {
        let n = x.len();
        let fft = realfft::RealFftPlanner::<f64>::new().plan_fft_forward(n);
        let mut input: Vec<f64> = x
            .iter()
            .enumerate()
            .map(|(i, v)| (0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n as f64).cos()) * f64::from(*v))
            .collect();
        let mut spectrum = fft.make_output_vec();
        fft.process(&mut input, &mut spectrum).unwrap();
        let bin = FS / n as f64;
        let (lo, hi) = ((hz * 0.995 / bin) as usize, (hz * 1.02 / bin) as usize);
        20.0 * spectrum[lo..=hi].iter().map(|c| c.norm()).fold(1e-30, f64::max).log10()
    }

    #[test]
    fn brightness_timbre_and_poly_modulation_shape_the_notes_own_strike() {
        // C3 on the bridge force (no body in between), struck alone; how loud
        // its 9th-14th partials are against its first, over 0.05-0.55 s.
        let c3 = 130.813;
        let strike = |events: &[NoteEvent<()>], mpe: bool| {
            let mut settings = settings(InstrumentKind::Piano);
            settings = settings.heard_through(struck_engine::body::Output::BridgeForce);
            let wanted = Arc::new(Mutex::new(settings));
            let (p, _workshop) = performer(&wanted);
            let mut p = p.with_params(Arc::new(StruckParams::default()));
            p.set_mpe(mpe.then_some(48.0));
            let mut port = Port::new();
            port.load(events);
            let controls = Controls { output: struck_engine::body::Output::BridgeForce, ..Controls::default() };
            let total = (0.6 * FS) as usize;
            let mut out = Vec::with_capacity(total);
            let (mut l, mut r) = (vec![0.0; 256], vec![0.0; 256]);
            while out.len() < total {
                p.process(controls, &mut port, &mut l, &mut r);
                port.load(&[]);
                out.extend_from_slice(&l);
            }
            let x = &out[(0.05 * FS) as usize..(0.55 * FS) as usize];
            let high = (9..=14).map(|n| partial_db(x, n as f64 * c3)).sum::<f64>() / 6.0;
            (high - partial_db(x, c3), partial_db(x, 4.0 * c3) - partial_db(x, c3))
        };
        let brightness = |b: f32| NoteEvent::PolyBrightness {
            timing: 0,
            voice_id: VoiceID::ID(1),
            channel: Channel::Number(0),
            key: Key::Number(48),
            brightness: b,
        };
        let modulation = |id: u32, offset: f32| NoteEvent::PolyModulation {
            timing: 0,
            voice_id: 1,
            poly_modulation_id: id,
            normalized_offset: offset,
        };
        let (plain, plain_4th) = strike(&[note_on(0, 48, 0.7, 1, 0)], false);
        // The expressions come just after the note-on, at its sample, as CLAP hosts send them.
        let (bright, _) = strike(&[note_on(0, 48, 0.7, 1, 0), brightness(1.0)], false);
        let (dark, _) = strike(&[note_on(0, 48, 0.7, 1, 0), brightness(0.0)], false);
        let (harder, _) = strike(&[note_on(0, 48, 0.7, 1, 0), modulation(crate::params::POLY_HARDNESS, 0.5)], false);
        // C3's hammer, built at 0.13 of the string, modulated to a quarter of it
        // (its 4th partial's node): the offset that takes the strike position
        // parameter from its middle (as built) to 0.25 / 0.13.
        let params = StruckParams::default();
        let built = 0.13;
        let offset = params.hammer.position.preview_normalized((0.25 / built) as f32) - 0.5;
        let factor = params.hammer_modulation((0.0, offset)).1;
        let (_, moved_4th) =
            strike(&[note_on(0, 48, 0.7, 1, 0), modulation(crate::params::POLY_POSITION, offset)], false);
        // MPE: the member channel's CC74 before its note.
        let timbre = NoteEvent::MidiCC { timing: 0, channel: 2, cc: 74, value: 1.0 };
        let (mpe_bright, _) = strike(&[timbre, note_on(0, 48, 0.7, 1, 2)], true);
        let (mpe_off, _) = strike(&[timbre, note_on(0, 48, 0.7, 1, 2)], false);
        eprintln!(
            "C3's partials 9-14 re its 1st: {plain:.1} dB as voiced; brightness 1: {bright:.1}, 0: {dark:.1}; \
             hardness modulated +0.5: {harder:.1}; MPE timbre 1: {mpe_bright:.1} (MPE off: {mpe_off:.1}); \
             strike position modulated x{factor:.2}: 4th partial re the 1st {plain_4th:.1} -> {moved_4th:.1} dB"
        );
        assert!(bright > plain + 3.0 && dark < plain - 3.0, "{dark:.1} {plain:.1} {bright:.1}");
        assert!(harder > plain + 3.0, "{harder:.1} against {plain:.1}");
        assert!(mpe_bright > plain + 3.0 && (mpe_off - plain).abs() < 0.01, "{mpe_bright:.1} {mpe_off:.1}");
        assert!((f64::from(factor) * built - 0.25).abs() < 1e-4, "{factor}");
        assert!(moved_4th < plain_4th - 15.0, "{plain_4th:.1} -> {moved_4th:.1} dB");
        // The expression goes ahead of its note's strike; the next note on the
        // key strikes as voiced again.
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
        let (mut p, _workshop) = performer(&wanted);
        for (event, time) in [(note_on(0, 48, 0.7, 1, 0), 5), (brightness(1.0), 5), (note_on(0, 48, 0.7, 2, 0), 9)] {
            p.translate(event, time);
        }
        let hammer = |hardness| Event::KeyHammer { key: 48, hardness, position: 1.0 };
        // (The host's 32-bit velocity, widened.)
        let strike = Event::NoteOn { key: 48, velocity: f64::from(0.7f32) };
        let events: Vec<(u32, Event)> = p.events.iter().map(|e| (e.time, e.event)).collect();
        assert_eq!(events, [(5, hammer(4.0)), (5, strike), (9, hammer(1.0)), (9, strike)]);
    }

    #[test]
    fn the_pitch_wheel_is_centred_exactly() {
        assert_eq!(pitch_wheel(8192.0 / 16383.0), 0.0);
        assert_eq!(pitch_wheel(0.0), -1.0);
        assert_eq!(pitch_wheel(1.0), 1.0);
        assert_eq!(pitch_wheel(4096.0 / 16383.0), -0.5);
    }

    /// Render `seconds` of audio in blocks of `block`, returning the left channel.
    fn run(p: &mut Performer, port: &mut Port, seconds: f64, block: usize) -> Vec<f32> {
        let total = (seconds * FS) as usize;
        let mut out = Vec::with_capacity(total);
        let (mut l, mut r) = (vec![0.0; block], vec![0.0; block]);
        while out.len() < total {
            p.process(Controls::default(), port, &mut l, &mut r);
            port.load(&[]);
            out.extend_from_slice(&l);
        }
        out
    }

    #[test]
    fn a_released_key_is_reported_ended_with_its_note_id_and_channel() {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
        let (mut p, _workshop) = performer(&wanted);
        let mut port = Port::new();
        port.load(&[note_on(10, 72, 0.8, 42, 3)]);
        let sound = run(&mut p, &mut port, 0.3, 256);
        assert!(sound.iter().any(|s| s.abs() > 1e-3), "the key sounds");
        assert!(port.ended.is_empty(), "nothing ends while the key is held");
        // (The undamped treble strings ring with it: keys sounding unstruck.)
        assert!(p.synth().key_sounding(72) && p.synth().active_keys() >= 1);
        port.load(&[note_off(0, 72)]);
        // The undamped treble it set ringing moves its damped strings through
        // the bridge for some seconds more (ended by 12 s, not yet at 5).
        run(&mut p, &mut port, 12.0, 256);
        assert_eq!(port.ended.len(), 1, "{:?}", port.ended);
        let (_, key, voice, channel) = port.ended[0];
        assert_eq!((key, voice, channel), (72, Some(42), 3));
        assert!(!p.synth().key_sounding(72));
    }

    #[test]
    fn a_voice_that_falls_silent_after_its_key_is_struck_again_is_named_as_itself() {
        // A key let go falls silent; the same key struck again (another note
        // id) just after. The end is the first note's, the second's comes
        // later: played as it comes in one block, and with load smoothing,
        // the synth behind the host (rendering only what it must), where the
        // second strike is sent long before the synth reaches the first
        // note's end.
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
        let play = |smoothed: bool, again: Option<usize>| {
            let (mut p, _workshop) = performer(&wanted);
            if smoothed {
                p.set_latency(128);
                p.synth.set_budget(0.0);
            }
            let mut port = Port::new();
            let (mut l, mut r) = (vec![0.0; 64], vec![0.0; 64]);
            let mut ended = Vec::new();
            for block in 0..(6.0 * FS) as usize / 64 {
                let start = block * 64;
                let mut events = Vec::new();
                if block == 0 {
                    events.push(note_on(10, 72, 0.8, 42, 3));
                }
                if block == 4800 / 64 {
                    events.push(note_off(0, 72));
                }
                if let Some(at) = again.filter(|at| (start..start + 64).contains(at)) {
                    events.push(note_on((at - start) as u32, 72, 0.8, 43, 5));
                }
                port.load(&events);
                p.process(Controls::default(), &mut port, &mut l, &mut r);
                ended.extend(
                    port.ended.drain(..).map(|(t, key, voice, channel)| (start + t as usize, key, voice, channel)),
                );
            }
            ended
        };
        let alone = play(false, None);
        assert_eq!(alone.len(), 1, "{alone:?}");
        let fell = alone[0].0;
        for smoothed in [false, true] {
            let ended = play(smoothed, Some(fell + 10));
            let Some(&(at, key, voice, channel)) = ended.first() else { panic!("smoothed: {smoothed}: no end") };
            assert_eq!((key, voice, channel), (72, Some(42), 3), "smoothed: {smoothed}, {ended:?}");
            // (Heard that much later, reported no later than heard.)
            assert!(
                at >= fell && at <= fell + if smoothed { 128 } else { 0 },
                "smoothed: {smoothed}: at {at}, fell {fell}"
            );
        }
    }

    #[test]
    fn more_events_than_the_list_holds_are_applied_in_pieces() {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Santoor)));
        let (mut p, _workshop) = performer(&wanted);
        let mut port = Port::new();
        // 2000 CC 121s (four engine events each) then a note: the list fills twice over.
        let mut events: Vec<NoteEvent<()>> = (0..2000).map(|i| cc(i / 10, 121, 0.0)).collect();
        events.push(note_on(300, 69, 1.0, 1, 0));
        port.load(&events);
        let (mut l, mut r) = (vec![0.0f32; 512], vec![0.0f32; 512]);
        assert!(p.process(Controls::default(), &mut port, &mut l, &mut r));
        assert!(l[..300].iter().all(|&s| s == 0.0), "silent before the note");
        assert!(l[300..].iter().any(|&s| s != 0.0), "the note starts at its sample");
    }

    /// After a key stops, the output decays into exact silence: hosts (and
    /// clap-validator's fuzzer) must never be handed f32 subnormals.
    #[test]
    fn the_tail_into_silence_has_no_subnormal_samples() {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
        let (mut p, _workshop) = performer(&wanted);
        let mut port = Port::new();
        port.load(&[note_on(0, 72, 0.8, 1, 0), note_off(4800, 72)]);
        let (mut l, mut r) = (vec![0.0f32; 512], vec![0.0f32; 512]);
        let mut sounded = false;
        // The undamped treble strings C5 set ringing die away after it: G6,
        // which its third partial drives, rings on in its unison's slow mode
        // (about -65 dB at 2 s, falling some 4 dB/s) and ends within about
        // 20 s; the board then comes to rest.
        for block in 0..(24.0 * FS) as usize / 512 {
            p.process(Controls::default(), &mut port, &mut l, &mut r);
            port.load(&[]);
            sounded |= l.iter().any(|s| s.abs() > 1e-3);
            for s in l.iter().chain(&r) {
                assert!(!s.is_subnormal(), "subnormal sample {s:e} in block {block}");
            }
        }
        assert!(sounded, "the key sounded");
        assert_eq!(p.synth().active_keys(), 0, "the key ended");
        assert!(l.iter().chain(&r).all(|&s| s == 0.0), "and the output reached exact silence");
    }

    /// A long session of random playing, pedalling, bending and automation, with
    /// instrument and voicing changes built by the workshop, every block rendered
    /// under the allocation checker nice-plug uses (debug builds abort on any
    /// allocation). Also checks the output stays finite and bounded.
    #[test]
    fn a_long_random_session_never_allocates_on_the_audio_path() {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
        let (mut p, _workshop) = performer(&wanted);
        let mut port = Port::new();
        let mut rng = Rng::new(0x5eed_1234_abcd_0001);
        let (mut l, mut r) = (vec![0.0f32; 4096], vec![0.0f32; 4096]);
        let mut events: Vec<NoteEvent<()>> = Vec::with_capacity(4096);
        let mut controls = Controls::default();
        let mut rendered = 0usize;
        let mut switches = 0;
        let mut installed = 0;
        let mut playing = p.synth().settings().clone();
        let session = (40.0 * FS) as usize;
        while rendered < session {
            // Between blocks, as a host's main thread would: automation and rebuilds.
            if rng.below(400) == 0 {
                let mut w = wanted.lock().unwrap();
                w.kind = InstrumentKind::ALL[rng.below(InstrumentKind::ALL.len() as u64) as usize];
                w.voicing.hammer_mass = 0.25 + 3.75 * rng.unit();
                w.voicing.damping = 0.25 + 3.75 * rng.unit();
                w.voicing.unison_detune = 4.0 * rng.unit();
                w.voicing.hammer_unevenness = rng.unit();
                switches += 1;
            }
            if rng.below(20) == 0 {
                controls.touch_min = 0.5 * rng.unit();
                controls.touch_max = 0.5 + 0.5 * rng.unit();
                controls.touch_shape = 0.25 + 3.75 * rng.unit();
                controls.polyphony = 1 + rng.below(128) as usize;
                controls.output_gain = 10f64.powf((rng.unit() * 72.0 - 60.0) / 20.0);
                controls.bend_range_semitones = rng.below(25) as f64;
            }
            let n = [0, 1, 17, 64, 128, 256, 511, 1024, 4096][rng.below(9) as usize];
            events.clear();
            let mut t = 0;
            for _ in 0..rng.below(12) {
                t = (t + rng.below(n as u64 / 4 + 1) as u32).min(n as u32);
                let key = 21 + rng.below(88) as u8;
                events.push(match rng.below(16) {
                    0..=5 => note_on(t, key, rng.unit_f32().max(0.01), rng.below(1000) as i32, rng.below(16) as u8),
                    6..=9 => note_off(t, key),
                    10 => cc(t, 64, rng.unit_f32()),
                    11 => cc(t, [66, 67][rng.below(2) as usize], rng.unit_f32()),
                    12 => NoteEvent::MidiPitchBend { timing: t, channel: 0, value: rng.unit_f32() },
                    13 => cc(t, [120, 121, 123][rng.below(3) as usize], 0.0),
                    14 => NoteEvent::Choke {
                        timing: t,
                        voice_id: VoiceID::Wildcard,
                        channel: Channel::Number(0),
                        key: Key::Number(key),
                    },
                    _ => cc(t, 1, rng.unit_f32()),
                });
            }
            port.load(&events);
            port.ended.clear();
            if rng.below(500) == 0 {
                p.reset();
            }
            let (left, right) = (&mut l[..n], &mut r[..n]);
            nice_assert_no_alloc::assert_no_alloc(|| p.process(controls, &mut port, left, right));
            for s in l[..n].iter().chain(&r[..n]) {
                assert!(s.is_finite() && s.abs() < 64.0, "sample {s} at {rendered}");
            }
            rendered += n;
            if *p.synth().settings() != playing {
                playing = p.synth().settings().clone();
                installed += 1;
            }
        }
        assert!(switches > 3, "the session asked for new instruments ({switches} times)");
        assert!(installed > 1, "new instruments were installed mid-session ({installed} times)");
        // The last switch arrives within a moment.
        let last = wanted.lock().unwrap().clone();
        let deadline = Instant::now() + Duration::from_secs(60);
        while *p.synth().settings() != last {
            assert!(Instant::now() < deadline, "the workshop never delivered {last:?}");
            std::thread::sleep(Duration::from_millis(5));
            port.load(&[]);
            nice_assert_no_alloc::assert_no_alloc(|| p.process(controls, &mut port, &mut l[..64], &mut r[..64]));
        }
    }

    /// Proof that the checker above is live in this build: a child test process that
    /// allocates inside it must die.
    #[test]
    #[cfg(debug_assertions)]
    fn the_allocation_checker_is_live_in_debug_builds() {
        let exe = std::env::current_exe().unwrap();
        // A test's name is its path without the crate's.
        let here = module_path!().split_once("::").map_or("", |(_, path)| path);
        let out = std::process::Command::new(exe)
            .args(["--exact", &format!("{here}::allocating_child"), "--ignored", "--nocapture", "--test-threads=1"])
            .env("STRUCK_ALLOCATING_CHILD", "1")
            .output()
            .unwrap();
        let stdout = String::from_utf8_lossy(&out.stdout);
        // The child must have found the test (a renamed module once made it run none, and pass).
        assert!(stdout.contains("running 1 test"), "the child ran no test: {stdout}");
        assert!(!out.status.success(), "an allocation under the checker did not abort");
    }

    #[test]
    #[ignore = "run by the_allocation_checker_is_live_in_debug_builds"]
    fn allocating_child() {
        if std::env::var_os("STRUCK_ALLOCATING_CHILD").is_some() {
            let v = nice_assert_no_alloc::assert_no_alloc(|| vec![1u8; 64]);
            std::hint::black_box(v);
        }
    }

    #[test]
    fn the_panels_keys_and_pedals_play_and_show_without_allocating() {
        let wanted = Arc::new(Mutex::new(settings(InstrumentKind::Piano)));
        let (p, _workshop) = performer(&wanted);
        let link = Arc::new(KeyboardLink::default());
        let mut p = p.with_keyboard(link.clone());
        let mut port = Port::new();
        let (mut l, mut r) = (vec![0.0f32; 512], vec![0.0f32; 512]);
        let mut block = |p: &mut Performer, port: &mut Port| {
            port.load(&[]);
            nice_assert_no_alloc::assert_no_alloc(|| p.process(Controls::default(), port, &mut l, &mut r));
            l.iter().map(|v| v.abs()).fold(0.0f32, f32::max)
        };
        assert_eq!(block(&mut p, &mut port), 0.0);
        link.press(69, 100);
        link.set_pedal_from_panel(crate::keyboard::Pedal::Sustain, 1.0);
        let loud = (0..20).map(|_| block(&mut p, &mut port)).fold(0.0f32, f32::max);
        assert!(loud > 1e-3 && p.synth().key_sounding(69), "the panel's A4 played at {loud}");
        assert!(link.is_down(69) && link.pedal(crate::keyboard::Pedal::Sustain) == 1.0);
        // Let go with the pedal down: the key is up and still rings.
        link.release(69);
        block(&mut p, &mut port);
        assert!(!link.is_down(69) && p.synth().key_sounding(69));
        // A MIDI note shows as held too.
        port.load(&[note_on(0, 40, 0.5, 1, 0)]);
        p.process(Controls::default(), &mut port, &mut l, &mut r);
        assert!(link.is_down(40));
    }
}
