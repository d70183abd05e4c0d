//! Writing results so that nothing is half-written and nothing the user gave
//! is lost: every file goes to a short temporary name beside its destination,
//! and only once all of them were written in full are they put in place
//! together; if one cannot be, those already placed are taken back and what
//! stood there before is restored. A destination may not be one of the
//! command's inputs (the same file, however named), nor named twice, nor
//! anything but a regular file (a device, a directory, a FIFO is never
//! replaced). A destination that is a symbolic link is written through: the
//! file it leads to is replaced, the link kept. Folders made for the outputs
//! are removed again if nothing was put in them. A destination the user's
//! path makes unwritable (no permission, a file where a folder should be, a
//! name too long, a read-only file system) is refused as bad input; what
//! goes wrong while writing (a full disk) is a failure.

use std::fs;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};

use super::failure::{Failure, shown};
use super::room;
use crate::cleanup;

/// The process that made a temporary named `name` (`.struck-PID-N.part`, a
/// file, or `.struck-PID.part`, a folder), if it is one.
fn temporary_owner(name: &str) -> Option<u32> {
    let middle = name.strip_prefix(".struck-")?.strip_suffix(".part")?;
    let (pid, n) = middle.split_once('-').unwrap_or((middle, "0"));
    if n.is_empty() || !n.bytes().all(|b| b.is_ascii_digit()) {
        return None;
    }
    pid.parse().ok()
}

/// Whether the process `pid` could still be a struck writing its temporaries:
/// it runs, and is a struck (its name or its program is ours). None when
/// that cannot be known (no /proc).
fn may_be_writing(pid: u32) -> Option<bool> {
    let proc = Path::new("/proc");
    if !proc.join("self").exists() {
        return None;
    }
    let dir = proc.join(pid.to_string());
    if !dir.exists() {
        return Some(false);
    }
    let named_struck = fs::read_to_string(dir.join("comm")).is_ok_and(|c| c.contains("struck"));
    let ours = match (fs::read_link(dir.join("exe")), fs::read_link(proc.join("self/exe"))) {
        (Ok(theirs), Ok(mine)) => theirs == mine,
        // (Another user's process: it may be.)
        (Err(_), _) => true,
        _ => false,
    };
    Some(named_struck || ours)
}

/// Remove, from the folder `dir`, the temporaries a struck that was killed
/// (SIGKILL, a crash, the power) left there: `.struck-PID-N.part` files and
/// `.struck-PID.part` folders whose process is gone. (What stood at an
/// output and was set aside while it was replaced, `.struck-PID-N.old`, is
/// the user's: never removed.)
fn sweep_stale(dir: &Path) {
    let Ok(entries) = fs::read_dir(dir) else { return };
    let me = std::process::id();
    for entry in entries.filter_map(Result::ok) {
        let name = entry.file_name();
        let Some(pid) = name.to_str().and_then(temporary_owner) else { continue };
        if pid == me || may_be_writing(pid) != Some(false) {
            continue;
        }
        let path = entry.path();
        match entry.file_type() {
            Ok(t) if t.is_dir() => {
                let _ = fs::remove_dir_all(&path);
            }
            Ok(t) if t.is_file() => {
                let _ = fs::remove_file(&path);
            }
            _ => {}
        }
    }
}

/// A mono WAV's format.
fn mono(sample_rate_hz: f64, bits_per_sample: u16, sample_format: hound::SampleFormat) -> hound::WavSpec {
    hound::WavSpec { channels: 1, sample_rate: sample_rate_hz.round() as u32, bits_per_sample, sample_format }
}

/// A file's identity on its file system (the same file under any name).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
struct FileId {
    device: u64,
    inode: u64,
}

fn identity(path: &Path) -> Option<FileId> {
    #[cfg(unix)]
    {
        use std::os::unix::fs::MetadataExt;
        fs::metadata(path).ok().map(|m| FileId { device: m.dev(), inode: m.ino() })
    }
    #[cfg(not(unix))]
    {
        let _ = path;
        None
    }
}

/// A file staged: its temporary, where it goes, and whether it was written.
struct Staging {
    temporary: PathBuf,
    destination: PathBuf,
    written: bool,
}

/// A file whose temporary is made ([`Staged::reserve`]) and waits to be written.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Slot(usize);

/// Files written to temporary names, waiting to be put in place together.
#[derive(Default)]
pub struct Staged {
    /// The files, in the order staged.
    files: Vec<Staging>,
    /// The command's inputs: how the user named them, and what they are.
    inputs: Vec<(PathBuf, FileId)>,
    /// Folders made for the outputs, outermost first.
    made: Vec<PathBuf>,
    committed: bool,
}

/// Refuse to write `path` if it is not a regular file, or is one of `inputs`.
fn check_destination(path: &Path, inputs: &[(PathBuf, FileId)]) -> Result<(), Failure> {
    let Ok(meta) = fs::metadata(path) else { return Ok(()) };
    if !meta.is_file() {
        let what = if meta.is_dir() { "a directory" } else { "not a regular file" };
        return Err(Failure::bad_input(format!("{}: is {what}; nothing is written over it", shown(path))));
    }
    if let Some(id) = identity(path)
        && let Some((input, _)) = inputs.iter().find(|(_, i)| *i == id)
    {
        return Err(Failure::bad_input(format!(
            "{}: is {}, one of the inputs; it would be overwritten",
            shown(path),
            shown(input)
        )));
    }
    Ok(())
}

/// The failure to write `path` for `error`: bad input when the path itself
/// is at fault (see the module's doc), a failure otherwise.
fn write_failure(verb: &str, path: &Path, error: &io::Error) -> Failure {
    use io::ErrorKind::*;
    let message = format!("cannot {verb} {}: {error}", shown(path));
    match error.kind() {
        PermissionDenied | NotADirectory | IsADirectory | InvalidFilename | ReadOnlyFilesystem | NotFound => {
            Failure::bad_input(message)
        }
        _ => Failure::failed(message),
    }
}

/// The failure to write `named` through its `temporary` for `error`: a write
/// past `ulimit -f` (which the writer may have wrapped; the file's length
/// tells) says so, any other as [`write_failure`] does.
pub fn staged_write_failure(named: &Path, temporary: &Path, error: &io::Error) -> Failure {
    let limit = room::at_file_size_limit(temporary).or_else(|| room::file_size_error(&error.to_string()));
    match limit {
        Some(limit) => room::file_size_failure(named, limit),
        None => write_failure("write", named, error),
    }
}

/// Where writing `path` lands: `path` itself, or if it is a symbolic link the
/// file it leads to (through any chain of links). A link that leads nowhere
/// is refused rather than written through.
fn through_links(path: &Path) -> Result<PathBuf, Failure> {
    let mut at = path.to_path_buf();
    for _ in 0..MAX_LINKS {
        match fs::symlink_metadata(&at) {
            Ok(meta) if meta.file_type().is_symlink() => {
                let target = fs::read_link(&at).map_err(|e| write_failure("follow", &at, &e))?;
                at = match at.parent() {
                    Some(parent) if target.is_relative() => parent.join(target),
                    _ => target,
                };
            }
            Ok(_) => return Ok(at),
            Err(_) if at == path => return Ok(at),
            Err(_) => {
                return Err(Failure::bad_input(format!(
                    "{}: is a link to {}, which does not exist; nothing is written through it",
                    shown(path),
                    shown(&at)
                )));
            }
        }
    }
    Err(Failure::bad_input(format!("{}: leads through more than {MAX_LINKS} links", shown(path))))
}

/// Links followed from a destination before giving up (as the system does).
const MAX_LINKS: usize = 40;

/// Check that `path` may be written by a command that read `inputs`, for
/// those that write through their own staging (charts, animations).
pub fn check_writable(path: &Path, inputs: &[&Path]) -> Result<(), Failure> {
    check_destination(path, &Staged::reading(inputs).inputs)?;
    through_links(path).map(|_| ())
}

impl Staged {
    /// Staging for a command that read `inputs` (none of them may be written).
    pub fn reading(inputs: &[&Path]) -> Self {
        let inputs = inputs.iter().filter_map(|p| identity(p).map(|id| (p.to_path_buf(), id))).collect();
        Self { files: Vec::new(), inputs, made: Vec::new(), committed: false }
    }

    /// The folder `dir` and any missing above it, made and remembered.
    fn make_folders(&mut self, dir: &Path) -> Result<(), Failure> {
        if let Some(taken) = dir.ancestors().find(|d| !d.as_os_str().is_empty() && d.exists() && !d.is_dir()) {
            return Err(Failure::bad_input(format!("{}: is not a folder; nothing is written into it", shown(taken))));
        }
        let missing: Vec<&Path> = dir.ancestors().take_while(|d| !d.as_os_str().is_empty() && !d.exists()).collect();
        for d in missing.into_iter().rev() {
            fs::create_dir(d).map_err(|e| write_failure("create", d, &e))?;
            cleanup::track_dir(d);
            self.made.push(d.to_path_buf());
        }
        Ok(())
    }

    /// A temporary name beside `path`, short whatever its own length.
    fn temporary_beside(&self, path: &Path) -> PathBuf {
        path.with_file_name(format!(".struck-{}-{}.part", std::process::id(), self.files.len()))
    }

    /// Make the temporary file for `named` beside where it goes (after the
    /// checks every destination has, the folders made), before the work
    /// that fills it: a destination that cannot be written is refused before
    /// any time is spent. Written later by [`Self::fill`].
    pub fn reserve(&mut self, named: &Path) -> Result<Slot, Failure> {
        check_destination(named, &self.inputs)?;
        let path = &through_links(named)?;
        if self
            .files
            .iter()
            .any(|f| f.destination == *path || identity(&f.destination).is_some_and(|id| identity(path) == Some(id)))
        {
            return Err(Failure::bad_input(format!("{}: named for two outputs", shown(named))));
        }
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            self.make_folders(parent)?;
        }
        sweep_stale(path.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new(".")));
        let temporary = self.temporary_beside(path);
        cleanup::track(&temporary);
        // Whether the folder takes a file at all is asked here, and told of
        // the path the user gave.
        if let Err(e) = fs::File::create(&temporary) {
            cleanup::forget(&temporary);
            return Err(write_failure("write", named, &e));
        }
        self.files.push(Staging { temporary, destination: path.to_path_buf(), written: false });
        Ok(Slot(self.files.len() - 1))
    }

    /// Have `write_to` write the file reserved as `slot` (at the path it is given).
    pub fn fill(
        &mut self,
        slot: Slot,
        named: &Path,
        write_to: impl FnOnce(&Path) -> io::Result<()>,
    ) -> Result<(), Failure> {
        let Some(staging) = self.files.get_mut(slot.0) else {
            return Err(Failure::failed(format!("{}: was not reserved", shown(named))));
        };
        match write_to(&staging.temporary) {
            Ok(()) => {
                staging.written = true;
                Ok(())
            }
            Err(e) => Err(staged_write_failure(named, &staging.temporary, &e)),
        }
    }

    /// The temporary file reserved as `slot`, for a writer on another thread
    /// (then [`Self::mark_written`]).
    pub fn temporary(&self, slot: Slot) -> &Path {
        &self.files[slot.0].temporary
    }

    /// The file reserved as `slot` was written at [`Self::temporary`].
    pub fn mark_written(&mut self, slot: Slot) {
        if let Some(staging) = self.files.get_mut(slot.0) {
            staging.written = true;
        }
    }

    /// [`Self::fill`] through a buffered writer.
    pub fn fill_with(
        &mut self,
        slot: Slot,
        named: &Path,
        fill: impl FnOnce(&mut BufWriter<fs::File>) -> io::Result<()>,
    ) -> Result<(), Failure> {
        self.fill(slot, named, |temporary| {
            let mut writer = BufWriter::new(fs::File::create(temporary)?);
            fill(&mut writer)?;
            writer.into_inner().map_err(|e| e.into_error())?.sync_all()
        })
    }

    /// Have `write_to` write a temporary file beside `path` and stage it.
    fn stage(&mut self, named: &Path, write_to: impl FnOnce(&Path) -> io::Result<()>) -> Result<(), Failure> {
        let slot = self.reserve(named)?;
        self.fill(slot, named, write_to)
    }

    /// Stage `temporary`, a file already written beside `path` (in a
    /// [`StagedFolder`] on the same file system), to be put at `path`.
    fn adopt(&mut self, temporary: &Path, named: &Path) -> Result<(), Failure> {
        check_destination(named, &self.inputs)?;
        let path = &through_links(named)?;
        if let Some(parent) = path.parent().filter(|p| !p.as_os_str().is_empty()) {
            self.make_folders(parent)?;
        }
        self.files.push(Staging { temporary: temporary.to_path_buf(), destination: path.to_path_buf(), written: true });
        Ok(())
    }

    /// Write one file by having `draw` write it at the path it is given (a
    /// temporary one beside `path`).
    pub fn write_at(&mut self, path: &Path, draw: impl FnOnce(&Path) -> io::Result<()>) -> Result<(), Failure> {
        self.stage(path, draw)
    }

    /// Write one file through `fill`.
    pub fn write(
        &mut self,
        path: &Path,
        fill: impl FnOnce(&mut BufWriter<fs::File>) -> io::Result<()>,
    ) -> Result<(), Failure> {
        let slot = self.reserve(path)?;
        self.fill_with(slot, path, fill)
    }

    /// Write a mono 32-bit float WAV into the file reserved as `slot`.
    pub fn fill_wav(&mut self, slot: Slot, path: &Path, sample_rate_hz: f64, samples: &[f32]) -> Result<(), Failure> {
        let spec = mono(sample_rate_hz, 32, hound::SampleFormat::Float);
        self.write_mono(slot, path, spec, samples, |w, s| w.write_sample(s))
    }

    /// Write a mono 16-bit PCM WAV (what every browser's player takes), clipping at full scale.
    pub fn write_wav16(&mut self, path: &Path, sample_rate_hz: f64, samples: &[f32]) -> Result<(), Failure> {
        let slot = self.reserve(path)?;
        let spec = mono(sample_rate_hz, 16, hound::SampleFormat::Int);
        self.write_mono(slot, path, spec, samples, |w, s| {
            w.write_sample((s.clamp(-1.0, 1.0) * i16::MAX as f32).round() as i16)
        })
    }

    fn write_mono(
        &mut self,
        slot: Slot,
        path: &Path,
        spec: hound::WavSpec,
        samples: &[f32],
        put: impl Fn(&mut hound::WavWriter<BufWriter<fs::File>>, f32) -> hound::Result<()>,
    ) -> Result<(), Failure> {
        self.fill(slot, path, |temporary| {
            let mut w = hound::WavWriter::create(temporary, spec).map_err(io::Error::other)?;
            for &s in samples {
                put(&mut w, s).map_err(io::Error::other)?;
            }
            w.finalize().map_err(io::Error::other)
        })
    }

    /// Put every staged file in place, all or none: what stood at a
    /// destination is set aside first and restored if any file fails.
    /// Refused once a stop signal came: whatever stood there is kept (and
    /// the temporaries are removed as `self` goes).
    pub fn commit(mut self) -> Result<(), Failure> {
        cleanup::holding(|held| {
            if cleanup::interrupted() {
                return Err(Failure::interrupted());
            }
            self.commit_held(held)
        })
    }

    fn commit_held(&mut self, held: &mut cleanup::Held) -> Result<(), Failure> {
        if let Some(f) = self.files.iter().find(|f| !f.written) {
            return Err(Failure::failed(format!("{}: reserved but never written", shown(&f.destination))));
        }
        let files: Vec<(PathBuf, PathBuf)> =
            std::mem::take(&mut self.files).into_iter().map(|f| (f.temporary, f.destination)).collect();
        // Set aside what the files replace.
        let mut aside: Vec<(PathBuf, PathBuf)> = Vec::new();
        let mut placed: Vec<&Path> = Vec::new();
        let result = (|| {
            for (i, (_, path)) in files.iter().enumerate() {
                check_destination(path, &self.inputs)?;
                if fs::symlink_metadata(path).is_ok() {
                    let old = path.with_file_name(format!(".struck-{}-{i}.old", std::process::id()));
                    fs::rename(path, &old).map_err(|e| write_failure("replace", path, &e))?;
                    aside.push((old, path.clone()));
                }
            }
            for (temporary, path) in &files {
                fs::rename(temporary, path).map_err(|e| write_failure("write", path, &e))?;
                placed.push(path);
            }
            Ok(())
        })();
        match result {
            Ok(()) => {
                for (old, _) in &aside {
                    let _ = fs::remove_file(old);
                }
                for (_, path) in &files {
                    held.placed(path);
                }
                self.committed = true;
                self.forget_all(&files, held);
                Ok(())
            }
            Err(e) => {
                for path in placed {
                    let _ = fs::remove_file(path);
                }
                for (old, path) in aside.iter().rev() {
                    let _ = fs::rename(old, path);
                }
                for (temporary, _) in &files {
                    let _ = fs::remove_file(temporary);
                }
                self.forget_all(&files, held);
                Err(e)
            }
        }
    }

    /// Take the files (put in place or removed) and the folders off the
    /// signal handler's lists; the lists are held by the caller.
    fn forget_all(&self, files: &[(PathBuf, PathBuf)], held: &mut cleanup::Held) {
        for (temporary, _) in files {
            held.forget(temporary);
        }
        for dir in &self.made {
            held.forget(dir);
        }
    }
}

impl Drop for Staged {
    /// Files not committed (an error came first) are removed, and the folders
    /// made for them if they are empty.
    fn drop(&mut self) {
        for f in &self.files {
            let _ = fs::remove_file(&f.temporary);
            cleanup::forget(&f.temporary);
        }
        if !self.committed {
            for dir in self.made.iter().rev() {
                let _ = fs::remove_dir(dir);
                cleanup::forget(dir);
            }
        }
    }
}

/// A folder inside a command's output folder that its many files are drawn
/// into, then moved into the output folder together ([`Self::commit_into`]),
/// on the same file system whatever is mounted where; it is removed with
/// whatever is left in it, also on a stop signal.
pub struct StagedFolder {
    path: PathBuf,
    /// Folders made for it that were missing (the output folder among them),
    /// outermost first: removed with it if nothing was put in them.
    made: Vec<PathBuf>,
}

impl StagedFolder {
    /// A new, empty folder inside `out` (`out` and the folders it lies in
    /// made if missing). Refused at once, before any work, if `out` or a
    /// folder above it is a file, or `out` takes no files.
    pub fn within(out: &Path) -> Result<Self, Failure> {
        if let Some(taken) = out.ancestors().find(|d| !d.as_os_str().is_empty() && d.exists() && !d.is_dir()) {
            return Err(Failure::bad_input(format!("{}: is not a folder; nothing is written into it", shown(taken))));
        }
        sweep_stale(out);
        let mut staged = Self { path: out.join(format!(".struck-{}.part", std::process::id())), made: Vec::new() };
        let missing: Vec<PathBuf> =
            out.ancestors().take_while(|d| !d.as_os_str().is_empty() && !d.exists()).map(Path::to_path_buf).collect();
        for d in missing.into_iter().rev() {
            fs::create_dir(&d).map_err(|e| write_failure("create", &d, &e))?;
            cleanup::track_dir(&d);
            staged.made.push(d);
        }
        fs::create_dir(&staged.path).map_err(|e| write_failure("write into", out, &e))?;
        cleanup::track_tree(&staged.path);
        Ok(staged)
    }

    /// Where to draw.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// `failure` of a file drawn here, naming it as it would be in `out`.
    pub fn as_out(&self, out: &Path, failure: Failure) -> Failure {
        let message = failure.message.replace(&shown(&self.path), &shown(out));
        Failure { message, ..failure }
    }

    /// The failure of drawing into the folder for `out`: the file-size limit
    /// if a file drawn reached it (named as it would be in `out`), else `error`.
    pub fn failure(&self, out: &Path, error: &anyhow::Error) -> Failure {
        let text = format!("{error:#}");
        let full = fs::read_dir(&self.path)
            .into_iter()
            .flatten()
            .filter_map(Result::ok)
            .find_map(|e| room::at_file_size_limit(&e.path()).map(|limit| (Some(e.file_name()), limit)));
        // A chart's writer removes what it could not finish, and names it.
        let named = || {
            error.chain().find_map(|e| match e.downcast_ref::<crate::plot::PlotError>() {
                Some(crate::plot::PlotError::Write { path, .. }) => path.file_name().map(|n| n.to_os_string()),
                _ => None,
            })
        };
        match full.or_else(|| room::file_size_error(&text).map(|limit| (named(), limit))) {
            Some((name, limit)) => {
                room::file_size_failure(&name.map_or_else(|| out.to_path_buf(), |n| out.join(n)), limit)
            }
            None => Failure::failed(text),
        }
    }

    /// Put every file drawn into `out` together (see [`Staged::commit`]),
    /// none of them over one of `inputs`.
    pub fn commit_into(self, out: &Path, inputs: &[&Path]) -> Result<(), Failure> {
        let mut staged = Staged::reading(inputs);
        let mut names: Vec<_> = fs::read_dir(&self.path)
            .map_err(|e| Failure::failed(format!("cannot read {}: {e}", shown(&self.path))))?
            .filter_map(|e| e.ok().map(|e| e.file_name()))
            .collect();
        names.sort();
        for name in names {
            staged.adopt(&self.path.join(&name), &out.join(&name))?;
        }
        staged.commit()
    }
}

impl Drop for StagedFolder {
    fn drop(&mut self) {
        let _ = fs::remove_dir_all(&self.path);
        cleanup::forget(&self.path);
        // A made folder the output went into is kept (it is not empty).
        for d in self.made.iter().rev() {
            let _ = fs::remove_dir(d);
            cleanup::forget(d);
        }
    }
}

/// Write `value` as one CSV field (empty for none), shortest round-trip form.
pub fn csv_field(out: &mut impl Write, value: Option<f64>) -> io::Result<()> {
    match value {
        Some(v) => write!(out, "{v:e}"),
        None => Ok(()),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_struck_temporaries_name_their_process() {
        assert_eq!(temporary_owner(".struck-1234-0.part"), Some(1234));
        assert_eq!(temporary_owner(".struck-1234-17.part"), Some(1234));
        assert_eq!(temporary_owner(".struck-1234.part"), Some(1234));
        for name in
            [".struck-1234-0.old", "struck-1234-0.part", ".struck-12a-0.part", ".struck-1234-.part", ".struck--1.part"]
        {
            assert_eq!(temporary_owner(name), None, "{name}");
        }
        // This program may be (it is itself); the one that started it (cargo) is
        // running, and no struck; one that ended is not running.
        assert_eq!(may_be_writing(std::process::id()), Some(true));
        assert_eq!(may_be_writing(std::os::unix::process::parent_id()), Some(false));
        let mut gone = std::process::Command::new("true").spawn().unwrap();
        let pid = gone.id();
        gone.wait().unwrap();
        assert_eq!(may_be_writing(pid), Some(false));
    }
}
