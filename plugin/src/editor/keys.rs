//! The panel's keyboard: the instrument's keys to click (lower on a key is
//! louder), the keys and pedals held from anywhere lit up, the pedals to
//! click, and in the standalone the computer's keys to play (a row of letters
//! as a piano's white and black keys).

use std::sync::Arc;

use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Stroke, StrokeKind, Ui, Vec2, pos2, vec2};
use struck_engine::design::InstrumentKind;

use crate::keyboard::{KeyboardLink, Pedal};

const WHITE: Color32 = Color32::from_rgb(226, 224, 216);
const WHITE_OUTSIDE: Color32 = Color32::from_rgb(120, 120, 116);
const BLACK: Color32 = Color32::from_rgb(30, 30, 34);
const BLACK_OUTSIDE: Color32 = Color32::from_rgb(70, 70, 74);
const HELD: Color32 = Color32::from_rgb(235, 150, 70);
#[cfg(test)]
pub(super) const HELD_FOR_TESTS: Color32 = HELD;
const HELD_BLACK: Color32 = Color32::from_rgb(190, 105, 40);
const EDGE: Color32 = Color32::from_rgb(60, 60, 66);
const LABEL: Color32 = Color32::from_rgb(90, 90, 96);

/// Black keys' share of a white key's width and of the keyboard's height.
const BLACK_WIDTH: f32 = 0.6;
const BLACK_HEIGHT: f32 = 0.62;
/// The softest velocity a click gives (at the key's back edge); the front edge gives 127.
const SOFTEST_CLICK: f32 = 16.0;

/// The computer's keys as notes over the octave's C: the home row the white
/// keys, the row above the black keys (as on most music programs).
const TYPED: [(egui::Key, u8); 17] = [
    (egui::Key::A, 0),
    (egui::Key::W, 1),
    (egui::Key::S, 2),
    (egui::Key::E, 3),
    (egui::Key::D, 4),
    (egui::Key::F, 5),
    (egui::Key::T, 6),
    (egui::Key::G, 7),
    (egui::Key::Y, 8),
    (egui::Key::H, 9),
    (egui::Key::U, 10),
    (egui::Key::J, 11),
    (egui::Key::K, 12),
    (egui::Key::O, 13),
    (egui::Key::L, 14),
    (egui::Key::P, 15),
    (egui::Key::Semicolon, 16),
];

/// The panel's keyboard and what it holds.
pub struct PanelKeyboard {
    link: Arc<KeyboardLink>,
    /// The key the pointer holds down.
    pointer_key: Option<u8>,
    /// Computer keys held, with the MIDI key each struck.
    typed: Vec<(egui::Key, u8)>,
    /// The C the computer's home row starts at, and the velocity it plays.
    typed_c: u8,
    typed_velocity: u8,
    /// Where the keyboard was last drawn.
    pub(super) drawn: Rect,
    /// The space bar holds the sustain pedal.
    space_held: bool,
}

impl PanelKeyboard {
    pub fn new(link: Arc<KeyboardLink>) -> Self {
        Self {
            link,
            pointer_key: None,
            typed: Vec::with_capacity(TYPED.len()),
            typed_c: 60,
            typed_velocity: 96,
            drawn: Rect::NOTHING,
            space_held: false,
        }
    }

    pub fn link(&self) -> &Arc<KeyboardLink> {
        &self.link
    }

    /// Draw the pedals' row and the keyboard of `kind` into `size`, and play
    /// what the pointer does on it.
    pub fn show(&mut self, ui: &mut Ui, kind: InstrumentKind, size: Vec2) {
        ui.horizontal(|ui| {
            for (pedal, name) in
                [(Pedal::Sustain, "Sustain"), (Pedal::Sostenuto, "Sostenuto"), (Pedal::UnaCorda, "Una corda")]
            {
                let down = self.link.pedal(pedal) >= 0.5;
                if ui.selectable_label(down, name).on_hover_text("click to hold or let go").clicked() {
                    let held = self.link.panel_pedal(pedal) >= 0.5;
                    self.link.set_pedal_from_panel(pedal, if held { 0.0 } else { 1.0 });
                }
            }
            if crate::standalone::is_standalone() {
                ui.label(
                    egui::RichText::new(format!(
                        "computer keys A to ; from {} · Z/X octave · C/V velocity {} · space sustain",
                        super::views::key_name(self.typed_c),
                        self.typed_velocity
                    ))
                    .small(),
                );
            }
        });
        let (response, painter) = ui.allocate_painter(size, Sense::click_and_drag());
        let layout = Layout::new(kind, response.rect);
        self.drawn = response.rect;
        for key in layout.white_keys() {
            let rect = layout.key_rect(key);
            let inside = layout.plays(key);
            let fill = if self.link.is_down(key) {
                HELD
            } else if inside {
                WHITE
            } else {
                WHITE_OUTSIDE
            };
            painter.rect_filled(rect, 2.0, fill);
            painter.rect_stroke(rect, 2.0, Stroke::new(1.0, EDGE), StrokeKind::Inside);
            if key % 12 == 0 {
                let at = pos2(rect.center().x, rect.bottom() - 3.0);
                painter.text(at, Align2::CENTER_BOTTOM, super::views::key_name(key), FontId::proportional(9.0), LABEL);
            }
        }
        for key in layout.black_keys() {
            let rect = layout.key_rect(key);
            let fill = if self.link.is_down(key) {
                HELD_BLACK
            } else if layout.plays(key) {
                BLACK
            } else {
                BLACK_OUTSIDE
            };
            painter.rect_filled(rect, 2.0, fill);
        }

        // The pointer: a press strikes the key under it, a drag moves to the
        // next key (a glissando), a release lets go.
        let pointer = ui.input(|i| (i.pointer.primary_down(), i.pointer.interact_pos()));
        let wanted = match pointer {
            (true, Some(at)) if response.is_pointer_button_down_on() => {
                layout.key_at(at).filter(|&k| layout.plays(k)).map(|k| (k, layout.velocity_at(k, at)))
            }
            _ => None,
        };
        if wanted.map(|w| w.0) != self.pointer_key {
            if let Some(old) = self.pointer_key.take() {
                self.link.release(old);
            }
            if let Some((key, velocity)) = wanted {
                self.link.press(key, velocity);
                self.pointer_key = Some(key);
            }
        }
    }

    /// Let go of whatever the computer's keys hold (their key-ups will not
    /// come: a text field took the keyboard, or the window lost it).
    pub fn let_go_of_typed(&mut self) {
        for (_, midi_key) in self.typed.drain(..) {
            self.link.release(midi_key);
        }
        if std::mem::take(&mut self.space_held) {
            self.link.set_pedal_from_panel(Pedal::Sustain, 0.0);
        }
    }

    /// Play the computer's keys (the standalone calls this each frame unless a
    /// text field has the keyboard).
    pub fn type_keys(&mut self, ui: &Ui) {
        if !ui.input(|i| i.focused) {
            self.let_go_of_typed();
            return;
        }
        let events = ui.input(|i| i.events.clone());
        for event in events {
            let egui::Event::Key { key, pressed, repeat: false, .. } = event else { continue };
            match (key, pressed) {
                (egui::Key::Z, true) => self.typed_c = self.typed_c.saturating_sub(12).max(12),
                (egui::Key::X, true) => self.typed_c = (self.typed_c + 12).min(108),
                (egui::Key::C, true) => self.typed_velocity = self.typed_velocity.saturating_sub(16).max(1),
                (egui::Key::V, true) => self.typed_velocity = (self.typed_velocity + 16).min(127),
                (egui::Key::Space, down) => {
                    self.space_held = down;
                    self.link.set_pedal_from_panel(Pedal::Sustain, if down { 1.0 } else { 0.0 })
                }
                (key, true) => {
                    if let Some(&(_, step)) = TYPED.iter().find(|(k, _)| *k == key)
                        && !self.typed.iter().any(|(k, _)| *k == key)
                    {
                        let midi_key = (self.typed_c + step).min(127);
                        self.link.press(midi_key, self.typed_velocity);
                        self.typed.push((key, midi_key));
                    }
                }
                (key, false) => {
                    if let Some(i) = self.typed.iter().position(|(k, _)| *k == key) {
                        let (_, midi_key) = self.typed.swap_remove(i);
                        self.link.release(midi_key);
                    }
                }
            }
        }
    }
}

impl Drop for PanelKeyboard {
    /// The panel closing lets go of what it holds (the pedals clicked down stay).
    fn drop(&mut self) {
        self.let_go_of_typed();
        if let Some(key) = self.pointer_key.take() {
            self.link.release(key);
        }
    }
}

/// Where each key lies on the drawn keyboard.
struct Layout {
    rect: Rect,
    /// The instrument's keys, and the white keys drawn (widened to white keys at both ends).
    plays: std::ops::RangeInclusive<u8>,
    first_white: u8,
    whites: usize,
    white_width: f32,
}

fn is_black(key: u8) -> bool {
    matches!(key % 12, 1 | 3 | 6 | 8 | 10)
}

/// White keys below `key` from C-1.
fn white_index(key: u8) -> usize {
    (0..key).filter(|&k| !is_black(k)).count()
}

impl Layout {
    fn new(kind: InstrumentKind, rect: Rect) -> Self {
        let plays = kind.key_range();
        let first_white = if is_black(*plays.start()) { plays.start() - 1 } else { *plays.start() };
        let last_white = if is_black(*plays.end()) { plays.end() + 1 } else { *plays.end() };
        let whites = white_index(last_white) - white_index(first_white) + 1;
        Self { rect, plays, first_white, whites, white_width: rect.width() / whites as f32 }
    }

    fn plays(&self, key: u8) -> bool {
        self.plays.contains(&key)
    }

    fn last_white(&self) -> u8 {
        let mut key = self.first_white;
        let mut seen = 1;
        while seen < self.whites {
            key += 1;
            seen += usize::from(!is_black(key));
        }
        key
    }

    fn white_keys(&self) -> impl Iterator<Item = u8> {
        (self.first_white..=self.last_white()).filter(|&k| !is_black(k))
    }

    fn black_keys(&self) -> impl Iterator<Item = u8> {
        (self.first_white..=self.last_white()).filter(|&k| is_black(k))
    }

    fn key_rect(&self, key: u8) -> Rect {
        let left = self.rect.left() + (white_index(key) - white_index(self.first_white)) as f32 * self.white_width;
        if is_black(key) {
            let width = BLACK_WIDTH * self.white_width;
            Rect::from_min_size(
                pos2(left - 0.5 * width, self.rect.top()),
                vec2(width, BLACK_HEIGHT * self.rect.height()),
            )
        } else {
            Rect::from_min_size(pos2(left, self.rect.top()), vec2(self.white_width, self.rect.height()))
        }
    }

    /// The key under `at` (the black keys lie over the white).
    fn key_at(&self, at: Pos2) -> Option<u8> {
        if !self.rect.contains(at) {
            return None;
        }
        self.black_keys()
            .find(|&k| self.key_rect(k).contains(at))
            .or_else(|| self.white_keys().find(|&k| self.key_rect(k).contains(at)))
    }

    /// How hard a click at `at` strikes `key`: softest at its back edge, 127 at its front.
    fn velocity_at(&self, key: u8, at: Pos2) -> u8 {
        let rect = self.key_rect(key);
        let depth = ((at.y - rect.top()) / rect.height()).clamp(0.0, 1.0);
        (SOFTEST_CLICK + (127.0 - SOFTEST_CLICK) * depth).round().clamp(1.0, 127.0) as u8
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_layout_finds_keys_and_velocities() {
        let rect = Rect::from_min_size(Pos2::ZERO, vec2(520.0, 80.0));
        let piano = Layout::new(InstrumentKind::Piano, rect);
        // A0 to C8: 52 white keys, 36 black.
        assert_eq!((piano.white_keys().count(), piano.black_keys().count()), (52, 36));
        assert_eq!(piano.white_width, 10.0);
        // The front of the first white key, A0, loudest; the back of it, softest.
        assert_eq!(piano.key_at(pos2(2.0, 79.0)), Some(21));
        assert_eq!(piano.velocity_at(21, pos2(2.0, 80.0)), 127);
        assert_eq!(piano.velocity_at(21, pos2(2.0, 0.0)), SOFTEST_CLICK as u8);
        // A#0 lies over the boundary of A0 and B0, on the upper part only.
        assert_eq!(piano.key_at(pos2(10.0, 20.0)), Some(22));
        assert_eq!(piano.key_at(pos2(10.5, 70.0)), Some(23));
        // Outside: nothing.
        assert_eq!(piano.key_at(pos2(600.0, 40.0)), None);
        // A range starting on a black key is widened to the white key below it, which does not play.
        let santoor = Layout::new(InstrumentKind::Santoor, rect);
        assert!(!is_black(santoor.first_white));
        let playable = santoor.white_keys().chain(santoor.black_keys()).filter(|&k| santoor.plays(k)).count();
        assert_eq!(playable, InstrumentKind::Santoor.key_range().count());
    }
}
