//! Axes: how data values map onto a chart's coordinate, where the ticks go
//! and how they are labelled.
//!
//! Charts are drawn in "axis space": the value itself on a linear axis, its
//! base-10 logarithm on a logarithmic one. Ticks are chosen here rather than by
//! plotters, so logarithmic axes get labelled decades with light lines at 2-9.

use std::ops::Range;

use plotters::coord::ranged1d::{DefaultFormatting, KeyPointHint, Ranged};

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

    /// Whether axis-space `coordinate` lies within the extent.
    pub fn contains(&self, coordinate: f64) -> bool {
        let slack = 1e-9 * (self.high - self.low);
        coordinate >= self.low - slack && coordinate <= self.high + slack
    }

    /// The coordinate spec for plotters: the extent with its labelled (bold)
    /// and light tick positions.
    pub fn spec(&self) -> Ticked {
        Ticked { low: self.low, high: self.high, ticks: self.ticks() }
    }

    /// The label of the tick at axis-space `coordinate`.
    pub fn label(&self, coordinate: f64) -> String {
        match self.scale {
            Scale::Linear => {
                let step = linear_step(self.high - self.low);
                let value = if coordinate.abs() < 1e-9 * step { 0.0 } else { coordinate };
                let largest = self.low.abs().max(self.high.abs());
                if largest >= 1e6 || step < 1e-4 {
                    scientific(value)
                } else {
                    let decimals = (-(step.log10() + 1e-9).floor()).max(0.0) as usize;
                    format!("{value:.decimals$}")
                }
            }
            Scale::Log => plain(10f64.powf(coordinate)),
        }
    }

    /// Where the ticks go, in axis space.
    pub fn ticks(&self) -> Ticks {
        match self.scale {
            Scale::Linear => linear_ticks(self.low, self.high),
            Scale::Log => log_ticks(self.low, self.high),
        }
    }
}

/// A plotters coordinate spec in axis space whose ticks are given rather
/// than chosen by plotters.
pub struct Ticked {
    pub low: f64,
    pub high: f64,
    pub ticks: Ticks,
}

impl Ranged for Ticked {
    // Tick labels come from Axis::label through the mesh's formatters;
    // plotters insists on a default formatting all the same.
    type FormatOption = DefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        let fraction = (value - self.low) / (self.high - self.low);
        let length = f64::from(limit.1 - limit.0);
        // As plotters maps its own f64 ranges.
        if length >= 0.0 {
            limit.0 + (length * fraction + 1e-3).floor() as i32
        } else {
            limit.0 + (length * fraction - 1e-3).ceil() as i32
        }
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() { self.ticks.minor.clone() } else { self.ticks.major.clone() }
    }

    fn range(&self) -> Range<f64> {
        self.low..self.high
    }
}

/// Tick positions in axis space.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Ticks {
    /// Labelled, with a grid line.
    pub major: Vec<f64>,
    /// A lighter grid line only.
    pub minor: Vec<f64>,
}

/// The labelled-tick spacing for a linear span: 1, 2 or 5 times a power of
/// ten, giving about six ticks.
fn linear_step(span: f64) -> f64 {
    let raw = span / 6.0;
    let power = 10f64.powf(raw.log10().floor());
    let mantissa = raw / power;
    let nice = if mantissa < 1.5 {
        1.0
    } else if mantissa < 3.5 {
        2.0
    } else if mantissa < 7.5 {
        5.0
    } else {
        10.0
    };
    nice * power
}

/// Multiples of `step` within `low..=high`.
fn multiples(low: f64, high: f64, step: f64) -> Vec<f64> {
    let first = (low / step - 1e-9).ceil() as i64;
    let last = (high / step + 1e-9).floor() as i64;
    (first..=last).map(|i| i as f64 * step).collect()
}

fn linear_ticks(low: f64, high: f64) -> Ticks {
    let step = linear_step(high - low);
    let mantissa = (step / 10f64.powf(step.log10().floor())).round();
    let minor_step = if mantissa == 2.0 { step / 4.0 } else { step / 5.0 };
    Ticks { major: multiples(low, high, step), minor: multiples(low, high, minor_step) }
}

fn log_ticks(low: f64, high: f64) -> Ticks {
    let first = (low - 1e-9).ceil() as i32;
    let last = (high + 1e-9).floor() as i32;
    let inside = |c: &f64| *c >= low - 1e-9 && *c <= high + 1e-9;
    let decades = (low.floor() as i32)..=(high.ceil() as i32);
    let within_decades = |factors: &[f64]| -> Vec<f64> {
        decades.clone().flat_map(|d| factors.iter().map(move |f| d as f64 + f.log10())).filter(|c| inside(c)).collect()
    };
    let count = last - first + 1;
    if count >= 2 && high - low > 2.5 {
        // Label the decades, every few when there are many of them.
        let stride = (count + 7) / 8;
        let major: Vec<f64> = (first..=last).filter(|d| (d - first) % stride == 0).map(f64::from).collect();
        let minor = if count <= 7 {
            within_decades(&[2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0])
        } else {
            (first..=last).map(f64::from).filter(|d| !major.contains(d)).collect()
        };
        Ticks { major, minor }
    } else {
        // Two and a half decades or less: label 1, 2 and 5 (or every digit)
        // times the powers of ten.
        let mut major = within_decades(&[1.0, 2.0, 5.0]);
        if major.len() < 3 {
            major = within_decades(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
        }
        if major.len() < 2 {
            // A narrow span inside one decade: linear ticks of the value.
            let (a, b) = (10f64.powf(low), 10f64.powf(high));
            let step = linear_step(b - a);
            major = multiples(a, b, step).into_iter().filter(|v| *v > 0.0).map(f64::log10).collect();
        }
        let minor = within_decades(&[1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0]);
        Ticks { major, minor }
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
    use super::*;

    #[test]
    fn log_axis_over_six_decades_labels_each_decade_with_light_lines_between() {
        let axis = Axis::fit(Scale::Log, None, [1e-3, 0.0, -5.0, 1e3], false, "x").unwrap();
        assert!((axis.low + 3.0).abs() < 1e-12 && (axis.high - 3.0).abs() < 1e-12);
        let ticks = axis.ticks();
        assert_eq!(ticks.major, vec![-3.0, -2.0, -1.0, 0.0, 1.0, 2.0, 3.0]);
        assert_eq!(ticks.minor.len(), 6 * 8);
        let labels: Vec<String> = ticks.major.iter().map(|&c| axis.label(c)).collect();
        assert_eq!(labels, ["0.001", "0.01", "0.1", "1", "10", "100", "1000"]);
    }

    #[test]
    fn log_axis_over_many_decades_labels_every_other() {
        let axis = Axis::exact(Scale::Log, (1e-6, 1e6), "x").unwrap();
        let ticks = axis.ticks();
        assert_eq!(ticks.major.len(), 7);
        assert_eq!(axis.label(-6.0), "1e-6");
        assert_eq!(axis.label(6.0), "1e6");
    }

    #[test]
    fn log_axis_over_two_decades_labels_one_two_five() {
        let axis = Axis::exact(Scale::Log, (50.0, 5000.0), "x").unwrap();
        let labels: Vec<String> = axis.ticks().major.iter().map(|&c| axis.label(c)).collect();
        assert_eq!(labels, ["50", "100", "200", "500", "1000", "2000", "5000"]);
    }

    #[test]
    fn log_axis_within_a_decade_still_has_labels() {
        let axis = Axis::exact(Scale::Log, (2.0, 8.0), "x").unwrap();
        let labels: Vec<String> = axis.ticks().major.iter().map(|&c| axis.label(c)).collect();
        assert_eq!(labels, ["2", "3", "4", "5", "6", "7", "8"]);
        let narrow = Axis::exact(Scale::Log, (400.0, 440.0), "x").unwrap();
        assert!(narrow.ticks().major.len() >= 3);
    }

    #[test]
    fn linear_ticks_are_round_numbers() {
        let axis = Axis::exact(Scale::Linear, (-0.3, 2.7), "y").unwrap();
        let labels: Vec<String> = axis.ticks().major.iter().map(|&c| axis.label(c)).collect();
        assert_eq!(labels, ["0.0", "0.5", "1.0", "1.5", "2.0", "2.5"]);
        let small = Axis::exact(Scale::Linear, (0.0, 3e-6), "y").unwrap();
        assert_eq!(small.label(small.ticks().major[1]), "5e-7");
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
