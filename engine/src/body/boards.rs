//! One body design per instrument: the plate, the box and holes of the boxed
//! instruments, the bridge lines (where each key's strings bear on the board) and
//! two microphone positions.
//!
//! Every board is reduced to an equivalent rectangle (x along the grain, y across)
//! of about the real board's area; the bridge lines are drawn schematically in
//! that rectangle from the key ranges of `the instruments' designs (`crate::design`)` (read-only).
//! Where a number is a measurement its source is given; where none was found it is
//! marked "assumption" with the reasoning.

use std::f64::consts::PI;
use std::ops::RangeInclusive;

use super::plate::{self, BodyMode, Boundary, Plate, Ribs, Wood};
use super::radiation::radiation_loss_factor;
use crate::design::InstrumentKind;
use crate::string::damping::AIR_DENSITY_KG_M3;

/// The most zones a body's bridges are divided into.
pub const MAX_ZONES: usize = 8;

/// Where on the bridges a key's strings bear, as the body sees it: between two
/// zones, with the share of its force each takes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ZoneShare {
    pub zones: [usize; 2],
    pub weights: [f64; 2],
}

/// Modal density a point on a board's bridge sees above the ribs' guiding
/// frequency, /Hz (Boutillon & Ege 2013: 0.01-0.02 /Hz; "about 200 modes"
/// in 0-10 kHz).
pub const APPARENT_DENSITY_PER_HZ: f64 = 0.01;

/// Speed of sound in air at 20 C, m/s.
pub const SOUND_SPEED_M_S: f64 = 343.0;

/// Sitka spruce at 12 % moisture: static E_L 9.05 GPa, E_R 0.817 GPa, nu_LR 0.438
/// and (ultrasonic) G_LR 1.196 GPa, Acta Acustica 2025 (aacus240113), Table 5,
/// after its ref. [22]. Density 420 kg/m^3: soundboard spruce is 400-450 kg/m^3
/// (assumption from the usual Sitka specific gravity of about 0.40).
pub const SPRUCE: Wood =
    Wood { density_kg_m3: 420.0, e_along_pa: 9.05e9, e_across_pa: 0.817e9, shear_pa: 1.196e9, poisson_along: 0.438 };

/// Hard (sugar) maple, the usual wood of a bridge, as recalled from the USDA
/// Wood Handbook (FPL-GTR-190, Table 5-3a: MOE 12.6 GPa, specific gravity
/// 0.63, so about 705 kg/m^3 at 12 % moisture); not re-verified in this session.
/// Along its grain, which runs along the bridge.
pub const MAPLE_E_PA: f64 = 12.6e9;
pub const MAPLE_DENSITY_KG_M3: f64 = 705.0;

/// What a board's bridges are: continuous maple beams of a section that
/// carry the strings' motion along themselves, or a row of separate small
/// bridges, one to a course, joined only by the board (the santur's
/// "chessmen").
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Bridges {
    Continuous { width_m: f64, height_m: f64 },
    Separate,
}

/// Black walnut, as recalled from the USDA Wood Handbook (FPL-GTR-190, Tables 5-1
/// and 5-3: E_L 11.6 GPa, E_R/E_L 0.106, G_LR/E_L 0.085, nu_LR 0.495, specific
/// gravity 0.55); not re-verified in this session. Santoor/santur tops are
/// walnut or similar hardwood.
pub const WALNUT: Wood =
    Wood { density_kg_m3: 610.0, e_along_pa: 11.6e9, e_across_pa: 1.23e9, shear_pa: 0.99e9, poisson_along: 0.495 };

/// Modal loss factor of a soundboard: Ege, Boutillon & Rebillat (JSV 332, 2013;
/// arXiv:1212.2323) measured about 2 % (1-3 %) on an upright's board, "close to
/// those imposed by wood"; used for every instrument (assumption beyond the piano).
pub const BOARD_LOSS_FACTOR: f64 = 0.02;

/// Loss factor of the air in a box's holes: Q = 20 (assumption; guitar-body air
/// modes are commonly quoted with Q of 10-30, radiation and wall losses; a
/// coupled mode adds what its net volume radiates on top).
pub const AIR_LOSS_FACTOR: f64 = 0.05;

/// A Helmholtz resonator formed by the box and its soundholes.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct AirCavity {
    /// Enclosed volume, m^3.
    pub volume_m3: f64,
    /// Number of equal round holes.
    pub holes: u32,
    /// Radius of each hole, m.
    pub hole_radius_m: f64,
    /// Thickness of the top at the holes, m.
    pub wall_m: f64,
}

impl AirCavity {
    /// Total open area, m^2.
    pub fn hole_area_m2(&self) -> f64 {
        f64::from(self.holes) * PI * self.hole_radius_m.powi(2)
    }

    /// Effective neck length of one hole: wall plus two flanged end corrections,
    /// L = t + 2 (0.85 r) (Rayleigh; Kinsler & Frey).
    pub fn neck_length_m(&self) -> f64 {
        self.wall_m + 1.7 * self.hole_radius_m
    }

    /// Helmholtz frequency f = c/(2 pi) sqrt(A/(V L)), Hz (equal holes in
    /// parallel: total area, one hole's neck length).
    pub fn frequency_hz(&self) -> f64 {
        SOUND_SPEED_M_S / (2.0 * PI) * (self.hole_area_m2() / (self.volume_m3 * self.neck_length_m())).sqrt()
    }

    /// The box's lowest pair of modes: the top's (1, 1) mode `top` (the wood's
    /// loss in its loss factor) and the air in the holes,
    /// coupled by the cavity's stiffness (the two-oscillator model of
    /// Christensen & Vistisen, JASA 68, 1980; Fletcher & Rossing, The Physics
    /// of Musical Instruments, 2nd ed., section 9.4).
    ///
    /// The top moves q (its (1, 1) shape's peak, outward), sweeping the volume
    /// S q with S = 4 a b / pi^2; the air plug in the holes (mass rho L A)
    /// moves z outward, sweeping A z. The cavity's pressure is
    /// -(rho c^2 / V) (S q + A z), so the stiffness matrix is
    /// [[K + k S^2, k S A], [k S A, k A^2]] with k = rho c^2 / V, and what
    /// leaves the box is the volume S q + A z. Slowly pushed, the air in the
    /// holes makes way for the top (S q + A z = 0): the box neither stiffens
    /// the top's static give nor radiates a slow push; only the two coupled
    /// resonances ring, each with the net volume of its own shape. (Taken as
    /// two modes of their own, a top and an air mode each driven by the
    /// bridge, the air mode added a static give of 1 / (k S^2) to the top's
    /// 1 / K and rang a boom under every strike.)
    ///
    /// Each coupled mode is returned in the top's (1, 1) shape, with the
    /// modal mass the bridge sees through the top, the losses of its two
    /// parts weighted by their shares of its kinetic energy (the air's
    /// [`AIR_LOSS_FACTOR`]), plus what its net volume radiates, and its net
    /// volume re the top's own.
    pub fn couple(&self, plate: &Plate, top: &BodyMode) -> [BodyMode; 2] {
        let s = 4.0 * plate.area_m2() / (PI * PI);
        let a = self.hole_area_m2();
        let k = AIR_DENSITY_KG_M3 * SOUND_SPEED_M_S * SOUND_SPEED_M_S / self.volume_m3;
        let plug_kg = AIR_DENSITY_KG_M3 * self.neck_length_m() * a;
        let top_kg = top.modal_mass_kg;
        let top_k = top_kg * (2.0 * PI * top.frequency_hz).powi(2);
        // In mass-normalised coordinates the stiffness is symmetric; its
        // eigenvectors (u_top, u_air), of unit length, are the pair's shapes.
        let stiffness = nalgebra::Matrix2::new(
            (top_k + k * s * s) / top_kg,
            k * s * a / (top_kg * plug_kg).sqrt(),
            k * s * a / (top_kg * plug_kg).sqrt(),
            k * a * a / plug_kg,
        );
        let eigen = stiffness.symmetric_eigen();
        let mut pair = [0, 1].map(|i| (eigen.eigenvalues[i], eigen.eigenvectors[(0, i)], eigen.eigenvectors[(1, i)]));
        pair.sort_by(|x, y| x.0.total_cmp(&y.0));
        pair.map(|(w2, u_top, u_air)| {
            let frequency_hz = w2.max(0.0).sqrt() / (2.0 * PI);
            // Top and plug displacements per unit modal coordinate.
            let (q, z) = (u_top / top_kg.sqrt(), u_air / plug_kg.sqrt());
            let mode = BodyMode {
                frequency_hz,
                loss_factor: 0.0,
                modal_mass_kg: 1.0 / (q * q).max(f64::MIN_POSITIVE),
                m: 1,
                n: 1,
                net_volume: 1.0 + a * z / (s * q),
            };
            BodyMode {
                loss_factor: u_top * u_top * top.loss_factor
                    + u_air * u_air * AIR_LOSS_FACTOR
                    + radiation_loss_factor(plate, &mode),
                ..mode
            }
        })
    }
}

/// A bridge drawn as a polyline in plate fractions; its keys are spread evenly
/// along it, the first key at the first point.
#[derive(Clone, Debug, PartialEq)]
pub struct BridgeLine {
    /// Keys whose strings bear on this bridge.
    pub keys: RangeInclusive<u8>,
    /// Polyline vertices (x, y), fractions of the plate's sides.
    pub points: &'static [(f64, f64)],
}

impl BridgeLine {
    /// How far along the line `key` sits, 0 (its first key) to 1 (its last).
    fn fraction(&self, key: u8) -> f64 {
        let (lo, hi) = (f64::from(*self.keys.start()), f64::from(*self.keys.end()));
        if hi > lo { ((f64::from(key) - lo) / (hi - lo)).clamp(0.0, 1.0) } else { 0.0 }
    }

    /// Position of `key` on this line (clamped to its ends).
    fn point(&self, key: u8) -> (f64, f64) {
        along_polyline(self.points, self.fraction(key))
    }
}

/// Where a bridge is cut into zones, as fractions along it.
fn zone_fractions(bridge: &BridgeLine) -> &'static [f64] {
    if bridge.keys.len() >= 24 { &[0.0, 1.0 / 3.0, 2.0 / 3.0, 1.0] } else { &[0.0, 1.0] }
}

/// Point at fraction `t` of a polyline's length.
fn along_polyline(points: &[(f64, f64)], t: f64) -> (f64, f64) {
    let seg = |p: &(f64, f64), q: &(f64, f64)| (q.0 - p.0).hypot(q.1 - p.1);
    let total: f64 = points.windows(2).map(|w| seg(&w[0], &w[1])).sum();
    let mut left = t * total;
    for w in points.windows(2) {
        let l = seg(&w[0], &w[1]);
        if left <= l && l > 0.0 {
            let u = left / l;
            return (w[0].0 + u * (w[1].0 - w[0].0), w[0].1 + u * (w[1].1 - w[0].1));
        }
        left -= l;
    }
    points.last().copied().unwrap_or((0.5, 0.5))
}

/// An instrument's body.
#[derive(Clone, Debug, PartialEq)]
pub struct BodyDesign {
    /// Which instrument.
    pub instrument: InstrumentKind,
    /// The equivalent rectangular board.
    pub plate: Plate,
    /// The box and holes of a boxed instrument.
    pub air: Option<AirCavity>,
    /// The compass, MIDI keys (as in `crate::design`).
    pub keys: RangeInclusive<u8>,
    /// Bridges and the keys on each.
    pub bridges: Vec<BridgeLine>,
    /// Whether each bridge line is one beam or a row of separate bridges.
    pub bridge_kind: Bridges,
    /// Plausible range of the first body mode, Hz, and why.
    pub first_mode_range_hz: (f64, f64, &'static str),
}

impl BodyDesign {
    /// Where `midi_key`'s strings bear on the board, (x, y) as fractions. Keys
    /// outside the compass are clamped to it. A key that sounds on the short side
    /// of another course (the dulcimer's G#5-D6) takes that course's point.
    pub fn bridge_point(&self, midi_key: u8) -> (f64, f64) {
        let key = self.bridge_key(midi_key);
        self.bridges.iter().find(|b| b.keys.contains(&key)).or(self.bridges.last()).map_or((0.5, 0.5), |b| b.point(key))
    }

    /// The bridge line `midi_key`'s strings bear on.
    fn bridge_of(&self, midi_key: u8) -> Option<&BridgeLine> {
        let key = self.bridge_key(midi_key);
        self.bridges.iter().find(|b| b.keys.contains(&key)).or(self.bridges.last())
    }

    /// A bridge line's length, m.
    fn line_length_m(&self, bridge: &BridgeLine) -> f64 {
        let (a, b) = (self.plate.length_m, self.plate.width_m);
        bridge.points.windows(2).map(|w| ((w[1].0 - w[0].0) * a).hypot((w[1].1 - w[0].1) * b)).sum()
    }

    /// The bridges as beams, when they are continuous: bending stiffness EI
    /// (N m^2, bending under the strings' push, so about the section's width)
    /// and mass per length (kg/m), of maple.
    pub fn bridge_beam(&self) -> Option<(f64, f64)> {
        match self.bridge_kind {
            Bridges::Continuous { width_m, height_m } if width_m > 0.0 && height_m > 0.0 => {
                let area = width_m * height_m;
                Some((MAPLE_E_PA * width_m * height_m.powi(3) / 12.0, MAPLE_DENSITY_KG_M3 * area))
            }
            _ => None,
        }
    }

    /// How far apart along one bridge two keys' strings bear, m; None when
    /// they bear on different bridges.
    pub fn along_bridge_m(&self, a: u8, b: u8) -> Option<f64> {
        let (la, lb) = (self.bridge_of(a)?, self.bridge_of(b)?);
        if la != lb {
            return None;
        }
        let (ka, kb) = (self.bridge_key(a), self.bridge_key(b));
        Some((la.fraction(ka) - la.fraction(kb)).abs() * self.line_length_m(la))
    }

    /// How far apart two keys' bridge points are across the board, m.
    pub fn apart_m(&self, a: u8, b: u8) -> f64 {
        let (pa, pb) = (self.bridge_point(a), self.bridge_point(b));
        ((pa.0 - pb.0) * self.plate.length_m).hypot((pa.1 - pb.1) * self.plate.width_m)
    }

    /// The body's modes up to `max_hz`, sorted by frequency: the plate's, its
    /// (1, 1) mode coupled to the air of a box ([`AirCavity::couple`]). A plate
    /// mode loses what the wood takes and what it radiates
    /// ([`radiation_loss_factor`]).
    pub fn modes(&self, max_hz: f64) -> Vec<BodyMode> {
        let mut list = plate::modes(&self.plate, max_hz);
        for mode in &mut list {
            mode.loss_factor += radiation_loss_factor(&self.plate, mode);
        }
        if let Some(air) = &self.air {
            list.retain(|mode| (mode.m, mode.n) != (1, 1));
            let top = plate::mode(&self.plate, 1, 1);
            list.extend(air.couple(&self.plate, &top).into_iter().filter(|m| m.frequency_hz <= max_hz));
            list.sort_by(|p, q| p.frequency_hz.total_cmp(&q.frequency_hz));
        }
        list
    }

    /// The modes the running body carries up to `max_hz`: every mode below the
    /// frequency where the ribs start to guide waves between them (1 kHz for a
    /// board without ribs, or if that lies lower), and above it as many as a
    /// bridge point sees there, [`APPARENT_DENSITY_PER_HZ`] (Boutillon & Ege:
    /// the modes localise between the ribs and the density seen from the
    /// bridge falls to 0.01-0.02 /Hz). Each mode kept above stands for those
    /// left out beside it: its modal mass is divided by their number, which
    /// keeps the board's mean mobility n/(4M).
    pub fn running_modes(&self, max_hz: f64) -> Vec<BodyMode> {
        let split_hz = self.plate.inter_rib_hz().unwrap_or(1000.0).max(1000.0);
        let density = plate::modal_density(&self.plate, split_hz);
        let keep = (APPARENT_DENSITY_PER_HZ / density).min(1.0);
        let mut credit = 0.0;
        let mut list = Vec::new();
        for mode in self.modes(max_hz) {
            if mode.frequency_hz <= split_hz {
                list.push(mode);
                continue;
            }
            credit += keep;
            if credit >= 1.0 {
                credit -= 1.0;
                list.push(BodyMode { modal_mass_kg: mode.modal_mass_kg * keep, ..mode });
            }
        }
        list
    }

    /// Drive-point mobility at `midi_key`'s bridge point, (re, im) s/kg, with
    /// modes to `max_hz` (pass `self.modes(max_hz)`) and the smooth residual.
    pub fn bridge_mobility(&self, modes: &[BodyMode], max_hz: f64, midi_key: u8, f_hz: f64) -> (f64, f64) {
        plate::mobility(&self.plate, modes, max_hz, self.bridge_point(midi_key), f_hz)
    }

    /// The points the bridges are cut into for the running body: each bridge's
    /// ends, and two more between them on a bridge of 24 keys or more (in key
    /// order along the bridge), at most [`MAX_ZONES`].
    pub fn zone_points(&self) -> Vec<(f64, f64)> {
        self.bridges
            .iter()
            .flat_map(|b| zone_fractions(b).iter().map(|&t| along_polyline(b.points, t)).collect::<Vec<_>>())
            .collect()
    }

    /// Which two zones `midi_key`'s strings bear between, and the share of the
    /// force each takes (linear along the bridge).
    pub fn zone_share(&self, midi_key: u8) -> ZoneShare {
        let key = self.bridge_key(midi_key);
        let mut first = 0;
        for bridge in &self.bridges {
            let fractions = zone_fractions(bridge);
            if bridge.keys.contains(&key) {
                let t = bridge.fraction(key);
                let j = fractions.windows(2).position(|w| t <= w[1]).unwrap_or(fractions.len() - 2);
                let (t0, t1) = (fractions[j], fractions[j + 1]);
                let w1 = ((t - t0) / (t1 - t0)).clamp(0.0, 1.0);
                return ZoneShare { zones: [first + j, first + j + 1], weights: [1.0 - w1, w1] };
            }
            first += fractions.len();
        }
        ZoneShare { zones: [0, 0], weights: [0.0, 0.0] }
    }

    /// The two zone points `midi_key` bears between, with its share of the
    /// force on each: how the running body hears the key.
    pub fn share_points(&self, midi_key: u8) -> Vec<((f64, f64), f64)> {
        let zones = self.zone_points();
        let share = self.zone_share(midi_key);
        share.zones.iter().zip(share.weights).filter_map(|(&z, w)| zones.get(z).map(|&p| (p, w))).collect()
    }

    /// The key whose place on the bridges `midi_key` takes (clamped to the
    /// compass; a dulcimer's short sides take their course's).
    fn bridge_key(&self, midi_key: u8) -> u8 {
        let key = midi_key.clamp(*self.keys.start(), *self.keys.end());
        match self.instrument {
            InstrumentKind::Dulcimer if key > 79 => key - 7,
            _ => key,
        }
    }

    /// The same body with its board `size` times as long and as wide (held to
    /// 0.5..=2): the same wood, thickness and ribs, the bridges' mass grown with
    /// the board's area and the box's air with its volume.
    pub fn scaled(mut self, size: f64) -> Self {
        let s = size.clamp(0.5, 2.0);
        self.plate.length_m *= s;
        self.plate.width_m *= s;
        self.plate.bridge_mass_kg *= s * s;
        if let Some(air) = &mut self.air {
            air.volume_m3 *= s * s;
        }
        self
    }

    /// A key in the middle of the compass.
    pub fn middle_key(&self) -> u8 {
        ((u16::from(*self.keys.start()) + u16::from(*self.keys.end())) / 2) as u8
    }
}

/// The design of one instrument.
pub fn design(instrument: InstrumentKind) -> BodyDesign {
    match instrument {
        InstrumentKind::Piano => piano_grand(),
        InstrumentKind::Fortepiano => fortepiano(),
        InstrumentKind::Clavichord => clavichord(),
        InstrumentKind::Harpsichord => harpsichord(),
        InstrumentKind::Santoor => santoor(),
        InstrumentKind::Dulcimer => dulcimer(),
        InstrumentKind::Cimbalom => cimbalom(),
    }
}

/// Grand piano. Board: 1.5 m along the grain x 1.05 m, 1.58 m^2, the area of a
/// 1.8-2 m grand's board (assumption: a concert grand's is about 2.6 m^2, a baby
/// grand's about 1.5); 9 mm spruce (design notes 1.1: "a bare 9 mm spruce plate";
/// grand boards are 8-10 mm, thinner at the rim). Ribs: 11 across the grain at
/// 0.13 m, 25 mm wide, 18 mm mean depth (assumption: ribs of 20-25 mm at the
/// centre tapered to about 10 mm at the rim). Clamped (Ege & Boutillon).
/// Bass bridge: keys 21-40 (A0-E2, the lowest 20 keys) on a short bridge near
/// the bent side; long bridge: keys 41-108 running diagonally from the tail
/// towards the treble corner. Mics: "player" 0.3 m above the board's keyboard
/// end in the middle, "lid" 1 m above the bent side's middle.
/// Bridges: maple, 32 mm wide and 34 mm tall (Fandrich, piano designer, PTG
/// list 2009: "a nominal width of about 32 mm and a height in the 30 - 34 mm
/// range", 30 mm at C8 and taller into the tenor).
fn piano_grand() -> BodyDesign {
    let plate = Plate {
        length_m: 1.5,
        width_m: 1.05,
        thickness_m: 0.009,
        wood: SPRUCE,
        ribs: Some(Ribs {
            spacing_m: 0.13,
            width_m: 0.028,
            depth_m: 0.024,
            e_pa: SPRUCE.e_along_pa,
            density_kg_m3: 420.0,
        }),
        boundary: Boundary::Clamped,
        loss_factor: BOARD_LOSS_FACTOR,
        bridge_mass_kg: 1.5,
    };
    BodyDesign {
        instrument: InstrumentKind::Piano,
        plate,
        air: None,
        keys: 21..=108,
        bridges: vec![
            BridgeLine { keys: 21..=40, points: &[(0.80, 0.78), (0.86, 0.62)] },
            BridgeLine { keys: 41..=108, points: &[(0.62, 0.86), (0.42, 0.55), (0.20, 0.18)] },
        ],
        bridge_kind: Bridges::Continuous { width_m: 0.032, height_m: 0.034 },
        first_mode_range_hz: (
            30.0,
            120.0,
            "Conklin (KTH five lectures, 'How does a soundboard vibrate?'): concert grand first mode 49 Hz; a smaller board sits higher",
        ),
    }
}

/// Fortepiano after Walter (compass F1-g''', keys 29-91). Board 1.3 m x 0.7 m
/// (assumption: the instrument is about 2.2 m by 0.95 m); 3.5 mm spruce
/// (assumption: Viennese boards of the period are commonly given as 3-4 mm);
/// light ribs 12 mm x 10 mm at 0.2 m (assumption). One bridge, not overstrung.
/// Bridge: maple, 18 mm x 22 mm (assumption: a light Viennese bridge).
fn fortepiano() -> BodyDesign {
    let plate = Plate {
        length_m: 1.3,
        width_m: 0.7,
        thickness_m: 0.0035,
        wood: SPRUCE,
        ribs: Some(Ribs {
            spacing_m: 0.2,
            width_m: 0.012,
            depth_m: 0.010,
            e_pa: SPRUCE.e_along_pa,
            density_kg_m3: 420.0,
        }),
        boundary: Boundary::Clamped,
        loss_factor: BOARD_LOSS_FACTOR,
        bridge_mass_kg: 0.4,
    };
    BodyDesign {
        instrument: InstrumentKind::Fortepiano,
        plate,
        air: None,
        keys: 29..=91,
        bridges: vec![BridgeLine { keys: 29..=91, points: &[(0.82, 0.85), (0.5, 0.5), (0.15, 0.15)] }],
        bridge_kind: Bridges::Continuous { width_m: 0.018, height_m: 0.022 },
        first_mode_range_hz: (
            25.0,
            150.0,
            "no measurement found; a thin board of about 0.9 m^2: below the piano's to about twice it",
        ),
    }
}

/// Clavichord (keys 36-88). Board 0.45 m x 0.28 m right of the keys (assumption:
/// the soundboard of a 1.5 m fretted clavichord); 2.5 mm spruce (assumption:
/// clavichord boards are 2-3 mm); no ribs. The box below and its rose give an
/// air mode: 0.55 m x 0.3 m x 0.1 m of air (the case's bass end), a 60 mm rose
/// (assumption). Bridge: one S-curved bridge.
/// Bridge: 8 mm x 12 mm (assumption).
fn clavichord() -> BodyDesign {
    let plate = Plate {
        length_m: 0.45,
        width_m: 0.28,
        thickness_m: 0.0025,
        wood: SPRUCE,
        ribs: None,
        boundary: Boundary::Clamped,
        loss_factor: BOARD_LOSS_FACTOR,
        bridge_mass_kg: 0.05,
    };
    BodyDesign {
        instrument: InstrumentKind::Clavichord,
        plate,
        air: Some(AirCavity { volume_m3: 0.55 * 0.3 * 0.1, holes: 1, hole_radius_m: 0.03, wall_m: 0.0025 }),
        keys: 36..=88,
        bridges: vec![BridgeLine { keys: 36..=88, points: &[(0.85, 0.85), (0.55, 0.55), (0.2, 0.2)] }],
        bridge_kind: Bridges::Continuous { width_m: 0.008, height_m: 0.012 },
        first_mode_range_hz: (
            50.0,
            500.0,
            "no measurement found; a 0.13 m^2, 2.5 mm unribbed board clamped all round: tens to a few hundred Hz",
        ),
    }
}

/// Italian harpsichord (keys 36-86; the Naples strings run to 1.48 m). Board
/// 1.6 m along the grain (parallel to the spine and the strings) x 0.55 m
/// (assumption from a 1.9 m case), 3 mm spruce (assumption: Italian boards are
/// commonly quoted at about 3 mm), no ribs under the bridge (assumption: Italian
/// boards have few bars). Case air: 1.6 x 0.6 x 0.15 m with no rose (the Italian
/// rose is small; here one of 40 mm radius, assumption). Bridge: bass at the
/// tail, treble near the nut end.
/// Bridge: 10 mm x 14 mm (assumption: Italian bridges are slender).
fn harpsichord() -> BodyDesign {
    let plate = Plate {
        length_m: 1.6,
        width_m: 0.55,
        thickness_m: 0.003,
        wood: SPRUCE,
        ribs: Some(Ribs {
            spacing_m: 0.2,
            width_m: 0.010,
            depth_m: 0.012,
            e_pa: SPRUCE.e_along_pa,
            density_kg_m3: 420.0,
        }),
        boundary: Boundary::Clamped,
        loss_factor: BOARD_LOSS_FACTOR,
        bridge_mass_kg: 0.2,
    };
    BodyDesign {
        instrument: InstrumentKind::Harpsichord,
        plate,
        air: Some(AirCavity { volume_m3: 1.6 * 0.6 * 0.15 * 0.6, holes: 1, hole_radius_m: 0.04, wall_m: 0.003 }),
        keys: 36..=86,
        bridges: vec![BridgeLine { keys: 36..=86, points: &[(0.88, 0.80), (0.55, 0.50), (0.12, 0.22)] }],
        bridge_kind: Bridges::Continuous { width_m: 0.010, height_m: 0.014 },
        first_mode_range_hz: (20.0, 150.0, "no measurement found; a long, thin (3 mm) unribbed board: low first mode"),
    }
}

/// Santoor/santur (keys 52-89). Top: trapezoid of about 0.9 and 0.6 m by 0.3 m
/// (Persian santur dimensions, assumption), taken as 0.78 m x 0.3 m, 6 mm walnut
/// (assumption); internal posts ignored. Box 0.06 m deep: V = 0.78 x 0.3 x 0.06
/// m^3; two roses of 25 mm radius (assumption). Bridges: the bass column (keys
/// 52-70, right) and the treble column (71-89, left), each running from the back
/// (long strings) to the front. Each column is a row of separate "chessman" bridges, one to a
/// course (Náini 2007, two columns of 9), joined only by the top.
fn santoor() -> BodyDesign {
    let plate = Plate {
        length_m: 0.78,
        width_m: 0.3,
        thickness_m: 0.006,
        wood: WALNUT,
        ribs: None,
        boundary: Boundary::Clamped,
        loss_factor: BOARD_LOSS_FACTOR,
        bridge_mass_kg: 0.15,
    };
    BodyDesign {
        instrument: InstrumentKind::Santoor,
        plate,
        air: Some(AirCavity { volume_m3: 0.78 * 0.3 * 0.06, holes: 2, hole_radius_m: 0.025, wall_m: 0.006 }),
        keys: 52..=89,
        bridges: vec![
            BridgeLine { keys: 52..=70, points: &[(0.75, 0.88), (0.75, 0.12)] },
            BridgeLine { keys: 71..=89, points: &[(0.30, 0.88), (0.30, 0.12)] },
        ],
        bridge_kind: Bridges::Separate,
        first_mode_range_hz: (80.0, 500.0, "no measurement found; a 0.23 m^2, 6 mm hardwood top: a few hundred Hz"),
    }
}

/// Hammered dulcimer, 16/15 (keys 50-86; bass 50-61, treble long sides 62-79,
/// short sides 80-86). Top: trapezoid 1.0 m and 0.65 m by 0.42 m, taken as
/// 0.82 m x 0.42 m, 6.4 mm (1/4") spruce (assumption, a common kit spec), two
/// braces under the bridges ignored. Box 75 mm deep; two 38 mm radius (3")
/// roses (assumption). Bass bridge at 0.8 of the length, treble bridge at 0.4
/// (it divides the treble courses 3:2, Peterson 1994).
/// Bridges: 13 mm x 19 mm (assumption: about 1/2" by 3/4").
fn dulcimer() -> BodyDesign {
    let plate = Plate {
        length_m: 0.82,
        width_m: 0.42,
        thickness_m: 0.0064,
        wood: SPRUCE,
        ribs: None,
        boundary: Boundary::Clamped,
        loss_factor: BOARD_LOSS_FACTOR,
        bridge_mass_kg: 0.3,
    };
    BodyDesign {
        instrument: InstrumentKind::Dulcimer,
        plate,
        air: Some(AirCavity { volume_m3: 0.82 * 0.42 * 0.075, holes: 2, hole_radius_m: 0.038, wall_m: 0.0064 }),
        keys: 50..=86,
        bridges: vec![
            BridgeLine { keys: 50..=61, points: &[(0.80, 0.88), (0.80, 0.15)] },
            BridgeLine { keys: 62..=79, points: &[(0.40, 0.90), (0.40, 0.10)] },
        ],
        bridge_kind: Bridges::Continuous { width_m: 0.013, height_m: 0.019 },
        first_mode_range_hz: (60.0, 400.0, "no measurement found; a 0.34 m^2, 6.4 mm spruce top clamped to the rim"),
    }
}

/// Concert cimbalom (keys 36-88). Top: trapezoid with sides about 1.40 and
/// 0.95 m (Schunda's concert cimbalom; Pap, American Lutherie 61, 2000) by 0.7 m, taken as 1.18 m x 0.7 m,
/// 8 mm spruce with ribs at 0.15 m, 20 mm x 15 mm (assumption: a piano-like
/// construction on a smaller scale). Box 0.12 m deep, three roses of 40 mm
/// radius (assumption). Bridges: wound bass courses 36-51 on the right bridge,
/// steel courses 52-88 on the left.
/// Bridges: 20 mm x 25 mm (assumption: a piano's, smaller).
fn cimbalom() -> BodyDesign {
    let plate = Plate {
        length_m: 1.18,
        width_m: 0.7,
        thickness_m: 0.008,
        wood: SPRUCE,
        ribs: Some(Ribs {
            spacing_m: 0.15,
            width_m: 0.020,
            depth_m: 0.015,
            e_pa: SPRUCE.e_along_pa,
            density_kg_m3: 420.0,
        }),
        boundary: Boundary::Clamped,
        loss_factor: BOARD_LOSS_FACTOR,
        bridge_mass_kg: 0.8,
    };
    BodyDesign {
        instrument: InstrumentKind::Cimbalom,
        plate,
        air: Some(AirCavity { volume_m3: 1.18 * 0.7 * 0.12, holes: 3, hole_radius_m: 0.04, wall_m: 0.008 }),
        keys: 36..=88,
        bridges: vec![
            BridgeLine { keys: 36..=51, points: &[(0.78, 0.88), (0.78, 0.12)] },
            BridgeLine { keys: 52..=88, points: &[(0.38, 0.90), (0.38, 0.10)] },
        ],
        bridge_kind: Bridges::Continuous { width_m: 0.020, height_m: 0.025 },
        first_mode_range_hz: (
            40.0,
            250.0,
            "no measurement found; a ribbed 0.8 m^2 board between the piano's and the dulcimer's",
        ),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_key_lands_inside_the_board() {
        for i in InstrumentKind::ALL {
            let d = design(i);
            for key in d.keys.clone() {
                let (x, y) = d.bridge_point(key);
                assert!((0.0..=1.0).contains(&x) && (0.0..=1.0).contains(&y), "{i:?} {key}: {x} {y}");
            }
        }
    }

    #[test]
    fn piano_bass_keys_use_the_bass_bridge() {
        let d = design(InstrumentKind::Piano);
        assert_eq!(d.bridge_point(21), (0.80, 0.78));
        let (x40, _) = d.bridge_point(40);
        let (x41, _) = d.bridge_point(41);
        assert!(x40 > 0.8 && x41 < 0.7, "{x40} {x41}");
        assert_eq!(d.bridge_point(108), (0.20, 0.18));
    }

    #[test]
    fn every_key_bears_between_two_neighbouring_zones_of_its_bridge() {
        for i in InstrumentKind::ALL {
            let d = design(i);
            let zones = d.zone_points();
            assert!(zones.len() <= MAX_ZONES, "{i:?}: {}", zones.len());
            for key in d.keys.clone() {
                let share = d.zone_share(key);
                assert!((share.weights[0] + share.weights[1] - 1.0).abs() < 1e-12, "{i:?} {key}");
                assert_eq!(share.zones[1], share.zones[0] + 1, "{i:?} {key}");
                // The share's point lies on the segment between its zones, near the key's own.
                let (a, b) = (zones[share.zones[0]], zones[share.zones[1]]);
                let mix =
                    (a.0 * share.weights[0] + b.0 * share.weights[1], a.1 * share.weights[0] + b.1 * share.weights[1]);
                let own = d.bridge_point(key);
                assert!((mix.0 - own.0).hypot(mix.1 - own.1) < 0.15, "{i:?} {key}: {mix:?} against {own:?}");
            }
        }
    }

    #[test]
    fn the_running_body_thins_its_modes_above_the_ribs_and_keeps_its_mean_mobility() {
        let d = design(InstrumentKind::Piano);
        let (all, running) = (d.modes(10_000.0), d.running_modes(10_000.0));
        let split = d.plate.inter_rib_hz().unwrap().max(1000.0);
        let above = |list: &[BodyMode]| list.iter().filter(|m| m.frequency_hz > split).count() as f64;
        let density = above(&running) / (10_000.0 - split);
        assert!((0.0075..0.0125).contains(&density), "{density}");
        assert!(running.len() < all.len() / 2, "{} of {}", running.len(), all.len());
        // Sum of 1/m per hertz above the split: the mean mobility's measure.
        let weight = |list: &[BodyMode]| {
            list.iter().filter(|m| m.frequency_hz > split).map(|m| 1.0 / m.modal_mass_kg).sum::<f64>()
        };
        assert!((weight(&running) / weight(&all) - 1.0).abs() < 0.05);
    }

    #[test]
    fn a_larger_board_rings_lower_and_holds_more_modes() {
        let built = design(InstrumentKind::Piano);
        let larger = design(InstrumentKind::Piano).scaled(1.25);
        let (f, g) = (built.modes(1000.0), larger.modes(1000.0));
        // Frequencies go as 1 / size^2 for the same wood and thickness (the bridges'
        // mass grows as the area, so as the board's).
        assert!(
            (g[0].frequency_hz / f[0].frequency_hz - 1.0 / 1.5625).abs() < 0.02,
            "{} {}",
            f[0].frequency_hz,
            g[0].frequency_hz
        );
        assert!(g.len() > f.len());
        assert_eq!(design(InstrumentKind::Piano).scaled(1.0), built);
    }

    #[test]
    fn dulcimer_short_sides_share_their_course_point() {
        let d = design(InstrumentKind::Dulcimer);
        assert_eq!(d.bridge_point(80), d.bridge_point(73));
        assert_eq!(d.bridge_point(86), d.bridge_point(79));
    }

    #[test]
    fn helmholtz_formula_reproduces_a_textbook_case() {
        // 1 litre, one 20 mm radius hole in a 2 mm wall: c/(2 pi) sqrt(A/(V L)).
        let a = AirCavity { volume_m3: 1e-3, holes: 1, hole_radius_m: 0.02, wall_m: 0.002 };
        let expect = 343.0 / (2.0 * PI) * (PI * 0.0004 / (1e-3 * (0.002 + 0.034))).sqrt();
        assert!((a.frequency_hz() / expect - 1.0).abs() < 1e-12);
        assert!((300.0..340.0).contains(&a.frequency_hz()), "{}", a.frequency_hz()); // 322 Hz by hand
    }
}
