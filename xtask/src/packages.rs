//! The Debian packages that building and testing Struck need, checked before
//! anything is built and installed with apt-get when they are missing.
//!
//! On a machine with dpkg its database is the authority (a command or a `.pc`
//! file that happens to be there does not count: `convert` may be a stand-in,
//! and a library found by accident hides a missing install step). Elsewhere
//! each package is probed for what it provides, and whatever is missing is
//! printed for the user to install with their own package manager.

use std::collections::BTreeSet;
use std::process::{Command, Stdio};

use anyhow::{Context, Result, bail};

use crate::util::{has_command, is_root};

/// How to tell, without dpkg, that a package's contents are there.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Probe {
    /// A program on PATH.
    Command(&'static str),
    /// A library known to pkg-config.
    PkgConfig(&'static str),
    /// A Python that can create a virtual environment with pip in it.
    PythonVenv,
    /// A file at this path (a package of data, such as a SoundFont).
    File(&'static str),
}

/// One Debian package and what it provides.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Package {
    pub name: &'static str,
    pub probe: Probe,
}

/// Packages that are installed together for one reason, printed with it.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Need {
    pub packages: &'static [Package],
    pub why: &'static str,
    /// Satisfied whatever dpkg says when this probe passes (a Python from
    /// pyenv needs no python3-venv).
    pub enough_if: Option<Probe>,
}

const fn pkg(name: &'static str, probe: Probe) -> Package {
    Package { name, probe }
}

/// What building the plugin and the `struck` binary needs (nice-plug's audio
/// backends: jack-sys's build script wants `jack.pc` although JACK is loaded at
/// run time; X11, XCB and GL are loaded at run time and need no headers).
pub const BUILD: &[Need] = &[
    Need {
        packages: &[pkg("gcc", Probe::Command("cc"))],
        why: "the C compiler and linker of the -sys crates",
        enough_if: None,
    },
    Need {
        packages: &[pkg("pkg-config", Probe::Command("pkg-config"))],
        why: "how the -sys crates' build scripts find ALSA and JACK",
        enough_if: None,
    },
    Need {
        packages: &[
            pkg("libasound2-dev", Probe::PkgConfig("alsa")),
            pkg("libjack-jackd2-dev", Probe::PkgConfig("jack")),
        ],
        why: "the ALSA and JACK headers the audio backends build against",
        enough_if: None,
    },
];

/// What the checks of `cargo xtask test` need beyond the build.
pub const TEST: &[Need] = &[
    Need {
        packages: &[
            pkg("xvfb", Probe::Command("Xvfb")),
            pkg("x11-utils", Probe::Command("xwininfo")),
            pkg("imagemagick", Probe::Command("import")),
            pkg("xdotool", Probe::Command("xdotool")),
        ],
        why: "a virtual display, xwininfo, import and xdotool, for the screenshot of the editor played from the computer's keys and the pointer",
        enough_if: None,
    },
    Need {
        packages: &[pkg("jackd2", Probe::Command("jackd"))],
        why: "a JACK server with the dummy driver, for the MIDI-keyboard test",
        enough_if: None,
    },
    Need {
        packages: &[pkg("ardour", Probe::Command("ardour7-lua"))],
        why: "Ardour 7 and its headless Lua session tool, for the DAW test",
        enough_if: None,
    },
    Need {
        packages: &[pkg("python3", Probe::Command("python3")), pkg("python3-venv", Probe::PythonVenv)],
        why: "Python with venv and pip, to load the VST3 in pedalboard",
        enough_if: Some(Probe::PythonVenv),
    },
    Need {
        packages: &[
            pkg("fluidsynth", Probe::Command("fluidsynth")),
            pkg("fluid-soundfont-gm", Probe::File("/usr/share/sounds/sf2/FluidR3_GM.sf2")),
            pkg("faust", Probe::Command("faust")),
        ],
        why: "FluidSynth with the FluidR3_GM SoundFont, and the Faust compiler for the STK piano: the yardsticks of `struck compare`",
        enough_if: None,
    },
];

/// The packages that `dpkg-query -W -f='${Package}\t${db:Status-Abbrev}\n'`
/// reports as installed ("ii"). Packages dpkg has never heard of are simply
/// absent from its output; a multi-arch package may appear once per
/// architecture, and one installed copy is enough.
pub fn parse_dpkg_installed(output: &str) -> BTreeSet<String> {
    output
        .lines()
        .filter_map(|line| {
            let (name, status) = line.split_once('\t')?;
            let name = name.trim();
            let name = name.split_once(':').map_or(name, |(base, _arch)| base);
            (status.starts_with("ii") && !name.is_empty()).then(|| name.to_string())
        })
        .collect()
}

/// A need that is not met: its missing packages and why they are needed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Missing {
    pub packages: Vec<&'static str>,
    pub why: &'static str,
}

/// The needs that are not met, each with only its missing packages, in order.
pub fn missing(needs: &[Need], installed: impl Fn(&Package) -> bool, probe: impl Fn(Probe) -> bool) -> Vec<Missing> {
    needs
        .iter()
        .filter(|need| !need.enough_if.is_some_and(&probe))
        .map(|need| Missing {
            packages: need.packages.iter().filter(|p| !installed(p)).map(|p| p.name).collect(),
            why: need.why,
        })
        .filter(|m| !m.packages.is_empty())
        .collect()
}

/// The package names of some needs, in order, each once.
pub fn names<'a>(lists: impl IntoIterator<Item = &'a [&'static str]>) -> Vec<&'static str> {
    let mut seen = BTreeSet::new();
    lists.into_iter().flatten().copied().filter(|n| seen.insert(*n)).collect()
}

fn missing_names(absent: &[Missing]) -> Vec<&'static str> {
    names(absent.iter().map(|m| m.packages.as_slice()))
}

fn need_names(needs: &[Need]) -> Vec<&'static str> {
    let mut seen = BTreeSet::new();
    needs.iter().flat_map(|n| n.packages.iter().map(|p| p.name)).filter(|n| seen.insert(*n)).collect()
}

/// The line printed before installing: "installing A B: why; C: why".
pub fn install_line(absent: &[Missing]) -> String {
    let parts: Vec<String> = absent.iter().map(|m| format!("{}: {}", m.packages.join(" "), m.why)).collect();
    format!("installing {}", parts.join("; "))
}

fn probe(probe: Probe) -> bool {
    match probe {
        Probe::Command(name) => has_command(name),
        Probe::PkgConfig(lib) => {
            has_command("pkg-config")
                && Command::new("pkg-config")
                    .args(["--exists", lib])
                    .stderr(Stdio::null())
                    .status()
                    .is_ok_and(|s| s.success())
        }
        Probe::PythonVenv => {
            has_command("python3")
                && Command::new("python3")
                    .args(["-c", "import venv, ensurepip"])
                    .stdout(Stdio::null())
                    .stderr(Stdio::null())
                    .status()
                    .is_ok_and(|s| s.success())
        }
        Probe::File(path) => std::path::Path::new(path).is_file(),
    }
}

/// What dpkg says is installed among `packages`, or `None` without dpkg.
fn dpkg_installed(packages: &[&str]) -> Option<BTreeSet<String>> {
    if !has_command("dpkg-query") {
        return None;
    }
    // Exit status 1 only means that some name is unknown to dpkg.
    let output = Command::new("dpkg-query")
        .arg("-W")
        .arg("-f=${Package}\t${db:Status-Abbrev}\n")
        .args(packages)
        .stderr(Stdio::null())
        .output()
        .ok()?;
    Some(parse_dpkg_installed(&String::from_utf8_lossy(&output.stdout)))
}

fn find_missing(needs: &[Need]) -> Vec<Missing> {
    match dpkg_installed(&need_names(needs)) {
        Some(installed) => missing(needs, |p| installed.contains(p.name), probe),
        None => missing(needs, |p| probe(p.probe), probe),
    }
}

/// Whether a file of /var/lib/apt/lists is a package list (they may be
/// compressed: `..._binary-amd64_Packages.lz4`).
pub fn is_package_list(file_name: &str) -> bool {
    file_name.ends_with("_Packages") || file_name.contains("_Packages.")
}

/// Whether apt has any package lists (a fresh container has none, and
/// `apt-get install` then finds nothing).
fn apt_has_lists() -> bool {
    std::fs::read_dir("/var/lib/apt/lists")
        .map(|dir| dir.flatten().any(|e| is_package_list(&e.file_name().to_string_lossy())))
        .unwrap_or(false)
}

fn apt_get(args: &[&str]) -> Result<bool> {
    // No questions (jackd2 asks about real-time priority); sudo resets the
    // environment, so there the variable is set by `env` on its far side.
    let mut command = if is_root() {
        let mut c = Command::new("apt-get");
        c.env("DEBIAN_FRONTEND", "noninteractive");
        c
    } else {
        let mut c = Command::new("sudo");
        c.args(["env", "DEBIAN_FRONTEND=noninteractive", "apt-get"]);
        c
    };
    // Wait for another apt or dpkg to finish instead of failing at once.
    command.args(["-o", "DPkg::Lock::Timeout=900"]).args(args);
    let status = command.stdin(Stdio::null()).status().context("could not run apt-get")?;
    Ok(status.success())
}

/// Check `needs` and install what is missing with apt-get, or fail with the
/// list of packages to install when that is not possible (no apt-get, not
/// root and no sudo, or `install` is false).
pub fn ensure(needs: &[Need], install: bool) -> Result<()> {
    let absent = find_missing(needs);
    if absent.is_empty() {
        println!("system packages: all present ({})", need_names(needs).join(" "));
        return Ok(());
    }
    let names = missing_names(&absent);
    let list = names.join(" ");
    let can_apt = has_command("apt-get") && (is_root() || has_command("sudo"));
    if !install || !can_apt {
        for m in &absent {
            eprintln!("missing: {}: {}", m.packages.join(" "), m.why);
        }
        let how = if !install {
            "installing was turned off (--no-install)"
        } else if !has_command("apt-get") {
            "this system has no apt-get; these are Debian's names, install the equivalents"
        } else {
            "not root and no sudo"
        };
        bail!("missing system packages: {list} ({how}); on Debian: apt-get install -y {list}");
    }

    println!("{}", install_line(&absent));
    let mut args = vec!["install", "-y", "-q"];
    args.extend(names.iter().copied());
    if !apt_has_lists() {
        println!("apt has no package lists yet: apt-get update");
        if !apt_get(&["update", "-q"])? {
            bail!("apt-get update failed");
        }
    }
    if !apt_get(&args)? {
        println!("apt-get install failed; updating the package lists and trying again");
        if !apt_get(&["update", "-q"])? || !apt_get(&args)? {
            bail!("could not install {list}");
        }
    }
    let still = find_missing(needs);
    if !still.is_empty() {
        bail!("still missing after apt-get install: {}", missing_names(&still).join(" "));
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn dpkg_output_counts_only_installed_packages() {
        let out = "gcc\tii \nlibjack-jackd2-dev\trc \nxvfb\tun \nlibasound2-dev:amd64\tii \npkg-config\tiU \n";
        let installed = parse_dpkg_installed(out);
        assert_eq!(installed.into_iter().collect::<Vec<_>>(), ["gcc", "libasound2-dev"]);
    }

    #[test]
    fn dpkg_output_tolerates_junk_and_duplicates() {
        let out = "\nno tab here\nimagemagick\tii\nimagemagick\tii \n\tii \n";
        let installed = parse_dpkg_installed(out);
        assert_eq!(installed.into_iter().collect::<Vec<_>>(), ["imagemagick"]);
    }

    #[test]
    fn missing_keeps_only_absent_packages_with_their_reason() {
        let installed = |p: &Package| p.name == "gcc" || p.name == "pkg-config" || p.name == "libasound2-dev";
        let absent = missing(BUILD, installed, |_| false);
        assert_eq!(absent, [Missing { packages: vec!["libjack-jackd2-dev"], why: BUILD[2].why }]);
    }

    #[test]
    fn nothing_missing_when_all_installed() {
        assert!(missing(BUILD, |_| true, |_| false).is_empty());
        assert!(missing(TEST, |_| true, |_| false).is_empty());
    }

    #[test]
    fn a_python_that_makes_venvs_needs_no_packages() {
        let absent = missing(TEST, |_| false, |p| p == Probe::PythonVenv);
        assert_eq!(
            missing_names(&absent),
            [
                "xvfb",
                "x11-utils",
                "imagemagick",
                "xdotool",
                "jackd2",
                "ardour",
                "fluidsynth",
                "fluid-soundfont-gm",
                "faust"
            ]
        );
        let absent = missing(TEST, |_| false, |_| false);
        assert_eq!(
            missing_names(&absent),
            [
                "xvfb",
                "x11-utils",
                "imagemagick",
                "xdotool",
                "jackd2",
                "ardour",
                "python3",
                "python3-venv",
                "fluidsynth",
                "fluid-soundfont-gm",
                "faust"
            ]
        );
    }

    #[test]
    fn the_install_line_says_what_and_why() {
        let absent = missing(BUILD, |p| p.name == "gcc" || p.name == "pkg-config", |_| false);
        assert_eq!(
            install_line(&absent),
            "installing libasound2-dev libjack-jackd2-dev: the ALSA and JACK headers the audio backends build against"
        );
        let absent = missing(&[BUILD[2], TEST[1]], |_| false, |_| false);
        assert_eq!(
            install_line(&absent),
            "installing libasound2-dev libjack-jackd2-dev: the ALSA and JACK headers the audio backends build \
             against; jackd2: a JACK server with the dummy driver, for the MIDI-keyboard test"
        );
    }

    #[test]
    fn package_lists_are_recognised_compressed_or_not() {
        assert!(is_package_list("deb.debian.org_debian_dists_bookworm_main_binary-amd64_Packages"));
        assert!(is_package_list("deb.debian.org_debian_dists_bookworm_main_binary-amd64_Packages.lz4"));
        assert!(!is_package_list("deb.debian.org_debian_dists_bookworm_InRelease"));
        assert!(!is_package_list("lock"));
    }

    #[test]
    fn names_are_listed_once_in_order() {
        let needs = [BUILD[2], BUILD[2], TEST[1]];
        assert_eq!(need_names(&needs), ["libasound2-dev", "libjack-jackd2-dev", "jackd2"]);
        assert_eq!(names([&["a", "b"][..], &["b", "c"][..]]), ["a", "b", "c"]);
    }

    #[test]
    fn the_build_needs_exactly_the_audio_headers_beyond_the_toolchain() {
        assert_eq!(need_names(BUILD), ["gcc", "pkg-config", "libasound2-dev", "libjack-jackd2-dev"]);
    }
}
