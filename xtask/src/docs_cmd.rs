//! `cargo xtask docs`: docs/validation.md's generated tables and figures,
//! rewritten by the tests that measure them.
//!
//! Each of those tests renders its part of the doc and, in a normal run, fails
//! when the doc says otherwise; with `STRUCK_WRITE_DOCS=1` it writes its part
//! there instead (engine/tests/support/validation_doc.rs). This runs exactly
//! those tests with the variable set.

use std::process::Command;

use anyhow::Result;

use crate::util::{cargo, run};

/// The tests that write docs/validation.md: (package, test target, the tests).
pub const WRITERS: [(&str, &str, &[&str]); 4] = [
    ("struck-tests", "reference_cases", &["the_table_of_the_reference_cases"]),
    ("struck-engine", "body_physics", &["report_table"]),
    (
        "struck-engine",
        "body",
        &[
            "the_treble_falls_away_as_a_recorded_grands_and_its_knock_stays_in_bounds",
            "a_crescendo_never_dips_on_any_key_of_any_instrument",
            "nothing_comes_out_below_20_hz",
            "a_sustained_middle_note_is_heard_in_stereo_and_survives_mono",
            "each_partial_decays_at_its_own_rate_through_the_body",
            "the_loudest_touch_peaks_under_minus_1_dbfs_through_the_microphones",
            "a_held_note_decays_fast_then_slowly",
            "neighbouring_keys_ring_alike_at_every_touch",
            "every_instrument_survives_mono_from_every_perspective",
        ],
    ),
    (
        "struck-engine",
        "coupling",
        &[
            "the_sustain_pedal_lets_the_other_strings_ring_with_a_held_note",
            "after_a_staccato_note_the_undamped_treble_rings_on_at_its_own_pitch",
            "after_a_staccato_forte_note_the_undamped_treble_answers_at_more_than_minus_70_db",
            "the_bass_at_forte_grows_components_at_sums_of_its_partials",
            "una_corda_shifts_the_action_quieter_and_darker_and_half_way_between",
        ],
    ),
];

/// The `cargo test` command line for one test target's writers.
pub fn command(package: &str, test: &str, names: &[&str]) -> Command {
    let mut command = Command::new(cargo());
    command.args(["test", "-p", package, "--test", test, "--", "--exact"]).args(names).env(WRITE, "1");
    command
}

/// The variable that turns the tests' checks of the doc into writes.
pub const WRITE: &str = "STRUCK_WRITE_DOCS";

pub fn docs() -> Result<()> {
    for (package, test, names) in WRITERS {
        run(&mut command(package, test, names))?;
    }
    println!("docs/validation.md written from the tests (git diff shows what changed)");
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_writer_names_a_test_that_is_there() {
        let root = crate::util::workspace_root();
        for (package, test, names) in WRITERS {
            let dir = match package {
                "struck-engine" => "engine",
                "struck-lab" => "lab",
                "struck-tests" => "tests",
                other => panic!("{other}"),
            };
            let source = std::fs::read_to_string(root.join(dir).join("tests").join(format!("{test}.rs"))).unwrap();
            for name in names {
                assert!(source.contains(&format!("fn {name}()")), "{test}.rs has no {name}");
            }
            assert!(source.contains("validation_doc::"), "{test}.rs writes nothing");
        }
    }
}
