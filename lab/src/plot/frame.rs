//! What every chart shares: the title, the axes with their ticks, light grid
//! and labels, the box round the plot, and the legend.

use plotters::coord::Shift;
use plotters::prelude::*;

use super::axis::{Axis, Ticked};
use super::{Corner, FONT, fail};

/// A chart's coordinates: both axes in axis space with our own ticks.
pub type Coords = Cartesian2d<Ticked, Ticked>;

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
    };

    /// For an animation about 640 by 360.
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
    let mut widest_px = 0;
    for c in y.ticks().major {
        widest_px = widest_px.max(area.estimate_text_size(&y.label(c), &tick_style).map_err(fail)?.0);
    }
    let y_label_area = layout.y_label_area.max(widest_px + 5 + 8 + layout.label_font + 12);
    let mut chart = ChartBuilder::on(area)
        .margin_top(layout.margin_top)
        .margin_right(layout.margin_right)
        .margin_left(layout.margin_left)
        .margin_bottom(layout.margin_bottom)
        .x_label_area_size(layout.x_label_area)
        .y_label_area_size(y_label_area)
        .build_cartesian_2d(x.spec(), y.spec())
        .map_err(fail)?;
    let x_tick = |c: &f64| x.label(*c);
    let y_tick = |c: &f64| y.label(*c);
    chart
        .configure_mesh()
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
pub fn draw_box<DB: DrawingBackend>(chart: &ChartContext<'_, DB, Coords>) -> Result<(), String> {
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
        .background_style(WHITE.mix(0.88))
        .border_style(RGBColor(120, 120, 120))
        .draw()
        .map_err(fail)
}
