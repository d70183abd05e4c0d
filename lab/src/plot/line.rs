//! Curves and data points on linear or logarithmic axes: force pulses and
//! their spectra (Figs 3-5, 12-14, 26, 33-35), the piano's string table
//! (Figs 8-10) and the clavichord's tuning, tangent and damping (Figs 29-31).

use std::fmt::Write as _;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axis::{Axis, Scale, clip_polyline};
use super::frame::{self, Key, Layout, Paint, draw_markers, set_legend};
use super::typeset::Typeset;
use super::{CHART_SIZE_PX, Colour, Corner, MarkerShape, PlotError, csv_field, ensure_fonts, fail, write_atomically};

/// How a series is drawn.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum SeriesStyle {
    /// Its points joined by a line, broken where a point cannot be placed
    /// (not finite, or not positive on a logarithmic axis).
    #[default]
    Line,
    /// A marker at each point.
    Markers(MarkerShape),
    /// Its points joined by a line, with a marker at each.
    LineAndMarkers(MarkerShape),
}

/// One curve or set of data points.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Series {
    /// Its name in the legend; a series with an empty label has no entry.
    pub label: String,
    /// Its colour.
    pub colour: Colour,
    /// Its points as (x, y), in the order they are joined.
    pub points: Vec<(f64, f64)>,
    /// Line, markers or both.
    pub style: SeriesStyle,
}

impl Series {
    /// A curve through `points`.
    pub fn line(label: impl Into<String>, colour: Colour, points: Vec<(f64, f64)>) -> Self {
        Self { label: label.into(), colour, points, style: SeriesStyle::Line }
    }

    /// A marker of `shape` at each of `points`.
    pub fn markers(label: impl Into<String>, colour: Colour, shape: MarkerShape, points: Vec<(f64, f64)>) -> Self {
        Self { label: label.into(), colour, points, style: SeriesStyle::Markers(shape) }
    }
}

/// A chart of curves and data points.
///
/// Axes without a range cover the data that can be placed on them, with 4%
/// to spare at each end; points outside a given range are cut off at the
/// plot's edge. A dB axis is the caller's: pass the levels in dB on a linear
/// axis.
#[derive(Clone, Debug, PartialEq)]
pub struct LinePlot {
    /// Across the top; none if empty.
    pub title: String,
    /// Under the x axis, with its unit.
    pub x_label: String,
    /// Beside the y axis, with its unit.
    pub y_label: String,
    /// Linear or logarithmic.
    pub x_scale: Scale,
    /// Linear or logarithmic.
    pub y_scale: Scale,
    /// The x axis's extent (low, high) in values; None fits the data.
    pub x_range: Option<(f64, f64)>,
    /// The y axis's extent (low, high) in values; None fits the data.
    pub y_range: Option<(f64, f64)>,
    /// Drawn in order, the first underneath.
    pub series: Vec<Series>,
    /// Where the legend goes (there is one when any series has a label).
    pub legend: Corner,
    /// The PNG's width and height.
    pub size_px: (u32, u32),
}

impl Default for LinePlot {
    fn default() -> Self {
        Self {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            x_range: None,
            y_range: None,
            series: Vec::new(),
            legend: Corner::UpperRight,
            size_px: CHART_SIZE_PX,
        }
    }
}

impl LinePlot {
    /// An empty chart on linear axes.
    pub fn new(title: impl Into<String>, x_label: impl Into<String>, y_label: impl Into<String>) -> Self {
        Self { title: title.into(), x_label: x_label.into(), y_label: y_label.into(), ..Self::default() }
    }

    /// Draw the chart into the PNG file `png` (written whatever its name's
    /// extension).
    pub fn draw(&self, png: &Path) -> Result<(), PlotError> {
        let axes = self.axes().map_err(|reason| PlotError::bad_data(png, reason))?;
        write_atomically(png, "png", |temporary| {
            ensure_fonts()?;
            let root = Typeset::new(BitMapBackend::new(temporary, self.size_px)).into_drawing_area();
            self.paint(&root, &axes)?;
            root.present().map_err(fail)
        })
    }

    /// Write the numbers behind the chart to `csv`, one row a point in the
    /// tidy layout `series,x,y` (a header first; a series is named by its
    /// label, or `series N` counting from 1 when it has none; every point is
    /// written, including those the chart cannot place).
    pub fn write_csv(&self, csv: &Path) -> Result<(), PlotError> {
        let mut text = String::from("series,x,y\n");
        for (i, series) in self.series.iter().enumerate() {
            let name = if series.label.is_empty() { format!("series {}", i + 1) } else { csv_field(&series.label) };
            for (x, y) in &series.points {
                let _ = writeln!(text, "{name},{x},{y}");
            }
        }
        super::write_text(csv, &text)
    }

    fn axes(&self) -> Result<(Axis, Axis), String> {
        let xs = self.series.iter().flat_map(|s| s.points.iter().map(|p| p.0));
        let ys = self.series.iter().flat_map(|s| s.points.iter().map(|p| p.1));
        Ok((
            Axis::fit(self.x_scale, self.x_range, xs, true, "x")?,
            Axis::fit(self.y_scale, self.y_range, ys, true, "y")?,
        ))
    }

    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, (x, y): &(Axis, Axis)) -> Result<(), String> {
        let layout = Layout::CHART;
        let area = frame::titled(root, &self.title, &layout)?;
        let mut chart = frame::chart(&area, (x, y), (&self.x_label, &self.y_label), &layout)?;
        let (x_extent, y_extent) = (x.range(), y.range());
        let radius_px = 5;
        for series in &self.series {
            let placed: Vec<Option<(f64, f64)>> =
                series.points.iter().map(|&(a, b)| Some((x.place(a)?, y.place(b)?))).collect();
            let colour = series.colour;
            let (line, shape) = match series.style {
                SeriesStyle::Line => (true, None),
                SeriesStyle::Markers(shape) => (false, Some(shape)),
                SeriesStyle::LineAndMarkers(shape) => (true, Some(shape)),
            };
            let key = match (line, shape) {
                (true, Some(shape)) => Key::LineAndMarker(shape, colour),
                (false, Some(shape)) => Key::Marker(shape, colour, Paint::Outline),
                _ => Key::Line(colour),
            };
            // One draw call carries the legend entry: the line's, or the
            // markers' when there is no line.
            let label = series.label.as_str();
            if line {
                let style = colour.rgb().stroke_width(2);
                let runs = clip_polyline(&placed, &x_extent, &y_extent);
                let paths = runs.into_iter().map(|run| {
                    PathElement::new(run.into_iter().map(|(a, b)| (x.value(a), y.value(b))).collect::<Vec<_>>(), style)
                });
                let drawn = chart.draw_series(paths).map_err(fail)?;
                if !label.is_empty() {
                    set_legend(drawn, label, key, radius_px);
                }
            }
            if let Some(shape) = shape {
                let inside = placed.iter().flatten().filter(|(a, b)| x.contains(*a) && y.contains(*b));
                let points = inside.map(|&(a, b)| (x.value(a), y.value(b))).collect();
                let drawn = draw_markers(&mut chart, points, (shape, colour, radius_px, Paint::Outline))?;
                if !line && !label.is_empty() {
                    set_legend(drawn, label, key, radius_px);
                }
            }
        }
        if self.series.iter().any(|s| !s.label.is_empty()) {
            frame::legend(&mut chart, self.legend, &layout)?;
        }
        Ok(())
    }

    /// The chart drawn into an RGB buffer of `size_px` (for tests).
    #[cfg(test)]
    fn render_rgb(&self) -> Result<Vec<u8>, String> {
        ensure_fonts()?;
        let axes = self.axes()?;
        let (w, h) = self.size_px;
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        {
            let root = Typeset::new(BitMapBackend::with_buffer(&mut rgb, self.size_px)).into_drawing_area();
            self.paint(&root, &axes)?;
            root.present().map_err(fail)?;
        }
        Ok(rgb)
    }
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{dark_pixels, distinct_colours, has_colour, png_size, samples_dir};
    use super::*;

    /// Something like Fig 3: a force pulse with jumps and a precursor wiggle.
    fn pulse() -> Vec<(f64, f64)> {
        (0..=400)
            .map(|i| {
                let t_ms = f64::from(i) * 0.005;
                let f = if t_ms < 1.6 { 20.0 * (1.0 - 0.3 * t_ms) + 8.0 * (t_ms > 0.8) as i32 as f64 } else { 0.0 };
                (t_ms, f + (40.0 * t_ms).sin() * 0.5)
            })
            .collect()
    }

    /// Something like Fig 4: two spectra over four decades of frequency, in dB.
    fn spectra() -> LinePlot {
        let spectrum = |offset: f64, peaks: bool| -> Vec<(f64, f64)> {
            (0..2000)
                .map(|i| {
                    let f = 10.0 * 1.004f64.powi(i);
                    let peak = if peaks { 25.0 * (f / 261.6 * std::f64::consts::PI).sin().abs().powi(40) } else { 0.0 };
                    (f, offset - 20.0 * (1.0 + (f / 800.0).powi(2)).log10() + peak)
                })
                .collect()
        };
        LinePlot {
            x_scale: Scale::Log,
            series: vec![
                Series::line("contact force", Colour::RED, spectrum(0.0, false)),
                Series::line("bridge force", Colour::BLUE, spectrum(-20.0, true)),
            ],
            ..LinePlot::new("Spectra of the contact and bridge forces", "frequency (Hz)", "level (dB re 1 N)")
        }
    }

    #[test]
    fn a_line_plot_draws_a_png_of_its_size_with_its_curves_and_text() {
        let dir = tempfile::tempdir().unwrap();
        let plot = LinePlot {
            series: vec![Series::line("x = 2/5", Colour::RED, pulse())],
            ..LinePlot::new("Contact force, 1 g hammer", "time (ms)", "force (N)")
        };
        let png = dir.path().join("pulse.png");
        plot.draw(&png).unwrap();
        let bytes = std::fs::read(&png).unwrap();
        assert_eq!(png_size(&bytes), Some(CHART_SIZE_PX));
        // A blank 900 x 560 PNG compresses to a few hundred bytes.
        assert!(bytes.len() > 10_000, "{} bytes", bytes.len());

        let rgb = plot.render_rgb().unwrap();
        assert!(has_colour(&rgb, Colour::RED), "the curve is drawn");
        assert!(distinct_colours(&rgb) > 50, "anti-aliased text and grid");
        let (w, _) = CHART_SIZE_PX;
        assert!(dark_pixels(&rgb, w, (250, 650), (0, 36)) > 100, "the title is set");
        assert!(dark_pixels(&rgb, w, (0, 40), (100, 460)) > 50, "the y label is set");
        // Only what was drawn in the temporary's place is left.
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["pulse.png"]);
        if let Some(samples) = samples_dir() {
            plot.draw(&samples.join("line-pulse.png")).unwrap();
            let small = LinePlot {
                series: vec![Series::line(
                    "",
                    Colour::BLUE,
                    pulse().into_iter().map(|(t, f)| (t, -1.234e-6 * f)).collect(),
                )],
                ..LinePlot::new("Wide tick labels", "time (ms)", "displacement (m)")
            };
            small.draw(&samples.join("line-wide-ticks.png")).unwrap();
        }
    }

    #[test]
    fn log_axes_take_data_over_decades_and_leave_out_what_they_cannot_place() {
        let mut plot = spectra();
        // A zero-frequency point and a negative level on a log-log chart.
        plot.series[0].points.insert(0, (0.0, 0.0));
        plot.y_scale = Scale::Log;
        for series in &mut plot.series {
            for p in &mut series.points {
                p.1 = 10f64.powf(p.1 / 20.0);
            }
        }
        plot.series[1].points.push((5000.0, -1.0));
        let (x, y) = plot.axes().unwrap();
        assert!(x.low < 1.01 && x.high > 4.3, "10 Hz to 30 kHz: {x:?}");
        assert!(y.high - y.low > 2.0, "levels over decades: {y:?}");
        let rgb = plot.render_rgb().unwrap();
        assert!(has_colour(&rgb, Colour::RED) && has_colour(&rgb, Colour::BLUE));
        if let Some(samples) = samples_dir() {
            plot.draw(&samples.join("line-loglog.png")).unwrap();
            spectra().draw(&samples.join("line-spectra.png")).unwrap();
        }
    }

    #[test]
    fn markers_and_fixed_ranges_are_drawn() {
        // Like Fig 31: measured Q factors as markers, models as lines.
        let measured = |scale: f64| -> Vec<(f64, f64)> {
            (1..40)
                .map(|n| {
                    (
                        73.4 * f64::from(n),
                        scale * (200.0 + 40.0 * f64::from(n)) * (1.0 + 0.3 * (f64::from(n) * 1.7).sin()),
                    )
                })
                .collect()
        };
        let model = |scale: f64| -> Vec<(f64, f64)> {
            (1..40).map(|n| (73.4 * f64::from(n), scale * (200.0 + 40.0 * f64::from(n)))).collect()
        };
        let plot = LinePlot {
            x_scale: Scale::Log,
            y_scale: Scale::Log,
            x_range: Some((50.0, 5000.0)),
            y_range: Some((100.0, 3000.0)),
            legend: Corner::LowerRight,
            series: vec![
                Series::markers("clavichord, measured", Colour::RED, MarkerShape::Star, measured(0.6)),
                Series::markers("harpsichord, measured", Colour::BLUE, MarkerShape::Circle, measured(1.0)),
                Series::line("clavichord, model", Colour::RED, model(0.6)),
                Series::line("harpsichord, model", Colour::BLUE, model(1.0)),
                Series {
                    style: SeriesStyle::LineAndMarkers(MarkerShape::Square),
                    ..Series::line("", Colour::GREEN, vec![(100.0, 150.0), (8000.0, 9000.0)])
                },
            ],
            ..LinePlot::new("Q factors of a D2 string", "frequency (Hz)", "Q factor")
        };
        let rgb = plot.render_rgb().unwrap();
        assert!(has_colour(&rgb, Colour::GREEN), "the line running out of the frame is drawn up to its edge");
        if let Some(samples) = samples_dir() {
            plot.draw(&samples.join("line-markers.png")).unwrap();
            // Like Fig 9: tension along the keyboard, one series a string group.
            let group = |notes: std::ops::Range<i32>, base: f64| -> Vec<(f64, f64)> {
                notes.map(|n| (f64::from(n), base + 300.0 * f64::from(n % 7) / 7.0)).collect()
            };
            let tension = LinePlot {
                series: vec![
                    Series {
                        style: SeriesStyle::LineAndMarkers(MarkerShape::Circle),
                        ..Series::line("single", Colour::RED, group(1..18, 1000.0))
                    },
                    Series {
                        style: SeriesStyle::LineAndMarkers(MarkerShape::Square),
                        ..Series::line("pairs", Colour::BLUE, group(18..31, 800.0))
                    },
                    Series {
                        style: SeriesStyle::LineAndMarkers(MarkerShape::Diamond),
                        ..Series::line(
                            "triplets (C strings)",
                            Colour::GREEN,
                            (0..6).map(|k| (f64::from(31 + 12 * k), 650.0)).collect(),
                        )
                    },
                ],
                y_range: Some((0.0, 1500.0)),
                legend: Corner::LowerLeft,
                ..LinePlot::new("String tensions", "note number", "tension (N)")
            };
            tension.draw(&samples.join("line-and-markers.png")).unwrap();
        }
    }

    #[test]
    fn csv_holds_every_point_under_its_series() {
        let dir = tempfile::tempdir().unwrap();
        let plot = LinePlot {
            series: vec![
                Series::line("speed 1, \"gentle\"", Colour::GREEN, vec![(0.0, 1.0), (1.0, 2.5)]),
                Series::line("", Colour::BLACK, vec![(0.5, f64::NAN)]),
            ],
            ..LinePlot::default()
        };
        let csv = dir.path().join("pulses.csv");
        plot.write_csv(&csv).unwrap();
        let text = std::fs::read_to_string(&csv).unwrap();
        assert_eq!(
            text,
            "series,x,y\n\"speed 1, \"\"gentle\"\"\",0,1\n\"speed 1, \"\"gentle\"\"\",1,2.5\nseries 2,0.5,NaN\n"
        );
    }

    #[test]
    fn a_bad_path_or_bad_range_is_an_error_naming_the_file_and_writes_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let plot = spectra();
        let missing = dir.path().join("no-such-folder").join("spectra.png");
        let error = plot.draw(&missing).unwrap_err();
        assert!(matches!(error, PlotError::Write { .. }));
        assert!(error.to_string().contains(&missing.display().to_string()), "{error}");
        let error = plot.write_csv(&missing.with_extension("csv")).unwrap_err();
        assert!(error.to_string().contains("spectra.csv"), "{error}");

        // An existing chart survives a failed redraw.
        let png = dir.path().join("spectra.png");
        std::fs::write(&png, b"the old chart").unwrap();
        let bad = LinePlot { x_range: Some((0.0, 100.0)), ..spectra() };
        let error = bad.draw(&png).unwrap_err();
        assert!(matches!(error, PlotError::BadData { .. }) && error.to_string().contains("positive"), "{error}");
        assert_eq!(std::fs::read(&png).unwrap(), b"the old chart");
        let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
        assert_eq!(names, ["spectra.png"]);
    }

    #[test]
    fn an_empty_chart_still_draws() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("empty.png");
        LinePlot { y_scale: Scale::Log, ..LinePlot::new("", "x", "y") }.draw(&png).unwrap();
        assert!(png_size(&std::fs::read(&png).unwrap()).is_some());
    }
}
