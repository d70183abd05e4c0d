//! Every file a command reads goes through here: a regular file only, read up
//! to a cap (see [`struck_engine::input`]), refused with one line naming it.

use std::path::Path;

use struck_engine::input::read_regular;

use super::failure::{Failure, shown};

/// Most bytes of a MIDI file (a long piano piece is tens of kB).
pub const MAX_SONG_BYTES: u64 = 16 << 20;
/// Most bytes of a strike case (a page of JSON).
pub const MAX_CASE_BYTES: u64 = 1 << 20;

/// The bytes of the file at `path`, at most `cap`.
pub fn read(path: &Path, cap: u64) -> Result<Vec<u8>, Failure> {
    read_regular(path, cap).map_err(|e| Failure::bad_input(format!("{}: {e}", shown(path))))
}

/// The UTF-8 text of the file at `path`, at most `cap` bytes.
pub fn read_text(path: &Path, cap: u64) -> Result<String, Failure> {
    String::from_utf8(read(path, cap)?).map_err(|_| Failure::bad_input(format!("{}: not UTF-8 text", shown(path))))
}
