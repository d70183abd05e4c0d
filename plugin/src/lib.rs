//! Struck as a CLAP/VST3 plugin and a standalone program: a thin translator
//! over the engine.
//!
//! Host parameters become the engine's plain structs ([`params`]); host note
//! and MIDI events become engine events ([`performer`]); the engine's
//! [`Synth`] renders. Everything that allocates happens in `activate` (the
//! first instrument is built there, synchronously), in the [`Workshop`] thread
//! (rebuilding the instrument when its voicing or kind changes) or in the
//! editor; `process` only reads atomics, moves prebuilt instruments in and out
//! through lock-free queues and renders.

pub mod editor;
pub mod keyboard;
pub mod params;
pub mod performer;
pub mod standalone;
pub mod state;

use std::num::NonZeroU32;
use std::sync::atomic::AtomicBool;
use std::sync::{Arc, Mutex};

use nice_plug::prelude::*;
use nice_plug_egui::{EguiEditor, EguiEditorState};
use struck_engine::synth::{GuardReport, Instrument, OfflineBuilds, Synth, Workshop};

use crate::editor::{ScopeFeed, SharedScope, StruckEditor};
use crate::keyboard::KeyboardLink;
use crate::params::{BuildKey, StruckParams};
use crate::performer::{EventPort, Performer, VoiceId};

/// Keys the synth can sound at once, at most (the polyphony parameter's top).
pub const MAX_VOICES: u32 = 128;

/// The plugin.
pub struct StruckPlugin {
    params: Arc<StruckParams>,
    /// The audio thread's part; built in `activate`.
    performer: Option<Performer>,
    /// Rebuilds instruments off the audio thread; only `activate` touches it.
    workshop: Option<Workshop>,
    /// The live view's reader, for the editor only: the audio thread never takes this lock.
    scope: SharedScope,
    editor_state: Arc<EguiEditorState>,
    sample_rate_hz: f64,
    /// The voice capacity last reported to the host.
    voice_capacity: u32,
    /// Rendering offline: a change of what the instrument is built from is
    /// built at once and heard from its sample ([`Performer::catch_up`]).
    offline: bool,
    /// How fast the host asks for audio: a host rendering faster than real
    /// time is rendering offline, whether or not it says so (Ardour's export
    /// tells each block, which the wrapper does not pass on).
    pace: Pace,
    /// What the instrument playing offline was built from, and when it is
    /// to be built again.
    builds: OfflineBuilds<BuildKey>,
    /// True while the workshop builds an instrument (the panel says so).
    building: Arc<AtomicBool>,
    /// The panel's keyboard and what it shows of the keys and pedals.
    keyboard: Arc<KeyboardLink>,
    /// What the output's guard had done when the log was last told, and the
    /// samples since (it is told at most once a second).
    guard_told: GuardReport,
    since_told: u64,
    /// A CLAP host has been asked to restart the plugin for a new latency
    /// (load smoothing switched while active), and has not yet.
    restart_asked: bool,
}

/// Work the audio thread hands to a background thread.
pub enum Task {
    /// Log what the output's guard has done (at this sample rate).
    Guard(GuardReport, f64),
}

impl Default for StruckPlugin {
    fn default() -> Self {
        Self {
            params: Arc::new(StruckParams::default()),
            performer: None,
            workshop: None,
            scope: Arc::new(Mutex::new(None)),
            editor_state: editor::default_state(),
            sample_rate_hz: 0.0,
            voice_capacity: 0,
            offline: false,
            pace: Pace::default(),
            builds: OfflineBuilds::new(0.0),
            building: Arc::new(AtomicBool::new(false)),
            keyboard: Arc::new(KeyboardLink::default()),
            guard_told: GuardReport::default(),
            since_told: u64::MAX,
            restart_asked: false,
        }
    }
}

impl Plugin for StruckPlugin {
    const NAME: &'static str = "Struck";
    const VENDOR: &'static str = "The Struck developers";
    const URL: &'static str = "https://example.invalid/struck";
    const EMAIL: &'static str = "struck@example.invalid";
    const VERSION: &'static str = env!("CARGO_PKG_VERSION");

    const AUDIO_IO_LAYOUTS: &'static [AudioIOLayout] = &[AudioIOLayout {
        main_input_channels: None,
        main_output_channels: NonZeroU32::new(2),
        ..AudioIOLayout::const_default()
    }];

    const MIDI_INPUT: MidiConfig = MidiConfig::MidiCCs;
    /// A block is cut where a parameter changes, so that offline a rebuilt
    /// instrument is heard from the sample its change comes at.
    const SAMPLE_ACCURATE_AUTOMATION: bool = true;
    /// Room for a host's burst of events in one block without growing (on the
    /// audio thread): a VST3 host reopening a session restores the wrapper's
    /// 16 x 130 hidden MIDI-controller parameters at once (see
    /// [`performer::is_restored_controller`]), 2080 events on top of the notes.
    const INPUT_EVENT_CAPACITY: usize = 4096;

    type Editor = EguiEditor<StruckEditor>;
    type SysExMessage = ();
    type BackgroundTask = Task;

    /// The guard's reports become log lines here, off the audio thread.
    fn task_executor(&mut self) -> TaskExecutor<Self> {
        Box::new(|task| match task {
            Task::Guard(report, sample_rate_hz) => {
                nice_warn!("Struck: {}; lower the velocities or the Level", report.describe(sample_rate_hz))
            }
        })
    }

    fn params(&self) -> Arc<dyn Params> {
        self.params.clone()
    }

    /// Every value of a state the host loads (a session, a preset) is checked
    /// before the wrapper applies it: a bad one becomes its default, with a
    /// line in the log ([`state::repair`]).
    fn filter_state(state: &mut PluginState) {
        for line in state::repair(state) {
            nice_warn!("{line}");
        }
    }

    fn editor(&mut self, _async_executor: AsyncExecutor<Self>) -> Option<Self::Editor> {
        if standalone::is_standalone() && !standalone::display_available() {
            // A standalone with no display plays headless rather than failing to open a window.
            return None;
        }
        editor::create(
            self.params.clone(),
            self.scope.clone(),
            self.editor_state.clone(),
            self.building.clone(),
            self.keyboard.clone(),
        )
    }

    /// Builds the first instrument synchronously and starts the workshop. Allocates.
    fn activate(
        &mut self,
        _audio_io_layout: &AudioIOLayout,
        buffer_config: &BufferConfig,
        context: &mut impl ActivateContext<Self>,
    ) -> bool {
        let sample_rate_hz = buffer_config.sample_rate as f64;
        // Hosts may activate again without deactivating (e.g. after loading state): keep
        // what is built when the rate is the same; the workshop follows the parameters.
        if self.performer.is_none() || self.sample_rate_hz != sample_rate_hz {
            self.workshop = None;
            let settings = self.params.settings(sample_rate_hz);
            let instrument = match Instrument::build(&settings) {
                Ok(instrument) => instrument,
                Err(e) => {
                    nice_error!("Struck cannot build the instrument: {e}");
                    return false;
                }
            };
            let (synth, scope) = Synth::new(Box::new(instrument));
            let params = self.params.clone();
            let (workshop, delivery) =
                Workshop::spawn_telling(settings, move || Some(params.settings(sample_rate_hz)), self.building.clone());
            self.performer = Some(
                Performer::new(synth, delivery).with_keyboard(self.keyboard.clone()).with_params(self.params.clone()),
            );
            self.workshop = Some(workshop);
            *self.scope.lock().unwrap_or_else(|e| e.into_inner()) = Some(ScopeFeed { scope, sample_rate_hz });
            self.sample_rate_hz = sample_rate_hz;
        }
        self.voice_capacity = self.params.controls().polyphony as u32;
        context.set_current_voice_capacity(self.voice_capacity);
        if let Some(performer) = self.performer.as_mut() {
            let latency = self.params.latency(sample_rate_hz);
            if performer.latency() != latency {
                performer.set_latency(latency);
            }
            // The only place a CLAP plugin may tell its host of a new
            // latency: inside activate (nice-plug calls the host's
            // `latency.changed` from here when the value differs).
            context.set_latency_samples(latency as u32);
        }
        self.restart_asked = false;
        self.offline = buffer_config.process_mode == ProcessMode::Offline;
        // (Offline, the first block makes sure what plays is what is asked for.)
        self.builds = OfflineBuilds::new(sample_rate_hz);
        true
    }

    /// Real-time safe: the reset happens at the start of the next block.
    fn reset(&mut self) {
        if let Some(performer) = self.performer.as_mut() {
            performer.reset();
        }
    }

    /// Allocates: no (checked in debug builds with `assert_process_allocs`).
    fn process(
        &mut self,
        buffer: &mut Buffer,
        _aux: &mut AuxiliaryBuffers,
        context: &mut impl ProcessContext<Self>,
    ) -> ProcessStatus {
        // (The standalone, when asked, times every callback; the guard's drop ends it.)
        let _timing = standalone::time_callback(buffer.samples(), self.sample_rate_hz);
        let samples = buffer.samples();
        let channels = buffer.as_slice();
        let Some(performer) = self.performer.as_mut() else {
            for channel in channels.iter_mut() {
                channel.fill(0.0);
            }
            return ProcessStatus::Normal;
        };
        let fast = self.pace.faster_than_real_time(samples, self.sample_rate_hz);
        performer.keep_up(self.offline || fast);
        if self.offline || fast {
            // A host rendering offline does not wait for the clock: what the
            // automation changed is built now and heard from this sample (the
            // block is cut where it changed), and every bounce is the same.
            // What moves on (a ramp, an LFO) is built again once every
            // REBUILD_SPACING_S of audio, at its value then, and the bounce
            // keeps ahead of real time; between builds the synth takes the
            // damping and the hammer live.
            if self.builds.due(self.params.build_key(), samples) {
                performer.catch_up();
            }
        }
        let controls = self.params.controls();
        if controls.polyphony as u32 != self.voice_capacity {
            self.voice_capacity = controls.polyphony as u32;
            context.set_current_voice_capacity(self.voice_capacity);
        }
        let report_ends = context.plugin_api() == PluginApi::Clap;
        let [left, right] = channels else {
            // The only layout is stereo; anything else gets silence.
            for channel in channels.iter_mut() {
                channel.fill(0.0);
            }
            return ProcessStatus::Normal;
        };
        performer.set_mpe(self.params.mpe());
        performer.set_voicing(&self.params.voicing());
        let latency = self.params.latency(self.sample_rate_hz);
        if latency != performer.latency() {
            if context.plugin_api() == PluginApi::Clap {
                // CLAP lets the latency change only inside activate: the
                // plugin asks the host to restart it (a thread-safe call) and
                // keeps the latency it reported, and the delay it is heard
                // with, until then.
                if !self.restart_asked {
                    context.request_restart();
                    self.restart_asked = true;
                }
            } else {
                // VST3 and the standalone take it at once: nice-plug restarts
                // the VST3 component with the latency flag, and the host asks
                // for the new latency.
                performer.set_latency(latency);
                context.set_latency_samples(latency as u32);
            }
        }
        let mut host = HostEvents { context, report_ends };
        let sounding = performer.process(controls, &mut host, left, right);
        // What the output's guard did goes to the log (a task handed over
        // without allocating), once a second at most.
        let guard = performer.synth().guard();
        self.since_told = self.since_told.saturating_add(samples as u64);
        if guard != self.guard_told && self.since_told >= self.sample_rate_hz as u64 {
            host.context.execute_background(Task::Guard(guard, self.sample_rate_hz));
            (self.guard_told, self.since_told) = (guard, 0);
        }
        // A ringing key keeps the host processing (its tail); silence lets it sleep.
        if sounding { ProcessStatus::KeepAlive } else { ProcessStatus::Normal }
    }
}

impl ClapPlugin for StruckPlugin {
    const CLAP_ID: &'static str = "dev.struck.struck";
    const CLAP_DESCRIPTION: Option<&'static str> =
        Some("Hammered, struck, tangented and plucked strings computed from physics");
    const CLAP_MANUAL_URL: Option<&'static str> = None;
    const CLAP_SUPPORT_URL: Option<&'static str> = None;
    const CLAP_FEATURES: &'static [ClapFeature] =
        &[ClapFeature::Instrument, ClapFeature::Synthesizer, ClapFeature::Stereo];
    // Declared for CLAP's voice-info extension: the voice count is the polyphony
    // setting, and a key is one voice (a restrike reuses it).
    const CLAP_POLY_MODULATION_CONFIG: Option<PolyModulationConfig> =
        Some(PolyModulationConfig { max_voice_capacity: MAX_VOICES, supports_overlapping_voices: false });
}

impl Vst3Plugin for StruckPlugin {
    const VST3_CLASS_ID: [u8; 16] = *b"StruckPhysString";
    const VST3_SUBCATEGORIES: &'static [Vst3SubCategory] =
        &[Vst3SubCategory::Instrument, Vst3SubCategory::Synth, Vst3SubCategory::Stereo];
}

/// Whether the host asks for audio faster than real time: over each quarter
/// second of audio, measured against the wall clock. A host playing in real
/// time cannot deliver it much faster than it is heard (a block or two ahead
/// at most); one rendering offline does, many times over. Real-time safe (it
/// reads the clock).
#[derive(Default)]
struct Pace {
    window_start: Option<std::time::Instant>,
    audio_s: f64,
    fast: bool,
}

/// Audio in each window, s, and how many times real time counts as offline.
const PACE_WINDOW_S: f64 = 0.25;
const PACE_OFFLINE: f64 = 2.5;

impl Pace {
    /// Count a block of `samples` at `sample_rate_hz`; whether the last whole
    /// window came faster than real time.
    fn faster_than_real_time(&mut self, samples: usize, sample_rate_hz: f64) -> bool {
        let now = std::time::Instant::now();
        let start = *self.window_start.get_or_insert(now);
        if sample_rate_hz > 0.0 {
            self.audio_s += samples as f64 / sample_rate_hz;
        }
        if self.audio_s >= PACE_WINDOW_S {
            let wall_s = now.duration_since(start).as_secs_f64();
            self.fast = wall_s * PACE_OFFLINE < self.audio_s;
            self.window_start = Some(now);
            self.audio_s = 0.0;
        }
        self.fast
    }
}

nice_export_clap!(StruckPlugin);
nice_export_vst3!(StruckPlugin);

struct HostEvents<'a, C> {
    context: &'a mut C,
    report_ends: bool,
}

impl<C: ProcessContext<StruckPlugin>> EventPort<()> for HostEvents<'_, C> {
    fn next_event(&mut self) -> Option<NoteEvent<()>> {
        self.context.next_event()
    }

    fn key_ended(&mut self, time: u32, key: u8, voice: VoiceId, channel: u8) {
        if self.report_ends {
            let voice_id = voice.map_or(nice_plug::midi::VoiceID::Wildcard, nice_plug::midi::VoiceID::ID);
            let event = NoteEvent::VoiceTerminated {
                timing: time,
                voice_id,
                channel: nice_plug::midi::Channel::Number(channel),
                key: nice_plug::midi::Key::Number(key),
            };
            // A full host queue loses the notice, never the audio.
            let _ = self.context.try_send_event(event);
        }
    }
}
