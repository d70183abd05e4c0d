//! Small helpers: where the workspace is, and running programs with their
//! command line echoed.

use std::ffi::OsStr;
use std::path::{Path, PathBuf};
use std::process::Command;

use anyhow::{Context, Result, bail};

/// The workspace root: the parent of this crate's directory.
pub fn workspace_root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).parent().expect("xtask/ has a parent").to_path_buf()
}

/// Cargo's target directory for this workspace (`target/` unless configured
/// otherwise), as `cargo metadata` reports it.
pub fn target_dir() -> Result<PathBuf> {
    let metadata = cargo_metadata::MetadataCommand::new()
        .cargo_path(cargo())
        .manifest_path(workspace_root().join("Cargo.toml"))
        .no_deps()
        .exec()
        .context("could not run `cargo metadata`")?;
    Ok(metadata.target_directory.into_std_path_buf())
}

/// The cargo that runs us (so a `cargo +toolchain xtask` stays on it).
pub fn cargo() -> PathBuf {
    std::env::var_os("CARGO").map_or_else(|| PathBuf::from("cargo"), PathBuf::from)
}

/// Whether `name` is an executable file in a directory of PATH.
pub fn has_command(name: &str) -> bool {
    use std::os::unix::fs::PermissionsExt;
    let Some(path) = std::env::var_os("PATH") else { return false };
    std::env::split_paths(&path)
        .any(|dir| std::fs::metadata(dir.join(name)).is_ok_and(|m| m.is_file() && m.permissions().mode() & 0o111 != 0))
}

/// Whether we run as root (no sudo needed for apt-get).
pub fn is_root() -> bool {
    Command::new("id")
        .arg("-u")
        .output()
        .is_ok_and(|o| o.status.success() && String::from_utf8_lossy(&o.stdout).trim() == "0")
}

/// A command line as a shell would show it (for echoing, not for a shell).
pub fn show(command: &Command) -> String {
    let quote = |s: &OsStr| {
        let s = s.to_string_lossy();
        if !s.is_empty() && s.chars().all(|c| c.is_ascii_alphanumeric() || "-_./=:+,@%".contains(c)) {
            s.into_owned()
        } else {
            format!("'{}'", s.replace('\'', r"'\''"))
        }
    };
    let env = command.get_envs().filter_map(|(k, v)| Some(format!("{}={}", k.to_string_lossy(), quote(v?))));
    let words = std::iter::once(command.get_program()).chain(command.get_args()).map(quote);
    env.chain(words).collect::<Vec<_>>().join(" ")
}

/// Run a command in the workspace root, echoing it, and fail on a non-zero exit.
pub fn run(command: &mut Command) -> Result<()> {
    let root = workspace_root();
    if command.get_current_dir().is_none() {
        command.current_dir(&root);
    }
    println!("$ {}", show(command));
    let status = command.status().with_context(|| format!("could not start `{}`", show(command)))?;
    if !status.success() {
        bail!("`{}` failed ({status})", show(command));
    }
    Ok(())
}

/// Express `path` relative to the workspace root when it is inside it.
pub fn relative(path: &Path) -> PathBuf {
    path.strip_prefix(workspace_root()).map_or_else(|_| path.to_path_buf(), Path::to_path_buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn commands_are_shown_quoted_only_where_needed() {
        let mut c = Command::new("cargo");
        c.args(["test", "--workspace", "it's here", "a b", ""]);
        assert_eq!(show(&c), r"cargo test --workspace 'it'\''s here' 'a b' ''");
        c.env("STRUCK_REQUIRE_BUNDLE", "1");
        assert!(show(&c).starts_with("STRUCK_REQUIRE_BUNDLE=1 cargo test"), "{}", show(&c));
    }

    #[test]
    fn the_workspace_root_holds_the_workspace_manifest() {
        let manifest = std::fs::read_to_string(workspace_root().join("Cargo.toml")).unwrap();
        assert!(manifest.contains("[workspace]"));
    }
}
