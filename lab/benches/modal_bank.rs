//! The modal bank's hot loops: free modes in banks of 1k, 16k and 64k (the
//! whole-keyboard scale), a piano bass string while its hammer is on it
//! (8 sub-steps per sample, each with the implicit contact solve), and the
//! contact solve alone, and each instrument's body driven at two of its zones.
//!
//! Throughput is in mode-samples (free, body), mode-steps (contact) or solves per second.

use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use struck_engine::CONTROL_BLOCK;
use struck_engine::body::boards::{MAX_ZONES, design};
use struck_engine::body::soundboard::{MicPlacement, Soundboard};
use struck_engine::exciter::hammer::contact::{ContactLaw, Felt, Guess, LastPower};
use struck_engine::struck_string::DEFAULT_SUBSTEPS;
use struck_lab::perf::{contact_string, synthetic_bank};

const BLOCK: usize = 64;

fn free_modes(c: &mut Criterion) {
    let mut group = c.benchmark_group("free modes, block of 64 at 48 kHz");
    for count in [1024, 16 * 1024, 64 * 1024] {
        let (mut bank, step) = synthetic_bank(count, 48_000.0);
        let mut out = vec![0.0; BLOCK];
        group.throughput(Throughput::Elements((count * BLOCK) as u64));
        group.bench_function(format!("{count} modes"), |b| {
            b.iter(|| {
                out.fill(0.0);
                bank.process_free(&step, &mut out);
                std::hint::black_box(&out);
            })
        });
    }
    group.finish();
}

fn in_contact(c: &mut Criterion) {
    let (mut string, hammer) = contact_string();
    let modes = string.string().mode_count();
    let mut group = c.benchmark_group("string in contact");
    group.throughput(Throughput::Elements((modes * DEFAULT_SUBSTEPS) as u64));
    group.bench_function(format!("C2, {modes} modes, 8 sub-steps per sample"), |b| {
        // Time only samples with the hammer on the string; striking again is left out.
        b.iter_custom(|samples| {
            let mut timed = Duration::ZERO;
            for _ in 0..samples {
                if !string.in_contact() {
                    string.strike(hammer);
                }
                let start = Instant::now();
                std::hint::black_box(string.tick());
                timed += start.elapsed();
            }
            timed
        })
    });
    group.finish();
}

/// The arguments of the solves of one felt compression: (c0, c_hat) for each
/// step as the compression rises from 0 to `peak_m` and falls back along a half
/// sine. Each step starts where the previous solve ended; its force-free
/// prediction c_hat is the half sine's next point plus W times the felt's force
/// there, so the solve lands near the half sine.
fn compression_sequence(law: ContactLaw, w: f64, peak_m: f64, steps: usize) -> Vec<(f64, f64)> {
    let mut c0 = 0.0;
    (1..steps)
        .map(|k| {
            let target = peak_m * (std::f64::consts::PI * k as f64 / steps as f64).sin();
            let c_hat = target + w * law.force_n(target);
            let args = (c0, c_hat);
            c0 = law.solve(c0, c_hat, w).compression_m;
            args
        })
        .collect()
}

fn contact_solve(c: &mut Criterion) {
    // The C2 felt of contact_string(): K = 4e8 N/m^2.3, alpha = 2.3 (50 N at 1 mm).
    let law = ContactLaw { stiffness: 4.0e8, exponent: 2.3 };
    let w = 1e-7;
    let steps = compression_sequence(law, w, 1e-3, 1024);
    let mut group = c.benchmark_group("contact solve");
    group.throughput(Throughput::Elements(steps.len() as u64));
    group.bench_function("felt K 4e8 alpha 2.3, compression 0 to 1 mm and back, W 1e-7 m/N", |b| {
        b.iter(|| {
            let law = std::hint::black_box(law);
            for &(c0, c_hat) in std::hint::black_box(&steps) {
                std::hint::black_box(law.solve(std::hint::black_box(c0), c_hat, std::hint::black_box(w)));
            }
        })
    });
    // As a strike runs them: each step from the felt the last left, from the
    // force of the last five carried on by a quartic and the compression of the
    // last three by a parabola.
    group.bench_function("the same, chained, from extrapolated forces", |b| {
        b.iter(|| {
            let law = std::hint::black_box(law);
            let mut felt = Felt::default();
            let mut forces = [0.0; 5];
            let mut compressions = [0.0; 3];
            let binomial = law.binomial();
            let last_power = LastPower::default();
            for &(_, c_hat) in std::hint::black_box(&steps) {
                let [f0, f1, f2, f3, f4] = forces;
                let guess = Guess {
                    force_n: 5.0 * (f0 - f3) - 10.0 * (f1 - f2) + f4,
                    compression_m: 3.0 * (compressions[0] - compressions[1]) + compressions[2],
                    binomial: &binomial,
                    last_power: &last_power,
                };
                let (step, end) = law.step(felt, c_hat, std::hint::black_box(w), Some(guess));
                felt = end;
                forces = [step.step_force_n, f0, f1, f2, f3];
                compressions = [step.compression_m, compressions[0], compressions[1]];
            }
            std::hint::black_box(felt)
        })
    });
    group.finish();
}

fn bodies(c: &mut Criterion) {
    let mut group = c.benchmark_group("body, block of 64 at 48 kHz, two zones pushed on");
    for kind in struck_engine::design::InstrumentKind::ALL {
        let board = design(kind);
        let zones = board.zone_points();
        let mut body = Soundboard::build(&board, 48_000.0, &zones, MicPlacement::default().positions(&board), 1.0);
        // A noise-like push at the first two zones (or the one a board has).
        let mut forces = [[0.0; CONTROL_BLOCK]; MAX_ZONES];
        let mut x = 0x2545_f491_4f6c_dd1d_u64;
        for row in forces.iter_mut().take(2.min(zones.len())) {
            for f in row.iter_mut() {
                x ^= x << 13;
                x ^= x >> 7;
                x ^= x << 17;
                *f = (x >> 11) as f64 / (1u64 << 53) as f64 - 0.5;
            }
        }
        let (mut left, mut right) = ([0.0; CONTROL_BLOCK], [0.0; CONTROL_BLOCK]);
        group.throughput(Throughput::Elements((body.mode_count() * CONTROL_BLOCK) as u64));
        group.bench_function(format!("{}, {} modes", kind.name(), body.mode_count()), |b| {
            b.iter(|| {
                body.process(&forces, &mut left, &mut right);
                std::hint::black_box((&left, &right));
            })
        });
    }
    group.finish();
}

fn instruments(c: &mut Criterion) {
    let mut group = c.benchmark_group("instrument, chords every 0.2 s with the pedal down");
    group.sample_size(10);
    for kind in struck_engine::design::InstrumentKind::ALL {
        // One second of audio per iteration; the figure to read is seconds per second of audio.
        group.throughput(Throughput::Elements(48_000));
        group.bench_function(kind.name(), |b| b.iter(|| struck_lab::perf::synth_throughput(kind, 1.0)));
    }
    group.finish();
}

criterion_group!(benches, free_modes, in_contact, contact_solve, bodies, instruments);
criterion_main!(benches);
