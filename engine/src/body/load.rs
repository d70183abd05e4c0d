//! The body's load on the strings: each partial of a string loses energy into
//! the board, and is pulled in pitch by it, through the board's drive-point
//! admittance Y(f) at the string's own bridge point (Gough 1981; Euphonics 7.2).
//!
//! A string ending on a bridge of admittance Y has the complex frequency of
//! its mode n moved by eps_n = w_n^2 Y(f_n) / (2 m_n omega_n^2) (w_n the mode's
//! bridge weight, m_n its modal mass; T Y / L for a flexible string): Re eps_n
//! adds to the mode's decay rate, Im eps_n lowers its angular frequency (a
//! spring-like board, Im Y > 0, flattens it; a mass-like one sharpens it).
//! The partial's loss therefore follows the board's resonances: a partial on a
//! resonance dies fast, one between two rings on.
//!
//! The level is the design's: each instrument's strings were given the decay
//! of a resistive bridge of sourced Re Y (`design`), and the body's admittance
//! is scaled, frequency by frequency, so that its smooth (Skudrzyk) mean at
//! the bridge equals that value. The board model's own mean (1.2e-3 s/kg for
//! the piano, within Wogram's and Conklin's measurements) would halve the
//! piano's sustain, which Weinreich's decay rates do not support: a bridge
//! moves less than the bare board under it. And the model's mean rises above
//! the ribs' guiding frequency as a resistance, where Wogram measured the
//! board's impedance there as nearly a pure stiffness (phase near -90
//! degrees): taken as loss, the rise would cut the top octave's sustain to a
//! quarter. What the body brings the strings is the admittance's shape about
//! its mean: its resonances and its reactance.
//!
//! The board's irregularity blends the modal admittance with the smooth mean
//! (real, as an infinite plate's): a technician's answer to notes that fall on
//! a strong resonance and die ("dead notes"). It shapes the strings' load only;
//! the radiated sound keeps every resonance.
//!
//! A tuner tunes the string as it sits on the board: the first partial is put
//! back where the design tuned it, so what moves is every other partial
//! against it.

#![cfg_attr(not(test), deny(clippy::unwrap_used, clippy::expect_used, clippy::panic))]

use std::f64::consts::PI;

use super::boards::BodyDesign;
use super::plate::{self, BodyMode};
use num_complex::Complex64;

use crate::design::ResistiveBridge;
use crate::string::StringModes;

/// Modes carried one by one in the admittance, at most up to this frequency,
/// Hz (above it, or above a ribbed board's guiding frequency, the continuum).
const EXPLICIT_TOP_HZ: f64 = 10_000.0;

/// The continuum's admittance is read from a table log-spaced by this ratio
/// (0.5 %, a quarter of the board's resonance bandwidth at 2 % loss).
const TABLE_STEP: f64 = 0.005;
const TABLE_FROM_HZ: f64 = 10.0;
const TABLE_TO_HZ: f64 = 30_000.0;

/// A board's admittance at every key's bridge point, ready to load strings.
pub struct BoardLoad<'a> {
    board: &'a BodyDesign,
    modes: Vec<BodyMode>,
    /// ln of the continuum table's first frequency, and the table (re, im) s/kg.
    residual: Vec<(f64, f64)>,
    /// 0: the smooth mean only, 1: every resonance.
    irregularity: f64,
    /// The bending wave along the bridges on the continuum table's
    /// frequencies (none for separate bridges, or where the board overwhelms it).
    waves: Vec<Option<plate::BeamWave>>,
}

/// What a board's admittance is worked out from: its modes carried one by
/// one, and the continuum's table above them (see [`BoardLoad`]). It depends on
/// the board's design only (not on the sample rate, nor on the irregularity).
#[derive(Clone)]
struct Admittance {
    modes: Vec<BodyMode>,
    residual: Vec<(f64, f64)>,
    waves: Vec<Option<plate::BeamWave>>,
}

/// One frequency's entry in a board's admittance table: the residual mobility,
/// and the bridges' bending wave (none: the board has no continuous bridge).
type TableEntry = ((f64, f64), Option<Option<plate::BeamWave>>);

/// How many boards' [`Admittance`]s are kept (a few sizes of each body).
const KEPT_BOARDS: usize = 8;

/// `board`'s [`Admittance`]: worked out once per design and kept (the last
/// [`KEPT_BOARDS`] designs), as building an instrument at each of a host's
/// sample rates, or again, asks for the same board's (tens to hundreds of
/// milliseconds each). Off the audio thread, where instruments are built.
fn admittance(board: &BodyDesign) -> Admittance {
    // Every field of the design by its exact value (the shortest decimal
    // that reads back to the same bits).
    let key = format!("{board:?}");
    let kept = kept_boards();
    // (A thread that panicked holding the lock left the list whole.)
    if let Some((_, found)) = kept.lock().unwrap_or_else(|e| e.into_inner()).iter().find(|(k, _)| *k == key) {
        return found.clone();
    }
    let top = board.plate.inter_rib_hz().unwrap_or(EXPLICIT_TOP_HZ).min(EXPLICIT_TOP_HZ);
    let modes = board.modes(top);
    let points = ((TABLE_TO_HZ / TABLE_FROM_HZ).ln() / TABLE_STEP).ceil() as usize + 1;
    let frequency = |i: usize| TABLE_FROM_HZ * (i as f64 * TABLE_STEP).exp();
    // Each frequency's entries on their own: the table is shared out over
    // the cores in stretches of frequencies.
    let beam = board.bridge_beam();
    let entry = |i: usize| {
        let residual = plate::residual_mobility(&board.plate, top, frequency(i));
        let wave = beam.map(|(ei, rho_a)| plate::beam_wave(&board.plate, ei, rho_a, frequency(i)));
        (residual, wave)
    };
    let entries: Vec<TableEntry> = crate::cores::in_stretches(points, &|i, out| out.push(entry(i)));
    let residual = entries.iter().map(|e| e.0).collect();
    let waves = if beam.is_some() { entries.iter().map(|e| e.1.flatten()).collect() } else { Vec::new() };
    let admittance = Admittance { modes, residual, waves };
    let mut kept = kept.lock().unwrap_or_else(|e| e.into_inner());
    if !kept.iter().any(|(k, _)| *k == key) {
        if kept.len() >= KEPT_BOARDS {
            kept.remove(0);
        }
        kept.push((key, admittance.clone()));
    }
    admittance
}

type KeptBoards = std::sync::Mutex<Vec<(String, Admittance)>>;

fn kept_boards() -> &'static KeptBoards {
    static KEPT: std::sync::OnceLock<KeptBoards> = std::sync::OnceLock::new();
    KEPT.get_or_init(Default::default)
}

/// Forget every board's admittance kept (for measuring a first build).
pub(crate) fn forget_boards() {
    let dropped = std::mem::take(&mut *kept_boards().lock().unwrap_or_else(|e| e.into_inner()));
    drop(dropped);
}

impl<'a> BoardLoad<'a> {
    /// The admittance of `board`, its resonances weighted by `irregularity`
    /// (0..=1). Allocates; off the audio thread (a few milliseconds).
    pub fn new(board: &'a BodyDesign, irregularity: f64) -> Self {
        let Admittance { modes, residual, waves } = admittance(board);
        Self { board, modes, residual, irregularity: irregularity.clamp(0.0, 1.0), waves }
    }

    /// The bridges' bending wave at `f_hz`, between the table's nearest
    /// frequencies (none where either has none).
    fn wave(&self, f_hz: f64) -> Option<plate::BeamWave> {
        let x = ((f_hz / TABLE_FROM_HZ).ln() / TABLE_STEP).clamp(0.0, self.waves.len().saturating_sub(1) as f64);
        let i = (x.floor() as usize).min(self.waves.len().saturating_sub(2));
        match (self.waves.get(i)?, self.waves.get(i + 1)) {
            (Some(a), Some(Some(b))) => Some(a.towards(b, x - i as f64)),
            (Some(a), None) => Some(*a),
            _ => None,
        }
    }

    /// The smooth (Skudrzyk) mean mobility at `f_hz`, s/kg: real, as an
    /// infinite plate's.
    fn smooth(&self, f_hz: f64) -> f64 {
        plate::skeleton_mobility(&self.board.plate, f_hz)
    }

    /// The continuum above the explicit modes at `f_hz`, (re, im) s/kg.
    fn residual(&self, f_hz: f64) -> (f64, f64) {
        let x = ((f_hz / TABLE_FROM_HZ).ln() / TABLE_STEP).clamp(0.0, (self.residual.len() - 1) as f64);
        let i = (x.floor() as usize).min(self.residual.len().saturating_sub(2));
        let t = x - i as f64;
        match (self.residual.get(i), self.residual.get(i + 1)) {
            (Some(a), Some(b)) => (a.0 + (b.0 - a.0) * t, a.1 + (b.1 - a.1) * t),
            (Some(a), None) => *a,
            _ => (0.0, 0.0),
        }
    }

    /// The admittance at `midi_key`'s bridge point at `f_hz`, (re, im) s/kg,
    /// resonances weighted by the irregularity.
    pub fn admittance(&self, midi_key: u8, f_hz: f64) -> (f64, f64) {
        self.admittance_at(&self.weights(midi_key), f_hz)
    }

    /// Each mode's phi^2 / m at `midi_key`'s bridge point, kg^-1.
    fn weights(&self, midi_key: u8) -> Vec<f64> {
        let (x, y) = self.board.bridge_point(midi_key);
        self.modes.iter().map(|mode| plate::shape_at(mode, x, y).powi(2) / mode.modal_mass_kg).collect()
    }

    /// [`Self::admittance`] with the modes' weights at the point ([`Self::weights`]).
    fn admittance_at(&self, weights: &[f64], f_hz: f64) -> (f64, f64) {
        let w = 2.0 * PI * f_hz;
        let (mut re, mut im) = self.residual(f_hz);
        for (mode, &weight) in self.modes.iter().zip(weights) {
            let (r, i) = plate::modal_term(weight, 2.0 * PI * mode.frequency_hz, mode.loss_factor, w);
            re += r;
            im += i;
        }
        let k = self.irregularity;
        (k * re + (1.0 - k) * self.smooth(f_hz), k * im)
    }

    /// Load `string` (`midi_key`'s, set up with the losses of `resistive`):
    /// every mode's bridge loss becomes the board's, scaled so the board's
    /// smooth mean is the resistive bridge's Re Y, and its frequency moves
    /// by the reactance; then the first partial is tuned back.
    pub fn load(&self, midi_key: u8, resistive: ResistiveBridge, unison: usize, string: &mut StringModes) {
        if !(resistive.admittance_s_kg > 0.0) {
            return;
        }
        let eps = self.coupling(midi_key, resistive, string);
        let z0 = string.impedance_ns_m();
        let first = string.modes.first().map(|m| m.omega_rad_s);
        for (mode, eps) in string.modes.iter_mut().zip(&eps) {
            let omega = mode.omega_rad_s;
            let resistive_rate = z0 * resistive.admittance_s_kg * omega / (mode.number as f64 * PI);
            let sigma = mode.decay_rate_s() + eps.re - resistive.loss_scale * resistive_rate;
            mode.omega_rad_s = omega - eps.im;
            mode.q = if sigma > 0.0 { mode.omega_rad_s / (2.0 * sigma) } else { f64::INFINITY };
        }
        // The tuner hears the unison's strings swing together, the first
        // partial pulled by all of them at once.
        let pull = eps.first().map_or(0.0, |e| e.im * (unison.max(1) - 1) as f64);
        if let (Some(before), Some(after)) = (first, string.modes.first().map(|m| m.omega_rad_s - pull))
            && after > 0.0
        {
            let ratio = before / after;
            string.modes.iter_mut().for_each(|m| m.omega_rad_s *= ratio);
        }
    }
}

impl BoardLoad<'_> {
    /// How the board pulls each mode of `string` (`midi_key`'s, set up with
    /// `resistive`'s losses) through its bridge point: the complex shift
    /// eps_n = w_n^2 Y(f_n) / (2 m_n omega_n^2) of its pole (decay rate
    /// Re eps, angular frequency -Im eps), Y scaled as [`Self::load`] says and
    /// its real part by the voicing's damping. The strings of a unison share
    /// it: each loses eps_n on its own, and their sum pulls all of them.
    pub fn coupling(&self, midi_key: u8, resistive: ResistiveBridge, string: &StringModes) -> Vec<Complex64> {
        let weights = self.weights(midi_key);
        string
            .modes
            .iter()
            .zip(self.reach(resistive, string))
            .map(|(mode, reach)| {
                let (re, im) = self.admittance_at(&weights, mode.omega_rad_s / (2.0 * PI));
                Complex64::new(resistive.loss_scale * reach * re, reach * im)
            })
            .collect()
    }

    /// How far each mode of `string` moves per unit of bridge admittance:
    /// c_n = w_n^2 / (2 m_n omega_n^2) with m_n = mu L / 2, times the scale
    /// that puts the board's smooth mean at `resistive`'s Re Y ([`Self::load`]),
    /// s^-1 per s/kg. A bridge point moving at Y times a force F moves the
    /// mode's force phasor by -c_n Y F per second.
    pub fn reach(&self, resistive: ResistiveBridge, string: &StringModes) -> Vec<f64> {
        let (mu, length) = (string.mass_per_length_kg_m, string.length_m);
        let (tension, bending) = (string.tension_n, string.bending_stiffness_n_m2);
        string
            .modes
            .iter()
            .map(|mode| {
                let omega = mode.omega_rad_s;
                let k = mode.wavenumber_rad_m;
                let weight = tension * k + bending * k * k * k;
                let mean = self.smooth(omega / (2.0 * PI));
                let scale = if mean > 0.0 { resistive.admittance_s_kg / mean } else { 0.0 };
                weight * weight / (mu * length * omega * omega) * scale
            })
            .collect()
    }

    /// Each mode's shape at `midi_key`'s bridge point over the root of its
    /// modal mass, kg^-1/2: what [`Self::transfer`] needs of a point.
    pub fn shapes(&self, midi_key: u8) -> Vec<f64> {
        let (x, y) = self.board.bridge_point(midi_key);
        self.modes.iter().map(|mode| plate::shape_at(mode, x, y) / mode.modal_mass_kg.sqrt()).collect()
    }

    /// The transfer admittance between two keys' bridge points at `f_hz`
    /// (velocity at one per force at the other), s/kg, from the points'
    /// [`Self::shapes`]. Where the board's modes are carried one by one, their
    /// sum: the resonances within an octave either side, weighted by the
    /// irregularity (the modes far off add with random signs between two
    /// points apart and are left out). Above them, where the ribs guide the
    /// board's waves between them and its modes no longer span it (Boutillon
    /// & Ege), the bridge carries the motion along itself: the board's direct
    /// field ([`Self::direct`]), in the share the continuum takes of the drive
    /// point's mean there.
    pub fn transfer(&self, a: &[f64], b: &[f64], keys: (u8, u8), f_hz: f64) -> Complex64 {
        let w = 2.0 * PI * f_hz;
        let from = self.modes.partition_point(|m| m.frequency_hz < 0.5 * f_hz);
        let to = self.modes.partition_point(|m| m.frequency_hz <= 2.0 * f_hz);
        let mut y = Complex64::new(0.0, 0.0);
        for k in from..to {
            let (mode, (sa, sb)) = (&self.modes[k], (a.get(k), b.get(k)));
            if let (Some(sa), Some(sb)) = (sa, sb) {
                let (re, im) = plate::modal_term(sa * sb, 2.0 * PI * mode.frequency_hz, mode.loss_factor, w);
                y += Complex64::new(re, im);
            }
        }
        y * self.irregularity + self.direct(keys.0, keys.1, f_hz) * self.continuum_share(f_hz)
    }

    /// The continuum's share of the drive point's smooth mean at `f_hz`: none
    /// well below the explicit modes' top, all well above it.
    fn continuum_share(&self, f_hz: f64) -> f64 {
        let mean = self.smooth(f_hz);
        if mean > 0.0 { (self.residual(f_hz).0 / mean).clamp(0.0, 1.0) } else { 0.0 }
    }

    /// The board's direct field between two keys' bridge points at `f_hz`, s/kg:
    /// the smooth mean carried from one to the other. Along one continuous
    /// bridge the bridge carries it, a bending wave held by the board that
    /// sheds itself into it as it goes ([`plate::beam_wave`]): C4's strings
    /// move G6's bridge point, 0.44 m along the piano's, about a third as much
    /// as their own at 1.57 kHz (a test). Between separate bridges the board
    /// carries it ([`plate::across_plate`]).
    pub fn direct(&self, a: u8, b: u8, f_hz: f64) -> Complex64 {
        let mean = self.smooth(f_hz);
        let plate = &self.board.plate;
        let carried = match (self.wave(f_hz), self.board.along_bridge_m(a, b)) {
            (Some(wave), Some(d)) => wave.transfer(d),
            _ => plate::across_plate(plate, self.board.apart_m(a, b), f_hz),
        };
        carried * mean
    }
}

/// How a control block of `step_s` of a unison of `strings` strings trading
/// through their bridge point moves a partial whose pole each string's loss
/// into the body shifts by `eps` ([`BoardLoad::coupling`]): (alpha, beta) for
/// [`trade`]. The strings' mean (their bridge force over N) pulls the bridge
/// and every string with it: with each string's own share already in its
/// pole, what is left is -eps (1 1^T - I), whose exponential over the block
/// is alpha = e^(eps h) on what differs from the mean and beta =
/// e^(-(N - 1) eps h) on the mean.
pub fn unison_step(eps: Complex64, strings: usize, step_s: f64) -> (Complex64, Complex64) {
    ((eps * step_s).exp(), (-eps * step_s * strings.saturating_sub(1) as f64).exp())
}

/// One block of a unison's trading (Weinreich 1977) on the strings' phasors
/// of one partial, `(alpha, beta)` from [`unison_step`]: the mean moves by
/// beta, what differs from it by alpha. Allocates: no.
pub fn trade((alpha, beta): (Complex64, Complex64), phasors: &mut [Complex64]) {
    let n = phasors.len().max(1) as f64;
    let mean = phasors.iter().sum::<Complex64>() / n;
    phasors.iter_mut().for_each(|z| *z = alpha * (*z - mean) + beta * mean);
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::body::boards::design;
    use crate::design::InstrumentKind;
    use crate::string::damping::{Damping, PhysicalLoss};
    use crate::string::{Mass, Stiffness, StringSpec, Tuning};

    /// A piano A4 string whose losses hold a resistive bridge of `admittance_s_kg`.
    fn a4(admittance_s_kg: f64) -> StringModes {
        StringSpec {
            length_m: 0.38,
            tuning: Tuning::FirstPartialHz(440.0),
            mass: Mass::SolidWire { diameter_m: 1.0e-3, density_kg_m3: 7850.0 },
            stiffness: Stiffness::YoungsModulus { modulus_pa: 2.0e11, bending_diameter_m: 1.0e-3 },
            damping: Damping::Physical(PhysicalLoss {
                internal_loss_factor: 3e-4,
                bridge_admittance_s_kg: admittance_s_kg,
            }),
            max_frequency_hz: 10_000.0,
            outer_diameter_m: None,
        }
        .build()
        .unwrap()
    }

    const RESISTIVE: ResistiveBridge = ResistiveBridge { admittance_s_kg: 5e-4, loss_scale: 1.0 };

    /// Each partial's loss into the bridge over the resistive bridge's.
    fn bridge_shares(loaded: &StringModes) -> Vec<f64> {
        let (bare, resistive) = (a4(0.0), a4(RESISTIVE.admittance_s_kg));
        loaded
            .modes
            .iter()
            .zip(bare.modes.iter().zip(&resistive.modes))
            .map(|(l, (b, r))| (l.decay_rate_s() - b.decay_rate_s()) / (r.decay_rate_s() - b.decay_rate_s()))
            .collect()
    }

    #[test]
    fn a_smooth_board_changes_nothing() {
        let board = design(InstrumentKind::Piano);
        let load = BoardLoad::new(&board, 0.0);
        let mut s = a4(RESISTIVE.admittance_s_kg);
        load.load(69, RESISTIVE, 1, &mut s);
        // The smooth mean is the resistive level at every frequency: every
        // partial keeps its decay, but for the stiff string's larger bridge
        // weight (the resistive formula is the flexible string's: a factor
        // sqrt(1 + B n^2)), and its pitch.
        let shares = bridge_shares(&s);
        let b = s.inharmonicity;
        for (n, v) in shares.iter().enumerate().map(|(i, v)| ((i + 1) as f64, v)) {
            assert!((v / (1.0 + b * n * n).sqrt() - 1.0).abs() < 1e-3, "{shares:?}");
        }
        let plain = a4(RESISTIVE.admittance_s_kg);
        assert!(s.modes.iter().zip(&plain.modes).all(|(a, b)| (a.omega_rad_s / b.omega_rad_s - 1.0).abs() < 1e-12));
    }

    #[test]
    fn partials_decay_at_rates_that_follow_the_boards_resonances() {
        let board = design(InstrumentKind::Piano);
        let load = BoardLoad::new(&board, 1.0);
        let mut s = a4(RESISTIVE.admittance_s_kg);
        load.load(69, RESISTIVE, 1, &mut s);
        let shares = bridge_shares(&s);
        let first: Vec<f64> = shares.iter().take(3).copied().collect();
        let (lo, hi) = first.iter().fold((f64::INFINITY, 0.0f64), |(lo, hi), v| (lo.min(*v), hi.max(*v)));
        println!("A4's first partials' bridge loss over the resistive bridge's: {first:?}");
        assert!(hi / lo > 2.0 && lo > 0.0, "{first:?}");
        assert!(s.modes.iter().all(|m| m.q > 0.5 && m.decay_rate_s().is_finite()));
        // Pitch: the first partial stays; the others move by hundredths of a
        // cent to cents.
        assert!((s.modes[0].omega_rad_s / a4(RESISTIVE.admittance_s_kg).modes[0].omega_rad_s - 1.0).abs() < 1e-12);
        let cents: Vec<f64> = s
            .modes
            .iter()
            .zip(&a4(RESISTIVE.admittance_s_kg).modes)
            .take(10)
            .map(|(a, b)| 1200.0 * (a.omega_rad_s / b.omega_rad_s).log2())
            .collect();
        assert!(cents.iter().any(|c| c.abs() > 0.01) && cents.iter().all(|c| c.abs() < 10.0), "{cents:?}");
    }

    /// Two strings of a unison, each turning by its own pole and trading
    /// block by block, against the coupled pair's exact motion (whose
    /// eigenvalues are Weinreich's lambda_mean - eps +- sqrt(eps^2 + delta^2)).
    #[test]
    fn a_traded_pair_follows_the_coupled_eigenvalues() {
        // Eight control blocks of 64 samples at 48 kHz, as the keys trade.
        let h = 512.0 / 48_000.0;
        let eps = Complex64::new(1.1, 0.3);
        for detune_hz in [0.0, 0.05, 0.2, 1.0] {
            let bare = [Complex64::new(-0.3, 2.0 * PI * 262.0), Complex64::new(-0.3, 2.0 * PI * (262.0 + detune_hz))];
            // The free step holds each string's own share of the bridge's pull.
            let own: Vec<Complex64> = bare.iter().map(|l| ((l - eps) * h).exp()).collect();
            let step = unison_step(eps, 2, h);
            let mut z = [Complex64::new(1.0, 0.0), Complex64::new(0.3, 0.2)];
            // The exact solution: a' = (D - eps 1 1^T) a, so a(t) = exp(A t) a(0).
            let a = nalgebra::Matrix2::new(bare[0] - eps, -eps, -eps, bare[1] - eps);
            let start = nalgebra::Vector2::new(z[0], z[1]);
            let blocks = 250;
            for _ in 0..blocks {
                z.iter_mut().zip(&own).for_each(|(z, t)| *z *= t);
                trade(step, &mut z);
            }
            let t = blocks as f64 * h;
            let exact = (a * Complex64::new(t, 0.0)).exp() * start;
            for (a, b) in z.iter().zip(exact.iter()) {
                assert!((a - b).norm() < 2e-3 * (1.0 + b.norm()), "detune {detune_hz} Hz: {a} against {b}");
            }
        }
    }

    #[test]
    fn the_bridge_carries_a_notes_motion_along_itself_to_the_treble() {
        let board = design(InstrumentKind::Piano);
        let load = BoardLoad::new(&board, 0.5);
        let (c4, g6) = (60, 91);
        let mean = load.smooth(1570.0);
        let along = load.direct(c4, g6, 1570.0).norm() / mean;
        let transfer = load.transfer(&load.shapes(c4), &load.shapes(g6), (c4, g6), 1570.0).norm() / mean;
        println!("C4 to G6 at 1.57 kHz, over the drive point's mean: bridge {along:.3}, transfer {transfer:.3}");
        // Most of the way along (0.44 m of a bridge that sheds about 10 dB a
        // metre into the board), and above the ribs' guiding frequency the
        // transfer is the bridge's.
        assert!((0.2..0.8).contains(&along), "{along}");
        assert!((transfer / along - 1.0).abs() < 0.25, "{transfer} against {along}");
        // Nearer keys more, and a key on the bass bridge only through the board.
        assert!(load.direct(c4, 67, 1570.0).norm() / mean > along);
        let across = load.direct(c4, 30, 1570.0).norm() / mean;
        assert!(across < along, "{across}");
        // A santur's separate bridges carry nothing along themselves.
        let santoor = design(InstrumentKind::Santoor);
        assert!(santoor.bridge_beam().is_none());
    }
}
