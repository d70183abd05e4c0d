//! The felt's hysteresis (Stulov 1995) against an independent integration.
//!
//! The target is a string cut down to one mode, struck at its middle: at the
//! strike point a mass m on a spring k (m = mu L / 2, k = m omega^2), with its
//! omitted modes' residual made zero (the mode's static compliance is set above
//! the whole string's). The same hammer and felt are integrated here with RK4 at
//! 10 ns, the felt's memory carried as a state:
//!
//!   dM/dt = (K C^alpha - M) / tau,  F = max(0, K C^alpha - eps M),
//!
//! (M = (K / tau) int C^alpha exp(-(t - s) / tau) ds, so F is Stulov's law), and
//! the work F dC as another, so the loop's area is known to the integrator's
//! accuracy.

use std::f64::consts::PI;

use struck_engine::exciter::ContactObserver;
use struck_engine::exciter::hammer::{ContactLaw, HammerSpec, Hysteresis};
use struck_engine::string::{Mode, StringModes};
use struck_engine::struck_string::StruckString;

const FS: f64 = 48_000.0;
const SUBSTEPS: usize = 32;
/// The target: 50 g at the strike point on a 100 Hz spring.
const TARGET_KG: f64 = 0.05;
const TARGET_HZ: f64 = 100.0;
const HAMMER_KG: f64 = 0.01;
const SPEED_M_S: f64 = 3.0;
const LAW: ContactLaw = ContactLaw { stiffness: 4.5e9, exponent: 2.5 };

fn target() -> StringModes {
    let length_m = 1.0;
    StringModes {
        length_m,
        // Stiff enough that the one mode's compliance exceeds the string's: no residual.
        tension_n: 1.0e6,
        mass_per_length_kg_m: 2.0 * TARGET_KG / length_m,
        bending_stiffness_n_m2: 0.0,
        inharmonicity: 0.0,
        f0_hz: TARGET_HZ,
        modes: vec![Mode { number: 1, wavenumber_rad_m: PI / length_m, omega_rad_s: 2.0 * PI * TARGET_HZ, q: 1e12 }],
    }
}

fn hammer(hysteresis: Option<Hysteresis>) -> HammerSpec {
    HammerSpec { mass_kg: HAMMER_KG, law: LAW, speed_m_s: SPEED_M_S, position: 0.5, hysteresis }
}

/// Every (sub)step the engine reports: (t, C, F).
#[derive(Default)]
struct Trace(Vec<(f64, f64, f64)>);

impl ContactObserver for Trace {
    fn step(&mut self, t_s: f64, compression_m: f64, force_n: f64) {
        self.0.push((t_s, compression_m, force_n));
    }
}

/// What one strike came to.
#[derive(Debug)]
struct Stroke {
    rebound_m_s: f64,
    contact_s: f64,
    peak_n: f64,
    /// Energy hammer and target lost, J.
    lost_j: f64,
    /// The area of the force-compression loop, sum of F dC, J.
    loop_j: f64,
    /// (C, F) over the first contact.
    curve: Vec<(f64, f64)>,
}

/// The first contact's duration and peak, and its (C, F) curve.
fn first_contact(points: &[(f64, f64, f64)]) -> (f64, f64, Vec<(f64, f64)>) {
    let start = points.iter().position(|p| p.2 > 0.0).expect("a contact");
    let end = start + points[start..].iter().position(|p| p.2 <= 0.0).expect("the hammer leaves");
    let peak = points[start..end].iter().map(|p| p.2).fold(0.0, f64::max);
    // Contact begins within the step before the first force and ends within the
    // step before the force is gone: both ends err alike.
    let curve = points[start - 1..=end].iter().map(|p| (p.1, p.2)).collect();
    (points[end].0 - points[start].0, peak, curve)
}

/// The engine's strike, run until the hammer has been gone 2 ms.
fn engine(hysteresis: Option<Hysteresis>) -> (Stroke, Trace) {
    let mut s = StruckString::with_substep_counts(target(), FS, &[SUBSTEPS]);
    s.strike(hammer(hysteresis));
    // At the throw: touching, no force.
    let mut trace = Trace(vec![(0.0, 0.0, 0.0)]);
    for _ in 0..(0.006 * FS) as usize {
        s.tick_observed(&mut trace);
    }
    assert!(!s.in_contact());
    let v = s.hammer().expect("in play").velocity_m_s;
    let kinetic = |v: f64| 0.5 * HAMMER_KG * v * v;
    let lost_j = kinetic(SPEED_M_S) - kinetic(v) - s.string_energy_j() - s.absorbed_by_omitted_modes_j();
    let loop_j = trace.0.windows(2).map(|w| 0.5 * (w[0].2 + w[1].2) * (w[1].1 - w[0].1)).sum();
    let (contact_s, peak_n, curve) = first_contact(&trace.0);
    (Stroke { rebound_m_s: v, contact_s, peak_n, lost_j, loop_j, curve }, trace)
}

/// The same strike integrated independently: RK4 at `dt`, state (x_h, v_h,
/// x_t, v_t, M, W).
fn independent(hysteresis: Option<Hysteresis>, dt: f64) -> Stroke {
    let (eps, tau) = hysteresis.map_or((0.0, 1.0), |h| (h.epsilon, h.tau_s));
    let k_t = TARGET_KG * (2.0 * PI * TARGET_HZ).powi(2);
    let force = |y: &[f64; 6]| -> (f64, f64) {
        let c = y[0] - y[2];
        let elastic = if c > 0.0 { LAW.stiffness * c.powf(LAW.exponent) } else { 0.0 };
        ((elastic - eps * y[4]).max(0.0), elastic)
    };
    let rate = |y: &[f64; 6]| -> [f64; 6] {
        let (f, elastic) = force(y);
        [y[1], -f / HAMMER_KG, y[3], (f - k_t * y[2]) / TARGET_KG, (elastic - y[4]) / tau, f * (y[1] - y[3])]
    };
    let add = |y: &[f64; 6], k: &[f64; 6], s: f64| -> [f64; 6] { std::array::from_fn(|i| y[i] + s * k[i]) };
    let mut y = [0.0, SPEED_M_S, 0.0, 0.0, 0.0, 0.0];
    let mut points = vec![(0.0, 0.0, 0.0)];
    let mut t = 0.0;
    while t < 0.004 {
        let k1 = rate(&y);
        let k2 = rate(&add(&y, &k1, 0.5 * dt));
        let k3 = rate(&add(&y, &k2, 0.5 * dt));
        let k4 = rate(&add(&y, &k3, dt));
        y = std::array::from_fn(|i| y[i] + dt / 6.0 * (k1[i] + 2.0 * k2[i] + 2.0 * k3[i] + k4[i]));
        t += dt;
        points.push((t, y[0] - y[2], force(&y).0));
    }
    let energy = |y: &[f64; 6]| 0.5 * HAMMER_KG * y[1] * y[1] + 0.5 * TARGET_KG * y[3] * y[3] + 0.5 * k_t * y[2] * y[2];
    let lost_j = 0.5 * HAMMER_KG * SPEED_M_S * SPEED_M_S - energy(&y);
    let (contact_s, peak_n, curve) = first_contact(&points);
    Stroke { rebound_m_s: y[1], contact_s, peak_n, lost_j, loop_j: y[5], curve }
}

fn relative(a: f64, b: f64) -> f64 {
    (a - b).abs() / b.abs()
}

/// Stulov's felt: a memory as long as the contact, one of a few sub-steps, a
/// strong one, and the piano's default (`design::common::FELT_HYSTERESIS`).
const FELTS: [Hysteresis; 4] = [
    Hysteresis { epsilon: 0.3, tau_s: 1e-4 },
    Hysteresis { epsilon: 0.2, tau_s: 1e-6 },
    Hysteresis { epsilon: 0.9, tau_s: 1e-5 },
    Hysteresis { epsilon: 0.2, tau_s: 1e-5 },
];

#[test]
fn the_engine_strikes_as_the_independent_integration() {
    for felt in [None].into_iter().chain(FELTS.map(Some)) {
        let (e, _) = engine(felt);
        let r = independent(felt, 1e-8);
        let errors =
            [relative(e.rebound_m_s, r.rebound_m_s), relative(e.contact_s, r.contact_s), relative(e.peak_n, r.peak_n)];
        println!(
            "{felt:?}: rebound {:.6} vs {:.6} m/s, contact {:.3} vs {:.3} us, peak {:.3} vs {:.3} N; errors {:.2e} {:.2e} {:.2e}",
            e.rebound_m_s,
            r.rebound_m_s,
            e.contact_s * 1e6,
            r.contact_s * 1e6,
            e.peak_n,
            r.peak_n,
            errors[0],
            errors[1],
            errors[2]
        );
        assert!(errors[0] < 1e-5, "{felt:?} rebound: {} vs {}", e.rebound_m_s, r.rebound_m_s);
        // The contact's ends are known to a sub-step (0.65 us) in both.
        assert!((e.contact_s - r.contact_s).abs() < 2.0 / (FS * SUBSTEPS as f64), "{felt:?} contact");
        assert!(errors[2] < 1e-4, "{felt:?} peak: {} vs {}", e.peak_n, r.peak_n);
    }
}

#[test]
fn the_energy_lost_is_the_loop_area() {
    let kinetic = 0.5 * HAMMER_KG * SPEED_M_S * SPEED_M_S;
    for felt in FELTS {
        let (e, _) = engine(Some(felt));
        let r = independent(Some(felt), 1e-8);
        println!(
            "{felt:?}: lost {:.6e} J ({:.2} %), loop {:.6e} J (engine); lost {:.6e} J, loop {:.6e} J (independent); \
             loop/lost {:.1e} (engine) {:.1e} (independent), lost {:.1e} engine/independent",
            e.lost_j,
            100.0 * e.lost_j / kinetic,
            e.loop_j,
            r.lost_j,
            r.loop_j,
            relative(e.loop_j, e.lost_j),
            relative(r.loop_j, r.lost_j),
            relative(e.lost_j, r.lost_j)
        );
        assert!(e.lost_j > 1e-3 * kinetic, "{felt:?}: the felt loses energy");
        assert!(relative(e.loop_j, e.lost_j) < 1e-4, "{felt:?} engine: loop {} vs lost {}", e.loop_j, e.lost_j);
        assert!(relative(r.loop_j, r.lost_j) < 1e-6, "{felt:?} independent: loop {} vs lost {}", r.loop_j, r.lost_j);
        assert!(relative(e.lost_j, r.lost_j) < 1e-4, "{felt:?}: lost {} vs {}", e.lost_j, r.lost_j);
    }
    // The elastic felt gives back what it takes.
    let (e, _) = engine(None);
    assert!(e.lost_j.abs() < 1e-9 * kinetic && e.loop_j.abs() < 1e-5 * kinetic, "{e:?}");
}

#[test]
fn no_memory_is_the_elastic_felt_exactly() {
    let (elastic, a) = engine(None);
    let (zero, b) = engine(Some(Hysteresis { epsilon: 0.0, tau_s: 1e-5 }));
    assert_eq!(a.0, b.0);
    assert_eq!(elastic.rebound_m_s, zero.rebound_m_s);
}

#[test]
fn hysteresis_slows_the_rebound_and_opens_a_loop() {
    let (elastic, _) = engine(None);
    for felt in FELTS {
        let (e, _) = engine(Some(felt));
        assert!(e.rebound_m_s < 0.0 && e.rebound_m_s.abs() < elastic.rebound_m_s.abs(), "{felt:?}");
        // Loading (up to the deepest compression) stands above unloading.
        let deepest = e.curve.iter().enumerate().max_by(|a, b| a.1.0.total_cmp(&b.1.0)).expect("a curve").0;
        let (loading, unloading) = e.curve.split_at(deepest);
        let c_max = e.curve[deepest].0;
        for fraction in [0.3, 0.5, 0.7, 0.9] {
            let c = fraction * c_max;
            let up = force_at(loading, c);
            let down = force_at(unloading, c);
            assert!(up > down, "{felt:?} at {fraction} of the deepest: loading {up} N, unloading {down} N");
        }
    }
}

/// The force where a branch of the curve (monotone in C) passes `c`, by linear interpolation.
fn force_at(branch: &[(f64, f64)], c: f64) -> f64 {
    branch
        .windows(2)
        .find(|w| (w[0].0 - c) * (w[1].0 - c) <= 0.0)
        .map(|w| {
            let t = if w[1].0 == w[0].0 { 0.0 } else { (c - w[0].0) / (w[1].0 - w[0].0) };
            w[0].1 + t * (w[1].1 - w[0].1)
        })
        .unwrap_or(0.0)
}
