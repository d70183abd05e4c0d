//! Colour-shaded grids with a colour bar: the hammer design charts of Figs
//! 15-22 (contact time, number of contacts and spectral centroid over hammer
//! mass and stiffness), with markers for the nominal hammer and the piano's
//! C strings.

use std::fmt::Write as _;
use std::path::Path;

use plotters::coord::Shift;
use plotters::prelude::*;
use plotters::style::FontTransform;
use plotters::style::text_anchor::{HPos, Pos, VPos};

use super::axis::{Axis, LABELS, Scale};
use super::frame::{self, Key, Layout, Paint, draw_markers, set_legend};
use super::typeset::Typeset;
use super::{CHART_SIZE_PX, Colour, Corner, FONT, MarkerShape, PlotError, ensure_fonts, fail, write_atomically};

/// How a cell's value becomes its colour.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum ColourMap {
    /// A continuous scale from black through red and yellow to white (like
    /// Matlab's "hot"), low to high: Fig 15's contact time, Fig 17's
    /// spectral centroid.
    #[default]
    Hot,
    /// Whole numbers of events, each its own colour: 1 white, then 2 yellow,
    /// 3 orange, 4 red, 5 magenta, 6 blue, 7 cyan, 8 green, 9 brown, 10 and
    /// more dark grey, 0 black (Fig 16: "in the white region there is only a
    /// single contact"). Values are rounded to the nearest whole number.
    Counts,
}

/// The colour of "no data" (a cell whose value is not finite).
const NO_DATA: Colour = Colour::GREY;

/// Colours of the counts 0 to 9; 10 and more are [`MANY`].
const COUNT_COLOURS: [Colour; 10] = [
    Colour(0, 0, 0),
    Colour(255, 255, 255),
    Colour(255, 225, 60),
    Colour(250, 140, 20),
    Colour(215, 35, 35),
    Colour(190, 50, 180),
    Colour(50, 90, 220),
    Colour(40, 190, 215),
    Colour(50, 160, 70),
    Colour(130, 80, 40),
];
const MANY: Colour = Colour(70, 70, 70);
/// The count from which all share one colour.
const MANY_FROM: i64 = 10;

/// The "hot" colour at `t` from 0 (black-red) to 1 (white).
pub fn hot(t: f64) -> Colour {
    let t = t.clamp(0.0, 1.0);
    let ramp = |from: f64, to: f64| ((t - from) / (to - from)).clamp(0.0, 1.0);
    let r = 0.05 + 0.95 * ramp(0.0, 0.375);
    let (g, b) = (ramp(0.375, 0.75), ramp(0.75, 1.0));
    let byte = |v: f64| (255.0 * v).round() as u8;
    Colour(byte(r), byte(g), byte(b))
}

fn count_colour(count: i64) -> Colour {
    if count >= MANY_FROM { MANY } else { COUNT_COLOURS[count.max(0) as usize] }
}

/// A point marked on a heatmap.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Marker {
    /// Its legend entry; markers with the same label, shape and colour share
    /// one, and those with an empty label have none.
    pub label: String,
    /// Where it is, in the x axis's values.
    pub x: f64,
    /// Where it is, in the y axis's values.
    pub y: f64,
    /// Its shape (the seed's squares, stars and circles).
    pub shape: MarkerShape,
    /// Its fill; it is outlined in black.
    pub colour: Colour,
}

/// A grid of values shaded by colour, with a colour bar, and markers on top.
///
/// The cells are centred on `x` and `y` and meet halfway between centres
/// (halfway in the logarithm on a logarithmic axis, so that cells spaced
/// logarithmically are drawn equally wide); the outer cells are as wide as
/// their neighbours. The axes cover the cells exactly.
#[derive(Clone, Debug, PartialEq)]
pub struct Heatmap {
    /// Across the top; none if empty.
    pub title: String,
    /// Under the x axis, with its unit.
    pub x_label: String,
    /// Beside the y axis, with its unit.
    pub y_label: String,
    /// The cells' centres along x, increasing.
    pub x: Vec<f64>,
    /// The cells' centres along y, increasing.
    pub y: Vec<f64>,
    /// Linear or logarithmic (the cells spaced in the logarithm).
    pub x_scale: Scale,
    /// Linear or logarithmic (the cells spaced in the logarithm).
    pub y_scale: Scale,
    /// Row by row from the lowest y: the cell at `x[ix]`, `y[iy]` is
    /// `values[iy * x.len() + ix]`. NaN (or any value not finite) is "no
    /// data", drawn grey.
    pub values: Vec<f64>,
    /// Beside the colour bar, with its unit.
    pub colour_label: String,
    /// How values become colours.
    pub colour_map: ColourMap,
    /// The values at the ends of a [`ColourMap::Hot`] scale (beyond them the
    /// end colours); None spans the finite values.
    pub colour_range: Option<(f64, f64)>,
    /// Drawn over the cells, in order.
    pub markers: Vec<Marker>,
    /// Where the legend goes (there is one when a marker has a label, or a
    /// cell has no data).
    pub legend: Corner,
    /// The PNG's width and height.
    pub size_px: (u32, u32),
}

impl Default for Heatmap {
    fn default() -> Self {
        Self {
            title: String::new(),
            x_label: String::new(),
            y_label: String::new(),
            x: Vec::new(),
            y: Vec::new(),
            x_scale: Scale::Linear,
            y_scale: Scale::Linear,
            values: Vec::new(),
            colour_label: String::new(),
            colour_map: ColourMap::Hot,
            colour_range: None,
            markers: Vec::new(),
            legend: Corner::UpperRight,
            size_px: CHART_SIZE_PX,
        }
    }
}

/// What drawing a heatmap needs beyond its data, worked out before any file
/// is touched.
struct Plan {
    x: Axis,
    y: Axis,
    /// Cell edges in axis space, one more than the centres.
    x_edges: Vec<f64>,
    y_edges: Vec<f64>,
    scale: ColourScale,
}

/// The colour bar's scale.
enum ColourScale {
    /// Values from `low` to `high` across the "hot" colours.
    Continuous { low: f64, high: f64 },
    /// The counts shown, from `first` to `last` (the last may stand for
    /// "this many or more").
    Counts { first: i64, last: i64 },
}

impl ColourScale {
    fn colour(&self, value: f64) -> Colour {
        if !value.is_finite() {
            return NO_DATA;
        }
        match *self {
            ColourScale::Continuous { low, high } => hot((value - low) / (high - low)),
            ColourScale::Counts { .. } => count_colour(value.round() as i64),
        }
    }
}

impl Heatmap {
    /// Draw the heatmap into the PNG file `png` (written whatever its name's
    /// extension).
    pub fn draw(&self, png: &Path) -> Result<(), PlotError> {
        let plan = self.plan().map_err(|reason| PlotError::bad_data(png, reason))?;
        write_atomically(png, "png", |temporary| {
            ensure_fonts()?;
            let root = Typeset::new(BitMapBackend::new(temporary, self.size_px)).into_drawing_area();
            self.paint(&root, &plan)?;
            root.present().map_err(fail)
        })
    }

    /// Write the numbers behind the heatmap to `csv`: a header `x,y,value`,
    /// then one row a cell in the order of `values` (x varying fastest),
    /// each value as given (NaN where there is no data).
    pub fn write_csv(&self, csv: &Path) -> Result<(), PlotError> {
        self.check_shape().map_err(|reason| PlotError::bad_data(csv, reason))?;
        let mut text = String::from("x,y,value\n");
        for (i, value) in self.values.iter().enumerate() {
            let (x, y) = (self.x[i % self.x.len()], self.y[i / self.x.len()]);
            let _ = writeln!(text, "{x},{y},{value}");
        }
        super::write_text(csv, &text)
    }

    fn check_shape(&self) -> Result<(), String> {
        let (nx, ny) = (self.x.len(), self.y.len());
        if nx == 0 || ny == 0 {
            return Err(format!("a heatmap needs cells: {nx} x centres by {ny} y centres"));
        }
        if self.values.len() != nx * ny {
            return Err(format!("{} values for {nx} x by {ny} y cells (want {})", self.values.len(), nx * ny));
        }
        Ok(())
    }

    fn plan(&self) -> Result<Plan, String> {
        self.check_shape()?;
        let x_edges = edges(&self.x, self.x_scale, "x")?;
        let y_edges = edges(&self.y, self.y_scale, "y")?;
        let x = Axis { scale: self.x_scale, low: x_edges[0], high: x_edges[x_edges.len() - 1] };
        let y = Axis { scale: self.y_scale, low: y_edges[0], high: y_edges[y_edges.len() - 1] };
        let finite = || self.values.iter().copied().filter(|v| v.is_finite());
        let scale = match self.colour_map {
            ColourMap::Hot => {
                let (low, high) = match self.colour_range {
                    Some((low, high)) if low.is_finite() && high.is_finite() && low < high => (low, high),
                    Some((low, high)) => {
                        return Err(format!("colour range {low}..{high}: want finite ends, low below high"));
                    }
                    None => {
                        let low = finite().fold(f64::INFINITY, f64::min);
                        let high = finite().fold(f64::NEG_INFINITY, f64::max);
                        if low > high {
                            (0.0, 1.0)
                        } else if low == high {
                            (low - 0.5, high + 0.5)
                        } else {
                            (low, high)
                        }
                    }
                };
                ColourScale::Continuous { low, high }
            }
            ColourMap::Counts => {
                let counts = || finite().map(|v| (v.round() as i64).clamp(0, MANY_FROM));
                let first = counts().min().unwrap_or(1).min(1);
                let last = counts().max().unwrap_or(1).max(first + 1);
                ColourScale::Counts { first, last }
            }
        };
        Ok(Plan { x, y, x_edges, y_edges, scale })
    }

    fn paint<DB: DrawingBackend>(&self, root: &DrawingArea<DB, Shift>, plan: &Plan) -> Result<(), String> {
        let layout = Layout::CHART;
        let area = frame::titled(root, &self.title, &layout)?;
        let main = self.paint_colour_bar(&area, &plan.scale, &layout)?;
        let (x, y) = (&plan.x, &plan.y);
        let mut chart = frame::chart(&main, (x, y), (&self.x_label, &self.y_label), &layout)?;

        let nx = self.x.len();
        let cells = self.values.iter().enumerate().map(|(i, &value)| {
            let (ix, iy) = (i % nx, i / nx);
            let corners = [
                (x.value(plan.x_edges[ix]), y.value(plan.y_edges[iy])),
                (x.value(plan.x_edges[ix + 1]), y.value(plan.y_edges[iy + 1])),
            ];
            Rectangle::new(corners, plan.scale.colour(value).rgb().filled())
        });
        chart.draw_series(cells).map_err(fail)?;
        frame::draw_box(&chart)?;

        let radius_px = 7;
        // One legend entry for each label, shape and colour, in order of
        // first appearance.
        let mut groups: Vec<(&str, MarkerShape, Colour)> = Vec::new();
        for m in &self.markers {
            let group = (m.label.as_str(), m.shape, m.colour);
            if !groups.contains(&group) {
                groups.push(group);
            }
        }
        for &(label, shape, colour) in &groups {
            let members =
                self.markers.iter().filter(|m| (m.label.as_str(), m.shape, m.colour) == (label, shape, colour));
            let points = members
                .filter_map(|m| Some((x.place(m.x)?, y.place(m.y)?)))
                .filter(|&(a, b)| x.contains(a) && y.contains(b))
                .map(|(a, b)| (x.value(a), y.value(b)))
                .collect();
            let drawn = draw_markers(&mut chart, points, (shape, colour, radius_px, Paint::Solid))?;
            if !label.is_empty() {
                set_legend(drawn, label, Key::Marker(shape, colour, Paint::Solid), radius_px);
            }
        }
        let no_data = self.values.iter().any(|v| !v.is_finite());
        if no_data {
            let series = chart.draw_series(std::iter::empty::<Rectangle<(f64, f64)>>()).map_err(fail)?;
            set_legend(series, "no data", Key::Block(NO_DATA), radius_px);
        }
        if no_data || groups.iter().any(|g| !g.0.is_empty()) {
            frame::legend(&mut chart, self.legend, &layout)?;
        }
        Ok(())
    }

    /// The colour bar in a column on the right of `area`, level with the
    /// plot; the rest of `area`.
    fn paint_colour_bar<DB: DrawingBackend>(
        &self,
        area: &DrawingArea<DB, Shift>,
        scale: &ColourScale,
        layout: &Layout,
    ) -> Result<DrawingArea<DB, Shift>, String> {
        // The counts' ticks are plotters' linear ones at most one a count,
        // which over the blocks' edges are the whole numbers.
        let (axis, labels, tick_count): (Axis, Option<(i64, i64)>, usize) = match *scale {
            ColourScale::Continuous { low, high } => (Axis { scale: Scale::Linear, low, high }, None, LABELS),
            ColourScale::Counts { first, last } => {
                let axis = Axis { scale: Scale::Linear, low: first as f64 - 0.5, high: last as f64 + 0.5 };
                (axis, Some((first, last)), (last - first + 1) as usize)
            }
        };
        let continuous = axis.labeller();
        let tick = |c: &f64| match labels {
            None => continuous(c),
            Some((_, last)) if c.round() as i64 == last && last >= MANY_FROM => format!("{MANY_FROM}+"),
            Some(_) => format!("{}", c.round() as i64),
        };
        // The bar a fixed width; its tick labels, then its own label (read
        // upwards, like the y axis's) to the right.
        let tick_style = TextStyle::from((FONT, layout.tick_font).into_font());
        let mut widest_px = 0;
        for t in axis.coord().key_points(tick_count) {
            widest_px = widest_px.max(area.estimate_text_size(&tick(&t), &tick_style).map_err(fail)?.0);
        }
        let (bar_margin_left, bar_px, margin_right) = (14, 22, 6);
        let tick_area_px = widest_px + 14;
        let label_px = if self.colour_label.is_empty() { 0 } else { layout.label_font + 10 };
        let column_px = bar_margin_left + bar_px + tick_area_px + label_px + margin_right;
        let (width_px, _) = area.dim_in_pixel();
        let (main, column) = area.split_horizontally(width_px.saturating_sub(column_px));
        let mut bar = ChartBuilder::on(&column)
            .margin_top(layout.margin_top)
            .margin_bottom(layout.margin_bottom)
            .margin_left(bar_margin_left)
            .margin_right(margin_right + label_px)
            .x_label_area_size(layout.x_label_area)
            .right_y_label_area_size(tick_area_px)
            .build_cartesian_2d(0.0..1.0, axis.coord())
            .map_err(fail)?;
        bar.configure_mesh()
            .disable_mesh()
            .disable_x_axis()
            .y_labels(tick_count)
            .y_label_formatter(&tick)
            .label_style((FONT, layout.tick_font))
            .axis_desc_style((FONT, layout.label_font))
            .axis_style(BLACK)
            .set_all_tick_mark_size(5)
            .draw()
            .map_err(fail)?;
        match labels {
            None => {
                let steps = 256;
                let span = axis.high - axis.low;
                bar.draw_series((0..steps).map(|k| {
                    let (a, b) = (f64::from(k) / f64::from(steps), f64::from(k + 1) / f64::from(steps));
                    let colour = hot((a + b) / 2.0);
                    Rectangle::new([(0.0, axis.low + a * span), (1.0, axis.low + b * span)], colour.rgb().filled())
                }))
                .map_err(fail)?;
            }
            Some((first, last)) => {
                bar.draw_series((first..=last).map(|c| {
                    let corners = [(0.0, c as f64 - 0.5), (1.0, c as f64 + 0.5)];
                    Rectangle::new(corners, count_colour(c).rgb().filled())
                }))
                .map_err(fail)?;
                // Lines between the blocks, so that white stands apart.
                bar.draw_series(((first + 1)..=last).map(|c| {
                    PathElement::new(vec![(0.0, c as f64 - 0.5), (1.0, c as f64 - 0.5)], RGBColor(90, 90, 90))
                }))
                .map_err(fail)?;
            }
        }
        frame::draw_box(&bar)?;
        if !self.colour_label.is_empty() {
            let (x_px, y_px) = bar.plotting_area().get_pixel_range();
            let base = column.get_base_pixel();
            let at =
                (x_px.end - base.0 + tick_area_px as i32 + label_px as i32 / 2, (y_px.start + y_px.end) / 2 - base.1);
            let style = TextStyle::from((FONT, layout.label_font).into_font())
                .transform(FontTransform::Rotate270)
                .pos(Pos::new(HPos::Center, VPos::Center));
            column.draw_text(&self.colour_label, &style, at).map_err(fail)?;
        }
        Ok(main)
    }

    /// The heatmap drawn into an RGB buffer of `size_px` (for tests).
    #[cfg(test)]
    fn render_rgb(&self) -> Result<Vec<u8>, String> {
        ensure_fonts()?;
        let plan = self.plan()?;
        let (w, h) = self.size_px;
        let mut rgb = vec![0u8; (w * h * 3) as usize];
        {
            let root = Typeset::new(BitMapBackend::with_buffer(&mut rgb, self.size_px)).into_drawing_area();
            self.paint(&root, &plan)?;
            root.present().map_err(fail)?;
        }
        Ok(rgb)
    }
}

/// The edges of cells centred on `centres`, in axis space.
fn edges(centres: &[f64], scale: Scale, what: &str) -> Result<Vec<f64>, String> {
    let placed = centres.iter().map(|&c| scale.to_axis(c)).collect::<Option<Vec<f64>>>().ok_or_else(|| {
        let need = if scale == Scale::Log { "positive and finite on a logarithmic axis" } else { "finite" };
        format!("{what} centres must be {need}")
    })?;
    if placed.windows(2).any(|w| w[1] <= w[0]) {
        return Err(format!("{what} centres must increase"));
    }
    let n = placed.len();
    if n == 1 {
        return Ok(vec![placed[0] - 0.5, placed[0] + 0.5]);
    }
    let mut edges = Vec::with_capacity(n + 1);
    edges.push(placed[0] - (placed[1] - placed[0]) / 2.0);
    edges.extend(placed.windows(2).map(|w| (w[0] + w[1]) / 2.0));
    edges.push(placed[n - 1] + (placed[n - 1] - placed[n - 2]) / 2.0);
    Ok(edges)
}

#[cfg(test)]
mod tests {
    use super::super::test_support::{distinct_colours, has_colour, png_size, samples_dir};
    use super::*;

    /// A design chart like Fig 15/18: a smooth field over log-spaced mass and
    /// stiffness, with a nominal hammer and eight C strings marked.
    fn design_chart(map: ColourMap) -> Heatmap {
        let (nx, ny) = (60, 50);
        let x: Vec<f64> = (0..nx).map(|i| 10f64.powf(-2.0 + 3.0 * f64::from(i) / f64::from(nx - 1))).collect();
        let y: Vec<f64> = (0..ny).map(|j| 10f64.powf(-1.0 + 4.0 * f64::from(j) / f64::from(ny - 1))).collect();
        let mut values = Vec::with_capacity(x.len() * y.len());
        for &k in &y {
            for &m in &x {
                let periods = (m / k).sqrt() * 3.0;
                values.push(match map {
                    ColourMap::Hot => periods,
                    ColourMap::Counts => 1.0 + ((m * k).log10() + 2.0).max(0.0).floor(),
                });
            }
        }
        // A patch where the simulation failed.
        for iy in 20..24 {
            for ix in 30..36 {
                values[iy * nx as usize + ix] = f64::NAN;
            }
        }
        let mut markers: Vec<Marker> = (1..=8)
            .map(|n| Marker {
                label: "C1-C8, identical hammers".into(),
                x: 0.02 * 2f64.powi(n - 1),
                y: 0.3 * 1.6f64.powi(n - 1),
                shape: MarkerShape::Square,
                colour: Colour::CYAN,
            })
            .collect();
        markers.extend((1..=8).map(|n| Marker {
            label: "C1-C8, actual masses".into(),
            x: 0.025 * 1.8f64.powi(n - 1),
            y: 0.3 * 1.6f64.powi(n - 1),
            shape: MarkerShape::Star,
            colour: Colour::CYAN,
        }));
        markers.push(Marker {
            label: "C4 hammer".into(),
            x: 0.3,
            y: 10.0,
            shape: MarkerShape::Circle,
            colour: Colour::GREEN,
        });
        Heatmap {
            title: "Contact time, normalised".into(),
            x_label: "hammer mass / string mass".into(),
            y_label: "K / (T / L)".into(),
            x,
            y,
            x_scale: Scale::Log,
            y_scale: Scale::Log,
            values,
            colour_label: match map {
                ColourMap::Hot => "contact time (periods)".into(),
                ColourMap::Counts => "number of contacts".into(),
            },
            colour_map: map,
            markers,
            legend: Corner::LowerRight,
            ..Heatmap::default()
        }
    }

    #[test]
    fn a_heatmap_draws_its_cells_no_data_markers_and_colour_bar() {
        let map = design_chart(ColourMap::Hot);
        let rgb = map.render_rgb().unwrap();
        assert!(has_colour(&rgb, NO_DATA), "NaN cells are grey");
        assert!(has_colour(&rgb, Colour::CYAN), "the markers are drawn");
        assert!(has_colour(&rgb, hot(1.0)) && has_colour(&rgb, hot(0.0)), "both ends of the colour bar");
        assert!(distinct_colours(&rgb) > 200, "a continuous shading");
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("time.png");
        map.draw(&png).unwrap();
        assert_eq!(png_size(&std::fs::read(&png).unwrap()), Some(CHART_SIZE_PX));
        if let Some(samples) = samples_dir() {
            map.draw(&samples.join("heatmap-hot.png")).unwrap();
        }
    }

    #[test]
    fn counts_are_white_for_one_and_distinct_above() {
        let map = design_chart(ColourMap::Counts);
        let rgb = map.render_rgb().unwrap();
        for count in 1..=4 {
            assert!(has_colour(&rgb, count_colour(count)), "count {count}");
        }
        let colours: Vec<Colour> = (0..=MANY_FROM).map(count_colour).collect();
        for (i, a) in colours.iter().enumerate() {
            assert!(colours[i + 1..].iter().all(|b| b != a), "count {i} has a colour of its own");
        }
        if let Some(samples) = samples_dir() {
            map.draw(&samples.join("heatmap-counts.png")).unwrap();
            let linear = Heatmap {
                title: "Contact time, C4".into(),
                x: (1..=40).map(|i| f64::from(i) * 0.5).collect(),
                x_scale: Scale::Linear,
                x_label: "hammer mass (g)".into(),
                y_label: "K (N/m^2.5)".into(),
                colour_label: "contact time (ms)".into(),
                markers: vec![Marker {
                    label: "nominal C4 hammer".into(),
                    x: 8.7,
                    y: 4.0,
                    shape: MarkerShape::Star,
                    colour: Colour::CYAN,
                }],
                values: (0..40 * 50).map(|i| f64::from(i % 40) * 0.1 + f64::from(i / 40) * 0.02).collect(),
                colour_range: Some((0.0, 5.0)),
                legend: Corner::UpperLeft,
                ..design_chart(ColourMap::Hot)
            };
            linear.draw(&samples.join("heatmap-linear.png")).unwrap();
        }
    }

    #[test]
    fn csv_has_one_row_a_cell_x_fastest() {
        let dir = tempfile::tempdir().unwrap();
        let map = Heatmap {
            x: vec![1.0, 2.0, 3.0],
            y: vec![10.0, 20.0],
            values: vec![1.0, 2.0, 3.0, 4.0, f64::NAN, 6.0],
            ..Heatmap::default()
        };
        let csv = dir.path().join("cells.csv");
        map.write_csv(&csv).unwrap();
        let text = std::fs::read_to_string(&csv).unwrap();
        assert_eq!(text, "x,y,value\n1,10,1\n2,10,2\n3,10,3\n1,20,4\n2,20,NaN\n3,20,6\n");
    }

    #[test]
    fn log_cells_are_equally_wide_in_the_logarithm() {
        let e = edges(&[1.0, 10.0, 100.0], Scale::Log, "x").unwrap();
        let want = [-0.5, 0.5, 1.5, 2.5];
        assert!(e.iter().zip(want).all(|(a, b)| (a - b).abs() < 1e-12), "{e:?}");
        assert!(edges(&[1.0, 0.0], Scale::Log, "x").unwrap_err().contains("positive"));
        assert!(edges(&[2.0, 1.0], Scale::Linear, "y").unwrap_err().contains("increase"));
    }

    #[test]
    fn mismatched_values_are_an_error_naming_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let png = dir.path().join("bad.png");
        let map = Heatmap { x: vec![1.0, 2.0], y: vec![1.0, 2.0], values: vec![0.0; 3], ..Heatmap::default() };
        let error = map.draw(&png).unwrap_err();
        assert!(error.to_string().contains("bad.png") && error.to_string().contains("3 values"), "{error}");
        assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "nothing written");
    }
}
