//! `struck chart ...`: the lab's design charts as PNGs with the numbers behind
//! them as CSV (one pair per chart, in `--out DIR`).

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::strike::{self, StrikeCase, seed};
use clap::{Args, Subcommand};
use struck_engine::design::InstrumentKind;

use crate::cli::Failure;
use crate::console;
use crate::figures::hammer::{self, GridOptions};
use crate::figures::{self, Drawn};

/// Largest grid side accepted.
pub const MAX_GRID: usize = 512;
/// Most strikes one strike chart draws (cases times speeds): each is a line.
pub const MAX_STRIKES: usize = 64;

#[derive(Args)]
pub struct ChartArgs {
    #[command(subcommand)]
    pub chart: Chart,
    /// Directory for the PNGs and CSVs (created if missing).
    #[arg(long, value_name = "DIR", global = true, default_value = "charts")]
    pub out: PathBuf,
}

#[derive(Subcommand)]
pub enum Chart {
    /// Hammer design charts (Figs. 15-17 of the seed): a grid of hammer mass x
    /// contact stiffness K, coloured by total contact time, number of contacts
    /// (gaps under 50 us merged) and spectral centroid of the contact force.
    Hammer(HammerArgs),
    /// The universal chart (Figs. 18-22): normalised mass and stiffness, contact
    /// time in string periods, with the piano's eight Cs marked.
    Universal(UniversalArgs),
    /// Stringing charts (Figs. 8-10): mass per length, tension and total
    /// impedance per key, breaks between string counts marked.
    Stringing(StringingArgs),
    /// Strike charts: contact and bridge force against time and their spectra,
    /// for one or more strike cases on one plot.
    Strike(StrikeChartArgs),
    /// Clavichord charts (Figs. 29-31): pitch rise against tangent depth,
    /// tangent motions, Q with and without the leak past the tangent.
    Clavichord,
    /// The instrument's body: the board's bridge mobility |Y(f)| at the lowest,
    /// middle and highest keys' bridge points against the Skudrzyk mean and
    /// (piano) Wogram's measurement; the close microphones' pressure per newton
    /// at the middle key; the mode count, the board's and the running body's.
    Body(StringingArgs),
}

#[derive(Args)]
pub struct HammerArgs {
    /// Instrument whose key is struck (any with hammers or mallets).
    #[arg(long, default_value = "piano", value_name = "NAME")]
    pub instrument: String,
    /// The key: a note name (C4, F#2, Bb5) or a MIDI number.
    #[arg(long, default_value = "C4", value_name = "NOTE")]
    pub key: String,
    /// A strike case file (JSON) with a hammer, instead of --instrument/--key.
    #[arg(long, value_name = "FILE", conflicts_with_all = ["instrument", "key"])]
    pub case: Option<PathBuf>,
    /// Hammer speed, m/s [default: 2.5, forte; a case file's own speed]
    #[arg(long, value_name = "M/S", allow_negative_numbers = true)]
    pub speed: Option<f64>,
    #[command(flatten)]
    pub grid: GridArgs,
}

#[derive(Args)]
pub struct GridArgs {
    /// Grid points along each axis.
    #[arg(long, default_value_t = 64, value_name = "N")]
    pub grid: usize,
    /// Logarithmically spaced masses (the universal chart's layout) instead of
    /// linear ones from near zero to twice the nominal hammer.
    #[arg(long)]
    pub log_mass: bool,
}

#[derive(Args)]
pub struct UniversalArgs {
    /// Grid points along each axis.
    #[arg(long, default_value_t = 64, value_name = "N")]
    pub grid: usize,
}

#[derive(Args)]
pub struct StringingArgs {
    #[arg(long, default_value = "piano", value_name = "NAME")]
    pub instrument: String,
}

#[derive(Args)]
pub struct StrikeChartArgs {
    /// Strike case files (JSON), drawn together.
    #[arg(required = true)]
    pub cases: Vec<PathBuf>,
    /// Change a field of every case, e.g. --set exciter.speed_m_s=2.5 (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub sets: Vec<String>,
    /// Run each case at each of these hammer or tangent speeds (m/s, comma-separated).
    #[arg(long, value_name = "V,V,...", value_delimiter = ',', allow_negative_numbers = true)]
    pub speeds: Vec<f64>,
    /// Divide the contact force by the speed (the seed's Fig. 13).
    #[arg(long)]
    pub per_speed: bool,
}

fn parse_kind(name: &str) -> Result<InstrumentKind, Failure> {
    name.parse::<InstrumentKind>().map_err(|e| Failure::bad_input(format!("--instrument: {e}")))
}

/// Read and check a case file, with `--set` edits.
pub fn read_case(path: &Path, sets: &[String]) -> Result<StrikeCase, Failure> {
    let text = super::input::read_text(path, super::input::MAX_CASE_BYTES)?;
    strike::parse_case(&text, sets).map_err(|e| Failure::bad_input(format!("{}: {e}", super::shown(path))))
}

fn check_grid(grid: usize) -> Result<(), Failure> {
    if (2..=MAX_GRID).contains(&grid) {
        Ok(())
    } else {
        Err(Failure::bad_input(format!("--grid: must lie between 2 and {MAX_GRID} (got {grid})")))
    }
}

fn check_speed(speed: f64) -> Result<f64, Failure> {
    if speed.is_finite() && speed > 0.0 && speed <= 100.0 {
        Ok(speed)
    } else {
        Err(Failure::bad_input(format!(
            "--speed: must be a speed above 0 and at most 100 m/s (got {})",
            struck_engine::readable(speed)
        )))
    }
}

/// The hammer case a `struck chart hammer` asks for.
pub fn hammer_case(args: &HammerArgs) -> Result<StrikeCase, Failure> {
    let mut case = match &args.case {
        Some(path) => read_case(path, &[])?,
        None => {
            let kind = parse_kind(&args.instrument)?;
            let key = seed::parse_note(&args.key).ok_or_else(|| {
                Failure::bad_input(format!("--key: '{}' is not a note (C4, F#2, Bb5) or MIDI number", args.key))
            })?;
            let speed = check_speed(args.speed.unwrap_or(seed::CHART_SPEED_M_S))?;
            seed::key_case(kind, key, speed, figures::FIGURE_RATE_HZ, 0.2).ok_or_else(|| {
                Failure::bad_input(format!(
                    "--key: the {} has no strings of its own at {} (range {} to {})",
                    kind.name(),
                    seed::note_name(key),
                    seed::note_name(*kind.key_range().start()),
                    seed::note_name(*kind.key_range().end())
                ))
            })?
        }
    };
    match &mut case.exciter {
        strike::ExciterSpec::Hammer(h) => {
            if let Some(speed) = args.speed {
                h.speed_m_s = check_speed(speed)?;
            }
            Ok(case)
        }
        _ => Err(Failure::bad_input(match &args.case {
            Some(path) => format!("{}: exciter.kind: a hammer chart needs a hammer", path.display()),
            None => format!("--instrument: the {} has no hammer; a hammer chart needs one", args.instrument),
        })),
    }
}

fn report(drawn: &[Drawn], started: Instant) {
    for d in drawn {
        console::out(format!("wrote {} and {}", d.png.display(), d.csv.display()));
    }
    console::out(format!("took {:.1} s", started.elapsed().as_secs_f64()));
}

pub fn run(args: &ChartArgs) -> Result<(), Failure> {
    let started = Instant::now();
    // Drawn into a folder inside --out, then moved out of it together.
    let final_out = &args.out;
    let staging = super::output::StagedFolder::within(final_out)?;
    let out = staging.path();
    let failed = |e: anyhow::Error| staging.failure(final_out, &e);
    let drawn = match &args.chart {
        Chart::Hammer(h) => {
            check_grid(h.grid.grid)?;
            let case = hammer_case(h)?;
            let options = GridOptions { size: h.grid.grid, log_mass: h.grid.log_mass, progress: true };
            hammer::hammer_charts(&case, &options, out, "hammer").map_err(failed)?
        }
        Chart::Universal(u) => {
            check_grid(u.grid)?;
            let options = GridOptions { size: u.grid, log_mass: true, progress: true };
            hammer::universal_charts(&options, out).map_err(failed)?
        }
        Chart::Stringing(s) => {
            let kind = parse_kind(&s.instrument)?;
            figures::stringing(kind, out, "stringing").map_err(failed)?
        }
        Chart::Strike(s) => {
            let runs = s.cases.len() * s.speeds.len().max(1);
            if runs > MAX_STRIKES {
                let (cases, speeds) = (s.cases.len(), s.speeds.len());
                return Err(Failure::bad_input(if speeds == 0 {
                    format!("{cases} cases make {runs} strikes on one chart (at most {MAX_STRIKES})")
                } else {
                    format!(
                        "--speeds: {cases} cases at {speeds} speeds make {runs} strikes on one chart (at most {MAX_STRIKES})"
                    )
                }));
            }
            let mut cases = Vec::new();
            for path in &s.cases {
                let case = read_case(path, &s.sets)?;
                if s.speeds.is_empty() {
                    cases.push(case.clone());
                }
                for &v in &s.speeds {
                    let v = check_speed(v).map_err(|_| {
                        Failure::bad_input(format!(
                            "--speeds: each must be above 0 and at most 100 m/s (got {})",
                            struck_engine::readable(v)
                        ))
                    })?;
                    let mut c = case.clone();
                    match &mut c.exciter {
                        strike::ExciterSpec::Hammer(h) => h.speed_m_s = v,
                        strike::ExciterSpec::Tangent(t) => t.speed_m_s = v,
                        strike::ExciterSpec::Pluck(_) => {
                            return Err(Failure::bad_input(format!(
                                "--speeds: {} is a pluck, which has no speed",
                                path.display()
                            )));
                        }
                    }
                    c.name = Some(format!("{} at {v} m/s", c.name.as_deref().unwrap_or("case")));
                    cases.push(c);
                }
            }
            // Every run is held until the charts are drawn.
            let memory = cases.iter().map(strike::run::peak_bytes).sum();
            let what = format!("{} on one chart", super::render::count(cases.len(), "strike"));
            super::room::check(&what, memory, 0, final_out)?;
            figures::strikes(&cases, out, s.per_speed).map_err(failed)?
        }
        Chart::Clavichord => figures::clavichord(out).map_err(failed)?,
        Chart::Body(b) => {
            let kind = parse_kind(&b.instrument)?;
            figures::body::body(kind, out).map_err(failed)?
        }
    };
    let inputs: Vec<&Path> = match &args.chart {
        Chart::Hammer(h) => h.case.iter().map(PathBuf::as_path).collect(),
        Chart::Strike(s) => s.cases.iter().map(PathBuf::as_path).collect(),
        _ => Vec::new(),
    };
    staging.commit_into(final_out, &inputs)?;
    let placed = |p: &Path| final_out.join(p.file_name().unwrap_or_default());
    let drawn: Vec<Drawn> = drawn.iter().map(|d| Drawn { png: placed(&d.png), csv: placed(&d.csv) }).collect();
    report(&drawn, started);
    Ok(())
}
