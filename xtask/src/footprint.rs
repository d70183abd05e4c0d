//! What the shipped plugin carries: no code of the lab's crates (charts, GIFs,
//! MIDI files, the command line, thread pools), and, built for release, each
//! bundle under [`MAX_BUNDLE_BYTES`].
//!
//! The crates are read from the library's symbol table: every Rust function
//! compiled into it is named by its crate's path, so a crate that reaches the
//! cdylib shows up there (its generic code as well, under the crate that
//! defines it). A release build is stripped, so there only the sizes are
//! checked; both profiles link the same crates.

use std::collections::BTreeSet;
use std::path::{Path, PathBuf};

use anyhow::{Context, Result, bail};
use object::{Object, ObjectSymbol};

use crate::bundle::{self, BUNDLE_NAME};
use crate::util::relative;

/// The most a release bundle's binary may weigh.
pub const MAX_BUNDLE_BYTES: u64 = 15 * 1024 * 1024;

/// Crates the lab and the `struck` binary use that the plugin must not link.
pub const LAB_ONLY_CRATES: &[&str] = &[
    "struck_lab",
    "plotters",
    "plotters_backend",
    "gif",
    "midly",
    "clap_builder",
    "hound",
    "indicatif",
    "rayon",
    "rayon_core",
];

/// The crates whose Rust code a binary's symbol table names.
pub fn crates_linked(binary: &Path) -> Result<BTreeSet<String>> {
    let data = std::fs::read(binary).with_context(|| format!("cannot read {}", relative(binary).display()))?;
    let file =
        object::File::parse(&*data).with_context(|| format!("{} is not an object file", relative(binary).display()))?;
    let mut crates = BTreeSet::new();
    for symbol in file.symbols().chain(file.dynamic_symbols()) {
        let Ok(name) = symbol.name() else { continue };
        if let Some(krate) = crate_of(&format!("{:#}", rustc_demangle::demangle(name))) {
            crates.insert(krate.to_string());
        }
    }
    Ok(crates)
}

/// The crate a demangled Rust path starts with (`<plotters::X as Y>::f` is
/// plotters'), if it is one.
fn crate_of(demangled: &str) -> Option<&str> {
    let path = demangled.trim_start_matches(['<', '&', '*', ' ']).trim_start_matches("mut ").trim_start_matches("dyn ");
    let (krate, _) = path.split_once("::")?;
    krate.chars().all(|c| c.is_ascii_alphanumeric() || c == '_').then_some(krate)
}

/// The three binaries a bundle step writes: the CLAP plugin, the VST3's library
/// and the standalone.
fn bundle_binaries() -> Result<Vec<(&'static str, PathBuf)>> {
    let standalone = bundle::bundled_dir()?.join(format!("{BUNDLE_NAME}{}", std::env::consts::EXE_SUFFIX));
    Ok(vec![
        ("CLAP plugin", bundle::clap_path()?),
        ("VST3 plugin", bundle::vst3_paths()?.1),
        ("standalone", standalone),
    ])
}

/// Check the bundles in target/bundled: the plugins link none of
/// [`LAB_ONLY_CRATES`], and (for a release build) no binary weighs more than
/// [`MAX_BUNDLE_BYTES`]. Prints what it measured.
pub fn check(release: bool) -> Result<()> {
    let mut problems = Vec::new();
    for (what, path) in bundle_binaries()? {
        let bytes =
            std::fs::metadata(&path).with_context(|| format!("{what} {} is missing", relative(&path).display()))?.len();
        let mb = bytes as f64 / (1024.0 * 1024.0);
        println!("{what:<12} {:>7.1} MB  {}", mb, relative(&path).display());
        if release && bytes > MAX_BUNDLE_BYTES {
            problems.push(format!("{what} weighs {mb:.1} MB (at most {} MB)", MAX_BUNDLE_BYTES / (1024 * 1024)));
        }
        if release {
            continue;
        }
        let crates = crates_linked(&path)?;
        if what == "standalone" {
            // It carries the lab's command line: if its crates do not show here,
            // the symbols are not being read and the plugins' check proves nothing.
            if !crates.contains("struck_lab") {
                problems.push(format!("{what}: no symbols of struck_lab found, so the check cannot see the lab"));
            }
            continue;
        }
        if !crates.contains("struck_engine") {
            problems.push(format!("{what}: no symbols of struck_engine found (is the symbol table stripped?)"));
        }
        let lab: Vec<&str> = LAB_ONLY_CRATES.iter().copied().filter(|c| crates.contains(*c)).collect();
        if !lab.is_empty() {
            problems.push(format!("{what} links the lab's crates: {}", lab.join(", ")));
        }
    }
    if !problems.is_empty() {
        bail!("the bundle carries too much: {}", problems.join("; "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_symbol_names_the_crate_its_path_starts_with() {
        assert_eq!(crate_of("plotters::chart::ChartBuilder::new"), Some("plotters"));
        assert_eq!(crate_of("<gif::Encoder<W> as core::ops::Drop>::drop"), Some("gif"));
        assert_eq!(crate_of("<&mut midly::Smf as core::fmt::Debug>::fmt"), Some("midly"));
        assert_eq!(crate_of("memcpy"), None);
        assert_eq!(crate_of("<[T] as core::fmt::Debug>::fmt"), None);
    }

    #[test]
    #[cfg_attr(
        not(debug_assertions),
        ignore = "a release test binary is stripped (profile.release), so it names no crate"
    )]
    fn the_xtask_binary_itself_is_read_and_names_its_crates() {
        let me = std::env::current_exe().unwrap();
        let crates = crates_linked(&me).unwrap();
        assert!(crates.contains("core") && crates.contains("anyhow"), "{crates:?}");
    }
}
