//! The synth played a few milliseconds behind the host, so that a burst of work
//! (a chord's strikes, every hammer on its strings at once) spreads over the
//! blocks after it instead of falling on one.
//!
//! The host hears each sample [`Paced::latency`] samples after its events
//! (a delay the plugin reports, so a host lines recorded notes up). Within
//! that slack the synth renders ahead as far as the events allow while a
//! block's time budget lasts, and never less than the host must hear: a
//! block whose own work is heavy leaves some of it to the next, and a light
//! one catches up. The samples are the synth's own, cut into other stretches
//! (which never changes them), only later.

use std::collections::VecDeque;
use std::time::{Duration, Instant};

use super::{Event, KeyEnded, Synth, TimedEvent};

/// How far the host hears behind its events: 128 samples at 48 kHz, so that
/// what a fortissimo chord's strikes put on two 64-sample blocks spreads over
/// four.
pub const PACED_LATENCY_S: f64 = 128.0 / 48_000.0;
/// The share of a block's period the synth may spend rendering ahead.
pub const PACED_BUDGET: f64 = 0.2;
/// Samples rendered ahead are sliced in multiples of this, the clock read
/// between slices (each slice costs the synth a few microseconds more than
/// rendering the samples in one).
const GRAIN: usize = 8;
/// The longest slice ahead while the synth is behind the host's block, samples.
const MOST: usize = 4 * GRAIN;
/// The ring of rendered samples, samples (a power of two; holds the latency
/// at 192 kHz, 512 samples, and a piece of a host block).
const RING: usize = 2048;
/// The longest latency the ring allows, samples.
pub const MAX_PACED_LATENCY: usize = 512;
/// Events waiting for the synth to reach them, and keys fallen silent in one block.
const QUEUE: usize = 8192;
const ENDED: usize = 1024;

/// A [`Synth`] a fixed number of samples behind the host. Real-time safe
/// (after [`Paced::new`], which allocates).
pub struct Paced {
    synth: Synth,
    latency: usize,
    /// A latency asked for, taken at the next block.
    next_latency: Option<usize>,
    /// Samples the host has been given (and events' time origin).
    now: u64,
    /// Samples the synth has rendered (each heard `latency` samples later),
    /// and up to which it was sounding.
    rendered: u64,
    sounded_until: u64,
    /// Rendered samples, at their index modulo [`RING`].
    left: Box<[f32]>,
    right: Box<[f32]>,
    /// Events not yet reached, at their absolute sample.
    queue: VecDeque<(u64, Event)>,
    /// One slice's events, relative to it.
    slice_events: Vec<TimedEvent>,
    /// Keys fallen silent this block, at the sample the host hears it, and
    /// whether each was struck again after.
    ended: Vec<KeyEnded>,
    restruck: Vec<bool>,
    /// The block being played: its first sample and its length.
    block: (u64, usize),
    budget: f64,
    sample_rate_hz: f64,
    /// What a sample took to render, s, lately, and whether that is known
    /// since the last events.
    per_sample_s: f64,
    cost_known: bool,
}

/// What [`Paced::process_with`] tells its judge before a slice ahead.
#[derive(Clone, Copy, Debug)]
pub struct Ahead {
    /// Samples rendered since it was last asked (or since the block began).
    pub done: usize,
    /// Whether events are applied at the slice's first sample (a strike whose
    /// cost is not known yet).
    pub after_events: bool,
    /// The longest the slice may be: up to the next event, or the host's present.
    pub may: usize,
    /// Whether everything before the host's block is rendered (nothing owed).
    pub caught_up: bool,
    /// Samples still to render in this block to keep an even pace: the
    /// samples the host must hear within k blocks more, over k + 1 blocks
    /// (the most of these for any k).
    pub even: usize,
}

impl Paced {
    /// `synth`, heard `latency` samples late (at most [`MAX_PACED_LATENCY`];
    /// 0 plays it as it is). Allocates.
    pub fn new(synth: Synth, latency: usize) -> Self {
        let sample_rate_hz = synth.instrument().settings().sample_rate_hz;
        let queue = VecDeque::with_capacity(QUEUE);
        // (A slice may take every event queued.)
        let slice_events = Vec::with_capacity(queue.capacity());
        Self {
            synth,
            latency: latency.min(MAX_PACED_LATENCY),
            next_latency: None,
            now: 0,
            rendered: 0,
            sounded_until: 0,
            left: vec![0.0; RING].into_boxed_slice(),
            right: vec![0.0; RING].into_boxed_slice(),
            queue,
            slice_events,
            ended: Vec::with_capacity(ENDED),
            restruck: Vec::with_capacity(ENDED),
            block: (0, 0),
            budget: PACED_BUDGET,
            sample_rate_hz,
            per_sample_s: 0.0,
            cost_known: false,
        }
    }

    /// The latency for `sample_rate_hz`: [`PACED_LATENCY_S`] in samples.
    pub fn latency_for(sample_rate_hz: f64) -> usize {
        ((PACED_LATENCY_S * sample_rate_hz).round() as usize).min(MAX_PACED_LATENCY)
    }

    /// How late the host hears the synth (from the next block, if changed).
    pub fn latency(&self) -> usize {
        self.next_latency.unwrap_or(self.latency)
    }

    pub fn synth(&self) -> &Synth {
        &self.synth
    }

    pub fn synth_mut(&mut self) -> &mut Synth {
        &mut self.synth
    }

    /// Whether anything still sounds or waits to: a key, the body, events
    /// and samples the synth has not reached yet, or samples it rendered
    /// sounding that are not heard yet.
    pub fn is_sounding(&self) -> bool {
        self.synth.is_sounding()
            || !self.queue.is_empty()
            || self.rendered < self.now
            || self.sounded_until + self.latency as u64 > self.now
    }

    /// For each of [`Self::ended_keys`], whether the key was struck again
    /// after it fell silent, in the events the host had sent by then (so the
    /// voice that ended is the one before the key's last).
    pub fn ended_restruck(&self) -> &[bool] {
        &self.restruck
    }

    /// Keys that fell silent during the last [`Self::process`], each at the
    /// sample of its block where the host hears it (or the block's last, if
    /// the synth has run further ahead than the block).
    pub fn ended_keys(&self) -> &[KeyEnded] {
        &self.ended
    }

    /// Spend up to `fraction` of each block's period rendering ahead
    /// (default [`PACED_BUDGET`]; 1 or more: render as far as the events
    /// allow whatever it takes, as an offline render would).
    pub fn set_budget(&mut self, fraction: f64) {
        self.budget = fraction.max(0.0);
    }

    /// Be heard `latency` samples late from the next block on. Everything
    /// queued before it is rendered first (a note-off or a pedal let go is not
    /// lost); the samples rendered and not yet heard are dropped, and a longer
    /// latency is a moment's silence. Real-time safe.
    pub fn set_latency(&mut self, latency: usize) {
        self.next_latency = Some(latency.min(MAX_PACED_LATENCY));
    }

    /// Render `left.len()` samples of what the host hears, applying `events`
    /// (sorted, relative to this block) `latency` samples before they are
    /// heard. Spends up to its budget ([`PACED_BUDGET`] of the block's
    /// period unless set) rendering ahead. Real-time safe.
    pub fn process(&mut self, events: &[TimedEvent], left: &mut [f32], right: &mut [f32]) {
        if self.budget >= 1.0 {
            // Keeping up: everything the events allow, now.
            return self.process_with(events, left, right, |ahead| ahead.may);
        }
        let n = left.len().min(right.len());
        let mut mark = Instant::now();
        let deadline = mark + Duration::from_secs_f64(self.budget * n as f64 / self.sample_rate_hz.max(1.0));
        let mut per_sample = self.per_sample_s;
        // Whether `per_sample` was measured on samples alone, and whether the
        // last slice was (not one that began with events, whose time is
        // theirs as much as the samples').
        let (mut known, mut clean) = (self.cost_known, true);
        self.process_with(events, left, right, |ahead| {
            let now = Instant::now();
            if ahead.done > 0 && clean {
                per_sample = now.duration_since(mark).as_secs_f64() / ahead.done as f64;
                known = true;
            }
            mark = now;
            let left = deadline.saturating_duration_since(now).as_secs_f64();
            clean = !ahead.after_events;
            known &= clean;
            // Behind an even pace, it is kept whatever the budget.
            let even = ahead.even.min(MOST);
            if !known {
                // What the events started is not known yet: a short slice to learn it.
                return if left > 0.0 { GRAIN.max(even).min(ahead.may) } else { even };
            }
            let afford = if per_sample > 0.0 { left / per_sample } else { f64::INFINITY };
            // Behind, at most a few grains at once: what a stretch costs can
            // rise with no event to say so (a damper's fall reaching its
            // strings), and a misjudged slice adds to what is owed.
            let may = if ahead.caught_up && afford >= ahead.may as f64 { ahead.may } else { ahead.may.min(MOST) };
            let len = if afford >= may as f64 { may } else { (afford as usize) / GRAIN * GRAIN };
            len.max(even)
        });
        (self.per_sample_s, self.cost_known) = (per_sample, known);
    }

    /// [`Self::process`], asking `ahead` before each slice rendered beyond
    /// what the host must hear now how many samples it shall be (0 stops).
    /// A slice ends at the next event queued.
    pub fn process_with(
        &mut self,
        events: &[TimedEvent],
        left: &mut [f32],
        right: &mut [f32],
        mut ahead: impl FnMut(Ahead) -> usize,
    ) {
        let n = left.len().min(right.len());
        self.ended.clear();
        self.restruck.clear();
        self.block = (self.now, n);
        if let Some(latency) = self.next_latency.take() {
            self.render_to(self.now);
            self.left.fill(0.0);
            self.right.fill(0.0);
            self.latency = latency;
        }
        if n == 0 {
            // No samples: the events still happen, here.
            for e in events {
                self.enqueue(self.now, e.event);
            }
        }
        // A host block longer than the ring holds beside the latency goes in pieces.
        let piece = RING - MAX_PACED_LATENCY;
        let mut next = 0;
        let mut from = 0;
        while from < n {
            let to = (from + piece).min(n);
            let start = self.now;
            // This piece's events, at their absolute samples.
            while next < events.len() && ((events[next].time as usize) < to || to == n) {
                let at = start + (events[next].time as usize).clamp(from, n) as u64 - from as u64;
                self.enqueue(at, events[next].event);
                next += 1;
            }
            let end = start + (to - from) as u64;
            // What the host hears in this piece must be rendered; more may be.
            let was = self.rendered;
            self.render_to(end.saturating_sub(self.latency as u64));
            let mut done = (self.rendered - was) as usize;
            let even = self.even_pace(end, to - from);
            let paced_from = self.rendered;
            while self.rendered < end {
                let after_events = self.queue.front().is_some_and(|e| e.0 <= self.rendered);
                let until = self.queue.iter().map(|e| e.0).find(|&at| at > self.rendered).unwrap_or(end).min(end);
                let may = (until - self.rendered) as usize;
                let even = even.saturating_sub((self.rendered - paced_from) as usize);
                let caught_up = self.rendered >= start;
                let len = ahead(Ahead { done, after_events, may, caught_up, even }).min(may);
                if len == 0 {
                    break;
                }
                self.render_to(self.rendered + len as u64);
                done = len;
            }
            self.now = end;
            self.deliver(start, &mut left[from..to], &mut right[from..to]);
            from = to;
        }
    }

    /// The samples to render by the end of a block ending at `end`, `n`
    /// long, to keep an even pace (the host's blocks staying that long).
    fn even_pace(&self, end: u64, n: usize) -> usize {
        let n = n.max(1) as u64;
        let mut most = 0;
        let mut k = 1;
        loop {
            // What the host hears within k more blocks, shared over k + 1.
            let due = (end + k * n).saturating_sub(self.latency as u64).min(end);
            most = most.max(due.saturating_sub(self.rendered).div_ceil(k + 1));
            if due == end {
                return most as usize;
            }
            k += 1;
        }
    }

    /// Copy the samples heard from `start` into the host's buffers.
    fn deliver(&self, start: u64, left: &mut [f32], right: &mut [f32]) {
        let latency = self.latency as u64;
        for (i, (l, r)) in left.iter_mut().zip(right.iter_mut()).enumerate() {
            let heard = start + i as u64;
            if heard < latency {
                (*l, *r) = (0.0, 0.0);
            } else {
                let at = (heard - latency) as usize % RING;
                (*l, *r) = (self.left[at], self.right[at]);
            }
        }
    }

    /// Queue `event` for sample `at` (not before any queued). A full queue
    /// first renders up to it, whatever the budget.
    fn enqueue(&mut self, at: u64, event: Event) {
        if self.queue.len() == self.queue.capacity() {
            self.render_to(at.max(self.rendered));
            if self.queue.len() == self.queue.capacity() {
                self.apply_due();
            }
        }
        self.queue.push_back((at, event));
    }

    /// Apply the events queued at the sample the synth has reached, with
    /// nothing rendered (a queue full of events on one sample).
    fn apply_due(&mut self) {
        self.slice_events.clear();
        while let Some(&(at, event)) = self.queue.front() {
            if at > self.rendered {
                break;
            }
            self.queue.pop_front();
            self.slice_events.push(TimedEvent::new(0, event));
        }
        self.synth.process(&self.slice_events, &mut [], &mut []);
        self.note_ended(self.rendered);
    }

    /// Render up to (not including) sample `to`, in stretches that stay in
    /// one turn of the ring.
    fn render_to(&mut self, to: u64) {
        while self.rendered < to {
            let from = self.rendered;
            let at = from as usize % RING;
            let len = ((to - from) as usize).min(RING - at);
            self.slice_events.clear();
            while let Some(&(time, event)) = self.queue.front() {
                if time >= from + len as u64 {
                    break;
                }
                self.queue.pop_front();
                self.slice_events.push(TimedEvent::new((time.max(from) - from) as u32, event));
            }
            let (left, right) = (&mut self.left[at..at + len], &mut self.right[at..at + len]);
            self.synth.process(&self.slice_events, left, right);
            self.note_ended(from);
            self.rendered = from + len as u64;
            if self.synth.is_sounding() {
                self.sounded_until = self.rendered;
            }
        }
    }

    /// Keep the keys the synth reported fallen silent in a stretch rendered from
    /// `from`, at the sample of this block the host hears it.
    fn note_ended(&mut self, from: u64) {
        let (start, n) = self.block;
        let last = n.saturating_sub(1) as u64;
        for e in self.synth.ended_keys() {
            if self.ended.len() == self.ended.capacity() {
                break;
            }
            let fell = from + u64::from(e.time);
            let heard = fell + self.latency as u64;
            self.ended.push(KeyEnded { time: heard.saturating_sub(start).min(last) as u32, key: e.key });
            // Struck again later in the same stretch, or still to come.
            let in_stretch = self.slice_events.iter().map(|t| (from + u64::from(t.time), t.event));
            let mut events = in_stretch.chain(self.queue.iter().copied());
            let key = e.key;
            self.restruck
                .push(events.any(|(at, e)| at >= fell && matches!(e, Event::NoteOn { key: k, .. } if k == key)));
        }
    }
}
