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
//! A preset is a JSON file with three optional parts (the engine's own structs,
//! each field optional; unknown fields are refused):
//!
//! ```json
//! {
//!   "instrument": "santoor",
//!   "voicing": { "hammer_mass": 1.2, "hammer_stiffness": 1.0, "hammer_exponent": 1.0,
//!                "strike_position": 1.0, "damping": 0.8, "unison_detune": 1.0 },
//!   "controls": { "touch_min": 0.0, "touch_max": 1.0, "touch_shape": 1.0, "polyphony": 64,
//!                 "output_gain": 1.0, "bend_range_semitones": 2.0 }
//! }
//! ```

use std::fs;
use std::io::{self, IsTerminal};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use serde::Deserialize;
use serde::de::DeserializeOwned;
use serde_json::{Map, Value};
use struck_engine::instrument::{InstrumentKind, Voicing};
use struck_engine::synth::{Controls, Event, Instrument, InstrumentSettings, Synth, TimedEvent};

use crate::Failure;
use crate::midi_file::{self, ReadOptions};
use crate::output::Staged;

/// Sample rates rendered, Hz.
pub const SAMPLE_RATES_HZ: std::ops::RangeInclusive<u32> = 22_050..=192_000;
/// Longest tail after the last event, s.
pub const MAX_TAIL_S: f64 = 600.0;
/// Largest block handed to the synth, samples.
pub const MAX_BLOCK_SIZE: usize = 8192;
/// A WAV's sizes are 32-bit: the data may not exceed this many bytes.
const MAX_WAV_DATA_BYTES: u64 = u32::MAX as u64 - 64;
/// Set by a stop signal while rendering.
static INTERRUPTED: AtomicBool = AtomicBool::new(false);
/// Exit status after a stop signal (128 + SIGINT, as shells report it).
const EXIT_INTERRUPTED: u8 = 130;

/// Samples between progress-bar updates.
const PROGRESS_EVERY: u64 = 1 << 15;

#[derive(clap::Args)]
pub struct RenderArgs {
    /// The song: a standard MIDI file, format 0 or 1.
    pub song: PathBuf,
    /// The WAV to write (stereo, 32-bit float). An existing file is replaced only
    /// once the render is complete.
    #[arg(long, value_name = "FILE")]
    pub out: PathBuf,
    /// piano, santoor, clavichord or harpsichord [default: the preset's, else piano]
    #[arg(long, value_name = "NAME")]
    pub instrument: Option<String>,
    /// A JSON preset: {"instrument": ..., "voicing": {...}, "controls": {...}}, every
    /// part and field optional (the README lists them). --instrument overrides its instrument.
    #[arg(long, value_name = "FILE")]
    pub preset: Option<PathBuf>,
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
    /// Play channel 10 too (ignored by default: General MIDI keeps drums there).
    #[arg(long)]
    pub include_channel_10: bool,
    /// Print nothing on success (and show no progress bar).
    #[arg(long, short)]
    pub quiet: bool,
}

/// A render preset. Every part is optional: what is missing is the instrument as built.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields, default)]
pub struct Preset {
    /// Piano when neither the preset nor --instrument names one.
    pub instrument: Option<InstrumentKind>,
    /// Scale factors on the instrument's own values (1 = as built).
    pub voicing: Voicing,
    /// Touch, polyphony, output gain, bend range.
    pub controls: Controls,
}

pub fn run(args: &RenderArgs) -> Result<(), Failure> {
    let sample_rate_hz = check_sample_rate(args.sample_rate)?;
    let tail_s = check_tail(args.tail_s)?;
    let block_size = check_block_size(args.block_size)?;
    let preset = match &args.preset {
        Some(path) => load_preset(path).map_err(|e| Failure::bad_input(format!("{}: {e}", path.display())))?,
        None => Preset::default(),
    };
    let kind = match &args.instrument {
        Some(name) => name.parse::<InstrumentKind>().map_err(|e| Failure::bad_input(format!("--instrument: {e}")))?,
        None => preset.instrument.unwrap_or_default(),
    };

    let shown = args.song.display();
    let bytes = fs::read(&args.song).map_err(|e| Failure::bad_input(format!("{shown}: cannot read: {e}")))?;
    let options = ReadOptions { include_channel_10: args.include_channel_10 };
    let song =
        midi_file::read(&bytes, sample_rate_hz, options).map_err(|e| Failure::bad_input(format!("{shown}: {e}")))?;
    if same_file(&args.song, &args.out) {
        return Err(Failure::bad_input(format!("--out: {} is the song itself", args.out.display())));
    }
    let keys = kind.key_range();
    let playable: usize = keys.clone().map(|k| song.notes_per_key[usize::from(k)]).sum();
    let notes = song.note_count();
    if playable == 0 {
        return Err(Failure::bad_input(format!(
            "{shown}: none of its {} is on the {kind}'s keys (MIDI {}..={})",
            count(notes, "note"),
            keys.start(),
            keys.end()
        )));
    }

    let fs_hz = f64::from(sample_rate_hz);
    let total = song.last_sample() + (tail_s * fs_hz).round() as u64;
    if total.saturating_mul(8) > MAX_WAV_DATA_BYTES {
        return Err(Failure::bad_input(format!(
            "{shown}: {:.0} s at {sample_rate_hz} Hz would exceed the 4 GB a WAV file can hold",
            total as f64 / fs_hz
        )));
    }

    let settings =
        InstrumentSettings { kind, voicing: preset.voicing, sample_rate_hz: fs_hz, tuning: Default::default() };
    let instrument = Instrument::build(&settings).map_err(|e| match &args.preset {
        Some(path) => Failure::bad_input(format!("{}: voicing: {e}", path.display())),
        None => Failure::failed(format!("cannot build the {kind}: {e}")),
    })?;
    let (mut synth, _scope) = Synth::new(Box::new(instrument));
    synth.set_controls(preset.controls);

    if !args.quiet && playable < notes {
        eprintln!(
            "struck render: {} of {notes} are outside the {kind}'s keys (MIDI {}..={}) and stay silent",
            count(notes - playable, "note"),
            keys.start(),
            keys.end()
        );
    }

    let progress = (!args.quiet && io::stderr().is_terminal()).then(|| progress_bar(total));
    let started = Instant::now();
    let spec = hound::WavSpec {
        channels: 2,
        sample_rate: sample_rate_hz,
        bits_per_sample: 32,
        sample_format: hound::SampleFormat::Float,
    };
    let mut peak = 0.0f32;
    let mut non_finite: Option<u64> = None;
    // Ctrl-C (or SIGTERM) stops between blocks, so the partial file is removed.
    let _ = ctrlc::set_handler(|| INTERRUPTED.store(true, Ordering::Relaxed));
    let mut staged = Staged::default();
    let written = staged.write(&args.out, |w| {
        let mut wav = hound::WavWriter::new(w, spec).map_err(io::Error::other)?;
        let mut done = 0u64;
        render(&mut synth, &song.events, total, block_size, |left, right| {
            if INTERRUPTED.load(Ordering::Relaxed) {
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
            if let Some(bar) = &progress
                && (done % PROGRESS_EVERY < left.len() as u64 || done == total)
            {
                bar.set_position(done);
            }
            Ok(())
        })?;
        wav.finalize().map_err(io::Error::other)
    });
    if let Some(bar) = &progress {
        bar.finish_and_clear();
    }
    if INTERRUPTED.load(Ordering::Relaxed) {
        return Err(Failure { status: EXIT_INTERRUPTED, message: "interrupted; nothing was written".into() });
    }
    if let Some(sample) = non_finite {
        return Err(Failure::failed(format!(
            "the synth produced a non-finite sample at {:.3} s; nothing was written",
            sample as f64 / fs_hz
        )));
    }
    written?;
    staged.commit()?;

    if !args.quiet {
        let wall_s = started.elapsed().as_secs_f64();
        let audio_s = total as f64 / fs_hz;
        let peak_note = if peak > 0.0 {
            let db = 20.0 * f64::from(peak).log10();
            let over = if peak > 1.0 { " (above full scale: lower controls.output_gain in a preset)" } else { "" };
            format!("peak {db:+.1} dBFS{over}")
        } else {
            "silent".to_string()
        };
        println!(
            "{shown} -> {}: {kind}, {}, {audio_s:.2} s at {sample_rate_hz} Hz in {wall_s:.2} s \
             ({:.1}x real time), {peak_note}",
            args.out.display(),
            count(notes, "note"),
            audio_s / wall_s.max(1e-9)
        );
    }
    Ok(())
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
        Err(Failure::bad_input(format!("--sample-rate: must be a whole number of Hz from {lo} to {hi} (got {hz})")))
    }
}

fn check_tail(tail_s: f64) -> Result<f64, Failure> {
    if (0.0..=MAX_TAIL_S).contains(&tail_s) {
        Ok(tail_s)
    } else {
        Err(Failure::bad_input(format!("--tail-s: must be from 0 to {MAX_TAIL_S:.0} s (got {tail_s})")))
    }
}

fn check_block_size(n: i64) -> Result<usize, Failure> {
    match usize::try_from(n) {
        Ok(n) if (1..=MAX_BLOCK_SIZE).contains(&n) => Ok(n),
        _ => Err(Failure::bad_input(format!("--block-size: must be from 1 to {MAX_BLOCK_SIZE} samples (got {n})"))),
    }
}

/// Whether two paths name the same existing file.
fn same_file(a: &Path, b: &Path) -> bool {
    match (fs::canonicalize(a), fs::canonicalize(b)) {
        (Ok(a), Ok(b)) => a == b,
        _ => false,
    }
}

/// Read and check a preset; the error names the field and the reason.
pub fn load_preset(path: &Path) -> Result<Preset, String> {
    let text = fs::read_to_string(path).map_err(|e| format!("cannot read: {e}"))?;
    let value: Value = serde_json::from_str(&text).map_err(|e| format!("not valid JSON: {e}"))?;
    let Value::Object(top) = &value else {
        return Err("a preset must be a JSON object".to_string());
    };
    if let Some(instrument) = top.get("instrument") {
        serde_json::from_value::<Option<InstrumentKind>>(instrument.clone()).map_err(|e| format!("instrument: {e}"))?;
    }
    if let Some(voicing) = top.get("voicing") {
        check_section::<Voicing>("voicing", voicing, &serde_json::to_value(Voicing::default()).expect("serialises"))?;
    }
    if let Some(controls) = top.get("controls") {
        check_section::<Controls>(
            "controls",
            controls,
            &serde_json::to_value(Controls::default()).expect("serialises"),
        )?;
    }
    // Unknown top-level fields are named by serde here.
    let preset: Preset = serde_json::from_value(value).map_err(|e| e.to_string())?;
    check_preset(&preset)?;
    Ok(preset)
}

/// The engine's structs fill missing fields but accept unknown ones: a misspelt
/// field would silently do nothing, so each key is checked against the defaults'
/// keys, and each value on its own so that a wrong type names its field.
fn check_section<T: DeserializeOwned>(name: &str, section: &Value, defaults: &Value) -> Result<(), String> {
    let (Value::Object(fields), Value::Object(known)) = (section, defaults) else {
        return Err(format!("{name}: must be a JSON object"));
    };
    for (key, value) in fields {
        if !known.contains_key(key) {
            let expected: Vec<&str> = known.keys().map(String::as_str).collect();
            return Err(format!("{name}.{key}: unknown field (expected one of {})", expected.join(", ")));
        }
        let one = Value::Object(Map::from_iter([(key.clone(), value.clone())]));
        serde_json::from_value::<T>(one).map_err(|e| format!("{name}.{key}: {e}"))?;
    }
    Ok(())
}

fn check_preset(preset: &Preset) -> Result<(), String> {
    let v = &preset.voicing;
    for (field, value) in [
        ("hammer_mass", v.hammer_mass),
        ("hammer_stiffness", v.hammer_stiffness),
        ("hammer_exponent", v.hammer_exponent),
        ("strike_position", v.strike_position),
        ("damping", v.damping),
    ] {
        within(&format!("voicing.{field}"), value, 0.01, 100.0, "")?;
    }
    within("voicing.unison_detune", v.unison_detune, 0.0, 100.0, "")?;
    let c = &preset.controls;
    within("controls.touch_min", c.touch_min, 0.0, 1.0, "")?;
    within("controls.touch_max", c.touch_max, 0.0, 1.0, "")?;
    within("controls.touch_shape", c.touch_shape, 0.1, 10.0, "")?;
    within("controls.output_gain", c.output_gain, 0.0, 100.0, "")?;
    within("controls.bend_range_semitones", c.bend_range_semitones, 0.0, 48.0, " semitones")?;
    if !(1..=128).contains(&c.polyphony) {
        return Err(format!("controls.polyphony: must be from 1 to 128 keys (got {})", c.polyphony));
    }
    Ok(())
}

fn within(field: &str, value: f64, lo: f64, hi: f64, unit: &str) -> Result<(), String> {
    if (lo..=hi).contains(&value) {
        Ok(())
    } else {
        Err(format!("{field}: must be from {lo} to {hi}{unit} (got {value})"))
    }
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
            (1500, Event::NoteOff { key: 60 }),
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

    #[test]
    fn preset_fields_are_checked_by_name() {
        let dir = std::env::temp_dir().join(format!("struck-preset-{}", std::process::id()));
        fs::create_dir_all(&dir).unwrap();
        let check = |text: &str| {
            let path = dir.join("p.json");
            fs::write(&path, text).unwrap();
            load_preset(&path)
        };
        let good = check(r#"{"instrument": "santoor", "voicing": {"damping": 0.5}, "controls": {"polyphony": 8}}"#);
        let good = good.unwrap();
        assert_eq!(good.instrument, Some(InstrumentKind::Santoor));
        assert_eq!(good.voicing.damping, 0.5);
        assert_eq!(good.voicing.hammer_mass, 1.0);
        assert_eq!(good.controls.polyphony, 8);
        assert_eq!(check("{}").unwrap(), Preset::default());
        for (text, named) in [
            (r#"{"voicng": {}}"#, "voicng"),
            (r#"{"voicing": {"hammer_mas": 1}}"#, "voicing.hammer_mas"),
            (r#"{"controls": {"polyphony": "many"}}"#, "controls.polyphony"),
            (r#"{"controls": {"touch_max": 2}}"#, "controls.touch_max"),
            (r#"{"instrument": "organ"}"#, "instrument"),
            (r#"{"voicing": 3}"#, "voicing"),
            ("[1]", "object"),
            ("{", "JSON"),
        ] {
            let e = check(text).unwrap_err();
            assert!(e.contains(named), "{text}: {e}");
        }
        fs::remove_dir_all(&dir).unwrap();
    }
}
