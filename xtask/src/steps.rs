//! A list of named steps run in order: a header before each, a stop at the
//! first failure, and a summary with each step's duration at the end.

use std::fmt::Write as _;
use std::time::{Duration, Instant};

use anyhow::{Result, bail};

/// One step of a task.
pub struct Step<'a> {
    /// Short and stable, for `--only`, `--skip` and `--from`.
    pub name: &'static str,
    /// One line: what it does and why.
    pub what: String,
    pub run: Box<dyn Fn() -> Result<()> + 'a>,
}

impl<'a> Step<'a> {
    pub fn new(name: &'static str, what: impl Into<String>, run: impl Fn() -> Result<()> + 'a) -> Self {
        Self { name, what: what.into(), run: Box::new(run) }
    }
}

/// What became of a step.
#[derive(Debug, Clone, PartialEq)]
pub enum Outcome {
    Passed(Duration),
    Failed(Duration, String),
    /// Left out by the selection.
    Skipped,
    /// Not reached: an earlier step failed.
    NotRun,
}

/// Which steps to run, from the command line.
#[derive(Debug, Default, Clone, PartialEq, Eq)]
pub struct Selection {
    pub only: Vec<String>,
    pub skip: Vec<String>,
    pub from: Option<String>,
}

impl Selection {
    /// Which of `names` to run; an unknown name is an error that lists the known ones.
    pub fn choose(&self, names: &[&str]) -> Result<Vec<bool>> {
        let known = |n: &String| -> Result<()> {
            if names.contains(&n.as_str()) {
                Ok(())
            } else {
                bail!("no step named '{n}'; the steps are: {}", names.join(", "))
            }
        };
        self.only.iter().chain(&self.skip).chain(&self.from).try_for_each(known)?;
        let start = self.from.as_ref().map_or(0, |f| names.iter().position(|n| n == f).unwrap_or(0));
        Ok(names
            .iter()
            .enumerate()
            .map(|(i, name)| {
                i >= start
                    && (self.only.is_empty() || self.only.iter().any(|o| o == name))
                    && !self.skip.iter().any(|s| s == name)
            })
            .collect())
    }
}

/// Run the chosen steps in order, stopping at the first failure.
pub fn run(task: &str, steps: &[Step<'_>], chosen: &[bool]) -> Vec<Outcome> {
    let total = chosen.iter().filter(|c| **c).count();
    let mut outcomes = Vec::with_capacity(steps.len());
    let mut failed = false;
    let mut index = 0;
    for (step, &chose) in steps.iter().zip(chosen) {
        if !chose {
            outcomes.push(Outcome::Skipped);
            continue;
        }
        if failed {
            outcomes.push(Outcome::NotRun);
            continue;
        }
        index += 1;
        println!("\n==> {task} [{index}/{total}] {}: {}", step.name, step.what);
        let start = Instant::now();
        let result = (step.run)();
        let elapsed = start.elapsed();
        match result {
            Ok(()) => {
                println!("==> {}: ok ({})", step.name, seconds(elapsed));
                outcomes.push(Outcome::Passed(elapsed));
            }
            Err(error) => {
                let message = format!("{error:#}");
                eprintln!("==> {}: FAILED ({}): {message}", step.name, seconds(elapsed));
                outcomes.push(Outcome::Failed(elapsed, message));
                failed = true;
            }
        }
    }
    outcomes
}

fn seconds(d: Duration) -> String {
    let s = d.as_secs_f64();
    if s < 60.0 { format!("{s:.1} s") } else { format!("{}m{:04.1}s", (s / 60.0).floor(), s % 60.0) }
}

/// The summary table, and a closing line counting the steps
/// ("steps: 4 passed, 1 failed, 1 skipped").
pub fn summary(task: &str, names: &[&str], outcomes: &[Outcome]) -> String {
    let width = names.iter().map(|n| n.len()).max().unwrap_or(0);
    let mut out = format!("\n==> {task}: summary\n");
    let mut total = Duration::ZERO;
    let (mut passed, mut failed, mut skipped) = (0, 0, 0);
    for (name, outcome) in names.iter().zip(outcomes) {
        let (status, time) = match outcome {
            Outcome::Passed(d) => {
                passed += 1;
                total += *d;
                ("ok", seconds(*d))
            }
            Outcome::Failed(d, _) => {
                failed += 1;
                total += *d;
                ("FAILED", seconds(*d))
            }
            Outcome::Skipped => {
                skipped += 1;
                ("skipped", String::new())
            }
            Outcome::NotRun => {
                skipped += 1;
                ("not run", String::new())
            }
        };
        let line = format!("  {name:<width$}  {status:<7}  {time:>9}");
        let _ = writeln!(out, "{}", line.trim_end());
    }
    let _ = writeln!(out, "  {:<width$}  {:<7}  {:>9}", "total", "", seconds(total));
    if let Some((name, Outcome::Failed(_, message))) =
        names.iter().zip(outcomes).find(|(_, o)| matches!(o, Outcome::Failed(..)))
    {
        let _ = writeln!(out, "{task} failed at step '{name}': {message}");
    }
    let _ = write!(out, "steps: {passed} passed, {failed} failed");
    if skipped > 0 {
        let _ = write!(out, ", {skipped} skipped");
    }
    out
}

/// Whether every step that was chosen passed.
pub fn all_passed(outcomes: &[Outcome]) -> bool {
    outcomes.iter().all(|o| matches!(o, Outcome::Passed(_) | Outcome::Skipped))
}

#[cfg(test)]
mod tests {
    use std::cell::RefCell;

    use super::*;

    const NAMES: &[&str] = &["packages", "bundle", "cargo-test", "pedalboard"];

    fn selection(only: &[&str], skip: &[&str], from: Option<&str>) -> Selection {
        Selection {
            only: only.iter().map(|s| s.to_string()).collect(),
            skip: skip.iter().map(|s| s.to_string()).collect(),
            from: from.map(str::to_string),
        }
    }

    #[test]
    fn everything_runs_by_default() {
        assert_eq!(Selection::default().choose(NAMES).unwrap(), [true; 4]);
    }

    #[test]
    fn only_skip_and_from_combine() {
        assert_eq!(selection(&["bundle", "pedalboard"], &[], None).choose(NAMES).unwrap(), [false, true, false, true]);
        assert_eq!(selection(&[], &["packages"], None).choose(NAMES).unwrap(), [false, true, true, true]);
        assert_eq!(selection(&[], &[], Some("cargo-test")).choose(NAMES).unwrap(), [false, false, true, true]);
        assert_eq!(selection(&[], &["pedalboard"], Some("bundle")).choose(NAMES).unwrap(), [false, true, true, false]);
    }

    #[test]
    fn unknown_step_names_are_refused_with_the_list() {
        let error = selection(&["bundel"], &[], None).choose(NAMES).unwrap_err().to_string();
        assert!(error.contains("'bundel'") && error.contains("packages, bundle, cargo-test, pedalboard"), "{error}");
        assert!(selection(&[], &["nope"], None).choose(NAMES).is_err());
        assert!(selection(&[], &[], Some("nope")).choose(NAMES).is_err());
    }

    #[test]
    fn steps_stop_at_the_first_failure() {
        let ran = RefCell::new(Vec::new());
        let step = |name: &'static str, ok: bool| {
            let ran = &ran;
            Step::new(name, "a step", move || {
                ran.borrow_mut().push(name);
                if ok { Ok(()) } else { bail!("{name} broke") }
            })
        };
        let steps = [step("packages", true), step("bundle", false), step("cargo-test", true), step("pedalboard", true)];
        let outcomes = run("test", &steps, &[true, true, true, false]);
        assert_eq!(*ran.borrow(), ["packages", "bundle"]);
        assert!(matches!(outcomes[0], Outcome::Passed(_)));
        assert!(matches!(&outcomes[1], Outcome::Failed(_, m) if m == "bundle broke"));
        assert_eq!(outcomes[2], Outcome::NotRun);
        assert_eq!(outcomes[3], Outcome::Skipped);
        assert!(!all_passed(&outcomes));

        let text = summary("test", NAMES, &outcomes);
        assert!(text.contains("test failed at step 'bundle': bundle broke"), "{text}");
        assert!(text.ends_with("steps: 1 passed, 1 failed, 2 skipped"), "{text}");
        assert!(text.contains("cargo-test  not run\n"), "{text}");
    }

    #[test]
    fn a_clean_run_passes_and_says_so() {
        let steps: Vec<Step> = NAMES.iter().map(|n| Step::new(n, "fine", || Ok(()))).collect();
        let outcomes = run("test", &steps, &[true; 4]);
        assert!(all_passed(&outcomes));
        let text = summary("test", NAMES, &outcomes);
        assert!(text.ends_with("steps: 4 passed, 0 failed"), "{text}");
        assert_eq!(text.lines().filter(|l| l.contains(" ok ")).count(), 4, "{text}");
    }

    #[test]
    fn durations_read_in_seconds_or_minutes() {
        assert_eq!(seconds(Duration::from_millis(1234)), "1.2 s");
        assert_eq!(seconds(Duration::from_secs(754)), "12m34.0s");
    }
}
