//! `struck strike CASE.json --out DIR [--wav FILE] [--set path=value ...]`.

use std::io::Write;
use std::path::PathBuf;

use crate::strike::{self, LabRun};

use super::output::{Staged, csv_field};
use crate::cli::Failure;
use crate::console;

#[derive(clap::Args)]
pub struct StrikeArgs {
    /// The strike case (JSON).
    pub case: PathBuf,
    /// Directory for metrics.json and trace.csv (created if missing).
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// Also write the bridge force as a 32-bit float WAV at the case's sample rate.
    #[arg(long, value_name = "FILE")]
    pub wav: Option<PathBuf>,
    /// Gain from newtons to WAV full scale, in dB (0 dB: 1 N = 1.0). Without it the
    /// WAV is normalised to a peak of -1 dBFS. A fixed gain keeps the relative
    /// loudness of several strikes.
    #[arg(long, value_name = "DB", allow_negative_numbers = true, requires = "wav")]
    pub wav_gain_db: Option<f64>,
    /// Change one field of the case before it is checked, e.g. --set exciter.speed_m_s=2.5
    /// (repeatable; the value is JSON, or a bare word for a string).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub sets: Vec<String>,
    /// Print nothing on success.
    #[arg(long, short)]
    pub quiet: bool,
}

/// Peak level of a normalised WAV: -1 dBFS.
const NORMALISED_PEAK: f64 = 0.891_250_938;
/// Largest gain from newtons to a WAV's full scale, dB either way (a float
/// WAV holds 1e38: 760 dB over 1 N would fill it with infinities).
const MAX_WAV_GAIN_DB: f64 = 200.0;
/// Bytes a row of trace.csv takes at most: five numbers in shortest form.
const CSV_BYTES_PER_ROW: u64 = 5 * 24 + 1;

fn stop_if_interrupted() -> Result<(), Failure> {
    if crate::cleanup::interrupted() { Err(Failure::interrupted()) } else { Ok(()) }
}

/// The dotted name of the first null in `value` (where a non-finite number
/// was serialised), None if there is none.
fn null_field(value: &serde_json::Value, at: &str) -> Option<String> {
    let join = |key: &str| if at.is_empty() { key.to_string() } else { format!("{at}.{key}") };
    match value {
        serde_json::Value::Null => Some(at.to_string()),
        serde_json::Value::Object(map) => map.iter().find_map(|(k, v)| null_field(v, &join(k))),
        serde_json::Value::Array(items) => {
            items.iter().enumerate().find_map(|(i, v)| null_field(v, &format!("{at}[{i}]")))
        }
        _ => None,
    }
}

/// A hammer cannot leave the string faster than it came: a rebound above the
/// strike speed means a contact too stiff for f64 and the time step to
/// resolve, and its figures would be garbage.
fn check_energy(case: &strike::StrikeCase, result: &LabRun) -> Result<(), String> {
    let (strike::ExciterSpec::Hammer(h), Some(rebound)) = (&case.exciter, result.metrics.rebound_speed_m_s) else {
        return Ok(());
    };
    if rebound > h.speed_m_s * (1.0 + 1e-6) {
        return Err(format!(
            "exciter.stiffness: the hammer rebounds at {rebound:.3e} m/s from {:.3} m/s, more energy than it brought \
             (a contact this stiff is beyond what the step resolves)",
            h.speed_m_s
        ));
    }
    Ok(())
}

pub fn run(args: &StrikeArgs) -> Result<(), Failure> {
    let shown = super::shown(&args.case);
    let text = super::input::read_text(&args.case, super::input::MAX_CASE_BYTES)?;
    let case = strike::parse_case(&text, &args.sets).map_err(|e| Failure::bad_input(format!("{shown}: {e}")))?;
    if let Some(gain) = args.wav_gain_db
        && !(gain.is_finite() && gain.abs() <= MAX_WAV_GAIN_DB)
    {
        return Err(Failure::bad_input(format!(
            "--wav-gain-db: must lie between -{MAX_WAV_GAIN_DB} and {MAX_WAV_GAIN_DB} dB (got {})",
            struck_engine::readable(gain)
        )));
    }
    if args.wav.is_some() && case.sample_rate_hz.fract() != 0.0 {
        return Err(Failure::bad_input(format!(
            "--wav: the case's sample rate, {} Hz, is not a whole number of Hz, as a WAV's must be",
            struck_engine::readable(case.sample_rate_hz)
        )));
    }
    // The outputs' temporaries are made first: an --out or --wav that cannot
    // be written is refused before the run.
    let mut staged = Staged::reading(&[args.case.as_path()]);
    let metrics_path = args.out.join("metrics.json");
    let trace_path = args.out.join("trace.csv");
    let metrics_slot = staged.reserve(&metrics_path)?;
    let trace_slot = staged.reserve(&trace_path)?;
    let wav_slot = args.wav.as_ref().map(|wav| staged.reserve(wav)).transpose()?;
    // Room for the trace in memory and the files on disk, before starting.
    let rows = case.sample_count() as u64;
    let disk = rows * CSV_BYTES_PER_ROW + args.wav.as_ref().map_or(0, |_| rows * 4);
    if let Some(wav) = &args.wav {
        super::room::check_file_size(wav, super::render::WAV_HEADER_BYTES + rows * 4)?;
    }
    super::room::check(&format!("{shown} ({rows} samples)"), strike::run::peak_bytes(&case), disk, &args.out)?;
    let result = strike::run::run_stoppable(&case, crate::cleanup::flag()).map_err(|stopped| match stopped {
        strike::run::Stopped::Interrupted => Failure::interrupted(),
        strike::run::Stopped::OutOfMemory { bytes } => out_of_memory(&format!("{shown} ({rows} samples)"), bytes),
    })?;
    check_finite(&result)?;
    check_energy(&case, &result).map_err(|e| Failure::bad_input(format!("{shown}: {e}")))?;

    let metrics = serde_json::to_value(&result.metrics).expect("metrics serialise");
    if let Some(field) = null_field(&metrics, "") {
        return Err(Failure::bad_input(format!(
            "{shown}: the run's {field} is not a finite number (the case leaves f64's range); nothing was written"
        )));
    }
    let metrics = serde_json::to_string_pretty(&metrics).expect("metrics serialise");
    staged.fill_with(metrics_slot, &metrics_path, |w| writeln!(w, "{metrics}"))?;
    stop_if_interrupted()?;
    staged
        .fill_with(trace_slot, &trace_path, |w| {
            write_trace(w, &result)?;
            stop_if_interrupted().map_err(|_| std::io::Error::other("interrupted"))
        })
        .map_err(|e| if crate::cleanup::interrupted() { Failure::interrupted() } else { e })?;
    let mut wav_note = String::new();
    if let (Some(wav), Some(slot)) = (&args.wav, wav_slot) {
        let peak = result.trace.bridge_force_n.iter().fold(0.0f64, |m, v| m.max(v.abs()));
        let gain = match args.wav_gain_db {
            Some(db) => 10f64.powf(db / 20.0),
            None if peak > 0.0 => NORMALISED_PEAK / peak,
            None => 1.0,
        };
        let mut samples: Vec<f32> = Vec::new();
        samples
            .try_reserve_exact(result.trace.len())
            .map_err(|_| out_of_memory(&format!("--wav {}", super::shown(wav)), rows * 4))?;
        samples.extend(result.trace.bridge_force_n.iter().map(|v| (v * gain) as f32));
        if !samples.iter().all(|s| s.is_finite()) {
            return Err(Failure::bad_input(format!(
                "--wav-gain-db {:.1}: the loudest sample, {:.3e} N, would leave a float WAV's range",
                20.0 * gain.log10(),
                peak
            )));
        }
        staged.fill_wav(slot, wav, case.sample_rate_hz, &samples)?;
        stop_if_interrupted()?;
        wav_note = format!(", {} (gain {:+.1} dB re 1 N)", super::shown(wav), 20.0 * gain.log10());
    }
    staged.commit()?;

    if !args.quiet {
        let m = &result.metrics;
        // (A case's name is the user's text: its control characters are shown, not acted on.)
        let name = m.name.as_deref().map_or_else(|| shown.to_string(), super::failure::printable);
        let contacts = match m.contact_count {
            0 => "no contact".to_string(),
            1 => format!("1 contact, {:.3} ms", m.contact_time_s * 1e3),
            n => format!("{n} contacts, {:.3} ms in all", m.contact_time_s * 1e3),
        };
        let rebound = m.rebound_speed_m_s.map(|v| format!(", rebound {v:.3} m/s")).unwrap_or_default();
        console::out(format!(
            "{name}: {} modes to {:.0} Hz; {contacts}{rebound}; bridge force {:.4} N RMS",
            m.string.mode_count, m.string.max_mode_frequency_hz, m.bridge_force_rms_n
        ));
        console::out(format!("wrote {}, {}{wav_note}", super::shown(&metrics_path), super::shown(&trace_path)));
    }
    Ok(())
}

/// What a strike says when `bytes` of memory in one piece could not be had.
fn out_of_memory(what: &str, bytes: u64) -> Failure {
    let limit = super::room::tightest_memory_limit().map(|l| format!(" ({l})")).unwrap_or_default();
    Failure::bad_input(format!(
        "{what}: cannot get {} of memory{limit}; nothing was written",
        super::room::size_text_rounded(bytes)
    ))
}

fn write_trace(w: &mut impl Write, result: &LabRun) -> std::io::Result<()> {
    let t = &result.trace;
    writeln!(w, "t_s,contact_force_n,bridge_force_n,exciter_position_m,string_position_m")?;
    for row in 0..t.len() {
        write!(w, "{:e},{:e},{:e},", t.time_s(row), t.contact_force_n[row], t.bridge_force_n[row])?;
        csv_field(w, t.exciter_position_m.as_ref().map(|c| c[row]))?;
        writeln!(w, ",{:e}", t.string_position_m[row])?;
    }
    Ok(())
}

/// A case whose numbers leave f64's range (a stiffness of 1e300, say) gives
/// a trace that is not finite: refused, naming the column, never written.
fn check_finite(result: &LabRun) -> Result<(), Failure> {
    let t = &result.trace;
    let columns = [
        ("contact_force_n", Some(&t.contact_force_n)),
        ("bridge_force_n", Some(&t.bridge_force_n)),
        ("string_position_m", Some(&t.string_position_m)),
        ("exciter_position_m", t.exciter_position_m.as_ref()),
    ];
    for (name, column) in columns {
        if let Some(row) = column.and_then(|c| c.iter().position(|v| !v.is_finite())) {
            return Err(Failure::bad_input(format!(
                "the run's {name} is not finite from sample {row} (the case leaves f64's range); nothing was written"
            )));
        }
    }
    Ok(())
}
