//! The panel's presets and tuning files: factory and user presets loaded into
//! the parameters and saved from them, and Scala scales loaded from disk.
//!
//! Everything here runs on the GUI thread. A file that cannot be read or is
//! malformed is refused with one line under the buttons, and what was playing
//! stays as it was.

use std::path::{Path, PathBuf};

use egui::{Color32, RichText, Ui};
use nice_plug::prelude::*;
use struck_engine::preset::{Preset, factory_presets, list_user_presets, save_user_preset, user_preset_dir};
use struck_engine::tuning::{KeyboardMapping, ScalaScale};

use super::{group, set, slider, temperament_row};
use crate::params::{InstrumentChoice, StruckParams, TemperamentChoice};

/// What the panel last did, for the line under the buttons.
enum Status {
    None,
    Done(String),
    Refused(String),
}

impl Status {
    fn show(&self, ui: &mut Ui) {
        match self {
            Status::None => {}
            Status::Done(text) => {
                ui.label(RichText::new(text).small());
            }
            Status::Refused(text) => {
                ui.label(RichText::new(text).small().color(Color32::from_rgb(230, 110, 90)));
            }
        }
    }
}

/// One preset the panel offers: a factory preset, or a user preset's file.
struct Entry {
    name: String,
    source: Source,
}

enum Source {
    Factory(Box<Preset>),
    User(PathBuf),
}

pub struct Library {
    entries: Vec<Entry>,
    selected: usize,
    name: String,
    preset_status: Status,
    scl_path: String,
    kbm_path: String,
    tuning_status: Status,
}

impl Library {
    pub fn new() -> Self {
        let mut library = Self {
            entries: Vec::new(),
            selected: 0,
            name: String::new(),
            preset_status: Status::None,
            scl_path: String::new(),
            kbm_path: String::new(),
            tuning_status: Status::None,
        };
        library.refresh();
        library
    }

    /// The factory presets, then the user's (read again from their folder).
    fn refresh(&mut self) {
        self.entries = factory_presets()
            .into_iter()
            .map(|p| Entry { name: p.name.clone(), source: Source::Factory(Box::new(p)) })
            .collect();
        if let Some(dir) = user_preset_dir() {
            match list_user_presets(&dir) {
                Ok(paths) => self.entries.extend(paths.into_iter().map(|path| Entry {
                    name: format!("{} (user)", path.file_stem().unwrap_or_default().to_string_lossy()),
                    source: Source::User(path),
                })),
                Err(e) => self.preset_status = Status::Refused(e.to_string()),
            }
        }
        self.selected = self.selected.min(self.entries.len().saturating_sub(1));
    }

    /// The Presets group: choose and load, or name and save.
    pub fn presets(&mut self, ui: &mut Ui, params: &StruckParams, setter: &ParamSetter) {
        group(ui, "Presets", |ui| {
            let chosen = self.entries.get(self.selected).map_or("(none)", |e| e.name.as_str()).to_string();
            ui.horizontal(|ui| {
                egui::ComboBox::from_id_salt("struck-presets").width(200.0).selected_text(chosen).show_ui(ui, |ui| {
                    for (i, entry) in self.entries.iter().enumerate() {
                        ui.selectable_value(&mut self.selected, i, &entry.name);
                    }
                });
                if ui.button("Load").clicked() {
                    self.preset_status = match self.load_selected() {
                        Ok(preset) => {
                            apply(&preset, params, setter);
                            Status::Done(format!("loaded \"{}\"", preset.name))
                        }
                        Err(e) => Status::Refused(e),
                    };
                }
            });
            ui.horizontal(|ui| {
                ui.add(egui::TextEdit::singleline(&mut self.name).hint_text("name").desired_width(200.0));
                if ui.button("Save").clicked() {
                    self.preset_status = match self.save(params) {
                        Ok(path) => {
                            self.refresh();
                            Status::Done(format!("saved to {}", path.display()))
                        }
                        Err(e) => Status::Refused(e),
                    };
                }
            });
            self.preset_status.show(ui);
        });
    }

    fn load_selected(&self) -> Result<Preset, String> {
        match &self.entries.get(self.selected).ok_or("no preset chosen")?.source {
            Source::Factory(preset) => Ok((**preset).clone()),
            Source::User(path) => Preset::load(path).map_err(|e| e.to_string()),
        }
    }

    fn save(&self, params: &StruckParams) -> Result<PathBuf, String> {
        let dir = user_preset_dir().ok_or("no folder for user presets (neither XDG_CONFIG_HOME nor HOME is set)")?;
        let preset = Preset {
            name: self.name.trim().to_string(),
            instrument: Some(params.kind()),
            voicing: params.voicing(),
            controls: params.controls(),
            tuning: params.tuning(),
            mics: params.mics(),
        };
        save_user_preset(&dir, &preset).map_err(|e| e.to_string())
    }

    /// The Tuning group: A4, temperament, its root, stretch, and a Scala file.
    pub fn tuning(&mut self, ui: &mut Ui, params: &StruckParams, setter: &ParamSetter) {
        group(ui, "Tuning", |ui| {
            slider(ui, "A4", &params.tuning.a4_hz, setter);
            temperament_row(ui, params, setter);
            slider(ui, "Root", &params.tuning.root, setter);
            slider(ui, "Stretch", &params.tuning.stretch, setter);
            ui.horizontal(|ui| {
                ui.add(egui::TextEdit::singleline(&mut self.scl_path).hint_text("scale.scl").desired_width(130.0));
                ui.add(egui::TextEdit::singleline(&mut self.kbm_path).hint_text("mapping.kbm").desired_width(100.0));
                if ui.button("Load").clicked() {
                    self.tuning_status = match load_scale(&self.scl_path, &self.kbm_path) {
                        Ok(scale) => {
                            let what = scale.description.clone();
                            let files = [self.scl_path.trim(), self.kbm_path.trim()]
                                .into_iter()
                                .filter(|p| !p.is_empty())
                                .collect::<Vec<_>>()
                                .join(" + ");
                            if let Ok(mut held) = params.scala.write() {
                                *held = Some(scale);
                            }
                            if let Ok(mut held) = params.scala_files.write() {
                                *held = files;
                            }
                            set(setter, &params.tuning.temperament, TemperamentChoice::Scala);
                            Status::Done(format!("playing {what}"))
                        }
                        Err(e) => Status::Refused(e),
                    };
                }
            });
            if let Ok(files) = params.scala_files.read()
                && !files.is_empty()
                && matches!(self.tuning_status, Status::None)
            {
                ui.label(RichText::new(format!("scale: {files}")).small());
            }
            self.tuning_status.show(ui);
            ui.label(RichText::new(params.tuning().describe()).small());
        });
    }
}

/// A Scala scale from `scl` and, when given, its keyboard mapping from `kbm`.
fn load_scale(scl: &str, kbm: &str) -> Result<ScalaScale, String> {
    if scl.trim().is_empty() {
        return Err("name a .scl file first".to_string());
    }
    let mut scale = ScalaScale::load(Path::new(scl.trim())).map_err(|e| e.to_string())?;
    if !kbm.trim().is_empty() {
        scale.keyboard_mapping = Some(KeyboardMapping::load(Path::new(kbm.trim())).map_err(|e| e.to_string())?);
    }
    Ok(scale)
}

/// Set every parameter from `preset` (values beyond a parameter's range are held at its end).
fn apply(preset: &Preset, params: &StruckParams, setter: &ParamSetter) {
    if let Some(kind) = preset.instrument
        && let Some(choice) = InstrumentChoice::ALL.into_iter().find(|c| c.kind() == kind)
    {
        set(setter, &params.instrument.kind, choice);
    }
    let v = &preset.voicing;
    set(setter, &params.hammer.mass, v.hammer_mass as f32);
    set(setter, &params.hammer.stiffness, v.hammer_stiffness as f32);
    set(setter, &params.hammer.exponent, v.hammer_exponent as f32);
    set(setter, &params.hammer.position, v.strike_position as f32);
    set(setter, &params.strings.damping, v.damping as f32);
    set(setter, &params.strings.detune, v.unison_detune as f32);
    set(setter, &params.output.board, v.board_size as f32);
    set(setter, &params.output.irregularity, v.board_irregularity as f32);
    set(setter, &params.hammer.hysteresis, v.felt_hysteresis as f32);
    set(setter, &params.hammer.unevenness, v.hammer_unevenness as f32);
    set(setter, &params.tangent.depth, v.tangent_depth as f32);
    set(setter, &params.tangent.fretted, v.fretted);
    let c = &preset.controls;
    set(setter, &params.touch.min, c.touch_min as f32);
    set(setter, &params.touch.max, c.touch_max as f32);
    set(setter, &params.touch.shape, c.touch_shape as f32);
    set(setter, &params.output.source, crate::params::OutputChoice::of(c.output));
    set(setter, &params.output.perspective, crate::params::PerspectiveChoice::of(preset.mics.perspective));
    set(setter, &params.output.width, preset.mics.width as f32);
    set(setter, &params.tangent.bebung, c.bebung_cents as f32);
    set(setter, &params.touch.velocity_floor, (c.velocity_floor * 127.0).round() as i32);
    set(setter, &params.touch.velocity_ceiling, (c.velocity_ceiling * 127.0).round() as i32);
    set(setter, &params.resonance.sympathy, c.sympathy as f32);
    set(setter, &params.resonance.phantom, c.phantom as f32);
    set(setter, &params.action.key_noise, c.key_noise as f32);
    set(setter, &params.action.damper_noise, c.damper_noise as f32);
    set(setter, &params.action.pedal_noise, c.pedal_noise as f32);
    set(setter, &params.output.polyphony, c.polyphony.clamp(1, 128) as i32);
    set(setter, &params.output.bend_range, c.bend_range_semitones.round() as i32);
    set(setter, &params.output.level_db, (20.0 * c.output_gain.max(1e-3).log10()) as f32);
    let t = &preset.tuning;
    if let Ok(mut held) = params.scala.write() {
        *held = t.scale.clone();
    }
    if let Ok(mut held) = params.scala_files.write() {
        *held = t.scale.as_ref().map(|s| s.description.clone()).unwrap_or_default();
    }
    set(setter, &params.tuning.a4_hz, t.a4_hz as f32);
    set(setter, &params.tuning.temperament, TemperamentChoice::of(t.temperament));
    set(setter, &params.tuning.root, i32::from(t.root));
    set(setter, &params.tuning.stretch, t.stretch as f32);
}

#[cfg(test)]
mod tests {
    use std::sync::Arc;

    use nice_plug::context::gui::{GuiContext, GuiContextInner};

    use super::*;
    use struck_engine::body::soundboard::Perspective;

    /// A host that sets what the panel asks it to set, as a real one does.
    struct Host;

    impl GuiContextInner for Host {
        fn plugin_api(&self) -> PluginApi {
            PluginApi::Standalone
        }
        unsafe fn raw_begin_set_parameter(&self, _param: ParamPtr) {}
        unsafe fn raw_set_parameter_normalized(&self, param: ParamPtr, normalized: f32) {
            // SAFETY: the pointer comes from the test's own StruckParams, alive for the call.
            unsafe { param._internal_set_normalized_value(normalized) };
        }
        unsafe fn raw_end_set_parameter(&self, _param: ParamPtr) {}
        fn get_state(&self) -> PluginState {
            unreachable!("presets do not go through the host's state")
        }
        fn set_state(&self, _state: PluginState) {}
        fn request_restart(&self) {}
    }

    #[test]
    fn every_factory_preset_loads_into_the_parameters_and_saves_back() {
        let gui = GuiContext::new(Arc::new(Host));
        let setter = gui.param_setter();
        // One beyond the factory's: every newer setting away from as built.
        let mut voiced = factory_presets().remove(0);
        voiced.name = "Piano, every setting moved".into();
        voiced.voicing.felt_hysteresis = 2.5;
        voiced.voicing.hammer_unevenness = 0.6;
        voiced.voicing.board_irregularity = 0.8;
        voiced.controls.sympathy = 0.4;
        voiced.controls.phantom = 3.0;
        voiced.controls.key_noise = 0.0;
        voiced.controls.damper_noise = 2.0;
        voiced.controls.pedal_noise = 0.5;
        for preset in factory_presets().into_iter().chain([voiced]) {
            let params = StruckParams::default();
            apply(&preset, &params, &setter);
            let saved = Preset {
                name: preset.name.clone(),
                instrument: Some(params.kind()),
                voicing: params.voicing(),
                controls: params.controls(),
                tuning: params.tuning(),
                mics: params.mics(),
            };
            let what = &preset.name;
            assert_eq!(Some(saved.instrument.unwrap()), preset.instrument.or(Some(params.kind())), "{what}");
            let close = |a: f64, b: f64| (a - b).abs() <= 1e-3 * b.abs().max(1.0);
            let (v, w) = (&saved.voicing, &preset.voicing);
            assert!(close(v.hammer_mass, w.hammer_mass) && close(v.damping, w.damping), "{what}: {v:?}");
            assert!(close(v.tangent_depth, w.tangent_depth) && v.fretted == w.fretted, "{what}: {v:?}");
            assert!(close(v.felt_hysteresis, w.felt_hysteresis), "{what}: {v:?}");
            assert!(close(v.hammer_unevenness, w.hammer_unevenness), "{what}: {v:?}");
            assert!(close(v.board_irregularity, w.board_irregularity) && close(v.board_size, w.board_size), "{what}");
            let (c, d) = (&saved.controls, &preset.controls);
            assert!(close(c.bebung_cents, d.bebung_cents), "{what}");
            assert!(
                close(c.velocity_floor, d.velocity_floor) && close(c.velocity_ceiling, d.velocity_ceiling),
                "{what}"
            );
            assert!(close(c.sympathy, d.sympathy) && close(c.phantom, d.phantom), "{what}: {c:?}");
            assert!(close(c.key_noise, d.key_noise) && close(c.damper_noise, d.damper_noise), "{what}: {c:?}");
            assert!(close(c.pedal_noise, d.pedal_noise), "{what}: {c:?}");
            // The level parameter moves in steps of 0.1 dB.
            let level_db = 20.0 * (saved.controls.output_gain / preset.controls.output_gain).log10();
            assert!(level_db.abs() <= 0.05, "{what}: {level_db} dB");
            assert!(close(saved.tuning.a4_hz, preset.tuning.a4_hz), "{what}");
            assert_eq!(saved.tuning.temperament, preset.tuning.temperament, "{what}");
            assert_eq!(saved.mics.perspective, preset.mics.perspective, "{what}");
            assert!(Preset::parse(&saved.to_json()).is_ok(), "{what}");
        }
        // The stage piano listens through the coincident pair, which keeps it whole in mono.
        let stage = factory_presets().into_iter().filter(|p| p.mics.perspective == Perspective::Coincident).count();
        assert!(stage >= 1, "no factory preset chooses the coincident pair");
    }

    #[test]
    fn a_malformed_scale_is_refused_in_one_line_and_the_tuning_stays() {
        let dir = std::env::temp_dir().join(format!("struck-panel-scale-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        let bad = dir.join("bad.scl");
        std::fs::write(&bad, "! bad\nnot a scale\n3\n100.0\n3/0\n2/1\n").unwrap();
        let err = load_scale(bad.to_str().unwrap(), "").unwrap_err();
        assert!(err.contains("bad.scl") && !err.contains('\n'), "{err}");
        let good = dir.join("good.scl");
        std::fs::write(&good, "! good\nfive-limit\n2\n5/4\n2/1\n").unwrap();
        assert_eq!(load_scale(good.to_str().unwrap(), "").unwrap().degrees_cents.len(), 2);
        assert!(load_scale("", "").is_err());
        std::fs::remove_dir_all(&dir).unwrap();
    }

    /// The settings whose voicing comes with the program, each with the
    /// name of its file: every instrument as it starts and every factory
    /// preset, as `struck render` builds them and as the plugin does (its
    /// parameters hold single-precision values), each once.
    fn shipped_settings() -> Vec<(String, struck_engine::synth::InstrumentSettings)> {
        use struck_engine::synth::{VOICING_RATE_HZ, default_settings};
        let gui = GuiContext::new(Arc::new(Host));
        let setter = gui.param_setter();
        let fs = VOICING_RATE_HZ;
        let mut wanted = Vec::new();
        for choice in InstrumentChoice::ALL {
            let kind = choice.kind();
            wanted.push((format!("{kind}"), default_settings(kind, fs)));
            let params = StruckParams::default();
            set(&setter, &params.instrument.kind, choice);
            wanted.push((format!("{kind}-plugin"), params.settings(fs)));
        }
        for preset in factory_presets() {
            let name: String = preset
                .name
                .to_lowercase()
                .chars()
                .map(|c| if c.is_ascii_alphanumeric() { c } else { '-' })
                .collect::<String>()
                .split('-')
                .filter(|w| !w.is_empty())
                .collect::<Vec<_>>()
                .join("-");
            wanted.push((name.clone(), preset.settings(fs)));
            let params = StruckParams::default();
            apply(&preset, &params, &setter);
            wanted.push((format!("{name}-plugin"), params.settings(fs)));
        }
        let mut seen = std::collections::HashSet::new();
        wanted.retain(|(_, s)| seen.insert(format!("{s:?}")));
        wanted
    }

    #[test]
    fn the_voicings_that_come_with_the_program_are_those_found_now() {
        use struck_engine::synth::{Instrument, shipped_text, shipped_voicings};
        let wanted = shipped_settings();
        let fresh: Vec<_> = wanted
            .iter()
            .map(|(name, s)| (name, Instrument::build_afresh(s).expect("the factory's settings build").voicing()))
            .collect();
        if std::env::var_os("STRUCK_WRITE_VOICINGS").is_some() {
            // Write them again: `STRUCK_WRITE_VOICINGS=1 cargo test -p struck voicings_that_come`.
            let dir = Path::new(env!("CARGO_MANIFEST_DIR")).join("../engine/voicings");
            for old in std::fs::read_dir(&dir).expect("the voicings' folder").flatten() {
                if old.path().extension().is_some_and(|e| e == "json") {
                    std::fs::remove_file(old.path()).expect("an old voicing removed");
                }
            }
            let mut list = String::from("// Written by the test that checks them (see voicings.rs).\n[\n");
            for (name, voicing) in &fresh {
                let text = shipped_text(voicing).expect("a voicing as JSON");
                std::fs::write(dir.join(format!("{name}.json")), text).expect("a voicing written");
                list.push_str(&format!("    include_str!(\"{name}.json\"),\n"));
            }
            list.push_str("]\n");
            std::fs::write(dir.join("list.rs"), list).expect("the list written");
            return;
        }
        let shipped = shipped_voicings();
        assert_eq!(shipped.len(), fresh.len(), "voicings shipped, and settings to ship them for");
        let close = |a: f64, b: f64| (a - b).abs() <= 1e-9 * a.abs().max(b.abs());
        for (name, voicing) in &fresh {
            let key = format!("{:?}", voicing.settings);
            let found = shipped.iter().find(|v| format!("{:?}", v.settings) == key);
            let found = found.unwrap_or_else(|| panic!("no voicing comes with the program for {name}"));
            assert_eq!(found.keys.len(), voicing.keys.len(), "{name}");
            for (a, b) in found.keys.iter().zip(&voicing.keys) {
                let same = a.midi_key == b.midi_key
                    && a.strokes == b.strokes
                    && close(a.body_gain, b.body_gain)
                    && close(a.gain, b.gain)
                    && close(a.gain_to, b.gain_to)
                    && a.regulation.len() == b.regulation.len()
                    && a.regulation.iter().zip(&b.regulation).all(|(x, y)| close(x.0, y.0) && close(x.1, y.1));
                assert!(same, "{name}, key {}: shipped {a:?}, found now {b:?}", b.midi_key);
            }
        }
    }
}
