//! Phantom partials: a string stretches as it swings, and its tension rises
//! with the square of its slope, so its end pulls on the bridge along the
//! string at sums of its partials' frequencies (Conklin 1999; Bank & Sujbert
//! 2005), growing as the square of the amplitude: the metallic edge of a
//! piano's bass at forte.
//!
//! At the bridge end the stretch adds (EA/2) y_x(0)^2 to the tension, and the
//! slope is y_x(0) = sum_n r_n Re z_n, with z_n mode n's bridge-force phasor
//! (the force is w_n q_n, w_n = T k_n + EI k_n^3) and r_n = k_n / w_n. The
//! sum-frequency part of the square is
//!
//!   F_L = Re sum_{n <= m} g_nm (EA/2) r_n r_m z_n z_m,  g_nm = 1 (n < m), 1/2 (n = m):
//!
//! each product z_n z_m is itself a free mode, turning by the product of the
//! two poles (frequency f_n + f_m, decay sigma_n + sigma_m). So the phantoms
//! run like the strings' own modes: each control block every product is set
//! from the strings' phasors, and turns by its pole until the next. Each
//! string stretches on its own: a unison's products are summed string by
//! string.
//!
//! The string's longitudinal modes shape the pull: the bridge end of a
//! fixed-fixed wire under a stretch spread along it answers quasi-statically
//! below its first longitudinal mode and with peaks at the odd modes,
//! H(w) = sum_{k odd} (8 / (k pi)^2) / (1 - (w / w_k)^2 + i w / (Q_L w_k))
//! (H(0) = 1): Bank & Sujbert's "formant-like peaks at the longitudinal modal
//! frequencies". The first, f_L = c_L / (2 L) with c_L^2 = E A_core / mu, is
//! 2500/L Hz for plain steel (Conklin, JASA 99, 1996).
//!
//! The bridge turns a part of that pull along the string into a push on the
//! board ([`LONGITUDINAL_TO_BOARD`]); the rest of the pull is taken by the
//! bridge's stiffness in the board's plane. Moore et al. (2015-2018) measured
//! phantoms from the wood as well, often louder: a level above 1 stands for
//! those.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::f64::consts::PI;

use num_complex::Complex64;

use crate::modal_bank::{FreeGather, LANES, Poles, free_block, inverse};
use crate::string::StringModes;
use crate::struck_string::StruckString;

/// Young's modulus of the steel core that carries a string's stretch, Pa.
const STEEL_MODULUS_PA: f64 = 2.0e11;

/// The share of the string's pull along itself that reaches the board as a
/// push across it: the string's angle over the bridge, its downbearing of 1
/// to 2 degrees (sin 1.4 degrees). The bridge's rocking on its foot may pass
/// more; the level control reaches that.
pub const LONGITUDINAL_TO_BOARD: f64 = 0.025;

/// The most the products pull on the bridge together, times the string's
/// tension there (and [`LONGITUDINAL_TO_BOARD`]). The products are the first
/// term of the stretch in the slope's square, which holds while the slope is
/// small; a piano's bass at fortissimo pulls up to 3 times its tension with
/// the longitudinal resonances, and a string tuned a hundred times slacker
/// (a scale putting a bass key at 2 Hz), struck or set swinging by the
/// pedal's lift, would pull a million times: its pull is held at this.
const MOST_PULL_OVER_TENSION: f64 = 10.0;

/// Quality factor of the longitudinal modes: our assumption (steel rings
/// long; the bridge end's losses set it).
const LONGITUDINAL_Q: f64 = 50.0;

/// Odd longitudinal modes carried in H(w).
const LONGITUDINAL_MODES: usize = 7;

/// Partials whose products are carried (the lowest; the products of higher
/// ones are weak and die fast).
pub const PARTIALS: usize = 12;

/// Products further under the key's loudest partial than this are left out
/// (-50 dB: well under its partials, and they fall twice as fast).
pub const BELOW_LOUDEST: f64 = 3e-3;

/// The most products a key carries at once: the strongest over the floor.
const MOST_PRODUCTS: usize = 32;

/// Products above this frequency are left out, Hz.
const TOP_HZ: f64 = 6_000.0;

/// The first longitudinal mode of `string`, Hz: its core's stiffness EA (the
/// core carries the bending, EI = E pi d^4 / 64, and the stretch, EA = E pi
/// d^2 / 4, so EA = sqrt(4 pi E EI)) over the whole string's mass.
pub fn first_longitudinal_hz(string: &StringModes) -> f64 {
    let ea = (4.0 * PI * STEEL_MODULUS_PA * string.bending_stiffness_n_m2).sqrt();
    (ea / string.mass_per_length_kg_m).sqrt() / (2.0 * string.length_m)
}

/// The longitudinal answer H at angular frequency `w` of a string whose
/// first longitudinal mode is at `w1`.
fn longitudinal_answer(w: f64, w1: f64) -> Complex64 {
    let share = |j: usize| 8.0 / ((2 * j + 1) as f64 * PI).powi(2);
    // The modes above those carried answer statically.
    let above = 1.0 - (0..LONGITUDINAL_MODES).map(share).sum::<f64>();
    (0..LONGITUDINAL_MODES)
        .map(|j| {
            let x = w / ((2 * j + 1) as f64 * w1);
            Complex64::new(share(j), 0.0) / Complex64::new(1.0 - x * x, x / LONGITUDINAL_Q)
        })
        .sum::<Complex64>()
        + above
}

/// The products a string's stretch makes at its bridge: partials (n, m) and
/// each product's gain onto the board, N per N^2.
#[derive(Clone, Debug, Default)]
pub struct PhantomTable {
    pairs: Vec<(u16, u16, Complex64)>,
}

impl PhantomTable {
    /// The products of `string`'s first [`PARTIALS`] partials below
    /// [`TOP_HZ`] and `nyquist_hz`. Allocates.
    pub fn new(string: &StringModes, nyquist_hz: f64) -> Self {
        let ea = (4.0 * PI * STEEL_MODULUS_PA * string.bending_stiffness_n_m2).sqrt();
        if !(ea > 0.0) {
            return Self::default();
        }
        let w1 = 2.0 * PI * first_longitudinal_hz(string);
        let modes = &string.modes[..string.modes.len().min(PARTIALS)];
        let slope = |m: &crate::string::Mode| {
            let k = m.wavenumber_rad_m;
            1.0 / (string.tension_n + string.bending_stiffness_n_m2 * k * k)
        };
        let top = 2.0 * PI * TOP_HZ.min(nyquist_hz);
        let mut pairs = Vec::new();
        for (n, a) in modes.iter().enumerate() {
            for (m, b) in modes.iter().enumerate().skip(n) {
                let w = a.omega_rad_s + b.omega_rad_s;
                if w > top {
                    break;
                }
                let share = if n == m { 0.25 } else { 0.5 };
                let gain = longitudinal_answer(w, w1) * (share * ea * slope(a) * slope(b) * LONGITUDINAL_TO_BOARD);
                pairs.push((n as u16, m as u16, gain));
            }
        }
        Self { pairs }
    }

    pub fn len(&self) -> usize {
        self.pairs.len()
    }

    pub fn is_empty(&self) -> bool {
        self.pairs.is_empty()
    }
}

/// A key's phantom partials in play: the products set each control block and
/// turning by their poles, packed in groups of [`LANES`] for the modes' own
/// free kernel. Real-time safe once built.
#[derive(Clone)]
pub struct Phantom {
    table: PhantomTable,
    re: Vec<f64>,
    im: Vec<f64>,
    pole_re: Vec<f64>,
    pole_im: Vec<f64>,
    /// Each pole's inverse, for a gathering ([`crate::modal_bank::inverse`]).
    back_re: Vec<f64>,
    back_im: Vec<f64>,
    back_inv: Vec<f64>,
    /// Products in play this block (the arrays are zero past them, to the next group).
    running: usize,
    /// Scratch for choosing the strongest: size, product, phasor.
    found: Vec<(f64, usize, Complex64)>,
}

impl Phantom {
    /// In play for `table`. Allocates.
    pub fn new(table: PhantomTable) -> Self {
        let n = table.len().min(MOST_PRODUCTS).next_multiple_of(LANES);
        let found = vec![(0.0, 0, Complex64::new(0.0, 0.0)); table.len()];
        Self {
            table,
            re: vec![0.0; n],
            im: vec![0.0; n],
            pole_re: vec![0.0; n],
            pole_im: vec![0.0; n],
            back_re: vec![0.0; n],
            back_im: vec![0.0; n],
            back_inv: vec![0.0; n],
            running: 0,
            found,
        }
    }

    /// At a control block: set every product from `strings`' phasors at
    /// `level` (1 = the physics), keeping those over `floor_n`. Returns
    /// whether any is. Allocates: no.
    pub fn start_block(&mut self, strings: &[StruckString], level: f64, floor_n: f64) -> bool {
        let before = self.running;
        self.running = 0;
        let Some(lead) = strings.first() else { return false };
        if level > 0.0 && floor_n.is_finite() {
            // Every product over the floor, then the strongest kept.
            let mut found = 0;
            for (k, &(n, m, gain)) in self.table.pairs.iter().enumerate() {
                let (n, m) = (n as usize, m as usize);
                let mut product = Complex64::new(0.0, 0.0);
                for s in strings {
                    let bank = s.bank();
                    if m < bank.running() {
                        product += bank.phasor(n) * bank.phasor(m);
                    }
                }
                let z = product * gain * level;
                let size = z.re.abs() + z.im.abs();
                if size >= floor_n && found < self.found.len() {
                    self.found[found] = (size, k, z);
                    found += 1;
                }
            }
            let kept = found.min(self.re.len());
            if found > kept && kept > 0 {
                self.found[..found].select_nth_unstable_by(kept - 1, |a, b| b.0.total_cmp(&a.0));
            }
            for (i, &(_, k, z)) in self.found[..kept].iter().enumerate() {
                let (n, m, _) = self.table.pairs[k];
                let pole = lead.pole(n as usize) * lead.pole(m as usize);
                (self.re[i], self.im[i], self.pole_re[i], self.pole_im[i]) = (z.re, z.im, pole.re, pole.im);
                (self.back_re[i], self.back_im[i], self.back_inv[i]) = inverse(pole.re, pole.im);
            }
            self.running = kept;
            // Held where the slope's square no longer describes the string.
            let total: f64 = self.found[..kept].iter().map(|f| f.0).sum();
            let most = MOST_PULL_OVER_TENSION * lead.string().tension_n * LONGITUDINAL_TO_BOARD;
            if total > most {
                let scale = most / total;
                self.re[..kept].iter_mut().chain(&mut self.im[..kept]).for_each(|v| *v *= scale);
            }
        }
        // Clear what the last block left past this one's products.
        let (from, to) = (self.running, before.max(self.running).next_multiple_of(LANES).min(self.re.len()));
        for v in self.arrays() {
            v[from..to].fill(0.0);
        }
        self.running > 0
    }

    /// Add the products' pull to `acc` by lane, sample by sample, turning
    /// them. Allocates: no.
    pub fn accumulate(&mut self, acc: &mut [[f64; LANES]]) {
        let n = self.running.next_multiple_of(LANES).min(self.re.len());
        free_block(&mut self.re[..n], &mut self.im[..n], &self.pole_re[..n], &self.pole_im[..n], acc);
    }

    /// Gather the products in play into `gather` (see
    /// [`crate::modal_bank::FreeGather`]); where they lie, or None without room.
    pub fn gather_free(&self, gather: &mut FreeGather) -> Option<usize> {
        let n = self.running.next_multiple_of(LANES).min(self.re.len());
        let poles = Poles {
            re: &self.pole_re[..n],
            im: &self.pole_im[..n],
            back_re: &self.back_re[..n],
            back_im: &self.back_im[..n],
        };
        gather.take(&self.re[..n], &self.im[..n], poles)
    }

    /// Take back the products' state from `gather` after it has run.
    pub fn scatter_free(&mut self, gather: &FreeGather, at: usize) {
        let n = self.running.next_multiple_of(LANES).min(self.re.len());
        gather.give_back(at, &mut self.re[..n], &mut self.im[..n], &self.back_re[..n], &self.back_inv[..n]);
    }

    /// Every per-product array: the products' state, their poles and the poles' inverses.
    fn arrays(&mut self) -> [&mut Vec<f64>; 7] {
        [
            &mut self.re,
            &mut self.im,
            &mut self.pole_re,
            &mut self.pole_im,
            &mut self.back_re,
            &mut self.back_im,
            &mut self.back_inv,
        ]
    }

    /// Room the products need in a gathering.
    pub fn room(&self) -> usize {
        self.re.len()
    }

    /// Forget the products in play.
    pub fn silence(&mut self) {
        self.running = 0;
        for v in self.arrays() {
            v.fill(0.0);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::design::{InstrumentKind, Voicing, key_design};

    fn piano_string(key: u8) -> StringModes {
        let d = key_design(InstrumentKind::Piano, &Voicing::default(), key, 20_000.0).unwrap();
        d.strings[d.struck.start].build().unwrap()
    }

    #[test]
    fn the_first_longitudinal_mode_lies_12_to_20_times_the_fundamental() {
        // Conklin: "more than ten times" the fundamental, between 3 octaves
        // and a fifth and 4 octaves and a third above it.
        for key in [21u8, 28, 36, 48, 60, 72] {
            let s = piano_string(key);
            let ratio = first_longitudinal_hz(&s) / s.modes[0].frequency_hz();
            println!("piano key {key}: f_L / f_1 = {ratio:.1}");
            assert!((10.0..=22.0).contains(&ratio), "key {key}: {ratio:.1}");
        }
    }

    #[test]
    fn the_longitudinal_answer_is_one_far_below_its_first_mode_and_peaks_on_it() {
        let w1 = 1000.0;
        assert!((longitudinal_answer(1e-3, w1).re - 1.0).abs() < 0.01);
        assert!(longitudinal_answer(w1, w1).norm() > 10.0 * longitudinal_answer(0.5 * w1, w1).norm());
    }

    #[test]
    fn a_product_turns_at_the_sum_of_its_partials_and_grows_as_their_square() {
        let s = piano_string(36);
        let table = PhantomTable::new(&s, 24_000.0);
        assert!(table.len() > 50, "{}", table.len());
        // Every product of the first 16 partials under 6 kHz, each once.
        let expected = (0..PARTIALS)
            .flat_map(|n| (n..PARTIALS).map(move |m| (n, m)))
            .filter(|&(n, m)| s.modes[n].omega_rad_s + s.modes[m].omega_rad_s <= 2.0 * PI * TOP_HZ)
            .count();
        assert_eq!(table.len(), expected);
    }
}
