//! The lab's charts and animations, drawn into PNG and GIF files: the figures
//! of Woodhouse's Euphonics 12.2 (force pulses and spectra, the piano's string
//! table, the hammer design charts, the string animations).
//!
//! Plain data in, one file out: a [`LinePlot`] (curves and markers on linear
//! or logarithmic axes), a [`Heatmap`] (a colour-shaded grid with a colour
//! bar and overlaid markers, like the design charts of Figs 15-22) and an
//! [`Animation`] (a string's shape frame by frame, with the hammer and the
//! struck point, like Figs 2 and 23-25). Each can also write the numbers it
//! draws as CSV.
//!
//! The charts are plotters' own: its mesh draws the axes, linear or
//! logarithmic, with their ticks, grid and labels (the `axis` module picks the
//! ranges, labels the ticks and cuts curves at the plot's edge); markers are
//! plotters' elements composed at a point; PNGs are encoded by plotters'
//! bitmap backend and GIFs by its GIF backend, which stores every frame whole
//! in a palette of its own: exact for a frame of 256 colours or fewer, which
//! an animation's frames keep to (its text shaded in six levels, its legend
//! opaque), quantised otherwise.
//!
//! Drawing needs no display and no system fonts: text is set in a font
//! embedded in the binary (egui's Ubuntu Light, from `epaint_default_fonts`),
//! registered once with plotters' `ab_glyph` support (which plotters uses to
//! measure text) and drawn by the `typeset` module (which places glyphs better than
//! plotters does). Every file is written
//! under a temporary name beside its destination and renamed into place, so
//! a failure leaves nothing half-written and an existing file as it was. The
//! destination's folder must exist.

mod animation;
mod axis;
mod frame;
mod heatmap;
mod line;
mod typeset;

use std::fs;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;
use std::sync::atomic::{AtomicU64, Ordering};

use plotters::style::{FontStyle, RGBColor};

pub use animation::{Animation, AnimationFrame, MAX_GIF_FRAMES};
pub use axis::Scale;
pub use heatmap::{ColourMap, Heatmap, Marker};
pub use line::{LinePlot, Series, SeriesStyle};

/// The size of a chart's PNG unless the caller sets another, in pixels.
pub const CHART_SIZE_PX: (u32, u32) = (900, 560);

/// The font family every text of the charts is set in (the embedded font is
/// registered under this name and the other generic ones).
const FONT: &str = "sans-serif";

/// A chart could not be drawn or written.
#[derive(Debug, thiserror::Error)]
pub enum PlotError {
    /// The data cannot make the chart (mismatched lengths, a non-positive
    /// bound on a logarithmic axis, ...); nothing was written.
    #[error("cannot draw {}: {reason}", path.display())]
    BadData {
        /// The file that was to be written.
        path: PathBuf,
        /// What is wrong with the data.
        reason: String,
    },
    /// Drawing or writing the file failed; nothing was written, and a file
    /// already at `path` is as it was.
    #[error("cannot write {}: {reason}", path.display())]
    Write {
        /// The file that was to be written.
        path: PathBuf,
        /// Why it could not be written.
        reason: String,
    },
}

impl PlotError {
    fn bad_data(path: &Path, reason: impl Into<String>) -> Self {
        Self::BadData { path: path.to_path_buf(), reason: reason.into() }
    }

    fn write(path: &Path, reason: impl Into<String>) -> Self {
        Self::Write { path: path.to_path_buf(), reason: reason.into() }
    }
}

/// A colour as 8-bit red, green and blue.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub struct Colour(pub u8, pub u8, pub u8);

impl Colour {
    /// Red, the seed's first curve (Fig 4's contact force, Fig 31's clavichord).
    pub const RED: Colour = Colour(220, 0, 0);
    /// Blue, the seed's second curve (Fig 4's bridge force).
    pub const BLUE: Colour = Colour(0, 0, 230);
    /// Green, dark enough to read on white (Fig 13's gentlest strike).
    pub const GREEN: Colour = Colour(0, 150, 0);
    /// Black (Fig 14's loudest strike).
    pub const BLACK: Colour = Colour(0, 0, 0);
    /// Magenta.
    pub const MAGENTA: Colour = Colour(200, 0, 200);
    /// Cyan, dark enough to read on white (Fig 19's stars).
    pub const CYAN: Colour = Colour(0, 180, 200);
    /// Orange.
    pub const ORANGE: Colour = Colour(240, 130, 0);
    /// Grey: a heatmap's cells with no data.
    pub const GREY: Colour = Colour(160, 160, 160);
    /// White.
    pub const WHITE: Colour = Colour(255, 255, 255);

    /// The seed's curve colours in order (red, blue, green, black, magenta,
    /// cyan, orange), cycling for `index` past the end.
    pub fn palette(index: usize) -> Colour {
        const ORDER: [Colour; 7] =
            [Colour::RED, Colour::BLUE, Colour::GREEN, Colour::BLACK, Colour::MAGENTA, Colour::CYAN, Colour::ORANGE];
        ORDER[index % ORDER.len()]
    }

    fn rgb(self) -> RGBColor {
        RGBColor(self.0, self.1, self.2)
    }
}

impl Default for Colour {
    /// Black.
    fn default() -> Self {
        Colour::BLACK
    }
}

/// The shape of a marker on a line plot, a heatmap or an animation.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub enum MarkerShape {
    /// A circle (Fig 20's green circles, Fig 31's blue circles).
    #[default]
    Circle,
    /// A square (Fig 18's cyan squares).
    Square,
    /// A five-pointed star (Fig 19's cyan stars, the hammer in Fig 2).
    Star,
    /// A diagonal cross.
    Cross,
    /// An upward triangle.
    Triangle,
    /// A diamond.
    Diamond,
}

/// The corner of the plot the legend sits in.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub enum Corner {
    /// Top left.
    UpperLeft,
    /// Top right.
    #[default]
    UpperRight,
    /// Bottom left.
    LowerLeft,
    /// Bottom right.
    LowerRight,
}

impl Corner {
    fn position(self) -> plotters::chart::SeriesLabelPosition {
        use plotters::chart::SeriesLabelPosition as P;
        match self {
            Corner::UpperLeft => P::UpperLeft,
            Corner::UpperRight => P::UpperRight,
            Corner::LowerLeft => P::LowerLeft,
            Corner::LowerRight => P::LowerRight,
        }
    }
}

/// Register the embedded font with plotters, once per process.
fn ensure_fonts() -> Result<(), String> {
    static REGISTERED: OnceLock<bool> = OnceLock::new();
    let ok = *REGISTERED.get_or_init(|| {
        let font = epaint_default_fonts::UBUNTU_LIGHT;
        ["sans-serif", "serif", "monospace"]
            .iter()
            .all(|family| plotters::style::register_font(family, FontStyle::Normal, font).is_ok())
    });
    if ok { Ok(()) } else { Err("the embedded font could not be read".into()) }
}

/// Write `path` by having `fill` write a temporary file beside it (named with
/// `extension`, which picks the image format) and renaming that into place.
/// On failure the temporary file is removed and `path` is untouched.
fn write_atomically(
    path: &Path,
    extension: &str,
    fill: impl FnOnce(&Path) -> Result<(), String>,
) -> Result<(), PlotError> {
    static SERIAL: AtomicU64 = AtomicU64::new(0);
    let Some(name) = path.file_name() else {
        return Err(PlotError::write(path, "the path names no file"));
    };
    // Unique within the process too, so that two threads writing the same
    // destination do not share a temporary file.
    let temporary = path.with_file_name(format!(
        ".{}.part-{}-{}.{extension}",
        name.to_string_lossy(),
        std::process::id(),
        SERIAL.fetch_add(1, Ordering::Relaxed)
    ));
    crate::cleanup::track(&temporary);
    let result = fill(&temporary).and_then(|()| fs::rename(&temporary, path).map_err(|e| e.to_string()));
    let result = result.map_err(|reason| {
        let _ = fs::remove_file(&temporary);
        PlotError::write(path, reason)
    });
    crate::cleanup::forget(&temporary);
    result
}

/// Write `text` to `path` atomically.
fn write_text(path: &Path, text: &str) -> Result<(), PlotError> {
    write_atomically(path, "csv", |temporary| {
        use std::io::Write;
        let mut file = fs::File::create(temporary).map_err(|e| e.to_string())?;
        file.write_all(text.as_bytes()).and_then(|()| file.sync_all()).map_err(|e| e.to_string())
    })
}

/// A CSV field: quoted (with inner quotes doubled) when it holds a comma, a
/// quote or a line break.
fn csv_field(text: &str) -> String {
    if text.contains([',', '"', '\n', '\r']) { format!("\"{}\"", text.replace('"', "\"\"")) } else { text.to_string() }
}

/// A drawing error as text.
fn fail(error: impl std::fmt::Display) -> String {
    error.to_string()
}

#[cfg(test)]
mod test_support {
    //! Checks on drawn images shared by the tests of the chart kinds.

    /// The width and height in a PNG file's header, if it is a PNG.
    pub fn png_size(bytes: &[u8]) -> Option<(u32, u32)> {
        const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
        if bytes.len() < 24 || &bytes[..8] != SIGNATURE || &bytes[12..16] != b"IHDR" {
            return None;
        }
        let word = |at: usize| u32::from_be_bytes([bytes[at], bytes[at + 1], bytes[at + 2], bytes[at + 3]]);
        Some((word(16), word(20)))
    }

    /// How many distinct colours an RGB buffer holds.
    pub fn distinct_colours(rgb: &[u8]) -> usize {
        let mut colours: Vec<[u8; 3]> = rgb.chunks_exact(3).map(|p| [p[0], p[1], p[2]]).collect();
        colours.sort_unstable();
        colours.dedup();
        colours.len()
    }

    /// How many pixels of the rectangle `x0..x1` by `y0..y1` of a `width`-wide
    /// RGB buffer are dark (text, axes, black lines).
    pub fn dark_pixels(rgb: &[u8], width: u32, (x0, x1): (u32, u32), (y0, y1): (u32, u32)) -> usize {
        (y0..y1)
            .flat_map(|y| (x0..x1).map(move |x| ((y * width + x) * 3) as usize))
            .filter(|&i| rgb[i] < 100 && rgb[i + 1] < 100 && rgb[i + 2] < 100)
            .count()
    }

    /// Whether some pixel of an RGB buffer is exactly `colour`.
    pub fn has_colour(rgb: &[u8], colour: super::Colour) -> bool {
        rgb.chunks_exact(3).any(|p| p == [colour.0, colour.1, colour.2])
    }

    /// A folder under /tmp/plot-samples to keep sample images in for a look,
    /// when STRUCK_PLOT_SAMPLES is set; None otherwise.
    pub fn samples_dir() -> Option<std::path::PathBuf> {
        std::env::var_os("STRUCK_PLOT_SAMPLES").map(|_| {
            let dir = std::path::PathBuf::from("/tmp/plot-samples");
            std::fs::create_dir_all(&dir).expect("sample folder");
            dir
        })
    }
}
