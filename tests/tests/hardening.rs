//! What the command line does with input it must not trust and outputs it must
//! not spoil (the hardening issue): every refusal is one line with exit status
//! 2, nothing the user gave is overwritten, nothing is left half-written.

use std::path::{Path, PathBuf};
use std::process::Output;
use std::time::{Duration, Instant};

use struck_tests::{SANTOOR_CASE, midi_gen, stderr, struck};

/// A test MIDI file.
fn midi(name: &str) -> PathBuf {
    midi_gen::test_dir().join(name)
}

fn text(path: &Path) -> String {
    path.to_str().unwrap().to_string()
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
    let case = dir.path().join("case.json");
    std::fs::write(&case, SANTOOR_CASE).unwrap();
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
    let case = dir.path().join("case.json");
    std::fs::write(&case, SANTOOR_CASE).unwrap();
    refused(&struck(&["render", &text(&midi("a4.mid")), "--out", "/dev/null"]), "is not a regular file");
    assert!(!Path::new("/dev/null").metadata().unwrap().file_type().is_file());
    let deep = dir.path().join("new").join("deeper");
    refused(&struck(&["strike", &text(&case), "--out", &text(&deep), "--wav", "/dev/null"]), "is not a regular file");
    assert!(!dir.path().join("new").exists(), "the folders made for it are gone");
    refused(&struck(&["strike", &text(&case), "--out", &text(dir.path()), "--wav", &text(dir.path())]), "is a directory");
    refused(&struck(&["strike", &text(&case), "--out", "/dev/null"]), "/dev/null: is not a folder");
    refused(&struck(&["strike", &text(&case), "--out", &text(&case)]), "is not a folder");
    assert_eq!(std::fs::read_to_string(&case).unwrap(), SANTOOR_CASE);
}

#[test]
fn physics_out_of_range_is_refused_naming_the_field() {
    let dir = tempfile::tempdir().unwrap();
    let case = dir.path().join("case.json");
    std::fs::write(&case, SANTOOR_CASE).unwrap();
    let out = text(&dir.path().join("o"));
    refused(&struck(&["strike", &text(&case), "--out", &out, "--set", "exciter.stiffness=1e22"]), "exciter.stiffness");
    refused(&struck(&["strike", &text(&case), "--out", &out, "--wav", "w.wav", "--wav-gain-db", "800"]), "--wav-gain-db");
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
    let case = dir.path().join("case.json");
    std::fs::write(&case, SANTOOR_CASE).unwrap();
    let out = dir.path().join("out").join("deeper");
    let child = std::process::Command::new(struck_tests::struck_binary())
        .args(["strike", &text(&case), "--out", &text(&out), "--set", "duration_s=60", "--set", "sample_rate_hz=384000"])
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
    let case = dir.path().join("case.json");
    std::fs::write(&case, SANTOOR_CASE).unwrap();
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
