//! The notes played by the sources compared with the recordings: Struck in
//! this process (the same synth `struck render` plays through), and the
//! yardsticks by their own programs: FluidSynth with the FluidR3_GM
//! SoundFont (Frank Wen), and Faust-STK's commuted piano (Romain Michon,
//! after Smith and Van Duyne) compiled once into a small offline renderer.
//!
//! Every note is played alone, held for the whole render, as the recordings
//! hold theirs; each render is returned as the mono sum of its channels.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use serde::Serialize;
use struck_engine::body::Output;
use struck_engine::preset::Preset;
use struck_engine::synth::{Event, Instrument, Synth, TimedEvent, midi_velocity};

use super::measure::mono_sum;
use super::nominal_hz;

/// Where FluidR3_GM is installed (Debian's fluid-soundfont-gm).
pub const FLUID_SOUNDFONT: &str = "/usr/share/sounds/sf2/FluidR3_GM.sf2";
/// Faust-STK's piano and its tables (Debian's faust-common).
pub const FAUST_STK_DIR: &str = "/usr/share/faust/examples/physicalModeling/faust-stk";

/// Who plays a note.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Source {
    /// The Salamander Grand Piano's recording (the reference).
    Recording,
    Struck,
    /// FluidSynth playing FluidR3_GM's grand.
    Fluid,
    /// Faust-STK's commuted piano.
    FaustStk,
}

impl Source {
    /// The compared sources, in the table's order.
    pub const COMPARED: [Source; 3] = [Source::Struck, Source::Fluid, Source::FaustStk];

    pub fn key(self) -> &'static str {
        match self {
            Source::Recording => "recording",
            Source::Struck => "struck",
            Source::Fluid => "fluid",
            Source::FaustStk => "faust_stk",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Source::Recording => "Yamaha C5",
            Source::Struck => "Struck",
            Source::Fluid => "FluidR3",
            Source::FaustStk => "Faust-STK",
        }
    }
}

/// Render `key` at `velocity` (1-127) on Struck as `preset` sets it (the
/// default preset is the piano), heard through `output`, held for `seconds`:
/// the mono sum.
pub fn render_struck(
    preset: &Preset,
    key: u8,
    velocity: u8,
    seconds: f64,
    output: Output,
    fs: f64,
) -> Result<Vec<f64>, String> {
    let mut controls = preset.controls;
    controls.output = output;
    let settings = preset.settings(fs);
    let instrument = Instrument::build(&settings).map_err(|e| format!("cannot build the instrument: {e}"))?;
    let (mut synth, _scope) = Synth::new(Box::new(instrument));
    synth.set_controls(controls);
    let total = (seconds * fs).round() as usize;
    let block = 512;
    let (mut left, mut right) = (vec![0.0f32; block], vec![0.0f32; block]);
    let mut out = Vec::with_capacity(total);
    let mut start = 0;
    while start < total {
        let len = block.min(total - start);
        let events = if start == 0 {
            vec![TimedEvent::new(0, Event::NoteOn { key, velocity: midi_velocity(velocity) })]
        } else {
            Vec::new()
        };
        synth.process(&events, &mut left[..len], &mut right[..len]);
        out.extend(left[..len].iter().zip(&right[..len]).map(|(&l, &r)| f64::from(l) + f64::from(r)));
        start += len;
    }
    if out.iter().any(|x| !x.is_finite()) {
        return Err("the piano produced a non-finite sample".into());
    }
    Ok(out)
}

/// A standard MIDI file (format 0, 480 ticks a quarter at 120 bpm) playing
/// `key` at `velocity` from time 0 on General MIDI `program` (as MIDI sends
/// it, 0-127: 0 the acoustic grand), released after `seconds`.
pub fn one_note_midi(program: u8, key: u8, velocity: u8, seconds: f64) -> Vec<u8> {
    // 960 ticks a second.
    let release = (seconds * 960.0).round().clamp(0.0, f64::from(0x0fff_ffff)) as u32;
    let mut track = Vec::new();
    track.extend([0x00, 0xff, 0x51, 0x03, 0x07, 0xa1, 0x20]); // tempo 500000 us a quarter
    track.extend([0x00, 0xc0, program & 0x7f]);
    track.extend([0x00, 0x90, key & 0x7f, velocity.clamp(1, 127)]);
    track.extend(variable_length(release));
    track.extend([0x80, key & 0x7f, 0x40]);
    track.extend([0x00, 0xff, 0x2f, 0x00]);
    let mut file = Vec::new();
    file.extend(b"MThd");
    file.extend(6u32.to_be_bytes());
    file.extend([0, 0, 0, 1, 0x01, 0xe0]);
    file.extend(b"MTrk");
    file.extend((track.len() as u32).to_be_bytes());
    file.extend(track);
    file
}

/// A MIDI variable-length quantity.
fn variable_length(mut value: u32) -> Vec<u8> {
    let mut bytes = vec![(value & 0x7f) as u8];
    value >>= 7;
    while value > 0 {
        bytes.push(((value & 0x7f) as u8) | 0x80);
        value >>= 7;
    }
    bytes.reverse();
    bytes
}

/// Whether FluidSynth and the SoundFont are installed.
pub fn fluid_available() -> Result<(), String> {
    if !Path::new(FLUID_SOUNDFONT).is_file() {
        return Err(format!("no {FLUID_SOUNDFONT} (Debian's fluid-soundfont-gm)"));
    }
    match Command::new("fluidsynth").arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status() {
        Ok(s) if s.success() => Ok(()),
        _ => Err("no fluidsynth (Debian's fluidsynth)".into()),
    }
}

/// Render `key` at `velocity` with FluidSynth and FluidR3_GM's General MIDI
/// `program` (0: its grand; reverb and chorus off, so that the decays are the
/// SoundFont's), held for `seconds`.
pub fn render_fluid(program: u8, key: u8, velocity: u8, seconds: f64, fs: f64) -> Result<Vec<f64>, String> {
    let dir = tempfile::tempdir().map_err(|e| format!("cannot make a scratch folder: {e}"))?;
    let midi = dir.path().join("note.mid");
    let wav = dir.path().join("note.wav");
    fs::write(&midi, one_note_midi(program, key, velocity, seconds))
        .map_err(|e| format!("cannot write a MIDI file: {e}"))?;
    let output = Command::new("fluidsynth")
        .args(["-n", "-i", "-q", "-R", "0", "-C", "0", "-g", "1.0", "-T", "wav", "-O", "float", "-r"])
        .arg(format!("{fs}"))
        .arg("-F")
        .arg(&wav)
        .arg(FLUID_SOUNDFONT)
        .arg(&midi)
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run fluidsynth: {e}"))?;
    if !output.status.success() {
        return Err(format!("fluidsynth failed: {}", String::from_utf8_lossy(&output.stderr).trim()));
    }
    let mut samples = read_wav(&wav)?;
    samples.resize((seconds * fs).round() as usize, 0.0);
    Ok(samples)
}

/// The mono sum of a WAV's channels.
fn read_wav(path: &Path) -> Result<Vec<f64>, String> {
    let mut reader = hound::WavReader::open(path).map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    let spec = reader.spec();
    let channels = usize::from(spec.channels);
    let interleaved: Vec<f32> = match spec.sample_format {
        hound::SampleFormat::Float => reader.samples::<f32>().collect::<Result<_, _>>(),
        hound::SampleFormat::Int => {
            let scale = 2f32.powi(i32::from(spec.bits_per_sample) - 1);
            reader.samples::<i32>().map(|s| s.map(|s| s as f32 / scale)).collect::<Result<_, _>>()
        }
    }
    .map_err(|e| format!("cannot read {}: {e}", path.display()))?;
    Ok(mono_sum(&interleaved, channels))
}

/// The architecture file the STK piano is compiled with: a main that holds
/// one note (freq, gain, gate) and writes interleaved 32-bit floats.
const FAUST_ARCHITECTURE: &str = r#"// struck compare: one note of a Faust instrument, offline.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>
#include "faust/dsp/dsp.h"
#include "faust/gui/MapUI.h"
#include "faust/gui/meta.h"

<<includeIntrinsic>>
<<includeclass>>

static bool ends_with(const std::string& s, const char* tail) {
    std::string t(tail);
    return s.size() >= t.size() && s.compare(s.size() - t.size(), t.size(), t) == 0;
}

int main(int argc, char** argv) {
    if (argc != 6) { fprintf(stderr, "usage: RATE FREQ GAIN SECONDS OUT.f32\n"); return 2; }
    int rate = atoi(argv[1]);
    double freq = atof(argv[2]), gain = atof(argv[3]), seconds = atof(argv[4]);
    mydsp d;
    d.init(rate);
    MapUI ui;
    d.buildUserInterface(&ui);
    std::string f, g, t;
    for (int i = 0; i < ui.getParamsCount(); i++) {
        std::string p = ui.getParamAddress(i);
        if (ends_with(p, "/freq")) f = p;
        if (ends_with(p, "/gain")) g = p;
        if (ends_with(p, "/gate")) t = p;
    }
    if (f.empty() || g.empty() || t.empty()) { fprintf(stderr, "no freq, gain or gate\n"); return 1; }
    ui.setParamValue(f, freq);
    ui.setParamValue(g, gain);
    int nin = d.getNumInputs(), nout = d.getNumOutputs();
    const int B = 64;
    std::vector<std::vector<FAUSTFLOAT>> ins(nin > 0 ? nin : 1, std::vector<FAUSTFLOAT>(B, 0));
    std::vector<std::vector<FAUSTFLOAT>> outs(nout > 0 ? nout : 1, std::vector<FAUSTFLOAT>(B, 0));
    std::vector<FAUSTFLOAT*> ip, op;
    for (auto& v : ins) ip.push_back(v.data());
    for (auto& v : outs) op.push_back(v.data());
    FILE* o = fopen(argv[5], "wb");
    if (!o) { perror(argv[5]); return 1; }
    long n = (long)llround(seconds * rate);
    // One block with the gate closed, then the note: the gate's rise strikes.
    ui.setParamValue(t, 0.0);
    d.compute(B, ip.data(), op.data());
    ui.setParamValue(t, 1.0);
    for (long s = 0; s < n; s += B) {
        int len = (int)((n - s) < B ? (n - s) : B);
        d.compute(len, ip.data(), op.data());
        for (int i = 0; i < len; i++) {
            float frame[2] = {(float)op[0][i], (float)op[nout > 1 ? 1 : 0][i]};
            fwrite(frame, sizeof(float), 2, o);
        }
    }
    return fclose(o) == 0 ? 0 : 1;
}
"#;

/// Faust-STK's piano compiled into a renderer.
pub struct FaustRenderer {
    program: PathBuf,
}

impl FaustRenderer {
    /// The renderer in `cache` (faust-stk-piano/), compiled if it is not
    /// there yet (faust to C++, then the C++ compiler: a few seconds).
    pub fn build(cache: &Path) -> Result<Self, String> {
        let dsp = Path::new(FAUST_STK_DIR).join("piano.dsp");
        if !dsp.is_file() {
            return Err(format!("no {} (Debian's faust-common)", dsp.display()));
        }
        let version = Command::new("faust")
            .arg("--version")
            .stdin(Stdio::null())
            .output()
            .ok()
            .filter(|o| o.status.success())
            .ok_or("no faust compiler (Debian's faust)")?;
        let version = String::from_utf8_lossy(&version.stdout);
        let version = version.lines().next().unwrap_or("").trim().to_string();
        // A renderer is rebuilt when the compiler or the architecture changes.
        let stamp = format!("{version}\n{:016x}\n", fnv1a(FAUST_ARCHITECTURE.as_bytes()));
        let dir = cache.join("faust-stk-piano");
        let program = dir.join("piano-render");
        if program.is_file() && fs::read_to_string(dir.join("stamp")).is_ok_and(|s| s == stamp) {
            return Ok(Self { program });
        }
        fs::create_dir_all(&dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        let work = tempfile::Builder::new()
            .prefix(".build-")
            .tempdir_in(&dir)
            .map_err(|e| format!("cannot write into {}: {e}", dir.display()))?;
        let arch = work.path().join("arch.cpp");
        let cpp = work.path().join("piano.cpp");
        let built = work.path().join("piano-render");
        fs::write(&arch, FAUST_ARCHITECTURE).map_err(|e| format!("cannot write {}: {e}", arch.display()))?;
        run(Command::new("faust").arg("-I").arg(FAUST_STK_DIR).arg("-a").arg(&arch).arg(&dsp).arg("-o").arg(&cpp))?;
        run(Command::new("c++").args(["-O2", "-w", "-I"]).arg(FAUST_STK_DIR).arg(&cpp).arg("-o").arg(&built))?;
        fs::rename(&built, &program).map_err(|e| format!("cannot write {}: {e}", program.display()))?;
        fs::write(dir.join("stamp"), stamp).map_err(|e| format!("cannot write into {}: {e}", dir.display()))?;
        Ok(Self { program })
    }

    /// Render `key` at `velocity` (gain = velocity / 127), held for `seconds`.
    pub fn render(&self, key: u8, velocity: u8, seconds: f64, fs: f64) -> Result<Vec<f64>, String> {
        let dir = tempfile::tempdir().map_err(|e| format!("cannot make a scratch folder: {e}"))?;
        let raw = dir.path().join("note.f32");
        run(Command::new(&self.program)
            .arg(format!("{}", fs.round() as u32))
            .arg(format!("{:.6}", nominal_hz(key)))
            .arg(format!("{:.6}", f64::from(velocity) / 127.0))
            .arg(format!("{seconds}"))
            .arg(&raw))?;
        let bytes = fs::read(&raw).map_err(|e| format!("cannot read {}: {e}", raw.display()))?;
        let interleaved: Vec<f32> =
            bytes.chunks_exact(4).map(|b| f32::from_le_bytes([b[0], b[1], b[2], b[3]])).collect();
        Ok(mono_sum(&interleaved, 2))
    }
}

/// Run a command, its error output the message when it fails.
fn run(command: &mut Command) -> Result<(), String> {
    let name = command.get_program().to_string_lossy().into_owned();
    let output = command.stdin(Stdio::null()).output().map_err(|e| format!("cannot run {name}: {e}"))?;
    if output.status.success() {
        Ok(())
    } else {
        let text = String::from_utf8_lossy(&output.stderr);
        let line = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("no message").trim().to_string();
        Err(format!("{name} failed: {line}"))
    }
}

/// FNV-1a, 64 bits (a stamp, not a checksum against tampering).
fn fnv1a(bytes: &[u8]) -> u64 {
    bytes.iter().fold(0xcbf2_9ce4_8422_2325u64, |h, &b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_one_note_file_is_a_midi_file_the_lab_reads() {
        let bytes = one_note_midi(15, 60, 92, 6.0);
        assert!(bytes.windows(3).any(|w| w == [0x00, 0xc0, 15]), "program change");
        let song = crate::midi_file::read(&bytes, 48_000, crate::midi_file::ReadOptions::default()).unwrap();
        let notes: Vec<(u64, Event)> = song
            .events
            .iter()
            .copied()
            .filter(|(_, e)| matches!(e, Event::NoteOn { .. } | Event::NoteOff { .. }))
            .collect();
        assert_eq!(notes.len(), 2, "{notes:?}");
        assert!(matches!(notes[0], (0, Event::NoteOn { key: 60, velocity }) if (velocity - 92.0 / 127.0).abs() < 1e-6));
        assert!(matches!(notes[1], (288_000, Event::NoteOff { key: 60, .. })));
        assert_eq!(variable_length(0x0fff_ffff), [0xff, 0xff, 0xff, 0x7f]);
        assert_eq!(variable_length(0x80), [0x81, 0x00]);
    }

    #[test]
    fn struck_plays_the_note_it_is_given() {
        let fs = 48_000.0;
        let out = render_struck(&Preset::default(), 69, 92, 0.5, Output::BridgeForce, fs).unwrap();
        assert_eq!(out.len(), 24_000);
        assert!(out.iter().any(|&x| x != 0.0));
        let f = super::super::measure::Analyzer::new().measure(
            &out,
            fs,
            &super::super::measure::Context { nominal_hz: 440.0, band_hz: 20_000.0, usable_end_s: 0.5 },
        );
        let f0 = f.f0_hz.unwrap();
        assert!((1200.0 * (f0 / 440.0).log2()).abs() < 15.0, "{f0}");
    }
}
