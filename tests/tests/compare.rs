//! `struck compare` refuses bad arguments before it fetches, renders or
//! writes anything: exit status 2, one line naming the argument, no cache
//! made, no file written. (The comparison itself needs the recordings from
//! the network; its measurements are tested on synthetic signals in the lab.)

use std::path::Path;

use struck_tests::{stderr, stdout, struck};

/// Run `struck compare` with `extra` and a cache and JSON output in a fresh
/// folder; it must be refused naming `named`, leaving the folder as it was.
fn refused(extra: &[&str], named: &str) {
    let dir = tempfile::tempdir().unwrap();
    std::fs::write(dir.path().join("file"), b"a file, not a folder").unwrap();
    let cache = dir.path().join("cache");
    let json = dir.path().join("out.json");
    let mut args = vec!["compare", "--cache", cache.to_str().unwrap(), "--json", json.to_str().unwrap()];
    args.extend_from_slice(extra);
    let out = struck(&args);
    let message = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{extra:?}: {message}");
    assert_eq!(message.lines().count(), 1, "one line: {message:?}");
    assert!(message.starts_with("struck compare: ") || message.starts_with("struck: "), "{message:?}");
    assert!(message.contains(named), "{message:?} should name {named}");
    assert!(stdout(&out).is_empty());
    let left: Vec<String> =
        std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(left, ["file"], "{extra:?} left {left:?}");
}

#[test]
fn an_unknown_layer_is_refused() {
    refused(&["--layers", "4,17"], "--layers");
    refused(&["--layers", "0"], "--layers");
    refused(&["--layers", "soft"], "--layers");
}

#[test]
fn a_bad_note_name_is_refused() {
    refused(&["--notes", "C4,H9"], "--notes");
    refused(&["--notes", "C4,"], "--notes");
}

#[test]
fn a_note_that_was_not_recorded_is_refused() {
    refused(&["--notes", "C#4"], "not recorded");
}

#[test]
fn a_preset_that_cannot_be_read_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let missing = dir.path().join("no-such-preset.json");
    refused(&["--preset", missing.to_str().unwrap()], "no-such-preset.json");
    let broken = dir.path().join("broken-preset.json");
    std::fs::write(&broken, br#"{"name": "Broken", "voicing": {"hammer_stiffness": "hard"}}"#).unwrap();
    refused(&["--preset", broken.to_str().unwrap()], "broken-preset.json");
}

#[test]
fn a_bad_reference_or_instrument_is_refused() {
    refused(&["--reference", "steinway"], "--reference");
    refused(&["--reference", "fluid:128"], "--reference");
    refused(&["--reference", "fluid:"], "--reference");
    refused(&["--instrument", "banjo"], "--instrument");
    // A recorded note the instrument does not have.
    refused(&["--instrument", "harpsichord", "--notes", "A0,C4"], "outside the harpsichord's keys");
}

#[test]
fn a_doc_without_its_table_or_for_another_run_is_refused() {
    let dir = tempfile::tempdir().unwrap();
    let doc = dir.path().join("validation.md");
    std::fs::write(&doc, "# How it is checked\n\nNo table here.\n").unwrap();
    let path = doc.to_str().unwrap();
    refused(&["--doc", path], "has no line `<!-- table: real grand -->`");
    refused(&["--doc", path, "--no-yardsticks"], "--doc");
    refused(&["--doc", path, "--instrument", "harpsichord"], "--doc");
    refused(&["--doc", dir.path().join("missing.md").to_str().unwrap()], "missing.md");
    // Nothing written over it.
    assert_eq!(std::fs::read_to_string(&doc).unwrap(), "# How it is checked\n\nNo table here.\n");
}

/// Against FluidR3's recorded dulcimer (General MIDI program 15), one note in
/// one layer: the table is headed by the reference and Struck's dulcimer has
/// a figure on every feature one note can give.
#[test]
fn struck_is_measured_against_a_fluidr3_program() {
    if !Path::new("/usr/share/sounds/sf2/FluidR3_GM.sf2").is_file() {
        // The test step installs it (Debian's fluid-soundfont-gm); a bare
        // `cargo test` may run without.
        eprintln!("skipped: no FluidR3_GM");
        return;
    }
    let dir = tempfile::tempdir().unwrap();
    let json = dir.path().join("out.json");
    let out = struck(&[
        "compare",
        "--reference",
        "fluid:15",
        "--instrument",
        "dulcimer",
        "--notes",
        "C4",
        "--layers",
        "12",
        "--quiet",
        "--json",
        json.to_str().unwrap(),
    ]);
    assert_eq!(out.status.code(), Some(0), "{}", stderr(&out));
    let table = stdout(&out);
    assert!(table.starts_with("error vs FluidR3 program 15"), "{table}");
    let value: serde_json::Value = serde_json::from_slice(&std::fs::read(&json).unwrap()).unwrap();
    assert_eq!(value["instrument"], "dulcimer");
    assert!(value["recordings"].as_str().unwrap().contains("program 15"), "{}", value["recordings"]);
    let inharmonicity = &value["summary"]["inharmonicity"]["struck"];
    assert_eq!(inharmonicity["n"], 1, "{inharmonicity}");
}

#[test]
fn bad_jobs_and_outputs_are_refused() {
    refused(&["--jobs", "0"], "--jobs");
    refused(&["--jobs", "-3"], "--jobs");
    refused(&["--output", "wood"], "--output");
}

#[test]
fn an_unwritable_output_is_refused_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("file");
    std::fs::write(&file, b"x").unwrap();
    let cache = dir.path().join("cache");
    for (flag, path) in [("--json", file.join("out.json")), ("--csv", file.join("out.csv"))] {
        let out = struck(&["compare", "--cache", cache.to_str().unwrap(), flag, path.to_str().unwrap()]);
        let message = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{message}");
        assert_eq!(message.lines().count(), 1, "{message:?}");
        assert!(message.contains("is not a folder"), "{message:?}");
        assert!(!cache.exists(), "nothing fetched");
    }
    assert_eq!(std::fs::read(&file).unwrap(), b"x");
    // A cache that is a file.
    let out = struck(&["compare", "--cache", file.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("--cache"), "{}", stderr(&out));
    assert!(Path::new(&file).is_file());
}

#[test]
fn the_help_names_the_recordings_and_the_yardsticks() {
    let help = stdout(&struck(&["compare", "--help"]));
    for expected in [
        "Salamander",
        "CC BY 3.0",
        "FluidR3",
        "Faust-STK",
        "--layers",
        "--notes",
        "--jobs",
        "--json",
        "--csv",
        "--reference",
    ] {
        assert!(help.contains(expected), "compare --help lacks {expected}: {help}");
    }
}
