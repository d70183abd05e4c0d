//! Struck's project tasks: `cargo xtask demo`, `cargo xtask test`, `cargo
//! xtask docs` and `cargo xtask piano-scale`, with everything else (`cargo xtask bundle struck
//! --release`, ...) passed on to nice-plug-xtask.

mod bundle;
mod demo_cmd;
mod docs_cmd;
mod footprint;
mod packages;
mod piano_scale;
mod steps;
mod test_cmd;
mod util;

use std::process::ExitCode;

use anyhow::{Result, bail};

use crate::test_cmd::TestOptions;

const HELP: &str = "\
Struck's tasks

Usage:
  cargo xtask demo [--no-install]
      Build Struck in release and render the demo offline into demo/: the
      seed's lab with `struck demo` (Sounds 1-12, figures, animations and
      demo/index.html), every demo-songs/*.mid with `struck render` (the
      instrument is the file name's prefix, e.g. piano-*.mid), and the lab
      bench's santoor strike.
  cargo xtask test [--release] [--no-install] [--list]
                   [--only STEP,...] [--skip STEP,...] [--from STEP]
      Every test, as named steps in order: system packages, the plugin bundle,
      cargo test --workspace, the VST3 in pedalboard, the panel, the standalone
      over JACK, the VST3 in Ardour (--list names them). Stops at the first
      failure. --release runs them on the release build instead of the dev
      profile's (which keeps debug assertions on).
  cargo xtask docs
      Write docs/validation.md's generated tables from the tests that measure
      them (each such test runs with STRUCK_WRITE_DOCS=1; in a normal run it
      fails when the doc says otherwise).
  cargo xtask piano-scale
      Write the per-key scales of the piano, the fortepiano and the seed's
      Broadwood, engine/data/piano-scale.csv, fortepiano-scale.csv and
      broadwood-scale.csv, from the rules in xtask/src/piano_scale/.
  cargo xtask bundle struck [--release]
      nice-plug's bundler: target/bundled/Struck.clap, Struck.vst3 and the
      standalone. Any command not listed here goes to nice-plug-xtask.

Both demo and test first check the Debian packages they need and install the
missing ones with apt-get (through sudo when not root); --no-install only
checks them and fails with the list.";

/// Options common to `demo` and `test`.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Options {
    /// Install missing system packages (else only report them).
    pub install: bool,
}

/// What the command line asks for.
#[derive(Debug, Clone, PartialEq, Eq)]
enum Task {
    Help,
    Demo(Options),
    Test(TestOptions),
    Docs,
    PianoScale,
    /// Anything else, for nice-plug-xtask.
    NicePlug(Vec<String>),
}

fn list(value: &str) -> Vec<String> {
    value.split(',').map(str::trim).filter(|s| !s.is_empty()).map(str::to_string).collect()
}

fn parse(args: &[String]) -> Result<Task> {
    let Some((command, rest)) = args.split_first() else { return Ok(Task::Help) };
    match command.as_str() {
        "help" | "-h" | "--help" => Ok(Task::Help),
        "demo" => {
            let mut options = Options { install: true };
            for arg in rest {
                match arg.as_str() {
                    "--no-install" => options.install = false,
                    "-h" | "--help" => return Ok(Task::Help),
                    other => bail!("cargo xtask demo: unknown argument '{other}'\n\n{HELP}"),
                }
            }
            Ok(Task::Demo(options))
        }
        "test" => {
            let mut options = TestOptions { install: true, ..TestOptions::default() };
            let mut rest = rest.iter();
            while let Some(arg) = rest.next() {
                let (flag, inline) = match arg.split_once('=') {
                    Some((flag, value)) if flag.starts_with("--") => (flag, Some(value.to_string())),
                    _ => (arg.as_str(), None),
                };
                let mut value = || -> Result<String> {
                    match inline.clone().or_else(|| rest.next().cloned()) {
                        Some(v) => Ok(v),
                        None => bail!("cargo xtask test: {flag} needs a step name"),
                    }
                };
                match flag {
                    "--release" => options.release = true,
                    "--no-install" => options.install = false,
                    "--list" => options.list = true,
                    "--only" => options.selection.only.extend(list(&value()?)),
                    "--skip" => options.selection.skip.extend(list(&value()?)),
                    "--from" => options.selection.from = Some(value()?),
                    "-h" | "--help" => return Ok(Task::Help),
                    other => bail!("cargo xtask test: unknown argument '{other}'\n\n{HELP}"),
                }
            }
            Ok(Task::Test(options))
        }
        "docs" => match rest.first().map(String::as_str) {
            None => Ok(Task::Docs),
            Some("-h" | "--help") => Ok(Task::Help),
            Some(other) => bail!("cargo xtask docs: unknown argument '{other}'\n\n{HELP}"),
        },
        "piano-scale" => match rest.first().map(String::as_str) {
            None => Ok(Task::PianoScale),
            Some("-h" | "--help") => Ok(Task::Help),
            Some(other) => bail!("cargo xtask piano-scale: unknown argument '{other}'\n\n{HELP}"),
        },
        _ => Ok(Task::NicePlug(args.to_vec())),
    }
}

fn main() -> ExitCode {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let result = parse(&args).and_then(|task| {
        // Everything below runs from the workspace root, as nice-plug-xtask does.
        std::env::set_current_dir(util::workspace_root())?;
        match task {
            Task::Help => {
                println!("{HELP}");
                Ok(())
            }
            Task::Demo(options) => demo_cmd::demo(&options),
            Task::Test(options) => test_cmd::test(&options),
            Task::Docs => docs_cmd::docs(),
            Task::PianoScale => piano_scale::run(),
            Task::NicePlug(args) => nice_plug_xtask::main_with_args("cargo xtask", args),
        }
    });
    match result {
        Ok(()) => ExitCode::SUCCESS,
        Err(error) => {
            eprintln!("error: {error:#}");
            ExitCode::FAILURE
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn args(s: &str) -> Vec<String> {
        s.split_whitespace().map(str::to_string).collect()
    }

    #[test]
    fn our_commands_are_ours_and_the_rest_goes_to_nice_plug() {
        assert_eq!(parse(&args("")).unwrap(), Task::Help);
        assert_eq!(parse(&args("demo")).unwrap(), Task::Demo(Options { install: true }));
        assert_eq!(parse(&args("demo --no-install")).unwrap(), Task::Demo(Options { install: false }));
        assert_eq!(parse(&args("bundle struck --release")).unwrap(), Task::NicePlug(args("bundle struck --release")));
        assert_eq!(parse(&args("known-packages")).unwrap(), Task::NicePlug(args("known-packages")));
        assert_eq!(parse(&args("piano-scale")).unwrap(), Task::PianoScale);
        assert_eq!(parse(&args("docs")).unwrap(), Task::Docs);
    }

    #[test]
    fn test_options_parse() {
        let Task::Test(o) = parse(&args("test")).unwrap() else { panic!() };
        assert_eq!(o, TestOptions { install: true, ..TestOptions::default() });
        let Task::Test(o) =
            parse(&args("test --release --no-install --only bundle,cargo-test --skip=pedalboard --from packages"))
                .unwrap()
        else {
            panic!()
        };
        assert!(o.release && !o.install && !o.list);
        assert_eq!(o.selection.only, ["bundle", "cargo-test"]);
        assert_eq!(o.selection.skip, ["pedalboard"]);
        assert_eq!(o.selection.from.as_deref(), Some("packages"));
    }

    #[test]
    fn bad_arguments_are_refused() {
        assert!(parse(&args("test --only")).is_err());
        assert!(parse(&args("test --bogus")).is_err());
        assert!(parse(&args("demo --release")).is_err());
        assert!(parse(&args("piano-scale --bogus")).is_err());
        assert!(parse(&args("docs --bogus")).is_err());
    }
}
