//! Whether the machine has room for what a command is about to do: memory
//! for what it holds, disk for what it writes, and the limits the process
//! runs under (`ulimit -v`, `ulimit -d`, `ulimit -f`, its cgroup's memory
//! limit). Measured, not assumed; when a figure cannot be read, the work goes
//! ahead.

use std::path::{Path, PathBuf};

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

/// A resource getrlimit takes (its type differs between C libraries).
#[cfg(all(target_os = "linux", target_env = "gnu"))]
type Resource = libc::__rlimit_resource_t;
#[cfg(all(unix, not(all(target_os = "linux", target_env = "gnu"))))]
type Resource = libc::c_int;

/// The soft limit `resource` sets on this process, None when there is none.
#[cfg(unix)]
fn rlimit(resource: Resource) -> Option<u64> {
    // SAFETY: getrlimit fills the zeroed struct it is given.
    let mut limit: libc::rlimit = unsafe { std::mem::zeroed() };
    let read = unsafe { libc::getrlimit(resource, &mut limit) } == 0;
    (read && limit.rlim_cur != libc::RLIM_INFINITY).then_some(limit.rlim_cur as u64)
}

/// The largest file this process may write (`ulimit -f`), bytes; None when unlimited.
pub fn file_size_limit() -> Option<u64> {
    #[cfg(unix)]
    {
        rlimit(libc::RLIMIT_FSIZE)
    }
    #[cfg(not(unix))]
    {
        None
    }
}

/// Have a write past the file-size limit fail (EFBIG), to be reported and
/// cleaned up, instead of the signal (SIGXFSZ) killing the process with its
/// temporary files left behind.
pub fn ignore_file_size_signal() {
    #[cfg(unix)]
    // SAFETY: setting a signal's disposition to "ignore" touches no memory.
    unsafe {
        libc::signal(libc::SIGXFSZ, libc::SIG_IGN);
    }
}

/// What a command says when `path` reached the file-size limit (`ulimit -f`).
pub fn file_size_failure(path: &Path, limit: u64) -> Failure {
    Failure::bad_input(format!(
        "{}: the file-size limit (ulimit -f, {limit} bytes) is reached; nothing was written",
        shown(path)
    ))
}

/// Refuse, before the work, to write `bytes` to `path` past the file-size limit.
pub fn check_file_size(path: &Path, bytes: u64) -> Result<(), Failure> {
    match file_size_limit() {
        Some(limit) if bytes > limit => Err(Failure::bad_input(format!(
            "{}: would take {}, past the file-size limit (ulimit -f, {limit} bytes); nothing was written",
            shown(path),
            size_text_rounded(bytes)
        ))),
        _ => Ok(()),
    }
}

/// Whether writing `file` failed at the file-size limit: its length reached
/// the limit (the writer's own error may be wrapped beyond recognition).
pub fn at_file_size_limit(file: &Path) -> Option<u64> {
    let limit = file_size_limit()?;
    std::fs::metadata(file).ok().filter(|m| m.len() >= limit).map(|_| limit)
}

/// Whether an error, as the writer reported it (perhaps wrapped in its own
/// words), is a write refused past the file-size limit (EFBIG): the limit.
pub fn file_size_error(error: &str) -> Option<u64> {
    let limit = file_size_limit()?;
    #[cfg(unix)]
    let efbig = std::io::Error::from_raw_os_error(libc::EFBIG).to_string();
    #[cfg(not(unix))]
    let efbig = std::io::Error::from(std::io::ErrorKind::FileTooLarge).to_string();
    error.contains(&efbig).then_some(limit)
}

/// One limit on the memory this process may take.
#[derive(Clone, Debug, PartialEq)]
pub struct MemoryRoom {
    /// Bytes it leaves.
    pub left: u64,
    /// Whether it counts address space mapped (`ulimit -v`, `ulimit -d`)
    /// rather than memory used: a thread's allocator arena maps 64 MB as the
    /// thread first asks for memory, and may come after the check.
    pub counts_mapped: bool,
    /// What it is, as the refusal says it ("the memory limit (ulimit -v, 1.0 GB) leaves 900 MB").
    pub told: String,
}

/// Every limit on the memory this process may take, read now: `ulimit -v`
/// (RLIMIT_AS, less what the process already maps), `ulimit -d`
/// (RLIMIT_DATA, less its data), its cgroup's limit (v2 `memory.max`, v1
/// `memory.limit_in_bytes`, at every level, less what the group uses), and
/// the memory the system has available (of which three quarters are taken).
pub fn memory_rooms() -> Vec<MemoryRoom> {
    let mut rooms = Vec::new();
    let status = std::fs::read_to_string("/proc/self/status").unwrap_or_default();
    #[cfg(unix)]
    for (resource, flag, key, name) in
        [(libc::RLIMIT_AS, "-v", "VmSize:", "memory"), (libc::RLIMIT_DATA, "-d", "VmData:", "data")]
    {
        if let Some(limit) = rlimit(resource) {
            let used = status_bytes(&status, key).unwrap_or(0);
            rooms.push(MemoryRoom {
                left: limit.saturating_sub(used),
                counts_mapped: true,
                told: format!(
                    "the {name} limit (ulimit {flag}, {}) leaves {}",
                    size_text_rounded(limit),
                    size_text_rounded(limit.saturating_sub(used))
                ),
            });
        }
    }
    let cgroups = std::fs::read_to_string("/proc/self/cgroup").unwrap_or_default();
    let mounts = std::fs::read_to_string("/proc/self/mountinfo").unwrap_or_default();
    for (limit, used) in cgroup_limits(&cgroups, &mounts) {
        rooms.push(MemoryRoom {
            left: limit.saturating_sub(used),
            counts_mapped: false,
            told: format!(
                "the memory limit of its cgroup ({}) leaves {}",
                size_text_rounded(limit),
                size_text_rounded(limit.saturating_sub(used))
            ),
        });
    }
    if let Some(available) = available_memory() {
        rooms.push(MemoryRoom {
            left: available / 4 * 3,
            counts_mapped: false,
            told: format!("this machine has {} available", size_text_rounded(available)),
        });
    }
    rooms
}

/// A size in /proc/self/status ("VmSize:  123456 kB"), bytes.
fn status_bytes(status: &str, key: &str) -> Option<u64> {
    let line = status.lines().find(|l| l.starts_with(key))?;
    let kb: u64 = line[key.len()..].split_whitespace().next()?.parse().ok()?;
    Some(kb * 1024)
}

/// A cgroup hierarchy this process is in: where it is mounted, the folder of
/// the process's own group, and the names of its limit and usage files.
struct Hierarchy {
    mount: PathBuf,
    group: PathBuf,
    limit_file: &'static str,
    usage_file: &'static str,
}

/// The memory hierarchies of the process (v2, and v1's memory controller),
/// from /proc/self/cgroup and /proc/self/mountinfo.
fn hierarchies(cgroups: &str, mounts: &str) -> Vec<Hierarchy> {
    let mut found = Vec::new();
    for line in cgroups.lines() {
        let mut fields = line.splitn(3, ':');
        let (Some(id), Some(controllers), Some(path)) = (fields.next(), fields.next(), fields.next()) else {
            continue;
        };
        let v2 = id == "0" && controllers.is_empty();
        if !v2 && !controllers.split(',').any(|c| c == "memory") {
            continue;
        }
        // mountinfo: id parent major:minor root mount-point options ... - fstype source options
        for mount in mounts.lines() {
            let fields: Vec<&str> = mount.split_whitespace().collect();
            let Some(dash) = fields.iter().position(|f| *f == "-") else { continue };
            let (Some(root), Some(point), Some(fstype), Some(options)) =
                (fields.get(3), fields.get(4), fields.get(dash + 1), fields.get(dash + 3))
            else {
                continue;
            };
            let matches = if v2 {
                *fstype == "cgroup2"
            } else {
                *fstype == "cgroup" && options.split(',').any(|o| o == "memory")
            };
            if !matches {
                continue;
            }
            // The group's folder: its path below the mount's own root.
            let below = Path::new(path).strip_prefix(root).unwrap_or(Path::new(""));
            let below = below.strip_prefix("/").unwrap_or(below);
            let (limit_file, usage_file) =
                if v2 { ("memory.max", "memory.current") } else { ("memory.limit_in_bytes", "memory.usage_in_bytes") };
            found.push(Hierarchy {
                mount: PathBuf::from(point),
                group: Path::new(point).join(below),
                limit_file,
                usage_file,
            });
        }
    }
    found
}

/// Every memory limit set on the process's cgroups (its own and those above
/// it), with what each group uses: (limit, used), bytes.
fn cgroup_limits(cgroups: &str, mounts: &str) -> Vec<(u64, u64)> {
    let read =
        |dir: &Path, name: &str| -> Option<u64> { std::fs::read_to_string(dir.join(name)).ok()?.trim().parse().ok() };
    let mut limits = Vec::new();
    for h in hierarchies(cgroups, mounts) {
        for dir in h.group.ancestors().take_while(|d| d.starts_with(&h.mount)) {
            // ("max", or v1's huge number for none: no limit.)
            if let Some(limit) = read(dir, h.limit_file).filter(|&l| l < 1 << 60) {
                limits.push((limit, read(dir, h.usage_file).unwrap_or(0)));
            }
        }
    }
    limits
}

/// Address space a thread's allocator arena maps (glibc, 64-bit).
const ARENA_BYTES: u64 = 64 << 20;

/// The first memory limit that leaves less than `memory` bytes, if any.
/// (A strike maps about as much address space as it uses at its peak beyond
/// what the process maps already, less one arena: measured under `ulimit -v`,
/// 78 bytes a sample against its estimate's 88.)
pub fn short_of_memory(memory: u64) -> Option<MemoryRoom> {
    memory_rooms().into_iter().find(|room| {
        let need = if room.counts_mapped { memory.saturating_add(ARENA_BYTES) } else { memory };
        need > room.left
    })
}

/// The tightest memory limit, as a refusal says it (for an allocation that failed).
pub fn tightest_memory_limit() -> Option<String> {
    memory_rooms().into_iter().min_by_key(|r| r.left).map(|r| r.told)
}

/// Refuse work that needs `memory` bytes held and `disk` bytes written under
/// `out`, naming `what` and the figures, if the machine or the limits the
/// process runs under have not the room (see [`memory_rooms`]).
pub fn check(what: &str, memory: u64, disk: u64, out: &Path) -> Result<(), Failure> {
    if let Some(room) = short_of_memory(memory) {
        return Err(Failure::bad_input(format!(
            "{what} would hold {} in memory; {}; nothing was written",
            size_text_rounded(memory),
            room.told
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

    #[test]
    fn the_process_status_gives_its_sizes_in_bytes() {
        let status = "Name:\tstruck\nVmPeak:\t  200000 kB\nVmSize:\t  123456 kB\nVmData:\t    4096 kB\n";
        assert_eq!(status_bytes(status, "VmSize:"), Some(123_456 * 1024));
        assert_eq!(status_bytes(status, "VmData:"), Some(4096 * 1024));
        assert_eq!(status_bytes(status, "VmSwap:"), None);
        // This process's own.
        let own = std::fs::read_to_string("/proc/self/status").unwrap();
        assert!(status_bytes(&own, "VmSize:").is_some_and(|b| b > 1 << 20));
    }

    /// A cgroup file system laid out in `root`: (group folder, limit file, usage file) to write.
    fn lay_out(root: &Path, files: &[(&str, &str, &str)]) {
        for (path, name, text) in files {
            let dir = root.join(path);
            std::fs::create_dir_all(&dir).unwrap();
            std::fs::write(dir.join(name), text).unwrap();
        }
    }

    #[test]
    fn a_cgroup_v2_limit_is_read_at_every_level_of_the_process_group() {
        let fs = tempfile::tempdir().unwrap();
        let mount = fs.path().join("unified");
        lay_out(
            &mount,
            &[
                ("user.slice/session.scope", "memory.max", "max\n"),
                ("user.slice/session.scope", "memory.current", "1000\n"),
                ("user.slice", "memory.max", "1073741824\n"),
                ("user.slice", "memory.current", "104857600\n"),
            ],
        );
        let cgroups = "12:pids:/user.slice\n0::/user.slice/session.scope\n";
        let mounts = format!(
            "25 1 0:22 / /proc rw - proc proc rw\n41 31 0:38 / {} rw,relatime shared:9 - cgroup2 cgroup2 rw,nsdelegate\n",
            mount.display()
        );
        // "max" is no limit; the slice above holds the process to 1 GB, 100 MB of it used.
        assert_eq!(cgroup_limits(cgroups, &mounts), [(1 << 30, 100 << 20)]);
        // In a cgroup namespace the group is the mount's root.
        let mounts = format!("41 31 0:38 /user.slice {} rw - cgroup2 cgroup2 rw\n", mount.join("user.slice").display());
        assert_eq!(cgroup_limits("0::/user.slice\n", &mounts), [(1 << 30, 100 << 20)]);
        assert!(cgroup_limits("0::/\n", "").is_empty(), "no mount, no limit");
    }

    #[test]
    fn a_cgroup_v1_memory_limit_is_read_and_the_unlimited_one_ignored() {
        let fs = tempfile::tempdir().unwrap();
        let mount = fs.path().join("memory");
        lay_out(
            &mount,
            &[
                ("box/job", "memory.limit_in_bytes", "536870912\n"),
                ("box/job", "memory.usage_in_bytes", "52428800\n"),
                ("box", "memory.limit_in_bytes", "9223372036854771712\n"),
            ],
        );
        let cgroups = "7:cpu,cpuacct:/box/job\n4:memory:/box/job\n1:name=systemd:/\n";
        let mounts = format!(
            "32 31 0:29 / /sys/fs/cgroup/cpu rw - cgroup cgroup rw,cpu,cpuacct\n35 31 0:32 / {} rw,relatime - cgroup cgroup rw,memory\n",
            mount.display()
        );
        assert_eq!(cgroup_limits(cgroups, &mounts), [(512 << 20, 50 << 20)]);
    }
}
