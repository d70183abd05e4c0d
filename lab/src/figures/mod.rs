//! The seed's figures (Euphonics 12.2) as charts: each is computed by the lab,
//! drawn as a PNG and written out as the CSV of its numbers. `struck chart` and
//! `struck demo` both draw them through here.
//!
//! Strike figures are taken at 96 kHz (the reference cases' rate); spectra of a
//! force pulse are of the whole pulse, spectra of a bridge force of a
//! Hann-windowed stretch of it.

pub mod body;
pub mod hammer;

use std::path::{Path, PathBuf};

use crate::analysis::spectrum::{hann, magnitude_spectrum};
use crate::strike::seed::{self, Stringing};
use crate::strike::{self, LabRun, StrikeCase};
use struck_engine::design::{InstrumentKind, clavichord_pitch_rise_cents};
use struck_engine::exciter::tangent::TangentSpec;

use crate::plot::{Colour, LinePlot, MarkerShape, Scale, Series};

/// Sample rate of the strike figures, Hz.
pub const FIGURE_RATE_HZ: f64 = 96_000.0;

/// A drawn chart: where its picture and numbers went.
#[derive(Clone, Debug, PartialEq)]
pub struct Drawn {
    pub png: PathBuf,
    pub csv: PathBuf,
}

/// Draw `plot` as DIR/NAME.png with its numbers in DIR/NAME.csv.
pub fn draw_line(plot: &LinePlot, dir: &Path, name: &str) -> anyhow::Result<Drawn> {
    let drawn = Drawn { png: dir.join(format!("{name}.png")), csv: dir.join(format!("{name}.csv")) };
    plot.draw(&drawn.png)?;
    plot.write_csv(&drawn.csv)?;
    Ok(drawn)
}

/// The seed's line colours, in the order its multi-curve figures use them.
pub const SPEED_COLOURS: [Colour; 5] = [Colour::GREEN, Colour::BLUE, Colour::MAGENTA, Colour::RED, Colour::BLACK];

fn series(label: impl Into<String>, colour: Colour, points: Vec<(f64, f64)>) -> Series {
    Series::line(label, colour, points)
}

fn plot(title: impl Into<String>, x_label: &str, y_label: &str, series: Vec<Series>) -> LinePlot {
    LinePlot { series, ..LinePlot::new(title, x_label, y_label) }
}

/// A chart of forces against time from 0 to `until_s`, in ms.
fn timed(title: impl Into<String>, y_label: &str, until_s: f64, series: Vec<Series>) -> LinePlot {
    LinePlot { x_range: Some((0.0, until_s * 1e3)), ..plot(title, "time (ms)", y_label, series) }
}

/// Time (ms) against `values`, from sample 0 to `until_s`.
fn against_time_ms(values: &[f64], sample_rate_hz: f64, until_s: f64, scale: f64) -> Vec<(f64, f64)> {
    let rows = ((until_s * sample_rate_hz).ceil() as usize).min(values.len());
    (0..rows).map(|i| (i as f64 / sample_rate_hz * 1e3, values[i] * scale)).collect()
}

/// End of the last contact of a hammer run, s (0 when there was none).
fn contact_end_s(run: &LabRun) -> f64 {
    run.metrics.contacts.last().map_or(0.0, |c| c.end_s)
}

/// Magnitude spectrum in dB of `signal` (whole, or Hann-windowed when `windowed`),
/// relative to `reference` (None: its own peak), up to `max_hz`, bin 0 left out.
fn spectrum_db(
    signal: &[f64],
    sample_rate_hz: f64,
    windowed: bool,
    max_hz: f64,
    reference: Option<f64>,
) -> Vec<(f64, f64)> {
    // Zero-pad a short pulse to at least 1/8 s so its spectrum is finely sampled.
    let n = signal.len().max((sample_rate_hz / 8.0) as usize);
    let mut padded = signal.to_vec();
    let window = windowed.then(|| hann(signal.len()));
    if let Some(w) = &window {
        padded.iter_mut().zip(w).for_each(|(x, w)| *x *= w);
    }
    padded.resize(n, 0.0);
    let spectrum = magnitude_spectrum(&padded, None);
    let bin_hz = sample_rate_hz / n as f64;
    let reference = reference.unwrap_or_else(|| spectrum.iter().skip(1).fold(0.0f64, |m, &v| m.max(v)));
    spectrum
        .iter()
        .enumerate()
        .skip(1)
        .take_while(|(i, _)| *i as f64 * bin_hz <= max_hz)
        .map(|(i, &v)| (i as f64 * bin_hz, 20.0 * (v.max(1e-300) / reference).log10()))
        .collect()
}

/// Figs. 3-5: the santoor mallet's force pulse and spectra, at 2/5 and 1/10.
pub fn santoor(dir: &Path) -> anyhow::Result<Vec<Drawn>> {
    let at_2_5 = strike::run(&seed::santoor_mallet(1e-3, 0.4, FIGURE_RATE_HZ, 0.5));
    let at_1_10 = strike::run(&seed::santoor_mallet(1e-3, 0.1, FIGURE_RATE_HZ, 0.5));
    let fs = FIGURE_RATE_HZ;
    let until = contact_end_s(&at_2_5).max(contact_end_s(&at_1_10)) * 1.15;
    let mut drawn = Vec::new();
    let fig3 = timed(
        "Fig. 3: santoor string, 1 g mallet at 1 m/s, struck at 2/5",
        "contact force (N)",
        until,
        vec![series("", Colour::RED, against_time_ms(&at_2_5.trace.contact_force_n, fs, until, 1.0))],
    );
    drawn.push(draw_line(&fig3, dir, "fig03-santoor-force")?);

    let pulse = &at_2_5.trace.contact_force_n[..((until * fs) as usize).min(at_2_5.trace.len())];
    let fig4 = LinePlot {
        y_range: Some((-80.0, 5.0)),
        ..plot(
            "Fig. 4: spectra of the contact force and of the bridge force",
            "frequency (Hz)",
            "level (dB re each curve's peak)",
            vec![
                series("contact force", Colour::RED, spectrum_db(pulse, fs, false, 10_000.0, None)),
                series(
                    "bridge force",
                    Colour::BLUE,
                    spectrum_db(&at_2_5.trace.bridge_force_n, fs, true, 10_000.0, None),
                ),
            ],
        )
    };
    drawn.push(draw_line(&fig4, dir, "fig04-santoor-spectra")?);

    let fig5 = timed(
        "Fig. 5: the 1 g mallet's force, struck at 1/10 and at 2/5",
        "contact force (N)",
        until,
        vec![
            series("at 2/5", Colour::RED, against_time_ms(&at_2_5.trace.contact_force_n, fs, until, 1.0)),
            series("at 1/10", Colour::BLUE, against_time_ms(&at_1_10.trace.contact_force_n, fs, until, 1.0)),
        ],
    );
    drawn.push(draw_line(&fig5, dir, "fig05-santoor-force-1-10")?);
    Ok(drawn)
}

/// Vertical dashed lines at the keys where the number of strings changes.
fn breaks(rows: &[Stringing], low: f64, high: f64) -> Vec<Series> {
    rows.windows(2)
        .filter(|w| w[0].strings != w[1].strings)
        .map(|w| {
            let x = w[1].midi_key as f64 - 0.5;
            Series::line(
                format!("{} to {} strings", w[0].strings, w[1].strings),
                Colour::GREY,
                vec![(x, low), (x, high)],
            )
        })
        .collect()
}

/// Figs. 8-10: mass per length, tension and total impedance per key of `kind`.
pub fn stringing(kind: InstrumentKind, dir: &Path, prefix: &str) -> anyhow::Result<Vec<Drawn>> {
    stringing_of(&seed::stringing(kind), kind.name(), dir, prefix)
}

/// Figs. 8-10 of the seed: the stringing of its Broadwood baby grand (drawn as
/// the piano's, the files named so).
pub fn broadwood_stringing(dir: &Path, prefix: &str) -> anyhow::Result<Vec<Drawn>> {
    stringing_of(&seed::broadwood_stringing(), InstrumentKind::Piano.name(), dir, prefix)
}

/// Figs. 8-10 of `rows`, the stringing of the instrument called `name`.
fn stringing_of(rows: &[Stringing], name: &str, dir: &Path, prefix: &str) -> anyhow::Result<Vec<Drawn>> {
    anyhow::ensure!(!rows.is_empty(), "the {name} has no strings of its own");
    type Column = fn(&Stringing) -> f64;
    let figures: [(&str, &str, &str, &str, Scale, Column); 3] = [
        ("8", "mass-per-length", "mass per length of one string", "mass per length (g/m)", Scale::Log, |r| {
            r.mass_per_length_kg_m * 1e3
        }),
        ("9", "tension", "tension of one string", "tension (N)", Scale::Linear, |r| r.tension_n),
        ("10", "impedance", "impedance of all the strings of a note", "total impedance (N s/m)", Scale::Linear, |r| {
            r.total_impedance_ns_m
        }),
    ];
    let mut drawn = Vec::new();
    for (number, slug, what, y_label, y_scale, value) in figures {
        let points: Vec<(f64, f64)> = rows.iter().map(|r| (r.midi_key as f64, value(r))).collect();
        let (low, high) = points.iter().fold((f64::MAX, f64::MIN), |(l, h), p| (l.min(p.1), h.max(p.1)));
        let mut all = vec![Series::markers(what, Colour::BLUE, MarkerShape::Circle, points)];
        all.extend(breaks(rows, if y_scale == Scale::Log { low } else { 0.0 }, high * 1.05));
        let mut p = plot(format!("Fig. {number}: {name}, {what}"), "MIDI key (60 = C4)", y_label, all);
        p.y_scale = y_scale;
        if y_scale == Scale::Linear {
            p.y_range = Some((0.0, high * 1.1));
        }
        let file =
            if prefix == "fig" { format!("fig{number:0>2}-{name}-{slug}") } else { format!("{prefix}-{name}-{slug}") };
        drawn.push(draw_line(&p, dir, &file)?);
    }
    Ok(drawn)
}

/// Figs. 12-14: C2 with its own hammer at the five speeds: force, force over
/// speed, spectra.
pub fn piano_speeds(dir: &Path) -> anyhow::Result<Vec<Drawn>> {
    let fs = FIGURE_RATE_HZ;
    let speeds = seed::boutillon_speeds();
    let runs: Vec<LabRun> = speeds.iter().map(|&v| strike::run(&seed::piano_c_case(2, 2, v, true, fs, 0.05))).collect();
    let until = runs.iter().map(contact_end_s).fold(0.0, f64::max) * 1.1;
    let label = |v: f64| format!("{v:.2} m/s");
    let curves = |scale_by_speed: bool| -> Vec<Series> {
        runs.iter()
            .zip(speeds)
            .zip(SPEED_COLOURS)
            .map(|((run, v), colour)| {
                let scale = if scale_by_speed { 1.0 / v } else { 1.0 };
                series(label(v), colour, against_time_ms(&run.trace.contact_force_n, fs, until, scale))
            })
            .collect()
    };
    let mut drawn = Vec::new();
    let fig12 = timed("Fig. 12: C2 and its own hammer at five speeds", "contact force (N)", until, curves(false));
    drawn.push(draw_line(&fig12, dir, "fig12-c2-force")?);
    let fig13 =
        timed("Fig. 13: the same forces divided by the hammer's speed", "force / speed (N s/m)", until, curves(true));
    drawn.push(draw_line(&fig13, dir, "fig13-c2-force-per-speed")?);
    // One reference for all five so the levels compare: 1 N s (a pulse's spectrum
    // at low frequency is its impulse).
    let spectra = runs
        .iter()
        .zip(speeds)
        .zip(SPEED_COLOURS)
        .map(|((run, v), colour)| {
            let pulse = &run.trace.contact_force_n[..((until * fs) as usize).min(run.trace.len())];
            let db = spectrum_db(pulse, fs, false, 10_000.0, Some(fs));
            series(label(v), colour, db.into_iter().filter(|p| p.0 >= 10.0).collect())
        })
        .collect();
    let mut fig14 = plot("Fig. 14: spectra of the five force pulses", "frequency (Hz)", "level (dB re 1 N s)", spectra);
    fig14.x_scale = Scale::Log;
    drawn.push(draw_line(&fig14, dir, "fig14-c2-force-spectra")?);
    Ok(drawn)
}

/// Fig. 26: the start of C7's bridge force with its contact force.
pub fn piano_c7(dir: &Path) -> anyhow::Result<Vec<Drawn>> {
    let fs = FIGURE_RATE_HZ;
    let run = strike::run(&seed::piano_c_case(7, 7, seed::PIANO_MEZZO_SPEED_M_S, true, fs, 0.05));
    let until = (contact_end_s(&run) * 2.5).max(3e-3);
    let fig = timed(
        "Fig. 26: C7, its own hammer at 1 m/s: bridge and contact force",
        "force (N)",
        until,
        vec![
            series("bridge force", Colour::BLUE, against_time_ms(&run.trace.bridge_force_n, fs, until, 1.0)),
            series("contact force", Colour::RED, against_time_ms(&run.trace.contact_force_n, fs, until, 1.0)),
        ],
    );
    Ok(vec![draw_line(&fig, dir, "fig26-c7-bridge-force")?])
}

/// Figs. 29-31: the clavichord's pitch rise, tangent motions and Qs.
pub fn clavichord(dir: &Path) -> anyhow::Result<Vec<Drawn>> {
    let key = seed::CLAVICHORD_KEY;
    let mut drawn = Vec::new();
    let rise = (0..=60).map(|i| {
        let d = i as f64 * 0.05e-3;
        (d * 1e3, clavichord_pitch_rise_cents(key, d))
    });
    let fig29 = plot(
        "Fig. 29: clavichord D2, pitch rise against tangent displacement",
        "tangent displacement (mm)",
        "pitch rise (cents)",
        vec![series("", Colour::BLUE, rise.collect())],
    );
    drawn.push(draw_line(&fig29, dir, "fig29-clavichord-pitch-rise")?);

    let colours = [Colour::BLACK, Colour::BLUE, Colour::RED];
    let trajectories = seed::CLAVICHORD_SPEEDS_M_S
        .iter()
        .zip(colours)
        .map(|(&v, colour)| {
            let t = TangentSpec { speed_m_s: v, displacement_m: seed::CLAVICHORD_DISPLACEMENT_M };
            series(
                format!("{v} m/s"),
                colour,
                (0..=600).map(|i| (i as f64 * 0.1, t.position_m(i as f64 * 1e-4) * 1e3)).collect(),
            )
        })
        .collect();
    let fig30 = plot(
        "Fig. 30: tangent motion for three striking speeds, each to 2 mm",
        "time (ms)",
        "tangent position (mm)",
        trajectories,
    );
    drawn.push(draw_line(&fig30, dir, "fig30-tangent-motion")?);

    let clav = seed::clavichord_string().build()?;
    let harp = seed::harpsichord_damped(&seed::clavichord_string()).build()?;
    let q = |s: &struck_engine::string::StringModes| -> Vec<(f64, f64)> {
        s.modes.iter().filter(|m| m.frequency_hz() <= 5_000.0).map(|m| (m.frequency_hz(), m.q)).collect()
    };
    let mut fig31 = plot(
        "Fig. 31: Q of D2's partials, with and without tangent leakage",
        "frequency (Hz)",
        "Q",
        vec![
            series("clavichord, with tangent leakage", Colour::RED, q(&clav)),
            series("harpsichord damping, without", Colour::BLUE, q(&harp)),
        ],
    );
    fig31.x_scale = Scale::Log;
    fig31.y_scale = Scale::Log;
    drawn.push(draw_line(&fig31, dir, "fig31-clavichord-q")?);
    Ok(drawn)
}

/// Figs. 33-35: the clavichord's bridge force at three speeds, the harpsichord's
/// pluck beside two of them, and their spectra.
pub fn clavichord_strikes(dir: &Path) -> anyhow::Result<Vec<Drawn>> {
    let fs = FIGURE_RATE_HZ;
    let second = 1.0;
    let runs: Vec<LabRun> =
        seed::CLAVICHORD_SPEEDS_M_S.iter().map(|&v| strike::run(&seed::clavichord_case(v, fs, second))).collect();
    let harp = strike::run(&seed::harpsichord_case(fs, second));
    let until = 0.06;
    let colours = [Colour::BLACK, Colour::BLUE, Colour::RED];
    let label = |v: f64| format!("tangent {v} m/s");
    let mut drawn = Vec::new();
    let fig33 = plot(
        "Fig. 33: clavichord D2, bridge force for three tangent speeds",
        "time (ms)",
        "bridge force (N)",
        runs.iter()
            .zip(seed::CLAVICHORD_SPEEDS_M_S)
            .zip(colours)
            .map(|((r, v), c)| series(label(v), c, against_time_ms(&r.trace.bridge_force_n, fs, until, 1.0)))
            .collect(),
    );
    drawn.push(draw_line(&fig33, dir, "fig33-clavichord-bridge-force")?);
    let [quiet, typical, _] = seed::CLAVICHORD_SPEEDS_M_S;
    let fig34 = plot(
        "Fig. 34: clavichord and harpsichord pluck, same string",
        "time (ms)",
        "bridge force (N)",
        vec![
            series(label(quiet), Colour::BLACK, against_time_ms(&runs[0].trace.bridge_force_n, fs, until, 1.0)),
            series(label(typical), Colour::BLUE, against_time_ms(&runs[1].trace.bridge_force_n, fs, until, 1.0)),
            series("harpsichord pluck", Colour::GREEN, against_time_ms(&harp.trace.bridge_force_n, fs, until, 1.0)),
        ],
    );
    drawn.push(draw_line(&fig34, dir, "fig34-clavichord-and-harpsichord")?);
    // dB re 1 N as a sinusoid's amplitude: 2 |X| / sum(w) = 4 |X| / N for a Hann window.
    let n = runs[0].trace.len() as f64;
    let reference = n / 4.0;
    let spectra = vec![
        series(
            label(quiet),
            Colour::BLACK,
            spectrum_db(&runs[0].trace.bridge_force_n, fs, true, 2_000.0, Some(reference)),
        ),
        series(
            label(typical),
            Colour::BLUE,
            spectrum_db(&runs[1].trace.bridge_force_n, fs, true, 2_000.0, Some(reference)),
        ),
        series(
            "harpsichord pluck",
            Colour::GREEN,
            spectrum_db(&harp.trace.bridge_force_n, fs, true, 2_000.0, Some(reference)),
        ),
    ];
    let fig35 = LinePlot {
        y_range: Some((-120.0, 0.0)),
        ..plot("Fig. 35: spectra of Fig. 34's bridge forces over 1 s", "frequency (Hz)", "level (dB re 1 N)", spectra)
    };
    drawn.push(draw_line(&fig35, dir, "fig35-clavichord-spectra")?);
    Ok(drawn)
}

/// A strike chart of any cases: contact and bridge force against time and their
/// spectra, every case on one plot (`struck chart strike`).
pub fn strikes(cases: &[StrikeCase], dir: &Path, normalise_by_speed: bool) -> anyhow::Result<Vec<Drawn>> {
    let never = std::sync::atomic::AtomicBool::new(false);
    let runs: Vec<(String, LabRun, f64)> = cases
        .iter()
        .enumerate()
        .map(|(i, c)| {
            let speed = match c.exciter {
                strike::ExciterSpec::Hammer(h) => h.speed_m_s,
                strike::ExciterSpec::Tangent(t) => t.speed_m_s,
                strike::ExciterSpec::Pluck(_) => 1.0,
            };
            let name = c.name.clone().unwrap_or_else(|| format!("case {}", i + 1));
            // (Memory that cannot be had is said, not aborted on.)
            match strike::run::run_stoppable(c, &never) {
                Ok(run) => Ok((name, run, speed)),
                Err(strike::run::Stopped::OutOfMemory { bytes }) => Err(anyhow::anyhow!(
                    "{}: cannot get {} of memory for its trace",
                    crate::cli::printable(&name),
                    crate::cli::room::size_text_rounded(bytes)
                )),
                Err(strike::run::Stopped::Interrupted) => Err(anyhow::anyhow!("interrupted")),
            }
        })
        .collect::<anyhow::Result<_>>()?;
    let until = runs.iter().map(|(_, r, _)| contact_end_s(r)).fold(0.0, f64::max).max(2e-3) * 1.2;
    let line = |pick: fn(&LabRun) -> &Vec<f64>, per_speed: bool| -> Vec<Series> {
        runs.iter()
            .enumerate()
            .map(|(i, (name, r, v))| {
                let scale = if per_speed { 1.0 / v } else { 1.0 };
                series(name.clone(), Colour::palette(i), against_time_ms(pick(r), r.trace.sample_rate_hz, until, scale))
            })
            .collect()
    };
    let mut drawn = Vec::new();
    let contact = if normalise_by_speed {
        plot(
            "Contact force divided by speed",
            "time (ms)",
            "force / speed (N s/m)",
            line(|r| &r.trace.contact_force_n, true),
        )
    } else {
        plot("Contact force", "time (ms)", "contact force (N)", line(|r| &r.trace.contact_force_n, false))
    };
    drawn.push(draw_line(&contact, dir, "contact-force")?);
    drawn.push(draw_line(
        &plot("Bridge force", "time (ms)", "bridge force (N)", line(|r| &r.trace.bridge_force_n, false)),
        dir,
        "bridge-force",
    )?);
    let spectra = |pick: fn(&LabRun) -> &Vec<f64>, windowed: bool| -> Vec<Series> {
        runs.iter()
            .enumerate()
            .map(|(i, (name, r, _))| {
                let fs = r.trace.sample_rate_hz;
                let signal = pick(r);
                let signal = if windowed { &signal[..] } else { &signal[..((until * fs) as usize).min(signal.len())] };
                let reference = if windowed { signal.len() as f64 / 4.0 } else { fs };
                let db = spectrum_db(signal, fs, windowed, 10_000.0, Some(reference));
                series(name.clone(), Colour::palette(i), db.into_iter().filter(|p| p.0 >= 10.0).collect())
            })
            .collect()
    };
    let mut cs = plot(
        "Spectrum of the contact force",
        "frequency (Hz)",
        "level (dB re 1 N s)",
        spectra(|r| &r.trace.contact_force_n, false),
    );
    cs.x_scale = Scale::Log;
    drawn.push(draw_line(&cs, dir, "contact-force-spectrum")?);
    let mut bs = plot(
        "Spectrum of the bridge force (Hann window, whole case)",
        "frequency (Hz)",
        "level (dB re 1 N)",
        spectra(|r| &r.trace.bridge_force_n, true),
    );
    bs.x_scale = Scale::Log;
    drawn.push(draw_line(&bs, dir, "bridge-force-spectrum")?);
    Ok(drawn)
}
