//! Whether the machine has room for what a command is about to do: memory
//! for what it holds, disk for what it writes. Measured, not assumed; when a
//! figure cannot be read, the work goes ahead.

use std::path::Path;

use struck_engine::input::size_text;

use super::failure::{Failure, shown};

/// Memory the system could give this process now, bytes (Linux: MemAvailable).
pub fn available_memory() -> Option<u64> {
    let text = std::fs::read_to_string("/proc/meminfo").ok()?;
    let line = text.lines().find(|l| l.starts_with("MemAvailable:"))?;
    let kb: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kb * 1024)
}

/// Free space for an unprivileged writer on the file system that `path` (or
/// the nearest folder above it that exists) lies on, bytes.
pub fn free_disk(path: &Path) -> Option<u64> {
    let existing = path.ancestors().find(|p| !p.as_os_str().is_empty() && p.exists()).unwrap_or(Path::new("."));
    #[cfg(unix)]
    {
        use std::os::unix::ffi::OsStrExt;
        let name = std::ffi::CString::new(existing.as_os_str().as_bytes()).ok()?;
        // SAFETY: a valid NUL-terminated path and a zeroed struct for the result.
        unsafe {
            let mut stat: libc::statvfs = std::mem::zeroed();
            (libc::statvfs(name.as_ptr(), &mut stat) == 0).then(|| stat.f_bavail as u64 * stat.f_frsize as u64)
        }
    }
    #[cfg(not(unix))]
    {
        let _ = existing;
        None
    }
}

/// Refuse work that needs `memory` bytes held and `disk` bytes written under
/// `out`, naming `what` and the figures, if the machine has not the room
/// (memory: at most three quarters of what is available).
pub fn check(what: &str, memory: u64, disk: u64, out: &Path) -> Result<(), Failure> {
    if let Some(available) = available_memory()
        && memory > available / 4 * 3
    {
        return Err(Failure::bad_input(format!(
            "{what} would hold {} in memory; this machine has {} available",
            size_text_rounded(memory),
            size_text_rounded(available)
        )));
    }
    if let Some(free) = free_disk(out)
        && disk > free
    {
        return Err(Failure::bad_input(format!(
            "{what} would write {} under {}; its disk has {} free",
            size_text_rounded(disk),
            shown(out),
            size_text_rounded(free)
        )));
    }
    Ok(())
}

/// A size to two significant figures in kB, MB or GB.
pub fn size_text_rounded(bytes: u64) -> String {
    let b = bytes as f64;
    match bytes {
        0..1024 => size_text(bytes),
        1024..1_048_576 => format!("{:.0} kB", b / 1024.0),
        1_048_576..1_073_741_824 => format!("{:.0} MB", b / 1_048_576.0),
        _ => format!("{:.1} GB", b / 1_073_741_824.0),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_machine_reports_its_room_and_a_huge_job_is_refused() {
        assert!(available_memory().is_some_and(|m| m > 1 << 20));
        let dir = tempfile::tempdir().unwrap();
        assert!(free_disk(&dir.path().join("not/made/yet")).is_some_and(|d| d > 0));
        let e = check("the case", 1 << 62, 0, dir.path()).unwrap_err();
        assert!(e.message.starts_with("the case would hold 4294967296.0 GB in memory"), "{}", e.message);
        let e = check("the case", 0, 1 << 62, dir.path()).unwrap_err();
        assert!(e.message.contains("would write"), "{}", e.message);
        assert!(check("a small case", 1 << 20, 1 << 20, dir.path()).is_ok());
    }
}
