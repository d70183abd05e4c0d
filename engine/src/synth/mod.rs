//! The real-time instrument: keys, pedals and the audio-thread loop.
//!
//! An [`Instrument`] holds every key's precomputed tables and state; it is built
//! off the audio thread ([`Instrument::build`], or by a [`Workshop`] thread
//! whenever the settings change) and handed to the [`Synth`], which plays it.
//! [`Synth::process`] never allocates, locks or waits.
//!
//! Keys, not notes: a note-on strikes the key's strings in
//! whatever state they are in. Processing is split at events and at every
//! [`CONTROL_BLOCK`] samples of the synth's own clock, where dampers move,
//! bends retune, silent keys stop and the live view is fed. The split points
//! depend only on the events' times, so any host block size gives the same samples.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

mod body_voicing;
pub mod built;
mod event;
pub mod guard;
mod instrument;
mod output;
mod paced;
pub mod scope;
mod settings;
mod sympathy;
#[cfg(test)]
mod tuning_safety;
mod voicings;
mod workshop;

use serde::{Deserialize, Serialize};

pub use event::{BendRouter, Event, HAMMER_SPAN, HammerRouter, PressureRouter, TimedEvent, cc, midi_velocity};
pub use guard::{GuardReport, Silenced};
pub use paced::{Ahead, MAX_PACED_LATENCY, PACED_BUDGET, PACED_LATENCY_S, Paced};
pub use scope::{Scope, ScopeFrame};
pub use workshop::{Delivery, OfflineBuilds, REBUILD_SPACING_S, Workshop};

use crate::body::boards;
use crate::body::load::BoardLoad;
use crate::body::soundboard::{BODY_TOP_HZ, HeardModes, MicPlacement, Soundboard};
use crate::body::{Bridge, Output};
use crate::design::{self, InstrumentKind, KeyDesign, LiveVoicing, Touch, TouchRange, Voicing, key_frequency_hz};
use crate::key::{ActionNoise, Key, SYMPATHY_BLOCKS};
use crate::performance::{LIFT_SPREAD_BLOCKS, OwnNote, PerformanceState};
use crate::string::StringError;
use crate::tuning::TuningSettings;
use body_voicing::{Voiced, Voicer, heard_pa_per_n};
use scope::ScopeWriter;
use sympathy::Sympathy;

use instrument::{BeforeKeys, Fallen, KeyTick, push_ended};
pub use instrument::{Instrument, VOICING_RATE_HZ, VoicingFrom};
use output::{DcBlock, Outlet, OutputSample};
pub use settings::{BuildError, Controls, InstrumentSettings, default_settings};
pub use voicings::{InstrumentVoicing, shipped_text, shipped_voicings, voicing_settings};

pub use crate::CONTROL_BLOCK;
pub use crate::key::MAX_BEBUNG_CENTS;
pub use crate::performance::SOFTEST_MALLET;

/// A key whose output can no longer exceed this (-120 dBFS) stops computing.
pub const SILENCE: f64 = 1e-6;
/// A stolen key fades out over this long, s.
pub const STEAL_FADE_S: f64 = 0.005;
/// Keys of an instrument being replaced by another fade out over this long, s.
pub const SWITCH_FADE_S: f64 = 0.02;
/// Highest mode frequency kept, Hz (lower at low sample rates: 0.45 fs).
pub const MAX_MODE_FREQUENCY_HZ: f64 = 20_000.0;
/// Sample rates an instrument can be built for, Hz (hosts may ask for odd ones; the
/// sound is meant for 22.05 to 192 kHz).
pub const MIN_SAMPLE_RATE_HZ: f64 = 1_000.0;
pub const MAX_SAMPLE_RATE_HZ: f64 = 768_000.0;

/// Chunk length while the live view records a strike.
const SCOPE_CHUNK: usize = 8;

/// The release velocity of a key released by a note-on at velocity 0 (MIDI's
/// default, 64).
const DEFAULT_RELEASE: f64 = 64.0 / 127.0;

/// Events the synth reports back to the host: a key that has fallen silent.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct KeyEnded {
    pub time: u32,
    pub key: u8,
}

/// The player: takes events, writes audio. Built off the audio thread; then
/// [`Synth::process`] is real-time safe.
pub struct Synth {
    current: Box<Instrument>,
    /// An instrument of another kind fading out after a switch.
    outgoing: Option<Box<Instrument>>,
    /// Instruments replaced and waiting to be handed back for dropping elsewhere.
    retired: [Option<Box<Instrument>>; 8],
    controls: Controls,
    /// What the player is doing with it: pedals, wheels, per-note shaping.
    performance: PerformanceState,
    clock: u64,
    outlet: Outlet,
    ended: Vec<KeyEnded>,
    scope: ScopeWriter,
    /// The voicing the player asks for now: what of it the instrument was not
    /// built with, it takes live ([`Self::set_voicing`]); what the keys have
    /// taken of it, when, and whether a new damping waits for its turn.
    voicing: Voicing,
    live: LiveVoicing,
    live_taken_at: u64,
    live_pending: bool,
}

/// A ringing key takes a new damping at most once in this long, s: each time
/// its strings' poles are worked out again (an exp and a sin/cos a mode), and
/// a damping moved by an LFO would have that done in every block.
const LIVE_DAMPING_EVERY_S: f64 = 0.01;

impl Synth {
    /// A synth playing `instrument`, and the reader of its live view. Allocates.
    pub fn new(instrument: Box<Instrument>) -> (Self, Scope) {
        let (scope, reader) = scope::channel();
        let fs = instrument.settings.sample_rate_hz;
        let voicing = instrument.settings.voicing;
        let synth = Self {
            current: instrument,
            outgoing: None,
            retired: Default::default(),
            controls: Controls::default(),
            performance: PerformanceState::default(),
            clock: 0,
            outlet: Outlet::new(fs),
            ended: Vec::with_capacity(1024),
            scope,
            voicing,
            live: LiveVoicing::default(),
            live_taken_at: 0,
            live_pending: false,
        };
        (synth, reader)
    }

    pub fn settings(&self) -> &InstrumentSettings {
        &self.current.settings
    }

    pub fn controls(&self) -> &Controls {
        &self.controls
    }

    /// Set the per-block controls (real-time safe).
    pub fn set_controls(&mut self, controls: Controls) {
        self.controls = controls;
        self.performance.rebend(self.controls.bend_range_semitones);
    }

    /// The voicing the player asks for: what of it the instrument playing
    /// was not built with and can take live ([`LiveVoicing`]: the strings'
    /// losses, the hammer) it takes now; the rest waits for an instrument
    /// built with it ([`InstrumentSettings::builds_like`]). Real-time safe.
    pub fn set_voicing(&mut self, voicing: &Voicing) {
        if *voicing != self.voicing {
            self.voicing = *voicing;
            self.take_live_voicing(false);
        }
    }

    /// Give the keys the voicing asked for over the one they were built with:
    /// the hammer at once, a new damping once [`LIVE_DAMPING_EVERY_S`] has
    /// passed since the last (or `now`).
    fn take_live_voicing(&mut self, now: bool) {
        let mut live = LiveVoicing::between(&self.current.settings.voicing, &self.voicing);
        let every = (LIVE_DAMPING_EVERY_S * self.current.settings.sample_rate_hz) as u64;
        let due = now || self.clock >= self.live_taken_at.saturating_add(every);
        self.live_pending = !due && live.damping != self.live.damping;
        if self.live_pending {
            live.damping = self.live.damping;
        } else if live.damping != self.live.damping {
            self.live_taken_at = self.clock;
        }
        if live != self.live || now {
            self.live = live;
            for key in self.current.keys.iter_mut().flatten() {
                key.set_live_voicing(live);
            }
        }
    }

    /// What the output's guard has done so far ([`guard`]): read it off the
    /// audio thread, or after a render, to say so.
    pub fn guard(&self) -> GuardReport {
        self.outlet.guard.report()
    }

    /// Every string and body at rest at once (their state is lost: the
    /// guard found a sample that is not a number, or no music), the DC
    /// blocks too; the pedals stay where the player has them.
    /// (`time`: the control block's, where the keys that sounded end.)
    fn silence_all(&mut self, time: u32) {
        for instrument in std::iter::once(&mut self.current).chain(self.outgoing.as_mut()) {
            for key in instrument.keys.iter_mut().flatten() {
                if key.is_sounding() && self.ended.len() < self.ended.capacity() {
                    self.ended.push(KeyEnded { time, key: key.midi_key() });
                }
                key.silence();
            }
            instrument.soundboard.silence();
            instrument.sympathy.drop_held();
        }
        self.outlet.dc = [DcBlock::default(); 2];
    }

    /// Keys sounding now (the outgoing instrument's included).
    pub fn active_keys(&self) -> usize {
        self.current.active_keys().count() + self.outgoing.as_ref().map_or(0, |o| o.active_keys().count())
    }

    /// Whether anything still sounds: a key, or a body ringing on after its keys.
    pub fn is_sounding(&self) -> bool {
        let bodies = std::iter::once(&self.current).chain(self.outgoing.as_ref()).any(|i| !i.soundboard.is_resting());
        self.active_keys() > 0 || bodies
    }

    /// Modes the sounding keys are computing now (culled modes left out).
    pub fn running_modes(&self) -> usize {
        let outgoing = self.outgoing.as_ref().map_or(0, |o| o.active_keys().map(Key::running_modes).sum());
        self.current.active_keys().map(Key::running_modes).sum::<usize>() + outgoing
    }

    /// The instrument now playing.
    pub fn instrument(&self) -> &Instrument {
        &self.current
    }

    /// Whether the strings `midi_key` plays on the instrument now playing are sounding.
    pub fn key_sounding(&self, midi_key: u8) -> bool {
        let Some(Some((home, _))) = self.current.route.get(midi_key as usize) else { return false };
        self.current.keys[*home as usize].as_ref().is_some_and(Key::is_sounding)
    }

    /// Keys that fell silent during the last [`Self::process`] call.
    pub fn ended_keys(&self) -> &[KeyEnded] {
        &self.ended
    }

    /// Play `instrument` from now on. Of the same kind, ringing keys carry over
    /// into the new tables; of another kind, the old one fades out. Real-time safe:
    /// the replaced instrument waits in [`Self::take_retired`].
    pub fn install(&mut self, mut instrument: Box<Instrument>) {
        // Ringing keys carry over when every MIDI key still plays the same course
        // (a fretted clavichord made unfretted does not).
        if instrument.settings.kind == self.current.settings.kind && instrument.route == self.current.route {
            for (new, old) in instrument.keys.iter_mut().zip(self.current.keys.iter_mut()) {
                if let (Some(new), Some(old)) = (new, old)
                    && old.is_sounding()
                {
                    new.take_over(old, &self.performance);
                }
            }
            instrument.soundboard.take_over(&self.current.soundboard);
            let old = std::mem::replace(&mut self.current, instrument);
            self.retire(old);
        } else {
            let mut old = std::mem::replace(&mut self.current, instrument);
            let fs = old.settings.sample_rate_hz;
            for key in old.keys.iter_mut().flatten().filter(|k| k.is_sounding()) {
                key.fade_out(SWITCH_FADE_S, fs);
            }
            old.soundboard.fade_out(SWITCH_FADE_S);
            if let Some(previous) = self.outgoing.replace(old) {
                self.retire(previous);
            }
        }
        self.outlet.set_rate(self.current.settings.sample_rate_hz);
        self.take_live_voicing(true);
    }

    fn retire(&mut self, instrument: Box<Instrument>) {
        if let Some(slot) = self.retired.iter_mut().find(|s| s.is_none()) {
            *slot = Some(instrument);
        } else {
            // Never expected (the workshop drains every few milliseconds). Dropping
            // here would free memory on the audio thread: the oldest is leaked instead.
            let oldest = self.retired[0].replace(instrument);
            std::mem::forget(oldest);
        }
    }

    /// A replaced instrument to be dropped off the audio thread.
    pub fn take_retired(&mut self) -> Option<Box<Instrument>> {
        self.retired.iter_mut().find_map(|s| s.take())
    }

    /// Put back one that could not be handed on yet.
    pub fn keep_retired(&mut self, instrument: Box<Instrument>) {
        self.retire(instrument);
    }

    /// Render `left.len()` samples (`right` the same length), applying `events`
    /// (sorted by time) at their sample positions. Real-time safe.
    pub fn process(&mut self, events: &[TimedEvent], left: &mut [f32], right: &mut [f32]) {
        self.process_into(events, left, right);
    }

    /// [`Self::process`] with the samples as the synth makes them, before
    /// they are rounded to f32 (for checks that would see the least change).
    pub fn process_f64(&mut self, events: &[TimedEvent], left: &mut [f64], right: &mut [f64]) {
        self.process_into(events, left, right);
    }

    fn process_into<T: OutputSample>(&mut self, events: &[TimedEvent], left: &mut [T], right: &mut [T]) {
        debug_assert_eq!(left.len(), right.len());
        let n = left.len().min(right.len());
        self.ended.clear();
        let mut pos = 0;
        let mut next_event = 0;
        while pos < n {
            while next_event < events.len() && (events[next_event].time as usize) <= pos {
                self.handle(events[next_event].event);
                next_event += 1;
            }
            if self.live_pending {
                self.take_live_voicing(false);
            }
            let phase = (self.clock % CONTROL_BLOCK as u64) as usize;
            let until_event = events.get(next_event).map_or(n, |e| (e.time as usize).min(n));
            // While a strike is being recorded for the live view, finer chunks let it
            // catch the moment of peak contact (chunking never changes the samples).
            let chunk = if self.scope.recording() { SCOPE_CHUNK } else { CONTROL_BLOCK };
            let len = (n - pos).min(CONTROL_BLOCK - phase).min(chunk).min(until_event - pos);
            if phase == 0 {
                self.control(pos as u32);
            }
            self.render(&mut left[pos..pos + len], &mut right[pos..pos + len]);
            pos += len;
            self.clock += len as u64;
        }
        // Events stamped past the block's end still happen, at its end.
        for e in &events[next_event..] {
            self.handle(e.event);
        }
    }

    fn handle(&mut self, event: Event) {
        match event {
            // A velocity that is not a number is no touch at all (it would make every
            // sample of the key NaN); an infinite one is held to the range, as any other.
            Event::NoteOn { velocity, .. } if velocity.is_nan() => {}
            Event::NoteOn { key, velocity } if velocity <= 0.0 => self.note_off(key, 0.0),
            Event::NoteOn { key, velocity } => self.note_on(key, velocity),
            Event::NoteOff { key, velocity } => self.note_off(key, velocity),
            Event::Sustain(v) if v.is_finite() => self.performance.pedal_to(v as f64),
            Event::Sostenuto(v) => {
                let down = v >= 0.5;
                if down && !self.performance.sostenuto {
                    for k in self.current.keys.iter_mut().flatten() {
                        k.catch_sostenuto();
                    }
                } else if !down {
                    for k in self.current.keys.iter_mut().flatten() {
                        k.drop_sostenuto();
                    }
                }
                self.performance.sostenuto = down;
            }
            Event::UnaCorda(v) if v.is_finite() => self.performance.una_corda = (v as f64).clamp(0.0, 1.0),
            Event::ModWheel(v) if v.is_finite() => self.performance.mod_wheel(v as f64),
            Event::Pressure { key, pressure } if pressure.is_finite() => {
                if let Some((k, _)) = self.current.route(key) {
                    k.set_pressure(pressure as f64);
                }
            }
            Event::KeyVolume { key, gain } if gain.is_finite() => {
                self.performance.own[key as usize & 127].volume = f64::from(gain);
                self.apply_own(key);
            }
            Event::KeyPan { key, pan } if pan.is_finite() => {
                self.performance.own[key as usize & 127].pan = f64::from(pan);
                self.apply_own(key);
            }
            Event::KeyHammer { key, hardness, position } if hardness.is_finite() && position.is_finite() => {
                self.performance.own[key as usize & 127].hammer = (f64::from(hardness), f64::from(position));
                self.apply_own(key);
            }
            Event::KeyBend { key, semitones } if semitones.is_finite() => {
                self.performance.own[key as usize & 127].tune =
                    2f64.powf(f64::from(semitones.clamp(-96.0, 96.0)) / 12.0);
                self.apply_own(key);
            }
            Event::PitchBend(v) if !v.is_nan() => {
                self.performance.pitch_wheel(v as f64, self.controls.bend_range_semitones);
            }
            Event::ModWheel(_)
            | Event::Pressure { .. }
            | Event::KeyBend { .. }
            | Event::KeyVolume { .. }
            | Event::KeyHammer { .. }
            | Event::KeyPan { .. }
            | Event::UnaCorda(_)
            | Event::Sustain(_)
            | Event::PitchBend(_) => {}
            Event::AllNotesOff => {
                let performance = &self.performance;
                for k in self.current.keys.iter_mut().flatten().filter(|k| k.down()) {
                    k.release_all(performance);
                }
            }
            Event::Reset => {
                let fs = self.current.settings.sample_rate_hz;
                let held_up = PerformanceState::held_up();
                for k in self.current.keys.iter_mut().flatten().filter(|k| k.is_sounding()) {
                    // Silenced, not let go: no damper lands.
                    k.release_all(&held_up);
                    k.fade_out(STEAL_FADE_S, fs);
                }
                self.current.soundboard.fade_out(STEAL_FADE_S);
                self.performance = PerformanceState::default();
                // (A key fading out glides back, a silent one is there at once.)
                self.current.keys.iter_mut().flatten().for_each(|k| k.shape(OwnNote::default()));
            }
        }
    }

    fn note_on(&mut self, midi_key: u8, velocity: f64) {
        let Some((key, _)) = self.current.route(midi_key) else { return };
        if !key.is_sounding() {
            self.make_room();
        }
        let touch = self.controls.touch(self.current.touch, velocity);
        // Strings shared with another MIDI key take this key's own tuning,
        // volume, place and hammer.
        if let Some((key, _)) = self.current.route(midi_key) {
            let home = key.midi_key() as usize & 127;
            if self.performance.owner[home] != midi_key {
                self.performance.owner[home] = midi_key;
                self.apply_own(midi_key);
            }
        }
        let (bebung, noise) = (self.controls.bebung_cents, self.controls.noise());
        let Some((key, note)) = self.current.route(midi_key) else { return };
        key.set_bebung(bebung);
        key.set_noise(noise);
        key.press(note, touch, &self.performance);
        let home = key.midi_key();
        self.scope.struck(home);
    }

    /// `midi_key` comes up with release `velocity` (0 or unknown: MIDI's
    /// default, 64, as many keyboards send 0 for a release they do not measure).
    fn note_off(&mut self, midi_key: u8, velocity: f64) {
        let velocity = if velocity > 0.0 && velocity.is_finite() { velocity.min(1.0) } else { DEFAULT_RELEASE };
        let noise = self.controls.noise();
        if let Some((key, note)) = self.current.route(midi_key) {
            key.set_noise(noise);
            key.release(note, velocity, &self.performance);
        }
    }

    /// Hand `midi_key`'s own tuning, volume, place and hammer to its strings,
    /// if they are its now.
    fn apply_own(&mut self, midi_key: u8) {
        let own = self.performance.own[midi_key as usize & 127];
        let Some((key, _)) = self.current.route(midi_key) else { return };
        if self.performance.owner[key.midi_key() as usize & 127] != midi_key {
            return;
        }
        key.shape(own);
    }

    /// Below the polyphony cap, or steal: the quietest released key first, else the quietest.
    fn make_room(&mut self) {
        let playing = self.current.active_keys().filter(|k| !k.is_fading_out()).count();
        if playing < self.controls.polyphony.max(1) {
            return;
        }
        let fs = self.current.settings.sample_rate_hz;
        let victim =
            self.current.keys.iter_mut().flatten().filter(|k| k.is_sounding() && !k.is_fading_out()).min_by(|a, b| {
                (a.down(), a.level()).partial_cmp(&(b.down(), b.level())).unwrap_or(std::cmp::Ordering::Equal)
            });
        if let Some(k) = victim {
            k.fade_out(STEAL_FADE_S, fs);
        }
    }

    fn control(&mut self, time: u32) {
        if self.outlet.guard.take_trip() {
            self.silence_all(time);
        }
        self.control_before_keys();
        let tick = self.key_tick();
        for instrument in std::iter::once(&mut self.current).chain(self.outgoing.as_mut()) {
            let mut ended = Fallen::default();
            tick.control(&mut instrument.keys, &self.performance, &mut ended);
            push_ended(&mut self.ended, time, &ended);
        }
        // The outgoing instrument leaves once its keys are silent and its body has rung out.
        if let Some(old) = self.outgoing.take_if(|o| o.active_keys().next().is_none() && o.soundboard.is_resting()) {
            self.retire(old);
        }
        if let Some(key) = self.scope.key().and_then(|k| self.current.keys[k as usize].as_mut()) {
            // (The live view reads the string: back from its gathering.)
            key.settle();
            self.scope.control(key.midi_key(), key.watched_string());
        }
    }

    /// What every sounding key is told at a control block.
    fn key_tick(&self) -> KeyTick {
        KeyTick {
            block_s: CONTROL_BLOCK as f64 / self.current.settings.sample_rate_hz,
            bebung: self.controls.bebung_cents,
            phantom: self.controls.phantom.clamp(0.0, 4.0),
            noise: self.controls.noise(),
        }
    }

    /// A control block's work before its keys are told: the dampers the
    /// pedal is lifting, the strings' trading through the body.
    fn control_before_keys(&mut self) {
        let before = self.before_keys();
        let current = &mut *self.current;
        before.run(&mut current.keys, &mut current.sympathy, &mut self.performance);
    }

    /// What a control block does before its keys are told, as it stands.
    fn before_keys(&self) -> BeforeKeys {
        BeforeKeys {
            noise: self.controls.noise(),
            sympathy: self.controls.sympathy,
            block: self.clock / CONTROL_BLOCK as u64,
        }
    }

    fn render<T: OutputSample>(&mut self, left: &mut [T], right: &mut [T]) {
        let n = left.len();
        let [mix_l, mix_r] = &mut *self.outlet.mix;
        mix_l[..n].fill(0.0);
        mix_r[..n].fill(0.0);
        let scope_key = self.scope.key();
        let output = self.controls.output;
        for (i, instrument) in std::iter::once(&mut self.current).chain(self.outgoing.as_mut()).enumerate() {
            instrument.start_bridge(n, output);
            let watch = scope_key.filter(|_| i == 0).map(|k| (k, &mut self.scope));
            instrument.sound(n, watch);
            instrument.listen(output, &mut mix_l[..n], &mut mix_r[..n]);
        }
        self.write_out(left, right);
    }

    /// The mix's first `left.len()` samples through the DC block and the
    /// output gain, to `left` and `right` (and the live view).
    fn write_out<T: OutputSample>(&mut self, left: &mut [T], right: &mut [T]) {
        self.outlet.write(self.controls.output_gain, &mut self.scope, left, right);
    }
}
