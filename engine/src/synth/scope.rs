//! The live view: what the audio thread shows the panel, through lock-free queues.
//!
//! Frames (the last struck key's string shape, its hammer and the contact force
//! since the strike) and the output samples travel over `rtrb` ring buffers; the
//! audio thread pushes only when there is room and never waits.

use rtrb::{Consumer, Producer, RingBuffer};

use crate::struck_string::StruckString;

/// Points along the string in a frame.
pub const SHAPE_POINTS: usize = 96;
/// Samples of contact force kept from each strike.
pub const CONTACT_SAMPLES: usize = 1024;
/// Samples between frames (about 40 frames a second at 48 kHz).
pub const FRAME_INTERVAL: usize = 1024;
const FRAME_QUEUE: usize = 4;
const SAMPLE_QUEUE: usize = 16_384;

/// One picture of the last struck key.
#[derive(Clone, Debug)]
pub struct ScopeFrame {
    pub midi_key: u8,
    pub sample_rate_hz: f64,
    /// Speaking length of the first string, m.
    pub length_m: f64,
    /// Its displacement from the bridge (first point) to the far end, m.
    pub shape_m: [f32; SHAPE_POINTS],
    /// The hammer: where along the string (fraction of the length) and its height, m.
    pub hammer: Option<(f32, f32)>,
    /// The string and hammer at the moment of the largest contact force seen since
    /// the strike (the seed's Fig. 2 as it happens), and that force, N (0: none yet).
    pub strike_shape_m: [f32; SHAPE_POINTS],
    pub strike_hammer: Option<(f32, f32)>,
    pub strike_force_n: f32,
    /// Time of that moment after the strike, s.
    pub strike_time_s: f32,
    /// Summed contact force over the key's strings, one value per sample from the strike, N.
    pub contact_n: [f32; CONTACT_SAMPLES],
    /// How many of `contact_n` are filled.
    pub contact_len: usize,
}

impl Default for ScopeFrame {
    fn default() -> Self {
        Self {
            midi_key: 0,
            sample_rate_hz: 48_000.0,
            length_m: 1.0,
            shape_m: [0.0; SHAPE_POINTS],
            hammer: None,
            strike_shape_m: [0.0; SHAPE_POINTS],
            strike_hammer: None,
            strike_force_n: 0.0,
            strike_time_s: 0.0,
            contact_n: [0.0; CONTACT_SAMPLES],
            contact_len: 0,
        }
    }
}

/// The panel's side.
pub struct Scope {
    frames: Consumer<Box<ScopeFrame>>,
    returns: Producer<Box<ScopeFrame>>,
    samples: Consumer<f32>,
    latest: Option<Box<ScopeFrame>>,
}

impl Scope {
    /// The newest frame, if any has arrived (older ones go back to be reused).
    pub fn latest(&mut self) -> Option<&ScopeFrame> {
        while let Ok(frame) = self.frames.pop() {
            if let Some(old) = self.latest.replace(frame) {
                let _ = self.returns.push(old);
            }
        }
        self.latest.as_deref()
    }

    /// Move the output samples that have arrived into `out` (mono), oldest first.
    pub fn drain_samples(&mut self, out: &mut Vec<f32>) {
        let n = self.samples.slots();
        if let Ok(chunk) = self.samples.read_chunk(n) {
            out.extend(chunk);
        }
    }
}

/// The audio thread's side.
pub(super) struct ScopeWriter {
    frames: Producer<Box<ScopeFrame>>,
    returns: Consumer<Box<ScopeFrame>>,
    samples: Producer<f32>,
    /// A frame being filled (taken from the returns).
    frame: Option<Box<ScopeFrame>>,
    key: Option<u8>,
    contact: [f32; CONTACT_SAMPLES],
    contact_len: usize,
    /// Output samples since the last strike (saturating).
    since_strike: usize,
    since_frame: usize,
    strike_shape_m: [f32; SHAPE_POINTS],
    /// The string's modes at the strongest contact so far (the lowest
    /// [`STRIKE_MODES`]) and its end, drawn into `strike_shape_m` at the next
    /// frame: a picture taken at every new peak would cost the strike's
    /// blocks a drawing each.
    strike_modes: Box<[f64; STRIKE_MODES]>,
    strike_mode_count: usize,
    strike_end_m: f64,
    strike_drawn: bool,
    strike_hammer: Option<(f32, f32)>,
    strike_force_n: f32,
    strike_time_s: f32,
}

/// Modes kept for the picture of the string at its strongest contact.
const STRIKE_MODES: usize = 1024;

pub(super) fn channel() -> (ScopeWriter, Scope) {
    let (frames_tx, frames_rx) = RingBuffer::new(FRAME_QUEUE);
    let (mut returns_tx, returns_rx) = RingBuffer::new(FRAME_QUEUE + 2);
    for _ in 0..FRAME_QUEUE + 1 {
        let _ = returns_tx.push(Box::default());
    }
    let (samples_tx, samples_rx) = RingBuffer::new(SAMPLE_QUEUE);
    let writer = ScopeWriter {
        frames: frames_tx,
        returns: returns_rx,
        samples: samples_tx,
        frame: Some(Box::default()),
        key: None,
        contact: [0.0; CONTACT_SAMPLES],
        contact_len: 0,
        since_strike: usize::MAX,
        since_frame: 0,
        strike_shape_m: [0.0; SHAPE_POINTS],
        strike_modes: Box::new([0.0; STRIKE_MODES]),
        strike_mode_count: 0,
        strike_end_m: 0.0,
        strike_drawn: true,
        strike_hammer: None,
        strike_force_n: 0.0,
        strike_time_s: 0.0,
    };
    let reader = Scope { frames: frames_rx, returns: returns_tx, samples: samples_rx, latest: None };
    (writer, reader)
}

impl ScopeWriter {
    /// Whether anyone watches: the panel's side is still there. (An offline
    /// render drops it, and the synth then neither follows a key nor cuts its
    /// blocks finer for a strike.)
    fn watched(&self) -> bool {
        !self.frames.is_abandoned()
    }

    /// The key followed, while anyone watches.
    pub fn key(&self) -> Option<u8> {
        self.key.filter(|_| self.watched())
    }

    /// Whether the contact force of a strike is being recorded.
    pub fn recording(&self) -> bool {
        self.since_strike < CONTACT_SAMPLES && self.watched()
    }

    /// A key was struck: follow it, and record its contact force afresh.
    pub fn struck(&mut self, midi_key: u8) {
        self.key = Some(midi_key);
        self.contact_len = 0;
        self.since_strike = 0;
        self.strike_force_n = 0.0;
        self.strike_hammer = None;
        self.strike_drawn = true;
    }

    /// While the strike is being recorded: keep a picture of the string whenever
    /// its contact force is the largest yet (called after each rendered chunk).
    pub fn during_contact(&mut self, string: &StruckString) {
        if self.contact_len == 0 || self.contact_len >= CONTACT_SAMPLES || !string.in_contact() {
            return;
        }
        let tick = string.current();
        let force = tick.contact_force_n as f32;
        if force > self.strike_force_n {
            self.strike_force_n = force;
            self.strike_time_s = (self.contact_len as f64 / string.sample_rate_hz()) as f32;
            (self.strike_mode_count, self.strike_end_m) = string.displacements(&mut self.strike_modes[..]);
            self.strike_drawn = false;
            self.strike_hammer = string.hammer().map(|h| (h.spec.position as f32, h.position_m as f32));
        }
    }

    /// Room for the contact force of the next `n` samples (zeroed), while recording.
    pub fn contact_slots(&mut self, n: usize) -> Option<&mut [f32]> {
        if self.contact_len >= CONTACT_SAMPLES {
            return None;
        }
        let start = self.contact_len;
        let end = (start + n).min(CONTACT_SAMPLES);
        self.contact_len = start + n;
        if end - start < n {
            // The tail end of the recording: not worth splitting the block for.
            self.contact_len = CONTACT_SAMPLES;
            return None;
        }
        let slots = &mut self.contact[start..end];
        slots.fill(0.0);
        Some(slots)
    }

    /// Once per control block: publish a frame every [`FRAME_INTERVAL`] samples.
    pub fn control(&mut self, midi_key: u8, string: &StruckString) {
        self.since_frame += super::CONTROL_BLOCK;
        if self.since_frame < FRAME_INTERVAL {
            return;
        }
        self.since_frame = 0;
        if self.frame.is_none() {
            self.frame = self.returns.pop().ok();
        }
        let Some(frame) = self.frame.as_mut() else { return };
        frame.midi_key = midi_key;
        frame.sample_rate_hz = string.sample_rate_hz();
        frame.length_m = string.string().length_m;
        string.shape_m(&mut frame.shape_m);
        if !self.strike_drawn {
            string.shape_of(&self.strike_modes[..self.strike_mode_count], self.strike_end_m, &mut self.strike_shape_m);
            self.strike_drawn = true;
        }
        frame.hammer = string.hammer().map(|h| (h.spec.position as f32, h.position_m as f32));
        let len = self.contact_len.min(CONTACT_SAMPLES);
        frame.contact_n[..len].copy_from_slice(&self.contact[..len]);
        frame.contact_len = len;
        frame.strike_shape_m = self.strike_shape_m;
        frame.strike_hammer = self.strike_hammer;
        frame.strike_force_n = self.strike_force_n;
        frame.strike_time_s = self.strike_time_s;
        if let Some(frame) = self.frame.take()
            && let Err(rtrb::PushError::Full(frame)) = self.frames.push(frame)
        {
            self.frame = Some(frame);
        }
    }

    /// Output samples (mono) for the spectrum, handed over together (those
    /// there is no room for are dropped: the panel is not reading).
    pub fn samples(&mut self, values: &[f32]) {
        self.since_strike = self.since_strike.saturating_add(values.len());
        let n = values.len().min(self.samples.slots());
        if let Ok(chunk) = self.samples.write_chunk_uninit(n) {
            chunk.fill_from_iter(values.iter().copied());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// With nobody watching (the panel's side dropped, as an offline render
    /// does), the writer follows no key and records no strike: the synth then
    /// neither brings the key's strings back from their gathering every block
    /// nor cuts its blocks finer.
    #[test]
    fn nobody_watching_follows_no_key() {
        let (mut writer, reader) = channel();
        writer.struck(60);
        assert_eq!(writer.key(), Some(60));
        assert!(writer.recording());
        drop(reader);
        assert_eq!(writer.key(), None);
        assert!(!writer.recording());
        writer.struck(62);
        assert_eq!(writer.key(), None);
    }
}
