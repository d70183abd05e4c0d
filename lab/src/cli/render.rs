//! `struck render SONG.mid --out SONG.wav`: a MIDI file played offline through the
//! same real-time synth the plugin runs ([`Synth::process`], block by block, events
//! at their sample offsets within each block).
//!
//! The output is a stereo 32-bit float WAV at the synth's own level (not
//! normalised, so renders keep their relative loudness; a peak above full scale
//! survives in float and is reported). It lasts exactly from time 0 to the last
//! MIDI event plus `--tail-s`: a predictable length rather than "until silent".
//! The same file gives the same samples on every run and for every block size.
//!
//! A preset is a JSON file read by [`struck_engine::preset`] (instrument, voicing,
//! controls, tuning; every part optional, unknown fields refused). The tuning
//! flags (`--a4`, `--temperament`, `--stretch`, `--scl`, `--kbm`) override the
//! preset's tuning field by field.

use std::io::{self, IsTerminal};
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use struck_engine::body::Output;
use struck_engine::body::soundboard::Perspective;
use struck_engine::design::InstrumentKind;
use struck_engine::preset::Preset;
use struck_engine::synth::{Event, Instrument, Synth, TimedEvent};
use struck_engine::tuning::{A4_RANGE_HZ, KeyboardMapping, ScalaScale, Temperament, TuningSettings};

use super::output::{Slot, Staged, staged_write_failure};
use crate::cli::Failure;
use crate::console;
use crate::midi_file::{self, ReadOptions};

/// Sample rates rendered, Hz.
pub const SAMPLE_RATES_HZ: std::ops::RangeInclusive<u32> = 22_050..=192_000;
/// Longest tail after the last event, s.
pub const MAX_TAIL_S: f64 = 600.0;
/// Largest block handed to the synth, samples.
pub const MAX_BLOCK_SIZE: usize = 8192;
/// A WAV's sizes are 32-bit: the data may not exceed this many bytes.
const MAX_WAV_DATA_BYTES: u64 = u32::MAX as u64 - 64;
/// Bytes before a float WAV's samples (hound's RIFF, fmt and fact chunks).
pub const WAV_HEADER_BYTES: u64 = 68;
/// Memory a render holds, whatever the song's length (the WAV is written as
/// it is played): at most 20 MB measured for every instrument, rounded up.
const RENDER_PEAK_BYTES: u64 = 32 << 20;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// The songs: standard MIDI files, format 0 or 1. Several are rendered at
    /// once, one a core, each as it would be alone.
    #[arg(required = true, num_args = 1.., value_name = "SONG")]
    pub songs: Vec<PathBuf>,
    /// The WAV to write (stereo, 32-bit float); with several songs, the folder
    /// their WAVs are written into, each named after its song (a.mid -> a.wav).
    /// An existing file is replaced only once every render is complete.
    #[arg(long, value_name = "FILE|DIR")]
    pub out: PathBuf,
    /// piano|fortepiano|santoor|dulcimer|cimbalom|clavichord|harpsichord [default: the
    /// preset's, else piano]
    #[arg(long, value_name = "NAME")]
    pub instrument: Option<String>,
    /// A JSON preset: {"name": ..., "instrument": ..., "voicing": {...}, "controls": {...},
    /// "tuning": {...}}, every part and field optional (the README lists them).
    /// --instrument and the tuning flags override its fields.
    #[arg(long, value_name = "FILE")]
    pub preset: Option<PathBuf>,
    /// Frequency of A4, Hz (380 to 480) [default: the preset's, else 440]
    #[arg(long, value_name = "HZ", allow_negative_numbers = true)]
    pub a4: Option<f64>,
    /// equal|meantone|werckmeister3|vallotti (quarter-comma meantone, Werckmeister III and
    /// Vallotti are laid from C, with A4 kept at --a4) [default: the preset's, else equal]
    #[arg(long, value_name = "NAME")]
    pub temperament: Option<String>,
    /// Share of the stretch the strings' own inharmonicity asks for, 0 (none) to 1
    /// (every octave beatless on the lower key's second partial) [default: the preset's, else 1, as a tuner tunes]
    #[arg(long, value_name = "0..1", allow_negative_numbers = true)]
    pub stretch: Option<f64>,
    /// Tune to a Scala scale (.scl), degree 0 on C4 at its equal-tempered pitch
    /// from --a4 unless --kbm says otherwise; replaces the preset's scale.
    #[arg(long, value_name = "FILE.scl")]
    pub scl: Option<PathBuf>,
    /// A Scala keyboard mapping (.kbm) for the scale: which key plays which degree,
    /// and the reference key and frequency. Keys it leaves unmapped stay in equal
    /// temperament.
    #[arg(long, value_name = "FILE.kbm")]
    pub kbm: Option<PathBuf>,
    /// Sample rate, Hz (22050 to 192000).
    #[arg(long, value_name = "HZ", default_value_t = 48_000.0, allow_negative_numbers = true)]
    pub sample_rate: f64,
    /// Seconds rendered after the last MIDI event (0 to 600): the WAV lasts exactly
    /// the last event's time plus this.
    #[arg(long, value_name = "S", default_value_t = 4.0, allow_negative_numbers = true)]
    pub tail_s: f64,
    /// Samples per call to the synth (1 to 8192); the output is the same for any size.
    #[arg(long, value_name = "N", default_value_t = 512, allow_negative_numbers = true)]
    pub block_size: i64,
    /// What is heard: mics (the body through its pair of microphones) or bridge
    /// (the strings' force on a rigid bridge, panned: the seed's surrogate)
    /// [default: the preset's, else mics]
    #[arg(long, value_name = "mics|bridge")]
    pub output: Option<String>,
    /// Where the microphones listen from: close|player|lid|coincident [default: the preset's, else close]
    #[arg(long, value_name = "NAME")]
    pub mics: Option<String>,
    /// Play channel 10 too (ignored by default: General MIDI keeps drums there).
    #[arg(long)]
    pub include_channel_10: bool,
    /// The song is MPE: channels 2-16 (10 too) bend their own notes over this
    /// many semitones each way (48 unless given, as --mpe=24) and set their
    /// timbre (CC74: the felt's hardness); channel 1 bends all
    #[arg(
        long,
        value_name = "SEMITONES",
        num_args = 0..=1,
        require_equals = true,
        default_missing_value = "48",
        allow_negative_numbers = true
    )]
    pub mpe: Option<f64>,
    /// Print nothing on success (and show no progress bar).
    #[arg(long, short)]
    pub quiet: bool,
}

/// One song to render: read and checked, its WAV reserved.
struct Job {
    out: PathBuf,
    shown: String,
    events: Vec<(u64, Event)>,
    notes: usize,
    playable: usize,
    total: u64,
    slot: Slot,
}

/// What a render gave.
struct Rendered {
    peak: f32,
    wall_s: f64,
    guard: Option<String>,
}

/// Why a render stopped.
enum Stopped {
    Interrupted,
    NonFinite(u64),
    Write(io::Error),
}

pub fn run(args: &RenderArgs) -> Result<(), Failure> {
    let sample_rate_hz = check_sample_rate(args.sample_rate)?;
    let tail_s = check_tail(args.tail_s)?;
    let block_size = check_block_size(args.block_size)?;
    let preset = match &args.preset {
        Some(path) => Preset::load(path).map_err(|e| Failure::bad_input(e.to_string()))?,
        None => Preset::default(),
    };
    let tuning = tuning(args, &preset.tuning)?;
    let kind = match &args.instrument {
        Some(name) => name.parse::<InstrumentKind>().map_err(|e| Failure::bad_input(format!("--instrument: {e}")))?,
        None => preset.instrument.unwrap_or_default(),
    };
    let mpe_bend_range = check_mpe(args.mpe)?;
    let options = ReadOptions { include_channel_10: args.include_channel_10, mpe_bend_range };
    let outs = outputs(&args.songs, &args.out)?;

    let tuned = tuning != TuningSettings::default();
    let mut controls = preset.controls;
    if let Some(output) = &args.output {
        controls.output = match output.to_ascii_lowercase().as_str() {
            "mics" | "microphones" => Output::Microphones,
            "bridge" | "bridge-force" => Output::BridgeForce,
            _ => return Err(Failure::bad_input(format!("--output {output}: expected mics or bridge"))),
        };
    }
    let mut mics = preset.mics;
    if let Some(name) = &args.mics {
        mics.perspective = Perspective::ALL
            .into_iter()
            .find(|p| p.name().eq_ignore_ascii_case(name))
            .ok_or_else(|| Failure::bad_input(format!("--mics {name}: expected close, player, lid or coincident")))?;
    }
    let settings =
        Preset { instrument: Some(kind), tuning, mics, controls, ..preset.clone() }.settings(f64::from(sample_rate_hz));

    // Every song is read and checked, and every WAV's temporary made beside
    // it, before anything is built or rendered: a bad song or an --out that
    // cannot be written is refused with nothing written.
    let inputs: Vec<&Path> = args
        .songs
        .iter()
        .map(PathBuf::as_path)
        .chain([args.preset.as_deref(), args.scl.as_deref(), args.kbm.as_deref()].into_iter().flatten())
        .collect();
    let mut staged = Staged::reading(&inputs);
    let mut jobs = Vec::with_capacity(args.songs.len());
    for (song, out) in args.songs.iter().zip(outs) {
        let job = read_song(song, out, kind, sample_rate_hz, tail_s, options, &mut staged)?;
        jobs.push(job);
    }
    let threads = std::thread::available_parallelism().map_or(1, |n| n.get()).min(jobs.len()).max(1);
    if let Some(room) = super::room::short_of_memory(RENDER_PEAK_BYTES * threads as u64) {
        return Err(Failure::bad_input(format!(
            "the {kind} would hold {} in memory while it plays; {}; nothing was written",
            super::room::size_text_rounded(RENDER_PEAK_BYTES * threads as u64),
            room.told
        )));
    }
    // Ctrl-C (or SIGTERM) stops after the instrument is built or between
    // blocks, so nothing (or only the partial files, then removed) is written.
    let build = || {
        Instrument::build(&settings).map_err(|e| match (&args.preset, tuned) {
            (Some(path), _) => {
                Failure::bad_input(format!("{}: the {kind} cannot be built with this preset: {e}", path.display()))
            }
            (None, true) => Failure::bad_input(format!("the {kind} cannot be built in this tuning: {e}")),
            (None, false) => Failure::failed(format!("cannot build the {kind}: {e}")),
        })
    };
    // (Built once here, so that a preset or tuning the instrument cannot take
    // is refused before any render starts; the first song plays it.)
    let first = build()?;
    if crate::cleanup::interrupted() {
        return Err(Failure::interrupted());
    }

    if !args.quiet {
        for job in jobs.iter().filter(|j| j.playable < j.notes) {
            console::err(format!(
                "struck render: {}: {} of {} are outside the {kind}'s keys (MIDI {}..={}) and stay silent",
                job.shown,
                count(job.notes - job.playable, "note"),
                job.notes,
                kind.key_range().start(),
                kind.key_range().end()
            ));
        }
    }

    let all: u64 = jobs.iter().map(|j| j.total).sum();
    let progress = (!args.quiet && io::stderr().is_terminal()).then(|| progress_bar(all));
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: sample_rate_hz,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let temporaries: Vec<PathBuf> = jobs.iter().map(|j| staged.temporary(j.slot).to_path_buf()).collect();
    let first = std::sync::Mutex::new(Some(first));
    let play = |(job, temporary): (&Job, &PathBuf)| -> Result<Rendered, Failure> {
        let instrument = match first.lock().ok().and_then(|mut f| f.take()) {
            Some(built) => built,
            None => build()?,
        };
        let (mut synth, _) = Synth::new(Box::new(instrument));
        synth.set_controls(controls);
        let started = Instant::now();
        let peak = write_wav(&mut synth, job, block_size, spec, temporary, progress.as_ref());
        let wall_s = started.elapsed().as_secs_f64();
        let guard = synth.guard();
        let guard = guard.acted().then(|| guard.describe(f64::from(sample_rate_hz)));
        match peak {
            Ok(peak) => Ok(Rendered { peak, wall_s, guard }),
            Err(Stopped::Interrupted) => Err(Failure::interrupted()),
            Err(Stopped::NonFinite(sample)) => Err(Failure::failed(format!(
                "{}: the synth produced a non-finite sample at {:.3} s; nothing was written",
                job.shown,
                sample as f64 / f64::from(sample_rate_hz)
            ))),
            Err(Stopped::Write(e)) => Err(staged_write_failure(&job.out, temporary, &e)),
        }
    };
    // (Where no thread can be started, the songs play one after another on
    // this one, with the same samples.)
    let pool = (threads > 1).then(|| rayon::ThreadPoolBuilder::new().num_threads(threads).build());
    let results: Vec<Result<Rendered, Failure>> = match pool {
        Some(Ok(pool)) => pool.install(|| jobs.par_iter().zip(&temporaries).map(play).collect()),
        other => {
            if let Some(Err(e)) = other
                && !args.quiet
            {
                console::err(format!("struck render: rendering one song at a time (no thread could be started: {e})"));
            }
            jobs.iter().zip(&temporaries).map(play).collect()
        }
    };
    if let Some(bar) = &progress {
        bar.finish_and_clear();
    }
    if crate::cleanup::interrupted() {
        return Err(Failure::interrupted());
    }
    let mut rendered = Vec::with_capacity(results.len());
    for (job, result) in jobs.iter().zip(results) {
        rendered.push(result?);
        staged.mark_written(job.slot);
    }
    staged.commit()?;

    for (job, done) in jobs.iter().zip(&rendered) {
        // The output's guard is a last line: say so whenever it was reached.
        if let Some(guard) = &done.guard {
            console::err(format!(
                "struck render: {}: {guard}; lower the velocities or controls.output_gain",
                job.shown
            ));
        }
        if args.quiet {
            continue;
        }
        let audio_s = job.total as f64 / f64::from(sample_rate_hz);
        let peak_note = if done.peak > 0.0 {
            let db = 20.0 * f64::from(done.peak).log10();
            let over = if done.peak > 1.0 { " (above full scale: lower controls.output_gain in a preset)" } else { "" };
            format!("peak {db:+.1} dBFS{over}")
        } else {
            "silent".to_string()
        };
        // (A scale's description is the file's text: its control characters are shown, not acted on.)
        let tuning_note = if tuned {
            format!(" ({})", super::failure::printable(&settings.tuning.describe()))
        } else {
            String::new()
        };
        console::out(format!(
            "{} -> {}: {kind}{tuning_note}, {}, {audio_s:.2} s at {sample_rate_hz} Hz in {:.2} s \
             ({:.1}x real time), {peak_note}",
            job.shown,
            super::shown(&job.out),
            count(job.notes, "note"),
            done.wall_s,
            audio_s / done.wall_s.max(1e-9)
        ));
    }
    Ok(())
}

/// Where each song's WAV goes: `out` itself for one song; for several, `out`
/// is a folder and each WAV is named after its song.
fn outputs(songs: &[PathBuf], out: &Path) -> Result<Vec<PathBuf>, Failure> {
    if songs.len() == 1 {
        return Ok(vec![out.to_path_buf()]);
    }
    if out.exists() && !out.is_dir() {
        return Err(Failure::bad_input(format!(
            "--out {}: with {} songs, --out is the folder their WAVs go into, and this is a file",
            super::shown(out),
            songs.len()
        )));
    }
    let mut outs: Vec<PathBuf> = Vec::with_capacity(songs.len());
    for song in songs {
        let stem = song.file_stem().filter(|s| !s.is_empty()).ok_or_else(|| {
            Failure::bad_input(format!("{}: has no file name to name its WAV after", super::shown(song)))
        })?;
        let path = out.join(Path::new(stem).with_extension("wav"));
        if let Some(other) = outs.iter().position(|o| *o == path) {
            return Err(Failure::bad_input(format!(
                "{} and {}: both would be written to {}",
                super::shown(&songs[other]),
                super::shown(song),
                super::shown(&path)
            )));
        }
        outs.push(path);
    }
    Ok(outs)
}

/// Read `song` and check it can be rendered on `kind` into `out` (reserved in `staged`).
fn read_song(
    song: &Path,
    out: PathBuf,
    kind: InstrumentKind,
    sample_rate_hz: u32,
    tail_s: f64,
    options: ReadOptions,
    staged: &mut Staged,
) -> Result<Job, Failure> {
    let shown = super::shown(song);
    let bytes = super::input::read(song, super::input::MAX_SONG_BYTES)?;
    let read =
        midi_file::read(&bytes, sample_rate_hz, options).map_err(|e| Failure::bad_input(format!("{shown}: {e}")))?;
    let keys = kind.key_range();
    let playable: usize = keys.clone().map(|k| read.notes_per_key[usize::from(k)]).sum();
    let notes = read.note_count();
    if playable == 0 {
        return Err(Failure::bad_input(format!(
            "{shown}: none of its {} is on the {kind}'s keys (MIDI {}..={})",
            count(notes, "note"),
            keys.start(),
            keys.end()
        )));
    }
    let fs_hz = f64::from(sample_rate_hz);
    let total = read.last_sample() + (tail_s * fs_hz).round() as u64;
    if total.saturating_mul(8) > MAX_WAV_DATA_BYTES {
        return Err(Failure::bad_input(format!(
            "{shown}: {:.0} s at {sample_rate_hz} Hz would exceed the 4 GB a WAV file can hold",
            total as f64 / fs_hz
        )));
    }
    let slot = staged.reserve(&out)?;
    super::room::check_file_size(&out, WAV_HEADER_BYTES + total * 8)?;
    Ok(Job { out, shown, events: read.events, notes, playable, total, slot })
}

/// Play `job` through `synth` into a WAV at `temporary`; its peak.
fn write_wav(
    synth: &mut Synth,
    job: &Job,
    block_size: usize,
    spec: hound::WavSpec,
    temporary: &Path,
    progress: Option<&ProgressBar>,
) -> Result<f32, Stopped> {
    let mut peak = 0.0f32;
    let mut non_finite: Option<u64> = None;
    let mut interrupted = false;
    let written = (|| -> io::Result<()> {
        let file = std::fs::File::create(temporary)?;
        let synced = file.try_clone()?;
        let mut wav = hound::WavWriter::new(io::BufWriter::new(file), spec).map_err(io::Error::other)?;
        let mut done = 0u64;
        render(synth, &job.events, job.total, block_size, |left, right| {
            if crate::cleanup::interrupted() {
                interrupted = true;
                return Err(io::Error::other("interrupted"));
            }
            for (&l, &r) in left.iter().zip(right) {
                if !(l.is_finite() && r.is_finite()) {
                    non_finite = Some(done);
                    return Err(io::Error::other("a non-finite sample"));
                }
                peak = peak.max(l.abs()).max(r.abs());
                wav.write_sample(l).map_err(io::Error::other)?;
                wav.write_sample(r).map_err(io::Error::other)?;
                done += 1;
            }
            if let Some(bar) = progress {
                bar.inc(left.len() as u64);
            }
            Ok(())
        })?;
        wav.finalize().map_err(io::Error::other)?;
        synced.sync_all()
    })();
    match (written, non_finite) {
        (_, Some(sample)) => Err(Stopped::NonFinite(sample)),
        (Err(_), None) if interrupted => Err(Stopped::Interrupted),
        (Err(e), None) => Err(Stopped::Write(e)),
        (Ok(()), None) => Ok(peak),
    }
}

/// Play `events` (sample times from the start, in order) through `synth` for
/// `total` samples, `block_size` at a time, handing each block's output to `sink`.
/// Events are passed with times relative to their block, as a host does.
fn render(
    synth: &mut Synth,
    events: &[(u64, Event)],
    total: u64,
    block_size: usize,
    mut sink: impl FnMut(&[f32], &[f32]) -> io::Result<()>,
) -> io::Result<()> {
    let mut left = vec![0.0f32; block_size];
    let mut right = vec![0.0f32; block_size];
    let mut block_events: Vec<TimedEvent> = Vec::with_capacity(256);
    let mut next = 0;
    let mut start = 0u64;
    while start < total {
        let len = (total - start).min(block_size as u64) as usize;
        let end = start + len as u64;
        // The last block also takes events stamped at its very end (a zero tail).
        let last = end == total;
        block_events.clear();
        while let Some(&(time, event)) = events.get(next)
            && (time < end || last)
        {
            block_events.push(TimedEvent::new((time - start) as u32, event));
            next += 1;
        }
        synth.process(&block_events, &mut left[..len], &mut right[..len]);
        sink(&left[..len], &right[..len])?;
        start = end;
    }
    Ok(())
}

fn progress_bar(total: u64) -> ProgressBar {
    let style = ProgressStyle::with_template("{spinner} rendering [{bar:40}] {percent:>3}% (eta {eta})")
        .unwrap_or_else(|_| ProgressStyle::default_bar())
        .progress_chars("=> ");
    ProgressBar::new(total).with_style(style)
}

/// "1 note", "2 notes".
pub fn count(n: usize, noun: &str) -> String {
    if n == 1 { format!("1 {noun}") } else { format!("{n} {noun}s") }
}

fn check_sample_rate(hz: f64) -> Result<u32, Failure> {
    let (lo, hi) = (*SAMPLE_RATES_HZ.start(), *SAMPLE_RATES_HZ.end());
    if hz.fract() == 0.0 && (f64::from(lo)..=f64::from(hi)).contains(&hz) {
        Ok(hz as u32)
    } else {
        Err(Failure::bad_input(format!(
            "--sample-rate: must be a whole number of Hz from {lo} to {hi} (got {})",
            struck_engine::readable(hz)
        )))
    }
}

fn check_mpe(range: Option<f64>) -> Result<Option<f32>, Failure> {
    match range {
        None => Ok(None),
        Some(r) if (0.0..=96.0).contains(&r) => Ok(Some(r as f32)),
        Some(r) => Err(Failure::bad_input(format!(
            "--mpe: the bend range must be from 0 to 96 semitones (got {})",
            struck_engine::readable(r)
        ))),
    }
}

fn check_tail(tail_s: f64) -> Result<f64, Failure> {
    if (0.0..=MAX_TAIL_S).contains(&tail_s) {
        Ok(tail_s)
    } else {
        Err(Failure::bad_input(format!(
            "--tail-s: must be from 0 to {MAX_TAIL_S:.0} s (got {})",
            struck_engine::readable(tail_s)
        )))
    }
}

fn check_block_size(n: i64) -> Result<usize, Failure> {
    match usize::try_from(n) {
        Ok(n) if (1..=MAX_BLOCK_SIZE).contains(&n) => Ok(n),
        _ => Err(Failure::bad_input(format!("--block-size: must be from 1 to {MAX_BLOCK_SIZE} samples (got {n})"))),
    }
}

/// The preset's tuning with the tuning flags laid over it, checked.
fn tuning(args: &RenderArgs, preset: &TuningSettings) -> Result<TuningSettings, Failure> {
    let mut tuning = preset.clone();
    if let Some(hz) = args.a4 {
        if !A4_RANGE_HZ.contains(&hz) {
            return Err(Failure::bad_input(format!(
                "--a4: must be from {} to {} Hz (got {})",
                A4_RANGE_HZ.start(),
                A4_RANGE_HZ.end(),
                struck_engine::readable(hz)
            )));
        }
        tuning.a4_hz = hz;
    }
    if let Some(name) = &args.temperament {
        let temperament = name.parse::<Temperament>().map_err(|e| Failure::bad_input(format!("--temperament: {e}")))?;
        if args.scl.is_some() && temperament != Temperament::Scala {
            return Err(Failure::bad_input(format!(
                "--temperament {name} and --scl: a scale is its own temperament; give one or the other"
            )));
        }
        tuning.temperament = temperament;
    }
    if let Some(stretch) = args.stretch {
        if !(0.0..=1.0).contains(&stretch) {
            return Err(Failure::bad_input(format!(
                "--stretch: must be from 0 to 1 (got {})",
                struck_engine::readable(stretch)
            )));
        }
        tuning.stretch = stretch;
    }
    if let Some(path) = &args.scl {
        let scale = ScalaScale::load(path).map_err(|e| Failure::bad_input(format!("--scl {e}")))?;
        tuning.scale = Some(scale);
        tuning.temperament = Temperament::Scala;
    }
    if let Some(path) = &args.kbm {
        let mapping = KeyboardMapping::load(path).map_err(|e| Failure::bad_input(format!("--kbm {e}")))?;
        let Some(scale) = tuning.scale.as_mut() else {
            return Err(Failure::bad_input(
                "--kbm: a keyboard mapping needs a scale (--scl FILE, or a preset with one)",
            ));
        };
        scale.keyboard_mapping = Some(mapping);
        tuning.temperament = Temperament::Scala;
    }
    tuning.validate().map_err(|e| match e.field.as_str() {
        "temperament" => Failure::bad_input("--temperament: scala needs a scale (--scl FILE, or a preset with one)"),
        _ => Failure::bad_input(format!("tuning.{e}")),
    })?;
    Ok(tuning)
}

#[cfg(test)]
mod tests {
    use super::*;
    use struck_engine::synth::default_settings;

    /// Any block size gives the same samples (a short, busy passage: chords, pedal, bend).
    #[test]
    fn block_size_does_not_change_the_samples() {
        let events = [
            (0, Event::Sustain(0.6)),
            (10, Event::NoteOn { key: 60, velocity: 0.8 }),
            (10, Event::NoteOn { key: 64, velocity: 0.5 }),
            (700, Event::PitchBend(0.3)),
            (1500, Event::NoteOff { key: 60, velocity: 0.5 }),
            (1500, Event::NoteOn { key: 67, velocity: 1.0 }),
            (2000, Event::AllNotesOff),
        ];
        let play = |block: usize| {
            let instrument = Instrument::build(&default_settings(InstrumentKind::Piano, 48_000.0)).unwrap();
            let (mut synth, _scope) = Synth::new(Box::new(instrument));
            let mut out = Vec::new();
            render(&mut synth, &events, 3000, block, |l, r| {
                out.extend(l.iter().zip(r).flat_map(|(&l, &r)| [l, r]));
                Ok(())
            })
            .unwrap();
            out
        };
        let reference = play(64);
        assert_eq!(reference.len(), 6000);
        assert!(reference.iter().any(|&s| s != 0.0));
        for block in [1, 7, 500, 4096] {
            assert!(play(block) == reference, "block size {block}");
        }
    }
}
