//! `struck strike` against the published reference cases (an independent modal
//! solver to 0.8 MHz, cross-checked by finite differences), compared the way the
//! strike-case contract says: the bridge force after a zero-phase 8th-order
//! Butterworth at 20 kHz, contacts merged across gaps under 50 us, partials from a
//! Hann window over the first 0.5 s.
//!
//! Tolerances: contact count exact; contact time, rebound and bridge-force RMS
//! within 2 %; low-passed peak contact force within 3 %; partials within 1 dB
//! (those within 60 dB of the strongest); low-passed bridge force over the first
//! 30 ms within 5 % relative RMS.

use serde_json::Value;
use struck_lab::analysis::filter::{lowpass_20k, relative_rms_error, rms};
use struck_tests::{Csv, read_json, reference_dir, stderr, struck};

fn within(what: &str, value: f64, expected: f64, tolerance: f64) {
    let error = value / expected - 1.0;
    assert!(
        error.abs() <= tolerance,
        "{what}: {value} vs {expected} ({:+.3} %, allowed {} %)",
        100.0 * error,
        100.0 * tolerance
    );
}

fn check_case(name: &str) {
    let dir = tempfile::tempdir().unwrap();
    let case = reference_dir().join(format!("{name}.json"));
    let out = struck(&["strike", case.to_str().unwrap(), "--out", dir.path().to_str().unwrap(), "--quiet"]);
    assert!(out.status.success(), "{name}: {}", stderr(&out));
    let metrics = read_json(&dir.path().join("metrics.json"));
    let trace = Csv::read(&dir.path().join("trace.csv"));
    let expected = read_json(&reference_dir().join(format!("{name}.expected.json")));
    let fs = metrics["sample_rate_hz"].as_f64().unwrap();

    if let Some(count) = expected["contact_count_merged_gap50us"].as_u64() {
        assert_eq!(metrics["contact_count"].as_u64().unwrap(), count, "{name}: contacts");
    }
    within(
        &format!("{name} contact time"),
        metrics["contact_time_s"].as_f64().unwrap(),
        expected["total_contact_time_s"].as_f64().unwrap(),
        0.02,
    );
    if let Some(rebound) = expected["rebound_speed_m_per_s"].as_f64() {
        within(&format!("{name} rebound"), metrics["rebound_speed_m_s"].as_f64().unwrap(), rebound, 0.02);
    }

    // The bridge force, low-passed as the contract says.
    let bridge = trace.numbers("bridge_force_n");
    let lowpassed = lowpass_20k(&bridge, fs);
    let expected_rms = expected["bridge_rms_0_to_0p5s_N"].as_f64().unwrap();
    within(&format!("{name} bridge RMS (from the trace)"), rms(&lowpassed), expected_rms, 0.02);
    within(
        &format!("{name} bridge RMS (metrics)"),
        metrics["bridge_force_rms_lp20k_n"].as_f64().unwrap(),
        expected_rms,
        0.02,
    );
    within(&format!("{name} bridge RMS (raw)"), metrics["bridge_force_rms_n"].as_f64().unwrap(), expected_rms, 0.02);

    // The contact force's peak: low-passed where the reference gives it, else as sampled.
    let contact = trace.numbers("contact_force_n");
    match expected["peak_contact_force_LP20k_N"].as_f64() {
        Some(peak) => {
            let from_trace = lowpass_20k(&contact, fs).into_iter().fold(f64::MIN, f64::max);
            within(&format!("{name} low-passed peak force"), from_trace, peak, 0.03);
            within(
                &format!("{name} low-passed peak (metrics)"),
                metrics["peak_contact_force_lp20k_n"].as_f64().unwrap(),
                peak,
                0.03,
            );
        }
        None => {
            let peak = expected["peak_contact_force_N"].as_f64().unwrap();
            within(&format!("{name} peak force"), metrics["peak_contact_force_n"].as_f64().unwrap(), peak, 0.03);
        }
    }

    // Partials within 60 dB of the strongest, within 1 dB.
    let expected_partials = expected["partials"].as_array().unwrap();
    let strongest = expected_partials.iter().map(|p| p["level_db"].as_f64().unwrap()).fold(f64::MIN, f64::max);
    let partials = metrics["partials"].as_array().unwrap();
    assert_eq!(partials.len(), 20);
    for (ours, theirs) in partials.iter().zip(expected_partials) {
        let n = theirs["n"].as_u64().unwrap();
        assert_eq!(ours["number"].as_u64().unwrap(), n);
        within(
            &format!("{name} partial {n} frequency"),
            ours["frequency_hz"].as_f64().unwrap(),
            theirs["f_hz"].as_f64().unwrap(),
            1e-9,
        );
        let level = theirs["level_db"].as_f64().unwrap();
        if level > strongest - 60.0 {
            let difference = ours["level_db"].as_f64().unwrap() - level;
            assert!(difference.abs() <= 1.0, "{name} partial {n}: {difference:+.3} dB");
        }
    }

    // The waveform over the first 30 ms.
    let reference = Csv::read(&reference_dir().join(format!("{name}.csv")));
    let reference_bridge = reference.numbers("bridge_force");
    let n = reference_bridge.len();
    assert!(n > 2800, "the reference holds 30 ms at 96 kHz");
    let error = relative_rms_error(&lowpassed[..n], &reference_bridge);
    assert!(error < 0.05, "{name}: bridge waveform {:.2} % off (relative RMS)", 100.0 * error);
}

#[test]
fn santoor_mallet_s1_matches_the_reference() {
    check_case("S1");
}

#[test]
fn piano_c4_hammer_at_2_5_m_s_matches_the_reference() {
    check_case("P4_V2p5");
}

#[test]
fn clavichord_tangent_k2_matches_the_reference() {
    check_case("K2");
    // A tangent is in contact throughout: one interval, the whole duration.
    let dir = tempfile::tempdir().unwrap();
    let case = reference_dir().join("K2.json");
    let out = struck(&["strike", case.to_str().unwrap(), "--out", dir.path().to_str().unwrap(), "--quiet"]);
    assert!(out.status.success());
    let metrics = read_json(&dir.path().join("metrics.json"));
    assert_eq!(metrics["contacts"], serde_json::json!([{ "start_s": 0.0, "end_s": 0.5 }]));
    assert_eq!(metrics["rebound_speed_m_s"], Value::Null);
}
