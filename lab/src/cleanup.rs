//! What a stop signal (Ctrl-C, SIGTERM, SIGHUP) leaves behind: nothing.
//!
//! Temporary files and the folders made for them are listed here while they
//! exist. On a signal the flag [`interrupted`] is raised; a command that
//! checks it (a render between blocks, a strike every few thousand samples)
//! stops and cleans up on its own. One that does not is stopped a second
//! later: whatever is listed is removed and the process exits with status 130.
//! Putting a set of files in place holds the list ([`holding`]), so a signal
//! never lands between two of their renames, and is refused once the flag is
//! up: whatever stood at the outputs stays as it was. A signal that comes
//! after the outputs were put in place ([`Held::placed`]) finds the work
//! done: the process ends with status 0.

use std::path::{Path, PathBuf};
use std::sync::Mutex;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

/// Exit status after a stop signal (128 + SIGINT, as shells report it).
pub const EXIT_INTERRUPTED: u8 = 130;

/// What a command stopped by a signal says (after its name).
pub const INTERRUPTED_MESSAGE: &str = "interrupted; nothing was written";

static INTERRUPTED: AtomicBool = AtomicBool::new(false);

/// Whether a command's outputs were put in place (outside its scratch folders).
static DONE: AtomicBool = AtomicBool::new(false);

pub struct Listed {
    files: Vec<PathBuf>,
    dirs: Vec<PathBuf>,
    /// Folders removed with everything in them.
    trees: Vec<PathBuf>,
}

static LISTED: Mutex<Listed> = Mutex::new(Listed { files: Vec::new(), dirs: Vec::new(), trees: Vec::new() });

fn listed() -> std::sync::MutexGuard<'static, Listed> {
    LISTED.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

/// Whether a stop signal came.
pub fn interrupted() -> bool {
    INTERRUPTED.load(Ordering::Relaxed)
}

/// The flag itself, for work that polls it.
pub fn flag() -> &'static AtomicBool {
    &INTERRUPTED
}

/// List a temporary file (removed on a signal until [`forget`]).
pub fn track(path: &Path) {
    listed().files.push(path.to_path_buf());
}

/// List a folder made for outputs (removed on a signal if it is empty).
pub fn track_dir(path: &Path) {
    listed().dirs.push(path.to_path_buf());
}

/// List a scratch folder (removed with its contents on a signal).
pub fn track_tree(path: &Path) {
    listed().trees.push(path.to_path_buf());
}

/// Take `path` off the lists (put in place, or removed by its owner).
pub fn forget(path: &Path) {
    forget_from(&mut listed(), path);
}

fn forget_from(l: &mut Listed, path: &Path) {
    l.files.retain(|p| p != path);
    l.dirs.retain(|p| p != path);
    l.trees.retain(|p| p != path);
}

/// The lists, held (see [`holding`]).
pub struct Held<'a>(std::sync::MutexGuard<'a, Listed>);

impl Held<'_> {
    /// [`forget`], with the lists already held.
    pub fn forget(&mut self, path: &Path) {
        forget_from(&mut self.0, path);
    }

    /// A file was put in place at `path`: the command's work is done unless
    /// `path` lies inside a scratch folder (a file drawn to be moved out later).
    pub fn placed(&mut self, path: &Path) {
        if !self.0.trees.iter().any(|tree| path.starts_with(tree)) {
            DONE.store(true, Ordering::Relaxed);
        }
    }
}

/// Run `work` with the lists held: a signal waits until it is done.
pub fn holding<R>(work: impl FnOnce(&mut Held) -> R) -> R {
    work(&mut Held(listed()))
}

/// Handle stop signals for `command` (printed in the last line).
pub fn install(command: &'static str) {
    let _ = ctrlc::set_handler(move || {
        INTERRUPTED.store(true, Ordering::Relaxed);
        std::thread::sleep(Duration::from_secs(1));
        let l = listed();
        if DONE.load(Ordering::Relaxed) {
            // The outputs are in place; only the report was left to print.
            std::process::exit(0);
        }
        for file in &l.files {
            let _ = std::fs::remove_file(file);
        }
        for tree in &l.trees {
            let _ = std::fs::remove_dir_all(tree);
        }
        for dir in l.dirs.iter().rev() {
            let _ = std::fs::remove_dir(dir);
        }
        crate::console::err(format!("{command}: {INTERRUPTED_MESSAGE}"));
        std::process::exit(i32::from(EXIT_INTERRUPTED));
    });
}
