//! Names the engine's sources for the voicings it saves: every file under
//! `src/`, `data/`, `presets/` and `voicings/`, by path and content, hashed
//! (64-bit FNV-1a) into `STRUCK_ENGINE_SOURCES`. A voicing saved by one
//! engine is never read by another (see `synth::voicings`).

use std::path::{Path, PathBuf};

const FOLDERS: [&str; 4] = ["src", "data", "presets", "voicings"];

fn main() {
    let root = PathBuf::from(std::env::var_os("CARGO_MANIFEST_DIR").expect("cargo sets CARGO_MANIFEST_DIR"));
    let mut files = Vec::new();
    for folder in FOLDERS {
        println!("cargo:rerun-if-changed={folder}");
        gather(&root.join(folder), &mut files);
    }
    files.sort();
    let mut hash: u64 = 0xcbf2_9ce4_8422_2325;
    let mut add = |bytes: &[u8]| {
        for &b in bytes {
            hash = (hash ^ u64::from(b)).wrapping_mul(0x0100_0000_01b3);
        }
    };
    for file in &files {
        let name = file.strip_prefix(&root).unwrap_or(file).to_string_lossy().replace('\\', "/");
        add(name.as_bytes());
        add(&std::fs::read(file).unwrap_or_default());
    }
    println!("cargo:rustc-env=STRUCK_ENGINE_SOURCES={hash:016x}");
}

fn gather(dir: &Path, files: &mut Vec<PathBuf>) {
    let Ok(entries) = std::fs::read_dir(dir) else { return };
    for entry in entries.flatten() {
        let path = entry.path();
        if path.is_dir() {
            gather(&path, files);
        } else {
            files.push(path);
        }
    }
}
