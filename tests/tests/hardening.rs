//! What the command line does with input it must not trust and outputs it must
//! not spoil (the hardening issue): every refusal is one line with exit status
//! 2, nothing the user gave is overwritten, nothing is left half-written.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

use struck_tests::{SANTOOR_CASE, midi_gen, stderr, stdout, struck};

/// A test MIDI file.
fn midi(name: &str) -> PathBuf {
    midi_gen::test_dir().join(name)
}

fn text(path: &Path) -> String {
    path.to_str().unwrap().to_string()
}

/// The valid santoor case written as `case.json` in `dir`.
fn santoor_case(dir: &Path) -> PathBuf {
    let case = dir.join("case.json");
    std::fs::write(&case, SANTOOR_CASE).unwrap();
    case
}

/// Refused: status 2 and one line on stderr that contains `words`.
fn refused(out: &Output, words: &str) {
    let message = stderr(out);
    assert_eq!(out.status.code(), Some(2), "{message}");
    assert_eq!(message.lines().count(), 1, "one line: {message:?}");
    assert!(message.contains(words), "{message:?} should say {words:?}");
}

#[test]
fn devices_and_fifos_are_refused_at_once_for_every_file_read() {
    let dir = tempfile::tempdir().unwrap();
    let song = midi("a4.mid");
    let out = text(&dir.path().join("x.wav"));
    let started = Instant::now();
    refused(&struck(&["render", "/dev/zero", "--out", &out]), "/dev/zero: not a regular file (a device)");
    refused(&struck(&["render", &text(&song), "--out", &out, "--preset", "/dev/urandom"]), "not a regular file");
    refused(&struck(&["render", &text(&song), "--out", &out, "--scl", "/dev/zero"]), "not a regular file");
    refused(&struck(&["strike", "/dev/zero", "--out", &text(dir.path())]), "not a regular file");
    refused(&struck(&["render", &text(dir.path()), "--out", &out]), "(a directory)");
    let fifo = dir.path().join("pipe");
    if std::process::Command::new("mkfifo").arg(&fifo).status().is_ok_and(|s| s.success()) {
        refused(&struck(&["strike", &text(&fifo), "--out", &text(dir.path())]), "(a FIFO)");
        refused(&struck(&["render", &text(&fifo), "--out", &out]), "(a FIFO)");
    }
    assert!(started.elapsed() < Duration::from_secs(30), "nothing waited");
    assert!(!dir.path().join("x.wav").exists());
}

#[test]
fn a_file_larger_than_its_kind_may_be_is_refused_while_reading() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("huge.json");
    std::fs::write(&case, vec![b' '; (1 << 20) + 1]).unwrap();
    refused(&struck(&["strike", &text(&case), "--out", &text(&dir.path().join("o"))]), "larger than the 1 MB");
}

#[test]
fn no_output_may_be_one_of_the_inputs_however_it_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let out = dir.path().join("out");
    // --wav naming the case; the case inside --out as metrics.json; --wav naming metrics.json.
    refused(&struck(&["strike", &text(&case), "--out", &text(&out), "--wav", &text(&case)]), "one of the inputs");
    std::fs::create_dir(&out).unwrap();
    let inside = out.join("metrics.json");
    std::fs::write(&inside, SANTOOR_CASE).unwrap();
    refused(&struck(&["strike", &text(&inside), "--out", &text(&out)]), "one of the inputs");
    std::fs::remove_file(&inside).unwrap();
    refused(&struck(&["strike", &text(&case), "--out", &text(&out), "--wav", &text(&inside)]), "named for two outputs");
    // A render's preset and scale, also under another name.
    let preset = dir.path().join("p.json");
    std::fs::write(&preset, r#"{"name": "Mine"}"#).unwrap();
    let song = text(&midi("a4.mid"));
    refused(&struck(&["render", &song, "--out", &text(&preset), "--preset", &text(&preset)]), "one of the inputs");
    let scale = dir.path().join("s.scl");
    std::fs::write(&scale, "! s\nfifths\n1\n2/1\n").unwrap();
    let other_name = dir.path().join("out").join("..").join("s.scl");
    refused(&struck(&["render", &song, "--out", &text(&other_name), "--scl", &text(&scale)]), "one of the inputs");
    refused(&struck(&["animate", &text(&case), "--out", &text(&case)]), "one of the inputs");
    assert_eq!(std::fs::read_to_string(&case).unwrap(), SANTOOR_CASE);
    assert_eq!(std::fs::read_to_string(&preset).unwrap(), r#"{"name": "Mine"}"#);
    assert_eq!(std::fs::read_to_string(&scale).unwrap(), "! s\nfifths\n1\n2/1\n");
    assert!(std::fs::read_dir(&out).unwrap().next().is_none(), "nothing was written");
}

#[test]
fn a_device_or_folder_is_never_replaced_and_folders_made_for_a_failure_go() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    refused(&struck(&["render", &text(&midi("a4.mid")), "--out", "/dev/null"]), "is not a regular file");
    assert!(!Path::new("/dev/null").metadata().unwrap().file_type().is_file());
    let deep = dir.path().join("new").join("deeper");
    refused(&struck(&["strike", &text(&case), "--out", &text(&deep), "--wav", "/dev/null"]), "is not a regular file");
    assert!(!dir.path().join("new").exists(), "the folders made for it are gone");
    refused(
        &struck(&["strike", &text(&case), "--out", &text(dir.path()), "--wav", &text(dir.path())]),
        "is a directory",
    );
    refused(&struck(&["strike", &text(&case), "--out", "/dev/null"]), "/dev/null: is not a folder");
    refused(&struck(&["strike", &text(&case), "--out", &text(&case)]), "is not a folder");
    assert_eq!(std::fs::read_to_string(&case).unwrap(), SANTOOR_CASE);
}

#[test]
fn physics_out_of_range_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let out = text(&dir.path().join("o"));
    refused(&struck(&["strike", &text(&case), "--out", &out, "--set", "exciter.stiffness=1e22"]), "exciter.stiffness");
    refused(
        &struck(&["strike", &text(&case), "--out", &out, "--wav", "w.wav", "--wav-gain-db", "800"]),
        "--wav-gain-db",
    );
    assert!(!dir.path().join("o").exists());
}

#[test]
fn argument_errors_and_unknown_commands_take_one_line() {
    refused(&struck(&["render"]), "--out");
    refused(&struck(&["render", "a.mid", "--out", "b.wav", "--block-size", "many"]), "--block-size");
    refused(&struck(&["no-such-command"]), "no command");
    refused(&struck(&["-b", "dummy", "--period-size", "0"]), "--period-size 0");
    refused(&struck(&["-b", "dummy", "--period-size", "4294967295"]), "--period-size");
}

#[test]
fn the_standalones_environment_is_checked_before_it_plays() {
    let live = |var: &str, value: &str| {
        std::process::Command::new(struck_tests::struck_binary())
            .args(["-b", "dummy"])
            .env(var, value)
            .env_remove("DISPLAY")
            .output()
            .expect("run struck")
    };
    refused(&live("STRUCK_LOAD_SMOOTHING", "maybe"), "STRUCK_LOAD_SMOOTHING=maybe: must be on or off");
    let dir = tempfile::tempdir().unwrap();
    let nowhere = text(&dir.path().join("no-such-dir").join("callbacks.txt"));
    refused(&live("STRUCK_CALLBACK_STATS", &nowhere), "STRUCK_CALLBACK_STATS=");
}

#[test]
fn a_files_own_escape_sequences_are_shown_not_sent_to_the_terminal() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("case\u{1b}[31m.json");
    std::fs::write(&case, "{\"name\": 3, \"sample_rate_hz\u{1b}[2J\": 1}").unwrap();
    let out = struck(&["strike", &text(&case), "--out", &text(&dir.path().join("o"))]);
    let message = stderr(&out);
    assert_eq!(out.status.code(), Some(2));
    assert!(!message.contains('\u{1b}'), "{message:?}");
    assert!(message.contains("\\u{1b}"), "{message:?}");
}

#[test]
fn a_long_legal_output_name_is_written() {
    let dir = tempfile::tempdir().unwrap();
    let name = format!("{}.wav", "a".repeat(250));
    let out = dir.path().join(&name);
    let run = struck(&["render", &text(&midi("a4.mid")), "--out", &text(&out), "--tail-s", "0", "-q"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(out.exists());
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "no temporary file left");
}

#[test]
fn a_stop_signal_during_a_strike_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let out = dir.path().join("out").join("deeper");
    let child = std::process::Command::new(struck_tests::struck_binary())
        .args([
            "strike",
            &text(&case),
            "--out",
            &text(&out),
            "--set",
            "duration_s=60",
            "--set",
            "sample_rate_hz=384000",
        ])
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    let sent = std::process::Command::new("kill").args(["-TERM", &child.id().to_string()]).status().unwrap();
    assert!(sent.success());
    let done = child.wait_with_output().unwrap();
    assert_eq!(done.status.code(), Some(130), "{}", stderr(&done));
    assert!(stderr(&done).contains("interrupted; nothing was written"), "{}", stderr(&done));
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, ["case.json"], "only the case is left");
}

#[test]
fn a_strike_chart_takes_a_bounded_number_of_strikes() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let speeds = vec!["1"; 100].join(",");
    let out = text(&dir.path().join("new").join("deeper").join("charts"));
    refused(&struck(&["chart", "strike", &text(&case), "--out", &out, "--speeds", &speeds]), "at most 64");
    assert!(!dir.path().join("new").exists(), "the folders made for the refused chart are gone");
}

#[test]
fn metrics_never_hold_a_null() {
    // A tangent has no rebound and a pluck no contact force: those are left out.
    let dir = tempfile::tempdir().unwrap();
    for (name, exciter) in [
        ("tangent", serde_json::json!({"kind": "tangent", "speed_m_s": 0.5, "displacement_m": 0.001})),
        ("pluck", serde_json::json!({"kind": "pluck", "displacement_m": 0.001, "position": 0.2})),
    ] {
        let mut case: serde_json::Value = serde_json::from_str(SANTOOR_CASE).unwrap();
        case["exciter"] = exciter;
        case["duration_s"] = serde_json::json!(0.2);
        let path = dir.path().join(format!("{name}.json"));
        std::fs::write(&path, case.to_string()).unwrap();
        let out = dir.path().join(name);
        let run = struck(&["strike", &text(&path), "--out", &text(&out), "-q"]);
        assert!(run.status.success(), "{name}: {}", stderr(&run));
        let metrics = std::fs::read_to_string(out.join("metrics.json")).unwrap();
        assert!(!metrics.contains("null"), "{name}: {metrics}");
    }
}

#[test]
fn a_stop_signal_during_a_chart_leaves_nothing_behind() {
    // A chart draws many files: into a folder beside --out, put in place together.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("charts");
    let child = std::process::Command::new(struck_tests::struck_binary())
        .args(["chart", "hammer", "--instrument", "piano", "--key", "C4", "--grid", "200", "--out", &text(&out)])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(1500));
    assert!(std::process::Command::new("kill").args(["-INT", &child.id().to_string()]).status().unwrap().success());
    let done = child.wait_with_output().unwrap();
    assert_eq!(done.status.code(), Some(130), "{}", stderr(&done));
    assert!(std::fs::read_dir(dir.path()).unwrap().next().is_none(), "nothing left");
}

#[test]
fn an_argument_that_is_not_text_is_refused_in_one_line() {
    use std::ffi::OsStr;
    use std::os::unix::ffi::OsStrExt;
    let dir = tempfile::tempdir().unwrap();
    let bad = OsStr::from_bytes(b"bad\xff.mid");
    let run = |args: &[&OsStr]| std::process::Command::new(struck_tests::struck_binary()).args(args).output().unwrap();
    // The live program's options are all text.
    refused(&run(&[OsStr::new("--backend"), bad]), "is not valid UTF-8");
    // A subcommand's paths need not be: this one is read (and is missing).
    let song = dir.path().join(bad);
    let out = dir.path().join("x.wav");
    refused(&run(&[OsStr::new("render"), song.as_os_str(), OsStr::new("--out"), out.as_os_str()]), "cannot read");
}

#[test]
fn an_output_named_by_a_link_is_written_through_it() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let target = dir.path().join("target.wav");
    std::fs::write(&target, b"old").unwrap();
    let link = dir.path().join("link.wav");
    std::os::unix::fs::symlink("target.wav", &link).unwrap();
    let out = struck(&["strike", &text(&case), "--out", &text(&dir.path().join("o")), "--wav", &text(&link), "-q"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(link.symlink_metadata().unwrap().file_type().is_symlink(), "the link is kept");
    assert!(std::fs::read(&target).unwrap().starts_with(b"RIFF"), "the file it leads to is written");
    // A link that leads nowhere is not written through.
    let dangling = dir.path().join("dangling.wav");
    std::os::unix::fs::symlink("nowhere/x.wav", &dangling).unwrap();
    let o2 = dir.path().join("o2");
    refused(&struck(&["strike", &text(&case), "--out", &text(&o2), "--wav", &text(&dangling)]), "which does not exist");
    assert!(!o2.exists() && !dir.path().join("nowhere").exists());
}

#[test]
fn an_output_path_that_cannot_be_written_is_refused_before_the_work() {
    let dir = tempfile::tempdir().unwrap();
    let long = dir.path().join(format!("{}.wav", "a".repeat(300)));
    refused(&struck(&["render", &text(&midi("a4.mid")), "--out", &text(&long)]), "File name too long");
    // A file where the output folder should be: refused at once, naming it.
    let file = dir.path().join("afile");
    std::fs::write(&file, "x").unwrap();
    let inside = text(&file.join("charts"));
    refused(&struck(&["chart", "stringing", "--out", &inside]), "afile: is not a folder");
    refused(&struck(&["demo", "--quick", "--out", &inside]), "afile: is not a folder");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "nothing was left beside it");
}

#[test]
fn a_chart_is_drawn_inside_its_folder_and_nothing_is_left_beside_or_in_it() {
    let dir = tempfile::tempdir().unwrap();
    let charts = dir.path().join("charts");
    let out = struck(&["chart", "stringing", "--out", &text(&charts)]);
    assert!(out.status.success(), "{}", stderr(&out));
    let names: Vec<String> =
        std::fs::read_dir(&charts).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert!(!names.is_empty() && names.iter().all(|n| !n.starts_with('.')), "{names:?}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 1, "nothing beside the folder");
}

#[test]
fn a_key_given_twice_in_a_file_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("case.json");
    std::fs::write(&case, SANTOOR_CASE.replacen('{', "{\"duration_s\": 0.1,", 1)).unwrap();
    let out = text(&dir.path().join("o"));
    refused(&struck(&["strike", &text(&case), "--out", &out]), "\"duration_s\" is given twice");
    let preset = dir.path().join("p.json");
    std::fs::write(&preset, r#"{"instrument": "piano", "instrument": "santoor"}"#).unwrap();
    let wav = text(&dir.path().join("x.wav"));
    refused(&struck(&["render", &text(&midi("a4.mid")), "--out", &wav, "--preset", &text(&preset)]), "given twice");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 2, "nothing written");
}

#[test]
fn flags_that_cannot_mean_anything_are_refused() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let out = text(&dir.path().join("o"));
    refused(&struck(&["strike", &text(&case), "--out", &out, "--wav-gain-db", "0"]), "--wav");
    let wav = text(&dir.path().join("w.wav"));
    let set = "sample_rate_hz=44100.5";
    refused(&struck(&["strike", &text(&case), "--out", &out, "--set", set, "--wav", &wav]), "not a whole number");
    refused(&struck(&["bench", "--seconds", "1e-300"]), "--seconds");
    // A huge number is quoted short.
    refused(&struck(&["strike", &text(&case), "--out", &out, "--set", "exciter.position=1e300"]), "(got 1e300)");
    assert!(!dir.path().join("o").exists());
}

#[test]
fn a_cases_name_is_printed_with_its_escapes_shown() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("case.json");
    let named = SANTOOR_CASE.replace("\"santoor-a4-at-2/5\"", "\"evil\\u001b[31m\\nname\"");
    std::fs::write(&case, named).unwrap();
    let out = struck(&["strike", &text(&case), "--out", &text(&dir.path().join("o"))]);
    assert!(out.status.success(), "{}", stderr(&out));
    let said = String::from_utf8_lossy(&out.stdout).into_owned();
    assert!(!said.contains('\u{1b}') && said.contains("evil\\u{1b}[31m\\nname"), "{said:?}");
}

/// Where a test sends one of the program's streams.
#[derive(Clone, Copy, Debug)]
enum Stream {
    /// stdout to /dev/full (every write fails: no space left).
    FullStdout,
    /// stdout to a pipe whose reader has gone (every write fails: broken pipe).
    ClosedStdout,
    /// stderr to /dev/full.
    FullStderr,
}

/// Run `struck args` with `stream` broken; the exit code and what stderr
/// said (nothing when stderr is the broken one).
fn run_broken(stream: Stream, args: &[&str]) -> (Option<i32>, String) {
    use std::process::{Command, Stdio};
    let full = || Stdio::from(std::fs::OpenOptions::new().write(true).open("/dev/full").unwrap());
    let mut command = Command::new(struck_tests::struck_binary());
    command.args(args).stdin(Stdio::null());
    match stream {
        Stream::FullStdout => command.stdout(full()).stderr(Stdio::piped()),
        Stream::ClosedStdout => command.stdout(Stdio::piped()).stderr(Stdio::piped()),
        Stream::FullStderr => command.stdout(Stdio::null()).stderr(full()),
    };
    let mut child = command.spawn().unwrap();
    // The reader goes before the program writes anything.
    drop(child.stdout.take());
    let done = child.wait_with_output().unwrap();
    (done.status.code(), stderr(&done))
}

/// The exit status a command whose work succeeded has with `stream` broken,
/// and what it says: a report lost to a full stdout is status 1 and one line;
/// a reader that went away, or a stderr that cannot be written, changes nothing.
fn assert_finished(stream: Stream, (code, said): &(Option<i32>, String), what: &str) {
    assert!(!said.contains("panicked"), "{what}, {stream:?}: {said}");
    match stream {
        Stream::FullStdout => {
            assert_eq!(*code, Some(1), "{what}, {stream:?}: {said}");
            assert_eq!(said.lines().count(), 1, "{what}: one line: {said:?}");
            assert!(said.contains("cannot print") && said.contains("No space left"), "{what}: {said}");
        }
        Stream::ClosedStdout | Stream::FullStderr => {
            assert_eq!(*code, Some(0), "{what}, {stream:?}: {said}");
            assert!(said.is_empty(), "{what}, {stream:?}: {said}");
        }
    }
}

const BROKEN: [Stream; 3] = [Stream::FullStdout, Stream::ClosedStdout, Stream::FullStderr];

#[test]
fn a_full_or_closed_stdout_or_a_full_stderr_never_stops_a_render_or_spoils_its_wav() {
    let dir = tempfile::tempdir().unwrap();
    let song = text(&midi("a4.mid"));
    let reference = dir.path().join("reference.wav");
    let run = struck(&["render", &song, "--out", &text(&reference), "--tail-s", "1"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let expected = std::fs::read(&reference).unwrap();
    for stream in BROKEN {
        let wav = dir.path().join(format!("{stream:?}.wav"));
        let done = run_broken(stream, &["render", &song, "--out", &text(&wav), "--tail-s", "1"]);
        assert_finished(stream, &done, "render");
        assert!(std::fs::read(&wav).unwrap() == expected, "{stream:?}: the WAV is whole");
    }
    let left = std::fs::read_dir(dir.path()).unwrap().count();
    assert_eq!(left, 4, "the WAVs and nothing else");
}

#[test]
fn a_full_or_closed_stdout_never_stops_strike_chart_animate_or_help() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    for stream in BROKEN {
        let name = format!("{stream:?}");
        let out = dir.path().join(&name);
        let done =
            run_broken(stream, &["strike", &text(&case), "--out", &text(&out), "--wav", &text(&out.join("b.wav"))]);
        assert_finished(stream, &done, "strike");
        let trace = std::fs::read_to_string(out.join("trace.csv")).unwrap();
        assert_eq!(trace.lines().count(), 4801, "{name}: every row of the trace");
        assert!(std::fs::read_to_string(out.join("metrics.json")).unwrap().trim_end().ends_with('}'));
        assert!(std::fs::read(out.join("b.wav")).unwrap().starts_with(b"RIFF"));

        let gif = out.join("a.gif");
        assert_finished(
            stream,
            &run_broken(stream, &["animate", &text(&case), "--out", &text(&gif), "--frames", "4"]),
            "animate",
        );
        assert!(std::fs::read(&gif).unwrap().starts_with(b"GIF89a"), "{name}");

        let charts = out.join("charts");
        assert_finished(stream, &run_broken(stream, &["chart", "stringing", "--out", &text(&charts)]), "chart");
        let names: Vec<String> = std::fs::read_dir(&charts)
            .unwrap()
            .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
            .collect();
        assert!(names.iter().any(|n| n.ends_with(".png")) && !names.iter().any(|n| n.starts_with('.')), "{names:?}");
        let hidden = std::fs::read_dir(&out)
            .unwrap()
            .filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with('.'));
        assert_eq!(hidden.count(), 0, "{name}: no temporary left");
    }
    // What was asked for is on stdout: a full one is status 1 and one line.
    for args in [&["--help"][..], &["--version"], &["render", "--help"], &["help", "strike"]] {
        let (code, said) = run_broken(Stream::FullStdout, args);
        assert_eq!(code, Some(1), "{args:?}: {said}");
        assert_eq!(said.lines().count(), 1, "{args:?}: {said:?}");
        assert!(said.contains("cannot print the help: No space left"), "{args:?}: {said}");
        for stream in [Stream::ClosedStdout, Stream::FullStderr] {
            let (code, said) = run_broken(stream, args);
            assert_eq!(code, Some(0), "{args:?}, {stream:?}: {said}");
            assert!(said.is_empty(), "{args:?}, {stream:?}: {said}");
        }
    }
    // A refusal with nowhere to say it keeps its status.
    for args in [&["render", "missing.mid", "--out", "x.wav"][..], &["bench", "--seconds", "0"], &["no-such-command"]] {
        let (code, _) = run_broken(Stream::FullStderr, args);
        assert_eq!(code, Some(2), "{args:?}");
    }
}

#[test]
fn a_demo_whose_reader_went_away_still_writes_everything() {
    // The demo prints its first line before the work, and more as it goes.
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("demo");
    let done = run_broken(Stream::ClosedStdout, &["demo", "--quick", "--out", &text(&out)]);
    assert_finished(Stream::ClosedStdout, &done, "demo");
    assert!(std::fs::read_to_string(out.join("index.html")).unwrap().contains("</html>"));
    let hidden =
        std::fs::read_dir(&out).unwrap().filter(|e| e.as_ref().unwrap().file_name().to_string_lossy().starts_with('.'));
    assert_eq!(hidden.count(), 0, "no temporary left");
}

/// Start `struck args`, send `signal` after `delay_ms`, and wait: the exit
/// status as a shell reports it (130 for SIGINT, 143 for SIGTERM, whether the
/// program stopped itself or the signal did, before the program could catch it).
fn signalled(args: &[&str], signal: &str, delay_ms: u64) -> (i32, String) {
    use std::os::unix::process::ExitStatusExt;
    let child = std::process::Command::new(struck_tests::struck_binary())
        .args(args)
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(delay_ms));
    let sent = std::process::Command::new("kill").args([&format!("-{signal}"), &child.id().to_string()]).status();
    assert!(sent.unwrap().success(), "{args:?} still ran at {delay_ms} ms");
    let done = child.wait_with_output().unwrap();
    let code = done.status.code().unwrap_or_else(|| 128 + done.status.signal().unwrap());
    (code, stderr(&done))
}

/// Every file under `dir` (hidden ones too) with its bytes.
fn snapshot(dir: &Path) -> Vec<(PathBuf, Vec<u8>)> {
    let mut files = Vec::new();
    for entry in std::fs::read_dir(dir).unwrap() {
        let path = entry.unwrap().path();
        if path.is_dir() {
            files.push((path.clone(), Vec::new()));
            files.extend(snapshot(&path));
        } else {
            files.push((path.clone(), std::fs::read(&path).unwrap()));
        }
    }
    files.sort();
    files
}

#[test]
fn a_stop_signal_soon_after_the_start_leaves_every_existing_output_as_it_was() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let song = text(&midi("a4.mid"));
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    // What the commands below would replace, and files they leave alone.
    for name in ["x.wav", "x.gif", "metrics.json", "trace.csv", "index.html", "stringing-mass.png", "mine.txt"] {
        std::fs::write(out.join(name), format!("the user's {name}")).unwrap();
    }
    let before = snapshot(dir.path());
    let (gif, wav, folder) = (text(&out.join("x.gif")), text(&out.join("x.wav")), text(&out));
    let commands: [(&[&str], &[u64]); 5] = [
        // A big film (about two seconds' work), a long render, a long strike.
        (
            &["animate", &text(&case), "--out", &gif, "--frames", "1000", "--set", "sample_rate_hz=1536000"],
            &[20, 50, 100, 300],
        ),
        (&["render", &song, "--out", &wav, "--tail-s", "600"], &[20, 50, 100, 300]),
        (
            &["strike", &text(&case), "--out", &folder, "--set", "duration_s=60", "--set", "sample_rate_hz=96000"],
            &[50, 300],
        ),
        (&["chart", "hammer", "--grid", "200", "--out", &folder], &[50, 300]),
        (&["demo", "--quick", "--out", &folder], &[50, 300]),
    ];
    for (args, delays) in commands {
        for (i, &delay) in delays.iter().enumerate() {
            let (signal, status) = if i % 2 == 0 { ("INT", 130) } else { ("TERM", 143) };
            let (code, said) = signalled(args, signal, delay);
            // (Stopped by the program, 130; by the signal itself, 128 + its number.)
            assert!(code == 130 || code == status, "{} at {delay} ms, SIG{signal}: {code} {said}", args[0]);
            assert!(!said.contains("panicked"), "{said}");
            assert!(snapshot(dir.path()) == before, "{} at {delay} ms, SIG{signal}: every file as it was", args[0]);
        }
    }
}

/// Run `struck args` under `prlimit` limits (e.g. "--fsize=102400"), in `dir`.
fn limited(limits: &[&str], args: &[&str]) -> Output {
    std::process::Command::new("prlimit")
        .args(limits)
        .arg(struck_tests::struck_binary())
        .args(args)
        .output()
        .expect("run prlimit (util-linux)")
}

#[test]
fn a_file_size_limit_is_named_in_one_line_and_nothing_is_left() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    for name in ["x.wav", "metrics.json", "trace.csv", "x.gif", "stringing-piano-tension.png"] {
        std::fs::write(out.join(name), format!("the user's {name}")).unwrap();
    }
    let before = snapshot(dir.path());
    let limit = "--fsize=102400";
    let said = "the file-size limit (ulimit -f, 102400 bytes)";
    // Known before the work: a render's WAV, a strike's WAV.
    let song = text(&midi("a4.mid"));
    refused(&limited(&[limit], &["render", &song, "--out", &text(&out.join("x.wav"))]), said);
    let wav = text(&out.join("x.wav"));
    refused(
        &limited(&[limit], &["strike", &text(&case), "--out", &text(&out), "--set", "duration_s=1", "--wav", &wav]),
        said,
    );
    // Found while writing: a strike's trace (the signal would have killed it), a GIF, a chart's PNG.
    refused(
        &limited(&[limit], &["strike", &text(&case), "--out", &text(&out)]),
        &format!("trace.csv: {said} is reached"),
    );
    let gif = text(&out.join("x.gif"));
    refused(&limited(&["--fsize=20480"], &["animate", &text(&case), "--out", &gif]), "x.gif: the file-size limit");
    refused(&limited(&["--fsize=40960"], &["chart", "stringing", "--out", &text(&out)]), ".png: the file-size limit");
    assert!(snapshot(dir.path()) == before, "every file as it was, no temporary left");
}

#[test]
fn a_memory_limit_too_small_for_the_work_is_named_in_one_line() {
    let dir = tempfile::tempdir().unwrap();
    let case = santoor_case(dir.path());
    let out = dir.path().join("out");
    // The documented limits: 60 s at 1.536 MHz holds about 8 GB.
    let big = ["--set", "duration_s=60", "--set", "sample_rate_hz=1536000"];
    let strike = |limit: &str| {
        let mut args = vec!["strike", case.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend(big);
        limited(&[limit], &args)
    };
    refused(&strike("--as=2000000000"), "the memory limit (ulimit -v, 1.9 GB) leaves");
    refused(&strike("--data=2000000000"), "the data limit (ulimit -d, 1.9 GB) leaves");
    let said = stderr(&strike("--as=2000000000"));
    assert!(said.contains("(92160000 samples) would hold 7.6 GB in memory"), "{said}");
    // A strike chart holds every run it draws.
    let charts = out.to_str().unwrap();
    let mut args = vec!["chart", "strike", case.to_str().unwrap(), case.to_str().unwrap(), "--out", charts];
    args.extend(big);
    refused(
        &limited(&["--as=2000000000"], &args),
        "2 strikes on one chart would hold 15.1 GB in memory; the memory limit",
    );
    // A render holds little, but not nothing.
    let wav = dir.path().join("x.wav");
    refused(&limited(&["--as=60000000"], &["render", &text(&midi("a4.mid")), "--out", &text(&wav)]), "ulimit -v");
    let left: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(left, ["case.json"], "nothing written");
}

#[test]
fn temporaries_left_by_a_killed_struck_are_swept_when_a_command_next_writes_there() {
    /// A child killed when the test ends, however it ends.
    struct Running(std::process::Child);
    impl Drop for Running {
        fn drop(&mut self) {
            let _ = self.0.kill();
            let _ = self.0.wait();
        }
    }
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("out");
    std::fs::create_dir(&out).unwrap();
    // A process that has ended, and a struck still at work.
    let mut gone = std::process::Command::new("true").spawn().unwrap();
    let dead = gone.id();
    gone.wait().unwrap();
    let song = text(&midi("a4.mid"));
    let elsewhere = text(&dir.path().join("long.wav"));
    let working = Running(
        std::process::Command::new(struck_tests::struck_binary())
            .args(["render", &song, "--out", &elsewhere, "--tail-s", "600", "-q"])
            .stderr(std::process::Stdio::null())
            .spawn()
            .unwrap(),
    );
    let live = working.0.id();
    let stale_file = out.join(format!(".struck-{dead}-0.part"));
    let stale_folder = out.join(format!(".struck-{dead}.part"));
    let set_aside = out.join(format!(".struck-{dead}-0.old"));
    let in_use = out.join(format!(".struck-{live}-3.part"));
    let stale = || {
        std::fs::write(&stale_file, vec![0u8; 1 << 16]).unwrap();
        std::fs::create_dir(&stale_folder).unwrap();
        std::fs::write(stale_folder.join("half.png"), "half").unwrap();
    };
    stale();
    std::fs::write(&set_aside, "what stood at an output").unwrap();
    std::fs::write(&in_use, "being written").unwrap();

    let run = struck(&["render", &song, "--out", &text(&out.join("x.wav")), "--tail-s", "0", "-q"]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(!stale_file.exists() && !stale_folder.exists(), "a dead process's temporaries are swept");
    assert!(set_aside.exists(), "what was set aside is the user's, never swept");
    assert!(in_use.exists(), "a working struck's temporary is kept");
    // A chart (a folder of files) sweeps its folder too.
    stale();
    let run = struck(&["chart", "stringing", "--out", &text(&out)]);
    assert!(run.status.success(), "{}", stderr(&run));
    assert!(!stale_file.exists() && !stale_folder.exists(), "swept");
    assert!(in_use.exists() && set_aside.exists(), "kept");
    drop(working);
}

#[test]
fn a_text_file_saved_with_a_byte_order_mark_is_read() {
    // (Windows editors save UTF-8 so.)
    let dir = tempfile::tempdir().unwrap();
    let bom = |name: &str, text: &str| {
        let path = dir.path().join(name);
        std::fs::write(&path, [&b"\xef\xbb\xbf"[..], text.as_bytes()].concat()).unwrap();
        path.to_str().unwrap().to_string()
    };
    let case = bom("case.json", SANTOOR_CASE);
    let run = struck(&["strike", &case, "--out", &text(&dir.path().join("o")), "-q"]);
    assert!(run.status.success(), "a case: {}", stderr(&run));
    let preset = bom("p.json", r#"{"name": "Mine", "instrument": "santoor"}"#);
    let scale = bom("s.scl", "! s.scl\nfifths\n2\n3/2\n2/1\n");
    let mapping = bom("m.kbm", "0\n0\n127\n60\n69\n440.0\n0\n");
    let wav = text(&dir.path().join("x.wav"));
    let song = text(&midi("a4.mid"));
    let run = struck(&["render", &song, "--out", &wav, "--preset", &preset, "--scl", &scale, "--kbm", &mapping]);
    assert!(run.status.success(), "a preset, a scale, a mapping: {}", stderr(&run));
    assert!(stdout(&run).contains("santoor (scale \"fifths\""), "{}", stdout(&run));
}

#[test]
fn every_kind_of_file_is_read_up_to_the_size_the_readme_states() {
    // The README: MIDI files 16 MB, strike cases, presets and tuning files 1 MB.
    let dir = tempfile::tempdir().unwrap();
    let padded = |name: &str, text: &str, pad: &str, size: usize| {
        let path = dir.path().join(name);
        let mut bytes = text.as_bytes().to_vec();
        while bytes.len() + pad.len() <= size {
            bytes.extend_from_slice(pad.as_bytes());
        }
        bytes.resize(size, b' ');
        std::fs::write(&path, bytes).unwrap();
        path.to_str().unwrap().to_string()
    };
    const MB: usize = 1 << 20;
    let song = text(&midi("a4.mid"));
    let wav = text(&dir.path().join("x.wav"));
    let render = |extra: &[&str]| {
        let mut args = vec!["render", song.as_str(), "--out", wav.as_str(), "--tail-s", "0", "-q"];
        args.extend_from_slice(extra);
        struck(&args)
    };
    // At the size: read. A byte more: refused, naming the size.
    let preset = r#"{"name": "Mine"}"#;
    let run = render(&["--preset", &padded("p.json", preset, " ", MB)]);
    assert!(run.status.success(), "a 1 MB preset: {}", stderr(&run));
    refused(&render(&["--preset", &padded("p.json", preset, " ", MB + 1)]), "larger than the 1 MB");
    let scale = "! s.scl\nequal\n12\n100.\n200.\n300.\n400.\n500.\n600.\n700.\n800.\n900.\n1000.\n1100.\n2/1\n";
    let run = render(&["--scl", &padded("s.scl", scale, "! padding\n", MB)]);
    assert!(run.status.success(), "a 1 MB scale: {}", stderr(&run));
    refused(&render(&["--scl", &padded("s.scl", scale, "! padding\n", MB + 1)]), "larger than the 1 MB");
    let out = text(&dir.path().join("o"));
    let run = struck(&["strike", &padded("c.json", SANTOOR_CASE, " ", MB), "--out", &out, "-q"]);
    assert!(run.status.success(), "a 1 MB case: {}", stderr(&run));
    refused(&struck(&["strike", &padded("c.json", SANTOOR_CASE, " ", MB + 1), "--out", &out]), "larger than the 1 MB");
    let big_song = padded("s.mid", "", " ", 16 * MB + 1);
    refused(&struck(&["render", &big_song, "--out", &wav]), "larger than the 16 MB");
    let at_size = padded("s.mid", "", " ", 16 * MB);
    let said = stderr(&struck(&["render", &at_size, "--out", &wav]));
    assert!(!said.contains("larger than"), "a 16 MB song is read (and refused for what it holds): {said}");
}

#[test]
fn an_output_that_cannot_be_written_is_refused_before_the_instrument_or_the_run() {
    use struck_tests::midi_gen::{TrackBuilder, at_120, key, metrical, smf_bytes};
    let dir = tempfile::tempdir().unwrap();
    let folder = dir.path().join("a folder");
    std::fs::create_dir(&folder).unwrap();
    let file = dir.path().join("a file");
    std::fs::write(&file, "mine").unwrap();
    // A song the santoor plays but in part: "1 of 2 notes are outside the
    // santoor's keys" is said once the instrument is built. The refusal comes
    // before it, alone.
    let mut track = TrackBuilder::new();
    track.tempo(0, 120.0).note(0, at_120(0.5), key("A0"), 90).note(0, at_120(0.5), key("A4"), 90);
    let song = dir.path().join("song.mid");
    std::fs::write(&song, smf_bytes(midly::Format::SingleTrack, metrical(), &[track])).unwrap();
    let run = struck(&["render", &text(&song), "--out", &text(&dir.path().join("x.wav")), "--instrument", "santoor"]);
    assert!(run.status.success() && stderr(&run).contains("outside the santoor's keys"), "{}", stderr(&run));
    for out in [text(&folder), text(&file.join("x.wav"))] {
        refused(&struck(&["render", &text(&song), "--out", &out, "--instrument", "santoor"]), "nothing is written");
    }
    // A strike whose run ends refused (the hammer rebounds faster than it
    // came): an output that cannot be written is refused before the run.
    let case = santoor_case(dir.path());
    let stiff = ["--set", "exciter.stiffness=1e22"];
    let out = text(&dir.path().join("o"));
    let run = struck(&["strike", &text(&case), "--out", &out, stiff[0], stiff[1]]);
    refused(&run, "exciter.stiffness: the hammer rebounds");
    refused(
        &struck(&["strike", &text(&case), "--out", &out, "--wav", &text(&folder), stiff[0], stiff[1]]),
        "is a directory",
    );
    refused(&struck(&["strike", &text(&case), "--out", &text(&file), stiff[0], stiff[1]]), "is not a folder");
    assert_eq!(std::fs::read_to_string(&file).unwrap(), "mine");
    assert!(std::fs::read_dir(&folder).unwrap().next().is_none());
}

#[test]
fn a_scales_description_is_printed_with_its_escapes_shown() {
    let dir = tempfile::tempdir().unwrap();
    let scale = dir.path().join("s.scl");
    let degrees = "100.\n200.\n300.\n400.\n500.\n600.\n700.\n800.\n900.\n1000.\n1100.\n2/1\n";
    std::fs::write(&scale, format!("! s.scl\nevil \u{1b}[31mred\n12\n{degrees}")).unwrap();
    let wav = text(&dir.path().join("x.wav"));
    let run = struck(&["render", &text(&midi("a4.mid")), "--out", &wav, "--scl", &text(&scale), "--tail-s", "0"]);
    assert!(run.status.success(), "{}", stderr(&run));
    let said = stdout(&run);
    assert!(!said.contains('\u{1b}') && said.contains("scale \"evil \\u{1b}[31mred\""), "{said:?}");
}

#[test]
fn a_limit_on_threads_leaves_the_work_on_one_with_the_same_samples() {
    use std::os::unix::fs::PermissionsExt;
    // RLIMIT_NPROC counts every process and thread of the user: at 1, no
    // thread can be started. (It does not hold root back: as root the run
    // is another user's, who has none running.) Two songs, which would
    // render a core each, play one after the other instead.
    let dir = tempfile::tempdir().unwrap();
    let open = |path: &Path, mode: u32| std::fs::set_permissions(path, std::fs::Permissions::from_mode(mode)).unwrap();
    open(dir.path(), 0o777);
    let binary = dir.path().join("struck");
    std::fs::copy(struck_tests::struck_binary(), &binary).unwrap();
    open(&binary, 0o755);
    let songs = [dir.path().join("one.mid"), dir.path().join("two.mid")];
    for (song, source) in songs.iter().zip(["a4.mid", "a0.mid"]) {
        std::fs::copy(midi(source), song).unwrap();
        open(song, 0o644);
    }
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let root = status.lines().any(|l| l.starts_with("Uid:") && l.split_whitespace().nth(1) == Some("0"));
    let mut command = std::process::Command::new(if root { "setpriv" } else { "prlimit" });
    if root {
        command.args(["--reuid=65534", "--regid=65534", "--clear-groups", "prlimit"]);
    }
    let limited = dir.path().join("limited");
    let run = command
        .args(["--nproc=1"])
        .arg(&binary)
        .args(["render", &text(&songs[0]), &text(&songs[1]), "--out", &text(&limited)])
        .output()
        .unwrap();
    let said = stderr(&run);
    assert_eq!(run.status.code(), Some(0), "{said}");
    assert!(said.contains("one song at a time") && !said.contains("panicked"), "{said}");
    for (song, name) in songs.iter().zip(["one", "two"]) {
        let free = dir.path().join(format!("free-{name}.wav"));
        let run = struck(&["render", &text(song), "--out", &text(&free), "-q"]);
        assert!(run.status.success(), "{}", stderr(&run));
        let together = std::fs::read(limited.join(format!("{name}.wav"))).unwrap();
        assert!(together == std::fs::read(&free).unwrap(), "{name}: the same samples");
    }
}
