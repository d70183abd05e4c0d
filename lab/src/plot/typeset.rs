//! A drawing backend wrapper that sets text and thick lines itself.
//!
//! plotters' `ab_glyph` renderer places each glyph at the pen position without
//! its side bearing, so letters sit unevenly ("contac t"), and it joins thick
//! paths with unbounded mitres, so a jagged spectrum grows spikes far outside
//! the plot. [`Typeset`] passes everything else to the backend it wraps, but
//! lays text out with the embedded font's advances, kerning and bearings, and
//! draws thick lines with a square brush, a path segment by segment.

use std::sync::OnceLock;

use ab_glyph::{Font, FontRef, PxScale, ScaleFont, point};
use plotters_backend::text_anchor::{HPos, VPos};
use plotters_backend::{BackendColor, BackendCoord, BackendStyle, BackendTextStyle, DrawingBackend, DrawingErrorKind};

/// The embedded font, parsed once.
fn font() -> Option<&'static FontRef<'static>> {
    static FONT: OnceLock<Option<FontRef<'static>>> = OnceLock::new();
    FONT.get_or_init(|| FontRef::try_from_slice(epaint_default_fonts::UBUNTU_LIGHT).ok()).as_ref()
}

/// Text laid out on one line, in pixels from its top left; the baseline is
/// `ascent` down.
struct Line {
    /// Each glyph with its pen position along the line.
    glyphs: Vec<(ab_glyph::GlyphId, f32)>,
    width: f32,
    ascent: f32,
    height: f32,
    scale: PxScale,
}

fn lay_out(font: &FontRef<'static>, size_px: f64, text: &str) -> Line {
    let scale = PxScale::from(size_px as f32);
    let scaled = font.as_scaled(scale);
    let mut glyphs = Vec::with_capacity(text.len());
    let mut pen = 0.0f32;
    let mut previous = None;
    for c in text.chars() {
        let id = scaled.glyph_id(c);
        if let Some(p) = previous {
            pen += scaled.kern(p, id);
        }
        glyphs.push((id, pen));
        pen += scaled.h_advance(id);
        previous = Some(id);
    }
    Line { glyphs, width: pen, ascent: scaled.ascent(), height: scaled.ascent() - scaled.descent(), scale }
}

fn no_font<E: std::error::Error + Send + Sync>() -> DrawingErrorKind<E> {
    DrawingErrorKind::FontError("the embedded font could not be read".into())
}

/// A one-pixel line in a colour.
struct Thin(BackendColor);

impl BackendStyle for Thin {
    fn color(&self) -> BackendColor {
        self.0
    }
}

/// A backend whose text and thick lines are drawn as described above.
pub struct Typeset<B> {
    inner: B,
    /// How many levels of coverage text's edges are shaded in; None for all.
    coverage_levels: Option<u8>,
}

impl<B: DrawingBackend> Typeset<B> {
    /// Wrap `inner`.
    pub fn new(inner: B) -> Self {
        Self { inner, coverage_levels: None }
    }

    /// Wrap `inner`, shading text's edges in `levels` levels of coverage
    /// only: few enough colours for a frame that plotters' GIF backend then
    /// stores in an exact palette (it quantises a frame of more than 256
    /// colours, which can turn a small red star purple).
    pub fn with_coverage_levels(inner: B, levels: u8) -> Self {
        Self { inner, coverage_levels: Some(levels.max(1)) }
    }
}

impl<B: DrawingBackend> DrawingBackend for Typeset<B> {
    type ErrorType = B::ErrorType;

    fn get_size(&self) -> (u32, u32) {
        self.inner.get_size()
    }

    fn ensure_prepared(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.ensure_prepared()
    }

    fn present(&mut self) -> Result<(), DrawingErrorKind<Self::ErrorType>> {
        self.inner.present()
    }

    fn draw_pixel(&mut self, point: BackendCoord, color: BackendColor) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_pixel(point, color)
    }

    fn draw_line<S: BackendStyle>(
        &mut self,
        from: BackendCoord,
        to: BackendCoord,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        let width = style.stroke_width();
        if width <= 1 {
            return self.inner.draw_line(from, to, style);
        }
        // A square brush of one-pixel lines: as thick whatever the slope
        // (plotters' thick line is a polygon whose rounding thins it when
        // steep).
        let thin = Thin(style.color());
        let (low, high) = (-((width as i32 - 1) / 2), width as i32 / 2);
        for dx in low..=high {
            for dy in low..=high {
                let corner = (dx == low || dx == high) && (dy == low || dy == high);
                if corner && width > 2 {
                    continue;
                }
                self.inner.draw_line((from.0 + dx, from.1 + dy), (to.0 + dx, to.1 + dy), &thin)?;
            }
        }
        Ok(())
    }

    fn draw_rect<S: BackendStyle>(
        &mut self,
        upper_left: BackendCoord,
        bottom_right: BackendCoord,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_rect(upper_left, bottom_right, style, fill)
    }

    fn draw_path<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        path: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        if style.stroke_width() <= 1 {
            return self.inner.draw_path(path, style);
        }
        // Segment by segment, with no mitre at the joins.
        let mut previous: Option<BackendCoord> = None;
        for point in path {
            match previous {
                Some(p) if p == point => continue,
                Some(p) => self.draw_line(p, point, style)?,
                None => {}
            }
            previous = Some(point);
        }
        Ok(())
    }

    fn draw_circle<S: BackendStyle>(
        &mut self,
        center: BackendCoord,
        radius: u32,
        style: &S,
        fill: bool,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.draw_circle(center, radius, style, fill)
    }

    fn fill_polygon<S: BackendStyle, I: IntoIterator<Item = BackendCoord>>(
        &mut self,
        vert: I,
        style: &S,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.fill_polygon(vert, style)
    }

    fn blit_bitmap(
        &mut self,
        pos: BackendCoord,
        size: (u32, u32),
        src: &[u8],
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        self.inner.blit_bitmap(pos, size, src)
    }

    fn draw_text<S: BackendTextStyle>(
        &mut self,
        text: &str,
        style: &S,
        pos: BackendCoord,
    ) -> Result<(), DrawingErrorKind<B::ErrorType>> {
        let colour = style.color();
        if colour.alpha == 0.0 {
            return Ok(());
        }
        let font = font().ok_or_else(no_font)?;
        let line = lay_out(font, style.size(), text);
        // The anchor, as plotters places its own text, on the unrotated line.
        let dx = match style.anchor().h_pos {
            HPos::Left => 0.0,
            HPos::Center => -line.width / 2.0,
            HPos::Right => -line.width,
        };
        let dy = match style.anchor().v_pos {
            VPos::Top => 0.0,
            VPos::Center => -line.height / 2.0,
            VPos::Bottom => -line.height,
        };
        let (dx, dy) = (dx.round() as i32, dy.round() as i32);
        let transform = style.transform();
        let mut pixels = Vec::new();
        for &(id, pen) in &line.glyphs {
            let glyph = id.with_scale_and_position(line.scale, point(pen, line.ascent));
            if let Some(outline) = font.outline_glyph(glyph) {
                let bounds = outline.px_bounds();
                let (x0, y0) = (bounds.min.x as i32, bounds.min.y as i32);
                outline.draw(|x, y, coverage| {
                    if coverage > 1.0 / 255.0 {
                        pixels.push((x0 + x as i32 + dx, y0 + y as i32 + dy, coverage.min(1.0)));
                    }
                });
            }
        }
        let (w, h) = self.get_size();
        for (x, y, coverage) in pixels {
            let coverage = match self.coverage_levels {
                Some(levels) => (coverage * f32::from(levels)).round() / f32::from(levels),
                None => coverage,
            };
            if coverage <= 0.0 {
                continue;
            }
            let (x, y) = transform.transform(x, y);
            let (x, y) = (pos.0 + x, pos.1 + y);
            if x >= 0 && y >= 0 && (x as u32) < w && (y as u32) < h {
                let mixed = BackendColor { alpha: colour.alpha * f64::from(coverage), rgb: colour.rgb };
                self.inner.draw_pixel((x, y), mixed)?;
            }
        }
        Ok(())
    }

    fn estimate_text_size<S: BackendTextStyle>(
        &self,
        text: &str,
        style: &S,
    ) -> Result<(u32, u32), DrawingErrorKind<B::ErrorType>> {
        let font = font().ok_or_else(no_font)?;
        let line = lay_out(font, style.size(), text);
        Ok((line.width.ceil() as u32, line.height.ceil() as u32))
    }
}
