//! Axes: the extent each axis of a chart covers, plotters' linear or
//! logarithmic coordinate over it (whose key points are the ticks and grid
//! lines), the tick labels, and curves cut at the plot's edge.
//!
//! Ranges are worked out in "axis space" (the value itself on a linear axis,
//! its base-10 logarithm on a logarithmic one) and handed to plotters in
//! values. plotters places the ticks: round numbers on a linear axis; on a
//! logarithmic one the powers of ten, with light lines at 2-9 times them, and
//! when an axis spans too few powers of ten to label, 1, 2 and 5 (or every
//! digit) times them. plotters draws a line wherever its ends map to, over the
//! axes too, so curves are cut at the plot's edge here.

use std::ops::Range;

use plotters::coord::ranged1d::{BoldPoints, DefaultFormatting, KeyPointHint, LightPoints, Ranged};
use plotters::coord::types::RangedCoordf64;
use plotters::prelude::{IntoLogRange, LogCoord};

/// How many tick labels an axis has at most.
pub const LABELS: usize = 8;

/// How an axis maps values onto its length.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Scale {
    /// Equal steps of value are equal lengths.
    #[default]
    Linear,
    /// Equal ratios of value are equal lengths; values that are not positive
    /// cannot be placed and are left out.
    Log,
}

impl Scale {
    /// The axis-space coordinate of `value`, or None where it cannot be placed
    /// (not finite, or not positive on a logarithmic axis).
    pub(crate) fn to_axis(self, value: f64) -> Option<f64> {
        match self {
            Scale::Linear if value.is_finite() => Some(value),
            Scale::Log if value.is_finite() && value > 0.0 => Some(value.log10()),
            _ => None,
        }
    }

    /// The value at axis-space `coordinate`.
    pub(crate) fn to_value(self, coordinate: f64) -> f64 {
        match self {
            Scale::Linear => coordinate,
            Scale::Log => 10f64.powf(coordinate),
        }
    }
}

/// One axis of a chart: its scale and its extent in axis space.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Axis {
    pub scale: Scale,
    /// The lower end, in axis space.
    pub low: f64,
    /// The upper end, in axis space.
    pub high: f64,
}

/// The fraction of the data's span left free at each end of an automatic range.
const PADDING: f64 = 0.04;

impl Axis {
    /// The axis from an explicit range of values (`what` names it in errors),
    /// or else one that covers `data` with a little padding at each end.
    pub fn fit(
        scale: Scale,
        explicit: Option<(f64, f64)>,
        data: impl IntoIterator<Item = f64>,
        padding: bool,
        what: &str,
    ) -> Result<Axis, String> {
        if let Some(range) = explicit {
            return Axis::exact(scale, range, what);
        }
        let (mut low, mut high) = (f64::INFINITY, f64::NEG_INFINITY);
        for c in data.into_iter().filter_map(|v| scale.to_axis(v)) {
            low = low.min(c);
            high = high.max(c);
        }
        if low > high {
            // Nothing to place: a unit range (0..1, or 1..10 on a log axis).
            return Ok(Axis { scale, low: 0.0, high: 1.0 });
        }
        if low == high {
            let half = match scale {
                Scale::Linear if low != 0.0 => 0.1 * low.abs(),
                Scale::Linear => 1.0,
                Scale::Log => 0.5,
            };
            return Ok(Axis { scale, low: low - half, high: high + half });
        }
        let pad = if padding { PADDING * (high - low) } else { 0.0 };
        Ok(Axis { scale, low: low - pad, high: high + pad })
    }

    /// The axis covering exactly `low..high` (in values).
    pub fn exact(scale: Scale, (low, high): (f64, f64), what: &str) -> Result<Axis, String> {
        let (Some(l), Some(h)) = (scale.to_axis(low), scale.to_axis(high)) else {
            let need = if scale == Scale::Log { "positive and finite on a logarithmic axis" } else { "finite" };
            return Err(format!("{what} range {low}..{high}: the ends must be {need}"));
        };
        if l >= h {
            return Err(format!("{what} range {low}..{high}: the lower end must be below the upper"));
        }
        Ok(Axis { scale, low: l, high: h })
    }

    /// The extent in axis space.
    pub fn range(&self) -> Range<f64> {
        self.low..self.high
    }

    /// The axis-space coordinate of `value` if it is on the axis's scale (it
    /// may lie outside the extent).
    pub fn place(&self, value: f64) -> Option<f64> {
        self.scale.to_axis(value)
    }

    /// The value at axis-space `coordinate`.
    pub fn value(&self, coordinate: f64) -> f64 {
        self.scale.to_value(coordinate)
    }

    /// Whether axis-space `coordinate` lies within the extent.
    pub fn contains(&self, coordinate: f64) -> bool {
        let slack = 1e-9 * (self.high - self.low);
        coordinate >= self.low - slack && coordinate <= self.high + slack
    }

    /// plotters' coordinate for the axis, in values.
    pub fn coord(&self) -> Coord {
        let (low, high) = (self.value(self.low), self.value(self.high));
        match self.scale {
            Scale::Linear => Coord::Linear((low..high).into()),
            Scale::Log => {
                // plotters' logarithmic key points start at the first power of
                // ten in the range: widened down to a whole decade, the points
                // below `low` are dropped again. (Widened by a hair at both
                // ends too, so that rounding keeps the powers of ten at them.)
                let from = 10f64.powf(self.low.floor()) * (1.0 - 1e-9);
                Coord::Log {
                    log: (low..high).log_scale().into(),
                    ticks: (from..high * (1.0 + 1e-9)).log_scale().into(),
                    inside: (low, high),
                }
            }
        }
    }

    /// The labelled values: plotters' key points for the bold grid lines.
    pub fn ticks(&self) -> Vec<f64> {
        self.coord().key_points(BoldPoints(LABELS))
    }

    /// The tick labels' text, for plotters' mesh: round numbers with as many
    /// decimals as the step between ticks needs on a linear axis (the
    /// `2.5e-6` form for very large or small values), and values written
    /// plainly on a logarithmic one.
    pub fn labeller(&self) -> impl Fn(&f64) -> String + use<> {
        let (scale, low, high) = (self.scale, self.low, self.high);
        let ticks = self.ticks();
        let step = ticks.windows(2).map(|w| w[1] - w[0]).next().unwrap_or(high - low);
        move |&value| match scale {
            Scale::Linear => {
                let value = if value.abs() < 1e-9 * step { 0.0 } else { value };
                if low.abs().max(high.abs()) >= 1e6 || step < 1e-4 {
                    scientific(value)
                } else {
                    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
                    format!("{value:.decimals$}")
                }
            }
            Scale::Log => plain(value),
        }
    }
}

/// plotters' coordinate for an [`Axis`], linear or logarithmic, in values.
pub enum Coord {
    /// plotters' linear coordinate.
    Linear(RangedCoordf64),
    /// plotters' logarithmic coordinate over the axis (`log`), and over a
    /// range reaching down to a power of ten whose key points between the
    /// values `inside` are the ticks (`ticks`).
    Log { log: LogCoord<f64>, ticks: LogCoord<f64>, inside: (f64, f64) },
}

/// The key points of a logarithmic axis from `low` to `high`: plotters'
/// points of `log` (which reaches down to a power of ten) inside that range.
/// For the labels, when there are fewer than three powers of ten, 1, 2 and 5
/// times them, or every digit, from plotters' light points (1-9 times each
/// power); within a decade, plotters' linear ticks of the value.
fn log_key_points(log: &LogCoord<f64>, (low, high): (f64, f64), hint: impl KeyPointHint) -> Vec<f64> {
    // plotters gives each power of ten twice (as a point and as ten times
    // the one before) when it gives light points.
    let inside = |points: Vec<f64>| {
        let mut kept: Vec<f64> =
            points.into_iter().filter(|v| *v >= low * (1.0 - 1e-9) && *v <= high * (1.0 + 1e-9)).collect();
        kept.dedup_by(|a, b| (*a - *b).abs() <= 1e-9 * b.abs());
        kept
    };
    if hint.weight().allow_light_points() {
        return inside(log.key_points(hint));
    }
    let labels = hint.max_num_points();
    let powers = inside(log.key_points(hint));
    if powers.len() >= 3 {
        return powers;
    }
    let decades = (high / low).log10().ceil() as usize + 1;
    let digits = inside(log.key_points(LightPoints::new(labels, 10 * decades + 10)));
    let mantissa = |v: &f64| (v / 10f64.powf((v.log10() + 1e-9).floor())).round();
    let one_two_five: Vec<f64> = digits.iter().copied().filter(|v| [1.0, 2.0, 5.0].contains(&mantissa(v))).collect();
    if one_two_five.len() >= 3 {
        one_two_five
    } else if digits.len() >= 2 {
        digits
    } else {
        RangedCoordf64::from(low..high).key_points(labels)
    }
}

impl Ranged for Coord {
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        match self {
            Coord::Linear(linear) => linear.map(value, limit),
            Coord::Log { log, .. } => log.map(value, limit),
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        match self {
            Coord::Linear(linear) => linear.key_points(hint),
            Coord::Log { ticks, inside, .. } => log_key_points(ticks, *inside, hint),
        }
    }

    fn range(&self) -> Range<f64> {
        match self {
            Coord::Linear(linear) => linear.range(),
            Coord::Log { inside, .. } => inside.0..inside.1,
        }
    }
}

/// A value written plainly where that is short (0.001 to 99999), with three
/// significant figures at most and no trailing zeros; in the `2.5e-6` form
/// otherwise.
pub fn plain(value: f64) -> String {
    let size = value.abs();
    if value == 0.0 {
        return "0".into();
    }
    if !(1e-3..1e5).contains(&size) {
        return scientific(value);
    }
    let decimals = (2 - size.log10().floor() as i32).max(0) as usize;
    trim_zeros(format!("{value:.decimals$}"))
}

/// A value in the `2.5e-6` form, with three significant figures at most.
pub fn scientific(value: f64) -> String {
    if value == 0.0 {
        return "0".into();
    }
    let text = format!("{value:.2e}");
    match text.split_once('e') {
        Some((mantissa, exponent)) => format!("{}e{exponent}", trim_zeros(mantissa.to_string())),
        None => text,
    }
}

fn trim_zeros(text: String) -> String {
    if text.contains('.') { text.trim_end_matches('0').trim_end_matches('.').to_string() } else { text }
}

/// Clip the segment `a`-`b` to the rectangle `x` by `y` (Liang-Barsky); None
/// when no part of it is inside.
pub fn clip_segment(a: (f64, f64), b: (f64, f64), x: &Range<f64>, y: &Range<f64>) -> Option<((f64, f64), (f64, f64))> {
    let (dx, dy) = (b.0 - a.0, b.1 - a.1);
    let (mut t0, mut t1) = (0.0f64, 1.0f64);
    for (p, q) in [(-dx, a.0 - x.start), (dx, x.end - a.0), (-dy, a.1 - y.start), (dy, y.end - a.1)] {
        if p == 0.0 {
            if q < 0.0 {
                return None;
            }
        } else {
            let t = q / p;
            if p < 0.0 {
                t0 = t0.max(t);
            } else {
                t1 = t1.min(t);
            }
        }
    }
    // An end that needs no cutting is returned exactly, so that runs of
    // consecutive segments join.
    let at = |t: f64| {
        if t == 0.0 {
            a
        } else if t == 1.0 {
            b
        } else {
            (a.0 + t * dx, a.1 + t * dy)
        }
    };
    (t0 <= t1).then(|| (at(t0), at(t1)))
}

/// The parts of a polyline (in axis space, None where a point cannot be
/// placed) that lie inside the rectangle `x` by `y`, as separate runs.
pub fn clip_polyline(points: &[Option<(f64, f64)>], x: &Range<f64>, y: &Range<f64>) -> Vec<Vec<(f64, f64)>> {
    let mut runs = Vec::new();
    let mut run: Vec<(f64, f64)> = Vec::new();
    for pair in points.windows(2) {
        let clipped = match (pair[0], pair[1]) {
            (Some(a), Some(b)) => clip_segment(a, b, x, y),
            _ => None,
        };
        match clipped {
            Some((start, end)) => {
                if run.last() != Some(&start) && !run.is_empty() {
                    runs.push(std::mem::take(&mut run));
                }
                if run.is_empty() {
                    run.push(start);
                }
                run.push(end);
            }
            None if !run.is_empty() => runs.push(std::mem::take(&mut run)),
            None => {}
        }
    }
    if !run.is_empty() {
        runs.push(run);
    }
    runs
}

#[cfg(test)]
mod tests {
    use plotters::coord::ranged1d::LightPoints;

    use super::*;

    /// The labels plotters' mesh sets on `axis`.
    fn labels(axis: &Axis) -> Vec<String> {
        let label = axis.labeller();
        axis.ticks().iter().map(label).collect()
    }

    /// The light grid lines plotters' mesh draws on `axis` (10 a label).
    fn light_lines(axis: &Axis) -> Vec<f64> {
        axis.coord().key_points(LightPoints::new(LABELS, LABELS * 10))
    }

    #[test]
    fn log_axis_over_six_decades_labels_each_decade_with_light_lines_between() {
        let axis = Axis::fit(Scale::Log, None, [1e-3, 0.0, -5.0, 1e3], false, "x").unwrap();
        assert!((axis.low + 3.0).abs() < 1e-12 && (axis.high - 3.0).abs() < 1e-12);
        assert_eq!(labels(&axis), ["0.001", "0.01", "0.1", "1", "10", "100", "1000"]);
        // 2-9 times each power of ten, and the powers themselves.
        assert_eq!(light_lines(&axis).len(), 6 * 9 + 1);
    }

    #[test]
    fn log_axis_over_many_decades_labels_every_other() {
        let axis = Axis::exact(Scale::Log, (1e-6, 1e6), "x").unwrap();
        let labels = labels(&axis);
        assert_eq!(labels.len(), 7);
        assert_eq!((labels[0].as_str(), labels[6].as_str()), ("1e-6", "1e6"));
    }

    #[test]
    fn log_axis_over_two_decades_labels_one_two_five() {
        let axis = Axis::exact(Scale::Log, (50.0, 5000.0), "x").unwrap();
        assert_eq!(labels(&axis), ["50", "100", "200", "500", "1000", "2000", "5000"]);
    }

    #[test]
    fn log_axis_within_a_decade_still_has_labels() {
        let axis = Axis::exact(Scale::Log, (2.0, 8.0), "x").unwrap();
        assert_eq!(labels(&axis), ["2", "3", "4", "5", "6", "7", "8"]);
        let narrow = Axis::exact(Scale::Log, (400.0, 440.0), "x").unwrap();
        assert!(narrow.ticks().len() >= 3, "{:?}", narrow.ticks());
    }

    #[test]
    fn a_log_axis_maps_its_ends_to_the_plots_edges() {
        let coord = Axis::exact(Scale::Log, (50.0, 5000.0), "x").unwrap().coord();
        assert_eq!(coord.map(&50.0, (0, 400)), 0);
        assert_eq!(coord.map(&500.0, (0, 400)), 200);
        assert_eq!(coord.map(&5000.0, (0, 400)), 400);
    }

    #[test]
    fn linear_ticks_are_round_numbers() {
        let axis = Axis::exact(Scale::Linear, (-0.3, 2.7), "y").unwrap();
        assert_eq!(labels(&axis), ["0.0", "0.5", "1.0", "1.5", "2.0", "2.5"]);
        let small = Axis::exact(Scale::Linear, (0.0, 3e-6), "y").unwrap();
        assert_eq!(labels(&small)[1], "5e-7");
    }

    #[test]
    fn explicit_ranges_are_checked() {
        assert!(Axis::exact(Scale::Log, (0.0, 10.0), "x").unwrap_err().contains("positive"));
        assert!(Axis::exact(Scale::Linear, (3.0, 1.0), "y").unwrap_err().contains("below"));
        assert!(Axis::exact(Scale::Linear, (f64::NAN, 1.0), "y").is_err());
    }

    #[test]
    fn automatic_range_is_padded_and_skips_what_cannot_be_placed() {
        let axis = Axis::fit(Scale::Linear, None, [0.0, f64::NAN, 10.0, f64::INFINITY], true, "y").unwrap();
        assert!((axis.low + 0.4).abs() < 1e-12 && (axis.high - 10.4).abs() < 1e-12);
        let empty = Axis::fit(Scale::Log, None, [-1.0, 0.0], true, "y").unwrap();
        assert_eq!((empty.low, empty.high), (0.0, 1.0));
    }

    #[test]
    fn polylines_are_cut_at_the_frame_and_at_missing_points() {
        let (x, y) = (0.0..1.0, 0.0..1.0);
        let points = [Some((-1.0, 0.5)), Some((0.5, 0.5)), Some((0.5, 2.0)), None, Some((0.2, 0.2)), Some((0.3, 0.3))];
        let runs = clip_polyline(&points, &x, &y);
        assert_eq!(runs, vec![vec![(0.0, 0.5), (0.5, 0.5), (0.5, 1.0)], vec![(0.2, 0.2), (0.3, 0.3)]]);
    }
}
