//! Writing results so that nothing is half-written: every file goes to a
//! temporary name beside its destination and is renamed into place only after
//! all of them were written in full.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use crate::Failure;

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
    /// Write one file through `fill` to a temporary name beside `path`.
    pub fn write(
        &mut self,
        path: &Path,
        fill: impl FnOnce(&mut BufWriter<fs::File>) -> io::Result<()>,
    ) -> Result<(), Failure> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            fs::create_dir_all(parent)
                .map_err(|e| Failure::failed(format!("cannot create {}: {e}", parent.display())))?;
        }
        let temporary = temporary_beside(path);
        let result = fs::File::create(&temporary).and_then(|file| {
            let mut writer = BufWriter::new(file);
            fill(&mut writer)?;
            writer.into_inner().map_err(|e| e.into_error())?.sync_all()
        });
        match result {
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

    /// Write a WAV file (hound needs a seekable file, not a writer).
    pub fn write_wav(&mut self, path: &Path, sample_rate_hz: f64, samples: &[f32]) -> Result<(), Failure> {
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            fs::create_dir_all(parent)
                .map_err(|e| Failure::failed(format!("cannot create {}: {e}", parent.display())))?;
        }
        let temporary = temporary_beside(path);
        let spec = hound::WavSpec {
            channels: 1,
            sample_rate: sample_rate_hz.round() as u32,
            bits_per_sample: 32,
            sample_format: hound::SampleFormat::Float,
        };
        let result = hound::WavWriter::create(&temporary, spec).and_then(|mut w| {
            for &s in samples {
                w.write_sample(s)?;
            }
            w.finalize()
        });
        match result {
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
