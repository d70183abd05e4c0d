//! Writing results so that nothing is half-written: every file goes to a
//! temporary name beside its destination and is renamed into place only after
//! all of them were written in full.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use super::failure::Failure;

/// Files written to temporary names, waiting to be put in place together.
#[derive(Default)]
pub struct Staged {
    files: Vec<(PathBuf, PathBuf)>,
}

fn temporary_beside(path: &Path) -> PathBuf {
    let name = path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default();
    path.with_file_name(format!(".{name}.part-{}", std::process::id()))
}

impl Staged {
    /// Have `write_to` write a temporary file beside `path` and stage it.
    fn stage(&mut self, path: &Path, write_to: impl FnOnce(&Path) -> io::Result<()>) -> Result<(), Failure> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            fs::create_dir_all(parent)
                .map_err(|e| Failure::failed(format!("cannot create {}: {e}", parent.display())))?;
        }
        let temporary = temporary_beside(path);
        match write_to(&temporary) {
            Ok(()) => {
                self.files.push((temporary, path.to_path_buf()));
                Ok(())
            }
            Err(e) => {
                let _ = fs::remove_file(&temporary);
                Err(Failure::failed(format!("cannot write {}: {e}", path.display())))
            }
        }
    }

    /// Write one file through `fill`.
    pub fn write(
        &mut self,
        path: &Path,
        fill: impl FnOnce(&mut BufWriter<fs::File>) -> io::Result<()>,
    ) -> Result<(), Failure> {
        self.stage(path, |temporary| {
            let mut writer = BufWriter::new(fs::File::create(temporary)?);
            fill(&mut writer)?;
            writer.into_inner().map_err(|e| e.into_error())?.sync_all()
        })
    }

    /// Write a mono 32-bit float WAV.
    pub fn write_wav(&mut self, path: &Path, sample_rate_hz: f64, samples: &[f32]) -> Result<(), Failure> {
        self.write_mono(path, sample_rate_hz, 32, hound::SampleFormat::Float, samples, |w, s| w.write_sample(s))
    }

    /// Write a mono 16-bit PCM WAV (what every browser's player takes), clipping at full scale.
    pub fn write_wav16(&mut self, path: &Path, sample_rate_hz: f64, samples: &[f32]) -> Result<(), Failure> {
        self.write_mono(path, sample_rate_hz, 16, hound::SampleFormat::Int, samples, |w, s| {
            w.write_sample((s.clamp(-1.0, 1.0) * i16::MAX as f32).round() as i16)
        })
    }

    fn write_mono(
        &mut self,
        path: &Path,
        sample_rate_hz: f64,
        bits_per_sample: u16,
        sample_format: hound::SampleFormat,
        samples: &[f32],
        put: impl Fn(&mut hound::WavWriter<BufWriter<fs::File>>, f32) -> hound::Result<()>,
    ) -> Result<(), Failure> {
        let spec =
            hound::WavSpec { channels: 1, sample_rate: sample_rate_hz.round() as u32, bits_per_sample, sample_format };
        self.stage(path, |temporary| {
            let mut w = hound::WavWriter::create(temporary, spec).map_err(io::Error::other)?;
            for &s in samples {
                put(&mut w, s).map_err(io::Error::other)?;
            }
            w.finalize().map_err(io::Error::other)
        })
    }

    /// Put every staged file in place.
    pub fn commit(mut self) -> Result<(), Failure> {
        let files = std::mem::take(&mut self.files);
        for (i, (temporary, path)) in files.iter().enumerate() {
            if let Err(e) = fs::rename(temporary, path) {
                for (t, _) in &files[i..] {
                    let _ = fs::remove_file(t);
                }
                return Err(Failure::failed(format!("cannot write {}: {e}", path.display())));
            }
        }
        Ok(())
    }
}

impl Drop for Staged {
    /// Files not committed (an error came first) are removed.
    fn drop(&mut self) {
        for (temporary, _) in &self.files {
            let _ = fs::remove_file(temporary);
        }
    }
}

/// Write `value` as one CSV field (empty for none), shortest round-trip form.
pub fn csv_field(out: &mut impl Write, value: Option<f64>) -> io::Result<()> {
    match value {
        Some(v) => write!(out, "{v:e}"),
        None => Ok(()),
    }
}
