//! `struck demo --out DIR`: the seed's whole lab in one command. Sounds 1-12 as
//! WAVs, every figure as a PNG with its CSV, the animations as GIFs, and an
//! `index.html` that shows them in the seed's order.

use std::path::{Path, PathBuf};
use std::time::Instant;

use crate::strike::seed;
use indicatif::{ProgressBar, ProgressStyle};
use rayon::prelude::*;

use super::output::Staged;
use crate::cli::Failure;
use crate::cli::animate::{self, FilmOptions};
use crate::console;
use crate::demo_page::{self, Entry};
use crate::figures::hammer::{self, GridOptions};
use crate::figures::{self, Drawn};
use crate::seed_sounds::{self, SOUND_RATE_HZ};

/// Grid side of the hammer charts in a full demo and in a quick one.
pub const FULL_GRID: usize = 64;
pub const QUICK_GRID: usize = 16;

#[derive(clap::Args)]
pub struct DemoArgs {
    /// Directory to write into (created if missing; files of the same names are replaced).
    #[arg(long, value_name = "DIR", default_value = "demo")]
    pub out: PathBuf,
    /// Coarser hammer charts (16 x 16) and shorter animations, for a fast check.
    #[arg(long)]
    pub quick: bool,
}

fn bar(len: u64, what: &str) -> ProgressBar {
    let bar = ProgressBar::new(len).with_message(what.to_string());
    bar.set_style(
        ProgressStyle::with_template("{msg:>28} [{bar:40}] {pos}/{len} {elapsed}")
            .expect("a valid template")
            .progress_chars("=> "),
    );
    bar
}

fn file_name(path: &Path) -> String {
    path.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_default()
}

fn figure(label: &str, caption: &str, drawn: &Drawn) -> Entry {
    Entry::Figure {
        label: label.to_string(),
        caption: caption.to_string(),
        image: file_name(&drawn.png),
        data: vec![file_name(&drawn.csv)],
    }
}

/// The animations: Fig. 2 (santoor), 23-25 (C2, C4, C7 with their own hammers),
/// 32 (clavichord at 0.5 m/s).
fn films() -> Vec<(&'static str, &'static str, String, crate::strike::StrikeCase, f64)> {
    let fs = figures::FIGURE_RATE_HZ;
    let v = seed::CHART_SPEED_M_S;
    vec![
        (
            "Fig. 2",
            "fig02-santoor-animation.gif",
            "The santoor string struck at 2/5 by the 1 g mallet: the mallet (red star) meets the string at the green \
             star, rides it while reflections come back from both ends, and is thrown off."
                .to_string(),
            seed::santoor_mallet(1e-3, 0.4, fs, 0.5),
            0.0,
        ),
        (
            "Fig. 23",
            "fig23-c2-animation.gif",
            format!(
                "C2 and its own hammer at {v} m/s: the hammer leaves soon after the reflection from the near end returns, long before the one from the far end."
            ),
            seed::piano_c_case(2, 2, v, true, fs, 0.5),
            0.0,
        ),
        (
            "Fig. 24",
            "fig24-c4-animation.gif",
            format!(
                "C4 and its own hammer at {v} m/s: contact for about one period of the string; the felt's compression is comparable to the string's motion."
            ),
            seed::piano_c_case(4, 4, v, true, fs, 0.5),
            0.0,
        ),
        (
            "Fig. 25",
            "fig25-c7-animation.gif",
            format!(
                "C7 and its own hammer at {v} m/s: the hammer, heavier than the string, stays on for several periods and compresses its felt far more than the string moves."
            ),
            seed::piano_c_case(7, 7, v, true, fs, 0.5),
            0.0,
        ),
        (
            "Fig. 32",
            "fig32-clavichord-animation.gif",
            "The clavichord's D2 as its tangent arrives at 0.5 m/s and lifts the far end 2 mm (first two periods)."
                .to_string(),
            seed::clavichord_case(0.5, fs, 1.0),
            2.0,
        ),
    ]
}

pub fn run(args: &DemoArgs) -> Result<(), Failure> {
    let started = Instant::now();
    // Drawn into a folder inside --out, then moved out of it together.
    let final_out = &args.out;
    let staging = super::output::StagedFolder::within(final_out)?;
    let out = staging.path();
    let failed = |e: anyhow::Error| staging.failure(final_out, &e);
    let grid = if args.quick { QUICK_GRID } else { FULL_GRID };
    console::out(format!("struck demo: the seed's sounds, figures and animations into {}", final_out.display()));

    // Sounds, in parallel.
    let sounds = seed_sounds::sounds();
    let progress = bar(sounds.len() as u64, "Sounds 1-12");
    let rendered: Vec<Vec<f32>> = sounds
        .par_iter()
        .map(|s| {
            let samples = seed_sounds::render(s);
            progress.inc(1);
            samples
        })
        .collect();
    progress.finish();
    let mut staged = Staged::default();
    for (s, samples) in sounds.iter().zip(&rendered) {
        staged.write_wav16(&out.join(&s.file), SOUND_RATE_HZ, samples).map_err(|e| staging.as_out(final_out, e))?;
    }
    staged.commit()?;
    let sound = |n: u8| -> Entry {
        let s = &sounds[n as usize - 1];
        Entry::Sound { number: s.number, caption: s.caption.clone(), file: s.file.clone() }
    };

    // Line figures.
    let progress = bar(6, "Figures");
    let santoor = figures::santoor(out).map_err(failed)?;
    progress.inc(1);
    let stringing = figures::broadwood_stringing(out, "fig").map_err(failed)?;
    progress.inc(1);
    let speeds = figures::piano_speeds(out).map_err(failed)?;
    progress.inc(1);
    let c7 = figures::piano_c7(out).map_err(failed)?;
    progress.inc(1);
    let clavichord = figures::clavichord(out).map_err(failed)?;
    progress.inc(1);
    let clavichord_strikes = figures::clavichord_strikes(out).map_err(failed)?;
    progress.inc(1);
    progress.finish();

    // Hammer charts.
    let options = GridOptions { size: grid, log_mass: false, progress: true };
    let c4 = seed::piano_c_case(4, 4, seed::CHART_SPEED_M_S, true, figures::FIGURE_RATE_HZ, 0.2);
    let hammer = hammer::hammer_charts(&c4, &options, out, "fig").map_err(failed)?;
    let universal = hammer::universal_charts(&GridOptions { log_mass: true, ..options }, out).map_err(failed)?;

    // Animations.
    let films = films();
    let progress = bar(films.len() as u64, "Animations");
    let film_options = FilmOptions { frames: if args.quick { 40 } else { 120 } };
    let mut animations = Vec::new();
    for (label, file, caption, case, periods) in &films {
        let title = format!("{label}: {}", case.name.as_deref().unwrap_or(""));
        animate::draw_film(case, *periods, &title, &film_options, &out.join(file)).map_err(failed)?;
        animations.push(Entry::Figure {
            label: label.to_string(),
            caption: caption.clone(),
            image: file.to_string(),
            data: vec![],
        });
        progress.inc(1);
    }
    progress.finish();

    let captions = hammer::captions();
    let mut entries = vec![Entry::Heading("The santoor: a light mallet that bounces".into())];
    entries.push(animations[0].clone());
    entries.push(figure("Fig. 3", "Contact force of the 1 g mallet striking the santoor string at 2/5, 1 m/s: a jump at first touch, a ramp down, a second jump when the reflection from the nearer end returns (with a dispersive precursor ahead of it), until the mallet is thrown clear.", &santoor[0]));
    entries.push(figure("Fig. 4", "Spectrum of that contact force (red) and of the bridge force over half a second (blue); the partials are slightly stretched by the string's stiffness, and every fifth one is missing because the string was struck at 2/5.", &santoor[1]));
    entries.extend([sound(1), sound(2), sound(3)]);
    entries.push(figure("Fig. 5", "The 1 g mallet striking at 1/10 (blue) beside 2/5 (red): the same start, then the nearer bridge sends its reflection back much sooner.", &santoor[2]));
    entries.extend([sound(4), sound(5)]);
    entries.push(Entry::Heading("The piano's strings".into()));
    entries.push(figure("Fig. 8", "Mass per unit length of one string for every key of the seed's piano (the Broadwood baby grand's scale), with the changes from one to two to three strings per note marked.", &stringing[0]));
    entries.push(figure(
        "Fig. 9",
        "Tension of one string: about 650 N for the plain steel strings, a sawtooth for the wound ones.",
        &stringing[1],
    ));
    entries.push(figure("Fig. 10", "Wave impedance of all the strings of a note together: the sawtooth of Fig. 9 makes it run smoothly across the breaks.", &stringing[2]));
    entries.push(Entry::Heading("Piano notes: hammers, speeds and inharmonicity".into()));
    entries.extend([sound(6), sound(7), sound(8), sound(9)]);
    entries.push(figure("Fig. 12", "Contact force of C2's own hammer at the five speeds of Sound 8.", &speeds[0]));
    entries.push(figure("Fig. 13", "The same forces divided by the speed: with a linear felt they would coincide; the hardening felt sharpens the pulse as the speed rises.", &speeds[1]));
    entries.push(figure(
        "Fig. 14",
        "Spectra of the five pulses: flat at low frequency, falling above a turnover that rises with the speed.",
        &speeds[2],
    ));
    entries.push(sound(10));
    entries.push(Entry::Heading("Designing the hammer set".into()));
    for (drawn, (label, caption)) in hammer.iter().chain(&universal).zip(&captions) {
        entries.push(figure(label, caption, drawn));
    }
    entries.extend(animations[1..4].iter().cloned());
    entries.push(sound(11));
    entries.push(figure("Fig. 26", "The start of C7's bridge force (blue) with the contact force (red): a spike while the heavy hammer carries the string further than it ever goes again.", &c7[0]));
    entries.push(Entry::Heading("The clavichord".into()));
    entries.push(figure("Fig. 29", "How far the clavichord's D2 goes sharp as the tangent presses the string in: quadratic in the depth, about 5 cents at 2 mm.", &clavichord[0]));
    entries.push(figure(
        "Fig. 30",
        "The tangent's motion for three striking speeds, each slowing exponentially to rest 2 mm in.",
        &clavichord[1],
    ));
    entries.push(figure("Fig. 31", "Q of D2's partials: with the leak past the tangent (red) the lowest partials are damped far more than on a harpsichord-damped string (blue); above about 1 kHz the two agree.", &clavichord[2]));
    entries.push(animations[4].clone());
    entries.push(figure("Fig. 33", "Bridge force of D2 for the three tangent speeds: a dispersive wiggle, then the big jump when the pulse reaches the bridge; the faster the tangent, the louder.", &clavichord_strikes[0]));
    entries.push(figure("Fig. 34", "The quiet (black) and typical (blue) clavichord notes beside a harpsichord pluck of the same 2 mm on the same string (green).", &clavichord_strikes[1]));
    entries.push(figure("Fig. 35", "Their spectra over one second: the pluck stands well above the typical clavichord note, which stands 10 to 15 dB above the quiet one.", &clavichord_strikes[2]));
    entries.push(sound(12));

    let html = demo_page::page(
        "Struck: Euphonics 12.2, hammered strings, redone",
        "Every simulation, figure and sound of section 12.2 of Jim Woodhouse's Euphonics, computed again by Struck's \
         engine (exact per-mode stepping, implicit contact). Sounds are the force on the bridge, as in the seed. Each \
         chart links the CSV of its numbers.",
        &entries,
    );
    let mut staged = Staged::default();
    staged
        .write(&out.join("index.html"), |w| std::io::Write::write_all(w, html.as_bytes()))
        .map_err(|e| staging.as_out(final_out, e))?;
    staged.commit()?;
    staging.commit_into(final_out, &[])?;
    let files = entries.iter().flat_map(Entry::links).count();
    console::out(format!(
        "wrote {} files and {} in {:.1} s",
        files,
        final_out.join("index.html").display(),
        started.elapsed().as_secs_f64()
    ));
    Ok(())
}
