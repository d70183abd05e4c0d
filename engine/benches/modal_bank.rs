//! The modal bank's hot loops: free modes in banks of 1k, 16k and 64k (the
//! whole-keyboard scale), and a piano bass string while its hammer is on it
//! (8 sub-steps per sample, each with the implicit contact solve).
//!
//! Throughput is in mode-samples (free) or mode-steps (contact) per second.

use std::time::{Duration, Instant};

use criterion::{Criterion, Throughput, criterion_group, criterion_main};
use struck_engine::perf::{contact_string, synthetic_bank};
use struck_engine::struck_string::DEFAULT_SUBSTEPS;

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

fn instruments(c: &mut Criterion) {
    let mut group = c.benchmark_group("instrument, chords every 0.2 s with the pedal down");
    group.sample_size(10);
    for kind in struck_engine::instrument::InstrumentKind::ALL {
        // One second of audio per iteration; the figure to read is seconds per second of audio.
        group.throughput(Throughput::Elements(48_000));
        group.bench_function(kind.name(), |b| b.iter(|| struck_engine::perf::synth_throughput(kind, 1.0)));
    }
    group.finish();
}

criterion_group!(benches, free_modes, in_contact, instruments);
criterion_main!(benches);
