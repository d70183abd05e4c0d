//! A marker drawn at one point, in any of the [`MarkerShape`]s: a plotters
//! element, so that the same code draws it on a chart and in its legend.

use std::f64::consts::PI;
use std::iter::{Once, once};

use plotters::element::{Drawable, PointCollection};
use plotters::prelude::*;
use plotters::style::ShapeStyle;
use plotters_backend::{BackendCoord, DrawingErrorKind};

use super::{Colour, MarkerShape};

/// How a marker is painted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Paint {
    /// Its outline in its colour (a line plot's data points).
    Outline,
    /// Filled with its colour and outlined in black, to stand out on any
    /// background (markers on a heatmap or an animation).
    Solid,
}

/// A marker at `at`, `radius_px` from its centre to its outer points.
#[derive(Clone, Debug)]
pub struct Glyph<C> {
    pub at: C,
    pub shape: MarkerShape,
    pub colour: Colour,
    pub radius_px: i32,
    pub paint: Paint,
}

impl<'a, C: 'a> PointCollection<'a, C> for &'a Glyph<C> {
    type Point = &'a C;
    type IntoIter = Once<&'a C>;
    fn point_iter(self) -> Self::IntoIter {
        once(&self.at)
    }
}

impl<C, DB: DrawingBackend> Drawable<DB> for Glyph<C> {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut points: I,
        backend: &mut DB,
        _: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some(centre) = points.next() else { return Ok(()) };
        let colour = self.colour.rgb();
        let (fill, edge) = match self.paint {
            Paint::Outline => (None, ShapeStyle::from(colour).stroke_width(2)),
            Paint::Solid => (Some(ShapeStyle::from(colour).filled()), ShapeStyle::from(BLACK).stroke_width(1)),
        };
        let r = self.radius_px;
        if self.shape == MarkerShape::Circle {
            if let Some(fill) = fill {
                backend.draw_circle(centre, r as u32, &fill, true)?;
            }
            backend.draw_circle(centre, r as u32, &edge, false)?;
            if self.paint == Paint::Outline {
                // A two-pixel ring.
                backend.draw_circle(centre, (r - 1).max(1) as u32, &edge, false)?;
            }
            return Ok(());
        }
        if self.shape == MarkerShape::Cross {
            let arm = (f64::from(r) * 0.8).round() as i32;
            let thick = ShapeStyle::from(colour).stroke_width(3);
            for (dx, dy) in [(arm, arm), (arm, -arm)] {
                let (a, b) = ((centre.0 - dx, centre.1 - dy), (centre.0 + dx, centre.1 + dy));
                if self.paint == Paint::Solid {
                    backend.draw_line(a, b, &ShapeStyle::from(BLACK).stroke_width(5))?;
                }
                backend.draw_line(a, b, &thick)?;
            }
            return Ok(());
        }
        let outline = outline(self.shape, centre, f64::from(r));
        if let Some(fill) = fill {
            backend.fill_polygon(outline.iter().copied(), &fill)?;
        }
        let closed = outline.iter().copied().chain(once(outline[0]));
        backend.draw_path(closed, &edge)
    }
}

/// The corners of a polygonal marker of outer radius `r` centred at `c`.
fn outline(shape: MarkerShape, c: BackendCoord, r: f64) -> Vec<BackendCoord> {
    let point = |radius: f64, angle: f64| {
        (c.0 + (radius * angle.cos()).round() as i32, c.1 + (radius * angle.sin()).round() as i32)
    };
    match shape {
        MarkerShape::Square => {
            let h = (r * 0.85).round() as i32;
            vec![(c.0 - h, c.1 - h), (c.0 + h, c.1 - h), (c.0 + h, c.1 + h), (c.0 - h, c.1 + h)]
        }
        MarkerShape::Star => (0..10)
            .map(|k| {
                let radius = if k % 2 == 0 { r * 1.2 } else { r * 0.5 };
                point(radius, -PI / 2.0 + f64::from(k) * PI / 5.0)
            })
            .collect(),
        MarkerShape::Triangle => (0..3).map(|k| point(r, -PI / 2.0 + f64::from(k) * 2.0 * PI / 3.0)).collect(),
        MarkerShape::Diamond => (0..4).map(|k| point(r * 1.1, f64::from(k) * PI / 2.0)).collect(),
        MarkerShape::Circle | MarkerShape::Cross => (0..16).map(|k| point(r, f64::from(k) * PI / 8.0)).collect(),
    }
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

/// A legend entry's key, `at` the left end of its slot (plotters passes the
/// left middle of a slot about 30 pixels wide).
#[derive(Clone, Debug)]
pub struct LegendKey {
    pub at: BackendCoord,
    pub key: Key,
    pub radius_px: i32,
}

impl<'a> PointCollection<'a, BackendCoord> for &'a LegendKey {
    type Point = &'a BackendCoord;
    type IntoIter = Once<&'a BackendCoord>;
    fn point_iter(self) -> Self::IntoIter {
        once(&self.at)
    }
}

impl<DB: DrawingBackend> Drawable<DB> for LegendKey {
    fn draw<I: Iterator<Item = BackendCoord>>(
        &self,
        mut points: I,
        backend: &mut DB,
        size: (u32, u32),
    ) -> Result<(), DrawingErrorKind<DB::ErrorType>> {
        let Some((x, y)) = points.next() else { return Ok(()) };
        let middle = (x + 12, y);
        let line = |backend: &mut DB, colour: Colour| {
            backend.draw_line((x, y), (x + 24, y), &ShapeStyle::from(colour.rgb()).stroke_width(2))
        };
        let glyph = |shape, colour, paint| Glyph { at: middle, shape, colour, radius_px: self.radius_px, paint };
        match self.key {
            Key::Line(colour) => line(backend, colour),
            Key::Marker(shape, colour, paint) => glyph(shape, colour, paint).draw(once(middle), backend, size),
            Key::LineAndMarker(shape, colour) => {
                line(backend, colour)?;
                glyph(shape, colour, Paint::Outline).draw(once(middle), backend, size)
            }
            Key::Block(colour) => {
                let h = self.radius_px;
                backend.draw_rect((x + 4, y - h), (x + 20, y + h), &ShapeStyle::from(colour.rgb()).filled(), true)?;
                backend.draw_rect((x + 4, y - h), (x + 20, y + h), &ShapeStyle::from(BLACK), false)
            }
        }
    }
}
