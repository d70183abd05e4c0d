//! A key as the other strings on the body meet it: its partials' sums and
//! the drive the bridge's motion gives them (sympathetic resonance).

use super::{CULL_FLOOR, Complex64, DRIVEN_BLOCKS, Key, PerformanceState, StruckString, WAKE_OVER_SILENCE};

impl Key {
    /// For each of `ports` (strings, partial), the summed phasor of
    /// `partial` over `strings` (bit i: string i), N, into the same place of
    /// `out` (read from the gathering while its strings run there), taken
    /// string by string. `first` says that the ports are partials 0, 1, 2 ...
    /// of the same strings, as a key's are unless its strings sound apart:
    /// each string's modes are then read as one run (the same sums).
    #[inline]
    pub(crate) fn partial_sums(&self, ports: &[(u8, u16)], first: bool, out: &mut [Complex64]) {
        out.fill(Complex64::new(0.0, 0.0));
        if first && let Some(&(strings, _)) = ports.first() {
            for (i, s) in self.strings.iter().enumerate().filter(|&(i, _)| strings & (1 << i) != 0) {
                let sums = &mut out[..s.bank().running().min(ports.len())];
                match self.gathered_at(i) {
                    Some(at) => self.run.gather.add_phasors(at, s.audio().backs(), sums),
                    None => s.bank().add_phasors(sums),
                }
            }
            return;
        }
        for (i, s) in self.strings.iter().enumerate() {
            let (bit, running) = (1u8 << i, s.bank().running());
            let at = self.gathered_at(i);
            for (sum, &(strings, partial)) in out.iter_mut().zip(ports) {
                let partial = partial as usize;
                if strings & bit != 0 && partial < running {
                    *sum += match at {
                        Some(at) => {
                            let (back_re, _, back_inv) = s.audio().back(partial);
                            self.run.gather.phasor(at + partial, back_re, back_inv)
                        }
                        None => s.bank().phasor(partial),
                    };
                }
            }
        }
    }

    /// Where string `i`'s modes lie in the gathering while they run there.
    #[inline]
    pub(super) fn gathered_at(&self, i: usize) -> Option<usize> {
        match self.run.gathered.get(i) {
            Some(&Some(at)) if self.run.live && at != usize::MAX => Some(at),
            _ => None,
        }
    }

    /// The bridge's motion moves partial `partial` of each of `strings` by
    /// `delta` (N): a silent key whose damper would lie on its strings with
    /// the sustain pedal where `performance` has it takes nothing, nor one that would be silent at
    /// once (a drive under [`WAKE_OVER_SILENCE`] times `silence` of full
    /// scale); one that takes it starts to sound, its damper where the pedal has it and
    /// its pitch bent as `performance` bends it, and stays sounding while it is driven that hard.
    /// Returns whether it took it. Allocates: no.
    pub fn drive_partial(
        &mut self,
        strings: u8,
        partial: usize,
        delta: Complex64,
        performance: &PerformanceState,
        silence: f64,
    ) -> bool {
        // A partial running in the gathering is moved there; one it does not
        // hold (culled, or past a string's running modes) needs them back.
        let held = |i: usize, s: &StruckString| {
            strings & (1 << i) == 0 || partial >= s.bank().len() || partial < s.bank().running()
        };
        if self.run.live && !self.strings.iter().enumerate().all(|(i, s)| held(i, s)) {
            self.settle();
        }
        let floor_n = CULL_FLOOR * silence / self.gain_per_n.max(1e-300);
        let felt = self.would_wake(delta, silence);
        if !self.active {
            if self.damper.target(false, performance.sustain) >= 1.0 || !felt {
                return false;
            }
            self.wake(performance);
        }
        // (The phantom products follow at their next refresh: a trade moves
        // a partial by a little.) Only a drive that would wake it keeps it
        // sounding: a damped key the undamped treble moves faintly, and keys
        // that faintly move each other, still fall silent.
        if felt {
            self.driven = DRIVEN_BLOCKS;
        }
        // The last culling's bound still bounds the strings once it holds
        // the drive too (no rescan needed).
        self.cull.last.0 += (delta.re.abs() + delta.im.abs()) * f64::from(strings.count_ones());
        for i in 0..self.strings.len() {
            if strings & (1 << i) == 0 || partial >= self.strings[i].bank().len() {
                continue;
            }
            if let Some(at) = self.gathered_at(i) {
                let (back_re, back_im, _) = self.strings[i].audio().back(partial);
                self.run.gather.nudge(at + partial, delta, back_re, back_im);
                continue;
            }
            let s = &mut self.strings[i];
            let z = if partial < s.bank().running() { s.bank().phasor(partial) + delta } else { delta };
            if partial < s.bank().running() || z.re.abs() + z.im.abs() >= floor_n {
                s.bank_mut().set_phasor(partial, z);
            }
        }
        true
    }

    /// Whether moving a partial of its strings by `delta` (N) would wake it
    /// silent (more than [`WAKE_OVER_SILENCE`] times `silence`, full scale).
    pub fn would_wake(&self, delta: Complex64, silence: f64) -> bool {
        wakes(delta * self.gain_per_n, silence)
    }
}

/// Whether moving a silent key's partial by `delta` (full scale: at its
/// output gain) wakes it: more than [`WAKE_OVER_SILENCE`] times `silence`.
pub(crate) fn wakes(delta: Complex64, silence: f64) -> bool {
    delta.re.abs() + delta.im.abs() >= WAKE_OVER_SILENCE * silence
}

/// A partial of a group of a key's strings tuned alike, as the other strings
/// on the body meet it: its strings, its frequency and pole, and how the
/// board moves it ([`BoardLoad::reach`], its own loss into the board).
#[derive(Clone, Copy, Debug)]
pub(crate) struct Port {
    /// The strings (bit i: string i) that sound it together.
    pub strings: u8,
    pub partial: usize,
    pub f_hz: f64,
    /// Its pole, s^-1 (decay and angular frequency).
    pub lambda: Complex64,
    /// c_n: its phasor moves by -c_n Y F per second for a bridge point moving at Y F, s^-1 / (s/kg).
    pub reach: f64,
    /// What it loses into the board by itself, s^-1 (Re eps_n).
    pub loss_s: f64,
}
