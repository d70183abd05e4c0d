//! A string's shape frame by frame, as an animated GIF: the hammer (a red
//! star) coming down on the string at the struck point (a green star), the
//! outgoing waves and their reflections (Figs 2, 23-25), or a clavichord
//! string pushed up by its tangent (Fig 32). The vertical scale is hugely
//! exaggerated, and says by how much.

use std::path::Path;

use plotters::coord::Shift;
use plotters::drawing::DrawingAreaErrorKind;
use plotters::prelude::*;
use plotters::style::text_anchor::{HPos, Pos, VPos};
use plotters_backend::DrawingErrorKind;

use super::axis::{Axis, Scale, clip_polyline, plain};
use super::frame::{self, Key, Layout, Paint, draw_markers, set_legend};
use super::typeset::Typeset;
use super::{Colour, Corner, FONT, MarkerShape, PlotError, ensure_fonts, fail, write_atomically};

/// The most frames a GIF holds; more are thinned out evenly (see
/// [`Animation::draw_gif`]).
pub const MAX_GIF_FRAMES: usize = 150;

/// The shortest frame delay written: viewers show faster GIFs slowly.
const MIN_DELAY_MS: u32 = 20;

/// The levels of coverage a frame's text is shaded in: few enough that a
/// frame has at most 256 colours, which plotters' GIF backend stores exactly.
const TEXT_COVERAGE_LEVELS: u8 = 6;

/// The string's colour.
const STRING: Colour = Colour(0, 0, 200);
/// The hammer's (or tangent's) colour.
const HAMMER: Colour = Colour(235, 0, 0);
/// The struck point's colour.
const STRUCK: Colour = Colour(0, 200, 0);

/// The string at one instant.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct AnimationFrame {
    /// The time since the start, shown on the frame.
    pub time_s: f64,
    /// Positions along the string, in metres.
    pub string_x_m: Vec<f64>,
    /// The string's displacement at each position, in metres (drawn in mm).
    pub string_y_m: Vec<f64>,
    /// The hammer's position (x, y) in metres, drawn as a red star; None
    /// draws none.
    pub hammer: Option<(f64, f64)>,
    /// The string's struck point (x, y) in metres, drawn as a green star;
    /// None draws none.
    pub struck_point: Option<(f64, f64)>,
}

/// An animation of a string's shape.
///
/// The axes are fixed over all frames so that the scale does not jump: x
/// covers the string, y covers every frame's string, hammer and struck point
/// (or `y_range_m`), with 8% to spare. A hammer outside that range leaves the
/// frame, as in Fig 25.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// Across the top; none if empty.
    pub title: String,
    /// Under the x axis.
    pub x_label: String,
    /// Beside the y axis (the displacement is drawn in mm).
    pub y_label: String,
    /// The displacement axis's extent in metres; None fits every frame.
    pub y_range_m: Option<(f64, f64)>,
    /// How long each frame shows, in milliseconds (at least 20; GIFs count
    /// in hundredths of a second).
    pub frame_delay_ms: u32,
    /// The frames in order.
    pub frames: Vec<AnimationFrame>,
    /// Where the legend of the hammer and struck point goes.
    pub legend: Corner,
    /// The GIF's width and height.
    pub size_px: (u32, u32),
}

impl Default for Animation {
    fn default() -> Self {
        Self {
            title: String::new(),
            x_label: "position along the string (m)".into(),
            y_label: "displacement (mm)".into(),
            y_range_m: None,
            frame_delay_ms: 50,
            frames: Vec::new(),
            legend: Corner::UpperRight,
            size_px: (640, 360),
        }
    }
}

/// The axes, worked out before any file is touched.
struct Plan {
    /// Metres.
    x: Axis,
    /// Millimetres.
    y: Axis,
}

const MM_PER_M: f64 = 1000.0;

impl Animation {
    /// An animation of `frames` with the default labels, delay and size.
    pub fn new(title: impl Into<String>, frames: Vec<AnimationFrame>) -> Self {
        Self { title: title.into(), frames, ..Self::default() }
    }

    /// Draw the animation into the GIF file `gif`, looping. With more than
    /// [`MAX_GIF_FRAMES`] frames, that many are kept, evenly spaced from the
    /// first to the last, and each shows for proportionally longer, so the
    /// animation lasts as long as it would with them all.
    pub fn draw_gif(&self, gif: &Path) -> Result<(), PlotError> {
        let plan = self.plan().map_err(|reason| PlotError::bad_data(gif, reason))?;
        let (kept, delay_ms) = self.kept_frames();
        let (width, height) = self.size_px;
        if u16::try_from(width).is_err() || u16::try_from(height).is_err() {
            return Err(PlotError::bad_data(gif, format!("{width} x {height} is too big for a GIF")));
        }
        write_atomically(gif, "gif", |temporary| {
            ensure_fonts()?;
            {
                // plotters' GIF backend: each present() adds the frame drawn;
                // the GIF is finished when the backend is dropped.
                let backend = BitMapBackend::gif(temporary, self.size_px, delay_ms).map_err(|e| gif_error(&e))?;
                let root = Typeset::with_coverage_levels(backend, TEXT_COVERAGE_LEVELS).into_drawing_area();
                for &i in &kept {
                    self.paint(&root, &plan, &self.frames[i])?;
                    root.present().map_err(|e| match e {
                        DrawingAreaErrorKind::BackendError(DrawingErrorKind::DrawingError(e)) => gif_error(&e),
                        other => other.to_string(),
                    })?;
                }
            }
            std::fs::File::open(temporary).and_then(|file| file.sync_all()).map_err(fail)
        })
    }

    /// Draw frame `index` alone into the PNG file `png`, as it is drawn for
    /// the GIF (which may show parts of it in fewer colours).
    pub fn draw_frame_png(&self, index: usize, png: &Path) -> Result<(), PlotError> {
        let plan = self.plan().map_err(|reason| PlotError::bad_data(png, reason))?;
        let Some(frame) = self.frames.get(index) else {
            return Err(PlotError::bad_data(png, format!("no frame {index}: there are {}", self.frames.len())));
        };
        write_atomically(png, "png", |temporary| {
            ensure_fonts()?;
            let root = Typeset::with_coverage_levels(BitMapBackend::new(temporary, self.size_px), TEXT_COVERAGE_LEVELS)
                .into_drawing_area();
            self.paint(&root, &plan, frame)?;
            root.present().map_err(fail)
        })
    }

    /// The indices of the frames a GIF holds, and the delay of each.
    fn kept_frames(&self) -> (Vec<usize>, u32) {
        let n = self.frames.len();
        let delay_ms = self.frame_delay_ms.max(MIN_DELAY_MS);
        if n <= MAX_GIF_FRAMES {
            return ((0..n).collect(), delay_ms);
        }
        let last = (n - 1) as f64;
        let kept: Vec<usize> =
            (0..MAX_GIF_FRAMES).map(|k| (k as f64 * last / (MAX_GIF_FRAMES - 1) as f64).round() as usize).collect();
        let stretch = last / (MAX_GIF_FRAMES - 1) as f64;
        (kept, (f64::from(delay_ms) * stretch).round() as u32)
    }

    fn plan(&self) -> Result<Plan, String> {
        if self.frames.is_empty() {
            return Err("an animation needs frames".into());
        }
        for (i, f) in self.frames.iter().enumerate() {
            if f.string_x_m.len() != f.string_y_m.len() {
                return Err(format!(
                    "frame {i}: {} positions but {} displacements",
                    f.string_x_m.len(),
                    f.string_y_m.len()
                ));
            }
        }
        let xs = self.frames.iter().flat_map(|f| f.string_x_m.iter().copied());
        let x = Axis::fit(Scale::Linear, None, xs, false, "x")?;
        let ys = self.frames.iter().flat_map(|f| {
            let points = f.hammer.iter().chain(f.struck_point.iter()).map(|p| p.1);
            f.string_y_m.iter().copied().chain(points)
        });
        let y = match self.y_range_m {
            Some((low, high)) => Axis::exact(Scale::Linear, (low * MM_PER_M, high * MM_PER_M), "y")?,
            None => {
                let fitted = Axis::fit(Scale::Linear, None, ys.map(|y| y * MM_PER_M), false, "y")?;
                let pad = 0.08 * (fitted.high - fitted.low);
                Axis { low: fitted.low - pad, high: fitted.high + pad, ..fitted }
            }
        };
        Ok(Plan { x, y })
    }

    fn paint<DB: DrawingBackend>(
        &self,
        root: &DrawingArea<DB, Shift>,
        plan: &Plan,
        frame: &AnimationFrame,
    ) -> Result<(), String> {
        let layout = Layout::SMALL;
        root.fill(&WHITE).map_err(fail)?;
        // A header with the title in the middle and the time on the right.
        let header_px = layout.title_font + 14;
        let (header, body) = root.split_vertically(header_px);
        let (width_px, _) = root.dim_in_pixel();
        let middle = header_px as i32 / 2;
        let centred = Pos::new(HPos::Center, VPos::Center);
        let title = (FONT, layout.title_font).into_font().color(&BLACK).pos(centred);
        header.draw_text(&self.title, &title, (width_px as i32 / 2, middle)).map_err(fail)?;
        let time = (FONT, layout.legend_font).into_font().color(&BLACK).pos(Pos::new(HPos::Right, VPos::Center));
        header.draw_text(&time_label(frame.time_s), &time, (width_px as i32 - 10, middle)).map_err(fail)?;

        let (x, y) = (&plan.x, &plan.y);
        let mut chart = frame::chart(&body, (x, y), (&self.x_label, &self.y_label), &layout)?;
        let placed: Vec<Option<(f64, f64)>> = frame
            .string_x_m
            .iter()
            .zip(&frame.string_y_m)
            .map(|(&a, &b)| (a.is_finite() && b.is_finite()).then_some((a, b * MM_PER_M)))
            .collect();
        let runs = clip_polyline(&placed, &x.range(), &y.range());
        let style = STRING.rgb().stroke_width(2);
        chart.draw_series(runs.into_iter().map(|run| PathElement::new(run, style))).map_err(fail)?;

        // The struck point smaller and on top, so that both show when the
        // hammer is on it.
        let mut labelled = false;
        for (point, colour, label, radius_px) in
            [(frame.hammer, HAMMER, "hammer", 8), (frame.struck_point, STRUCK, "struck point", 5)]
        {
            let Some((a, b)) = point else { continue };
            let at = (a, b * MM_PER_M);
            let inside = x.contains(at.0) && y.contains(at.1);
            let points = if inside { vec![at] } else { Vec::new() };
            let drawn = draw_markers(&mut chart, points, (MarkerShape::Star, colour, radius_px, Paint::Solid))?;
            set_legend(drawn, label, Key::Marker(MarkerShape::Star, colour, Paint::Solid), 7);
            labelled = true;
        }
        if labelled {
            frame::legend(&mut chart, self.legend, &layout)?;
        }

        // How much the vertical scale is stretched, under the plot on the left.
        let (x_px, y_px) = chart.plotting_area().get_pixel_range();
        let metres_per_px_x = (x.high - x.low) / f64::from(x_px.end - x_px.start);
        let metres_per_px_y = (y.high - y.low) / MM_PER_M / f64::from(y_px.end - y_px.start);
        let note = format!("vertical scale \u{00d7}{}", plain(two_figures(metres_per_px_x / metres_per_px_y)));
        let grey =
            (FONT, layout.tick_font).into_font().color(&RGBColor(90, 90, 90)).pos(Pos::new(HPos::Left, VPos::Bottom));
        let base = body.get_base_pixel();
        let at = (8, y_px.end - base.1 + layout.x_label_area as i32 - 2);
        body.draw_text(&note, &grey, at).map_err(fail)
    }

    /// `frame` drawn into an RGB buffer of `size_px` (for tests).
    #[cfg(test)]
    fn render(&self, plan: &Plan, frame: &AnimationFrame) -> Result<Vec<u8>, String> {
        let (w, h) = self.size_px;
        let mut rgb = vec![0u8; w as usize * h as usize * 3];
        {
            let root =
                Typeset::with_coverage_levels(BitMapBackend::with_buffer(&mut rgb, self.size_px), TEXT_COVERAGE_LEVELS)
                    .into_drawing_area();
            self.paint(&root, plan, frame)?;
            root.present().map_err(fail)?;
        }
        Ok(rgb)
    }
}

/// The errors of plotters' bitmap and GIF backend.
type GifError = <BitMapBackend<'static> as DrawingBackend>::ErrorType;

/// A GIF backend's error as text: an I/O error as the system words it (plotters
/// words it as Rust would debug it), so that a full disk or the file-size
/// limit reads as such.
fn gif_error(error: &GifError) -> String {
    match error {
        GifError::IOError(e) | GifError::GifEncodingError(gif::EncodingError::Io(e)) => e.to_string(),
        other => other.to_string(),
    }
}

/// "t = 1.234 ms", or in seconds from 1 s.
fn time_label(time_s: f64) -> String {
    if time_s.abs() < 1.0 { format!("t = {:.3} ms", time_s * 1e3) } else { format!("t = {time_s:.3} s") }
}

/// `value` rounded to two significant figures.
fn two_figures(value: f64) -> f64 {
    if !value.is_finite() || value == 0.0 {
        return value;
    }
    let unit = 10f64.powf(value.abs().log10().floor() - 1.0);
    (value / unit).round() * unit
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{distinct_colours, has_colour, png_size, samples_dir};
    use super::*;

    /// Every frame of the GIF at `path` as the viewer shows it (RGB), with
    /// each frame's delay in milliseconds.
    fn decode(path: &Path) -> Vec<(Vec<u8>, u32)> {
        let mut options = gif::DecodeOptions::new();
        options.set_color_output(gif::ColorOutput::RGBA);
        let mut decoder = options.read_info(std::fs::File::open(path).unwrap()).unwrap();
        let (width, height) = (usize::from(decoder.width()), usize::from(decoder.height()));
        let mut canvas = vec![255u8; width * height * 3];
        let mut frames = Vec::new();
        while let Some(frame) = decoder.read_next_frame().unwrap() {
            let (left, top, w) = (usize::from(frame.left), usize::from(frame.top), usize::from(frame.width));
            for (k, pixel) in frame.buffer.chunks_exact(4).enumerate() {
                if pixel[3] != 0 {
                    let (x, y) = (left + k % w, top + k / w);
                    canvas[(y * width + x) * 3..][..3].copy_from_slice(&pixel[..3]);
                }
            }
            frames.push((canvas.clone(), u32::from(frame.delay) * 10));
        }
        frames
    }

    /// Like Fig 2: a 0.5 m string struck at 2/5 of its length, two triangular
    /// pulses running outwards and the hammer pushing in then thrown off.
    fn strike(frames: usize) -> Animation {
        let length_m = 0.5;
        let struck_m = 0.4 * length_m;
        let x: Vec<f64> = (0..=200).map(|i| length_m * f64::from(i) / 200.0).collect();
        let frames = (0..frames)
            .map(|k| {
                let t_s = k as f64 * 2e-5;
                let spread_m = 200.0 * t_s;
                let depth_m = -1e-3 * (t_s / 1e-3).min(1.0);
                let y: Vec<f64> = x
                    .iter()
                    .map(|&p| {
                        let d = (p - struck_m).abs();
                        let envelope = if p < struck_m { p / struck_m } else { (length_m - p) / (length_m - struck_m) };
                        if d < spread_m { depth_m * envelope.min(1.0) } else { 0.0 }
                    })
                    .collect();
                let hammer_y = if t_s < 1e-3 { depth_m - 1e-5 } else { depth_m + (t_s - 1e-3) * 2.0 };
                AnimationFrame {
                    time_s: t_s,
                    string_x_m: x.clone(),
                    string_y_m: y,
                    hammer: Some((struck_m, hammer_y)),
                    struck_point: Some((struck_m, depth_m)),
                }
            })
            .collect();
        Animation::new("Santoor string, 1 g hammer at 2/5", frames)
    }

    #[test]
    fn a_gif_is_written_and_its_frames_show_string_hammer_and_struck_point() {
        let anim = strike(60);
        ensure_fonts().unwrap();
        let rgb = anim.render(&anim.plan().unwrap(), &anim.frames[30]).unwrap();
        assert!(has_colour(&rgb, STRING) && has_colour(&rgb, HAMMER) && has_colour(&rgb, STRUCK));
        // Few enough colours for plotters' GIF backend to keep them exact.
        assert!(distinct_colours(&rgb) <= 256, "{} colours", distinct_colours(&rgb));
        let dir = tempfile::tempdir().unwrap();
        let gif = dir.path().join("strike.gif");
        anim.draw_gif(&gif).unwrap();
        let bytes = std::fs::read(&gif).unwrap();
        assert_eq!(&bytes[..6], b"GIF89a");
        assert_eq!(u16::from_le_bytes([bytes[6], bytes[7]]), 640);
        assert_eq!(u16::from_le_bytes([bytes[8], bytes[9]]), 360);
        assert_eq!(*bytes.last().unwrap(), 0x3b, "the GIF is finished");
        // Each frame is stored whole but compressed: under a tenth of its
        // 640 x 360 palette indices (about 18 kB a frame here).
        assert!(bytes.len() < 60 * 640 * 360 / 10, "{} bytes", bytes.len());
        let shown = decode(&gif);
        assert_eq!(shown.len(), 60);
        assert!(shown.iter().all(|(_, delay_ms)| *delay_ms == 50));
        let (frame_30, _) = &shown[30];
        let near = rgb
            .chunks_exact(3)
            .zip(frame_30.chunks_exact(3))
            .filter(|(a, b)| (0..3).map(|k| u32::from(a[k].abs_diff(b[k])).pow(2)).sum::<u32>() <= 3 * 26 * 26);
        assert_eq!(near.count(), 640 * 360, "the GIF shows frame 30 as drawn");
        assert!(has_colour(frame_30, STRING) && has_colour(frame_30, HAMMER) && has_colour(frame_30, STRUCK));
        let png = dir.path().join("frame.png");
        anim.draw_frame_png(30, &png).unwrap();
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), Some((640, 360)));
        if let Some(samples) = samples_dir() {
            anim.draw_gif(&samples.join("animation.gif")).unwrap();
            anim.draw_frame_png(30, &samples.join("animation-frame30.png")).unwrap();
            anim.draw_frame_png(59, &samples.join("animation-frame59.png")).unwrap();
        }
    }

    #[test]
    fn the_scale_is_fixed_over_all_frames_and_long_animations_are_thinned() {
        let anim = strike(400);
        let plan = anim.plan().unwrap();
        // The hammer's highest point, at the end, is inside the fixed range.
        let top_mm = anim.frames.iter().filter_map(|f| f.hammer).map(|h| h.1 * 1e3).fold(f64::MIN, f64::max);
        assert!(plan.y.high > top_mm && plan.y.low < -1.0, "{:?}", plan.y);
        let (kept, delay_ms) = anim.kept_frames();
        assert_eq!(kept.len(), MAX_GIF_FRAMES);
        assert_eq!((kept[0], kept[MAX_GIF_FRAMES - 1]), (0, 399));
        assert!(kept.windows(2).all(|w| w[1] > w[0]));
        assert_eq!(delay_ms, (50.0f64 * 399.0 / 149.0).round() as u32);
    }

    #[test]
    fn bad_frames_are_errors_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let gif = dir.path().join("bad.gif");
        let mut anim = strike(3);
        anim.frames[1].string_y_m.pop();
        let error = anim.draw_gif(&gif).unwrap_err();
        assert!(error.to_string().contains("bad.gif") && error.to_string().contains("frame 1"), "{error}");
        let error = Animation::new("", vec![]).draw_gif(&gif).unwrap_err();
        assert!(error.to_string().contains("needs frames"), "{error}");
        let missing = dir.path().join("nowhere").join("strike.gif");
        let error = strike(3).draw_gif(&missing).unwrap_err();
        assert!(matches!(error, PlotError::Write { .. }) && error.to_string().contains("strike.gif"), "{error}");
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "nothing written");
    }

    #[test]
    fn a_write_error_of_the_gif_backend_reads_as_the_system_words_it() {
        let full = std::io::Error::from_raw_os_error(27);
        let words = full.to_string();
        assert_eq!(gif_error(&GifError::GifEncodingError(gif::EncodingError::Io(full))), words);
    }

    #[test]
    fn exaggeration_is_rounded_to_two_figures() {
        assert_eq!(two_figures(1234.0), 1200.0);
        assert_eq!(plain(two_figures(87.6)), "88");
        assert_eq!(time_label(0.00125), "t = 1.250 ms");
    }
}
