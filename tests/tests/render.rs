//! `struck render`: MIDI files played through the real-time synth into WAVs, checked
//! by what can be heard (length, silence, pitch, pedals, bends, tempo) rather than
//! by exact loudness or timbre, and its refusals (exit status 2, one line naming
//! the problem, no WAV written and an existing one kept).
//!
//! The MIDI files are in `tests/data/midi/`, written by `struck_tests::midi_gen`;
//! the demo songs in `demo-songs/` by `struck_tests::demo_songs`.

use std::path::{Path, PathBuf};
use std::process::Output;

use struck_tests::{demo_songs, midi_gen, stderr, stdout, struck};

/// A test MIDI file.
fn midi(name: &str) -> PathBuf {
    midi_gen::test_dir().join(name)
}

fn path_str(path: &Path) -> &str {
    path.to_str().expect("a UTF-8 path")
}

/// A render: its samples and format.
struct Wav {
    left: Vec<f32>,
    right: Vec<f32>,
    sample_rate_hz: u32,
}

impl Wav {
    fn read(path: &Path) -> Self {
        let mut reader = hound::WavReader::open(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let spec = reader.spec();
        assert_eq!(spec.channels, 2, "stereo");
        assert_eq!(spec.bits_per_sample, 32);
        assert_eq!(spec.sample_format, hound::SampleFormat::Float);
        let samples: Vec<f32> = reader.samples::<f32>().map(Result::unwrap).collect();
        let left = samples.iter().step_by(2).copied().collect();
        let right = samples.iter().skip(1).step_by(2).copied().collect();
        Self { left, right, sample_rate_hz: spec.sample_rate }
    }

    fn len(&self) -> usize {
        self.left.len()
    }

    fn mono(&self) -> Vec<f64> {
        self.left.iter().zip(&self.right).map(|(&l, &r)| 0.5 * (f64::from(l) + f64::from(r))).collect()
    }

    fn index(&self, seconds: f64) -> usize {
        ((seconds * f64::from(self.sample_rate_hz)).round() as usize).min(self.len())
    }

    /// Mean square of both channels from `from_s` to `to_s`.
    fn energy(&self, from_s: f64, to_s: f64) -> f64 {
        let (a, b) = (self.index(from_s), self.index(to_s));
        let sum: f64 = (a..b).map(|i| f64::from(self.left[i]).powi(2) + f64::from(self.right[i]).powi(2)).sum();
        sum / (2 * (b - a).max(1)) as f64
    }

    fn first_sound(&self) -> Option<usize> {
        self.left.iter().zip(&self.right).position(|(&l, &r)| l != 0.0 || r != 0.0)
    }

    /// The strongest frequency within a semitone of `near_hz` between `from_s` and `to_s`.
    fn pitch_hz(&self, from_s: f64, to_s: f64, near_hz: f64) -> f64 {
        let mono = self.mono();
        let x = &mono[self.index(from_s)..self.index(to_s)];
        let n = x.len() as f64;
        let hann = |i: usize| 0.5 - 0.5 * (std::f64::consts::TAU * i as f64 / n).cos();
        let windowed: Vec<f64> = x.iter().enumerate().map(|(i, &v)| hann(i) * v).collect();
        let fs = f64::from(self.sample_rate_hz);
        let power = |f_hz: f64| dft_power(&windowed, f_hz / fs);
        let scan = |lo: f64, hi: f64, step: f64| {
            let steps = ((hi - lo) / step).ceil() as usize;
            (0..=steps)
                .map(|i| lo + i as f64 * step)
                .map(|f| (f, power(f)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
                .unwrap()
                .0
        };
        let semitone = 2f64.powf(1.0 / 12.0);
        let coarse = scan(near_hz / semitone, near_hz * semitone, 0.25);
        scan(coarse - 0.5, coarse + 0.5, 0.01)
    }
}

/// Power of `x` at `f` cycles per sample.
fn dft_power(x: &[f64], f: f64) -> f64 {
    let (mut re, mut im) = (0.0, 0.0);
    let step = (std::f64::consts::TAU * f).sin_cos();
    let (mut s, mut c) = (0.0f64, 1.0f64);
    for &v in x {
        re += v * c;
        im -= v * s;
        (s, c) = (s * step.1 + c * step.0, c * step.1 - s * step.0);
    }
    re * re + im * im
}

fn cents(f_hz: f64, reference_hz: f64) -> f64 {
    1200.0 * (f_hz / reference_hz).log2()
}

/// A scratch directory with the output path inside it.
struct Scratch {
    dir: tempfile::TempDir,
}

impl Scratch {
    fn new() -> Self {
        Self { dir: tempfile::tempdir().unwrap() }
    }

    fn path(&self, name: &str) -> PathBuf {
        self.dir.path().join(name)
    }

    fn out(&self) -> PathBuf {
        self.path("out.wav")
    }

    /// Render `song` to out.wav with `extra` arguments.
    fn render(&self, song: &Path, extra: &[&str]) -> Output {
        let out = self.out();
        let mut args = vec!["render", path_str(song), "--out", path_str(&out)];
        args.extend_from_slice(extra);
        struck(&args)
    }

    /// Render and read the WAV; the run must succeed.
    fn wav(&self, song: &Path, extra: &[&str]) -> Wav {
        let out = self.render(song, extra);
        assert!(out.status.success(), "struck render failed: {}", stderr(&out));
        Wav::read(&self.out())
    }

    /// Files in the directory other than `keep`.
    fn others(&self, keep: &[&str]) -> Vec<String> {
        std::fs::read_dir(self.dir.path())
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .filter(|n| !keep.contains(&n.as_str()))
            .collect()
    }
}

#[test]
fn midi_files_are_what_their_generator_writes() {
    let regenerate = std::env::var_os("STRUCK_REGENERATE_MIDI").is_some();
    let sets = [(midi_gen::test_dir(), midi_gen::test_files()), (demo_songs::demo_dir(), demo_songs::all())];
    for (dir, files) in sets {
        for (name, bytes) in files {
            let path = dir.join(name);
            if regenerate {
                std::fs::create_dir_all(&dir).unwrap();
                std::fs::write(&path, &bytes).unwrap();
            } else {
                let on_disk = std::fs::read(&path).unwrap_or_default();
                assert!(
                    on_disk == bytes,
                    "{} differs from its generator; regenerate with \
                     STRUCK_REGENERATE_MIDI=1 cargo test -p struck-tests --test render",
                    path.display()
                );
            }
        }
    }
}

#[test]
fn help_describes_render() {
    let help = stdout(&struck(&["render", "--help"]));
    for expected in [
        "--out",
        "--instrument",
        "--preset",
        "--sample-rate",
        "--tail-s",
        "--block-size",
        "-q",
        "exit status 2",
        "--a4",
        "--temperament",
        "--stretch",
        "--scl",
        "--kbm",
        "piano|fortepiano|santoor|dulcimer|cimbalom|clavichord|harpsichord",
        "equal|meantone|werckmeister3|vallotti",
    ] {
        assert!(help.contains(expected), "render --help lacks {expected}: {help}");
    }
    assert!(stdout(&struck(&["--help"])).contains("render"));
}

/// A4 from 0.5 s to 1.5 s, rendered with a 1 s tail: exactly 2.5 s, nothing before
/// the strike, sound after it, and a one-line summary.
#[test]
fn renders_a_note_at_its_time_for_the_tail_asked() {
    let scratch = Scratch::new();
    let out = scratch.render(&midi("a4.mid"), &["--tail-s", "1"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let summary = stdout(&out);
    assert_eq!(summary.lines().count(), 1, "{summary}");
    assert!(summary.contains("a4.mid") && summary.contains("piano") && summary.contains("real time"), "{summary}");
    let wav = Wav::read(&scratch.out());
    assert_eq!(wav.sample_rate_hz, 48_000);
    assert_eq!(wav.len(), 120_000, "1.5 s to the last event + 1 s");
    let first = wav.first_sound().expect("some sound");
    assert!((24_000..24_000 + 48).contains(&first), "the strike at 0.5 s sounds from sample {first}");
    let peak = wav.left.iter().chain(&wav.right).fold(0.0f32, |m, v| m.max(v.abs()));
    assert!(peak > 1e-3 && peak < 4.0, "peak {peak}");
    assert!(wav.energy(0.6, 1.4) > 1e-8, "the note sounds while held");
    assert!(scratch.others(&["out.wav"]).is_empty(), "{:?}", scratch.others(&["out.wav"]));
    assert!(wav.left != wav.right, "stereo, not mono twice");
}

#[test]
fn quiet_prints_nothing() {
    let scratch = Scratch::new();
    let out = scratch.render(&midi("a4.mid"), &["--tail-s", "0", "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).is_empty() && stderr(&out).is_empty());
    assert_eq!(Wav::read(&scratch.out()).len(), 72_000);
}

/// Every instrument is accepted by name, and its A4 sounds at 440 Hz (each string
/// is tuned by its first partial, so the stretch of the higher partials does not move it).
#[test]
fn a4_sounds_at_440_hz() {
    let scratch = Scratch::new();
    for instrument in ["piano", "fortepiano", "santoor", "dulcimer", "cimbalom", "clavichord", "harpsichord"] {
        let out = scratch.render(&midi("a4.mid"), &["--tail-s", "0", "--instrument", instrument]);
        assert!(out.status.success(), "{instrument}: {}", stderr(&out));
        assert!(stdout(&out).contains(instrument), "{}", stdout(&out));
        let wav = Wav::read(&scratch.out());
        let f = wav.pitch_hz(0.6, 1.45, 440.0);
        assert!(cents(f, 440.0).abs() < 5.0, "{instrument}: A4 at {f:.3} Hz ({:+.2} cents)", cents(f, 440.0));
    }
}

/// With the wheel fully up and the default bend range of 2 semitones, A4 sounds as B4;
/// a preset's range of 1 semitone gives A#4.
#[test]
fn pitch_bend_shifts_the_pitch() {
    let scratch = Scratch::new();
    let b4 = 440.0 * 2f64.powf(2.0 / 12.0);
    let wav = scratch.wav(&midi("a4-bend-up.mid"), &["--tail-s", "0"]);
    let f = wav.pitch_hz(0.6, 1.45, b4);
    assert!(cents(f, b4).abs() < 5.0, "bent A4 at {f:.3} Hz, B4 is {b4:.3} Hz");

    let preset = scratch.path("bend.json");
    std::fs::write(&preset, r#"{"controls": {"bend_range_semitones": 1}}"#).unwrap();
    let a_sharp = 440.0 * 2f64.powf(1.0 / 12.0);
    let wav = scratch.wav(&midi("a4-bend-up.mid"), &["--tail-s", "0", "--preset", path_str(&preset)]);
    let f = wav.pitch_hz(0.6, 1.45, a_sharp);
    assert!(cents(f, a_sharp).abs() < 5.0, "bent A4 at {f:.3} Hz, A#4 is {a_sharp:.3} Hz");
}

/// An MPE song: A3 on channel 2 and E4 on channel 3, channel 2 bent up
/// 2 semitones of MPE's 48 before its note. With `--mpe` A3 alone moves 200
/// cents; without, the bend is the wheel (2 semitones of range): both move
/// 2/48 of 200 cents.
#[test]
fn an_mpe_song_bends_its_notes_one_by_one() {
    let scratch = Scratch::new();
    let mut track = midi_gen::TrackBuilder::new();
    let raw = (8192.0 + 8191.0 * 2.0 / 48.0_f64).round() as u16;
    track
        .tempo(0, 120.0)
        .channel_bend(0, 1, raw)
        .note_on(midi_gen::at_120(0.1), 1, midi_gen::key("A3"), 90)
        .note_on(midi_gen::at_120(0.1), 2, midi_gen::key("E4"), 90)
        .note_off(midi_gen::at_120(1.6), 1, midi_gen::key("A3"))
        .note_off(midi_gen::at_120(1.6), 2, midi_gen::key("E4"));
    let song = scratch.path("mpe.mid");
    std::fs::write(&song, midi_gen::smf_bytes(midly::Format::SingleTrack, midi_gen::metrical(), &[track])).unwrap();
    let (a3, e4) = (220.0, 329.627_557);
    let mpe = scratch.wav(&song, &["--tail-s", "0", "--mpe"]);
    let (bent, straight) = (mpe.pitch_hz(0.6, 1.5, a3 * 2f64.powf(2.0 / 12.0)), mpe.pitch_hz(0.6, 1.5, e4));
    let plain = scratch.wav(&song, &["--tail-s", "0"]);
    let (a, e) = (plain.pitch_hz(0.6, 1.5, a3), plain.pitch_hz(0.6, 1.5, e4));
    eprintln!(
        "--mpe: A3 {:+.1} cents, E4 {:+.1}; without: A3 {:+.1}, E4 {:+.1}",
        cents(bent, a3),
        cents(straight, e4),
        cents(a, a3),
        cents(e, e4)
    );
    assert!((cents(bent, a3) - 200.0).abs() < 5.0 && cents(straight, e4).abs() < 5.0);
    assert!((cents(a, a3) - 8.3).abs() < 3.0 && (cents(e, e4) - 8.3).abs() < 3.0);
}

/// --a4 415 moves A4 down to 415 Hz (a semitone, near enough: 100.7 cents).
#[test]
fn a4_reference_moves_the_pitch() {
    let scratch = Scratch::new();
    let wav = scratch.wav(&midi("a4.mid"), &["--tail-s", "0", "--a4", "415"]);
    let f = wav.pitch_hz(0.6, 1.45, 415.0);
    assert!(cents(f, 415.0).abs() < 5.0, "A4 at {f:.3} Hz with --a4 415");
}

/// C4 held from 0.5 s to 1.5 s (written into the scratch directory).
fn c4_song(scratch: &Scratch) -> PathBuf {
    let mut track = midi_gen::TrackBuilder::new();
    track.tempo(0, 120.0).note(midi_gen::at_120(0.5), midi_gen::at_120(1.0), midi_gen::key("C4"), 100);
    let path = scratch.path("c4.mid");
    std::fs::write(&path, midi_gen::smf_bytes(midly::Format::SingleTrack, midi_gen::metrical(), &[track])).unwrap();
    path
}

const C4_EQUAL_HZ: f64 = 261.625_565;

/// The peak of a WAV's samples, dBFS.
fn peak_dbfs(wav: &Wav) -> f64 {
    20.0 * wav.left.iter().chain(&wav.right).fold(0.0f64, |m, v| m.max(f64::from(v.abs()))).log10()
}

/// A staccato C4 at velocity 100 in a Bohlen-Pierce scale (13 steps to the
/// twelfth) peaked at +263.5 dBFS, and the keyboard swept in it or in 5 equal
/// steps to the octave went non-finite: each now renders finite, exit 0,
/// within a few dB of its equal-tempered render.
#[test]
fn a_scale_with_steps_wider_than_a_semitone_renders_at_the_keyboards_level() {
    let scratch = Scratch::new();
    let bp = scratch.path("bp.scl");
    let mut text = String::from("! bp.scl\nBohlen-Pierce\n13\n!\n");
    for i in 1..13 {
        text += &format!("{:.4}\n", 1901.955 * i as f64 / 13.0);
    }
    std::fs::write(&bp, text + "3/1\n").unwrap();
    let five = scratch.path("five.scl");
    std::fs::write(&five, "! five.scl\n5 equal\n5\n!\n240.\n480.\n720.\n960.\n2/1\n").unwrap();
    let c4 = c4_song(&scratch);
    let mut sweep = midi_gen::TrackBuilder::new();
    sweep.tempo(0, 120.0);
    for (i, key) in (21..=108u8).enumerate() {
        sweep.note(midi_gen::at_120(0.1 * i as f64), midi_gen::at_120(0.08), key, 100);
    }
    let swept = scratch.path("sweep.mid");
    std::fs::write(&swept, midi_gen::smf_bytes(midly::Format::SingleTrack, midi_gen::metrical(), &[sweep])).unwrap();
    for song in [&c4, &swept] {
        let equal = peak_dbfs(&scratch.wav(song, &["--tail-s", "2"]));
        for scale in [&bp, &five] {
            let out = scratch.render(song, &["--tail-s", "2", "--scl", path_str(scale)]);
            assert!(out.status.success(), "{}", stderr(&out));
            assert!(!stderr(&out).contains("guard"), "{}", stderr(&out));
            let wav = Wav::read(&scratch.out());
            assert!(wav.left.iter().chain(&wav.right).all(|v| v.is_finite()));
            let peak = peak_dbfs(&wav);
            assert!(
                (peak - equal).abs() < 6.0,
                "{}: peak {peak:.1} dBFS, {equal:.1} in equal temperament",
                path_str(scale)
            );
        }
    }
}

/// A hundred thousand notes in a second (a MIDI feedback loop) rendered at
/// +30.3 dBFS, and C4 struck a thousand times at +14.5: the output's guard
/// holds them at +6 dBFS and the render says so on stderr, exit 0.
#[test]
fn a_flood_of_notes_is_held_at_the_ceiling_and_said() {
    let scratch = Scratch::new();
    let mut flood = midi_gen::TrackBuilder::new();
    flood.tempo(0, 120.0);
    for i in 0..20_000u64 {
        flood.note_on(i * midi_gen::at_120(1.0) / 20_000, 0, 21 + (i % 88) as u8, 1 + (i % 127) as u8);
    }
    let mut same = midi_gen::TrackBuilder::new();
    same.tempo(0, 120.0);
    for i in 0..1000u64 {
        same.note_on(i * midi_gen::at_120(1.0) / 1000, 0, 60, 127);
    }
    for (name, track) in [("flood.mid", flood), ("same.mid", same)] {
        let song = scratch.path(name);
        std::fs::write(&song, midi_gen::smf_bytes(midly::Format::SingleTrack, midi_gen::metrical(), &[track])).unwrap();
        let out = scratch.render(&song, &["--tail-s", "1"]);
        assert!(out.status.success(), "{}", stderr(&out));
        let said = stderr(&out);
        assert!(said.contains("the output guard held the output under +6 dBFS"), "{name}: {said}");
        assert_eq!(said.lines().count(), 1, "{said}");
        let wav = Wav::read(&scratch.out());
        assert!(peak_dbfs(&wav) <= 6.0 + 1e-4, "{name}: peak {:.2} dBFS", peak_dbfs(&wav));
    }
}

/// A harpsichord preset in quarter-comma meantone from C (A4 at 440 Hz): C4 sits
/// 10.26 cents above its equal-tempered pitch, and the summary says so. The flags
/// override the preset's tuning: --temperament equal puts C4 back.
#[test]
fn a_preset_with_a_tuning_renders_in_it() {
    let scratch = Scratch::new();
    let song = c4_song(&scratch);
    let preset = scratch.path("meantone.json");
    std::fs::write(
        &preset,
        r#"{"name": "Meantone harpsichord", "instrument": "harpsichord", "tuning": {"temperament": "meantone"}}"#,
    )
    .unwrap();
    let out = scratch.render(&song, &["--tail-s", "0", "--preset", path_str(&preset)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).contains("harpsichord (quarter-comma meantone, A4 = 440 Hz)"), "{}", stdout(&out));
    let f = Wav::read(&scratch.out()).pitch_hz(0.6, 1.45, C4_EQUAL_HZ);
    assert!((cents(f, C4_EQUAL_HZ) - 10.26).abs() < 2.0, "C4 at {f:.3} Hz ({:+.2} c)", cents(f, C4_EQUAL_HZ));

    let wav = scratch.wav(&song, &["--tail-s", "0", "--preset", path_str(&preset), "--temperament", "equal"]);
    let f = wav.pitch_hz(0.6, 1.45, C4_EQUAL_HZ);
    assert!(cents(f, C4_EQUAL_HZ).abs() < 2.0, "C4 at {f:.3} Hz ({:+.2} c)", cents(f, C4_EQUAL_HZ));
}

/// A just major scale on the white keys (--scl with --kbm, A4 = 440 Hz the
/// reference): C4 is 3/5 of A4, 264 Hz, 15.6 cents above equal temperament.
#[test]
fn a_scala_scale_and_mapping_tune_the_keys() {
    let scratch = Scratch::new();
    let song = c4_song(&scratch);
    let scl = scratch.path("just.scl");
    std::fs::write(&scl, "! just.scl\nJust major\n 7\n9/8\n5/4\n4/3\n3/2\n5/3\n15/8\n2/1\n").unwrap();
    let kbm = scratch.path("white.kbm");
    std::fs::write(&kbm, "! white.kbm\n12\n0\n127\n60\n69\n440.0\n7\n0\nx\n1\nx\n2\n3\nx\n4\nx\n5\nx\n6\n").unwrap();
    let out = scratch.render(&song, &["--tail-s", "0", "--scl", path_str(&scl), "--kbm", path_str(&kbm)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).contains("scale \"Just major\""), "{}", stdout(&out));
    let f = Wav::read(&scratch.out()).pitch_hz(0.6, 1.45, 264.0);
    assert!(cents(f, 264.0).abs() < 2.0, "C4 at {f:.3} Hz, just C4 is 264 Hz");
}

/// C4 released at 0.5 s: with the sustain pedal down it rings on; without, the
/// damper stops it.
/// Aftertouch in the file presses the clavichord's tangent deeper (Bebung):
/// full pressure raises D2 by the Bebung's range, 20 cents as built, or a
/// preset's own.
#[test]
fn aftertouch_in_the_file_bends_a_clavichord_note() {
    let scratch = Scratch::new();
    for (controls, expected) in [("{}", 20.0), (r#"{"bebung_cents": 35}"#, 35.0)] {
        let preset = scratch.path("clear.json");
        // One string's pitch: no unison spread.
        let text =
            format!(r#"{{"instrument": "clavichord", "voicing": {{"unison_detune": 0}}, "controls": {controls}}}"#);
        std::fs::write(&preset, text).unwrap();
        for song in ["d2-channel-pressure.mid", "d2-poly-pressure.mid"] {
            let wav = scratch.wav(&midi(song), &["--tail-s", "0", "--preset", path_str(&preset)]);
            // The third partial, where 0.01 Hz is 0.08 cent.
            let third = 3.0 * 73.416;
            let (before, after) = (wav.pitch_hz(0.4, 1.45, third), wav.pitch_hz(1.7, 3.0, third));
            let bent = cents(after, before);
            eprintln!("{song}, Bebung {expected} cents: D2 bent {bent:.2} cents");
            assert!((bent - expected).abs() < 0.5, "{song}: {bent:.2} cents, the Bebung says {expected}");
        }
    }
}

#[test]
fn sustain_pedal_holds_a_released_note() {
    let scratch = Scratch::new();
    let held = scratch.wav(&midi("c4-release-pedal.mid"), &["--tail-s", "1.5"]);
    let dry = scratch.wav(&midi("c4-release-dry.mid"), &["--tail-s", "1.5"]);
    assert_eq!(held.len(), dry.len());
    // While the key is down the two are the same note.
    let (before_held, before_dry) = (held.energy(0.15, 0.45), dry.energy(0.15, 0.45));
    assert!((before_held / before_dry - 1.0).abs() < 0.5, "{before_held} vs {before_dry}");
    let (after_held, after_dry) = (held.energy(1.0, 2.0), dry.energy(1.0, 2.0));
    assert!(after_held > 100.0 * after_dry, "after release: {after_held:e} with the pedal, {after_dry:e} without");
    assert!(after_held > 0.01 * before_held, "the pedalled note still rings: {after_held:e} vs {before_held:e}");
}

/// All sound off (CC120) silences a pedalled chord within milliseconds.
#[test]
fn all_sound_off_silences() {
    let scratch = Scratch::new();
    let wav = scratch.wav(&midi("chord-all-sound-off.mid"), &["--tail-s", "0"]);
    let before = wav.energy(0.3, 0.5);
    let after = wav.energy(0.55, 1.0);
    assert!(after < 1e-6 * before, "{after:e} after all sound off, {before:e} before");
}

/// Format 1 with a tempo track: 120 bpm for two beats, then 60 bpm; C4 on beat 3
/// starts at 2.0 s and its release on beat 4 at 3.0 s is the last event.
#[test]
fn tempo_changes_move_the_notes() {
    let scratch = Scratch::new();
    let wav = scratch.wav(&midi("tempo-map.mid"), &["--tail-s", "0.5"]);
    assert_eq!(wav.len(), 168_000);
    let first = wav.first_sound().expect("sound");
    assert!((96_000..96_048).contains(&first), "first sound at sample {first}");
}

/// SMPTE timing (25 frames of 40 ticks a second) at 44.1 kHz.
#[test]
fn smpte_timing_is_played() {
    let scratch = Scratch::new();
    let wav = scratch.wav(&midi("smpte-25fps.mid"), &["--tail-s", "0.25", "--sample-rate", "44100"]);
    assert_eq!(wav.sample_rate_hz, 44_100);
    assert_eq!(wav.len(), 44_100);
    let first = wav.first_sound().expect("sound");
    assert!((11_025..11_025 + 45).contains(&first), "first sound at sample {first}");
}

#[test]
fn renders_are_bit_identical_for_any_block_size() {
    let scratch = Scratch::new();
    let song = midi("chord-all-sound-off.mid");
    let render = |block: &str, extra: &[&str]| {
        let args = [&["--tail-s", "0.2", "--block-size", block, "-q"], extra].concat();
        let out = scratch.render(&song, &args);
        assert!(out.status.success(), "{}", stderr(&out));
        std::fs::read(scratch.out()).unwrap()
    };
    let reference = render("64", &[]);
    assert_eq!(render("64", &[]), reference, "two runs differ");
    assert_eq!(render("1", &[]), reference, "block size 1");
    assert_eq!(render("4096", &[]), reference, "block size 4096");
    assert_eq!(render("8192", &[]), reference, "block size 8192");
}

/// Several songs at once, one a core, into a folder: each WAV named after its
/// song and bit-identical to that song rendered alone. A folder that is a
/// file, or two songs that would write the same WAV, are refused before
/// anything is written.
#[test]
fn several_songs_render_at_once_each_as_alone() {
    let scratch = Scratch::new();
    let songs = [midi("chord-all-sound-off.mid"), midi("smpte-25fps.mid"), midi("tempo-map.mid")];
    let folder = scratch.dir.path().join("renders");
    let mut args: Vec<&str> = vec!["render", "--tail-s", "0.2", "-q", "--out", folder.to_str().unwrap()];
    args.extend(songs.iter().map(|s| s.to_str().unwrap()));
    let out = struck(&args);
    assert!(out.status.success(), "{}", stderr(&out));
    for song in &songs {
        let alone = scratch.render(song, &["--tail-s", "0.2", "-q"]);
        assert!(alone.status.success(), "{}", stderr(&alone));
        let name = song.file_stem().unwrap().to_str().unwrap();
        let together = std::fs::read(folder.join(format!("{name}.wav"))).unwrap();
        assert!(together == std::fs::read(scratch.out()).unwrap(), "{name} differs from its render alone");
    }
    // A file where the folder should be.
    let file = scratch.dir.path().join("a-file.wav");
    std::fs::write(&file, b"x").unwrap();
    let mut args: Vec<&str> = vec!["render", "--out", file.to_str().unwrap()];
    args.extend(songs.iter().map(|s| s.to_str().unwrap()));
    let out = struck(&args);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("is the folder"), "{}", stderr(&out));
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
    // The same song twice.
    let twice = scratch.dir.path().join("twice");
    let song = songs[0].to_str().unwrap();
    let out = struck(&["render", "--out", twice.to_str().unwrap(), song, song]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert_eq!(stderr(&out).lines().count(), 1, "{}", stderr(&out));
    assert!(stderr(&out).contains("both would be written"), "{}", stderr(&out));
    assert!(!twice.exists(), "nothing made");
}

/// Channel 10 (General MIDI drums) is left out unless asked for.
#[test]
fn channel_10_is_ignored_unless_included() {
    let scratch = Scratch::new();
    let song = midi("channel-10-only.mid");
    assert_refused(&scratch, &song, &[], "channel 10");
    let wav = scratch.wav(&song, &["--tail-s", "0.1", "--include-channel-10"]);
    assert!(wav.energy(0.1, 0.5) > 0.0);
}

/// --instrument overrides the preset's; the preset's is used without it.
#[test]
fn preset_names_the_instrument_unless_overridden() {
    let scratch = Scratch::new();
    let preset = scratch.path("santoor.json");
    std::fs::write(
        &preset,
        r#"{"instrument": "santoor", "voicing": {"damping": 2.0}, "controls": {"output_gain": 0.5}}"#,
    )
    .unwrap();
    let song = midi("a4.mid");
    let out = scratch.render(&song, &["--tail-s", "0", "--preset", path_str(&preset)]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).contains("santoor"), "{}", stdout(&out));
    let out = scratch.render(&song, &["--tail-s", "0", "--preset", path_str(&preset), "--instrument", "clavichord"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).contains("clavichord"), "{}", stdout(&out));
}

/// Notes outside the instrument's keys are reported; a song with none inside is refused.
#[test]
fn notes_outside_the_instrument_are_named() {
    let scratch = Scratch::new();
    assert_refused(&scratch, &midi("a0.mid"), &["--instrument", "santoor"], "santoor's keys");
    let wav = scratch.wav(&midi("a0.mid"), &["--tail-s", "0.1"]);
    assert!(wav.energy(0.1, 0.5) > 0.0, "the piano has A0");
}

/// Refused: status 2, one line on stderr that names `what`, nothing on stdout, no
/// WAV written (nor any temporary file left), and an existing WAV left as it was.
fn assert_refused(scratch: &Scratch, song: &Path, extra: &[&str], what: &str) {
    let out_path = scratch.out();
    let _ = std::fs::remove_file(&out_path);
    let inputs: Vec<String> = scratch.others(&[]);
    let keep: Vec<&str> = inputs.iter().map(String::as_str).collect();
    for existing in [false, true] {
        if existing {
            std::fs::write(&out_path, b"an earlier render").unwrap();
        }
        let out = scratch.render(song, extra);
        let message = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{extra:?}: {message}");
        assert_eq!(message.lines().count(), 1, "one line: {message:?}");
        assert!(message.starts_with("struck render: "), "{message:?}");
        assert!(message.contains(what), "{message:?} should name {what:?}");
        assert!(stdout(&out).is_empty());
        if existing {
            assert_eq!(std::fs::read(&out_path).unwrap(), b"an earlier render", "the existing file is kept");
            std::fs::remove_file(&out_path).unwrap();
        } else {
            assert!(!out_path.exists(), "no WAV may be written");
        }
        assert!(scratch.others(&keep).is_empty(), "left behind: {:?}", scratch.others(&keep));
    }
}

#[test]
fn refuses_bad_songs() {
    let scratch = Scratch::new();
    assert_refused(&scratch, &scratch.path("missing.mid"), &[], "missing.mid");

    let text = scratch.path("notes.mid");
    std::fs::write(&text, "C4 E4 G4\n").unwrap();
    assert_refused(&scratch, &text, &[], "not a MIDI file");

    let whole = std::fs::read(midi("tempo-map.mid")).unwrap();
    let cut = scratch.path("cut.mid");
    std::fs::write(&cut, &whole[..whole.len() - 10]).unwrap();
    assert_refused(&scratch, &cut, &[], "truncated");
    std::fs::write(&cut, &whole[..10]).unwrap();
    assert_refused(&scratch, &cut, &[], "truncated");

    assert_refused(&scratch, &midi("format-2.mid"), &[], "format 2");
    assert_refused(&scratch, &midi("no-notes.mid"), &[], "no notes");
}

#[test]
fn refuses_bad_arguments() {
    let scratch = Scratch::new();
    let song = midi("a4.mid");
    for (args, named) in [
        (&["--sample-rate", "8000"][..], "--sample-rate"),
        (&["--sample-rate", "200000"], "--sample-rate"),
        (&["--sample-rate", "44100.5"], "--sample-rate"),
        (&["--tail-s", "-1"], "--tail-s"),
        (&["--tail-s", "601"], "--tail-s"),
        (&["--tail-s", "NaN"], "--tail-s"),
        (&["--block-size", "0"], "--block-size"),
        (&["--block-size", "8193"], "--block-size"),
        (&["--mpe=97"], "--mpe: the bend range must be from 0 to 96 semitones (got 97)"),
        (&["--instrument", "organ"], "organ"),
        (&["--preset", "no-such-preset.json"], "no-such-preset.json"),
        (&["--a4", "500"], "--a4: must be from 380 to 480 Hz (got 500)"),
        (&["--a4", "NaN"], "--a4"),
        (&["--stretch", "1.5"], "--stretch: must be from 0 to 1"),
        (&["--stretch", "-0.1"], "--stretch"),
        (&["--temperament", "pythagorean"], "--temperament: unknown temperament \"pythagorean\""),
        (&["--temperament", "scala"], "--temperament: scala needs a scale"),
        (&["--scl", "no-such-scale.scl"], "--scl no-such-scale.scl: cannot read"),
        (&["--output", "speakers"], "--output speakers: expected mics or bridge"),
        (&["--mics", "under"], "--mics under: expected close, player, lid or coincident"),
    ] {
        assert_refused(&scratch, &song, args, named);
    }
}

#[test]
fn refuses_bad_presets() {
    let scratch = Scratch::new();
    let song = midi("a4.mid");
    let preset = scratch.path("preset.json");
    for (text, named) in [
        (r#"{"instrument": "organ"}"#, "instrument"),
        (r#"{"voicing": {"hammer_mas": 2}}"#, "voicing.hammer_mas"),
        (r#"{"voicing": {"damping": -1}}"#, "voicing.damping"),
        (r#"{"controls": {"polyphony": "all"}}"#, "controls.polyphony"),
        (r#"{"controls": {"touch_max": 3}}"#, "controls.touch_max"),
        (r#"{"tempo": 1}"#, "tempo"),
        (r#"{"tuning": {"a4_hz": 500}}"#, "tuning.a4_hz"),
        (r#"{"tuning": {"temperament": "scala"}}"#, "tuning.temperament"),
        (r#"{"voicing": {"tangent_depth": -1}}"#, "voicing.tangent_depth"),
        (r#"{"voicing": {"felt_hysteresis": 4}}"#, "voicing.felt_hysteresis"),
        (r#"{"voicing": {"hammer_unevenness": 1.5}}"#, "voicing.hammer_unevenness"),
        (r#"{"controls": {"phantom": -1}}"#, "controls.phantom"),
        ("{", "JSON"),
    ] {
        std::fs::write(&preset, text).unwrap();
        let out = scratch.render(&song, &["--preset", path_str(&preset)]);
        let message = stderr(&out);
        assert!(message.contains("preset.json"), "{text}: {message}");
        assert_refused(&scratch, &song, &["--preset", path_str(&preset)], named);
    }
}

/// A malformed tuning file is refused with its name, line and reason; nothing is written.
#[test]
fn refuses_bad_tuning_files() {
    let scratch = Scratch::new();
    let song = midi("a4.mid");
    let scl = scratch.path("bad.scl");
    std::fs::write(&scl, "! bad.scl\nA broken scale\n3\n9/8\n3/0\n2/1\n").unwrap();
    assert_refused(
        &scratch,
        &song,
        &["--scl", path_str(&scl)],
        r#"bad.scl: line 5: "3/0" is not a ratio (denominator 0)"#,
    );
    std::fs::write(&scl, "! short.scl\nToo few\n12\n100.0\n").unwrap();
    assert_refused(&scratch, &song, &["--scl", path_str(&scl)], "11 of the 12 pitches are missing");

    let good = scratch.path("good.scl");
    std::fs::write(&good, "Equal\n1\n2/1\n").unwrap();
    let kbm = scratch.path("bad.kbm");
    std::fs::write(&kbm, "12\n0\n127\n60\n69\n-440\n12\n").unwrap();
    assert_refused(&scratch, &song, &["--scl", path_str(&good), "--kbm", path_str(&kbm)], "bad.kbm: line 6");
    assert_refused(&scratch, &song, &["--kbm", path_str(&kbm)], "bad.kbm");
    std::fs::write(&kbm, "0\n0\n127\n60\n69\n440\n0\n").unwrap();
    assert_refused(&scratch, &song, &["--kbm", path_str(&kbm)], "--kbm: a keyboard mapping needs a scale");
    assert_refused(
        &scratch,
        &song,
        &["--scl", path_str(&good), "--temperament", "meantone"],
        "--temperament meantone and --scl",
    );
}

/// A WAV whose name is taken by a directory is refused before anything is
/// rendered (status 2: nothing replaces a directory), and leaves nothing behind.
#[test]
fn a_failed_write_leaves_nothing() {
    let scratch = Scratch::new();
    std::fs::create_dir(scratch.out()).unwrap();
    let out = scratch.render(&midi("a4.mid"), &["--tail-s", "0"]);
    assert_eq!(out.status.code(), Some(2), "{}", stderr(&out));
    assert!(stderr(&out).contains("is a directory"), "{}", stderr(&out));
    assert_eq!(stderr(&out).lines().count(), 1, "{}", stderr(&out));
    assert!(scratch.out().is_dir());
    assert!(scratch.others(&["out.wav"]).is_empty(), "{:?}", scratch.others(&["out.wav"]));
}

#[test]
fn an_interrupted_render_leaves_nothing_behind() {
    let scratch = Scratch::new();
    let song = crate_dir_song("piano-nocturne.mid");
    let out = scratch.out();
    // Ten minutes of tail at 192 kHz: long enough to be interrupted mid-way.
    let child = std::process::Command::new(struck_tests::struck_binary())
        .args(["render", path_str(&song), "--out", path_str(&out), "--sample-rate", "192000", "--tail-s", "600", "-q"])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(std::time::Duration::from_millis(700));
    let killed = std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap();
    assert!(killed.success());
    let output = child.wait_with_output().unwrap();
    assert_eq!(output.status.code(), Some(130), "{}", stderr(&output));
    assert!(stderr(&output).contains("interrupted"), "{}", stderr(&output));
    assert!(!out.exists() && scratch.others(&[]).is_empty(), "left behind: {:?}", scratch.others(&[]));
}

fn crate_dir_song(name: &str) -> PathBuf {
    struck_tests::crate_dir().parent().unwrap().join("demo-songs").join(name)
}

#[test]
fn a_voicing_not_shipped_is_saved_once_and_taken_from_the_cache_after() {
    // Settings no factory preset has: the keys are voiced through the body
    // (the better part of a second), the voicing saved in the cache folder,
    // and a second run takes it from there and renders the same samples. A
    // damaged file there is passed over (voiced again, the same).
    let dir = tempfile::tempdir().expect("a scratch folder");
    let cache = dir.path().join("cache");
    let preset = dir.path().join("hard.json");
    std::fs::write(&preset, r#"{"name": "hard", "instrument": "santoor", "voicing": {"hammer_stiffness": 1.37}}"#)
        .expect("a preset");
    let render = |name: &str| {
        let out = dir.path().join(name);
        let output = std::process::Command::new(struck_tests::struck_binary())
            .env("STRUCK_CACHE_DIR", &cache)
            .args(["render", "--preset", path_str(&preset), "--out", path_str(&out), path_str(&midi("a4.mid"))])
            .output()
            .expect("run struck");
        assert!(output.status.success(), "{}", stderr(&output));
        std::fs::read(out).expect("a WAV")
    };
    let saved = || -> Vec<PathBuf> {
        let mut files: Vec<PathBuf> = std::fs::read_dir(cache.join("voicings"))
            .into_iter()
            .flatten()
            .flatten()
            .filter(|d| d.path().is_dir())
            .flat_map(|d| std::fs::read_dir(d.path()).into_iter().flatten().flatten().map(|f| f.path()))
            .collect();
        files.sort();
        files
    };
    let first = render("first.wav");
    let files = saved();
    assert_eq!(files.len(), 1, "one voicing saved: {files:?}");
    assert!(files[0].extension().is_some_and(|e| e == "json"), "{files:?}");
    let text = std::fs::read_to_string(&files[0]).expect("the saved voicing");
    assert!(text.contains("\"hammer_stiffness\":1.37") && text.contains("\"santoor\""), "{}", &text[..200]);
    assert!(render("second.wav") == first, "the saved voicing renders as the one found");
    // It is read: every key turned up twice on the body is heard so.
    let (head, whole) = text.split_once('\n').expect("a head line");
    let mut voicing: serde_json::Value = serde_json::from_str(whole).expect("the voicing");
    for key in voicing["keys"].as_array_mut().expect("keys") {
        key["body_gain"] = (2.0 * key["body_gain"].as_f64().expect("a gain")).into();
    }
    std::fs::write(&files[0], format!("{head}\n{voicing}\n")).expect("turned up");
    let peak = |wav: &[u8]| {
        let mut reader = hound::WavReader::new(wav).expect("a WAV");
        reader.samples::<f32>().map(Result::unwrap).fold(0.0f32, |m, s| m.max(s.abs()))
    };
    let louder = 20.0 * (peak(&render("louder.wav")) / peak(&first)).log10();
    assert!((louder - 6.0).abs() < 1.0, "{louder} dB");
    std::fs::write(&files[0], "{\"settings\": broken").expect("damage it");
    assert!(render("third.wav") == first, "a damaged saved voicing is passed over");
    assert_eq!(saved(), files, "and saved again whole");
    assert!(std::fs::read_to_string(&files[0]).expect("saved again").contains("santoor"));
}
