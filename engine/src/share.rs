//! Work shared between two cores, offline: the synth's keys and its body each
//! cut in two halves that never write to the same place, the second half run
//! by a [`Helper`] thread while the caller runs the first (or, while a render
//! through the body is not watched, one job a stretch: the caller trades
//! among the strings while the helper drives the bridge and runs the body
//! over the stretch before, then each tells and sounds its half of the keys:
//! `Synth::stretch_beside`). Which half a piece of work falls in, and the
//! order the halves' sums are added in, never depend on whether a helper
//! ran one, so a render is bit-identical on one thread and on two.
//!
//! The halves are short (a control block of a few keys: some microseconds),
//! so the helper waits for them spinning, never sleeping between them, and
//! always takes the second half: its keys' state stays in its core's cache.
//! (A work-stealing pool ran the halves on either core and slept between
//! them: the 32-note chord rendered slower on two cores than on one.) The
//! helper parks after two milliseconds without work, and at once while the
//! caller runs alone: sharing is tried now and then against running alone,
//! and kept only while it is the faster ([`Helper::judge`]).
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

/// Whether sharing pays is judged on whole blocks, by the caller's clock
/// (see [`Helper::judge`]): a trial runs [`TRIAL_QUARTER`] control blocks
/// shared, twice that many alone, then as many shared again (so a load that
/// grows or shrinks steadily weighs on both alike), comparing the clock time
/// per unit of estimated work. Whichever was faster runs for [`KEEP_BLOCKS`],
/// then the next trial. Sharing must be faster by [`SHARE_BELOW`] to be kept.
/// (A check on each join, its clock time against its halves', missed what
/// sharing costs outside the joins: this virtual machine's second core is at
/// times much slower, or slows the first, and the 32-note chord rendered at
/// 0.8 of its one-thread speed.)
const TRIAL_QUARTER: u32 = 96;
const KEEP_BLOCKS: u32 = 3072;
const SHARE_BELOW: f64 = 0.95;

/// Where a helper stands in its trials.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Stage {
    /// The trial's first shared quarter, the alone half, the last shared quarter.
    First,
    Alone,
    Last,
    /// The trial's winner, kept for a while.
    Keep {
        shared: bool,
    },
}

/// What a trial has measured: clock time and estimated work, shared and alone.
#[derive(Clone, Copy, Debug, Default)]
struct Tally {
    shared_s: f64,
    shared_work: f64,
    alone_s: f64,
    alone_work: f64,
}

/// A second thread that runs one half of each piece of shared work.
pub struct Helper {
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
    /// The trial's stage, control blocks left in it, and what it measured.
    stage: Stage,
    blocks_left: u32,
    tally: Tally,
    /// Whether it judges at all (else it always hands over).
    judging: bool,
}

struct Shared {
    /// The job posted to the helper, null when there is none.
    job: CachePadded<AtomicPtr<Job>>,
    /// Set by the helper once the posted job has run.
    done: CachePadded<AtomicBool>,
    /// Set while the caller runs alone: the helper parks at once. (Advisory:
    /// it guards no data, and a job is never posted while it is set.)
    rest: AtomicBool,
    /// How many times the helper has parked to rest.
    #[cfg(test)]
    rests: std::sync::atomic::AtomicU32,
    stop: AtomicBool,
}

/// A value alone on its cache line (two cores polling neighbours would
/// pass the line back and forth).
#[repr(align(128))]
pub(crate) struct CachePadded<T>(pub(crate) T);

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

/// What a job runs, and the panic it ended in, if it did.
struct Slot<B> {
    work: Option<B>,
    panic: Option<Box<dyn Any + Send>>,
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
        slot.panic = catch_unwind(AssertUnwindSafe(work)).err();
    }
}

impl Helper {
    /// Start the helper thread. Allocates; not for the audio thread.
    pub fn start() -> std::io::Result<Self> {
        let shared = Arc::new(Shared {
            job: CachePadded(AtomicPtr::new(std::ptr::null_mut())),
            done: CachePadded(AtomicBool::new(false)),
            rest: AtomicBool::new(false),
            #[cfg(test)]
            rests: std::sync::atomic::AtomicU32::new(0),
            stop: AtomicBool::new(false),
        });
        let theirs = Arc::clone(&shared);
        let thread = std::thread::Builder::new().name("struck-helper".into()).spawn(move || serve(&theirs))?;
        Ok(Self {
            shared,
            thread: Some(thread),
            stage: Stage::First,
            blocks_left: TRIAL_QUARTER,
            tally: Tally::default(),
            judging: true,
        })
    }

    /// Whether the joins hand their second halves over now (see [`TRIAL_QUARTER`]).
    fn hands_over(&self) -> bool {
        !matches!(self.stage, Stage::Alone | Stage::Keep { shared: false })
    }

    /// Hand every join over from now on, never judging whether it pays (for
    /// tests that must see the work shared).
    pub fn always_hand_over(&mut self) {
        self.judging = false;
        self.stage = Stage::Keep { shared: true };
        self.shared.rest.store(false, Ordering::Relaxed);
        if let Some(thread) = &self.thread {
            thread.thread().unpark();
        }
    }

    /// Weigh a stretch of the caller's work that took `took` on its clock,
    /// `blocks` control blocks of `work` (an estimate in any unit that grows
    /// with the work: the same for the same work whether shared or not),
    /// and move the trial on (see [`TRIAL_QUARTER`]). A stage ends after the
    /// stretch that completes its blocks.
    pub fn judge(&mut self, took: Duration, work: f64, blocks: u32) {
        if !self.judging {
            return;
        }
        let shared = self.hands_over();
        if let Stage::First | Stage::Alone | Stage::Last = self.stage {
            let t = &mut self.tally;
            if shared {
                (t.shared_s, t.shared_work) = (t.shared_s + took.as_secs_f64(), t.shared_work + work);
            } else {
                (t.alone_s, t.alone_work) = (t.alone_s + took.as_secs_f64(), t.alone_work + work);
            }
        }
        self.blocks_left = self.blocks_left.saturating_sub(blocks);
        if self.blocks_left > 0 {
            return;
        }
        (self.stage, self.blocks_left) = match self.stage {
            Stage::First => (Stage::Alone, 2 * TRIAL_QUARTER),
            Stage::Alone => (Stage::Last, TRIAL_QUARTER),
            Stage::Last => {
                let t = std::mem::take(&mut self.tally);
                // Per unit of work; with no work measured, sharing has nothing to gain.
                let pays = t.shared_work > 0.0
                    && t.alone_work > 0.0
                    && t.shared_s / t.shared_work < SHARE_BELOW * (t.alone_s / t.alone_work);
                (Stage::Keep { shared: pays }, KEEP_BLOCKS)
            }
            Stage::Keep { .. } => (Stage::First, TRIAL_QUARTER),
        };
        // (Woken ahead of its first job, which would wake it too.)
        self.shared.rest.store(!self.hands_over(), Ordering::Relaxed);
        if self.hands_over()
            && let Some(thread) = &self.thread
        {
            thread.thread().unpark();
        }
    }

    /// Run `a` here and `b` on the helper, side by side; return once both
    /// have. A panic in either is passed on (after both have finished).
    /// While the caller runs alone (the judge's choice), `a` then `b` here:
    /// `b` may wait on something `a` does, never the other way round.
    /// (`&mut`: one job at a time, and none posted from inside another.)
    pub fn join<A: FnOnce(), B: FnOnce() + Send>(&mut self, a: A, b: B) {
        if !self.hands_over() {
            a();
            b();
            return;
        }
        let mut slot = Slot { work: Some(b), panic: None };
        let job = Job { run: run_slot::<B>, slot: (&raw mut slot).cast() };
        self.shared.done.store(false, Ordering::Relaxed);
        self.shared.job.store((&raw const job).cast_mut(), Ordering::Release);
        if let Some(thread) = &self.thread {
            thread.thread().unpark();
        }
        {
            // Waits for the helper however `a` ends: `slot` and `job` must
            // outlive its run of them.
            let _wait = WaitForHelper(&self.shared);
            a();
        }
        if let Some(panic) = slot.panic.take() {
            resume_unwind(panic);
        }
    }
}

/// On drop, waits for the helper to finish the posted job.
struct WaitForHelper<'a>(&'a Shared);

impl Drop for WaitForHelper<'_> {
    fn drop(&mut self) {
        // The other half is about as long as this one: spin.
        spin_until(&self.0.done);
    }
}

/// Wait for `flag` to be set by the other thread (Acquire): spinning on
/// reads, the core yielded at each look after [`SPIN_BEFORE_YIELDING`] (on a
/// busy machine the other thread may be waiting for this core).
pub(crate) fn spin_until(flag: &AtomicBool) {
    let mut spins = 0u32;
    let mut since = None;
    while !flag.load(Ordering::Acquire) {
        spins = spins.wrapping_add(1);
        if spins.is_multiple_of(SPINS_PER_LOOK)
            && since.get_or_insert_with(Instant::now).elapsed() > SPIN_BEFORE_YIELDING
        {
            std::thread::yield_now();
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
        } else if shared.rest.load(Ordering::Relaxed) {
            // The caller runs alone for a while: out of its way at once.
            #[cfg(test)]
            shared.rests.fetch_add(1, Ordering::Relaxed);
            std::thread::park();
            idle = 0;
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

/// Run `a` and `b`: side by side if there is a `helper`, else `a` first (so
/// `b` may wait on `a`, never the other way round).
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

    /// Where each of 10 joins ran: on this thread or not.
    fn joins_here(helper: &mut Helper) -> Vec<bool> {
        let here = std::thread::current().id();
        (0..10)
            .map(|_| {
                let mut on = None;
                helper.join(|| (), || on = Some(std::thread::current().id()));
                on == Some(here)
            })
            .collect()
    }

    /// Run one trial, each stretch one control block of one unit of work,
    /// taking `shared_us` shared and `alone_us` alone.
    fn trial(helper: &mut Helper, shared_us: u64, alone_us: u64) {
        for _ in 0..4 * TRIAL_QUARTER {
            let us = if helper.hands_over() { shared_us } else { alone_us };
            helper.judge(Duration::from_micros(us), 1.0, 1);
        }
    }

    #[test]
    fn sharing_is_kept_only_while_a_trial_finds_it_faster() {
        let mut helper = Helper::start().unwrap();
        // A trial shares for its first quarter, runs alone for half, shares again.
        assert!(joins_here(&mut helper).iter().all(|&here| !here), "a trial starts shared");
        for _ in 0..TRIAL_QUARTER {
            helper.judge(Duration::from_micros(10), 1.0, 1);
        }
        assert!(joins_here(&mut helper).iter().all(|&here| here), "the trial's middle runs alone");
        for _ in 0..2 * TRIAL_QUARTER {
            helper.judge(Duration::from_micros(10), 1.0, 1);
        }
        assert!(helper.hands_over(), "the trial's last quarter shares");
        for _ in 0..TRIAL_QUARTER {
            helper.judge(Duration::from_micros(10), 1.0, 1);
        }
        // Equal speeds: sharing has not paid. The helper has gone to rest.
        assert!(!helper.hands_over());
        assert!(joins_here(&mut helper).iter().all(|&here| here));
        let rested = || helper.shared.rests.load(Ordering::Relaxed) > 0;
        let since = Instant::now();
        while !rested() && since.elapsed() < Duration::from_secs(5) {
            std::thread::sleep(Duration::from_millis(1));
        }
        assert!(rested(), "the helper did not park while the caller ran alone");
        // It is tried again after a while, and now pays.
        helper.judge(Duration::from_micros(10), 1.0, KEEP_BLOCKS);
        assert!(helper.hands_over(), "tried again");
        trial(&mut helper, 8, 10);
        assert!(helper.hands_over());
        assert!(joins_here(&mut helper).iter().all(|&here| !here));
        // Sharing must be more than 5 % faster: 3 % is not enough.
        helper.judge(Duration::from_micros(10), 1.0, KEEP_BLOCKS);
        trial(&mut helper, 97, 100);
        assert!(!helper.hands_over(), "kept sharing for 3 %");
        helper.judge(Duration::from_micros(10), 1.0, KEEP_BLOCKS);
        trial(&mut helper, 90, 100);
        assert!(helper.hands_over(), "dropped sharing at 10 %");
        // Per unit of work: a shared stretch that did twice the work in 1.5
        // times the time pays, one that did the same work in 1.5 times does not.
        helper.judge(Duration::from_micros(10), 1.0, KEEP_BLOCKS);
        for _ in 0..4 * TRIAL_QUARTER {
            let (us, work) = if helper.hands_over() { (15, 2.0) } else { (10, 1.0) };
            helper.judge(Duration::from_micros(us), work, 1);
        }
        assert!(helper.hands_over());
        helper.judge(Duration::from_micros(10), 1.0, KEEP_BLOCKS);
        trial(&mut helper, 15, 10);
        assert!(!helper.hands_over());
    }

    #[test]
    fn a_helper_told_to_always_hand_over_does_so() {
        let mut helper = Helper::start().unwrap();
        helper.always_hand_over();
        trial(&mut helper, 1000, 1);
        helper.judge(Duration::from_micros(1000), 1.0, 10 * KEEP_BLOCKS);
        assert!(joins_here(&mut helper).iter().all(|&here| !here));
    }

    #[test]
    fn a_stretch_of_many_blocks_ends_a_stage_and_no_more() {
        let mut helper = Helper::start().unwrap();
        helper.judge(Duration::from_micros(10), 1.0, 10 * TRIAL_QUARTER);
        assert_eq!(helper.stage, Stage::Alone);
        helper.judge(Duration::from_micros(10), 1.0, 10 * TRIAL_QUARTER);
        assert_eq!(helper.stage, Stage::Last);
        // No work measured alone (a pause in the music), however fast the
        // shared stretches: nothing to judge by, so it runs alone.
        let mut silent = Helper::start().unwrap();
        for _ in 0..4 * TRIAL_QUARTER {
            let work = if silent.hands_over() { 1.0 } else { 0.0 };
            silent.judge(Duration::from_micros(1), work, 1);
        }
        assert_eq!(silent.stage, Stage::Keep { shared: false });
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
