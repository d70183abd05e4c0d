//! The panel: presets, then every parameter, grouped as a player thinks of them
//! (Instrument, Touch, Hammer, Strings, Tangent, Tuning, Output, Resonance and
//! action), beside a live
//! view of the physics.
//!
//! The panel owns the reading end of the engine's [`Scope`] (behind a mutex
//! that only the panel and `activate` take; the audio thread writes into the
//! scope's lock-free queues and never sees the lock). It repaints about 30
//! times a second while open.

mod keys;
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
use struck_engine::design::TouchRange;
use struck_engine::synth::Scope;

use crate::keyboard::KeyboardLink;
use crate::params::{InstrumentChoice, OutputChoice, PerspectiveChoice, StruckParams, TemperamentChoice};
use crate::standalone;
use views::LiveView;

/// The window's size, logical pixels.
pub const WIDTH: f64 = 1000.0;
pub const HEIGHT: f64 = 760.0;
const PARAMS_WIDTH: f32 = 340.0;
/// Time between repaints while the panel is open.
const REPAINT: Duration = Duration::from_millis(33);
const IDLE_REPAINT: Duration = Duration::from_millis(250);
/// The panel's keyboard's height, logical pixels.
const KEYBOARD_HEIGHT: f32 = 72.0;

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
    keyboard: Arc<KeyboardLink>,
) -> Option<EguiEditor<StruckEditor>> {
    create_egui_editor(
        state,
        RepaintNotifier::new(),
        EguiNiceSettings::new().with_tile("Struck"),
        StruckEditor::new(params, scope).telling_builds(building).playing(keyboard),
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
    keys: keys::PanelKeyboard,
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
            keys: keys::PanelKeyboard::new(Arc::new(KeyboardLink::default())),
        }
    }

    /// Play the plugin's keys from the panel's keyboard (and show what `keyboard` sees held).
    pub fn playing(self, keyboard: Arc<KeyboardLink>) -> Self {
        Self { keys: keys::PanelKeyboard::new(keyboard), ..self }
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
                    parameter_groups(ui, &params, &setter, self.keys.link());
                    self.library.tuning(ui, &params, &setter);
                    output_group(ui, &params, &setter);
                }
                None => {
                    ui.label("(no host context)");
                }
            });
        });
        egui::CentralPanel::default().show(ui, |ui| self.physics(ui));
        if standalone::is_standalone() {
            if ui.ctx().egui_wants_keyboard_input() {
                self.keys.let_go_of_typed();
            } else {
                self.keys.type_keys(ui);
            }
        }
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
        let height = (ui.available_height() - KEYBOARD_HEIGHT - 40.0).max(120.0);
        let fs = self.sample_rate_hz;
        views::spectrum_view(ui, self.live.spectrum_db(), fs, Vec2::new(width, height));
        ui.add_space(4.0);
        self.keys.show(ui, self.params.kind(), Vec2::new(width, KEYBOARD_HEIGHT));
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

fn parameter_groups(ui: &mut Ui, params: &StruckParams, setter: &ParamSetter, keyboard: &KeyboardLink) {
    group(ui, "Instrument", |ui| {
        choice_row(ui, setter, &params.instrument.kind, InstrumentChoice::ALL, |c| c.kind().name());
    });
    group(ui, "Touch", |ui| {
        slider(ui, "Softest", &params.touch.min, setter);
        slider(ui, "Hardest", &params.touch.max, setter);
        slider(ui, "Curve", &params.touch.shape, setter);
        slider(ui, "Your softest", &params.touch.velocity_floor, setter);
        slider(ui, "Your loudest", &params.touch.velocity_ceiling, setter);
        velocity_learn(ui, params, setter, keyboard);
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
        kind => group(
            ui,
            if matches!(kind, InstrumentKind::Piano | InstrumentKind::Fortepiano) { "Hammer" } else { "Mallets" },
            |ui| {
                slider(ui, "Mass", &params.hammer.mass, setter);
                slider(ui, "Felt stiffness K", &params.hammer.stiffness, setter);
                slider(ui, "Felt exponent α", &params.hammer.exponent, setter);
                slider(ui, "Strike position", &params.hammer.position, setter);
                slider(ui, "Felt hysteresis", &params.hammer.hysteresis, setter);
                slider(ui, "Unevenness", &params.hammer.unevenness, setter);
            },
        ),
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
            ui.label(RichText::new("full aftertouch presses the tangent deeper and raises the note this far").small());
        });
    }
}

/// The velocity learn: play your softest and loudest notes, and they become
/// the softest and hardest touch.
fn velocity_learn(ui: &mut Ui, params: &StruckParams, setter: &ParamSetter, keyboard: &KeyboardLink) {
    ui.horizontal(|ui| {
        if keyboard.is_learning() {
            let heard = match keyboard.learnt() {
                Some((soft, loud)) => format!("softest {:.0}, loudest {:.0}", soft * 127.0, loud * 127.0),
                None => "nothing yet".to_string(),
            };
            ui.label(RichText::new(format!("play your softest and loudest notes: {heard}")).small());
            if ui.button("Done").clicked() {
                apply_learnt(keyboard.stop_learning(), params, setter);
            }
        } else {
            if ui.button("Learn velocity").on_hover_text("play your softest and loudest notes, then Done").clicked() {
                keyboard.start_learning();
            }
            if ui.button("Reset").clicked() {
                set(setter, &params.touch.velocity_floor, 0);
                set(setter, &params.touch.velocity_ceiling, 127);
            }
        }
    });
}

/// Set the player's velocity range to what a learn heard (a range of at least
/// two steps; nothing heard changes nothing).
fn apply_learnt(learnt: Option<(f32, f32)>, params: &StruckParams, setter: &ParamSetter) {
    let Some((soft, loud)) = learnt else { return };
    let floor = ((soft * 127.0).round() as i32).clamp(0, 125);
    let ceiling = ((loud * 127.0).round() as i32).clamp(floor + 2, 127);
    set(setter, &params.touch.velocity_floor, floor);
    set(setter, &params.touch.velocity_ceiling, ceiling);
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
        toggle(
            ui,
            "Load smoothing",
            "a chord's work over a few blocks (2.7 ms later)",
            &params.output.smoothing,
            setter,
        );
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

    /// A host that counts parameter changes (and makes them, when `applies`).
    #[derive(Default)]
    struct Host {
        changes: AtomicUsize,
        applies: bool,
    }

    impl GuiContextInner for Host {
        fn plugin_api(&self) -> PluginApi {
            PluginApi::Standalone
        }
        unsafe fn raw_begin_set_parameter(&self, _param: ParamPtr) {}
        unsafe fn raw_set_parameter_normalized(&self, param: ParamPtr, normalized: f32) {
            self.changes.fetch_add(1, Ordering::Relaxed);
            if self.applies {
                // SAFETY: the parameter outlives the test's panel, which sets it from this thread.
                unsafe { param._internal_set_normalized_value(normalized) };
            }
        }
        unsafe fn raw_end_set_parameter(&self, _param: ParamPtr) {}
        fn get_state(&self) -> PluginState {
            unreachable!("the panel does not save state")
        }
        fn set_state(&self, _state: PluginState) {}
        fn request_restart(&self) {}
    }

    fn frame(ctx: &egui::Context, editor: &mut StruckEditor) -> egui::FullOutput {
        frame_with(ctx, editor, Vec::new())
    }

    fn frame_with(ctx: &egui::Context, editor: &mut StruckEditor, events: Vec<egui::Event>) -> egui::FullOutput {
        let input = egui::RawInput {
            screen_rect: Some(egui::Rect::from_min_size(egui::Pos2::ZERO, egui::vec2(WIDTH as f32, HEIGHT as f32))),
            events,
            ..Default::default()
        };
        let mut out = ctx.run_ui(input, |ui| editor.draw(ui));
        out.textures_delta.clear();
        out
    }

    fn pointer(at: egui::Pos2, pressed: bool) -> Vec<egui::Event> {
        vec![
            egui::Event::PointerMoved(at),
            egui::Event::PointerButton {
                pos: at,
                button: egui::PointerButton::Primary,
                pressed,
                modifiers: egui::Modifiers::NONE,
            },
        ]
    }

    #[test]
    fn the_panels_keyboard_plays_keys_louder_nearer_the_front_and_shows_what_is_held() {
        let params = Arc::new(StruckParams::default());
        let link = Arc::new(KeyboardLink::default());
        let mut editor = StruckEditor::new(params, Arc::new(Mutex::new(None))).playing(link.clone());
        editor.set_gui_context(GuiContext::new(Arc::new(Host::default())));
        let ctx = egui::Context::default();
        frame(&ctx, &mut editor);
        // The keyboard spans the central panel's width at the bottom of the window:
        // the piano's 52 white keys; C4 is the 24th (A0 B0 C1 ...).
        let drawn = editor.keys.drawn;
        assert!(drawn.width() > 500.0 && drawn.bottom() > HEIGHT as f32 - 30.0, "{drawn:?}");
        let bottom = drawn.bottom() - 2.0;
        let white = drawn.width() / 52.0;
        let c4 = egui::pos2(drawn.left() + 23.5 * white, bottom);
        let mut seen = crate::keyboard::PanelSeen::default();
        let mut taken = || {
            let mut out = Vec::new();
            link.take_panel_events(&mut seen, |e| out.push(e.event));
            out
        };
        frame_with(&ctx, &mut editor, pointer(c4, true));
        frame(&ctx, &mut editor);
        let struck = taken();
        let [struck_engine::synth::Event::NoteOn { key: 60, velocity }] = struck[..] else {
            panic!("a click on C4's front edge played {struck:?}");
        };
        assert!(velocity > 0.9, "near the front edge: {velocity}");
        frame_with(&ctx, &mut editor, pointer(c4, false));
        assert_eq!(taken(), [struck_engine::synth::Event::NoteOff { key: 60, velocity: 0.5 }]);
        // Nearer the back of the key: softer.
        let back = egui::pos2(c4.x, bottom - 0.6 * KEYBOARD_HEIGHT);
        frame_with(&ctx, &mut editor, pointer(back, true));
        let [struck_engine::synth::Event::NoteOn { key: 60, velocity: softer }] = taken()[..] else { panic!() };
        assert!(softer < 0.6 * velocity, "{softer} against {velocity}");
        frame_with(&ctx, &mut editor, pointer(back, false));
        taken();
        // Held keys and pedals light up, whoever holds them.
        let held_colour = |editor: &mut StruckEditor| {
            let out = frame(&ctx, editor);
            out.shapes.iter().any(|c| matches!(&c.shape, egui::Shape::Rect(r) if r.fill == keys::HELD_FOR_TESTS))
        };
        assert!(!held_colour(&mut editor));
        link.watch(&[struck_engine::synth::TimedEvent::new(
            0,
            struck_engine::synth::Event::NoteOn { key: 64, velocity: 0.5 },
        )]);
        assert!(held_colour(&mut editor));
        assert!(link.is_down(64));
    }

    #[test]
    fn the_computers_keys_play_from_the_home_row() {
        let link = Arc::new(KeyboardLink::default());
        let mut keyboard = keys::PanelKeyboard::new(link.clone());
        let ctx = egui::Context::default();
        let typed = |keyboard: &mut keys::PanelKeyboard, events: Vec<(egui::Key, bool)>| {
            let events = events
                .into_iter()
                .map(|(key, pressed)| egui::Event::Key {
                    key,
                    physical_key: None,
                    pressed,
                    repeat: false,
                    modifiers: egui::Modifiers::NONE,
                })
                .collect();
            let mut out = ctx.run_ui(egui::RawInput { events, ..Default::default() }, |ui| keyboard.type_keys(ui));
            out.textures_delta.clear();
        };
        // A is C4, W C#4, K C5; X an octave up; space the sustain.
        typed(&mut keyboard, vec![(egui::Key::A, true), (egui::Key::W, true), (egui::Key::Space, true)]);
        assert!(link.panel_holds(60) && link.panel_holds(61));
        assert_eq!(link.panel_pedal(crate::keyboard::Pedal::Sustain), 1.0);
        typed(
            &mut keyboard,
            vec![(egui::Key::A, false), (egui::Key::X, true), (egui::Key::K, true), (egui::Key::Space, false)],
        );
        assert!(!link.panel_holds(60) && link.panel_holds(61) && link.panel_holds(84));
        assert_eq!(link.panel_pedal(crate::keyboard::Pedal::Sustain), 0.0);
        // Their key-ups will not come (a text field took the keyboard, the
        // window lost it, the panel closed): let go.
        typed(&mut keyboard, vec![(egui::Key::Space, true)]);
        keyboard.let_go_of_typed();
        assert!(!link.panel_holds(61) && !link.panel_holds(84));
        assert_eq!(link.panel_pedal(crate::keyboard::Pedal::Sustain), 0.0);
        typed(&mut keyboard, vec![(egui::Key::S, true)]);
        assert!(link.panel_holds(74), "D5 (the octave up from C4)");
        drop(keyboard);
        assert!(!link.panel_holds(74), "closing the panel lets go");
    }

    #[test]
    fn a_velocity_learn_sets_the_players_range() {
        let params = Arc::new(StruckParams::default());
        let link = KeyboardLink::default();
        let host = Arc::new(Host { applies: true, ..Host::default() });
        link.start_learning();
        let at = |velocity| {
            struck_engine::synth::TimedEvent::new(0, struck_engine::synth::Event::NoteOn { key: 60, velocity })
        };
        link.watch(&[at(30.0 / 127.0), at(105.0 / 127.0), at(70.0 / 127.0)]);
        let gui = GuiContext::new(host);
        apply_learnt(link.stop_learning(), &params, &gui.param_setter());
        assert_eq!((params.touch.velocity_floor.value(), params.touch.velocity_ceiling.value()), (30, 105));
        let c = params.controls();
        assert_eq!(c.played_velocity(105.0 / 127.0), 1.0);
        assert_eq!(c.played_velocity(30.0 / 127.0), 0.0);
        // Nothing heard: nothing changes.
        link.start_learning();
        apply_learnt(link.stop_learning(), &params, &gui.param_setter());
        assert_eq!(params.touch.velocity_ceiling.value(), 105);
        // The touch curve says whose range it is.
        let mut editor = StruckEditor::new(params, Arc::new(Mutex::new(None)));
        editor.set_gui_context(GuiContext::new(Arc::new(Host::default())));
        let out = frame(&egui::Context::default(), &mut editor);
        assert!(drew_text(&out, "yours 30 to 105"));
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
        let link = Arc::new(KeyboardLink::default());
        assert!(
            create(params.clone(), shared.clone(), default_state(), Arc::new(AtomicBool::new(false)), link).is_some()
        );

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
