//! `struck bench`: the speed goals measured on this machine.
//!
//! The workloads are the engine's (`perf::workload`): the piano played through
//! the real-time synth at 48 kHz in 64-sample blocks on one thread, each run
//! several times with the fastest kept. Every figure is printed beside its goal
//! and marked PASS or MISS; `--json` writes the same figures as one JSON object
//! instead, each both nested (`.full_keyboard.load_fraction`) and under its
//! dotted name (`"full_keyboard.load_fraction"`). A missed goal is reported, not
//! an error: the exit status is 0 whenever the measurements ran. Every
//! instrument's build is timed at 44.1, 48, 96 and 192 kHz, afresh (nothing
//! kept) and again (a copy of the one kept), against 150 ms up to 48 kHz and
//! 500 ms above.

use std::time::Duration;

use crate::console;
use crate::perf::workload::{Extras, KeyboardRun, Smoothing};
use crate::perf::{self, workload};
use serde_json::{Map, Value, json};
use struck_engine::design::InstrumentKind;
use struck_engine::struck_string::DEFAULT_SUBSTEPS;
use struck_engine::synth::{PACED_BUDGET, Paced};

use crate::cli::Failure;

#[derive(clap::Args)]
pub struct BenchArgs {
    /// Scales the run: the full keyboard is held 4 S seconds and released for 2 S, the
    /// kernel timed for S, the idle piano for 2 S (0.01 <= S <= 600; 1 takes a few seconds).
    #[arg(long, default_value_t = 1.0, value_name = "S", allow_negative_numbers = true)]
    pub seconds: f64,
    /// Runs of each workload; the fastest is kept (1 to 100).
    #[arg(long, default_value_t = 3, value_name = "N")]
    pub runs: usize,
    /// Write only one JSON object to stdout (every figure nested and under its dotted
    /// name, e.g. "full_keyboard.load_fraction"), no text.
    #[arg(long)]
    pub json: bool,
    /// Also measure each instrument playing chords with the pedal down (about 10 S
    /// seconds of audio each, at least 1, at most 60).
    #[arg(long)]
    pub instruments: bool,
}

const SAMPLE_RATE_HZ: f64 = workload::SAMPLE_RATE_HZ;
const BLOCK: usize = workload::BLOCK;
/// Modes in the kernel's synthetic bank (a full keyboard's scale, after culling).
const KERNEL_MODES: usize = 10_240;
/// The multiply-add units' operations one mode-sample takes in the gathered
/// real form the synth runs free strings in: a multiply and a multiply-add
/// (the sum into the bridge force is an add, which this machine does on other
/// units).
const OPS_PER_MODE_SAMPLE: f64 = 2.0;
/// Multiply-adds one mode-sample takes as a complex phasor (one complex
/// multiply): the loop a string runs alone in.
const FMAS_PER_COMPLEX_MODE_SAMPLE: f64 = 4.0;
/// How long the 32-key chord is held (the goal is stated for 10 s).
const CHORD32_HELD_S: f64 = 10.0;
/// Keys of the full-keyboard workload.
const PIANO_KEYS: usize = 88;

/// The goals. Fractions are of one core.
const FULL_KEYBOARD_LOAD_MAX: f64 = 0.15;
/// The same with sympathetic strings, phantom partials and the action's sounds
/// on too.
const FULL_KEYBOARD_ALL_LOAD_MAX: f64 = 0.10;
const WORST_BLOCK_MAX: f64 = 0.40;
/// The 10-key chord's block with everything on.
const CHORD10_ALL_BLOCK_MAX: f64 = 0.25;
/// The gathered free loop against the FMA probe.
const KERNEL_FRACTION_MIN: f64 = 0.9;
const CHORD32_FACTOR_MIN: f64 = 100.0;
const IDLE_LOAD_MAX: f64 = 0.01;
/// An automated voicing parameter bounces offline at least as fast as real
/// time, over this much audio (times --seconds, at least 1).
const AUTOMATED_FACTOR_MIN: f64 = 1.0;
const AUTOMATED_S: f64 = 10.0;
/// The rates an instrument's build is timed at, Hz (a host tries them in
/// turn), and the longest a build may take at each, s: afresh (nothing kept)
/// and again (the same settings built a moment before).
const BUILD_RATES_HZ: [f64; 4] = [44_100.0, 48_000.0, 96_000.0, 192_000.0];
fn build_max_s(sample_rate_hz: f64) -> f64 {
    if sample_rate_hz <= 48_000.0 { 0.150 } else { 0.500 }
}

pub fn run(args: &BenchArgs) -> Result<(), Failure> {
    let seconds = args.seconds;
    // (Shorter, the kernel's timings round to nothing.)
    if !(0.01..=600.0).contains(&seconds) {
        return Err(Failure::bad_input(format!(
            "--seconds: must lie from 0.01 to 600 (got {})",
            struck_engine::readable(seconds)
        )));
    }
    if !(1..=100).contains(&args.runs) {
        return Err(Failure::bad_input(format!("--runs: must lie between 1 and 100 (got {})", args.runs)));
    }
    let runs = args.runs;
    let out = Out { text: !args.json };

    let (held_s, release_s, idle_s) = (4.0 * seconds, 2.0 * seconds, 2.0 * seconds);
    let probe_time = Duration::from_secs_f64(0.5 * seconds);
    let kernel_time = Duration::from_secs_f64(seconds);
    let contact_time = Duration::from_secs_f64(0.5 * seconds);

    let cpu = perf::cpu_model();
    let simd = perf::kernel_variant();
    let debug_build = cfg!(debug_assertions);
    out.line(format!("struck bench: {cpu}"));
    out.line(format!(
        "SIMD kernel: {simd}; one thread; f64 modes; {} kHz, blocks of {BLOCK} samples; each workload the fastest of {runs} run{}",
        SAMPLE_RATE_HZ / 1000.0,
        if runs == 1 { "" } else { "s" }
    ));
    if debug_build {
        // A warning, not part of the report: to stderr when stdout is the JSON.
        let note = "note: this is a debug build; build with --release for meaningful figures";
        if args.json { console::err(format!("struck bench: {note}")) } else { out.line(note.to_string()) }
    }

    let mut goals = Goals::default();

    // The machine's bound and the kernel against it.
    // Each rate the fastest of `runs` short runs, taken in turn (a shared
    // machine slows one now and then).
    let (mut fma_per_s, mut mode_samples_per_s, mut complex_per_s) = (0.0f64, 0.0f64, 0.0f64);
    for _ in 0..runs {
        fma_per_s = fma_per_s.max(perf::fma_probe(probe_time / runs as u32));
        mode_samples_per_s =
            mode_samples_per_s.max(perf::gathered_throughput(KERNEL_MODES, BLOCK, kernel_time / runs as u32));
        complex_per_s = complex_per_s.max(perf::free_throughput(KERNEL_MODES, BLOCK, kernel_time / runs as u32));
    }
    let ns_per_mode_sample = 1e9 / mode_samples_per_s;
    let fraction_of_fma_probe = OPS_PER_MODE_SAMPLE * mode_samples_per_s / fma_per_s;
    let complex_fraction = FMAS_PER_COMPLEX_MODE_SAMPLE * complex_per_s / fma_per_s;
    out.line(format!("FMA probe: {fma_per_s:.3e} f64 multiply-adds/s on this thread"));
    out.blank();
    out.line(format!(
        "kernel: {KERNEL_MODES} free modes gathered as a key's strings are, in real form, {BLOCK}-sample blocks: {ns_per_mode_sample:.3} ns per mode-sample ({mode_samples_per_s:.3e}/s)"
    ));
    let pass = goals.check("kernel", fraction_of_fma_probe, AtLeast, KERNEL_FRACTION_MIN);
    out.goal(
        "fraction of the FMA probe (2 per mode-sample)",
        format!("{fraction_of_fma_probe:.2}"),
        format!(">= {KERNEL_FRACTION_MIN}"),
        pass,
    );
    out.line(format!(
        "  as complex phasors (a string running alone): {:.3} ns per mode-sample, {complex_fraction:.2} of the probe (4 per mode-sample)",
        1e9 / complex_per_s
    ));

    // The full keyboard, held and released.
    out.blank();
    // Played as the plugin plays by default, with load smoothing, and without.
    let latency = Paced::latency_for(SAMPLE_RATE_HZ);
    let latency_ms = 1e3 * latency as f64 / SAMPLE_RATE_HZ;
    out.line(format!(
        "load smoothing (the plugin's default): heard {latency} samples ({latency_ms:.2} ms) late, rendering ahead up to {} of each block's period",
        percent(PACED_BUDGET)
    ));
    out.blank();
    let keyboard = workload::full_keyboard(held_s, release_s, runs, Extras::Off, Smoothing::On);
    let raw_keyboard = workload::full_keyboard(held_s, release_s, runs, Extras::Off, Smoothing::Off);
    let period_ms = 1e3 * BLOCK as f64 / SAMPLE_RATE_HZ;
    out.line(format!(
        "full keyboard: {PIANO_KEYS} keys struck one per block and held {:.2} s, pedal down; a 10-key chord (velocity 102) halfway, a 20-key one (120) at three quarters",
        keyboard.held_s
    ));
    out.line(format!(
        "  {} modes in all; {:.0} computed on average while held (the rest culled)",
        keyboard.modes, keyboard.running_modes_mean
    ));
    let pass = goals.check("full_keyboard_load", keyboard.load_fraction, Below, FULL_KEYBOARD_LOAD_MAX);
    out.goal("load", percent_of_core(keyboard.load_fraction), format!("< {}", percent(FULL_KEYBOARD_LOAD_MAX)), pass);
    let pass = goals.check("worst_block", keyboard.worst_block_fraction, Below, WORST_BLOCK_MAX);
    out.goal(
        "worst block (the chords' included)",
        format!("{} of {period_ms:.2} ms", percent(keyboard.worst_block_fraction)),
        format!("< {}", percent(WORST_BLOCK_MAX)),
        pass,
    );
    for (label, fraction) in [
        ("while the 10-key chord's hammers are on", keyboard.chord_block_fraction),
        ("... the 20-key chord's", keyboard.chord20_block_fraction),
    ] {
        out.line(format!("  {label:<width$}{} of {period_ms:.2} ms", percent(fraction), width = LABEL_WIDTH - 2));
    }
    out.line(unsmoothed(&raw_keyboard));
    out.line(format!("after release: every key and the pedal up, {:.2} s", keyboard.release_s));
    let pass = goals.check("after_release_load", keyboard.after_release_load_fraction, AtMost, keyboard.load_fraction);
    out.goal(
        "load",
        percent_of_core(keyboard.after_release_load_fraction),
        format!("<= held ({})", percent(keyboard.load_fraction)),
        pass,
    );
    let pass =
        goals.check("after_release_worst_block", keyboard.after_release_worst_block_fraction, Below, WORST_BLOCK_MAX);
    out.goal(
        "worst block",
        of_period(keyboard.after_release_worst_block_fraction),
        format!("< {}", percent(WORST_BLOCK_MAX)),
        pass,
    );
    out.line(after_release(&keyboard));

    // The same with everything on.
    out.blank();
    let all = workload::full_keyboard(held_s, release_s, runs, Extras::On, Smoothing::On);
    let raw_all = workload::full_keyboard(held_s, release_s, runs, Extras::On, Smoothing::Off);
    out.line(
        "full keyboard, everything on: the same with sympathetic strings, phantom partials and the action's sounds"
            .to_string(),
    );
    out.line(format!("  {:.0} modes computed on average while held", all.running_modes_mean));
    let pass = goals.check("full_keyboard_all_load", all.load_fraction, Below, FULL_KEYBOARD_ALL_LOAD_MAX);
    out.goal("load", percent_of_core(all.load_fraction), format!("< {}", percent(FULL_KEYBOARD_ALL_LOAD_MAX)), pass);
    for (name, label, fraction, limit) in [
        (
            "full_keyboard_all_worst_block",
            "worst block (the chords' included)",
            all.worst_block_fraction,
            WORST_BLOCK_MAX,
        ),
        ("chord10_block", "the 10-key chord's worst block", all.chord_block_fraction, CHORD10_ALL_BLOCK_MAX),
        ("chord20_block", "the 20-key chord's", all.chord20_block_fraction, WORST_BLOCK_MAX),
    ] {
        let pass = goals.check(name, fraction, Below, limit);
        out.goal(label, of_period(fraction), format!("< {}", percent(limit)), pass);
    }
    out.line(unsmoothed(&raw_all));
    out.line(after_release(&all));

    // Automation bounced offline.
    out.blank();
    out.line(format!(
        "A 2 Hz LFO on a voicing parameter, the piano bounced offline as a plugin host does ({:.0} s, chords every 0.5 s)",
        AUTOMATED_S * seconds.max(1.0)
    ));
    let mut automated = Vec::new();
    for param in [workload::Automated::Damping, workload::Automated::BoardSize] {
        let (factor, builds) = workload::automated_bounce(param, AUTOMATED_S * seconds.max(1.0), runs.min(2));
        let name = match param {
            workload::Automated::Damping => "automated_damping",
            workload::Automated::BoardSize => "automated_board_size",
        };
        let pass = goals.check(name, factor, AtLeast, AUTOMATED_FACTOR_MIN);
        out.goal(
            &format!("{} ({builds} builds)", param.label().replace('_', " ")),
            format!("{factor:.1}x real time"),
            format!(">= {AUTOMATED_FACTOR_MIN:.0}x"),
            pass,
        );
        automated.push((param.label(), factor, builds));
    }

    // The 32-note chord, offline.
    out.blank();
    let (chord32_factor, chord32_keys) = workload::chord32_realtime_factor(CHORD32_HELD_S, runs);
    out.line(format!(
        "32-note chord ({chord32_keys} keys) held {CHORD32_HELD_S:.0} s, rendered offline in 512-sample blocks"
    ));
    let pass = goals.check("chord32", chord32_factor, AtLeast, CHORD32_FACTOR_MIN);
    out.goal("speed", format!("{chord32_factor:.1}x real time"), format!(">= {CHORD32_FACTOR_MIN:.0}x"), pass);

    // Silence.
    out.blank();
    let idle = workload::idle_load(idle_s, runs);
    out.line(format!("idle: the piano with nothing played, {idle_s:.2} s"));
    let pass = goals.check("idle", idle, Below, IDLE_LOAD_MAX);
    out.goal("load", percent_of_core(idle), format!("< {}", percent(IDLE_LOAD_MAX)), pass);

    // The string in contact (no goal).
    out.blank();
    let (contact_rate, contact_modes) = perf::contact_throughput(contact_time);
    let contact_us_per_sample = 1e6 * (contact_modes * DEFAULT_SUBSTEPS) as f64 / contact_rate;
    out.line(format!(
        "in contact (C2 string, {contact_modes} modes, {DEFAULT_SUBSTEPS} sub-steps, implicit felt): {contact_rate:.3e} mode-steps/s, {contact_us_per_sample:.2} us per sample"
    ));

    // Every instrument's build at each rate.
    out.blank();
    out.line(
        "instrument builds: every key's tables, the body and the voicing through it; first (nothing built yet, the voicing as it comes with the program), again (a copy of the one kept), and voiced from nothing (settings the program has not met)"
            .to_string(),
    );
    let mut builds = Map::new();
    for kind in InstrumentKind::ALL {
        let mut rates = Map::new();
        for rate in BUILD_RATES_HZ {
            let times = perf::build_times(kind, rate, runs);
            let khz = rate / 1000.0;
            let limit = build_max_s(rate);
            for (what, id, seconds) in [
                ("first", "first", times.first_s),
                ("again", "again", times.again_s),
                ("voiced from nothing", "unvoiced", times.unvoiced_s),
            ] {
                let pass = goals.check(format!("build_{}_{}_{id}", kind.name(), rate as u32), seconds, AtMost, limit);
                out.goal(
                    &format!("{} at {khz} kHz, {what}", kind.name()),
                    format!("{:.1} ms", 1e3 * seconds),
                    format!("<= {:.0} ms", 1e3 * limit),
                    pass,
                );
            }
            rates.insert(
                format!("{}", rate as u32),
                json!({ "first_s": times.first_s, "again_s": times.again_s, "unvoiced_s": times.unvoiced_s, "max_s": limit }),
            );
        }
        builds.insert(kind.name().to_string(), Value::Object(rates));
    }

    // Each instrument (optional: about a second of computing each).
    let mut instruments = Map::new();
    if args.instruments {
        let audio_s = (10.0 * seconds).clamp(1.0, 60.0);
        for kind in InstrumentKind::ALL {
            let run = perf::synth_throughput(kind, audio_s);
            out.line(format!(
                "{:<11} chords every 0.2 s, pedal down: {:>6.1}x real time with up to {:>3} keys sounding (tables built in {:.1} ms)",
                kind.name(),
                run.real_time_factor,
                run.max_keys,
                1e3 * run.build_s
            ));
            instruments.insert(
                kind.name().to_string(),
                json!({
                    "realtime_factor": run.real_time_factor,
                    "max_keys": run.max_keys,
                    "build_s": run.build_s,
                }),
            );
        }
    }

    out.blank();
    let met = goals.met();
    out.line(format!("goals met: {met} of {}", goals.len()));

    if args.json {
        let mut report = json!({
            "cpu": cpu,
            "simd": simd,
            "debug_build": debug_build,
            "sample_rate_hz": SAMPLE_RATE_HZ as u32,
            "block": BLOCK,
            "threads": 1,
            "runs": runs,
            "seconds": seconds,
            "full_keyboard": {
                "keys": PIANO_KEYS,
                "modes": keyboard.modes,
                "running_modes_mean": keyboard.running_modes_mean,
                "held_s": keyboard.held_s,
                "load_fraction": keyboard.load_fraction,
                "worst_block_fraction": keyboard.worst_block_fraction,
                "chord10_block_fraction": keyboard.chord_block_fraction,
                "chord20_block_fraction": keyboard.chord20_block_fraction,
                "latency_samples": latency,
                "unsmoothed": unsmoothed_json(&raw_keyboard),
            },
            "full_keyboard_all": {
                "keys": PIANO_KEYS,
                "running_modes_mean": all.running_modes_mean,
                "held_s": all.held_s,
                "load_fraction": all.load_fraction,
                "worst_block_fraction": all.worst_block_fraction,
                "chord10_block_fraction": all.chord_block_fraction,
                "chord20_block_fraction": all.chord20_block_fraction,
                "after_release_load_fraction": all.after_release_load_fraction,
                "latency_samples": latency,
                "unsmoothed": unsmoothed_json(&raw_all),
            },
            "chord10": {
                "keys": workload::CHORD10.len(),
                "velocity": (workload::VELOCITY * 127.0).round() as u8,
                "worst_block_fraction": all.chord_block_fraction,
                "latency_samples": latency,
                "unsmoothed_worst_block_fraction": raw_all.chord_block_fraction,
            },
            "chord20": {
                "keys": workload::CHORD20.len(),
                "velocity": (workload::CHORD20_VELOCITY * 127.0).round() as u8,
                "worst_block_fraction": all.chord20_block_fraction,
                "latency_samples": latency,
                "unsmoothed_worst_block_fraction": raw_all.chord20_block_fraction,
            },
            "load_smoothing": {
                "latency_samples": latency,
                "latency_ms": latency_ms,
                "budget_fraction": PACED_BUDGET,
            },
            "after_release": {
                "release_s": keyboard.release_s,
                "load_fraction": keyboard.after_release_load_fraction,
                "worst_block_fraction": keyboard.after_release_worst_block_fraction,
                "keys_left": keyboard.keys_left,
                "silent_after_s": keyboard.silent_after_s,
            },
            "kernel": {
                "modes": KERNEL_MODES,
                "block": BLOCK,
                "mode_samples_per_s": mode_samples_per_s,
                "ns_per_mode_sample": ns_per_mode_sample,
                "fma_probe_per_s": fma_per_s,
                "form": "gathered, real",
                "ops_per_mode_sample": OPS_PER_MODE_SAMPLE,
                "fraction_of_fma_probe": fraction_of_fma_probe,
                "complex": {
                    "mode_samples_per_s": complex_per_s,
                    "ns_per_mode_sample": 1e9 / complex_per_s,
                    "fmas_per_mode_sample": FMAS_PER_COMPLEX_MODE_SAMPLE,
                    "fraction_of_fma_probe": complex_fraction,
                },
            },
            "automated": {
                "audio_s": AUTOMATED_S * seconds.max(1.0),
                "lfo_hz": 2.0,
                "rebuild_spacing_s": struck_engine::synth::REBUILD_SPACING_S,
                "params": automated
                    .iter()
                    .map(|(name, factor, builds)| json!({"param": name, "realtime_factor": factor, "builds": builds}))
                    .collect::<Vec<_>>(),
            },
            "chord32": {
                "held_s": CHORD32_HELD_S,
                "keys": chord32_keys,
                "realtime_factor": chord32_factor,
            },
            "idle": {
                "audio_s": idle_s,
                "load_fraction": idle,
            },
            "contact": {
                "modes": contact_modes,
                "substeps": DEFAULT_SUBSTEPS,
                "mode_steps_per_s": contact_rate,
                "us_per_sample": contact_us_per_sample,
            },
            "goals": goals.to_json(),
            "goals_met": met,
            "goals_total": goals.len(),
            "all_goals_met": met == goals.len(),
        });
        report["builds"] = Value::Object(builds);
        if !instruments.is_empty() {
            report["instruments"] = Value::Object(instruments);
        }
        let report = with_dotted_keys(report);
        let text = serde_json::to_string_pretty(&report)
            .map_err(|e| Failure::failed(format!("cannot write the report as JSON: {e}")))?;
        console::out(text);
    }
    Ok(())
}

/// A block's time as a share of its period, with the period.
fn of_period(fraction: f64) -> String {
    format!("{} of {:.2} ms", percent(fraction), 1e3 * BLOCK as f64 / SAMPLE_RATE_HZ)
}

/// What was still sounding after a keyboard run's release.
/// The same workload without load smoothing (no latency): each block's own work.
fn unsmoothed(run: &KeyboardRun) -> String {
    format!(
        "  without load smoothing (no latency): load {}, worst block {}, the 10-key chord's {}, the 20-key chord's {}",
        percent(run.load_fraction),
        percent(run.worst_block_fraction),
        percent(run.chord_block_fraction),
        percent(run.chord20_block_fraction)
    )
}

fn unsmoothed_json(run: &KeyboardRun) -> Value {
    json!({
        "load_fraction": run.load_fraction,
        "worst_block_fraction": run.worst_block_fraction,
        "chord10_block_fraction": run.chord_block_fraction,
        "chord20_block_fraction": run.chord20_block_fraction,
    })
}

fn after_release(run: &KeyboardRun) -> String {
    match run.silent_after_s {
        Some(s) => format!("  every key silent {s:.2} s after the release"),
        None => format!("  {} keys still sounding {:.2} s after the release", run.keys_left, run.release_s),
    }
}

/// Width of the label column of a goal line.
const LABEL_WIDTH: usize = 52;

/// The human-readable report, printed as the figures arrive (nothing with --json).
struct Out {
    text: bool,
}

impl Out {
    fn line(&self, line: String) {
        if self.text {
            console::out(line);
        }
    }

    fn blank(&self) {
        self.line(String::new());
    }

    fn goal(&self, label: &str, measured: String, goal: String, pass: bool) {
        // (A figure wider than its column still stands apart from its goal.)
        self.line(format!(
            "  {label:<width$}{measured:<23} goal {goal:<20}{}",
            if pass { "PASS" } else { "MISS" },
            width = LABEL_WIDTH - 2
        ));
    }
}

fn percent(fraction: f64) -> String {
    let p = 100.0 * fraction;
    if p < 1.0 { format!("{p:.3} %") } else { format!("{p:.1} %") }
}

fn percent_of_core(fraction: f64) -> String {
    format!("{} of a core", percent(fraction))
}

/// How a figure must compare with its goal's limit.
#[derive(Clone, Copy)]
enum Bound {
    Below,
    AtMost,
    AtLeast,
}
use Bound::{AtLeast, AtMost, Below};

impl Bound {
    fn holds(self, value: f64, limit: f64) -> bool {
        match self {
            Below => value < limit,
            AtMost => value <= limit,
            AtLeast => value >= limit,
        }
    }

    fn symbol(self) -> &'static str {
        match self {
            Below => "<",
            AtMost => "<=",
            AtLeast => ">=",
        }
    }
}

/// Each goal: its figure, the bound it must keep, and whether it does.
#[derive(Default)]
struct Goals {
    goals: Vec<(String, f64, Bound, f64, bool)>,
}

impl Goals {
    /// Record a goal; whether it is met.
    fn check(&mut self, name: impl Into<String>, value: f64, bound: Bound, limit: f64) -> bool {
        let pass = bound.holds(value, limit);
        self.goals.push((name.into(), value, bound, limit, pass));
        pass
    }

    fn len(&self) -> usize {
        self.goals.len()
    }

    fn met(&self) -> usize {
        self.goals.iter().filter(|g| g.4).count()
    }

    fn to_json(&self) -> Value {
        Value::Object(
            self.goals
                .iter()
                .map(|(name, value, bound, limit, pass)| {
                    let goal = json!({ "value": value, "bound": bound.symbol(), "limit": limit, "pass": pass });
                    (name.clone(), goal)
                })
                .collect(),
        )
    }
}

/// The report with every nested figure also at the top level under its dotted
/// name: `{"a": {"b": 1}}` becomes `{"a": {"b": 1}, "a.b": 1}`.
fn with_dotted_keys(report: Value) -> Value {
    fn flatten(prefix: &str, value: &Value, flat: &mut Map<String, Value>) {
        match value {
            Value::Object(fields) => {
                for (key, field) in fields {
                    flatten(&format!("{prefix}.{key}"), field, flat);
                }
            }
            leaf => {
                flat.insert(prefix.to_string(), leaf.clone());
            }
        }
    }
    let Value::Object(fields) = report else { return report };
    let mut flat = Map::new();
    for (key, field) in &fields {
        if field.is_object() {
            flatten(key, field, &mut flat);
        }
    }
    let mut all = fields;
    all.extend(flat);
    Value::Object(all)
}
