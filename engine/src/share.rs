//! Work shared between two cores, offline: the synth's keys and its body each
//! cut in two halves that never write to the same place, the second half run
//! by a [`Helper`] thread while the caller runs the first. Which half a piece
//! of work falls in, and the order the halves' sums are added in, never
//! depend on whether a helper ran one, so a render is bit-identical on one
//! thread and on two.
//!
//! The halves are short (a control block of a few keys: some microseconds),
//! so the helper waits for them spinning, never sleeping between them, and
//! always takes the second half: its keys' state stays in its core's cache.
//! (A work-stealing pool ran the halves on either core and slept between
//! them: the 32-note chord rendered slower on two cores than on one.) The
//! helper parks after two milliseconds without work.
//!
//! The real-time plugin never shares: its audio thread may not wait on another.

use std::any::Any;
use std::panic::{AssertUnwindSafe, catch_unwind, resume_unwind};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicPtr, Ordering};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

/// How long a wait spins before it yields the core at each look (on a busy
/// machine the other side may be waiting for it), and how long the helper
/// waits without work before it parks. Waking a parked thread takes some
/// tens of microseconds on a virtual machine: longer than a half's work, so
/// the helper waits out the caller's serial work (the strings' trading
/// through the bridge, writing the output) awake.
const SPIN_BEFORE_YIELDING: Duration = Duration::from_micros(50);
const SPIN_BEFORE_PARKING: Duration = Duration::from_millis(2);
/// Spins between looks at the clock.
const SPINS_PER_LOOK: u32 = 256;

/// Whether handing a half over pays: measured as the clock time of the
/// shared joins over the time their two halves took (each half side by side
/// with the other: 0.5; a helper kept waiting for its core: 1 or more),
/// weighted by that time and forgetting over about [`PAYS_MEMORY`] joins.
/// Above [`NOT_PAYING`] the halves run on the calling thread one after the
/// other (the same samples) for [`RETRY_AFTER`] joins, and then the helper
/// is tried again. (On this virtual machine the second core is at times much
/// slower for a while: a light piece rendered at half its one-thread speed.)
const PAYS_MEMORY: f64 = 50.0;
const NOT_PAYING: f64 = 0.9;
const RETRY_AFTER: u32 = 3000;

/// A second thread that runs one half of each piece of shared work.
pub struct Helper {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    /// The shared joins' clock time and their halves' time, decaying, and
    /// how many have been weighed since the helper was last tried.
    clock_s: f64,
    halves_s: f64,
    weighed: u32,
    /// Joins left to run on the calling thread.
    here_for: u32,
}

struct Shared {
    /// The job posted to the helper, null when there is none.
    job: CachePadded<AtomicPtr<Job>>,
    /// Set by the helper once the posted job has run.
    done: CachePadded<AtomicBool>,
    stop: AtomicBool,
}

/// A value alone on its cache line (two cores polling neighbours would
/// pass the line back and forth).
#[repr(align(128))]
struct CachePadded<T>(T);

impl<T> std::ops::Deref for CachePadded<T> {
    type Target = T;
    fn deref(&self) -> &T {
        &self.0
    }
}

/// A posted job: its closure's slot, on the poster's stack, and how to run it.
struct Job {
    run: unsafe fn(*mut ()),
    slot: *mut (),
}

/// What a job runs, the panic it ended in, if it did, and how long it took.
struct Slot<B> {
    work: Option<B>,
    panic: Option<Box<dyn Any + Send>>,
    took: Duration,
}

/// Run the closure in `slot`, a `Slot<B>`, keeping its panic.
///
/// # Safety
/// `slot` points to a live `Slot<B>` that nothing else touches until the
/// helper reports the job done.
unsafe fn run_slot<B: FnOnce()>(slot: *mut ()) {
    // SAFETY: as the caller promises.
    let slot = unsafe { &mut *slot.cast::<Slot<B>>() };
    if let Some(work) = slot.work.take() {
        let start = Instant::now();
        slot.panic = catch_unwind(AssertUnwindSafe(work)).err();
        slot.took = start.elapsed();
    }
}

impl Helper {
    /// Start the helper thread. Allocates; not for the audio thread.
    pub fn start() -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            job: CachePadded(AtomicPtr::new(std::ptr::null_mut())),
            done: CachePadded(AtomicBool::new(false)),
            stop: AtomicBool::new(false),
        });
        let theirs = Arc::clone(&shared);
        let thread = std::thread::Builder::new().name("struck-helper".into()).spawn(move || serve(&theirs))?;
        Ok(Self { shared, thread: Some(thread), clock_s: 0.0, halves_s: 0.0, weighed: 0, here_for: 0 })
    }

    /// Whether the next join hands its second half over (see [`NOT_PAYING`]).
    #[cfg(test)]
    fn hands_over(&self) -> bool {
        self.here_for == 0
    }

    /// Run `a` here and `b` on the helper, side by side; return once both
    /// have. A panic in either is passed on (after both have finished).
    /// (`&mut`: one job at a time, and none posted from inside another.)
    pub fn join<A: FnOnce(), B: FnOnce() + Send>(&mut self, a: A, b: B) {
        if self.here_for > 0 {
            self.here_for -= 1;
            a();
            b();
            return;
        }
        let start = Instant::now();
        let mut slot = Slot { work: Some(b), panic: None, took: Duration::ZERO };
        let job = Job { run: run_slot::<B>, slot: (&raw mut slot).cast() };
        self.shared.done.store(false, Ordering::Relaxed);
        self.shared.job.store((&raw const job).cast_mut(), Ordering::Release);
        if let Some(thread) = &self.thread {
            thread.thread().unpark();
        }
        let here = {
            // Waits for the helper however `a` ends: `slot` and `job` must
            // outlive its run of them.
            let _wait = WaitForHelper(&self.shared);
            a();
            start.elapsed()
        };
        if let Some(panic) = slot.panic.take() {
            resume_unwind(panic);
        }
        self.note(start.elapsed(), here + slot.took);
    }

    /// Weigh a shared join that took `clock` for halves that took `halves`.
    fn note(&mut self, clock: Duration, halves: Duration) {
        let keep = 1.0 - 1.0 / PAYS_MEMORY;
        self.clock_s = keep * self.clock_s + clock.as_secs_f64();
        self.halves_s = keep * self.halves_s + halves.as_secs_f64();
        self.weighed = self.weighed.saturating_add(1);
        // Judged on as many joins as it remembers (one strike's block alone
        // may leave one half with all the work).
        if self.weighed >= PAYS_MEMORY as u32 && self.clock_s > NOT_PAYING * self.halves_s {
            self.here_for = RETRY_AFTER;
            (self.clock_s, self.halves_s, self.weighed) = (0.0, 0.0, 0);
        }
    }
}

/// On drop, waits for the helper to finish the posted job.
struct WaitForHelper<'a>(&'a Shared);

impl Drop for WaitForHelper<'_> {
    fn drop(&mut self) {
        // The other half is about as long as this one: spin.
        let mut spins = 0u32;
        let mut since = None;
        while !self.0.done.load(Ordering::Acquire) {
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(SPINS_PER_LOOK)
                && since.get_or_insert_with(Instant::now).elapsed() > SPIN_BEFORE_YIELDING
            {
                std::thread::yield_now();
            }
        }
    }
}

/// The helper's loop: run each job posted, until told to stop. It spins
/// reading (a spin of `pause`s would have a virtual machine's host take the
/// core away, taking it for a lock's waiter).
fn serve(shared: &Shared) {
    let mut idle = 0u32;
    let mut idle_since = Instant::now();
    loop {
        // Read before taking: a spin of swaps would hold the line away from the poster.
        let job = if shared.job.load(Ordering::Relaxed).is_null() {
            std::ptr::null_mut()
        } else {
            shared.job.swap(std::ptr::null_mut(), Ordering::Acquire)
        };
        if !job.is_null() {
            // SAFETY: a job is posted by `Helper::join`, which does not
            // return before `done` is set, so the job and its slot are live,
            // and nothing else touches the slot meanwhile.
            unsafe { ((*job).run)((*job).slot) };
            shared.done.store(true, Ordering::Release);
            idle = 0;
        } else if shared.stop.load(Ordering::Acquire) {
            return;
        } else {
            if idle == 0 {
                idle_since = Instant::now();
            }
            idle += 1;
            if idle.is_multiple_of(SPINS_PER_LOOK) {
                let waited = idle_since.elapsed();
                if waited > SPIN_BEFORE_PARKING {
                    std::thread::park();
                    idle = 0;
                } else if waited > SPIN_BEFORE_YIELDING {
                    std::thread::yield_now();
                }
            }
        }
    }
}

impl Drop for Helper {
    /// Stops the thread and waits for it to end.
    fn drop(&mut self) {
        self.shared.stop.store(true, Ordering::Release);
        if let Some(thread) = self.thread.take() {
            thread.thread().unpark();
            // A job's panic was caught and passed on; the loop itself does not panic.
            let _ = thread.join();
        }
    }
}

/// Run `a` and `b`: side by side if there is a `helper`, else `a` first.
#[inline]
pub(crate) fn both<A: FnOnce(), B: FnOnce() + Send>(helper: Option<&mut Helper>, a: A, b: B) {
    match helper {
        Some(helper) => helper.join(a, b),
        None => {
            a();
            b();
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn both_halves_run_and_see_their_own_data() {
        let mut helper = Helper::start().unwrap();
        let mut data = vec![0u64; 1000];
        for round in 0..2000u64 {
            let (low, high) = data.split_at_mut(500);
            helper.join(|| low.iter_mut().for_each(|v| *v += round), || high.iter_mut().for_each(|v| *v += 2 * round));
        }
        let sum: u64 = (0..2000).sum();
        assert!(data[..500].iter().all(|&v| v == sum));
        assert!(data[500..].iter().all(|&v| v == 2 * sum));
    }

    #[test]
    fn a_panic_on_the_helper_reaches_the_caller_after_both_have_run() {
        let mut helper = Helper::start().unwrap();
        let mut ran = false;
        let result = catch_unwind(AssertUnwindSafe(|| helper.join(|| ran = true, || panic!("the helper's half"))));
        assert!(ran);
        let message = result.unwrap_err();
        assert_eq!(message.downcast_ref::<&str>(), Some(&"the helper's half"));
        // It still works.
        let mut x = 0;
        helper.join(|| (), || x = 5);
        assert_eq!(x, 5);
    }

    #[test]
    fn a_panic_here_waits_for_the_helper() {
        let mut helper = Helper::start().unwrap();
        let done = AtomicBool::new(false);
        let result = catch_unwind(AssertUnwindSafe(|| {
            helper.join(
                || panic!("the caller's half"),
                || {
                    std::thread::sleep(std::time::Duration::from_millis(20));
                    done.store(true, Ordering::Relaxed);
                },
            )
        }));
        assert!(result.is_err());
        assert!(done.load(Ordering::Relaxed), "the caller unwound before the helper's half had finished");
    }

    #[test]
    fn a_helper_that_does_not_pay_is_left_alone_for_a_while() {
        let mut helper = Helper::start().unwrap();
        let here = std::thread::current().id();
        let mut ran_on = Vec::new();
        for _ in 0..200 {
            let mut on = None;
            // The helper's half is all the work: handing it over saves nothing.
            helper.join(
                || (),
                || {
                    std::thread::sleep(Duration::from_micros(100));
                    on = Some(std::thread::current().id());
                },
            );
            ran_on.push(on.unwrap());
        }
        assert_ne!(ran_on[0], here, "the first join hands over");
        assert_eq!(ran_on[199], here, "still handing over a half that does not pay");
        assert!(!helper.hands_over());
    }

    #[test]
    fn a_dropped_helper_ends_its_thread() {
        let helper = Helper::start().unwrap();
        let shared = Arc::clone(&helper.shared);
        assert_eq!(Arc::strong_count(&shared), 3);
        drop(helper);
        // The thread's own handle on the flags went with it.
        assert_eq!(Arc::strong_count(&shared), 1);
    }

    #[test]
    fn a_parked_helper_wakes_for_work() {
        let mut helper = Helper::start().unwrap();
        std::thread::sleep(std::time::Duration::from_millis(50));
        let mut x = 0;
        helper.join(|| (), || x = 7);
        assert_eq!(x, 7);
    }
}
