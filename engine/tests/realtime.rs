//! The audio thread allocates nothing: a long randomised session (notes, pedals,
//! bends, control changes, rebuilds and instrument switches delivered by the
//! workshop thread) under an allocator that counts what the audio thread asks for.

use std::alloc::{GlobalAlloc, Layout, System};
use std::cell::Cell;
use std::sync::Arc;
use std::sync::atomic::{AtomicU64, AtomicUsize, Ordering};

use struck_engine::design::{InstrumentKind, Voicing};
use struck_engine::rng::Rng;
use struck_engine::synth::{Controls, Event, Instrument, InstrumentSettings, Synth, TimedEvent, Workshop};

struct Counting;

thread_local! {
    static WATCHED: Cell<bool> = const { Cell::new(false) };
}
static ON_AUDIO_THREAD: AtomicUsize = AtomicUsize::new(0);

unsafe impl GlobalAlloc for Counting {
    unsafe fn alloc(&self, layout: Layout) -> *mut u8 {
        if WATCHED.try_with(|w| w.get()).unwrap_or(false) {
            ON_AUDIO_THREAD.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.alloc(layout) }
    }

    unsafe fn dealloc(&self, ptr: *mut u8, layout: Layout) {
        if WATCHED.try_with(|w| w.get()).unwrap_or(false) {
            ON_AUDIO_THREAD.fetch_add(1, Ordering::Relaxed);
        }
        unsafe { System.dealloc(ptr, layout) }
    }
}

#[global_allocator]
static ALLOCATOR: Counting = Counting;

#[test]
fn a_long_random_session_allocates_nothing_on_the_audio_thread() {
    // The counter itself works: one watched allocation (and its free) is seen.
    WATCHED.with(|w| w.set(true));
    drop(std::hint::black_box(Box::new(7u64)));
    WATCHED.with(|w| w.set(false));
    assert_eq!(ON_AUDIO_THREAD.swap(0, Ordering::Relaxed), 2);

    let fs = 48_000.0;
    let first = InstrumentSettings {
        kind: InstrumentKind::Piano,
        voicing: Voicing::default(),
        sample_rate_hz: fs,
        tuning: Default::default(),
        mics: Default::default(),
        strings_on_body: true,
    };
    let (mut synth, _scope) = Synth::new(Box::new(Instrument::build(&first).unwrap()));
    // What the "host" wants built: changed from the audio loop below, read by the workshop.
    let wanted = Arc::new(AtomicU64::new(0));
    let reader = wanted.clone();
    let (workshop, mut delivery) = Workshop::spawn(first, move || {
        let code = reader.load(Ordering::Relaxed);
        let kinds = InstrumentKind::ALL.len() as u64;
        let kind = InstrumentKind::ALL[(code % kinds) as usize];
        let voicing = Voicing {
            damping: 1.0 + (code / kinds % 3) as f64 * 0.5,
            fretted: code / kinds / 3 % 2 == 1,
            ..Voicing::default()
        };
        Some(InstrumentSettings {
            kind,
            voicing,
            sample_rate_hz: fs,
            tuning: Default::default(),
            mics: Default::default(),
            strings_on_body: code.is_multiple_of(2),
        })
    });

    let mut rng = Rng::new(0x5eed_1234_abcd);
    let mut events: Vec<TimedEvent> = Vec::with_capacity(64);
    let (mut left, mut right) = (vec![0.0f32; 8192], vec![0.0f32; 8192]);
    let mut rendered = 0usize;
    let mut installs = 0;
    let total = (30.0 * fs) as usize;
    let mut peak = 0.0f32;
    while rendered < total {
        let block = [1, 32, 64, 100, 512, 2048, 8192][rng.below(7) as usize];
        events.clear();
        for _ in 0..rng.below(6) {
            let time = rng.below(block as u64) as u32;
            let key = 36 + rng.below(60) as u8;
            let event = match rng.below(10) {
                0..=3 => Event::NoteOn { key, velocity: 0.05 + 0.95 * rng.unit_f32() },
                4..=6 => Event::NoteOff { key, velocity: rng.unit_f32() },
                7 => Event::Sustain(rng.unit_f32()),
                8 => Event::PitchBend(2.0 * rng.unit_f32() - 1.0),
                _ => [
                    Event::Sostenuto(rng.unit_f32()),
                    Event::UnaCorda(rng.unit_f32()),
                    Event::AllNotesOff,
                    Event::Reset,
                    Event::ModWheel(rng.unit_f32()),
                    Event::Pressure { key, pressure: rng.unit_f32() },
                ][rng.below(6) as usize],
            };
            events.push(TimedEvent::new(time, event));
        }
        events.sort_by_key(|e| e.time);
        if rng.below(40) == 0 {
            wanted.store(rng.below(6 * InstrumentKind::ALL.len() as u64), Ordering::Relaxed);
        }
        let controls = Controls {
            polyphony: 1 + rng.below(64) as usize,
            output_gain: rng.unit(),
            touch_shape: 0.5 + rng.unit(),
            sympathy: rng.unit(),
            phantom: 4.0 * rng.unit(),
            key_noise: 4.0 * rng.unit(),
            damper_noise: 4.0 * rng.unit(),
            pedal_noise: 4.0 * rng.unit(),
            ..Controls::default()
        };
        let kind_before = synth.settings().clone();

        WATCHED.with(|w| w.set(true));
        delivery.exchange(&mut synth);
        synth.set_controls(controls);
        synth.process(&events, &mut left[..block], &mut right[..block]);
        WATCHED.with(|w| w.set(false));

        if *synth.settings() != kind_before {
            installs += 1;
        }
        peak = left[..block].iter().chain(&right[..block]).fold(peak, |p, v| {
            assert!(v.is_finite());
            p.max(v.abs())
        });
        rendered += block;
        // Give the workshop a moment now and then, as real time would.
        if rng.below(50) == 0 {
            std::thread::sleep(std::time::Duration::from_millis(30));
        }
    }
    drop(workshop);
    assert_eq!(ON_AUDIO_THREAD.load(Ordering::Relaxed), 0, "the audio thread allocated or freed memory");
    assert!(installs >= 3, "the session should have switched instruments a few times ({installs})");
    assert!(peak > 0.01, "the session should have made sound");
}
