//! The hammer design charts (Euphonics 12.2, Figs. 15-17) and the universal
//! chart (Figs. 18-22), drawn from [`crate::strike::sweep`].
//!
//! A grid point where the hammer was still pressing on the string when the
//! simulation stopped (after [`CHART_PERIODS`] periods of the string) has no
//! contact time or centroid to show and is drawn grey ("no data").

use std::path::Path;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Instant;

use crate::strike::seed;
use crate::strike::sweep::{self, GridResult, HammerGrid, StrikeSummary, UniversalScale};
use crate::strike::{ExciterSpec, StrikeCase};
use indicatif::{ProgressBar, ProgressStyle};

use crate::figures::{Drawn, FIGURE_RATE_HZ};
use crate::plot::{Colour, ColourMap, Heatmap, Marker, MarkerShape, Scale};

/// How long each grid point may run, in periods of the string's first partial.
pub const CHART_PERIODS: f64 = 30.0;
/// The universal chart's mass axis: hammer mass over string mass.
pub const MU_RANGE: (f64, f64) = (0.02, 30.0);
/// The universal chart's stiffness axis: kappa = K (V/f1)^(alpha-1) / (T/L).
pub const KAPPA_RANGE: (f64, f64) = (0.3, 1.0e6);
/// The exponent of the universal chart (the C4 hammer's).
pub const REFERENCE_EXPONENT: f64 = 2.5;

/// How a chart's grid is laid out and run.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct GridOptions {
    /// Points along each axis.
    pub size: usize,
    /// Masses spaced logarithmically (else linearly from near zero to twice the nominal).
    pub log_mass: bool,
    /// Show a progress bar.
    pub progress: bool,
}

/// `case` with its duration set to [`CHART_PERIODS`] periods of its string.
fn capped(case: &StrikeCase) -> StrikeCase {
    let f1 = case.build_string().partial_hz(1);
    StrikeCase { duration_s: CHART_PERIODS / f1, ..case.clone() }
}

/// Run `grid` on every core with a progress bar; returns the result and seconds taken.
fn run(grid: &HammerGrid, what: &str, options: &GridOptions) -> (GridResult, f64) {
    let started = Instant::now();
    let bar = if options.progress { ProgressBar::new(grid.len() as u64) } else { ProgressBar::hidden() };
    bar.set_style(
        ProgressStyle::with_template("{msg:>28} [{bar:40}] {pos}/{len} {elapsed}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar.set_message(what.to_string());
    let done = AtomicU64::new(0);
    let result = sweep::run_grid(grid, &|| {
        let n = done.fetch_add(1, Ordering::Relaxed) + 1;
        if n.is_multiple_of(16) {
            bar.set_position(n);
        }
    });
    bar.finish_and_clear();
    let seconds = started.elapsed().as_secs_f64();
    if options.progress {
        crate::console::out(format!(
            "{what}: {} strikes on {} threads in {seconds:.1} s",
            grid.len(),
            rayon::current_num_threads()
        ));
    }
    (result, seconds)
}

fn values(result: &GridResult, pick: impl Fn(&StrikeSummary) -> Option<f64>) -> Vec<f64> {
    result.summaries.iter().map(|s| if s.in_contact_at_cap { f64::NAN } else { pick(s).unwrap_or(f64::NAN) }).collect()
}

fn draw(map: &Heatmap, dir: &Path, name: &str) -> anyhow::Result<Drawn> {
    let drawn = Drawn { png: dir.join(format!("{name}.png")), csv: dir.join(format!("{name}.csv")) };
    map.draw(&drawn.png)?;
    map.write_csv(&drawn.csv)?;
    Ok(drawn)
}

fn hammer_of(case: &StrikeCase) -> anyhow::Result<struck_engine::exciter::hammer::HammerSpec> {
    match case.exciter {
        ExciterSpec::Hammer(h) => Ok(h),
        _ => anyhow::bail!("a hammer chart needs a hammer"),
    }
}

/// Figs. 15-17 for `case`'s string and hammer: contact time, contacts and
/// centroid over a grid of masses and stiffnesses. Files are named
/// `{prefix}15-...` when `prefix` is "fig", else `{prefix}-contact-time` etc.
pub fn hammer_charts(case: &StrikeCase, options: &GridOptions, dir: &Path, prefix: &str) -> anyhow::Result<Vec<Drawn>> {
    let case = capped(case);
    let nominal = hammer_of(&case)?;
    let n = options.size;
    let grid =
        if options.log_mass { HammerGrid::log_mass(&case, n, n)? } else { HammerGrid::linear_mass(&case, n, n)? };
    let name = case.name.clone().unwrap_or_else(|| "the case".into());
    let (result, _) = run(&grid, "hammer chart", options);
    let x: Vec<f64> = result.masses_kg.iter().map(|m| m * 1e3).collect();
    let marker = Marker {
        label: format!(
            "nominal hammer ({:.1} g, K {:.2e}, alpha {})",
            nominal.mass_kg * 1e3,
            nominal.law.stiffness,
            nominal.law.exponent
        ),
        x: nominal.mass_kg * 1e3,
        y: nominal.law.stiffness,
        shape: MarkerShape::Star,
        colour: Colour::CYAN,
    };
    let base = Heatmap {
        x_label: "hammer mass (g)".into(),
        y_label: format!("contact stiffness K (N/m^{})", nominal.law.exponent),
        x,
        y: result.stiffnesses.clone(),
        x_scale: if options.log_mass { Scale::Log } else { Scale::Linear },
        y_scale: Scale::Log,
        markers: vec![marker],
        ..Heatmap::default()
    };
    let speed = nominal.speed_m_s;
    let charts = [
        (
            "15",
            "contact-time",
            "total contact time",
            "contact time (ms)",
            ColourMap::Hot,
            values(&result, |s| Some(s.contact_time_s * 1e3)),
        ),
        (
            "16",
            "contacts",
            "number of contacts",
            "contacts",
            ColourMap::Counts,
            values(&result, |s| Some(s.contact_count as f64)),
        ),
        (
            "17",
            "centroid",
            "spectral centroid of the contact force",
            "centroid (Hz)",
            ColourMap::Hot,
            values(&result, |s| s.spectral_centroid_hz),
        ),
    ];
    let mut drawn = Vec::new();
    for (number, slug, what, unit, colour_map, values) in charts {
        let title = if prefix == "fig" {
            format!("Fig. {number}: {name}, {what}")
        } else {
            format!("{name}: {what}, {speed} m/s")
        };
        let map = Heatmap { title, colour_label: unit.into(), colour_map, values, ..base.clone() };
        let file = if prefix == "fig" { format!("fig{number}-hammer-{slug}") } else { format!("{prefix}-{slug}") };
        drawn.push(draw(&map, dir, &file)?);
    }
    Ok(drawn)
}

/// Where the piano's eight Cs fall on the universal chart: with the C4 hammer
/// (squares), with their own hammers' masses (stars), and with their own
/// hammers' felt brought to the chart's exponent (circles).
#[derive(Clone, Debug, PartialEq)]
pub struct CMarkers {
    pub squares: Vec<(f64, f64)>,
    pub stars: Vec<(f64, f64)>,
    pub circles: Vec<(f64, f64)>,
}

/// The Cs' positions, (mu, kappa) each, C1 to C8.
pub fn c_markers() -> anyhow::Result<CMarkers> {
    let v = seed::CHART_SPEED_M_S;
    let c4 = seed::piano_c_hammer(4, v);
    let mut m = CMarkers { squares: Vec::new(), stars: Vec::new(), circles: Vec::new() };
    for octave in 1..=8u8 {
        let own = capped(&seed::piano_c_case(octave, octave, v, true, FIGURE_RATE_HZ, 1.0));
        let scale = UniversalScale::of_case(&StrikeCase { exciter: ExciterSpec::Hammer(c4), ..own.clone() })?;
        let real = hammer_of(&own)?;
        m.squares.push((scale.mu(c4.mass_kg), scale.kappa(c4.law.stiffness)));
        m.stars.push((scale.mu(real.mass_kg), scale.kappa(c4.law.stiffness)));
        let equivalent = sweep::equivalent_stiffness(&own, REFERENCE_EXPONENT)?;
        m.circles.push((scale.mu(real.mass_kg), scale.kappa(equivalent)));
    }
    Ok(m)
}

/// Captions of Figs. 15-22, in order.
pub fn captions() -> Vec<(String, String)> {
    let grey = " Grey: the hammer was still on the string when the simulation stopped.";
    [
        ("Fig. 15", format!("Design chart for C4 (the whole three-string course as one string): hammers from nearly no mass to twice the nominal 9 g, felt stiffness K over four decades around the nominal 4.5e9 (alpha 2.5), all at 2.5 m/s, shaded by total contact time. Lighter or stiffer hammers leave sooner; heavier or softer ones stay longer.{grey}")),
        ("Fig. 16", "The same grid shaded by the number of contacts (gaps under 50 us merged): white is a single contact, colours are bounces.".to_string()),
        ("Fig. 17", format!("The same grid shaded by the spectral centroid of the contact force: light, stiff hammers give a bright pulse, heavy, soft ones a dull one.{grey}")),
        ("Fig. 18", format!("The universal chart: hammer mass over the string's vibrating mass against kappa = K (V/f1)^(alpha-1) / (T/L), which is K/(T/L) for a linear felt, with contact time in periods of the string; computed on C4, alpha 2.5, 2.5 m/s. Squares: the eight Cs of the piano as if all had the C4 hammer.{grey}")),
        ("Fig. 19", "As Fig. 18, with stars for the Cs' own hammer masses (12 g at C1 down to 5 g at C8) and the C4 felt.".to_string()),
        ("Fig. 20", "As Fig. 19, with circles for the Cs' own hammers, their felt exponent brought to 2.5 by simulation: each circle's K is the one that, with alpha 2.5, gives the same total contact time as the real felt (measured for C2, C4 and C7; the scale interpolates the others).".to_string()),
        ("Fig. 21", "The universal grid shaded by the number of contacts, with the same markers.".to_string()),
        ("Fig. 22", format!("The universal grid shaded by the centroid of the contact force as a harmonic number (centroid / f1), with the same markers.{grey}")),
    ]
    .into_iter()
    .map(|(l, c)| (l.to_string(), c))
    .collect()
}

/// Figs. 18-22: the universal chart on the C4 string with the Cs marked.
pub fn universal_charts(options: &GridOptions, dir: &Path) -> anyhow::Result<Vec<Drawn>> {
    let reference = capped(&seed::piano_c_case(4, 4, seed::CHART_SPEED_M_S, true, FIGURE_RATE_HZ, 1.0));
    let n = options.size;
    let mus = sweep::log_space(MU_RANGE.0, MU_RANGE.1, n);
    let kappas = sweep::log_space(KAPPA_RANGE.0, KAPPA_RANGE.1, n);
    let grid = HammerGrid::normalised(&reference, &mus, &kappas)?;
    let (result, _) = run(&grid, "universal chart", options);
    let cs = c_markers()?;
    let mark = |points: &[(f64, f64)], label: &str, shape: MarkerShape, colour: Colour| -> Vec<Marker> {
        points.iter().map(|&(x, y)| Marker { label: label.to_string(), x, y, shape, colour }).collect()
    };
    let squares = mark(&cs.squares, "C1-C8 with the C4 hammer", MarkerShape::Square, Colour::CYAN);
    let stars = mark(&cs.stars, "their own hammer masses", MarkerShape::Star, Colour::CYAN);
    let circles = mark(&cs.circles, "own hammers, exponent compensated", MarkerShape::Circle, Colour::GREEN);
    let base = Heatmap {
        x_label: "hammer mass / string mass".into(),
        y_label: "kappa = K (V/f1)^(alpha-1) / (T/L)".into(),
        x: result.mus(),
        y: result.kappas(),
        x_scale: Scale::Log,
        y_scale: Scale::Log,
        ..Heatmap::default()
    };
    let time = values(&result, |s| Some(s.contact_periods()));
    let contacts = values(&result, |s| Some(s.contact_count as f64));
    let centroid = values(&result, StrikeSummary::centroid_harmonic);
    let all: Vec<Marker> = [squares.clone(), stars.clone(), circles.clone()].concat();
    let charts = [
        ("18", "contact-time", "contact time", "contact time (periods)", ColourMap::Hot, &time, squares.clone()),
        (
            "19",
            "contact-time-masses",
            "contact time, real masses",
            "contact time (periods)",
            ColourMap::Hot,
            &time,
            [squares.clone(), stars].concat(),
        ),
        (
            "20",
            "contact-time-compensated",
            "contact time, exponent compensated",
            "contact time (periods)",
            ColourMap::Hot,
            &time,
            all.clone(),
        ),
        ("21", "contacts", "number of contacts", "contacts", ColourMap::Counts, &contacts, all.clone()),
        ("22", "centroid", "spectral centroid", "centroid (harmonic number)", ColourMap::Hot, &centroid, all),
    ];
    let mut drawn = Vec::new();
    for (number, slug, what, unit, colour_map, values, markers) in charts {
        let map = Heatmap {
            title: format!("Fig. {number}: universal chart, {what}"),
            colour_label: unit.into(),
            colour_map,
            values: values.clone(),
            markers,
            ..base.clone()
        };
        drawn.push(draw(&map, dir, &format!("fig{number}-universal-{slug}"))?);
    }
    Ok(drawn)
}
