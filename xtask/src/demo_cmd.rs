//! `cargo xtask demo`: build Struck in release and render the demo offline
//! (no sound card), all into `demo/`: the seed's lab (`struck demo`: Sounds
//! 1-12, every figure, the animations, `demo/index.html`), every MIDI file in
//! `demo-songs/` through `struck render`, and the lab bench's santoor strike.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Result, bail};

use crate::steps::{self, Step};
use crate::util::{relative, run, workspace_root};
use crate::{Options, bundle, footprint, packages};

/// The demo songs' folder; a song's instrument is its file name up to the
/// first '-' (`piano-*.mid`, `santoor-*.mid`, ...).
pub const SONGS_DIR: &str = "demo-songs";
/// Where the demo is written.
pub const OUT_DIR: &str = "demo";

/// A song to render: the MIDI file, the WAV to write and the instrument.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Song {
    pub midi: PathBuf,
    pub wav: PathBuf,
    pub instrument: String,
}

/// The song a file in `demo-songs/` stands for, or `None` if it is not a MIDI file.
pub fn song(midi: &Path, out_dir: &Path) -> Option<Song> {
    let extension = midi.extension()?.to_str()?.to_ascii_lowercase();
    if extension != "mid" && extension != "midi" {
        return None;
    }
    let stem = midi.file_stem()?.to_str()?;
    let instrument = stem.split_once('-').map_or(stem, |(prefix, _)| prefix);
    if instrument.is_empty() {
        return None;
    }
    Some(Song {
        midi: midi.to_path_buf(),
        wav: out_dir.join(format!("{stem}.wav")),
        instrument: instrument.to_ascii_lowercase(),
    })
}

/// The songs in `dir`, sorted by file name.
pub fn songs(dir: &Path, out_dir: &Path) -> Result<Vec<Song>> {
    let mut files: Vec<PathBuf> = match std::fs::read_dir(dir) {
        Ok(entries) => entries.flatten().map(|e| e.path()).filter(|p| p.is_file()).collect(),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => Vec::new(),
        Err(e) => bail!("{}: {e}", dir.display()),
    };
    files.sort();
    Ok(files.iter().filter_map(|f| song(f, out_dir)).collect())
}

/// The duration in seconds of a RIFF WAVE file from its header, if it has one.
pub fn wav_duration_s(bytes: &[u8]) -> Option<f64> {
    if bytes.len() < 12 || &bytes[0..4] != b"RIFF" || &bytes[8..12] != b"WAVE" {
        return None;
    }
    let u16_at = |i: usize| Some(u16::from_le_bytes(bytes.get(i..i + 2)?.try_into().ok()?));
    let u32_at = |i: usize| Some(u32::from_le_bytes(bytes.get(i..i + 4)?.try_into().ok()?));
    let (mut rate, mut block_align) = (None, None);
    let mut at = 12;
    while at + 8 <= bytes.len() {
        let id = &bytes[at..at + 4];
        let size = u32_at(at + 4)? as usize;
        let body = at + 8;
        if id == b"fmt " {
            rate = u32_at(body + 4);
            block_align = u16_at(body + 12);
        } else if id == b"data" {
            let (rate, block_align) = (rate?, block_align?);
            if rate == 0 || block_align == 0 {
                return None;
            }
            return Some((size / block_align as usize) as f64 / rate as f64);
        }
        at = body + size + (size & 1);
    }
    None
}

fn describe(path: &Path) -> String {
    let Ok(bytes) = std::fs::read(path) else { return "missing".to_string() };
    let size = if bytes.len() >= 1 << 20 {
        format!("{:.1} MiB", bytes.len() as f64 / (1 << 20) as f64)
    } else {
        format!("{:.0} KiB", (bytes.len() as f64 / 1024.0).ceil())
    };
    match wav_duration_s(&bytes) {
        Some(d) => format!("{d:.1} s, {size}"),
        None => size,
    }
}

pub fn demo(options: &Options) -> Result<()> {
    let root = workspace_root();
    let out_dir = root.join(OUT_DIR);
    let songs = songs(&root.join(SONGS_DIR), &out_dir)?;
    let struck = || -> Result<Command> { Ok(Command::new(bundle::struck_binary(true)?)) };

    let steps = vec![
        Step::new("packages", "the system packages the build needs", || {
            packages::ensure(packages::BUILD, options.install)
        }),
        Step::new("build", "cargo xtask bundle struck --release (the `struck` binary, and the plugin bundles)", || {
            bundle::bundle(true, false)
        }),
        Step::new(
            "seed",
            "the seed's lab: Euphonics 12.2's Sounds 1-12, figures and animations (`struck demo`)",
            || run(struck()?.args(["demo", "--out", OUT_DIR])),
        ),
        Step::new("strike", "the lab demo: Euphonics 12.2's santoor string struck by a 1 g mallet", || {
            std::fs::create_dir_all(&out_dir)?;
            run(struck()?
                .args(["strike", "cases/santoor-a4.json", "--out", OUT_DIR, "--wav"])
                .arg(relative(&out_dir.join("santoor-a4.wav"))))
        }),
        Step::new("songs", format!("render {SONGS_DIR}/*.mid into {OUT_DIR}/ with `struck render`"), || {
            if songs.is_empty() {
                bail!("no demo songs: {SONGS_DIR}/*.mid not found");
            }
            std::fs::create_dir_all(&out_dir)?;
            for song in &songs {
                run(struck()?
                    .arg("render")
                    .arg(relative(&song.midi))
                    .arg("--out")
                    .arg(relative(&song.wav))
                    .args(["--instrument", &song.instrument]))?;
            }
            Ok(())
        }),
        Step::new("footprint", "each bundle under 15 MB", || footprint::check(true)),
    ];
    let names: Vec<&str> = steps.iter().map(|s| s.name).collect();
    let outcomes = steps::run("demo", &steps, &vec![true; steps.len()]);
    println!("{}", steps::summary("demo", &names, &outcomes));

    let mut written: Vec<PathBuf> = vec![
        out_dir.join("index.html"),
        out_dir.join("santoor-a4.wav"),
        out_dir.join("metrics.json"),
        out_dir.join("trace.csv"),
    ];
    written.extend(songs.iter().map(|s| s.wav.clone()));
    let present: Vec<&PathBuf> = written.iter().filter(|p| p.exists()).collect();
    if !present.is_empty() {
        println!("\nThe demo is in {}:", out_dir.display());
        let width = present.iter().map(|p| relative(p).display().to_string().len()).max().unwrap_or(0);
        for path in present {
            println!("  {:<width$}  {}", relative(path).display().to_string(), describe(path));
        }
    }
    if !steps::all_passed(&outcomes) {
        bail!("the demo is incomplete");
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_instrument_is_the_file_name_prefix() {
        let out = Path::new("demo");
        let s = song(Path::new("demo-songs/piano-nocturne.mid"), out).unwrap();
        assert_eq!(s.instrument, "piano");
        assert_eq!(s.wav, Path::new("demo/piano-nocturne.wav"));
        assert_eq!(song(Path::new("x/Santoor-dance-2.MID"), out).unwrap().instrument, "santoor");
        assert_eq!(song(Path::new("x/clavichord.midi"), out).unwrap().instrument, "clavichord");
        assert_eq!(song(Path::new("x/harpsichord-a.mid"), out).unwrap().wav, Path::new("demo/harpsichord-a.wav"));
    }

    #[test]
    fn other_files_are_not_songs() {
        let out = Path::new("demo");
        assert_eq!(song(Path::new("demo-songs/README.md"), out), None);
        assert_eq!(song(Path::new("demo-songs/piano"), out), None);
        assert_eq!(song(Path::new("demo-songs/-x.mid"), out), None);
    }

    #[test]
    fn songs_are_listed_in_order_and_a_missing_folder_is_empty() {
        let dir = std::env::temp_dir().join(format!("xtask-songs-{}", std::process::id()));
        std::fs::create_dir_all(&dir).unwrap();
        for name in ["santoor-b.mid", "notes.txt", "piano-a.mid"] {
            std::fs::write(dir.join(name), b"").unwrap();
        }
        let found = songs(&dir, Path::new("demo")).unwrap();
        std::fs::remove_dir_all(&dir).unwrap();
        let instruments: Vec<&str> = found.iter().map(|s| s.instrument.as_str()).collect();
        assert_eq!(instruments, ["piano", "santoor"]);
        assert!(songs(&dir, Path::new("demo")).unwrap().is_empty());
    }

    fn wav(rate: u32, channels: u16, bits: u16, frames: u32, extra_chunk: bool) -> Vec<u8> {
        let block_align = channels * bits / 8;
        let mut b = Vec::new();
        b.extend_from_slice(b"RIFF\0\0\0\0WAVE");
        if extra_chunk {
            b.extend_from_slice(b"LIST\x03\0\0\0abc\0");
        }
        b.extend_from_slice(b"fmt \x10\0\0\0");
        b.extend_from_slice(&3u16.to_le_bytes());
        b.extend_from_slice(&channels.to_le_bytes());
        b.extend_from_slice(&rate.to_le_bytes());
        b.extend_from_slice(&(rate * block_align as u32).to_le_bytes());
        b.extend_from_slice(&block_align.to_le_bytes());
        b.extend_from_slice(&bits.to_le_bytes());
        b.extend_from_slice(b"data");
        b.extend_from_slice(&(frames * block_align as u32).to_le_bytes());
        b
    }

    #[test]
    fn wav_durations_come_from_the_header() {
        assert_eq!(wav_duration_s(&wav(48_000, 2, 32, 96_000, false)), Some(2.0));
        assert_eq!(wav_duration_s(&wav(44_100, 1, 16, 22_050, true)), Some(0.5));
        assert_eq!(wav_duration_s(b"RIFF\0\0\0\0WAVEdata\0\0\0\0"), None);
        assert_eq!(wav_duration_s(b"not a wav"), None);
    }
}
