//! How a subcommand fails: a one-line message and the exit status it deserves.

use std::path::Path;

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

/// What a command stopped by a signal says (after its name).
pub use crate::cleanup::INTERRUPTED_MESSAGE as INTERRUPTED;

impl Failure {
    pub fn bad_input(message: impl Into<String>) -> Self {
        Self { status: EXIT_BAD_INPUT, message: message.into() }
    }

    pub fn failed(message: impl Into<String>) -> Self {
        Self { status: EXIT_FAILURE, message: message.into() }
    }

    /// A stop signal came (see [`crate::cleanup`]): nothing was written.
    pub fn interrupted() -> Self {
        Self { status: crate::cleanup::EXIT_INTERRUPTED, message: INTERRUPTED.into() }
    }

    /// The message as one printable line: control characters (a file's own
    /// escape sequences, line breaks) shown as escapes, never acted on.
    pub fn line(&self) -> String {
        printable(&self.message)
    }
}

pub use struck_engine::printable;

/// A path as a message shows it (printable, see [`printable`]).
pub fn shown(path: &Path) -> String {
    printable(&path.display().to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_message_is_one_line_with_its_escapes_shown() {
        let f = Failure::bad_input("song.mid: bad text \u{1b}[31mred\u{1b}[0m\nsecond line\r");
        assert_eq!(f.line(), "song.mid: bad text \\u{1b}[31mred\\u{1b}[0m\\nsecond line\\r");
        assert_eq!(shown(Path::new("a\u{7}b.mid")), "a\\u{7}b.mid");
    }
}
