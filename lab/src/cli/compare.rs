//! `struck compare`: the piano measured against recordings of a real grand
//! (see [`crate::compare`] and docs/comparison.md).
//!
//! The recordings are fetched once into a cache outside the repository
//! (`--cache`); each note of each layer is then played by Struck and the
//! yardsticks, every file is measured the same way, and each source's
//! errors against the recording are summed up in a table on stdout, with
//! every figure in `--json` and `--csv`.

use std::collections::BTreeMap;
use std::io::{self, IsTerminal};
use std::path::{Path, PathBuf};
use std::time::Instant;

use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;
use struck_engine::body::Output;
use struck_engine::design::InstrumentKind;
use struck_engine::preset::Preset;

use super::output::Staged;
use crate::cli::Failure;
use crate::compare::measure::{Analyzer, Context, Features};
use crate::compare::report::{self, Take};
use crate::compare::salamander;
use crate::compare::sources::{self, FaustRenderer, Source};
use crate::compare::{RECORDED_KEYS, layer_velocity, nominal_hz, note_name, parse_layers, parse_notes};
use crate::console;

/// The recordings' sample rate, at which everything is rendered.
const SAMPLE_RATE_HZ: f64 = 48_000.0;
/// The recordings fade out over their last second: not measured.
const FADE_S: f64 = 1.0;
/// Most seconds measured after an onset (the late decays end at 6 s; a bass
/// note takes longer than that to fall 40 dB).
const MAX_MEASURED_S: f64 = 20.0;
/// Time rendered before the measured span, for a source's own onset.
const LEAD_S: f64 = 0.5;
/// The band measured is the recording's cutoff less this share.
const BAND_MARGIN: f64 = 0.1;

#[derive(clap::Args)]
pub struct CompareArgs {
    /// Velocity layers of the recordings to compare, 1 to 16 (played at the middle
    /// velocity of each layer's range: 4, 8, 12, 16 at 40, 60, 92, 124).
    #[arg(long, value_name = "N,N,...", default_value = "4,8,12,16")]
    pub layers: String,
    /// Notes to compare, among those recorded (every minor third from A0 to C8)
    /// [default: all 30]
    #[arg(long, value_name = "NOTE,...")]
    pub notes: Option<String>,
    /// Where the recordings are kept [default: $XDG_CACHE_HOME/struck/salamander, else
    /// ~/.cache/struck/salamander]
    #[arg(long, value_name = "DIR")]
    pub cache: Option<PathBuf>,
    /// What is heard from Struck: mics (the body through its microphones) or bridge
    /// (the strings' force on the bridge).
    #[arg(long, value_name = "mics|bridge", default_value = "mics")]
    pub output: String,
    /// Play Struck with this preset (its instrument, voicing, tuning and
    /// controls) instead of the default piano.
    #[arg(long, value_name = "FILE")]
    pub preset: Option<PathBuf>,
    /// Play this instrument: piano|fortepiano|santoor|dulcimer|cimbalom|clavichord|harpsichord
    /// [default: the preset's, else piano]
    #[arg(long, value_name = "NAME")]
    pub instrument: Option<String>,
    /// What Struck is measured against: salamander (the recordings of a Yamaha C5), or
    /// fluid:N, FluidR3_GM's recorded General MIDI program N as MIDI numbers it (0-127;
    /// 6 its harpsichord, 15 its dulcimer), played by FluidSynth at the same notes and
    /// velocities, within the instrument's compass. Against FluidR3 there are no
    /// yardsticks.
    #[arg(long, value_name = "salamander|fluid:N", default_value = "salamander")]
    pub reference: String,
    /// Leave out FluidR3_GM and Faust-STK.
    #[arg(long)]
    pub no_yardsticks: bool,
    /// Write every note's figures and errors as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Write one row per note, layer and source as CSV.
    #[arg(long, value_name = "FILE")]
    pub csv: Option<PathBuf>,
    /// Write the medians table into this Markdown file (docs/validation.md)
    /// between its lines `<!-- table: real grand -->` and `<!-- /table:
    /// real grand -->`, the rest of it as it was. Only for the piano against
    /// the recordings, with the yardsticks.
    #[arg(long, value_name = "FILE")]
    pub doc: Option<PathBuf>,
    /// Notes rendered and measured at once (1 to 64).
    #[arg(long, value_name = "N", default_value_t = 1, allow_negative_numbers = true)]
    pub jobs: i64,
    /// Print only the table (no progress, no worst notes).
    #[arg(long, short)]
    pub quiet: bool,
}

/// What the notes are measured against.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Against {
    /// The Salamander recordings of a Yamaha C5.
    Salamander,
    /// FluidR3_GM's General MIDI program (0-127) through FluidSynth.
    Fluid(u8),
}

impl Against {
    fn parse(text: &str) -> Result<Self, String> {
        let t = text.trim().to_ascii_lowercase();
        if t == "salamander" {
            return Ok(Against::Salamander);
        }
        let program = t
            .strip_prefix("fluid:")
            .ok_or_else(|| format!("{text:?}: expected salamander or fluid:N"))?
            .parse::<u8>()
            .ok()
            .filter(|&p| p <= 127)
            .ok_or_else(|| format!("{text:?}: the program must be a General MIDI program from 0 to 127"))?;
        Ok(Against::Fluid(program))
    }

    /// The reference's name in the table.
    fn title(self) -> String {
        match self {
            Against::Salamander => "Yamaha C5".into(),
            Against::Fluid(program) => format!("FluidR3 program {program}"),
        }
    }

    /// What the reference is, for the JSON.
    fn describe(self) -> String {
        match self {
            Against::Salamander => "Salamander Grand Piano V3 (Alexander Holm, CC BY 3.0), a Yamaha C5, npm @audio-samples/piano-velocityN 1.0.5".into(),
            Against::Fluid(program) => format!("FluidR3_GM (Frank Wen, MIT licence) General MIDI program {program}, played by FluidSynth"),
        }
    }
}

/// Seconds of each note FluidSynth plays as the reference.
const FLUID_REFERENCE_S: f64 = 12.0;

/// The checked arguments.
struct Plan {
    keys: Vec<u8>,
    layers: Vec<u8>,
    output: Output,
    jobs: usize,
    cache: PathBuf,
    preset: Preset,
    against: Against,
}

fn plan(args: &CompareArgs) -> Result<Plan, Failure> {
    let layers = parse_layers(&args.layers).map_err(|e| Failure::bad_input(format!("--layers: {e}")))?;
    let against = Against::parse(&args.reference).map_err(|e| Failure::bad_input(format!("--reference {e}")))?;
    let mut preset = match &args.preset {
        Some(path) => Preset::load(path).map_err(|e| Failure::bad_input(e.to_string()))?,
        None => Preset::default(),
    };
    if let Some(name) = &args.instrument {
        let kind: InstrumentKind = name.parse().map_err(|e| Failure::bad_input(format!("--instrument: {e}")))?;
        preset.instrument = Some(kind);
    }
    let instrument = preset.instrument.unwrap_or(InstrumentKind::Piano);
    let compass = instrument.key_range();
    let keys = match &args.notes {
        Some(list) => {
            let keys = parse_notes(list).map_err(|e| Failure::bad_input(format!("--notes: {e}")))?;
            if let Some(&key) = keys.iter().find(|&&k| !compass.contains(&k)) {
                return Err(Failure::bad_input(format!(
                    "--notes: {} is outside the {}'s keys ({} to {})",
                    note_name(key),
                    instrument.name(),
                    note_name(*compass.start()),
                    note_name(*compass.end())
                )));
            }
            keys
        }
        None => RECORDED_KEYS.iter().copied().filter(|k| compass.contains(k)).collect(),
    };
    let output = match args.output.to_ascii_lowercase().as_str() {
        "mics" | "microphones" => Output::Microphones,
        "bridge" | "bridge-force" => Output::BridgeForce,
        other => return Err(Failure::bad_input(format!("--output {other}: expected mics or bridge"))),
    };
    let jobs = match usize::try_from(args.jobs) {
        Ok(n) if (1..=64).contains(&n) => n,
        _ => return Err(Failure::bad_input(format!("--jobs: must be from 1 to 64 (got {})", args.jobs))),
    };
    let cache = match &args.cache {
        Some(dir) => dir.clone(),
        None => salamander::default_cache()
            .ok_or_else(|| Failure::bad_input("no cache folder: set XDG_CACHE_HOME or HOME, or give --cache DIR"))?,
    };
    if cache.exists() && !cache.is_dir() {
        return Err(Failure::bad_input(format!("--cache {}: is not a folder", super::shown(&cache))));
    }
    if let Some(doc) = &args.doc {
        if against != Against::Salamander || args.preset.is_some() || args.instrument.is_some() || args.no_yardsticks {
            return Err(Failure::bad_input(
                "--doc: its table is the piano's against the recordings, with the yardsticks: \
                 drop --reference, --preset, --instrument and --no-yardsticks",
            ));
        }
        doc_with_table(doc, "")?;
    }
    Ok(Plan { keys, layers, output, jobs, cache, preset, against })
}

/// The validation document's table of the comparison.
const DOC_TABLE: &str = "real grand";

/// `doc`'s text with its comparison table replaced by `table`, or why not.
fn doc_with_table(doc: &Path, table: &str) -> Result<String, Failure> {
    let text =
        std::fs::read_to_string(doc).map_err(|e| Failure::bad_input(format!("--doc {}: {e}", super::shown(doc))))?;
    report::with_table(&text, DOC_TABLE, table)
        .map_err(|why| Failure::bad_input(format!("--doc {}: {why}", super::shown(doc))))
}

/// A recording decoded and measured.
struct Reference {
    key: u8,
    layer: u8,
    features: Features,
    context: Context,
    /// Seconds measured from the onset.
    measured_s: f64,
    /// Seconds each source renders.
    render_s: f64,
}

pub fn run(args: &CompareArgs) -> Result<(), Failure> {
    let plan = plan(args)?;
    // The outputs' temporaries first: a path that cannot be written is
    // refused before anything is fetched or rendered.
    let mut staged = Staged::reading(&[]);
    let json_slot = args.json.as_ref().map(|p| staged.reserve(p)).transpose()?;
    let csv_slot = args.csv.as_ref().map(|p| staged.reserve(p)).transpose()?;
    let doc_slot = args.doc.as_ref().map(|p| staged.reserve(p)).transpose()?;
    let say = |line: String| {
        if !args.quiet {
            console::err(format!("struck compare: {line}"));
        }
    };
    let started = Instant::now();
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(plan.jobs)
        .build()
        .map_err(|e| Failure::failed(format!("cannot start {} threads: {e}", plan.jobs)))?;

    // The recordings.
    match plan.against {
        Against::Salamander => {
            for &layer in &plan.layers {
                if !salamander::layer_ready(&plan.cache, layer) {
                    say(format!("fetching {} into {}", salamander::package_name(layer), super::shown(&plan.cache)));
                }
                salamander::fetch_layer(&plan.cache, layer).map_err(Failure::failed)?;
                check_interrupted()?;
            }
        }
        Against::Fluid(_) => {
            sources::fluid_available().map_err(|e| Failure::failed(format!("--reference {}: {e}", args.reference)))?
        }
    }

    // The yardsticks.
    let mut unavailable: BTreeMap<Source, String> = BTreeMap::new();
    let mut faust: Option<FaustRenderer> = None;
    if let Against::Fluid(_) = plan.against {
        unavailable.insert(Source::Fluid, "left out (FluidR3 is the reference)".into());
        unavailable.insert(Source::FaustStk, "left out (FluidR3 is the reference)".into());
    } else if args.no_yardsticks {
        unavailable.insert(Source::Fluid, "left out (--no-yardsticks)".into());
        unavailable.insert(Source::FaustStk, "left out (--no-yardsticks)".into());
    } else {
        if let Err(e) = sources::fluid_available() {
            say(format!("FluidR3_GM not available: {e}"));
            unavailable.insert(Source::Fluid, e);
        }
        match FaustRenderer::build(&plan.cache) {
            Ok(r) => faust = Some(r),
            Err(e) => {
                say(format!("Faust-STK not available: {e}"));
                unavailable.insert(Source::FaustStk, e);
            }
        }
    }
    let compared: Vec<Source> = Source::COMPARED.into_iter().filter(|s| !unavailable.contains_key(s)).collect();

    let pairs: Vec<(u8, u8)> = plan.keys.iter().flat_map(|&k| plan.layers.iter().map(move |&l| (k, l))).collect();
    say(format!(
        "{} recordings measured, then played by {} and measured, on {} job{}",
        pairs.len(),
        compared.iter().map(|s| s.title()).collect::<Vec<_>>().join(", "),
        plan.jobs,
        if plan.jobs == 1 { "" } else { "s" }
    ));
    let bar = progress(&args.quiet, (pairs.len() * (1 + compared.len())) as u64);
    let tick = || {
        if let Some(bar) = &bar {
            bar.inc(1);
        }
    };

    let references: Vec<Reference> = pool
        .install(|| {
            pairs
                .par_iter()
                .map(|&(key, layer)| {
                    check_interrupted()?;
                    let r = match plan.against {
                        Against::Salamander => reference(&plan.cache, key, layer),
                        Against::Fluid(program) => fluid_reference(program, key, layer),
                    };
                    tick();
                    r
                })
                .collect::<Result<Vec<_>, Failure>>()
        })
        .inspect_err(|_| finish(&bar))?;

    let jobs: Vec<(usize, Source)> =
        (0..references.len()).flat_map(|i| compared.iter().map(move |&s| (i, s))).collect();
    let measured: Vec<(usize, Source, Result<Features, String>)> = pool
        .install(|| {
            jobs.par_iter()
                .map(|&(i, source)| {
                    check_interrupted()?;
                    let r = &references[i];
                    let velocity = layer_velocity(r.layer);
                    let rendered = match source {
                        Source::Struck => sources::render_struck(
                            &plan.preset,
                            r.key,
                            velocity,
                            r.render_s,
                            plan.output,
                            SAMPLE_RATE_HZ,
                        ),
                        Source::Fluid => sources::render_fluid(0, r.key, velocity, r.render_s, SAMPLE_RATE_HZ),
                        Source::FaustStk => match &faust {
                            Some(f) => f.render(r.key, velocity, r.render_s, SAMPLE_RATE_HZ),
                            None => Err("not available".into()),
                        },
                        Source::Recording => Err("not a rendered source".into()),
                    };
                    let features = rendered.map(|signal| measure_render(&signal, r));
                    tick();
                    Ok((i, source, features))
                })
                .collect::<Result<Vec<_>, Failure>>()
        })
        .inspect_err(|_| finish(&bar))?;
    finish(&bar);

    let mut takes: Vec<Take> = references
        .iter()
        .map(|r| {
            report::take(r.key, r.layer, layer_velocity(r.layer), r.context.band_hz, r.measured_s, r.features.clone())
        })
        .collect();
    for (i, source, features) in measured {
        takes[i].sources.insert(source, features);
    }
    report::compare(&mut takes);
    let summary = report::summarize(&takes);
    let wall_s = started.elapsed().as_secs_f64();

    let failures: Vec<String> = takes
        .iter()
        .flat_map(|t| {
            t.sources.iter().filter_map(move |(s, f)| {
                f.as_ref().err().map(|e| format!("{} {} v{}: {e}", s.title(), t.note, t.velocity))
            })
        })
        .collect();
    for line in failures.iter().take(5) {
        say(format!("failed: {line}"));
    }
    if failures.len() > 5 {
        say(format!("... and {} more failed renders (the JSON lists them)", failures.len() - 5));
    }

    if let (Some(slot), Some(path)) = (json_slot, &args.json) {
        let value = serde_json::json!({
            "recordings": plan.against.describe(),
            "instrument": plan.preset.instrument.unwrap_or(InstrumentKind::Piano).name(),
            "sample_rate_hz": SAMPLE_RATE_HZ,
            "struck_output": match plan.output { Output::Microphones => "mics", Output::BridgeForce => "bridge" },
            "layers": plan.layers,
            "velocities": plan.layers.iter().map(|&l| layer_velocity(l)).collect::<Vec<_>>(),
            "notes": plan.keys.iter().map(|&k| crate::compare::note_name(k)).collect::<Vec<_>>(),
            "unavailable": unavailable.iter().map(|(s, e)| (s.key(), e.clone())).collect::<BTreeMap<_, _>>(),
            "wall_s": wall_s,
            "summary": summary,
            "takes": takes,
        });
        staged.fill_with(slot, path, |w| {
            serde_json::to_writer_pretty(&mut *w, &value).map_err(io::Error::other)?;
            io::Write::write_all(w, b"\n")
        })?;
    }
    if let (Some(slot), Some(path)) = (csv_slot, &args.csv) {
        staged.fill_with(slot, path, |w| report::write_csv(w, &takes))?;
    }
    if let (Some(slot), Some(path)) = (doc_slot, &args.doc) {
        let text = doc_with_table(path, &report::markdown_table(&summary, &unavailable))?;
        staged.fill_with(slot, path, |w| io::Write::write_all(w, text.as_bytes()))?;
    }
    staged.commit()?;

    let reference_title = plan.against.title();
    for line in report::table(&summary, &unavailable, &reference_title) {
        console::out(line);
    }
    if !args.quiet {
        console::out("");
        for line in report::checks(&takes, &reference_title) {
            console::out(line);
        }
        console::out("");
        console::out("Struck's furthest notes per feature (note, velocity, error):");
        for line in report::worst(&takes, Source::Struck, 4) {
            console::out(line);
        }
        console::out("");
        console::out(format!(
            "{} x {}, {} in {:.0} s on {} job{}",
            super::render::count(plan.keys.len(), "note"),
            super::render::count(plan.layers.len(), "layer"),
            super::render::count(compared.len(), "source"),
            wall_s,
            plan.jobs,
            if plan.jobs == 1 { "" } else { "s" }
        ));
    }
    Ok(())
}

/// Decode and measure the recording of `key` in `layer`.
fn reference(cache: &Path, key: u8, layer: u8) -> Result<Reference, Failure> {
    let path = salamander::recording(cache, key, layer);
    let decoded = salamander::decode_ogg(&path).map_err(Failure::failed)?;
    let fs = f64::from(decoded.sample_rate_hz);
    if (fs - SAMPLE_RATE_HZ).abs() > 0.5 {
        return Err(Failure::failed(format!("{}: sampled at {fs} Hz, not 48 kHz", path.display())));
    }
    let signal = crate::compare::measure::mono_sum(&decoded.samples, decoded.channels);
    Ok(measure_reference(&signal, key, layer, FADE_S))
}

/// FluidR3's `program` playing `key` at the layer's velocity, measured as a
/// recording is.
fn fluid_reference(program: u8, key: u8, layer: u8) -> Result<Reference, Failure> {
    let signal = sources::render_fluid(program, key, layer_velocity(layer), FLUID_REFERENCE_S, SAMPLE_RATE_HZ)
        .map_err(Failure::failed)?;
    Ok(measure_reference(&signal, key, layer, 0.0))
}

/// Measure a reference `signal` at 48 kHz, leaving out its last `fade_s`.
fn measure_reference(signal: &[f64], key: u8, layer: u8, fade_s: f64) -> Reference {
    let fs = SAMPLE_RATE_HZ;
    let length_s = signal.len() as f64 / fs;
    let mut analyzer = Analyzer::new();
    let onset_s = crate::compare::measure::onset(signal, fs) as f64 / fs;
    let measured_s = (length_s - fade_s - onset_s).clamp(0.5, MAX_MEASURED_S);
    let cutoff = analyzer.cutoff(signal, (onset_s * fs) as usize, fs);
    let context = Context {
        nominal_hz: nominal_hz(key),
        band_hz: cutoff * (1.0 - BAND_MARGIN),
        usable_end_s: onset_s + measured_s,
    };
    let features = analyzer.measure(signal, fs, &context);
    Reference { key, layer, features, context, measured_s, render_s: LEAD_S + measured_s }
}

/// Measure a render over the recording's span, from the render's own onset.
fn measure_render(signal: &[f64], reference: &Reference) -> Features {
    let onset_s = crate::compare::measure::onset(signal, SAMPLE_RATE_HZ) as f64 / SAMPLE_RATE_HZ;
    let context = Context { usable_end_s: onset_s + reference.measured_s, ..reference.context };
    Analyzer::new().measure(signal, SAMPLE_RATE_HZ, &context)
}

fn check_interrupted() -> Result<(), Failure> {
    if crate::cleanup::interrupted() { Err(Failure::interrupted()) } else { Ok(()) }
}

fn progress(quiet: &bool, total: u64) -> Option<ProgressBar> {
    (!*quiet && io::stderr().is_terminal()).then(|| {
        let style = ProgressStyle::with_template("{spinner} comparing [{bar:40}] {pos}/{len} (eta {eta})")
            .unwrap_or_else(|_| ProgressStyle::default_bar())
            .progress_chars("=> ");
        ProgressBar::new(total).with_style(style)
    })
}

fn finish(bar: &Option<ProgressBar>) {
    if let Some(bar) = bar {
        bar.finish_and_clear();
    }
}
