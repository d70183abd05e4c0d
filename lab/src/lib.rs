//! # Struck's lab: everything that studies the instrument rather than plays it
//!
//! The engine (`struck_engine`) is the instrument and nothing else; the lab runs
//! it offline and measures it, and is the `struck` program's subcommands:
//!
//! - [`strike`]: one string excited once, as a strike case (`struck strike`):
//!   the case format and its checks, the run and its metrics, hammer design
//!   sweeps, the seed's own experiments, strikes filmed for animations.
//! - [`analysis`]: spectra, partial tracking, filters and levels.
//! - [`perf`]: the speed workloads behind `struck bench` and the criterion benches.
//! - [`plot`]: line charts, heatmaps and GIF animations (plotters, no system fonts).
//! - [`figures`], [`seed_sounds`], [`demo_page`]: Euphonics 12.2's figures,
//!   sounds and the demo's index page (`struck demo`, `struck chart`).
//! - [`compare`]: the piano measured against recordings of a real grand
//!   (`struck compare`).
//! - [`midi_file`]: standard MIDI files read into engine events (`struck render`).
//! - [`output`]: files written all together or not at all.
//! - [`cli`]: the subcommands themselves.
//!
//! Nothing here runs on an audio thread; it may allocate, spawn threads (rayon)
//! and take its time.

// Printing goes through `console`: println! panics when stdout is a closed
// pipe or a full disk.
#![warn(clippy::print_stdout, clippy::print_stderr)]

pub mod analysis;
pub mod cleanup;
pub mod cli;
pub mod compare;
pub mod console;
pub mod demo_page;
pub mod figures;
pub mod midi_file;
pub mod perf;
pub mod plot;
pub mod seed_sounds;
pub mod strike;
