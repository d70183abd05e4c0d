//! Building and bundling the plugin with nice-plug-xtask, as
//! `cargo xtask bundle struck [--release]` does, and where the results are.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};

use crate::util::{relative, target_dir};

/// The plugin's package (and binary) name.
pub const PACKAGE: &str = "struck";
/// The bundles' file name, from `bundler.toml`.
pub const BUNDLE_NAME: &str = "Struck";

/// The cargo arguments that choose the profile.
pub fn profile_args(release: bool) -> Vec<String> {
    if release { vec!["--release".to_string()] } else { Vec::new() }
}

/// The directory of a profile's build products (`target/debug`, `target/release`).
pub fn profile_dir(release: bool) -> Result<PathBuf> {
    Ok(target_dir()?.join(if release { "release" } else { "debug" }))
}

/// The `struck` program of a profile.
pub fn struck_binary(release: bool) -> Result<PathBuf> {
    let path = profile_dir(release)?.join(format!("{PACKAGE}{}", std::env::consts::EXE_SUFFIX));
    if !path.exists() {
        bail!("{} was not built", path.display());
    }
    Ok(path)
}

/// Where nice-plug-xtask writes the bundles.
pub fn bundled_dir() -> Result<PathBuf> {
    Ok(target_dir()?.join("bundled"))
}

/// The CLAP plugin file.
pub fn clap_path() -> Result<PathBuf> {
    Ok(bundled_dir()?.join(format!("{BUNDLE_NAME}.clap")))
}

/// The VST3 bundle directory, and the library inside it.
pub fn vst3_paths() -> Result<(PathBuf, PathBuf)> {
    let bundle = bundled_dir()?.join(format!("{BUNDLE_NAME}.vst3"));
    let library = bundle
        .join("Contents")
        .join(format!("{}-{}", std::env::consts::ARCH, std::env::consts::OS))
        .join(format!("{BUNDLE_NAME}.so"));
    Ok((bundle, library))
}

/// `cargo xtask bundle struck [--release]`, through nice-plug-xtask's library,
/// then a check that the CLAP, the VST3 and the standalone are all there
/// (an error when `require_all`, else a warning).
pub fn bundle(release: bool, require_all: bool) -> Result<()> {
    let mut args = vec!["bundle".to_string(), PACKAGE.to_string()];
    args.extend(profile_args(release));
    println!("$ cargo xtask {}", args.join(" "));
    nice_plug_xtask::main_with_args("cargo xtask", args).context("bundling failed")?;

    let (vst3, vst3_library) = vst3_paths()?;
    let standalone = bundled_dir()?.join(format!("{BUNDLE_NAME}{}", std::env::consts::EXE_SUFFIX));
    let expected = [("CLAP plugin", clap_path()?), ("VST3 plugin", vst3_library), ("standalone", standalone)];
    let absent: Vec<String> = expected
        .iter()
        .filter(|(_, path)| !path.exists())
        .map(|(what, path)| format!("{what} {}", relative(path).display()))
        .collect();
    if !absent.is_empty() {
        let message = format!(
            "the bundle is incomplete, missing: {} (does the plugin crate export the CLAP and VST3 entry points \
             and have crate-type cdylib?)",
            absent.join(", ")
        );
        if require_all {
            bail!(message);
        }
        eprintln!("warning: {message}");
    }
    println!("bundled: {}", relative(&vst3).display());
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::util::workspace_root;

    #[test]
    fn the_bundle_name_is_the_one_in_bundler_toml() {
        let text = std::fs::read_to_string(workspace_root().join("bundler.toml")).unwrap();
        let table = format!("[{PACKAGE}]");
        let start = text.find(&table).unwrap_or_else(|| panic!("bundler.toml has no {table}"));
        let section = &text[start + table.len()..];
        let section = &section[..section.find("\n[").unwrap_or(section.len())];
        assert!(section.contains(&format!("name = \"{BUNDLE_NAME}\"")), "{section}");
    }

    #[test]
    fn release_is_the_only_profile_argument() {
        assert!(profile_args(false).is_empty());
        assert_eq!(profile_args(true), ["--release"]);
    }
}
