//! Reading a file the user named: a regular file only, and no more than a cap,
//! enforced while reading (a file's reported size can lie: a device reports 0).
//!
//! A FIFO, a device, a directory or a socket is refused before it is opened
//! (opening a FIFO with no writer would wait forever); the file is then opened
//! without blocking, in case it was swapped for one in between.

use std::fmt;
use std::fs;
use std::io::{self, Read};
use std::path::Path;

/// Why a file was not read.
#[derive(Debug)]
pub enum ReadError {
    /// It could not be opened or read.
    Io(io::Error),
    /// It is not a regular file: what it is.
    NotRegular(&'static str),
    /// It holds more than the cap, bytes.
    TooLarge(u64),
}

impl fmt::Display for ReadError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Io(e) => write!(f, "cannot read: {e}"),
            Self::NotRegular(what) => write!(f, "not a regular file ({what})"),
            Self::TooLarge(cap) => write!(f, "larger than the {} this file may hold", size_text(*cap)),
        }
    }
}

impl std::error::Error for ReadError {}

/// A size as people say it: 1 MB, 256 kB, 12 bytes.
pub fn size_text(bytes: u64) -> String {
    match bytes {
        b if b >= 1 << 20 && b % (1 << 20) == 0 => format!("{} MB", b >> 20),
        b if b >= 1 << 10 && b % (1 << 10) == 0 => format!("{} kB", b >> 10),
        b => format!("{b} bytes"),
    }
}

/// What kind of file a non-regular one is.
fn kind(file_type: fs::FileType) -> &'static str {
    #[cfg(unix)]
    {
        use std::os::unix::fs::FileTypeExt;
        if file_type.is_fifo() {
            return "a FIFO";
        }
        if file_type.is_char_device() || file_type.is_block_device() {
            return "a device";
        }
        if file_type.is_socket() {
            return "a socket";
        }
    }
    if file_type.is_dir() { "a directory" } else { "not a file" }
}

/// The bytes of the regular file at `path`, at most `cap` of them.
pub fn read_regular(path: &Path, cap: u64) -> Result<Vec<u8>, ReadError> {
    let meta = fs::metadata(path).map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(meta.file_type())));
    }
    let mut options = fs::OpenOptions::new();
    options.read(true);
    #[cfg(unix)]
    {
        use std::os::unix::fs::OpenOptionsExt;
        options.custom_flags(libc::O_NONBLOCK);
    }
    let file = options.open(path).map_err(ReadError::Io)?;
    let meta = file.metadata().map_err(ReadError::Io)?;
    if !meta.is_file() {
        return Err(ReadError::NotRegular(kind(meta.file_type())));
    }
    let mut bytes = Vec::with_capacity(meta.len().min(cap) as usize);
    file.take(cap.saturating_add(1)).read_to_end(&mut bytes).map_err(ReadError::Io)?;
    if bytes.len() as u64 > cap {
        return Err(ReadError::TooLarge(cap));
    }
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_regular_file_is_read_whole_up_to_the_cap() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("a.txt");
        fs::write(&path, b"twelve bytes").unwrap();
        assert_eq!(read_regular(&path, 12).unwrap(), b"twelve bytes");
        let e = read_regular(&path, 11).unwrap_err();
        assert!(matches!(e, ReadError::TooLarge(11)), "{e}");
        assert_eq!(e.to_string(), "larger than the 11 bytes this file may hold");
    }

    #[cfg(unix)]
    #[test]
    fn devices_fifos_and_directories_are_refused_without_waiting() {
        let dir = tempfile::tempdir().unwrap();
        for (path, what) in
            [(Path::new("/dev/zero"), "a device"), (Path::new("/dev/urandom"), "a device"), (dir.path(), "a directory")]
        {
            let e = read_regular(path, 1 << 20).unwrap_err();
            assert_eq!(e.to_string(), format!("not a regular file ({what})"));
        }
        // A FIFO with no writer: refused at once, not waited on.
        let fifo = dir.path().join("pipe");
        let made = std::process::Command::new("mkfifo").arg(&fifo).status();
        if made.is_ok_and(|s| s.success()) {
            assert_eq!(read_regular(&fifo, 1 << 20).unwrap_err().to_string(), "not a regular file (a FIFO)");
        }
        assert!(matches!(read_regular(&dir.path().join("missing"), 10), Err(ReadError::Io(_))));
    }

    #[test]
    fn sizes_read_as_people_say_them() {
        assert_eq!(size_text(1 << 20), "1 MB");
        assert_eq!(size_text(256 << 10), "256 kB");
        assert_eq!(size_text(1000), "1000 bytes");
    }
}
