//! What the program says, on stdout and stderr, never stopping it.
//!
//! `println!` panics when stdout cannot be written (a closed pipe, a full
//! disk, `> /dev/full`): the command's work would end half-done with a
//! panic. Everything the commands print goes through here instead, a line at
//! a time. A line that cannot be written is dropped and the command goes on:
//! its files are still written in full and put in place. Afterwards
//! [`stdout_failure`] tells whether the report was lost:
//!
//! - stdout closed by its reader (`struck render ... | head -1`: a broken
//!   pipe) is not an error: the reader wanted no more, as with any Unix tool;
//!   the exit status is the work's own.
//! - any other failure to write stdout (a full disk) means the report the
//!   user asked for is lost: [`crate::cli::run`] says so on stderr and exits
//!   with status 1 (the files were written all the same).
//! - nothing written to stderr is ever checked: there is nowhere else to say
//!   that it failed.
//!
//! Rust ignores SIGPIPE, so a write to a closed pipe returns an error (EPIPE)
//! here rather than killing the process halfway through its work.

use std::fmt::Display;
use std::io::{self, Write};
use std::sync::Mutex;

/// What went wrong writing stdout, first failure only.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stdout {
    Open,
    /// Its reader went away (EPIPE).
    Closed,
    /// It failed otherwise (the error kept as text).
    Failed,
}

static STDOUT: Mutex<(Stdout, String)> = Mutex::new((Stdout::Open, String::new()));

fn state() -> std::sync::MutexGuard<'static, (Stdout, String)> {
    STDOUT.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Write `text` to stdout as it is (no newline added), flushed; a failure is
/// remembered and later writes are skipped.
pub fn out_text(text: &str) {
    let mut state = state();
    if state.0 != Stdout::Open {
        return;
    }
    let mut stdout = io::stdout().lock();
    if let Err(e) = stdout.write_all(text.as_bytes()).and_then(|()| stdout.flush()) {
        *state = if e.kind() == io::ErrorKind::BrokenPipe {
            (Stdout::Closed, String::new())
        } else {
            (Stdout::Failed, e.to_string())
        };
    }
}

/// Print one line on stdout (see the module's doc for a failure).
pub fn out(line: impl Display) {
    out_text(&format!("{line}\n"));
}

/// Print one line on stderr; a failure is ignored.
pub fn err(line: impl Display) {
    let mut stderr = io::stderr().lock();
    let _ = writeln!(stderr, "{line}").and_then(|()| stderr.flush());
}

/// Why stdout could not be written, if it failed for another reason than
/// its reader going away.
pub fn stdout_failure() -> Option<String> {
    let state = state();
    (state.0 == Stdout::Failed).then(|| state.1.clone())
}

/// Whether nothing more can be written to stdout (closed or failed).
pub fn stdout_gone() -> bool {
    state().0 != Stdout::Open
}
