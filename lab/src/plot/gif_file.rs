//! Writing rendered RGB frames as a small looping GIF.
//!
//! An animation's frames differ only where the string, the stars and the time
//! moved, so each frame after the first is stored as the rectangle that
//! changed, with the pixels inside it that did not change left transparent.
//! Each frame carries its own palette: the exact colours it needs when they
//! are 255 or fewer (the usual case), or else a fixed palette of greys and a
//! colour cube, each pixel taking the nearest.

use std::collections::HashMap;
use std::collections::hash_map::Entry;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;

use gif::{DisposalMethod, Encoder, Frame, Repeat};

/// A GIF being written, frame by frame.
pub struct GifFile {
    encoder: Encoder<BufWriter<File>>,
    width: usize,
    height: usize,
    /// The last frame given, as RGB: a pixel the same in the next is left
    /// as shown (even where the palette showed it approximately).
    previous: Vec<u8>,
    first: bool,
}

/// The colours a frame's pixels are drawn in.
struct Palette {
    /// RGB triples, at most 255 (the last index is kept for transparency).
    colours: Vec<[u8; 3]>,
    index: HashMap<[u8; 3], u8>,
}

impl Palette {
    /// The exact colours of `pixels` if there are few enough, else the fixed
    /// palette.
    fn for_pixels<'a>(pixels: impl Iterator<Item = &'a [u8]>) -> Palette {
        let mut colours = Vec::new();
        let mut index = HashMap::new();
        for p in pixels {
            let c = [p[0], p[1], p[2]];
            if let Entry::Vacant(entry) = index.entry(c) {
                if colours.len() == 255 {
                    return Palette::fixed();
                }
                entry.insert(colours.len() as u8);
                colours.push(c);
            }
        }
        Palette { colours, index }
    }

    /// A six-level colour cube and 39 greys between its levels.
    fn fixed() -> Palette {
        let levels = [0u8, 51, 102, 153, 204, 255];
        let mut colours: Vec<[u8; 3]> = Vec::with_capacity(255);
        for r in levels {
            for g in levels {
                for b in levels {
                    colours.push([r, g, b]);
                }
            }
        }
        for v in (0..=255u8).step_by(6).filter(|v| v % 51 != 0) {
            if colours.len() < 255 {
                colours.push([v, v, v]);
            }
        }
        Palette { colours, index: HashMap::new() }
    }

    /// The index of `c`, or of the nearest colour in a fixed palette.
    fn index_of(&mut self, c: [u8; 3]) -> u8 {
        if let Some(&i) = self.index.get(&c) {
            return i;
        }
        let distance = |p: &[u8; 3]| -> i32 { (0..3).map(|k| (i32::from(p[k]) - i32::from(c[k])).pow(2)).sum() };
        let nearest = (0..self.colours.len()).min_by_key(|&i| distance(&self.colours[i])).unwrap_or(0) as u8;
        self.index.insert(c, nearest);
        nearest
    }

    /// The palette as GIF bytes, with the transparent entry last.
    fn bytes(&self) -> (Vec<u8>, u8) {
        let mut bytes: Vec<u8> = self.colours.iter().flatten().copied().collect();
        let transparent = self.colours.len() as u8;
        bytes.extend([255, 255, 255]);
        (bytes, transparent)
    }
}

impl GifFile {
    /// Start a looping GIF of `width` by `height` at `path`.
    pub fn create(path: &Path, (width, height): (u32, u32)) -> Result<Self, String> {
        let (w, h) = (u16::try_from(width), u16::try_from(height));
        let (Ok(w), Ok(h)) = (w, h) else { return Err(format!("{width} x {height} is too big for a GIF")) };
        let file = File::create(path).map_err(|e| e.to_string())?;
        let mut encoder = Encoder::new(BufWriter::new(file), w, h, &[]).map_err(|e| e.to_string())?;
        encoder.set_repeat(Repeat::Infinite).map_err(|e| e.to_string())?;
        let (width, height) = (width as usize, height as usize);
        Ok(Self { encoder, width, height, previous: vec![255; width * height * 3], first: true })
    }

    /// Add the RGB image `rgb` (row by row, `width * height * 3` bytes),
    /// shown for `delay_ms`.
    pub fn add_frame(&mut self, rgb: &[u8], delay_ms: u32) -> Result<(), String> {
        if rgb.len() != self.previous.len() {
            return Err(format!("a frame of {} bytes, not {}", rgb.len(), self.previous.len()));
        }
        let width = self.width;
        let at = |x: usize, y: usize| (y * width + x) * 3;
        // Every pixel of the first frame, so that it covers the canvas
        // whatever a viewer's background.
        let changed: Vec<bool> = if self.first {
            vec![true; self.width * self.height]
        } else {
            rgb.chunks_exact(3).zip(self.previous.chunks_exact(3)).map(|(new, old)| new != old).collect()
        };
        let is_changed = |x: usize, y: usize| changed[y * width + x];
        let (mut x0, mut x1, mut y0, mut y1) = (usize::MAX, 0, usize::MAX, 0);
        for y in 0..self.height {
            for x in 0..self.width {
                if is_changed(x, y) {
                    (x0, x1, y0, y1) = (x0.min(x), x1.max(x), y0.min(y), y1.max(y));
                }
            }
        }
        if x0 > x1 {
            // Nothing moved: one transparent pixel holds the time.
            (x0, x1, y0, y1) = (0, 0, 0, 0);
        }
        let changed_pixels = (y0..=y1)
            .flat_map(|y| (x0..=x1).map(move |x| (x, y)))
            .filter(|&(x, y)| is_changed(x, y))
            .map(|(x, y)| &rgb[at(x, y)..at(x, y) + 3]);
        let mut palette = Palette::for_pixels(changed_pixels);
        let (palette_bytes, transparent) = palette.bytes();
        let mut indices = Vec::with_capacity((x1 - x0 + 1) * (y1 - y0 + 1));
        for y in y0..=y1 {
            for x in x0..=x1 {
                if !is_changed(x, y) {
                    indices.push(transparent);
                    continue;
                }
                let i = at(x, y);
                indices.push(palette.index_of([rgb[i], rgb[i + 1], rgb[i + 2]]));
            }
        }
        let frame = Frame {
            delay: u16::try_from(delay_ms.div_ceil(10)).unwrap_or(u16::MAX),
            dispose: DisposalMethod::Keep,
            transparent: Some(transparent),
            left: x0 as u16,
            top: y0 as u16,
            width: (x1 - x0 + 1) as u16,
            height: (y1 - y0 + 1) as u16,
            palette: Some(palette_bytes),
            buffer: indices.into(),
            ..Frame::default()
        };
        self.encoder.write_frame(&frame).map_err(|e| e.to_string())?;
        self.previous.copy_from_slice(rgb);
        self.first = false;
        Ok(())
    }

    /// End the GIF and flush it to disk.
    pub fn finish(self) -> Result<(), String> {
        let writer = self.encoder.into_inner().map_err(|e| e.to_string())?;
        let file = writer.into_inner().map_err(|e| e.into_error().to_string())?;
        file.sync_all().map_err(|e| e.to_string())
    }
}

#[cfg(test)]
pub mod tests {
    use super::*;

    /// Every frame of the GIF at `path` as the viewer shows it (RGB), with
    /// each frame's delay in milliseconds.
    pub fn decode(path: &Path) -> Vec<(Vec<u8>, u32)> {
        let mut options = gif::DecodeOptions::new();
        options.set_color_output(gif::ColorOutput::RGBA);
        let mut decoder = options.read_info(File::open(path).unwrap()).unwrap();
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

    /// A test image: a gradient with more colours than a palette holds, and a
    /// red square at `square_x`.
    fn image(square_x: usize) -> Vec<u8> {
        let (w, h) = (64, 48);
        let mut rgb = Vec::with_capacity(w * h * 3);
        for y in 0..h {
            for x in 0..w {
                let inside = (square_x..square_x + 8).contains(&x) && (20..28).contains(&y);
                rgb.extend(if inside { [230, 10, 10] } else { [(x * 4) as u8, (y * 5) as u8, 128] });
            }
        }
        rgb
    }

    #[test]
    fn frames_read_back_as_drawn_where_their_palettes_are_exact() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("squares.gif");
        let mut file = GifFile::create(&path, (64, 48)).unwrap();
        let drawn: Vec<Vec<u8>> = [4, 20, 36, 36].into_iter().map(image).collect();
        for rgb in &drawn {
            file.add_frame(rgb, 40).unwrap();
        }
        file.finish().unwrap();
        let shown = decode(&path);
        assert_eq!(shown.len(), 4);
        assert!(shown.iter().all(|(_, delay_ms)| *delay_ms == 40));
        for (i, (rgb, (seen, _))) in drawn.iter().zip(&shown).enumerate() {
            // The first frame's gradient needed the fixed palette: near (no
            // farther than the colour cube's half step in each channel).
            for (a, b) in rgb.chunks_exact(3).zip(seen.chunks_exact(3)) {
                let distance: u32 = (0..3).map(|k| u32::from(a[k].abs_diff(b[k])).pow(2)).sum();
                assert!(distance <= 3 * 26 * 26, "{a:?} shown as {b:?}");
            }
            // The square, drawn after the first frame with the few colours
            // that changed: exact.
            if i > 0 {
                let at = (0..64).find(|&x| rgb[(24 * 64 + x) * 3] == 230).unwrap();
                assert_eq!(seen[(24 * 64 + at + 3) * 3..][..3], [230, 10, 10]);
            }
        }
    }
}
