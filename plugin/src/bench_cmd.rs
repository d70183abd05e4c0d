//! `struck bench`: how fast the modal bank and the instruments run here.

use std::time::Duration;

use struck_engine::instrument::InstrumentKind;
use struck_engine::perf;

use crate::{BenchArgs, Failure};

const SAMPLE_RATE_HZ: f64 = 48_000.0;
const BLOCK: usize = 64;

pub fn run(args: &BenchArgs) -> Result<(), Failure> {
    if !(args.seconds.is_finite() && args.seconds > 0.0 && args.seconds <= 600.0) {
        return Err(Failure::bad_input(format!("--seconds: must lie between 0 and 600 (got {})", args.seconds)));
    }
    let time = Duration::from_secs_f64(args.seconds);
    println!("struck bench: {}", perf::cpu_model());
    println!("kernel: {}; one thread; f64 modes; blocks of {BLOCK} samples at 48 kHz", perf::kernel_variant());
    if cfg!(debug_assertions) {
        println!("note: this is a debug build; build with --release for meaningful figures");
    }
    for count in [1024, 16 * 1024, 64 * 1024] {
        let rate = perf::free_throughput(count, BLOCK, time);
        println!(
            "free modes {count:>6}: {:>8.3e} mode-samples/s  ({:>6.1} % of a core per 1000 modes at 48 kHz)",
            rate,
            100.0 * 1000.0 * SAMPLE_RATE_HZ / rate
        );
    }
    let (rate, modes) = perf::contact_throughput(time);
    println!(
        "in contact ({modes} modes, C2 string, 8 sub-steps, implicit felt): {rate:>8.3e} mode-steps/s  ({:.2} us per sample)",
        1e6 * modes as f64 * 8.0 / rate
    );
    let audio_s = (10.0 * args.seconds).clamp(1.0, 60.0);
    for kind in InstrumentKind::ALL {
        let run = perf::synth_throughput(kind, audio_s);
        println!(
            "{:<11} chords every 0.2 s, pedal down: {:>6.1} x real time with up to {:>3} keys sounding (tables built in {:.1} ms)",
            kind.name(),
            run.real_time_factor,
            run.max_keys,
            1e3 * run.build_s
        );
    }
    Ok(())
}
