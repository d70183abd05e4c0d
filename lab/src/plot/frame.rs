//! What every chart shares: the title, the axes (plotters' mesh, with its
//! ticks, light grid and labels), the box round the plot, the markers
//! (plotters' elements composed at a point) and the legend.

use std::f64::consts::PI;

use plotters::chart::SeriesAnno;
use plotters::coord::{CoordTranslate, Shift};
use plotters::prelude::*;

use super::axis::{Axis, Coord, LABELS};
use super::{Colour, Corner, FONT, MarkerShape, fail};

/// A chart's coordinates: plotters' linear or logarithmic axes, in values.
pub type Coords = Cartesian2d<Coord, Coord>;

/// Sizes of a chart's parts, in pixels.
#[derive(Clone, Copy, Debug)]
pub struct Layout {
    pub title_font: u32,
    pub label_font: u32,
    pub tick_font: u32,
    pub legend_font: u32,
    pub margin_top: u32,
    pub margin_right: u32,
    pub margin_left: u32,
    pub margin_bottom: u32,
    /// Under the plot: tick labels and the x label.
    pub x_label_area: u32,
    /// Left of the plot: tick labels and the y label (at least; more when
    /// the tick labels are wide).
    pub y_label_area: u32,
    /// How opaque the legend's white background is, from 0 to 1.
    pub legend_opacity: f64,
}

impl Layout {
    /// For a chart about 900 by 560.
    pub const CHART: Layout = Layout {
        title_font: 26,
        label_font: 21,
        tick_font: 18,
        legend_font: 18,
        margin_top: 10,
        margin_right: 28,
        margin_left: 10,
        margin_bottom: 8,
        x_label_area: 62,
        y_label_area: 92,
        legend_opacity: 0.88,
    };

    /// For an animation about 640 by 360, its legend opaque (what shows
    /// through would add colours to the frame: see `Typeset`).
    pub const SMALL: Layout = Layout {
        title_font: 20,
        label_font: 16,
        tick_font: 14,
        legend_font: 14,
        margin_top: 6,
        margin_right: 20,
        margin_left: 6,
        margin_bottom: 4,
        x_label_area: 46,
        y_label_area: 70,
        legend_opacity: 1.0,
    };
}

/// Fill `root` white and set `title` across its top; the rest of it.
pub fn titled<DB: DrawingBackend>(
    root: &DrawingArea<DB, Shift>,
    title: &str,
    layout: &Layout,
) -> Result<DrawingArea<DB, Shift>, String> {
    root.fill(&WHITE).map_err(fail)?;
    if title.is_empty() {
        return Ok(root.clone());
    }
    let area = root.titled(title, (FONT, layout.title_font)).map_err(fail)?;
    // A little air between the title and the plot.
    Ok(area.margin(4, 0, 0, 0))
}

/// The chart on `area` for axes `x` and `y`, with its grid, ticks, labels and
/// box drawn.
pub fn chart<'a, DB: DrawingBackend>(
    area: &'a DrawingArea<DB, Shift>,
    (x, y): (&Axis, &Axis),
    (x_label, y_label): (&str, &str),
    layout: &Layout,
) -> Result<ChartContext<'a, DB, Coords>, String> {
    // Room left of the plot for the widest tick label and the y label.
    let tick_style = TextStyle::from((FONT, layout.tick_font).into_font());
    let (x_tick, y_tick) = (x.labeller(), y.labeller());
    let mut widest_px = 0;
    for value in y.ticks() {
        widest_px = widest_px.max(area.estimate_text_size(&y_tick(&value), &tick_style).map_err(fail)?.0);
    }
    let y_label_area = layout.y_label_area.max(widest_px + 5 + 8 + layout.label_font + 12);
    let mut chart = ChartBuilder::on(area)
        .margin_top(layout.margin_top)
        .margin_right(layout.margin_right)
        .margin_left(layout.margin_left)
        .margin_bottom(layout.margin_bottom)
        .x_label_area_size(layout.x_label_area)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x.coord(), y.coord())
        .map_err(fail)?;
    // Ten light lines a label on a logarithmic axis, for 2-9 times each power
    // of ten; four on a linear one.
    let light = |axis: &Axis| if axis.scale == super::Scale::Log { 10 } else { 4 };
    chart
        .configure_mesh()
        .x_labels(LABELS)
        .y_labels(LABELS)
        .x_max_light_lines(light(x))
        .y_max_light_lines(light(y))
        .x_desc(x_label)
        .y_desc(y_label)
        .x_label_formatter(&x_tick)
        .y_label_formatter(&y_tick)
        .label_style((FONT, layout.tick_font))
        .axis_desc_style((FONT, layout.label_font))
        .bold_line_style(RGBColor(212, 212, 212))
        .light_line_style(RGBColor(238, 238, 238))
        .axis_style(BLACK)
        .set_all_tick_mark_size(5)
        .draw()
        .map_err(fail)?;
    draw_box(&chart)?;
    Ok(chart)
}

/// A black box round the plot (plotters draws only the left and bottom axes).
pub fn draw_box<DB: DrawingBackend, C: CoordTranslate>(chart: &ChartContext<'_, DB, C>) -> Result<(), String> {
    let plot = chart.plotting_area().strip_coord_spec();
    let (w, h) = plot.dim_in_pixel();
    plot.draw(&Rectangle::new([(0, 0), (w as i32 - 1, h as i32 - 1)], BLACK.stroke_width(1))).map_err(fail)
}

/// The legend of the labelled series, in `corner`.
pub fn legend<'a, DB: DrawingBackend + 'a>(
    chart: &mut ChartContext<'a, DB, Coords>,
    corner: Corner,
    layout: &Layout,
) -> Result<(), String> {
    chart
        .configure_series_labels()
        .position(corner.position())
        .margin(10)
        .legend_area_size(34)
        .label_font((FONT, layout.legend_font))
        .background_style(WHITE.mix(layout.legend_opacity))
        .border_style(RGBColor(120, 120, 120))
        .draw()
        .map_err(fail)
}

/// How a marker is painted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Paint {
    /// Its outline in its colour (a line plot's data points).
    Outline,
    /// Filled with its colour and outlined in black, to stand out on any
    /// background (markers on a heatmap or an animation).
    Solid,
}

/// Evaluate `$then` with `$make` bound to a closure making a marker of
/// `$shape` at a point, `$radius_px` from its centre to its outer points:
/// plotters' elements (`Circle`, `Cross`, `TriangleMarker`, `Rectangle`,
/// `Polygon`, `PathElement`) composed on an `EmptyElement`, so that the same
/// marker is drawn on a chart and in its legend. (A macro, as each shape is
/// an element of its own type.)
macro_rules! with_marker {
    ($shape:expr, $colour:expr, $radius_px:expr, $paint:expr, |$make:ident| $then:expr) => {{
        let (r, rgb): (i32, RGBColor) = ($radius_px, $colour.rgb());
        let solid = $paint == Paint::Solid;
        let fill = if solid { rgb.filled() } else { TRANSPARENT.filled() };
        let edge = if solid { BLACK.stroke_width(1) } else { rgb.stroke_width(2) };
        match $shape {
            MarkerShape::Circle => {
                let $make =
                    move |at| EmptyElement::at(at) + Circle::new((0, 0), r, fill) + Circle::new((0, 0), r, edge);
                $then
            }
            MarkerShape::Cross => {
                let arm = (f64::from(r) * 0.8).round() as i32;
                let under = if solid { BLACK.stroke_width(5) } else { TRANSPARENT.stroke_width(5) };
                let $make = move |at| {
                    EmptyElement::at(at) + Cross::new((0, 0), arm, under) + Cross::new((0, 0), arm, rgb.stroke_width(3))
                };
                $then
            }
            MarkerShape::Triangle => {
                let closed = closed_outline(MarkerShape::Triangle, r);
                let $make = move |at| {
                    EmptyElement::at(at) + TriangleMarker::new((0, 0), r, fill) + PathElement::new(closed.clone(), edge)
                };
                $then
            }
            MarkerShape::Square => {
                let h = (f64::from(r) * 0.85).round() as i32;
                let $make = move |at| {
                    EmptyElement::at(at)
                        + Rectangle::new([(-h, -h), (h, h)], fill)
                        + Rectangle::new([(-h, -h), (h, h)], edge)
                };
                $then
            }
            shape @ (MarkerShape::Star | MarkerShape::Diamond) => {
                let closed = closed_outline(shape, r);
                let $make = move |at| {
                    EmptyElement::at(at) + Polygon::new(closed.clone(), fill) + PathElement::new(closed.clone(), edge)
                };
                $then
            }
        }
    }};
}

/// Draw a marker at each of `points` (in values) on `chart`; the series, to
/// give a legend entry.
pub fn draw_markers<'a, 'c, DB: DrawingBackend + 'a>(
    chart: &'c mut ChartContext<'a, DB, Coords>,
    points: Vec<(f64, f64)>,
    (shape, colour, radius_px, paint): (MarkerShape, Colour, i32, Paint),
) -> Result<&'c mut SeriesAnno<'a, DB>, String> {
    with_marker!(shape, colour, radius_px, paint, |make| chart.draw_series(points.into_iter().map(make)).map_err(fail))
}

/// The corners of a polygonal marker of outer radius `r`, about its centre,
/// closed (the first again at the end).
fn closed_outline(shape: MarkerShape, r: i32) -> Vec<(i32, i32)> {
    let r = f64::from(r);
    let point =
        |radius: f64, angle: f64| ((radius * angle.cos()).round() as i32, (radius * angle.sin()).round() as i32);
    let mut corners: Vec<(i32, i32)> = match shape {
        MarkerShape::Star => (0..10)
            .map(|k| {
                let radius = if k % 2 == 0 { r * 1.2 } else { r * 0.5 };
                point(radius, -PI / 2.0 + f64::from(k) * PI / 5.0)
            })
            .collect(),
        MarkerShape::Diamond => (0..4).map(|k| point(r * 1.1, f64::from(k) * PI / 2.0)).collect(),
        // Upward, as plotters' TriangleMarker.
        _ => (0..3).map(|k| point(r, -PI / 2.0 + f64::from(k) * 2.0 * PI / 3.0)).collect(),
    };
    corners.push(corners[0]);
    corners
}

/// What a legend entry shows beside its label.
#[derive(Clone, Copy, Debug)]
pub enum Key {
    /// A short line.
    Line(Colour),
    /// A marker.
    Marker(MarkerShape, Colour, Paint),
    /// A short line through a marker.
    LineAndMarker(MarkerShape, Colour),
    /// A block of colour (a heatmap's "no data" cells).
    Block(Colour),
}

/// Give `series` a legend entry: `label` beside `key` (plotters passes the
/// key the left middle of a slot about 30 pixels wide).
pub fn set_legend<'a, DB: DrawingBackend + 'a>(series: &mut SeriesAnno<'a, DB>, label: &str, key: Key, radius_px: i32) {
    let series = series.label(label);
    let line = |colour: Colour| PathElement::new(vec![(-12, 0), (12, 0)], colour.rgb().stroke_width(2));
    match key {
        Key::Line(colour) => {
            series.legend(move |(x, y)| EmptyElement::at((x + 12, y)) + line(colour));
        }
        Key::Marker(shape, colour, paint) => with_marker!(shape, colour, radius_px, paint, |make| {
            series.legend(move |(x, y)| make((x + 12, y)));
        }),
        Key::LineAndMarker(shape, colour) => with_marker!(shape, colour, radius_px, Paint::Outline, |make| {
            series.legend(move |(x, y)| make((x + 12, y)) + line(colour));
        }),
        Key::Block(colour) => {
            let corners = [(-8, -radius_px), (8, radius_px)];
            series.legend(move |(x, y)| {
                EmptyElement::at((x + 12, y))
                    + Rectangle::new(corners, colour.rgb().filled())
                    + Rectangle::new(corners, BLACK.stroke_width(1))
            });
        }
    }
}
