//! The panel: presets, then every parameter, grouped as a player thinks of them
//! (Instrument, Touch, Hammer, Strings, Tangent, Tuning, Output, Resonance and
//! action), beside a live
//! view of the physics.
//!
//! The panel owns the reading end of the engine's [`Scope`] (behind a mutex
//! that only the panel and `activate` take; the audio thread writes into the
//! scope's lock-free queues and never sees the lock). It repaints about 30
//! times a second while open.

mod library;
pub mod views;

use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex};
use std::time::Duration;

use egui::{RichText, Ui, Vec2};
use nice_plug::context::gui::GuiContext;
use nice_plug::editor::dpi::LogicalSize;
use nice_plug::prelude::*;
use nice_plug_egui::widgets::ParamSlider;
use nice_plug_egui::{
    EguiEditor, EguiEditorState, EguiNiceSettings, Frame, NiceEguiApp, RepaintNotifier, baseview, create_egui_editor,
};
use struck_engine::design::InstrumentKind;
use struck_engine::synth::Scope;
use struck_engine::design::TouchRange;

use crate::params::{InstrumentChoice, OutputChoice, PerspectiveChoice, StruckParams, TemperamentChoice};
use crate::standalone;
use views::LiveView;

/// The window's size, logical pixels.
pub const WIDTH: f64 = 1000.0;
pub const HEIGHT: f64 = 660.0;
const PARAMS_WIDTH: f32 = 340.0;
/// Time between repaints while the panel is open.
const REPAINT: Duration = Duration::from_millis(33);
const IDLE_REPAINT: Duration = Duration::from_millis(250);

/// The live view's source: the scope reader of the synth now playing, with its rate.
pub struct ScopeFeed {
    pub scope: Scope,
    pub sample_rate_hz: f64,
}

/// Shared between `activate` (which replaces it with each new synth) and the panel.
pub type SharedScope = Arc<Mutex<Option<ScopeFeed>>>;

pub fn default_state() -> Arc<EguiEditorState> {
    EguiEditorState::from_size(LogicalSize::new(WIDTH, HEIGHT), 1.0)
}

/// The editor nice-plug opens in a host window or the standalone's.
pub fn create(
    params: Arc<StruckParams>,
    scope: SharedScope,
    state: Arc<EguiEditorState>,
    building: Arc<AtomicBool>,
) -> Option<EguiEditor<StruckEditor>> {
    create_egui_editor(
        state,
        RepaintNotifier::new(),
        EguiNiceSettings::new().with_tile("Struck"),
        StruckEditor::new(params, scope).telling_builds(building),
    )
}

/// The panel's state (it appears in the plugin's `Editor` type, hence public).
pub struct StruckEditor {
    params: Arc<StruckParams>,
    scope: SharedScope,
    gui: Option<GuiContext>,
    live: LiveView,
    sample_rate_hz: f64,
    library: library::Library,
    /// True while the instrument is being rebuilt for new settings.
    building: Arc<AtomicBool>,
}

impl StruckEditor {
    pub fn new(params: Arc<StruckParams>, scope: SharedScope) -> Self {
        Self {
            params,
            scope,
            gui: None,
            live: LiveView::default(),
            sample_rate_hz: 48_000.0,
            building: Arc::new(AtomicBool::new(false)),
            library: library::Library::new(),
        }
    }

    /// Say in the panel while the instrument is rebuilt (`building` true).
    pub fn telling_builds(self, building: Arc<AtomicBool>) -> Self {
        Self { building, ..self }
    }

    /// Hand the panel the host's context (what `build` receives in a real window).
    pub fn set_gui_context(&mut self, gui: GuiContext) {
        self.gui = Some(gui);
    }

    /// Draw the whole panel into `ui` (and read the scope).
    pub fn draw(&mut self, ui: &mut Ui) {
        if let Ok(mut feed) = self.scope.lock()
            && let Some(feed) = feed.as_mut()
        {
            self.live.update(&mut feed.scope);
            self.sample_rate_hz = feed.sample_rate_hz;
        }
        let params = self.params.clone();
        egui::Panel::left("struck-parameters").exact_size(PARAMS_WIDTH).resizable(false).show(ui, |ui| {
            egui::ScrollArea::vertical().show(ui, |ui| match &self.gui {
                Some(gui) => {
                    let setter = gui.param_setter();
                    self.library.presets(ui, &params, &setter);
                    parameter_groups(ui, &params, &setter);
                    self.library.tuning(ui, &params, &setter);
                    output_group(ui, &params, &setter);
                }
                None => {
                    ui.label("(no host context)");
                }
            });
        });
        egui::CentralPanel::default().show(ui, |ui| self.physics(ui));
    }

    fn physics(&mut self, ui: &mut Ui) {
        ui.horizontal(|ui| {
            ui.heading("The string, as it moves");
            if self.building.load(Ordering::Relaxed) {
                // New settings are heard once the instrument is rebuilt.
                ui.label(RichText::new("rebuilding the instrument for the new settings...").italics());
            }
        });
        let width = ui.available_width();
        let frame = self.live.frame().cloned();
        views::string_view(ui, frame.as_ref(), Vec2::new(width, 170.0));
        ui.add_space(6.0);
        views::contact_view(ui, frame.as_ref(), Vec2::new(width, 150.0));
        ui.add_space(6.0);
        let height = (ui.available_height() - 4.0).max(120.0);
        let fs = self.sample_rate_hz;
        views::spectrum_view(ui, self.live.spectrum_db(), fs, Vec2::new(width, height));
    }
}

/// One titled group of parameters.
pub(crate) fn group(ui: &mut Ui, title: &str, add: impl FnOnce(&mut Ui)) {
    ui.group(|ui| {
        ui.set_width(ui.available_width());
        ui.label(RichText::new(title).strong().size(15.0));
        add(ui);
    });
    ui.add_space(4.0);
}

/// A labelled slider row.
pub(crate) fn slider<P: Param>(ui: &mut Ui, label: &str, param: &P, setter: &ParamSetter) {
    ui.horizontal(|ui| {
        ui.add_sized([118.0, 18.0], egui::Label::new(label));
        ui.add(ParamSlider::for_param(param, setter).with_width(120.0));
    });
}

fn parameter_groups(ui: &mut Ui, params: &StruckParams, setter: &ParamSetter) {
    group(ui, "Instrument", |ui| {
        choice_row(ui, setter, &params.instrument.kind, InstrumentChoice::ALL, |c| c.kind().name());
    });
    group(ui, "Touch", |ui| {
        slider(ui, "Softest", &params.touch.min, setter);
        slider(ui, "Hardest", &params.touch.max, setter);
        slider(ui, "Curve", &params.touch.shape, setter);
        let kind = params.kind();
        let what = match kind.touch_range() {
            TouchRange::Speed { .. } => "exciter speed, m/s",
            TouchRange::PluckHeight { .. } => "pluck height, mm",
        };
        ui.label(RichText::new(format!("velocity to {what}")).small());
        views::touch_curve(ui, &params.controls(), kind, Vec2::new(ui.available_width(), 96.0));
    });
    // Only the groups that act on the instrument chosen.
    match params.kind() {
        InstrumentKind::Clavichord => {}
        InstrumentKind::Harpsichord => group(ui, "Plectrum", |ui| {
            slider(ui, "Pluck position", &params.hammer.position, setter);
        }),
        kind => group(ui, if matches!(kind, InstrumentKind::Piano | InstrumentKind::Fortepiano) { "Hammer" } else { "Mallets" }, |ui| {
            slider(ui, "Mass", &params.hammer.mass, setter);
            slider(ui, "Felt stiffness K", &params.hammer.stiffness, setter);
            slider(ui, "Felt exponent α", &params.hammer.exponent, setter);
            slider(ui, "Strike position", &params.hammer.position, setter);
            slider(ui, "Felt hysteresis", &params.hammer.hysteresis, setter);
        }),
    }
    group(ui, "Strings", |ui| {
        slider(ui, "Damping", &params.strings.damping, setter);
        slider(ui, "Unison detune", &params.strings.detune, setter);
    });
    if params.kind() == InstrumentKind::Clavichord {
        group(ui, "Tangent", |ui| {
            slider(ui, "Depth", &params.tangent.depth, setter);
            slider(ui, "Bebung", &params.tangent.bebung, setter);
            toggle(ui, "Fretted", "keys share strings", &params.tangent.fretted, setter);
            ui.label(RichText::new("aftertouch presses deeper: the pitch follows the finger").small());
        });
    }
}

/// A labelled checkbox for an on/off parameter, `what` saying what on means.
fn toggle(ui: &mut Ui, label: &str, what: &str, param: &BoolParam, setter: &ParamSetter) {
    ui.horizontal(|ui| {
        ui.add_sized([118.0, 18.0], egui::Label::new(label));
        let mut on = param.value();
        if ui.checkbox(&mut on, what).changed() {
            setter.begin_set_parameter(param);
            setter.set_parameter(param, on);
            setter.end_set_parameter(param);
        }
    });
}

fn output_group(ui: &mut Ui, params: &StruckParams, setter: &ParamSetter) {
    group(ui, "Output", |ui| {
        slider(ui, "Polyphony", &params.output.polyphony, setter);
        slider(ui, "Bend range", &params.output.bend_range, setter);
        toggle(ui, "MPE", "channels 2-16 bend their own notes", &params.output.mpe, setter);
        if params.output.mpe.value() {
            slider(ui, "MPE bend range", &params.output.mpe_range, setter);
        }
        slider(ui, "Level", &params.output.level_db, setter);
        choice_row(ui, setter, &params.output.source, [OutputChoice::Microphones, OutputChoice::BridgeForce], |c| {
            match c {
                OutputChoice::Microphones => "Microphones",
                OutputChoice::BridgeForce => "Bridge force",
            }
        });
        choice_row(ui, setter, &params.output.perspective, PerspectiveChoice::ALL, |c| c.perspective().name());
        slider(ui, "Width", &params.output.width, setter);
        slider(ui, "Board size", &params.output.board, setter);
        slider(ui, "Irregularity", &params.output.irregularity, setter);
    });
    group(ui, "Resonance and action", |ui| {
        slider(ui, "Sympathetic", &params.resonance.sympathy, setter);
        slider(ui, "Phantom partials", &params.resonance.phantom, setter);
        slider(ui, "Key noise", &params.action.key_noise, setter);
        slider(ui, "Damper noise", &params.action.damper_noise, setter);
        slider(ui, "Pedal noise", &params.action.pedal_noise, setter);
        ui.label(RichText::new("100 %: as the physics has them").small());
    });
}

/// Set one parameter as a single gesture.
pub(crate) fn set<P: Param>(setter: &ParamSetter, param: &P, value: P::Plain) {
    setter.begin_set_parameter(param);
    setter.set_parameter(param, value);
    setter.end_set_parameter(param);
}

/// The temperament's choices as a row of buttons.
pub(crate) fn temperament_row(ui: &mut Ui, params: &StruckParams, setter: &ParamSetter) {
    choice_row(ui, setter, &params.tuning.temperament, TemperamentChoice::ALL, |c| c.temperament().label());
}

/// A choice parameter as a row of buttons, `name` labelling each choice.
fn choice_row<E: Enum + PartialEq + Copy + 'static>(
    ui: &mut Ui,
    setter: &ParamSetter,
    param: &EnumParam<E>,
    choices: impl IntoIterator<Item = E>,
    name: impl Fn(E) -> &'static str,
) {
    ui.horizontal_wrapped(|ui| {
        let current = param.value();
        for choice in choices {
            if ui.selectable_label(current == choice, name(choice)).clicked() && current != choice {
                set(setter, param, choice);
            }
        }
    });
}

impl NiceEguiApp for StruckEditor {
    fn build(
        &mut self,
        _egui_ctx: egui::Context,
        gui: GuiContext,
        _frame: &mut Frame,
    ) -> Result<(), baseview::HandlerError> {
        standalone::watch_stop_signals();
        self.gui = Some(gui);
        Ok(())
    }

    fn ui(&mut self, ui: &mut Ui, _frame: &mut Frame) {
        if standalone::stop_requested() {
            ui.ctx().send_viewport_cmd(egui::ViewportCommand::Close);
        }
        self.draw(ui);
        // Animate while there is sound; otherwise look a few times a second (software
        // OpenGL on a small machine would spend a quarter of a core repainting nothing).
        ui.ctx().request_repaint_after(if self.live.sounding { REPAINT } else { IDLE_REPAINT });
    }
}

#[cfg(test)]
mod tests {
    use std::sync::atomic::{AtomicUsize, Ordering};

    use nice_plug::context::gui::GuiContextInner;
    use struck_engine::design::InstrumentKind;
    use struck_engine::synth::{Event, Instrument, Synth, TimedEvent, default_settings};

    use super::*;

    /// A host that counts parameter changes.
    #[derive(Default)]
    struct Host {
        changes: AtomicUsize,
    }

    impl GuiContextInner for Host {
        fn plugin_api(&self) -> PluginApi {
            PluginApi::Standalone
        }
        unsafe fn raw_begin_set_parameter(&self, _param: ParamPtr) {}
        unsafe fn raw_set_parameter_normalized(&self, _param: ParamPtr, _normalized: f32) {
            self.changes.fetch_add(1, Ordering::Relaxed);
        }
        unsafe fn raw_end_set_parameter(&self, _param: ParamPtr) {}
        fn get_state(&self) -> PluginState {
            unreachable!("the panel does not save state")
        }
        fn set_state(&self, _state: PluginState) {}
        fn request_restart(&self) {}
    }

    fn frame(ctx: &egui::Context, editor: &mut StruckEditor) -> egui::FullOutput {
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(WIDTH as f32, HEIGHT as f32))),
            ..Default::default()
        };
        ctx.run_ui(input, |ui| editor.draw(ui))
    }

    /// Whether a frame drew `text` anywhere.
    fn drew_text(out: &egui::FullOutput, text: &str) -> bool {
        fn has(shape: &egui::Shape, text: &str) -> bool {
            match shape {
                egui::Shape::Text(t) => t.galley.text().contains(text),
                egui::Shape::Vec(shapes) => shapes.iter().any(|s| has(s, text)),
                _ => false,
            }
        }
        out.shapes.iter().any(|clipped| has(&clipped.shape, text))
    }

    #[test]
    fn the_panel_shows_the_groups_of_the_instrument_chosen() {
        let params = Arc::new(StruckParams::default());
        let mut editor = StruckEditor::new(params.clone(), Arc::new(Mutex::new(None)));
        editor.set_gui_context(GuiContext::new(Arc::new(Host::default())));
        let ctx = egui::Context::default();
        let mut shows = |kind: InstrumentChoice, title: &str| {
            let kind_param = &params.instrument.kind;
            // SAFETY: as a host does, from one thread, on a parameter alive for the call.
            unsafe { kind_param.as_ptr()._internal_set_normalized_value(kind_param.preview_normalized(kind)) };
            let mut out = frame(&ctx, &mut editor);
            out.textures_delta.clear();
            drew_text(&out, title)
        };
        for (kind, present, absent) in [
            (InstrumentChoice::Piano, "Hammer", "Tangent"),
            (InstrumentChoice::Santoor, "Mallets", "Hammer"),
            (InstrumentChoice::Clavichord, "Tangent", "Hammer"),
            (InstrumentChoice::Clavichord, "Bebung", "Mallets"),
            (InstrumentChoice::Harpsichord, "Plectrum", "Tangent"),
        ] {
            assert!(shows(kind, present), "{kind:?} lacks {present}");
            assert!(!shows(kind, absent), "{kind:?} shows {absent}");
        }
    }

    #[test]
    fn the_panel_says_so_while_the_instrument_is_rebuilt() {
        let params = Arc::new(StruckParams::default());
        let building = Arc::new(AtomicBool::new(false));
        let mut editor = StruckEditor::new(params, Arc::new(Mutex::new(None))).telling_builds(building.clone());
        editor.set_gui_context(GuiContext::new(Arc::new(Host::default())));
        let ctx = egui::Context::default();
        let says = "rebuilding the instrument";
        let drawn = |editor: &mut StruckEditor| {
            let mut out = frame(&ctx, editor);
            out.textures_delta.clear();
            drew_text(&out, says)
        };
        assert!(!drawn(&mut editor));
        building.store(true, Ordering::Relaxed);
        assert!(drawn(&mut editor));
    }

    /// The panel builds and draws with no window: every group, the touch curve and
    /// the three live views fed by a synth that has just struck a key.
    #[test]
    fn the_panel_draws_headless_from_a_live_scope() {
        let params = Arc::new(StruckParams::default());
        let shared: SharedScope = Arc::new(Mutex::new(None));
        assert!(create(params.clone(), shared.clone(), default_state(), Arc::new(AtomicBool::new(false))).is_some());

        let fs = 48_000.0;
        let instrument = Instrument::build(&default_settings(InstrumentKind::Santoor, fs)).unwrap();
        let (mut synth, scope) = Synth::new(Box::new(instrument));
        *shared.lock().unwrap() = Some(ScopeFeed { scope, sample_rate_hz: fs });
        let (mut l, mut r) = (vec![0.0f32; 4800], vec![0.0f32; 4800]);
        synth.process(&[TimedEvent::new(0, Event::NoteOn { key: 69, velocity: 0.9 })], &mut l, &mut r);

        let host = Arc::new(Host::default());
        let mut editor = StruckEditor::new(params, shared);
        editor.set_gui_context(GuiContext::new(host.clone()));
        let ctx = egui::Context::default();
        for _ in 0..3 {
            let mut out = frame(&ctx, &mut editor);
            out.textures_delta.clear();
            let shapes = out.shapes.len();
            assert!(shapes > 100, "the panel drew {shapes} shapes");
            let vertices: usize = ctx
                .tessellate(out.shapes, out.pixels_per_point)
                .iter()
                .map(|p| match &p.primitive {
                    egui::epaint::Primitive::Mesh(mesh) => mesh.vertices.len(),
                    _ => 0,
                })
                .sum();
            assert!(vertices > 1000, "the panel tessellated to {vertices} vertices");
        }
        let shown = editor.live.frame().expect("a scope frame arrived");
        assert_eq!(shown.midi_key, 69);
        assert!(shown.contact_len > 0 && shown.contact_n.iter().any(|&f| f > 0.0));
        let spectrum = editor.live.spectrum_db();
        // A4 at 440 Hz stands out within 20 dB of the loudest bin (which may be
        // the box's air mode near 130 Hz, rung by the mallet's knock).
        let bin_hz = fs / views::SPECTRUM_SIZE as f64;
        let loudest = spectrum.iter().copied().fold(f32::MIN, f32::max);
        let a4 = spectrum
            .iter()
            .enumerate()
            .filter(|(i, _)| (*i as f64 * bin_hz - 440.0).abs() < 20.0)
            .map(|(_, &d)| d)
            .fold(f32::MIN, f32::max);
        assert!(loudest > -60.0 && a4 > loudest - 20.0, "A4 at {a4} dB, the loudest bin at {loudest} dB");
        assert_eq!(host.changes.load(Ordering::Relaxed), 0, "drawing changes no parameter");
    }

    #[test]
    fn names_and_lengths_read_well() {
        assert_eq!(views::key_name(69), "A4");
        assert_eq!(views::key_name(60), "C4");
        assert_eq!(views::key_name(21), "A0");
        assert_eq!(views::format_length(1.5e-3), "1.50 mm");
        assert_eq!(views::format_length(2.0e-5), "20.0 µm");
    }
}
