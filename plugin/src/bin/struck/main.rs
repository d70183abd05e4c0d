//! `struck`: the standalone instrument when run with no subcommand (nice-plug's
//! host, reading its own options), else one of the lab's subcommands
//! (`strike`, `render`, `chart`, `animate`, `demo`, `bench`: `struck_lab::cli`).
//!
//! The binary lives in the plugin's package because the bundler takes the
//! standalone from there. Its own code sits apart in `src/bin/struck/`: the lab's
//! code and crates, and the standalone host's launcher, reach only this binary,
//! never the plugin library the CLAP and VST3 bundles are made of.

// Printing goes through `struck_lab::console`: println! panics when stdout
// is a closed pipe or a full disk.
#![warn(clippy::print_stdout, clippy::print_stderr)]

mod live;

use std::process::ExitCode;

fn main() -> ExitCode {
    if let Some(status) = live::run_unless_subcommand(&struck_lab::cli::command()) {
        return status;
    }
    struck_lab::cli::run()
}
