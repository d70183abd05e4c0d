//! Measuring the modal bank's speed: mode-samples per second for free banks of
//! any size and for a string while a hammer is on it. `struck bench` prints
//! these; the criterion benchmark times the same workloads.

pub mod workload;

use std::f64::consts::PI;
use std::time::{Duration, Instant};

use struck_engine::exciter::hammer::HammerSpec;
use struck_engine::exciter::hammer::contact::ContactLaw;
use struck_engine::modal_bank::{FreeGather, LANES, ModalBank, StepTable};
use struck_engine::string::damping::Damping;
use struck_engine::string::{Mass, Mode, Stiffness, StringModes, StringSpec, Tuning};
use struck_engine::struck_string::{DEFAULT_SUBSTEPS, StruckString};

/// The processor's model name, with its family and model numbers where
/// /proc/cpuinfo gives them (one name covers several generations: "AMD EPYC"
/// has been a Zen 3, a Zen 4 and a Zen 5, whose figures differ by half).
pub fn cpu_model() -> String {
    std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|info| cpu_identity(&info))
        .unwrap_or_else(|| std::env::consts::ARCH.to_string())
}

/// The first processor's "model name" in a /proc/cpuinfo text, followed by
/// "(family F, model M)" when both numbers are there.
fn cpu_identity(info: &str) -> Option<String> {
    let first = info.split("\n\n").next()?;
    let field = |name: &str| {
        first.lines().find_map(|l| {
            let (key, value) = l.split_once(':')?;
            (key.trim() == name).then(|| value.trim().to_string())
        })
    };
    let name = field("model name")?;
    Some(match (field("cpu family"), field("model")) {
        (Some(family), Some(model)) => format!("{name} (family {family}, model {model})"),
        _ => name,
    })
}

/// Which compiled version of the inner loops this processor runs.
pub fn kernel_variant() -> &'static str {
    #[cfg(target_arch = "x86_64")]
    {
        if is_x86_feature_detected!("avx512f")
            && is_x86_feature_detected!("avx512vl")
            && is_x86_feature_detected!("fma")
        {
            return "x86_64 AVX-512 + FMA";
        }
        if is_x86_feature_detected!("avx2") && is_x86_feature_detected!("fma") {
            return "x86_64 AVX2 + FMA";
        }
        "x86_64 baseline (SSE2, software FMA)"
    }
    #[cfg(target_arch = "aarch64")]
    {
        "aarch64 NEON"
    }
    #[cfg(not(any(target_arch = "x86_64", target_arch = "aarch64")))]
    {
        "portable"
    }
}

/// A synthetic bank of `count` modes spread logarithmically from 20 Hz to 20 kHz
/// with Q = 1000, as a whole keyboard's modes would be, each ringing.
pub fn synthetic_bank(count: usize, sample_rate_hz: f64) -> (ModalBank, StepTable) {
    let modes: Vec<Mode> = (0..count)
        .map(|i| {
            let f = 20.0 * 1000f64.powf(i as f64 / count.max(2) as f64);
            Mode { number: i + 1, wavenumber_rad_m: (i + 1) as f64 * PI, omega_rad_s: 2.0 * PI * f, q: 1000.0 }
        })
        .collect();
    let string = StringModes {
        length_m: 1.0,
        tension_n: 700.0,
        mass_per_length_kg_m: 0.005,
        bending_stiffness_n_m2: 0.0,
        inharmonicity: 0.0,
        f0_hz: 20.0,
        modes,
    };
    let mut bank = ModalBank::new(&string);
    for i in 0..count {
        bank.add_velocity(i, 1e-3);
    }
    let step = StepTable::new(&string, 1.0 / sample_rate_hz);
    (bank, step)
}

/// Free-mode throughput, mode-samples per second, over at least `min_time`.
pub fn free_throughput(count: usize, block: usize, min_time: Duration) -> f64 {
    let (mut bank, step) = synthetic_bank(count, 48_000.0);
    let mut out = vec![0.0; block];
    mode_samples_per_s(count, block, min_time, || {
        out.fill(0.0);
        bank.process_free(&step, &mut out);
        std::hint::black_box(&out);
    })
}

/// Free-mode throughput in the gathered real form the synth runs a key's free
/// strings in ([`FreeGather`]), mode-samples per second, over at least
/// `min_time`: the synthetic bank gathered once and run `block` samples at a
/// time, as a key's gathering runs over its control blocks.
pub fn gathered_throughput(count: usize, block: usize, min_time: Duration) -> f64 {
    let (bank, step) = synthetic_bank(count, 48_000.0);
    let mut gather = FreeGather::with_room(count);
    bank.gather_free(&step, &mut gather).expect("room for the bank");
    let mut acc = vec![[0.0; LANES]; block];
    mode_samples_per_s(count, block, min_time, || {
        gather.run_fresh(&mut acc);
        std::hint::black_box(&acc);
    })
}

/// Mode-samples per second of `run_block` (`count` modes over `block`
/// samples), run 16 times between looks at the clock until `min_time` has passed.
fn mode_samples_per_s(count: usize, block: usize, min_time: Duration, mut run_block: impl FnMut()) -> f64 {
    let mut samples = 0usize;
    let start = Instant::now();
    while start.elapsed() < min_time {
        for _ in 0..16 {
            run_block();
        }
        samples += 16 * block;
    }
    (count * samples) as f64 / start.elapsed().as_secs_f64()
}

/// A Broadwood-like C2 string (the 11 g hammer, C2 felt K = 4e8, alpha = 2.3) at 48 kHz.
pub fn contact_string() -> (StruckString, HammerSpec) {
    let string = StringSpec {
        length_m: 0.925,
        tuning: Tuning::FirstPartialHz(65.41),
        mass: Mass::PerLengthKgM(0.0789),
        stiffness: Stiffness::Inharmonicity(2.2e-4),
        damping: Damping::UniformQ(2000.0),
        max_frequency_hz: 20_000.0,
        outer_diameter_m: None,
    }
    .build()
    .expect("a valid string");
    let hammer = HammerSpec {
        mass_kg: 0.011,
        law: ContactLaw { stiffness: 4.0e8, exponent: 2.3 },
        speed_m_s: 2.5,
        position: 0.135,
        hysteresis: None,
    };
    (StruckString::new(string, 48_000.0, DEFAULT_SUBSTEPS), hammer)
}

/// Throughput while a hammer is on the string: mode-steps (sub-steps included)
/// per second, each with its implicit contact solve. Returns (rate, modes).
pub fn contact_throughput(min_time: Duration) -> (f64, usize) {
    let (mut s, hammer) = contact_string();
    let modes = s.string().mode_count();
    let mut steps = 0usize;
    let mut timed = Duration::ZERO;
    while timed < min_time {
        s.strike(hammer);
        let start = Instant::now();
        let mut samples = 0;
        while s.in_contact() {
            std::hint::black_box(s.tick());
            samples += 1;
        }
        timed += start.elapsed();
        steps += samples * DEFAULT_SUBSTEPS;
    }
    ((steps * modes) as f64 / timed.as_secs_f64(), modes)
}

/// What a polyphonic workload achieved.
#[derive(Clone, Copy, Debug)]
pub struct SynthThroughput {
    /// Seconds of audio per second of computing, one thread.
    pub real_time_factor: f64,
    /// Most keys sounding at once during the run.
    pub max_keys: usize,
    /// Time to build the instrument's tables, s.
    pub build_s: f64,
}

/// Play `kind` at 48 kHz for `audio_s` seconds in 512-sample blocks: a four-note
/// chord every 20 blocks (about 0.2 s) wandering over the keyboard, sustain pedal
/// down throughout, so keys pile up to the polyphony cap of 128.
pub fn synth_throughput(kind: struck_engine::design::InstrumentKind, audio_s: f64) -> SynthThroughput {
    use struck_engine::synth::{Controls, Event, Instrument, Synth, TimedEvent, default_settings};
    const BLOCK: usize = 512;
    let start = Instant::now();
    let instrument = Instrument::build(&default_settings(kind, 48_000.0)).expect("the built-in instruments build");
    let build_s = start.elapsed().as_secs_f64();
    let (mut synth, _scope) = Synth::new(Box::new(instrument));
    synth.set_controls(Controls { polyphony: 128, ..Controls::default() });
    let keys: Vec<u8> = kind.key_range().collect();
    let (mut left, mut right) = (vec![0.0f32; BLOCK], vec![0.0f32; BLOCK]);
    let mut events = Vec::with_capacity(8);
    let blocks = (audio_s * 48_000.0 / BLOCK as f64).ceil() as usize;
    let mut max_keys = 0;
    let start = Instant::now();
    for b in 0..blocks {
        events.clear();
        if b % 20 == 0 {
            events.push(TimedEvent::new(0, Event::Sustain(1.0)));
            for j in 0..4 {
                let key = keys[(b / 20 * 7 + j * 5) % keys.len()];
                events.push(TimedEvent::new(3, Event::NoteOn { key, velocity: 0.7 }));
            }
        }
        synth.process(&events, &mut left, &mut right);
        max_keys = max_keys.max(synth.active_keys());
    }
    let elapsed = start.elapsed().as_secs_f64();
    SynthThroughput { real_time_factor: blocks as f64 * BLOCK as f64 / 48_000.0 / elapsed, max_keys, build_s }
}

/// How long building `kind`'s instrument at `sample_rate_hz` takes, s
/// ([`BuildTimes`]), each the fastest of `runs` (at least 1).
pub fn build_times(kind: struck_engine::design::InstrumentKind, sample_rate_hz: f64, runs: usize) -> BuildTimes {
    use struck_engine::synth::{Instrument, built, default_settings};
    let settings = default_settings(kind, sample_rate_hz);
    let timed = |build: &dyn Fn() -> Instrument, forget: bool| {
        let mut fastest = f64::INFINITY;
        for _ in 0..runs.max(1) {
            if forget {
                built::forget();
            }
            let start = Instant::now();
            let instrument = build();
            fastest = fastest.min(start.elapsed().as_secs_f64());
            // Dropped after the clock stops, as a host drops the one it replaces.
            drop(instrument);
        }
        fastest
    };
    let build = || Instrument::build(&settings).expect("the built-in instruments build");
    let first_s = timed(&build, true);
    let again_s = timed(&build, false);
    let unvoiced_s = timed(&|| Instrument::build_afresh(&settings).expect("the built-in instruments build"), true);
    built::forget();
    BuildTimes { first_s, again_s, unvoiced_s }
}

/// How long an instrument takes to build, s.
#[derive(Clone, Copy, Debug)]
pub struct BuildTimes {
    /// In a program that has built nothing yet: its voicing through the body
    /// comes with the program (as every instrument's as it starts does).
    pub first_s: f64,
    /// The same settings again: a copy of the one kept.
    pub again_s: f64,
    /// Voiced through the body from nothing, as settings the program has not
    /// met (a voicing parameter moved) are.
    pub unvoiced_s: f64,
}

/// Independent multiply-add chains in the probe, each as wide as one vector
/// register of the target (8 f64 lanes with AVX-512, 4 with AVX2, 2 with NEON
/// and SSE): enough to cover the latency of every FMA unit (4 cycles x 2 units
/// x a margin) and few enough to stay in the registers. (Chains of 8 lanes
/// everywhere spilled to the stack with AVX2: on a Zen 3 the probe read
/// 1.05-2.0e10 multiply-adds a second where its units do 2.3e10.)
const PROBE_CHAINS: usize = 12;

/// `rounds` rounds of [`PROBE_CHAINS`] chains of multiply-adds: the chains and
/// how many multiply-adds they took.
#[multiversion::multiversion(targets("x86_64+avx512f+avx512vl+fma", "x86_64+avx2+fma", "aarch64+neon"))]
fn fma_chains(rounds: usize, x: f64, y: f64) -> ([f64; PROBE_CHAINS * LANES], usize) {
    multiversion::target::match_target! {
        "x86_64+avx512f" => chains_of::<8>(rounds, x, y),
        "x86_64+avx2" => chains_of::<4>(rounds, x, y),
        _ => chains_of::<2>(rounds, x, y),
    }
}

/// [`fma_chains`] with chains `W` lanes wide, laid out one after the other.
#[inline(always)]
fn chains_of<const W: usize>(rounds: usize, x: f64, y: f64) -> ([f64; PROBE_CHAINS * LANES], usize) {
    let mut acc = [[0.0; W]; PROBE_CHAINS];
    for (c, chain) in acc.iter_mut().enumerate() {
        for (l, a) in chain.iter_mut().enumerate() {
            *a = (c * W + l) as f64 * 1e-3;
        }
    }
    for _ in 0..rounds {
        for chain in acc.iter_mut() {
            for a in chain.iter_mut() {
                *a = a.mul_add(x, y);
            }
        }
    }
    let mut all = [0.0; PROBE_CHAINS * LANES];
    for (to, from) in all.iter_mut().zip(acc.iter().flatten()) {
        *to = *from;
    }
    (all, rounds * PROBE_CHAINS * W)
}

/// The machine's multiply-add throughput on this thread, f64 multiply-adds per
/// second, at the widest vectors the kernels are compiled for (the same dispatch).
pub fn fma_probe(min_time: Duration) -> f64 {
    const ROUNDS: usize = 100_000;
    let (x, y) = std::hint::black_box((0.999_999, 1e-9));
    let mut fmas = 0usize;
    let start = Instant::now();
    while start.elapsed() < min_time {
        let (acc, done) = fma_chains(ROUNDS, x, y);
        std::hint::black_box(acc);
        fmas += done;
    }
    fmas as f64 / start.elapsed().as_secs_f64()
}

#[cfg(test)]
mod tests {
    use super::cpu_identity;

    #[test]
    fn the_processor_is_named_with_its_family_and_model() {
        let info = "processor\t: 0\nvendor_id\t: AuthenticAMD\ncpu family\t: 25\nmodel\t\t: 17\n\
                    model name\t: AMD EPYC\nstepping\t: 1\n\nprocessor\t: 1\ncpu family\t: 26\nmodel\t\t: 2\n\
                    model name\t: Other\n";
        assert_eq!(cpu_identity(info).as_deref(), Some("AMD EPYC (family 25, model 17)"));
        // An Arm machine's cpuinfo has neither a family nor a model name.
        assert_eq!(cpu_identity("processor\t: 0\nBogoMIPS\t: 50.00\nCPU part\t: 0xd0c\n"), None);
        assert_eq!(cpu_identity("model name\t: Some CPU\n").as_deref(), Some("Some CPU"));
    }
}
