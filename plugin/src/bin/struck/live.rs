//! `struck` with no subcommand: Struck played live, through nice-plug's
//! standalone host (JACK or ALSA audio and MIDI, the editor in a window).
//!
//! nice-plug parses the standalone's own options (`-b jack`, `--sample-rate`,
//! ...) from the command line. Two things are added here. First, the audio
//! backend the options ask for is probed before the standalone starts, because
//! the standalone falls back to a silent dummy backend (or exits 0) when none
//! works: Struck says so in one line and exits with status 1 instead. Second,
//! a signal stops the program cleanly with or without a window: nice-plug's
//! handler (extended to SIGTERM and SIGHUP through `ctrlc`'s `termination`
//! feature) ends a headless run, and the editor closes its window when
//! `struck::standalone::stop_requested` turns true.

use std::io::IsTerminal;
use std::process::ExitCode;

use struck_lab::console;

use struck::StruckPlugin;
use struck::standalone::{
    CALLBACK_STATS_VAR, mark_standalone, report_callbacks_to, smoothing_from_env, stop_requested, watch_stop_signals,
    write_callback_report,
};

/// The line printed when no audio device can be used.
pub fn no_device_message(reasons: &str) -> String {
    format!(
        "struck: no audio device found ({reasons}); use -b jack with a running JACK server, \
         or render offline with `struck render`"
    )
}

/// Run the standalone unless the command line names one of `cli`'s subcommands
/// (or asks for its version); `struck --help` shows both helps. Returns the exit
/// status when the standalone ran (or refused to), None to let `cli` parse.
pub fn run_unless_subcommand(cli: &::clap::Command) -> Option<ExitCode> {
    let raw: Vec<std::ffi::OsString> = std::env::args_os().collect();
    let first = raw.get(1).and_then(|a| a.to_str());
    // (The program's own path, which the standalone is handed too, may be any bytes.)
    let args = || raw.iter().map(|a| a.to_string_lossy().into_owned()).collect::<Vec<String>>();
    let ours = |word: &str| {
        word == "help"
            || word == "-V"
            || word == "--version"
            || cli.get_subcommands().any(|s| s.get_name() == word || s.get_all_aliases().any(|a| a == word))
    };
    match first {
        Some(word) if ours(word) => None,
        // The subcommands take paths that need not be UTF-8 (their parser
        // reads them as the system gives them); the standalone's options are
        // all text.
        _ if let Some(bad) = raw.iter().skip(1).find(|a| a.to_str().is_none()) => {
            console::err(format!("struck: the argument {:?} is not valid UTF-8", bad.to_string_lossy()));
            Some(ExitCode::from(2))
        }
        Some("-h" | "--help") if raw.len() == 2 => {
            let mut cli = cli.clone();
            let help = cli.render_long_help();
            // (Styled on a terminal, plain text elsewhere, as clap prints it.)
            console::out_text(&if std::io::stdout().is_terminal() {
                help.ansi().to_string()
            } else {
                help.to_string()
            });
            console::out("\nWith no command, struck plays live (JACK or ALSA, MIDI in, the panel in a window):\n");
            // The standalone's own options follow (nice-plug prints them and exits),
            // unless stdout already failed: then that is said, with status 1.
            if let Some(e) = console::stdout_failure() {
                console::err(format!("struck: cannot print the help: {e}"));
                return Some(ExitCode::FAILURE);
            }
            if console::stdout_gone() {
                return Some(ExitCode::SUCCESS);
            }
            Some(run(args()))
        }
        Some(word) if !word.starts_with('-') => {
            let names: Vec<&str> = cli.get_subcommands().map(|s| s.get_name()).collect();
            console::err(format!("struck: no command {word:?} (the commands: {}; none plays live)", names.join(", ")));
            Some(ExitCode::from(2))
        }
        _ => Some(run(args())),
    }
}

/// Probe the audio backend the options ask for, then hand over to nice-plug's standalone.
pub fn run(args: Vec<String>) -> ExitCode {
    let wanted = Wanted::scan(&args[1.min(args.len())..]);
    if let Some(Err(reason)) = wanted.as_ref().map(Wanted::check) {
        console::err(format!("struck: {reason}"));
        return ExitCode::from(2);
    }
    if let Some(wanted) = wanted
        && let Err(reasons) = probe(&wanted)
    {
        console::err(no_device_message(&reasons));
        return ExitCode::FAILURE;
    }
    if let Err(reason) = smoothing_from_env() {
        console::err(format!("struck: {reason}"));
        return ExitCode::from(2);
    }
    let stats = std::env::var_os(CALLBACK_STATS_VAR).filter(|p| !p.is_empty()).map(std::path::PathBuf::from);
    if let Some(path) = &stats
        && let Err(reason) = report_callbacks_to(path.clone())
    {
        console::err(format!("struck: {reason}"));
        return ExitCode::from(2);
    }
    mark_standalone();
    start_stop_watchdog();
    let played = nice_plug::prelude::nice_export_standalone_with_args::<StruckPlugin, _>(args);
    if let Some(path) = &stats
        && let Err(e) = write_callback_report(path)
    {
        console::err(format!("struck: cannot write the callback report {}: {e}", path.display()));
    }
    if played {
        ExitCode::SUCCESS
    } else {
        console::err("struck: the standalone stopped with an error (see the messages above)");
        ExitCode::FAILURE
    }
}

#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Backend {
    Auto,
    Jack,
    Alsa,
    Dummy,
}

/// The few standalone options the probe needs.
#[derive(Debug, PartialEq)]
struct Wanted {
    backend: Backend,
    output_device: Option<String>,
    sample_rate_hz: u32,
    period: u32,
}

impl Wanted {
    /// Read the options after the program name; None when there is nothing to
    /// probe (help, or options nice-plug will refuse with its own message).
    fn scan(args: &[String]) -> Option<Self> {
        let mut wanted = Wanted { backend: Backend::Auto, output_device: None, sample_rate_hz: 48_000, period: 512 };
        let mut i = 0;
        while i < args.len() {
            let arg = args[i].as_str();
            let (name, inline) = match arg.split_once('=') {
                Some((name, value)) if arg.starts_with("--") => (name, Some(value.to_string())),
                _ if arg.len() > 2 && arg.starts_with('-') && !arg.starts_with("--") => {
                    (&arg[..2], Some(arg[2..].to_string()))
                }
                _ => (arg, None),
            };
            let takes_value = !matches!(name, "-h" | "--help" | "-V" | "--version");
            if !takes_value {
                return None;
            }
            let value = match inline {
                Some(v) => v,
                None => {
                    i += 1;
                    args.get(i)?.clone()
                }
            };
            match name {
                "-b" | "--backend" => {
                    wanted.backend = match value.as_str() {
                        "auto" => Backend::Auto,
                        "jack" => Backend::Jack,
                        "alsa" => Backend::Alsa,
                        "dummy" => Backend::Dummy,
                        _ => return None,
                    }
                }
                "--output-device" => wanted.output_device = Some(value),
                "-r" | "--sample-rate" => wanted.sample_rate_hz = value.parse::<f32>().ok()? as u32,
                "-p" | "--period-size" => wanted.period = value.parse().ok()?,
                _ => {}
            }
            i += 1;
        }
        Some(wanted)
    }
}

/// Periods the standalone may run in, samples: a period of 0 would spin a core
/// and a huge one take gigabytes before the first sound.
const PERIODS: std::ops::RangeInclusive<u32> = 16..=8192;
/// Sample rates it may run at, Hz (those the instrument is built for).
const SAMPLE_RATES_HZ: std::ops::RangeInclusive<u32> = 22_050..=192_000;

impl Wanted {
    /// Refuse a period or sample rate out of range, naming it.
    fn check(&self) -> Result<(), String> {
        let within = |option: &str, value: u32, range: &std::ops::RangeInclusive<u32>, unit: &str| {
            if range.contains(&value) {
                Ok(())
            } else {
                Err(format!("{option} {value}: must lie between {} and {} {unit}", range.start(), range.end()))
            }
        };
        within("--period-size", self.period, &PERIODS, "samples")?;
        within("--sample-rate", self.sample_rate_hz, &SAMPLE_RATES_HZ, "Hz")
    }
}

/// Whether the backend the standalone will try can play; the reasons when not.
fn probe(wanted: &Wanted) -> Result<(), String> {
    match wanted.backend {
        Backend::Dummy => Ok(()),
        Backend::Jack => probe_jack(),
        Backend::Alsa => probe_alsa(wanted),
        Backend::Auto => probe_jack().or_else(|jack| probe_alsa(wanted).map_err(|alsa| format!("{jack}; {alsa}"))),
    }
}

fn probe_jack() -> Result<(), String> {
    match jack::Client::new("struck", jack::ClientOptions::NO_START_SERVER) {
        Ok(_client) => Ok(()),
        Err(jack::Error::LibraryError(_)) => Err("JACK: the JACK library is not installed".into()),
        Err(_) => Err("JACK: no server running".into()),
    }
}

fn probe_alsa(wanted: &Wanted) -> Result<(), String> {
    use cpal::traits::{DeviceTrait, HostTrait};
    let _quiet = QuietAlsa::new();
    let host = cpal::host_from_id(cpal::HostId::Alsa).map_err(|e| format!("ALSA: {e}"))?;
    let device = match &wanted.output_device {
        // A named device nice-plug does not find makes it list the ones there are: let it.
        Some(_) => return Ok(()),
        None => host.default_output_device().ok_or("ALSA: no default output device")?,
    };
    let configs = device
        .supported_output_configs()
        .map_err(|e| format!("ALSA: cannot open the default output device: {}", first_sentence(&e.to_string())))?;
    let fits = configs.into_iter().any(|c| {
        (c.min_sample_rate()..=c.max_sample_rate()).contains(&wanted.sample_rate_hz)
            && match c.buffer_size() {
                cpal::SupportedBufferSize::Range { min, max } => (*min..=*max).contains(&wanted.period),
                cpal::SupportedBufferSize::Unknown => false,
            }
    });
    if fits {
        Ok(())
    } else {
        Err(format!(
            "ALSA: the default output device cannot play {} Hz in periods of {} samples",
            wanted.sample_rate_hz, wanted.period
        ))
    }
}

/// An error message up to its first full stop.
fn first_sentence(message: &str) -> &str {
    message.split_once(". ").map_or(message, |(first, _)| first).trim_end_matches('.')
}

/// alsa-lib prints its own errors to stderr; while the probe runs they are dropped
/// (the probe reports in one line), and alsa-lib's own printing is back afterwards.
struct QuietAlsa;

type AlsaErrorHandler = unsafe extern "C" fn(
    file: *const libc::c_char,
    line: libc::c_int,
    function: *const libc::c_char,
    err: libc::c_int,
    fmt: *const libc::c_char,
);

unsafe extern "C" {
    fn snd_lib_error_set_handler(handler: Option<AlsaErrorHandler>) -> libc::c_int;
}

unsafe extern "C" fn drop_alsa_error(
    _file: *const libc::c_char,
    _line: libc::c_int,
    _function: *const libc::c_char,
    _err: libc::c_int,
    _fmt: *const libc::c_char,
) {
}

impl QuietAlsa {
    fn new() -> Self {
        // SAFETY: alsa-lib is linked through cpal. Its handler type is variadic; a handler
        // that reads only the fixed arguments (here: none) is sound to call through it on
        // the Linux ABIs, where the fixed arguments are passed as for a plain function.
        unsafe {
            snd_lib_error_set_handler(Some(drop_alsa_error));
        }
        Self
    }
}

impl Drop for QuietAlsa {
    fn drop(&mut self) {
        // SAFETY: a null handler restores alsa-lib's default.
        unsafe {
            snd_lib_error_set_handler(None);
        }
    }
}

/// How long the backend may take to stop after a stop signal. A clean stop takes
/// under 0.1 s; a session manager (and the JACK session test) allows 5 s in all.
const STOP_GRACE: std::time::Duration = std::time::Duration::from_secs(2);

/// nice-plug 0.4.2's JACK backend can deadlock while stopping (its process callback
/// returns Quit while the main thread deactivates the client; both then wait on the
/// server's socket). A signal must still stop the program: once one has arrived,
/// this thread ends the process if the backend has not returned within [`STOP_GRACE`].
fn start_stop_watchdog() {
    let spawned = std::thread::Builder::new().name("struck-stop-watchdog".into()).spawn(|| {
        // nice-plug installs its handler as the standalone starts: chain onto it once it is there.
        for _ in 0..500 {
            if handler_installed(libc::SIGTERM) {
                break;
            }
            std::thread::sleep(std::time::Duration::from_millis(10));
        }
        watch_stop_signals();
        while !stop_requested() {
            std::thread::sleep(std::time::Duration::from_millis(50));
        }
        std::thread::sleep(STOP_GRACE);
        console::err(format!(
            "struck: the audio backend did not stop within {} s of the signal; exiting",
            STOP_GRACE.as_secs()
        ));
        // SAFETY: ends the process at once; nothing is left half-written (the standalone writes no files).
        unsafe { libc::_exit(0) }
    });
    if let Err(e) = spawned {
        console::err(format!("struck: cannot start the stop watchdog: {e}"));
    }
}

fn handler_installed(signal: libc::c_int) -> bool {
    // SAFETY: reading the current disposition with valid pointers.
    unsafe {
        let mut current: libc::sigaction = std::mem::zeroed();
        libc::sigaction(signal, std::ptr::null(), &mut current) == 0
            && current.sa_sigaction != libc::SIG_DFL
            && current.sa_sigaction != libc::SIG_IGN
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn scan(args: &[&str]) -> Option<Wanted> {
        Wanted::scan(&args.iter().map(|s| s.to_string()).collect::<Vec<_>>())
    }

    #[test]
    fn reads_the_options_the_probe_needs() {
        let w = scan(&["-b", "alsa", "--sample-rate", "44100", "-p256"]).unwrap();
        assert_eq!(w.backend, Backend::Alsa);
        assert_eq!((w.sample_rate_hz, w.period), (44_100, 256));
        let w = scan(&["--backend=jack", "--output-device", "null"]).unwrap();
        assert_eq!(w.backend, Backend::Jack);
        assert_eq!(w.output_device.as_deref(), Some("null"));
        assert_eq!(scan(&[]).unwrap().backend, Backend::Auto);
        assert_eq!(scan(&["-bdummy"]).unwrap().backend, Backend::Dummy);
    }

    #[test]
    fn a_period_or_rate_the_machine_cannot_run_is_refused() {
        assert!(scan(&["-b", "dummy", "--period-size", "512"]).unwrap().check().is_ok());
        for args in [["--period-size", "0"], ["--period-size", "4294967295"], ["--sample-rate", "8000"]] {
            let e = scan(&args).unwrap().check().unwrap_err();
            assert!(e.starts_with(args[0]) && !e.contains('\n'), "{e}");
        }
    }

    #[test]
    fn leaves_help_and_bad_options_to_the_standalone() {
        assert_eq!(scan(&["--help"]), None);
        assert_eq!(scan(&["-b"]), None);
        assert_eq!(scan(&["-b", "coreaudio"]), None);
        assert_eq!(scan(&["--sample-rate", "fast"]), None);
    }

    #[test]
    fn the_dummy_backend_needs_no_device() {
        assert_eq!(probe(&scan(&["-b", "dummy"]).unwrap()), Ok(()));
    }

    #[test]
    fn the_message_is_one_line_naming_the_way_out() {
        let m = no_device_message("JACK: no server running");
        assert!(!m.contains('\n'));
        assert!(m.starts_with("struck: no audio device found (JACK: no server running)"));
        assert!(m.contains("-b jack") && m.contains("struck render"));
    }
}
