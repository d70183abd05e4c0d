//! The `struck` command line: help and version, what `struck strike` writes, and
//! how it refuses bad input (exit status 2, one line naming the field, nothing
//! written), one test per rule.

use std::path::{Path, PathBuf};

use serde_json::Value;
use struck_tests::{Csv, SANTOOR_CASE, read_json, stderr, stdout, struck};

/// A case file in a fresh directory, and an output directory beside it.
struct Scratch {
    dir: tempfile::TempDir,
}

impl Scratch {
    fn with_case(text: &str) -> Self {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("case.json"), text).unwrap();
        Self { dir }
    }

    fn case(&self) -> PathBuf {
        self.dir.path().join("case.json")
    }

    fn out(&self) -> PathBuf {
        self.dir.path().join("out")
    }

    fn strike(&self, extra: &[&str]) -> std::process::Output {
        let (case, out) = (self.case(), self.out());
        let mut args = vec!["strike", case.to_str().unwrap(), "--out", out.to_str().unwrap()];
        args.extend_from_slice(extra);
        struck(&args)
    }
}

fn edited(edit: impl FnOnce(&mut Value)) -> String {
    let mut case: Value = serde_json::from_str(SANTOOR_CASE).unwrap();
    edit(&mut case);
    case.to_string()
}

/// The case is refused: status 2, a single line on stderr that names `field`, and
/// nothing written.
fn assert_refused(scratch: &Scratch, extra: &[&str], field: &str) {
    let out = scratch.strike(extra);
    let message = stderr(&out);
    assert_eq!(out.status.code(), Some(2), "{message}");
    assert_eq!(message.lines().count(), 1, "one line: {message:?}");
    assert!(message.contains(field), "{message:?} should name {field}");
    assert!(message.starts_with("struck strike: "), "{message:?}");
    assert!(!scratch.out().exists(), "nothing may be written");
    assert!(stdout(&out).is_empty());
}

fn refuses(text: &str, field: &str) {
    assert_refused(&Scratch::with_case(text), &[], field);
}

#[test]
fn help_explains_every_subcommand() {
    let out = struck(&["--help"]);
    assert!(out.status.success());
    let help = stdout(&out);
    for expected in ["strike", "bench", "physics", "--version"] {
        assert!(help.contains(expected), "{help}");
    }
    let strike = stdout(&struck(&["strike", "--help"]));
    for expected in ["--out", "--wav", "--wav-gain-db", "--set", "metrics.json", "trace.csv", "exit status 2"] {
        assert!(strike.contains(expected), "strike --help lacks {expected}: {strike}");
    }
    let bench = stdout(&struck(&["bench", "--help"]));
    assert!(bench.contains("mode-samples") || bench.contains("modes"), "{bench}");
    // No subcommand starts the standalone (tested in plugin_host.rs); its options are in the help.
    assert!(help.contains("render") && help.contains("--backend"), "{help}");
}

#[test]
fn version_is_the_package_version() {
    let out = struck(&["--version"]);
    assert!(out.status.success());
    assert_eq!(stdout(&out).trim(), format!("struck {}", env!("CARGO_PKG_VERSION")));
}

#[test]
fn strike_writes_metrics_and_a_trace_row_per_sample() {
    let s = Scratch::with_case(SANTOOR_CASE);
    let out = s.strike(&[]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).contains("metrics.json"));
    let metrics = read_json(&s.out().join("metrics.json"));
    for field in [
        "contacts",
        "contact_count",
        "raw_contact_count",
        "contact_time_s",
        "peak_contact_force_n",
        "peak_contact_force_time_s",
        "rebound_speed_m_s",
        "bridge_force_rms_n",
        "spectral_centroid_hz",
        "partials",
        "string",
    ] {
        assert!(metrics.get(field).is_some(), "metrics.json lacks {field}");
    }
    for field in ["tension_n", "mass_per_length_kg_m", "inharmonicity", "f0_hz", "mode_count", "impedance_ns_m"] {
        assert!(metrics["string"].get(field).is_some(), "metrics.json string lacks {field}");
    }
    assert_eq!(metrics["contact_count"], metrics["contacts"].as_array().unwrap().len());
    // sqrt(T mu) of the santoor string, 0.543 N s/m (Euphonics 12.2.2).
    assert!((metrics["string"]["impedance_ns_m"].as_f64().unwrap() - 0.543).abs() < 0.002);

    let trace = Csv::read(&s.out().join("trace.csv"));
    assert_eq!(trace.header, ["t_s", "contact_force_n", "bridge_force_n", "exciter_position_m", "string_position_m"]);
    assert_eq!(trace.len(), 4800);
    let t = trace.numbers("t_s");
    assert_eq!(t[0], 0.0);
    assert!((t[4799] - 4799.0 / 48_000.0).abs() < 1e-15);
    // The hammer meets the string where it is and pushes it along +y; the first
    // pulse at the bridge is positive.
    let (hammer, string) = (trace.numbers("exciter_position_m"), trace.numbers("string_position_m"));
    assert_eq!(hammer[0], string[0]);
    assert!(hammer[1] > 0.0 && string[1] > 0.0);
    let bridge = trace.numbers("bridge_force_n");
    let first_pulse = bridge.iter().cloned().find(|b| b.abs() > 0.1).unwrap();
    assert!(first_pulse > 0.0);
}

#[test]
fn a_pluck_leaves_the_exciter_column_empty() {
    let s = Scratch::with_case(&edited(|c| {
        c["exciter"] = serde_json::json!({ "kind": "pluck", "displacement_m": 0.002, "position": 0.4 });
    }));
    let out = s.strike(&["--quiet"]);
    assert!(out.status.success(), "{}", stderr(&out));
    assert!(stdout(&out).is_empty());
    let trace = Csv::read(&s.out().join("trace.csv"));
    let exciter = trace.header.iter().position(|h| h == "exciter_position_m").unwrap();
    assert!(trace.columns[exciter].iter().all(Option::is_none));
    // Released from the triangle: the plucked point starts near 2 mm.
    let y0 = trace.numbers("string_position_m")[0];
    assert!((y0 - 0.002).abs() < 0.0001, "{y0}");
    let metrics = read_json(&s.out().join("metrics.json"));
    assert_eq!(metrics["contacts"], serde_json::json!([]));
    assert_eq!(metrics["contact_count"], 0);
}

#[test]
fn set_changes_a_field_before_the_case_is_checked() {
    let s = Scratch::with_case(SANTOOR_CASE);
    assert!(s.strike(&["--quiet"]).status.success());
    let soft = read_json(&s.out().join("metrics.json"))["bridge_force_rms_n"].as_f64().unwrap();
    assert!(s.strike(&["--quiet", "--set", "exciter.speed_m_s=2.5"]).status.success());
    let loud = read_json(&s.out().join("metrics.json"))["bridge_force_rms_n"].as_f64().unwrap();
    // A linear spring: everything scales with the speed.
    assert!((loud / soft - 2.5).abs() < 1e-6, "{loud} / {soft}");
    // Several, and a string value.
    let out = s.strike(&[
        "--quiet",
        "--set",
        "exciter.kind=pluck",
        "--set",
        "exciter={\"kind\":\"pluck\",\"displacement_m\":0.001,\"position\":0.2}",
    ]);
    assert!(out.status.success(), "{}", stderr(&out));
    // The exciter really became a 1 mm pluck: no contact, released from 1 mm.
    assert_eq!(read_json(&s.out().join("metrics.json"))["contact_count"], 0);
    let y0 = Csv::read(&s.out().join("trace.csv")).numbers("string_position_m")[0];
    assert!((y0 - 0.001).abs() < 0.0001, "{y0}");
}

#[test]
fn wav_holds_the_bridge_force_as_32_bit_float() {
    let s = Scratch::with_case(SANTOOR_CASE);
    let wav = s.dir.path().join("strike.wav");
    let out = s.strike(&["--wav", wav.to_str().unwrap(), "--wav-gain-db", "0"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let mut reader = hound::WavReader::open(&wav).unwrap();
    let spec = reader.spec();
    assert_eq!((spec.channels, spec.sample_rate, spec.bits_per_sample), (1, 48_000, 32));
    assert_eq!(spec.sample_format, hound::SampleFormat::Float);
    let samples: Vec<f32> = reader.samples::<f32>().map(Result::unwrap).collect();
    let bridge = Csv::read(&s.out().join("trace.csv")).numbers("bridge_force_n");
    assert_eq!(samples.len(), bridge.len());
    // At 0 dB, 1 N is full scale.
    for (a, b) in samples.iter().zip(&bridge) {
        assert_eq!(*a, *b as f32);
    }
    // Without a gain the WAV is normalised to -1 dBFS.
    assert!(s.strike(&["--quiet", "--wav", wav.to_str().unwrap()]).status.success());
    let peak = hound::WavReader::open(&wav).unwrap().samples::<f32>().map(|v| v.unwrap().abs()).fold(0.0, f32::max);
    assert!((20.0 * peak.log10() + 1.0).abs() < 0.01, "{peak}");
}

#[test]
fn writing_is_all_or_nothing() {
    let s = Scratch::with_case(SANTOOR_CASE);
    assert!(s.strike(&["--quiet"]).status.success());
    let before = std::fs::read(s.out().join("metrics.json")).unwrap();
    // A refused case leaves an existing output untouched.
    assert_eq!(s.strike(&["--set", "exciter.position=2"]).status.code(), Some(2));
    assert_eq!(std::fs::read(s.out().join("metrics.json")).unwrap(), before);
    // No temporary files are left beside the results.
    let names: Vec<String> =
        std::fs::read_dir(s.out()).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    assert_eq!(names.len(), 2, "{names:?}");
    // An output folder that is a file: refused (status 2, one line), the file kept.
    let blocked = s.dir.path().join("blocked");
    std::fs::write(&blocked, "a file where a directory should be").unwrap();
    let out = struck(&["strike", s.case().to_str().unwrap(), "--out", blocked.to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert_eq!(stderr(&out).lines().count(), 1, "{}", stderr(&out));
    assert!(stderr(&out).contains("is not a folder"), "{}", stderr(&out));
    assert_eq!(std::fs::read_to_string(&blocked).unwrap(), "a file where a directory should be");
}

// ---- refusals, one per rule -------------------------------------------------

#[test]
fn refuses_a_missing_case_file() {
    let s = Scratch::with_case("{}");
    let missing = s.dir.path().join("nope.json");
    let out = struck(&["strike", missing.to_str().unwrap(), "--out", s.out().to_str().unwrap()]);
    assert_eq!(out.status.code(), Some(2));
    assert!(stderr(&out).contains("nope.json") && stderr(&out).contains("cannot read"));
    assert!(!s.out().exists());
}

#[test]
fn refuses_text_that_is_not_json() {
    refuses("{ \"sample_rate_hz\": 48000,", "not valid JSON");
}

#[test]
fn refuses_json_that_is_not_an_object() {
    refuses("[1, 2, 3]", "case: must be an object");
}

#[test]
fn refuses_a_misspelt_field() {
    refuses(&edited(|c| c["string"]["lenght_m"] = 0.4.into()), "string.lenght_m: unknown field");
    refuses(&edited(|c| c["sampel_rate_hz"] = 1.into()), "sampel_rate_hz: unknown field");
    refuses(&edited(|c| c["exciter"]["mass_g"] = 1.into()), "exciter.mass_g: unknown field");
}

#[test]
fn refuses_a_missing_field() {
    refuses(
        &edited(|c| c["string"].as_object_mut().unwrap().remove("length_m").map(drop).unwrap()),
        "string.length_m: missing",
    );
    refuses(
        &edited(|c| c["exciter"].as_object_mut().unwrap().remove("speed_m_s").map(drop).unwrap()),
        "exciter.speed_m_s: missing",
    );
}

#[test]
fn refuses_a_field_of_the_wrong_type() {
    refuses(&edited(|c| c["string"]["length_m"] = "long".into()), "string.length_m: must be a number");
}

#[test]
fn refuses_both_f1_and_tension() {
    refuses(&edited(|c| c["string"]["tension_n"] = 190.0.into()), "string.tension_n: contradicts string.f1_hz");
}

#[test]
fn refuses_neither_f1_nor_tension() {
    refuses(
        &edited(|c| c["string"].as_object_mut().unwrap().remove("f1_hz").map(drop).unwrap()),
        "string.f1_hz: missing",
    );
}

#[test]
fn refuses_the_mass_given_two_ways() {
    refuses(&edited(|c| c["string"]["mass_per_length_kg_m"] = 0.0015.into()), "string.density_kg_m3: contradicts");
}

#[test]
fn refuses_a_density_without_a_diameter() {
    refuses(
        &edited(|c| {
            let s = c["string"].as_object_mut().unwrap();
            s.remove("diameter_m");
            s.remove("youngs_modulus_pa");
        }),
        "string.density_kg_m3: needs string.diameter_m",
    );
}

#[test]
fn refuses_both_inharmonicity_and_youngs_modulus() {
    refuses(
        &edited(|c| c["string"]["inharmonicity"] = 2e-4.into()),
        "string.youngs_modulus_pa: contradicts string.inharmonicity",
    );
}

#[test]
fn refuses_youngs_modulus_without_a_diameter() {
    refuses(
        &edited(|c| {
            let s = c["string"].as_object_mut().unwrap();
            s.remove("diameter_m");
            s.remove("density_kg_m3");
            s.insert("mass_per_length_kg_m".into(), 0.0015.into());
        }),
        "string.youngs_modulus_pa: needs",
    );
}

#[test]
fn refuses_a_core_diameter_without_youngs_modulus() {
    refuses(
        &edited(|c| {
            let s = c["string"].as_object_mut().unwrap();
            s.remove("youngs_modulus_pa");
            s.insert("core_diameter_m".into(), 0.0003.into());
        }),
        "string.core_diameter_m",
    );
}

#[test]
fn refuses_a_string_too_stiff_to_tune() {
    // A 2 cm steel bar 0.4 m long rings above 100 Hz from its bending alone.
    refuses(
        &edited(|c| {
            c["string"]["diameter_m"] = 0.02.into();
            c["string"]["f1_hz"] = 100.0.into();
        }),
        "string.f1_hz: the string is too stiff",
    );
}

#[test]
fn refuses_negative_and_zero_quantities() {
    refuses(&edited(|c| c["string"]["length_m"] = (-0.4).into()), "string.length_m: must be positive");
    refuses(&edited(|c| c["exciter"]["mass_kg"] = (-0.001).into()), "exciter.mass_kg: must be positive");
    refuses(&edited(|c| c["exciter"]["stiffness"] = 0.into()), "exciter.stiffness: must be positive");
    refuses(&edited(|c| c["exciter"]["speed_m_s"] = 0.into()), "exciter.speed_m_s: must be positive");
}

#[test]
fn refuses_a_position_outside_the_string() {
    refuses(&edited(|c| c["exciter"]["position"] = 1.0.into()), "exciter.position: must lie strictly between 0 and 1");
    refuses(&edited(|c| c["exciter"]["position"] = 0.into()), "exciter.position");
    refuses(
        &edited(|c| c["exciter"] = serde_json::json!({ "kind": "pluck", "displacement_m": 0.002, "position": -0.1 })),
        "exciter.position",
    );
}

#[test]
fn refuses_a_felt_exponent_below_one() {
    refuses(&edited(|c| c["exciter"]["exponent"] = 0.9.into()), "exciter.exponent: must lie between 1 and");
}

#[test]
fn refuses_a_mode_grid_with_no_modes() {
    refuses(
        &edited(|c| c["string"]["max_frequency_hz"] = 300.0.into()),
        "string.max_frequency_hz: the mode grid is empty",
    );
}

#[test]
fn refuses_a_cut_off_above_nyquist() {
    refuses(
        &edited(|c| c["string"]["max_frequency_hz"] = 30_000.0.into()),
        "string.max_frequency_hz: must not exceed the Nyquist",
    );
}

#[test]
fn refuses_an_overdamped_or_empty_q() {
    refuses(&edited(|c| c["string"]["q"] = 0.5.into()), "string.q: must be a number greater than 0.5");
    refuses(&edited(|c| c["string"]["q"] = serde_json::json!([])), "string.q: an empty list");
    refuses(&edited(|c| c["string"]["q"] = serde_json::json!([1000, -3])), "string.q[1]");
}

#[test]
fn refuses_loss_parameters_beside_a_q() {
    refuses(
        &edited(|c| c["string"]["internal_loss_factor"] = 1e-4.into()),
        "string.internal_loss_factor: contradicts string.q",
    );
}

#[test]
fn refuses_a_sample_rate_or_duration_out_of_range() {
    refuses(&edited(|c| c["sample_rate_hz"] = 100.into()), "sample_rate_hz: must lie between");
    refuses(&edited(|c| c["duration_s"] = 0.into()), "duration_s: must be positive");
    refuses(&edited(|c| c["duration_s"] = 3600.into()), "duration_s: must be at most");
}

#[test]
fn refuses_an_unknown_exciter_kind() {
    refuses(&edited(|c| c["exciter"]["kind"] = "bow".into()), "exciter.kind: unknown kind \"bow\"");
}

#[test]
fn refuses_fields_of_another_kind_of_exciter() {
    refuses(&edited(|c| c["exciter"]["kind"] = "tangent".into()), "unknown field");
}

#[test]
fn refuses_a_tangent_without_a_displacement() {
    refuses(
        &edited(|c| c["exciter"] = serde_json::json!({ "kind": "tangent", "speed_m_s": 0.5 })),
        "exciter.displacement_m: missing",
    );
}

#[test]
fn refuses_a_felt_hysteresis_out_of_its_range() {
    refuses(&edited(|c| c["exciter"]["hysteresis"] = 0.99.into()), "exciter.hysteresis: must be an object");
    refuses(
        &edited(|c| c["exciter"]["hysteresis"] = serde_json::json!({"epsilon": 1.5, "tau_s": 1e-5})),
        "exciter.hysteresis.epsilon",
    );
    refuses(
        &edited(|c| c["exciter"]["hysteresis"] = serde_json::json!({"epsilon": 0.2, "tau_s": 0.0})),
        "exciter.hysteresis.tau_s",
    );
}

#[test]
fn refuses_a_malformed_set() {
    let s = Scratch::with_case(SANTOOR_CASE);
    assert_refused(&s, &["--set", "exciter.speed_m_s"], "--set exciter.speed_m_s: expected path=value");
    assert_refused(&s, &["--set", "string.nothing.here=1"], "string.nothing does not exist");
    assert_refused(&s, &["--set", "exciter.speed_m_s=-3"], "exciter.speed_m_s: must be positive");
}

#[test]
fn refuses_a_non_finite_wav_gain() {
    let s = Scratch::with_case(SANTOOR_CASE);
    let wav = s.dir.path().join("x.wav");
    assert_refused(&s, &["--wav", wav.to_str().unwrap(), "--wav-gain-db", "inf"], "--wav-gain-db");
    assert!(!Path::new(&wav).exists());
}

/// `struck bench --json`: one JSON object on stdout, every figure both under its
/// dotted name and nested. Speeds are not asserted (a shared machine varies).
#[test]
fn bench_json_holds_every_figure_flat_and_nested() {
    let out = struck(&["bench", "--json", "--seconds", "0.05"]);
    assert!(out.status.success(), "{}", stderr(&out));
    let text = stdout(&out);
    let report: Value = serde_json::from_str(&text).unwrap_or_else(|e| panic!("not one JSON value ({e}): {text}"));
    assert!(report.is_object(), "{text}");

    // Every figure found both ways, and the same both ways.
    let figure = |dotted: &str| -> Value {
        let flat = report.get(dotted).unwrap_or_else(|| panic!("no flat key {dotted:?}: {text}"));
        let pointer = format!("/{}", dotted.replace('.', "/"));
        let nested = report.pointer(&pointer).unwrap_or_else(|| panic!("no nested {pointer}: {text}"));
        assert_eq!(flat, nested, "{dotted}");
        flat.clone()
    };
    let number = |dotted: &str| -> f64 {
        let x = figure(dotted).as_f64().unwrap_or_else(|| panic!("{dotted} is not a number: {text}"));
        assert!(x.is_finite() && x >= 0.0, "{dotted} = {x}");
        x
    };
    // Figures that are work done in a measured time: above zero.
    for dotted in [
        "full_keyboard.load_fraction",
        "full_keyboard.worst_block_fraction",
        "full_keyboard.chord10_block_fraction",
        "full_keyboard.modes",
        "full_keyboard.running_modes_mean",
        "full_keyboard_all.load_fraction",
        "full_keyboard_all.worst_block_fraction",
        "full_keyboard_all.running_modes_mean",
        "full_keyboard_all.chord20_block_fraction",
        "chord10.worst_block_fraction",
        "chord20.worst_block_fraction",
        "kernel.ns_per_mode_sample",
        "kernel.complex.ns_per_mode_sample",
        "kernel.complex.fraction_of_fma_probe",
        "kernel.fraction_of_fma_probe",
        "kernel.fma_probe_per_s",
        "chord32.realtime_factor",
        "chord32.keys",
        "after_release.worst_block_fraction",
        "contact.mode_steps_per_s",
        "contact.modes",
    ] {
        assert!(number(dotted) > 0.0, "{dotted} should be positive: {text}");
    }
    for dotted in ["idle.load_fraction", "after_release.load_fraction"] {
        number(dotted);
    }
    // One thread only: no second core's figures.
    for gone in ["full_keyboard_all_helper", "chord32.realtime_factor_threads", "chord32.core_round_trip_ns"] {
        assert!(
            report.get(gone).is_none() && report.pointer(&format!("/{}", gone.replace('.', "/"))).is_none(),
            "{gone}: {text}"
        );
    }
    assert!(number("full_keyboard.running_modes_mean") <= number("full_keyboard.modes"));
    assert!(number("full_keyboard.worst_block_fraction") >= number("full_keyboard.chord10_block_fraction"));
    assert!(number("full_keyboard.worst_block_fraction") >= number("full_keyboard.chord20_block_fraction"));
    assert_eq!(figure("chord20.worst_block_fraction"), figure("full_keyboard_all.chord20_block_fraction"));
    assert_eq!(figure("chord10.worst_block_fraction"), figure("full_keyboard_all.chord10_block_fraction"));
    assert_eq!(report["chord20"]["keys"], 20);
    let silent = figure("after_release.silent_after_s");
    assert!(silent.is_null() || silent.as_f64().is_some_and(|s| s > 0.0), "{silent}");
    assert_eq!(report["sample_rate_hz"], 48_000);
    assert_eq!(report["block"], 64);
    assert_eq!(report["threads"], 1);
    assert_eq!(report["runs"], 3);
    for name in ["cpu", "simd"] {
        let value = report[name].as_str().unwrap_or_else(|| panic!("{name} is not a string: {text}"));
        assert!(!value.trim().is_empty(), "{name} is empty");
    }

    // Each goal: its figure, the bound, and whether it is met (not which).
    let goals = report["goals"].as_object().unwrap_or_else(|| panic!("no goals: {text}"));
    for goal in [
        "full_keyboard_load",
        "full_keyboard_all_load",
        "worst_block",
        "kernel",
        "chord10_block",
        "chord20_block",
        "chord32",
        "idle",
        "after_release_load",
    ] {
        assert!(goals.contains_key(goal), "no goal {goal}: {text}");
    }
    for gone in ["chord32_threads", "chord32_threads_identical"] {
        assert!(!goals.contains_key(gone), "goal {gone} is withdrawn: {text}");
    }
    for (name, goal) in goals {
        assert!(goal["pass"].is_boolean(), "goals.{name}.pass: {goal}");
        assert!(goal["value"].as_f64().is_some_and(f64::is_finite), "goals.{name}.value: {goal}");
        assert_eq!(figure(&format!("goals.{name}.pass")), goal["pass"]);
    }
    assert_eq!(figure("goals.kernel.value"), figure("kernel.fraction_of_fma_probe"));
    // Every instrument's build at every rate, first, again and voiced from
    // nothing, each a goal.
    for kind in ["piano", "fortepiano", "santoor", "dulcimer", "cimbalom", "clavichord", "harpsichord"] {
        for rate in [44_100, 48_000, 96_000, 192_000] {
            for (figure_name, goal) in [("first_s", "first"), ("again_s", "again"), ("unvoiced_s", "unvoiced")] {
                assert!(number(&format!("builds.{kind}.{rate}.{figure_name}")) > 0.0, "{kind} at {rate}: {text}");
                let name = format!("build_{kind}_{rate}_{goal}");
                assert_eq!(
                    figure(&format!("goals.{name}.value")),
                    figure(&format!("builds.{kind}.{rate}.{figure_name}"))
                );
            }
        }
    }
    assert_eq!(figure("goals.chord20_block.value"), figure("chord20.worst_block_fraction"));
    let met = goals.values().filter(|g| g["pass"] == true).count();
    assert_eq!(report["goals_met"], met);
    assert_eq!(report["all_goals_met"], met == goals.len());
}

#[test]
fn bench_refuses_bad_arguments_with_one_line() {
    for (args, named) in [
        (&["--seconds", "-1"][..], "--seconds"),
        (&["--seconds", "nan"], "--seconds"),
        (&["--seconds", "0"], "--seconds"),
        (&["--seconds", "601"], "--seconds"),
        (&["--seconds", "inf", "--json"], "--seconds"),
        (&["--runs", "0"], "--runs"),
    ] {
        let out = struck(&[&["bench"][..], args].concat());
        let message = stderr(&out);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {message}");
        assert_eq!(message.lines().count(), 1, "{args:?}: one line: {message:?}");
        assert!(message.starts_with("struck bench: ") && message.contains(named), "{args:?}: {message:?}");
        assert!(stdout(&out).is_empty(), "{args:?}");
    }
}
