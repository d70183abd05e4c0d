//! The live physics view, drawn with egui's painter from the engine's
//! [`Scope`]: the last struck key's string with its hammer (Woodhouse's
//! Fig. 2 as it happens), the contact force of the last strike, and the output
//! spectrum; and the small velocity-to-touch curve of the Touch group.

use std::sync::Arc;

use egui::{Align2, Color32, FontId, Pos2, Rect, Sense, Shape, Stroke, StrokeKind, Ui, Vec2, pos2};
use realfft::num_complex::Complex;
use realfft::{RealFftPlanner, RealToComplex};
use struck_engine::design::{InstrumentKind, TouchRange};
use struck_engine::synth::scope::{CONTACT_SAMPLES, SHAPE_POINTS};
use struck_engine::synth::{Controls, Scope, ScopeFrame};

/// Output samples the spectrum is taken over.
pub const SPECTRUM_SIZE: usize = 4096;
/// The spectrum's axes.
const SPECTRUM_LOW_HZ: f32 = 20.0;
const SPECTRUM_HIGH_HZ: f32 = 20_000.0;
const SPECTRUM_FLOOR_DB: f32 = -120.0;
const SPECTRUM_TOP_DB: f32 = 0.0;

const BACKGROUND: Color32 = Color32::from_rgb(18, 20, 24);
const GRID: Color32 = Color32::from_rgb(48, 52, 60);
const AXIS_TEXT: Color32 = Color32::from_rgb(150, 156, 168);
const STRING_COLOUR: Color32 = Color32::from_rgb(230, 200, 120);
const HAMMER_COLOUR: Color32 = Color32::from_rgb(200, 90, 80);
const FORCE_COLOUR: Color32 = Color32::from_rgb(120, 190, 240);
const SPECTRUM_COLOUR: Color32 = Color32::from_rgb(140, 220, 150);
const CURVE_COLOUR: Color32 = Color32::from_rgb(230, 170, 90);

/// What the panel keeps between frames: the newest scope frame and the last
/// [`SPECTRUM_SIZE`] output samples with their spectrum. Allocates only when made.
pub struct LiveView {
    frame: Option<ScopeFrame>,
    incoming: Vec<f32>,
    history: Vec<f32>,
    fresh_samples: bool,
    /// The last update brought sound (the panel then animates at full rate).
    pub sounding: bool,
    window: Vec<f32>,
    fft: Arc<dyn RealToComplex<f32>>,
    fft_in: Vec<f32>,
    fft_out: Vec<Complex<f32>>,
    fft_scratch: Vec<Complex<f32>>,
    spectrum_db: Vec<f32>,
}

impl Default for LiveView {
    fn default() -> Self {
        let fft = RealFftPlanner::<f32>::new().plan_fft_forward(SPECTRUM_SIZE);
        let window = (0..SPECTRUM_SIZE)
            .map(|i| {
                let phase = 2.0 * std::f32::consts::PI * i as f32 / SPECTRUM_SIZE as f32;
                0.5 - 0.5 * phase.cos()
            })
            .collect();
        Self {
            frame: None,
            incoming: Vec::with_capacity(32 * 1024),
            history: Vec::with_capacity(SPECTRUM_SIZE + 32 * 1024),
            fresh_samples: false,
            sounding: false,
            fft_in: fft.make_input_vec(),
            fft_out: fft.make_output_vec(),
            fft_scratch: fft.make_scratch_vec(),
            spectrum_db: vec![SPECTRUM_FLOOR_DB; SPECTRUM_SIZE / 2 + 1],
            window,
            fft,
        }
    }
}

impl LiveView {
    /// Take what the audio thread has published since the last call.
    pub fn update(&mut self, scope: &mut Scope) {
        if let Some(frame) = scope.latest() {
            match &mut self.frame {
                Some(kept) => kept.clone_from(frame),
                None => self.frame = Some(frame.clone()),
            }
        }
        self.incoming.clear();
        scope.drain_samples(&mut self.incoming);
        // Above -120 dBFS: worth animating.
        self.sounding = self.incoming.iter().any(|v| v.abs() > 1e-6);
        if !self.incoming.is_empty() {
            self.history.extend_from_slice(&self.incoming);
            if self.history.len() > SPECTRUM_SIZE {
                self.history.drain(..self.history.len() - SPECTRUM_SIZE);
            }
            self.fresh_samples = true;
        }
    }

    pub fn frame(&self) -> Option<&ScopeFrame> {
        self.frame.as_ref()
    }

    /// The output spectrum, dB re full scale per bin (Hann window), bins 0..=N/2.
    pub fn spectrum_db(&mut self) -> &[f32] {
        if std::mem::take(&mut self.fresh_samples) {
            let pad = SPECTRUM_SIZE - self.history.len();
            self.fft_in[..pad].fill(0.0);
            for ((x, &s), &w) in self.fft_in[pad..].iter_mut().zip(&self.history).zip(&self.window[pad..]) {
                *x = s * w;
            }
            let norm = 2.0 / self.window.iter().sum::<f32>();
            if self.fft.process_with_scratch(&mut self.fft_in, &mut self.fft_out, &mut self.fft_scratch).is_ok() {
                for (db, bin) in self.spectrum_db.iter_mut().zip(&self.fft_out) {
                    *db = (20.0 * (bin.norm() * norm + 1e-12).log10()).max(SPECTRUM_FLOOR_DB);
                }
            }
        }
        &self.spectrum_db
    }
}

/// A plot area with its background, returned for drawing into.
fn plot_area(ui: &mut Ui, size: Vec2) -> (egui::Painter, Rect) {
    let (response, painter) = ui.allocate_painter(size, Sense::hover());
    let rect = response.rect;
    painter.rect_filled(rect, 4.0, BACKGROUND);
    painter.rect_stroke(rect, 4.0, Stroke::new(1.0, GRID), StrokeKind::Inside);
    (painter, rect.shrink(6.0))
}

fn small() -> FontId {
    FontId::proportional(11.0)
}

/// Equal-tempered note name of a MIDI key, e.g. 69 -> "A4".
pub fn key_name(midi_key: u8) -> String {
    const NAMES: [&str; 12] = ["C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"];
    format!("{}{}", NAMES[midi_key as usize % 12], midi_key as i32 / 12 - 1)
}

/// A length in metres with a unit that suits it.
pub fn format_length(metres: f64) -> String {
    let a = metres.abs();
    if a >= 1e-3 {
        format!("{:.2} mm", metres * 1e3)
    } else if a >= 1e-6 {
        format!("{:.1} µm", metres * 1e6)
    } else {
        format!("{:.0} nm", metres * 1e9)
    }
}

/// The string's shape along its length with the hammer as a block at its place and height.
pub fn string_view(ui: &mut Ui, frame: Option<&ScopeFrame>, size: Vec2) {
    let (painter, rect) = plot_area(ui, size);
    let Some(frame) = frame else {
        painter.text(
            rect.center(),
            Align2::CENTER_CENTER,
            "play a key (the keyboard below, or MIDI) to see its string",
            small(),
            AXIS_TEXT,
        );
        return;
    };
    let hammer = frame.hammer;
    let peak = frame
        .shape_m
        .iter()
        .chain(frame.strike_shape_m.iter())
        .map(|y| y.abs())
        .chain(hammer.map(|(_, h)| h.abs()))
        .chain(frame.strike_hammer.map(|(_, h)| h.abs()))
        .fold(0.0f32, f32::max);
    let scale = (1.25 * peak).max(1e-9);
    let mid = rect.center().y;
    let half = 0.5 * rect.height() - 14.0;
    let to_screen = |fraction: f32, y_m: f32| pos2(rect.left() + fraction * rect.width(), mid - half * y_m / scale);
    painter.line_segment([pos2(rect.left(), mid), pos2(rect.right(), mid)], Stroke::new(1.0, GRID));
    let points: Vec<Pos2> =
        frame.shape_m.iter().enumerate().map(|(i, &y)| to_screen(i as f32 / (SHAPE_POINTS - 1) as f32, y)).collect();
    painter.add(Shape::line(points, Stroke::new(2.0, STRING_COLOUR)));
    if let Some((position, height_m)) = frame.strike_hammer {
        // The moment of the largest contact force of the last strike, drawn faintly behind.
        let faint = STRING_COLOUR.gamma_multiply(0.35);
        let points: Vec<Pos2> = frame
            .strike_shape_m
            .iter()
            .enumerate()
            .map(|(i, &y)| to_screen(i as f32 / (SHAPE_POINTS - 1) as f32, y))
            .collect();
        painter.add(Shape::line(points, Stroke::new(1.5, faint)));
        let face = to_screen(position, height_m);
        let block = Rect::from_min_max(pos2(face.x - 6.0, face.y), pos2(face.x + 6.0, face.y + 16.0));
        painter.rect_filled(block, 2.0, HAMMER_COLOUR.gamma_multiply(0.5));
        painter.text(
            rect.center_top(),
            Align2::CENTER_TOP,
            format!(
                "faint: at its peak contact force ({:.1} N on this string), {:.2} ms in",
                frame.strike_force_n,
                frame.strike_time_s * 1e3
            ),
            small(),
            AXIS_TEXT,
        );
    }
    if let Some((position, height_m)) = hammer {
        // The felt's face at the hammer's height, its body behind it (y grows the way it pushes).
        let face = to_screen(position, height_m);
        let block = Rect::from_min_max(pos2(face.x - 6.0, face.y), pos2(face.x + 6.0, face.y + 16.0));
        painter.rect_filled(block, 2.0, HAMMER_COLOUR);
    }
    painter.text(rect.left_top(), Align2::LEFT_TOP, "bridge", small(), AXIS_TEXT);
    painter.text(
        rect.right_top(),
        Align2::RIGHT_TOP,
        format!("{} · L = {:.3} m", key_name(frame.midi_key), frame.length_m),
        small(),
        AXIS_TEXT,
    );
    painter.text(
        rect.left_bottom(),
        Align2::LEFT_BOTTOM,
        format!("full height ±{}", format_length(scale as f64)),
        small(),
        AXIS_TEXT,
    );
}

/// The contact force of the last strike against time, ms.
pub fn contact_view(ui: &mut Ui, frame: Option<&ScopeFrame>, size: Vec2) {
    let (painter, rect) = plot_area(ui, size);
    let Some(frame) = frame.filter(|f| f.contact_len > 0) else {
        painter.text(rect.center(), Align2::CENTER_CENTER, "contact force appears here", small(), AXIS_TEXT);
        return;
    };
    let len = frame.contact_len.min(CONTACT_SAMPLES);
    let forces = &frame.contact_n[..len];
    let peak = forces.iter().fold(0.0f32, |m, f| m.max(f.abs())).max(1e-6);
    let span_ms = CONTACT_SAMPLES as f64 / frame.sample_rate_hz * 1e3;
    let plot = Rect::from_min_max(rect.min + Vec2::new(0.0, 14.0), rect.max - Vec2::new(0.0, 14.0));
    let to_screen = |i: usize, f: f32| {
        pos2(plot.left() + plot.width() * i as f32 / CONTACT_SAMPLES as f32, plot.bottom() - plot.height() * f / peak)
    };
    painter.line_segment([plot.left_bottom(), plot.right_bottom()], Stroke::new(1.0, GRID));
    for tick in 0..=(span_ms.floor() as usize) {
        if tick % tick_step(span_ms) == 0 {
            let x = plot.left() + plot.width() * (tick as f64 / span_ms) as f32;
            painter.line_segment([pos2(x, plot.bottom()), pos2(x, plot.bottom() + 3.0)], Stroke::new(1.0, AXIS_TEXT));
            painter.text(pos2(x, plot.bottom() + 3.0), Align2::CENTER_TOP, format!("{tick}"), small(), AXIS_TEXT);
        }
    }
    let points: Vec<Pos2> = forces.iter().enumerate().map(|(i, &f)| to_screen(i, f)).collect();
    painter.add(Shape::line(points, Stroke::new(1.5, FORCE_COLOUR)));
    let touching = forces.iter().filter(|f| **f > 0.0).count();
    let contact_ms = touching as f64 / frame.sample_rate_hz * 1e3;
    painter.text(
        rect.left_top(),
        Align2::LEFT_TOP,
        format!("contact force: peak {peak:.2} N, {contact_ms:.2} ms in contact"),
        small(),
        AXIS_TEXT,
    );
    painter.text(rect.right_bottom(), Align2::RIGHT_BOTTOM, "ms", small(), AXIS_TEXT);
}

/// Every how many ms a tick is labelled so that about eight fit.
fn tick_step(span_ms: f64) -> usize {
    [1, 2, 5, 10, 20, 50].into_iter().find(|&s| span_ms / s as f64 <= 8.0).unwrap_or(100)
}

/// The output spectrum on a log-frequency axis, 20 Hz to 20 kHz.
pub fn spectrum_view(ui: &mut Ui, spectrum_db: &[f32], sample_rate_hz: f64, size: Vec2) {
    let (painter, rect) = plot_area(ui, size);
    let plot = Rect::from_min_max(rect.min + Vec2::new(28.0, 14.0), rect.max - Vec2::new(0.0, 14.0));
    let octaves = (SPECTRUM_HIGH_HZ / SPECTRUM_LOW_HZ).ln();
    let x_of = |hz: f32| plot.left() + plot.width() * (hz / SPECTRUM_LOW_HZ).ln() / octaves;
    let y_of = |db: f32| {
        let t =
            (db.clamp(SPECTRUM_FLOOR_DB, SPECTRUM_TOP_DB) - SPECTRUM_FLOOR_DB) / (SPECTRUM_TOP_DB - SPECTRUM_FLOOR_DB);
        plot.bottom() - plot.height() * t
    };
    for (hz, label) in [(100.0, "100"), (1_000.0, "1k"), (10_000.0, "10k")] {
        let x = x_of(hz);
        painter.line_segment([pos2(x, plot.top()), pos2(x, plot.bottom())], Stroke::new(1.0, GRID));
        painter.text(pos2(x, plot.bottom() + 2.0), Align2::CENTER_TOP, label, small(), AXIS_TEXT);
    }
    for db in [-100.0, -80.0, -60.0, -40.0, -20.0] {
        let y = y_of(db);
        painter.line_segment([pos2(plot.left(), y), pos2(plot.right(), y)], Stroke::new(1.0, GRID));
        painter.text(pos2(plot.left() - 3.0, y), Align2::RIGHT_CENTER, format!("{db:.0}"), small(), AXIS_TEXT);
    }
    let bins = spectrum_db.len();
    if bins > 1 {
        let fft_size = 2 * (bins - 1);
        let hz_per_bin = sample_rate_hz as f32 / fft_size as f32;
        let columns = plot.width().max(1.0) as usize;
        let mut points = Vec::with_capacity(columns);
        for c in 0..columns {
            let lo = SPECTRUM_LOW_HZ * (octaves * c as f32 / columns as f32).exp();
            let hi = SPECTRUM_LOW_HZ * (octaves * (c + 1) as f32 / columns as f32).exp();
            if lo > 0.5 * sample_rate_hz as f32 {
                break;
            }
            let db = if hi - lo < hz_per_bin {
                // Narrower than a bin (the low end): between the two nearest bins.
                let at = (0.5 * (lo + hi) / hz_per_bin).min((bins - 1) as f32);
                let below = at.floor() as usize;
                let above = (below + 1).min(bins - 1);
                let t = at - below as f32;
                spectrum_db[below] + t * (spectrum_db[above] - spectrum_db[below])
            } else {
                // Wider (the high end): the loudest bin in it.
                let first = ((lo / hz_per_bin).round() as usize).min(bins - 1);
                let last = ((hi / hz_per_bin).round() as usize).clamp(first, bins - 1);
                spectrum_db[first..=last].iter().fold(SPECTRUM_FLOOR_DB, |m, &d| m.max(d))
            };
            points.push(pos2(plot.left() + c as f32, y_of(db)));
        }
        painter.add(Shape::line(points, Stroke::new(1.5, SPECTRUM_COLOUR)));
    }
    painter.text(rect.left_top(), Align2::LEFT_TOP, "output spectrum, dBFS", small(), AXIS_TEXT);
    painter.text(rect.right_bottom(), Align2::RIGHT_BOTTOM, "Hz", small(), AXIS_TEXT);
}

/// Velocity (1..127) against touch under the present controls.
pub fn touch_curve(ui: &mut Ui, controls: &Controls, kind: InstrumentKind, size: Vec2) {
    let range: TouchRange = kind.touch_range();
    let (painter, rect) = plot_area(ui, size);
    let plot = Rect::from_min_max(rect.min + Vec2::new(30.0, 12.0), rect.max - Vec2::new(0.0, 12.0));
    let top = range.bounds().1;
    let to_screen = |velocity: f64, touch: f64| {
        pos2(
            plot.left() + plot.width() * ((velocity - 1.0) / 126.0) as f32,
            plot.bottom() - plot.height() * (touch / top) as f32,
        )
    };
    painter.line_segment([plot.left_bottom(), plot.right_bottom()], Stroke::new(1.0, GRID));
    painter.line_segment([plot.left_bottom(), plot.left_top()], Stroke::new(1.0, GRID));
    let points: Vec<Pos2> =
        (1..=127).map(|v| to_screen(v as f64, controls.touch(range, v as f64 / 127.0).value())).collect();
    painter.add(Shape::line(points, Stroke::new(1.5, CURVE_COLOUR)));
    let unit = range.max().unit();
    let soft = controls.touch(range, 1.0 / 127.0).value();
    let hard = controls.touch(range, 1.0).value();
    painter.text(plot.left_top(), Align2::RIGHT_CENTER, format!("{top:.1} "), small(), AXIS_TEXT);
    painter.text(plot.left_bottom(), Align2::RIGHT_CENTER, "0 ", small(), AXIS_TEXT);
    painter.text(
        rect.left_top() + Vec2::new(30.0, -2.0),
        Align2::LEFT_TOP,
        format!("{soft:.2} to {hard:.2} {unit}"),
        small(),
        AXIS_TEXT,
    );
    // The player's own range, when learnt or set: the curve runs flat outside it.
    let (floor, ceiling) = (controls.velocity_floor, controls.velocity_ceiling);
    let axis = if (floor, ceiling) == (0.0, 1.0) {
        "velocity 1 to 127".to_string()
    } else {
        format!("velocity 1 to 127, yours {:.0} to {:.0}", floor * 127.0, ceiling * 127.0)
    };
    painter.text(rect.right_bottom(), Align2::RIGHT_BOTTOM, axis, small(), AXIS_TEXT);
}
