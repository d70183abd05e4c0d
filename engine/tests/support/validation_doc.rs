//! docs/validation.md's figures, written by the tests that measure them.
//!
//! The doc marks each generated part: `<!-- NAME -->` and `<!-- /NAME -->`
//! around a whole table (on lines of their own) or around one cell's text
//! (inline). A test renders its part and calls [`section`]: in a normal run
//! the doc must already read so (else the test fails, saying to run `cargo
//! xtask docs`); with `STRUCK_WRITE_DOCS=1` the test writes it there instead.
//! Several tests, in several processes, may write at once: each holds a lock
//! on a file in the target directory while it reads, edits and renames the
//! doc, and changes only its own part.
//!
//! The lab's and the integration crate's tests include this file too
//! (`#[path]`), so it uses only the standard library.

#![allow(dead_code)]

use std::fs;
use std::path::PathBuf;

/// The variable that turns the checks into writes.
pub const WRITE: &str = "STRUCK_WRITE_DOCS";

fn doc_path() -> PathBuf {
    // Every crate that includes this file lies one level under the workspace's root.
    PathBuf::from(env!("CARGO_MANIFEST_DIR")).join("../docs/validation.md")
}

fn markers(name: &str) -> (String, String) {
    (format!("<!-- {name} -->"), format!("<!-- /{name} -->"))
}

/// Where the text between `name`'s markers lies in `doc`.
fn span(doc: &str, name: &str) -> Result<std::ops::Range<usize>, String> {
    let (open, close) = markers(name);
    let start = doc.find(&open).ok_or_else(|| format!("docs/validation.md has no `{open}`"))? + open.len();
    let end = start + doc[start..].find(&close).ok_or_else(|| format!("docs/validation.md has no `{close}`"))?;
    if doc[start + 1..].contains(&open) {
        return Err(format!("docs/validation.md has `{open}` twice"));
    }
    Ok(start..end)
}

/// The part of docs/validation.md between `name`'s markers must read `text`
/// (written there when `STRUCK_WRITE_DOCS` is set).
pub fn section(name: &str, text: &str) {
    let path = doc_path();
    if std::env::var_os(WRITE).is_none() {
        let doc = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
        let at = span(&doc, name).unwrap_or_else(|e| panic!("{e}"));
        assert!(
            doc[at.clone()] == *text,
            "docs/validation.md's `{name}` is not what the test measures; run `cargo xtask docs`\n\
             the doc:\n{}\nmeasured:\n{text}",
            &doc[at]
        );
        return;
    }
    // One writer at a time, across threads and processes (the lock goes with its file,
    // so a killed test leaves none behind).
    let lock = fs::OpenOptions::new()
        .create(true)
        .truncate(false)
        .write(true)
        .open(PathBuf::from(env!("CARGO_TARGET_TMPDIR")).join("validation-doc.lock"))
        .expect("the lock file");
    lock.lock().expect("the lock on docs/validation.md");
    let doc = fs::read_to_string(&path).unwrap_or_else(|e| panic!("{}: {e}", path.display()));
    let at = span(&doc, name).unwrap_or_else(|e| panic!("{e}"));
    if doc[at.clone()] != *text {
        let mut new = String::with_capacity(doc.len() + text.len());
        new.push_str(&doc[..at.start]);
        new.push_str(text);
        new.push_str(&doc[at.end..]);
        let temporary = path.with_extension(format!("md.{}.tmp", std::process::id()));
        fs::write(&temporary, new).expect("the new docs/validation.md");
        fs::rename(&temporary, &path).expect("docs/validation.md replaced");
    }
    lock.unlock().expect("the lock released");
}

/// A whole table: its markers stand on lines of their own, a blank line on
/// either side of the table.
pub fn table(name: &str, header: &[&str], rows: &[Vec<String>]) {
    let line = |cells: &[String]| format!("| {} |\n", cells.join(" | "));
    let mut text = String::from("\n\n");
    text += &line(&header.iter().map(|h| h.to_string()).collect::<Vec<_>>());
    text += &line(&vec!["---".to_string(); header.len()]);
    for row in rows {
        assert_eq!(row.len(), header.len(), "{name}: {row:?}");
        text += &line(row);
    }
    text += "\n";
    section(name, &text);
}

/// A signed percentage to `decimals` places, "+1.44 %"; -0 is written 0.
pub fn percent(ratio_minus_one: f64, decimals: usize) -> String {
    let v = 100.0 * ratio_minus_one;
    let s = format!("{v:+.decimals$}");
    let zero = format!("{:.decimals$}", 0.0);
    if s[1..] == zero { format!("{zero} %") } else { format!("{s} %") }
}

/// One row of a table, written by the test that checks it: its markers stand
/// in the row's first and last cells, `| <!-- NAME -->target | measured |
/// met<!-- /NAME --> |`, so the row's other cells may come from other tests or
/// from the doc itself.
pub fn row(name: &str, cells: &[String]) {
    section(name, &cells.join(" | "));
}
