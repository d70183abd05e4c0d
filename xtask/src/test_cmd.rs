//! `cargo xtask test`: every test, as a list of named steps run in order.
//!
//! The plugin's heavy dependency tree is built in one profile only: the bundle,
//! the Rust tests and the `struck` binary the tests build (tests/src/lib.rs
//! builds it in the tests' own profile) all share it. By default that is the
//! dev profile, whose debug assertions and overflow checks stay on (and with
//! them nice-plug's `assert_process_allocs`) while Cargo.toml optimises it;
//! `--release` runs the same steps on the release build that ships.
//!
//! Within that profile, `cargo test --workspace` resolves features with the
//! dev-dependencies (criterion, clack-host), which turns on a few more features
//! of zerocopy, serde and syn than `cargo build -p struck` (the bundle, and the
//! tests' own build of `struck`); the crates above them (egui, nice-plug, the
//! plugin) are then compiled once for each set.
//!
//! To add a check, write a function returning `Result<()>` and add a
//! `Step::new(name, what, ...)` line to `steps()`: the header, the stop at the
//! first failure and the summary come with it.

use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

use crate::bundle::{self, profile_args};
use crate::footprint;
use crate::packages;
use crate::steps::{self, Selection, Step};
use crate::util::{cargo, relative, run, target_dir, workspace_root};

/// What the Python checks import, pinned, in one venv: pedalboard (a VST3 host),
/// JACK-Client (a JACK client playing the standalone like a MIDI keyboard) and numpy
/// (mido is not needed: MIDI goes in as bytes).
pub const PYTHON_REQUIREMENTS: &[&str] =
    &["pedalboard==0.9.26", "numpy==2.4.6", "JACK-Client==0.5.7", "cffi==2.1.1", "pycparser==3.12"];
/// The script that loads the VST3 in pedalboard.
pub const PEDALBOARD_SCRIPT: &str = "tests/python/pedalboard_check.py";
/// The script that plays the standalone over JACK (dummy driver) and records it.
pub const JACK_SCRIPT: &str = "tests/python/jack_session.py";
/// The script that plays the standalone live for a minute at small JACK periods and
/// times its callbacks.
pub const JACK_LIVE_SCRIPT: &str = "tests/python/jack_live.py";
/// The script that drives Ardour 7 headless with the VST3, for every instrument.
pub const ARDOUR_SCRIPT: &str = "tests/ardour/roundtrip.sh";

/// The script that opens the panel under Xvfb and checks a screenshot of it.
pub const PANEL_SCRIPT: &str = "tests/python/editor_screenshot.sh";

/// How `cargo xtask test` was asked to run.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TestOptions {
    pub release: bool,
    pub install: bool,
    pub selection: Selection,
    pub list: bool,
}

/// The steps of `cargo xtask test`, in order.
pub fn steps(options: &TestOptions) -> Vec<Step<'_>> {
    let release = options.release;
    let profile = if release { "release" } else { "dev" };
    vec![
        Step::new("packages", "the system packages the build and the checks need", move || {
            let needs: Vec<packages::Need> = packages::BUILD.iter().chain(packages::TEST).copied().collect();
            packages::ensure(&needs, options.install)
        }),
        Step::new(
            "lint",
            "cargo clippy --workspace --all-targets -D warnings (the real-time rooms deny unwrap, expect and panic)",
            lint,
        ),
        Step::new(
            "bundle",
            format!("cargo xtask bundle struck{} (the CLAP, VST3 and standalone in target/bundled)", flag(release)),
            move || bundle::bundle(release, true),
        ),
        Step::new(
            "footprint",
            if release {
                "each bundle is under 15 MB (the release build is stripped: the lab's crates are checked on the dev build)"
            } else {
                "the plugins link none of the lab's crates (sizes are checked on a release build and by the demo)"
            },
            move || footprint::check(release),
        ),
        Step::new(
            "cargo-test",
            format!("cargo test --workspace --no-fail-fast{} (the Rust tests, {profile} profile)", flag(release)),
            move || cargo_test(release),
        ),
        Step::new(
            "pedalboard",
            "load the VST3 in pedalboard, render notes, check the sound and the parameters, load damaged states",
            pedalboard,
        ),
        Step::new("panel", "open the standalone's panel under Xvfb and check a screenshot of it", move || {
            panel(release)
        }),
        Step::new(
            "jack-session",
            "play the standalone over JACK (dummy driver) from another client: pitch, dampers, pedal",
            move || jack_session(release),
        ),
        Step::new(
            "ardour",
            "every instrument in Ardour 7 (headless): a session saved, reopened and rendered again, the same bytes",
            ardour,
        ),
        Step::new(
            "jack-live",
            format!(
                "play a dense fortissimo piece live over JACK for 60 s at 48 kHz/64 and 96 kHz/128, load \
                 smoothing on and off ({profile} build): no xrun, every callback under half its period"
            ),
            move || jack_live(release),
        ),
    ]
}

/// `cargo test --workspace`. The bundle was just made, so the tests that load
/// it must find it (STRUCK_REQUIRE_BUNDLE turns their "skipped" into a failure).
fn cargo_test(release: bool) -> Result<()> {
    run(Command::new(cargo())
        .args(["test", "--workspace", "--no-fail-fast"])
        .args(profile_args(release))
        .env("STRUCK_REQUIRE_BUNDLE", "1"))
}

/// Clippy over everything, warnings as errors.
fn lint() -> Result<()> {
    run(Command::new(cargo()).args(["clippy", "--workspace", "--all-targets", "--", "-D", "warnings"]))
}

fn flag(release: bool) -> &'static str {
    if release { " --release" } else { "" }
}

pub fn test(options: &TestOptions) -> Result<()> {
    let steps = steps(options);
    let names: Vec<&str> = steps.iter().map(|s| s.name).collect();
    if options.list {
        for step in &steps {
            println!("{:<12} {}", step.name, step.what);
        }
        return Ok(());
    }
    let chosen = options.selection.choose(&names)?;
    let outcomes = steps::run("test", &steps, &chosen);
    println!("{}", steps::summary("test", &names, &outcomes));
    if !steps::all_passed(&outcomes) {
        bail!("cargo xtask test failed");
    }
    Ok(())
}

/// The virtual environment's Python, created with pedalboard in it if needed
/// (a stamp file remembers which requirements were installed).
fn checks_python(venv: &Path) -> Result<PathBuf> {
    let python = venv.join("bin").join("python");
    if !python.exists() {
        run(Command::new("python3").arg("-m").arg("venv").arg(venv)).context("could not create the venv")?;
    }
    let stamp = venv.join("struck-requirements.txt");
    let wanted = PYTHON_REQUIREMENTS.join("\n") + "\n";
    if std::fs::read_to_string(&stamp).ok().as_deref() != Some(wanted.as_str()) {
        run(Command::new(&python)
            .args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "--no-input"])
            .args(PYTHON_REQUIREMENTS))
        .context("could not install the Python checks' packages")?;
        std::fs::write(&stamp, wanted)?;
    }
    Ok(python)
}

fn pedalboard() -> Result<()> {
    let venv = target_dir()?.join("pedalboard-venv");
    let python = checks_python(&venv)?;
    let (vst3, _) = bundle::vst3_paths()?;
    if !vst3.exists() {
        bail!("{} is not there: run the bundle step first", relative(&vst3).display());
    }
    let script = relative(&workspace_root().join(PEDALBOARD_SCRIPT));
    let wav = target_dir()?.join("pedalboard.wav");
    run(Command::new(&python).arg(&script).arg("--self-test").env("PYTHONDONTWRITEBYTECODE", "1"))?;
    run(Command::new(&python)
        .arg(&script)
        .arg(relative(&vst3))
        .arg("--wav")
        .arg(relative(&wav))
        .env("PYTHONDONTWRITEBYTECODE", "1"))
}

fn panel(release: bool) -> Result<()> {
    let struck = bundle::struck_binary(release)?;
    let png = target_dir()?.join("editor.png");
    let attempt = || {
        run(Command::new("bash").arg(relative(&workspace_root().join(PANEL_SCRIPT))).arg(&struck).arg(relative(&png)))
    };
    // An X server can be slow to come up on a loaded machine: one more try before failing.
    attempt().or_else(|e| {
        println!("panel: {e:#}; trying once more");
        attempt()
    })
}

fn ardour() -> Result<()> {
    let (vst3, _) = bundle::vst3_paths()?;
    if !vst3.exists() {
        bail!("{} is not there: run the bundle step first", relative(&vst3).display());
    }
    let logs = target_dir()?.join("ardour-logs");
    run(Command::new("bash")
        .arg(relative(&workspace_root().join(ARDOUR_SCRIPT)))
        .arg(relative(&vst3))
        .arg(relative(&logs)))
}

fn jack_session(release: bool) -> Result<()> {
    let python = checks_python(&target_dir()?.join("pedalboard-venv"))?;
    let struck = bundle::struck_binary(release)?;
    let logs = target_dir()?.join("jack-session-logs");
    run(Command::new(&python)
        .arg(relative(&workspace_root().join(JACK_SCRIPT)))
        .arg(&struck)
        .arg("--keep-logs")
        .arg(relative(&logs))
        .env("PYTHONDONTWRITEBYTECODE", "1"))
}

/// Four runs of 60 s (about 4.5 minutes): the standalone's callbacks timed inside them.
fn jack_live(release: bool) -> Result<()> {
    let python = checks_python(&target_dir()?.join("pedalboard-venv"))?;
    let struck = bundle::struck_binary(release)?;
    let logs = target_dir()?.join("jack-live-logs");
    run(Command::new(&python)
        .arg(relative(&workspace_root().join(JACK_LIVE_SCRIPT)))
        .arg(&struck)
        .arg("--keep-logs")
        .arg(relative(&logs))
        .env("PYTHONDONTWRITEBYTECODE", "1"))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_steps_build_before_they_test() {
        let options = TestOptions::default();
        let names: Vec<&str> = steps(&options).iter().map(|s| s.name).collect();
        assert_eq!(
            names,
            [
                "packages",
                "lint",
                "bundle",
                "footprint",
                "cargo-test",
                "pedalboard",
                "panel",
                "jack-session",
                "ardour",
                "jack-live"
            ]
        );
    }

    #[test]
    fn step_names_are_unique_and_plain() {
        let options = TestOptions::default();
        let names: Vec<&str> = steps(&options).iter().map(|s| s.name).collect();
        for (i, name) in names.iter().enumerate() {
            assert!(!names[..i].contains(name), "{name} twice");
            assert!(name.chars().all(|c| c.is_ascii_lowercase() || c == '-'), "{name}");
        }
    }

    #[test]
    fn one_profile_for_the_bundle_and_the_tests() {
        let dev: Vec<String> = steps(&TestOptions::default()).iter().map(|s| s.what.clone()).collect();
        assert!(dev.iter().all(|w| !w.contains("--release")), "{dev:?}");
        let release = TestOptions { release: true, ..TestOptions::default() };
        let release = steps(&release);
        let what = |name: &str| release.iter().find(|s| s.name == name).map(|s| s.what.clone()).unwrap_or_default();
        assert!(what("bundle").contains("bundle struck --release"), "{}", what("bundle"));
        assert!(what("cargo-test").contains("--no-fail-fast --release"), "{}", what("cargo-test"));
        assert!(what("footprint").contains("15 MB"), "{}", what("footprint"));
    }

    #[test]
    fn the_pedalboard_requirements_are_pinned_and_the_script_is_there() {
        assert!(PYTHON_REQUIREMENTS.iter().all(|r| r.contains("==")));
        assert!(workspace_root().join(PEDALBOARD_SCRIPT).is_file());
    }
}
