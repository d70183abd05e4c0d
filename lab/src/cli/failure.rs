//! How a subcommand fails: a one-line message and the exit status it deserves.

/// Exit status for input that Struck refuses (a malformed case, a bad argument).
pub const EXIT_BAD_INPUT: u8 = 2;
/// Exit status when the work could not be done (e.g. the output cannot be written).
pub const EXIT_FAILURE: u8 = 1;

/// A failure with the exit status it deserves; printed as one line.
#[derive(Debug)]
pub struct Failure {
    pub status: u8,
    pub message: String,
}

impl Failure {
    pub fn bad_input(message: impl Into<String>) -> Self {
        Self { status: EXIT_BAD_INPUT, message: message.into() }
    }

    pub fn failed(message: impl Into<String>) -> Self {
        Self { status: EXIT_FAILURE, message: message.into() }
    }
}
