//! What voicing an instrument's keys through its body found, kept by the
//! settings it was found for: nine tenths of building an instrument, and
//! nothing in it depends on the sample rate. The voicings of the factory
//! presets and of each instrument as it starts come with the program (found
//! when it was made, and checked against a fresh voicing by its tests); any
//! other is found once, kept for the program's run (a build at each of a
//! host's sample rates, or the same voicing asked for again, voices once) and
//! saved in the user's cache folder, so a session reopened with it does not
//! voice again (until the engine changes).
//!
//! Touched only where instruments are built, never by the audio thread.

use std::ffi::OsString;
use std::path::{Path, PathBuf};
use std::sync::{Arc, Mutex, MutexGuard, OnceLock};

use serde::{Deserialize, Serialize};

use super::InstrumentSettings;
use super::instrument::VOICING_RATE_HZ;
use crate::key::KeyVoicing;

/// An instrument's voicing: every key's ([`KeyVoicing`]), in key order, as
/// found for `settings` (at [`VOICING_RATE_HZ`]).
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct InstrumentVoicing {
    pub settings: InstrumentSettings,
    pub keys: Vec<KeyVoicing>,
}

impl InstrumentVoicing {
    /// The voicing found for `midi_key`, if any.
    pub fn key(&self, midi_key: u8) -> Option<&KeyVoicing> {
        self.keys.iter().find(|k| k.midi_key == midi_key)
    }
}

/// The settings a voicing is found for: `settings` at the voicing's rate.
pub fn voicing_settings(settings: &InstrumentSettings) -> InstrumentSettings {
    InstrumentSettings { sample_rate_hz: VOICING_RATE_HZ, ..settings.clone() }
}

/// The settings as a key: every field by its exact value (the shortest
/// decimal that reads back to the same bits), at the voicing's rate.
fn key(settings: &InstrumentSettings) -> String {
    format!("{:?}", voicing_settings(settings))
}

/// How many voicings found in this run are kept (the least recently used
/// goes first): a piano's is a few tens of kilobytes.
const KEPT: usize = 32;

type Kept = Vec<(String, Arc<InstrumentVoicing>)>;

fn kept() -> MutexGuard<'static, Kept> {
    static KEPT_VOICINGS: OnceLock<Mutex<Kept>> = OnceLock::new();
    // A thread that panicked holding the lock left the list whole.
    KEPT_VOICINGS.get_or_init(|| Mutex::new(Vec::with_capacity(KEPT + 1))).lock().unwrap_or_else(|e| e.into_inner())
}

/// The voicing for `settings` (at any rate), if one was found in this run or
/// came with the program.
pub(super) fn find(settings: &InstrumentSettings) -> Option<Arc<InstrumentVoicing>> {
    let key = key(settings);
    {
        let mut kept = kept();
        if let Some(at) = kept.iter().position(|(k, _)| *k == key) {
            let entry = kept.remove(at);
            let found = entry.1.clone();
            kept.push(entry);
            return Some(found);
        }
    }
    let found = Arc::new(shipped(&key).or_else(|| saved(&key))?);
    keep_as(key, found.clone());
    Some(found)
}

/// Keep `voicing`, just found, and save it in the cache folder.
pub(super) fn keep(voicing: InstrumentVoicing) {
    let key = key(&voicing.settings);
    save(&key, &voicing);
    keep_as(key, Arc::new(voicing));
}

fn keep_as(key: String, voicing: Arc<InstrumentVoicing>) {
    let dropped: Kept = {
        let mut kept = kept();
        kept.retain(|(k, _)| *k != key);
        kept.push((key, voicing));
        let over = kept.len().saturating_sub(KEPT);
        kept.drain(..over).collect()
    };
    drop(dropped);
}

/// Forget every voicing found in this run (those that came with the program
/// stay).
pub(super) fn forget() {
    let dropped = std::mem::take(&mut *kept());
    drop(dropped);
}

/// The voicings that come with the program, each as JSON.
const SHIPPED: &[&str] = &include!("../../voicings/list.rs");

/// The voicing that came with the program for the settings whose key is
/// `key`, if one did.
fn shipped(key: &str) -> Option<InstrumentVoicing> {
    // Each text starts with its settings: only the one that matches is read
    // whole.
    SHIPPED.iter().find_map(|text| read(text, key))
}

/// The voicing `text` holds ([`shipped_text`]), if it is for settings `key`
/// (only then is it read past its first line) and reads whole.
fn read(text: &str, key: &str) -> Option<InstrumentVoicing> {
    let (head, whole) = text.split_once('\n')?;
    let head: Head = serde_json::from_str(head).ok()?;
    if format!("{:?}", head.settings) != key {
        return None;
    }
    serde_json::from_str(whole).ok()
}

/// Every voicing that came with the program (for its tests, and for
/// writing them again).
pub fn shipped_voicings() -> Vec<InstrumentVoicing> {
    SHIPPED.iter().filter_map(|text| serde_json::from_str(text.split_once('\n')?.1).ok()).collect()
}

/// A shipped voicing's text: its settings alone on the first line (so a
/// lookup reads no more), then the whole voicing.
pub fn shipped_text(voicing: &InstrumentVoicing) -> Result<String, serde_json::Error> {
    let head = serde_json::to_string(&Head { settings: voicing.settings.clone() })?;
    Ok(format!("{head}\n{}\n", serde_json::to_string(voicing)?))
}

#[derive(Serialize, Deserialize)]
struct Head {
    settings: InstrumentSettings,
}

/// The voicings saved by this program: a folder named after the engine's
/// sources and the voicings that came with it (another engine saves in
/// another, and clears the others away), under `$STRUCK_CACHE_DIR`, else
/// `$XDG_CACHE_HOME/struck/voicings`, else `~/.cache/struck/voicings`.
fn saved_dir() -> Option<PathBuf> {
    let root = cache_dir_from(
        std::env::var_os("STRUCK_CACHE_DIR"),
        std::env::var_os("XDG_CACHE_HOME"),
        std::env::var_os("HOME"),
    )?;
    Some(root.join(program_stamp()))
}

fn cache_dir_from(own: Option<OsString>, xdg_cache_home: Option<OsString>, home: Option<OsString>) -> Option<PathBuf> {
    // The XDG rules: a relative XDG_CACHE_HOME is to be ignored.
    let absolute = |p: Option<OsString>| p.map(PathBuf::from).filter(|p| p.is_absolute());
    if let Some(own) = absolute(own) {
        return Some(own.join("voicings"));
    }
    let cache = match absolute(xdg_cache_home) {
        Some(cache) => cache,
        None => PathBuf::from(home.filter(|h| !h.is_empty())?).join(".cache"),
    };
    Some(cache.join("struck").join("voicings"))
}

/// The engine's sources (as its build script hashed them) and the voicings
/// that came with the program, as a name: FNV-1a over both, in hex.
fn program_stamp() -> &'static str {
    static STAMP: OnceLock<String> = OnceLock::new();
    STAMP.get_or_init(|| {
        let sources = env!("STRUCK_ENGINE_SOURCES").bytes();
        format!("{:016x}", fnv1a(sources.chain(SHIPPED.iter().flat_map(|t| t.bytes()))))
    })
}

/// The 64-bit FNV-1a hash of `bytes`.
fn fnv1a(bytes: impl IntoIterator<Item = u8>) -> u64 {
    bytes.into_iter().fold(0xcbf2_9ce4_8422_2325, |h, b| (h ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3))
}

/// The file a voicing for settings `key` is saved in.
fn saved_file(dir: &Path, key: &str) -> PathBuf {
    dir.join(format!("{:016x}.json", fnv1a(key.bytes())))
}

/// How many voicings are saved at most (the least recently saved go first):
/// a piano's takes about 120 kB.
const MOST_SAVED: usize = 200;

/// The voicing saved for settings `key`, if one was (and reads whole).
fn saved(key: &str) -> Option<InstrumentVoicing> {
    read(&std::fs::read_to_string(saved_file(&saved_dir()?, key)).ok()?, key)
}

/// Save `voicing` (for settings `key`) in the cache folder, whole or not at
/// all (written aside, then renamed); where it cannot be, it is not (the
/// voicing is found again next time).
fn save(key: &str, voicing: &InstrumentVoicing) {
    let Some(dir) = saved_dir() else { return };
    if std::fs::create_dir_all(&dir).is_err() {
        return;
    }
    let Ok(text) = shipped_text(voicing) else { return };
    let file = saved_file(&dir, key);
    let aside = file.with_extension(format!("json.{}.part", std::process::id()));
    if std::fs::write(&aside, text).is_ok() && std::fs::rename(&aside, &file).is_ok() {
        tidy(&dir);
    } else {
        let _ = std::fs::remove_file(&aside);
    }
}

/// Clear away what other programs saved beside `dir`, and the least
/// recently saved beyond [`MOST_SAVED`] in it.
fn tidy(dir: &Path) {
    if let Some(parent) = dir.parent()
        && let Ok(others) = std::fs::read_dir(parent)
    {
        for other in others.flatten().filter(|o| o.path() != dir && o.path().is_dir()) {
            let _ = std::fs::remove_dir_all(other.path());
        }
    }
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    let mut saved: Vec<(std::time::SystemTime, PathBuf)> = entries
        .flatten()
        .filter(|e| e.path().extension().is_some_and(|x| x == "json"))
        .filter_map(|e| Some((e.metadata().ok()?.modified().ok()?, e.path())))
        .collect();
    if saved.len() > MOST_SAVED {
        saved.sort();
        for (_, path) in &saved[..saved.len() - MOST_SAVED] {
            let _ = std::fs::remove_file(path);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_cache_folder_follows_the_environment_and_the_xdg_rules() {
        let os = |s: &str| Some(OsString::from(s));
        assert_eq!(cache_dir_from(os("/tmp/own"), os("/x"), os("/home/a")), Some(PathBuf::from("/tmp/own/voicings")));
        assert_eq!(cache_dir_from(os("relative"), os("/x"), os("/home/a")), Some(PathBuf::from("/x/struck/voicings")));
        assert_eq!(
            cache_dir_from(None, os("relative"), os("/home/a")),
            Some(PathBuf::from("/home/a/.cache/struck/voicings"))
        );
        assert_eq!(cache_dir_from(None, None, None), None);
        assert_eq!(cache_dir_from(None, None, os("")), None);
    }

    #[test]
    fn fnv1a_is_the_published_hash() {
        // The FNV test vectors for 64-bit FNV-1a.
        assert_eq!(fnv1a(*b""), 0xcbf2_9ce4_8422_2325);
        assert_eq!(fnv1a(*b"a"), 0xaf63_dc4c_8601_ec8c);
        assert_eq!(fnv1a(*b"foobar"), 0x8594_4171_f739_67e8);
    }
}
