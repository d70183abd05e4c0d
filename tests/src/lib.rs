//! Helpers for Struck's whole-program tests: building and running the real
//! `struck` binary, reading what it writes, and the reference cases shipped as
//! test data in `tests/data/reference`.

use std::path::{Path, PathBuf};
use std::process::{Command, Output};
use std::sync::OnceLock;

use serde_json::Value;

pub mod demo_songs;
pub mod midi_gen;

/// The directory of this crate.
pub fn crate_dir() -> &'static Path {
    Path::new(env!("CARGO_MANIFEST_DIR"))
}

/// Where the reference cases live.
pub fn reference_dir() -> PathBuf {
    crate_dir().join("data").join("reference")
}

/// The `struck` binary of the same profile and target directory as this test,
/// built once per test process (a no-op when it is up to date).
pub fn struck_binary() -> &'static Path {
    static BINARY: OnceLock<PathBuf> = OnceLock::new();
    BINARY.get_or_init(|| {
        // This test runs from <target>/<profile>/deps/<name>.
        let exe = std::env::current_exe().expect("test executable path");
        let profile_dir = exe.parent().and_then(Path::parent).expect("target/<profile>");
        let target_dir = profile_dir.parent().expect("target directory");
        let profile = profile_dir.file_name().and_then(|n| n.to_str()).expect("profile name");
        let cargo = std::env::var("CARGO").unwrap_or_else(|_| "cargo".to_string());
        let mut build = Command::new(cargo);
        build.args(["build", "--quiet", "-p", "struck", "--bin", "struck"]).env("CARGO_TARGET_DIR", target_dir);
        match profile {
            "debug" => {}
            "release" => {
                build.arg("--release");
            }
            other => {
                build.args(["--profile", other]);
            }
        }
        let status = build.current_dir(crate_dir()).status().expect("run cargo build");
        assert!(status.success(), "building the struck binary failed");
        let binary = profile_dir.join(format!("struck{}", std::env::consts::EXE_SUFFIX));
        assert!(binary.exists(), "{} was not built", binary.display());
        binary
    })
}

/// Run `struck` with arguments.
pub fn struck(args: &[&str]) -> Output {
    Command::new(struck_binary()).args(args).output().expect("run struck")
}

pub fn stdout(output: &Output) -> String {
    String::from_utf8_lossy(&output.stdout).into_owned()
}

pub fn stderr(output: &Output) -> String {
    String::from_utf8_lossy(&output.stderr).into_owned()
}

pub fn read_json(path: &Path) -> Value {
    let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    serde_json::from_str(&text).unwrap_or_else(|e| panic!("{}: {e}", path.display()))
}

/// A CSV file as a header and columns (empty fields become `None`).
pub struct Csv {
    pub header: Vec<String>,
    pub columns: Vec<Vec<Option<f64>>>,
}

impl Csv {
    pub fn read(path: &Path) -> Self {
        let text = std::fs::read_to_string(path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let mut lines = text.lines();
        let header: Vec<String> = lines.next().expect("a header").split(',').map(str::to_string).collect();
        let mut columns = vec![Vec::new(); header.len()];
        for (row, line) in lines.enumerate() {
            let fields: Vec<&str> = line.split(',').collect();
            assert_eq!(fields.len(), header.len(), "row {row} of {}", path.display());
            for (column, field) in columns.iter_mut().zip(fields) {
                column.push(if field.is_empty() {
                    None
                } else {
                    Some(field.parse().unwrap_or_else(|_| panic!("row {row}: {field:?} is not a number")))
                });
            }
        }
        Self { header, columns }
    }

    /// A column that has a number in every row.
    pub fn numbers(&self, name: &str) -> Vec<f64> {
        let i = self.header.iter().position(|h| h == name).unwrap_or_else(|| panic!("no column {name}"));
        self.columns[i].iter().map(|v| v.unwrap_or_else(|| panic!("empty field in {name}"))).collect()
    }

    pub fn len(&self) -> usize {
        self.columns.first().map_or(0, Vec::len)
    }

    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}

/// A valid case to start from: the seed's santoor string struck by its 1 g mallet.
pub const SANTOOR_CASE: &str = r#"{
  "name": "santoor-a4-at-2/5",
  "sample_rate_hz": 48000,
  "duration_s": 0.1,
  "string": {
    "length_m": 0.4,
    "f1_hz": 440.0,
    "diameter_m": 0.0005,
    "density_kg_m3": 7850.0,
    "youngs_modulus_pa": 2.0e11,
    "q": 1000.0
  },
  "exciter": {
    "kind": "hammer",
    "mass_kg": 0.001,
    "stiffness": 1.0e6,
    "exponent": 1.0,
    "speed_m_s": 1.0,
    "position": 0.4
  }
}"#;
