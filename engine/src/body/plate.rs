//! An orthotropic, rib-stiffened rectangular plate: its modes, mode shapes,
//! drive-point mobility, modal density and Skudrzyk mean mobility.
//!
//! Coordinates: x runs along the grain (length `a`), y across it (width `b`).
//! Positions are given as fractions of the sides, 0..1.
//!
//! Mode frequencies (Warburton's approximation, as tabulated by Leissa,
//! "Vibration of plates", NASA SP-160, 1969, ch. 11; exact for simply supported
//! edges):
//!
//! omega_mn^2 rho h = pi^4 [D1 (Gx/a)^4 + 2 D3 Hx Hy / (a b)^2 + D2 (Gy/b)^4]
//!
//! with Gx = m, Hx = m^2 for simply supported edges (the familiar formula
//! omega = pi^2/sqrt(rho h) sqrt(D1 (m/a)^4 + 2 D3 (mn/ab)^2 + D2 (n/b)^4)), and
//! for clamped edges G = 1.506 (first mode) or m + 1/2, H = G^2 (1 - 2/(G pi)).
//! Mode shapes are sin(m pi x) sin(n pi y) with unit peak for both boundaries
//! (exact for simply supported; for clamped the beam functions are replaced by
//! the same sines, an approximation that keeps the drive-point mean and the
//! modal mass M/4). Ege & Boutillon (arXiv:1210.5688) found the upright board
//! behaves as a *clamped* homogeneous plate below 1.1 kHz, so the instruments use
//! `Boundary::Clamped`; `Boundary::SimplySupported` is the closed form.

use std::f64::consts::PI;

use num_complex::Complex64;

/// Edge condition of the plate.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Boundary {
    /// Simply supported on all four edges: exact sine modes.
    SimplySupported,
    /// Clamped on all four edges: Warburton's frequencies, sine shapes.
    Clamped,
}

/// Elastic constants and density of a quarter-sawn wood plate.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Wood {
    /// Density, kg/m^3.
    pub density_kg_m3: f64,
    /// Young's modulus along the grain (E_L), Pa.
    pub e_along_pa: f64,
    /// Young's modulus across the grain in the plane (E_R for quarter-sawn), Pa.
    pub e_across_pa: f64,
    /// In-plane shear modulus (G_LR), Pa.
    pub shear_pa: f64,
    /// Major Poisson ratio nu_LR (strain across / strain along, load along).
    pub poisson_along: f64,
}

/// Ribs glued across the grain (running along y), smeared into D2.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Ribs {
    /// Centre-to-centre spacing along x, m.
    pub spacing_m: f64,
    /// Rib width (along x), m.
    pub width_m: f64,
    /// Mean rib depth above the plate, m (ribs are tapered towards the rim).
    pub depth_m: f64,
    /// Young's modulus of the rib along its own length (the rib's grain), Pa.
    pub e_pa: f64,
    /// Rib density, kg/m^3.
    pub density_kg_m3: f64,
}

/// A rectangular (equivalent) soundboard.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Plate {
    /// Side along the grain, m.
    pub length_m: f64,
    /// Side across the grain, m.
    pub width_m: f64,
    /// Panel thickness, m.
    pub thickness_m: f64,
    /// The panel's wood.
    pub wood: Wood,
    /// Ribs across the grain, if any.
    pub ribs: Option<Ribs>,
    /// Edge condition.
    pub boundary: Boundary,
    /// Modal loss factor eta (constant with frequency).
    pub loss_factor: f64,
    /// Mass of the bridges (and bearing hardware) smeared over the board, kg.
    /// Adds mass only: the bridge's own bending stiffness is neglected.
    pub bridge_mass_kg: f64,
}

/// The three bending stiffnesses of the orthotropic plate, N m.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Stiffness {
    /// Along the grain.
    pub d1: f64,
    /// Across the grain (including smeared ribs).
    pub d2: f64,
    /// D1 nu21 + 2 Dxy.
    pub d3: f64,
}

/// One mode of the body.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BodyMode {
    /// Natural frequency, Hz.
    pub frequency_hz: f64,
    /// Loss factor eta (the mode decays as exp(-pi eta f t)).
    pub loss_factor: f64,
    /// Modal mass for a shape of unit peak, kg.
    pub modal_mass_kg: f64,
    /// Half-waves along x.
    pub m: u32,
    /// Half-waves along y.
    pub n: u32,
    /// The net volume the mode moves, re what its shape alone moves: 1 for a
    /// plate mode; a box's top-and-air modes add the air its holes move (in
    /// step or against the top's), [`crate::body::boards::AirCavity::couple`].
    pub net_volume: f64,
}

impl Plate {
    /// Area, m^2.
    pub fn area_m2(&self) -> f64 {
        self.length_m * self.width_m
    }

    /// Mass per area of the panel alone, kg/m^2.
    pub fn panel_mass_per_area(&self) -> f64 {
        self.wood.density_kg_m3 * self.thickness_m
    }

    /// Mass per area with the ribs smeared over their spacing, kg/m^2.
    pub fn mass_per_area(&self) -> f64 {
        let ribs = self.ribs.map_or(0.0, |r| r.density_kg_m3 * r.width_m * r.depth_m / r.spacing_m);
        self.panel_mass_per_area() + ribs + self.bridge_mass_kg / self.area_m2()
    }

    /// Total mass of panel and ribs, kg.
    pub fn mass_kg(&self) -> f64 {
        self.mass_per_area() * self.area_m2()
    }

    /// The panel's bending stiffnesses without ribs, N m.
    pub fn panel_stiffness(&self) -> Stiffness {
        let w = &self.wood;
        let h3 = self.thickness_m.powi(3);
        let nu21 = w.poisson_along * w.e_across_pa / w.e_along_pa;
        let k = h3 / (12.0 * (1.0 - w.poisson_along * nu21));
        let d1 = w.e_along_pa * k;
        let dxy = w.shear_pa * h3 / 12.0;
        Stiffness { d1, d2: w.e_across_pa * k, d3: d1 * nu21 + 2.0 * dxy }
    }

    /// Bending stiffnesses with the ribs smeared into D2, N m.
    ///
    /// Smearing (parallel-axis theorem): one rib and the strip of panel of width
    /// `spacing` it stiffens form a T-section. Its neutral axis sits at
    /// z_n = E_r A_r z_r / (E2 h s + E_r A_r) above the panel's mid-plane, where
    /// z_r = (h + d)/2 is the rib's centroid; the section's bending stiffness is
    /// E2 (s h^3/12 + s h z_n^2) + E_r (w d^3/12 + A_r (z_r - z_n)^2), and D2 is that
    /// divided by s. The panel's Poisson factor is left on the panel term only.
    /// D1 and D3 are left as the panel's (ribs across the grain do not bend
    /// with x; their torsional stiffness is neglected).
    pub fn stiffness(&self) -> Stiffness {
        let panel = self.panel_stiffness();
        match self.ribs {
            None => panel,
            Some(r) => Stiffness { d2: self.ribbed_d2(&panel, &r), ..panel },
        }
    }

    fn ribbed_d2(&self, panel: &Stiffness, r: &Ribs) -> f64 {
        let h = self.thickness_m;
        let s = r.spacing_m;
        let e2h = panel.d2 * 12.0 / (h * h); // E2 h / (1 - nu12 nu21), per width
        let area = r.width_m * r.depth_m;
        let z_rib = 0.5 * (h + r.depth_m);
        let z_n = r.e_pa * area * z_rib / (e2h * s + r.e_pa * area);
        let panel_part = panel.d2 * s + e2h * s * z_n * z_n;
        let rib_part = r.e_pa * (r.width_m * r.depth_m.powi(3) / 12.0 + area * (z_rib - z_n).powi(2));
        (panel_part + rib_part) / s
    }

    /// Geometric-mean stiffness sqrt(D1 D2), N m: the isotropic plate with the
    /// same asymptotic modal density (exact when D3 = sqrt(D1 D2)).
    pub fn mean_stiffness(&self) -> f64 {
        let d = self.stiffness();
        (d.d1 * d.d2).sqrt()
    }

    /// Frequency where the ribs stop acting as smeared stiffness: half a bending
    /// wavelength of the bare panel along the grain equals the rib spacing
    /// (Ege & Boutillon, arXiv:1210.5688: "the inter-rib effect appearing when the
    /// half-wavelength becomes equal to the rib spacing"). None without ribs.
    pub fn inter_rib_hz(&self) -> Option<f64> {
        let r = self.ribs?;
        let d1 = self.panel_stiffness().d1;
        let k = PI / r.spacing_m;
        Some(k * k * (d1 / self.panel_mass_per_area()).sqrt() / (2.0 * PI))
    }

    /// Frequency of mode (m, n), Hz, for this plate's boundary.
    pub fn mode_frequency_hz(&self, m: u32, n: u32) -> f64 {
        let d = self.stiffness();
        let (gx, hx) = beam_factors(self.boundary, m);
        let (gy, hy) = beam_factors(self.boundary, n);
        let (a, b) = (self.length_m, self.width_m);
        let k4 = d.d1 * (gx / a).powi(4) + 2.0 * d.d3 * hx * hy / (a * b).powi(2) + d.d2 * (gy / b).powi(4);
        PI * PI * (k4 / self.mass_per_area()).sqrt() / (2.0 * PI)
    }
}

/// Warburton's (G, H) for one direction: the effective half-wave count and the
/// coupling factor. Simply supported: (m, m^2). Clamped-clamped: G = 1.506 for
/// the first mode, m + 1/2 above; H = G^2 (1 - 2/(G pi)).
fn beam_factors(boundary: Boundary, m: u32) -> (f64, f64) {
    let mf = f64::from(m);
    match boundary {
        Boundary::SimplySupported => (mf, mf * mf),
        Boundary::Clamped => {
            let g = if m == 1 { 1.506 } else { mf + 0.5 };
            (g, g * g * (1.0 - 2.0 / (g * PI)))
        }
    }
}

/// All plate modes up to `max_hz`, sorted by frequency. Modal mass is M/4 (sine
/// shapes of unit peak); every mode takes the plate's loss factor.
pub fn modes(plate: &Plate, max_hz: f64) -> Vec<BodyMode> {
    let mut out = Vec::new();
    let mut m = 1;
    while plate.mode_frequency_hz(m, 1) <= max_hz {
        let mut n = 1;
        loop {
            let mode = mode(plate, m, n);
            if mode.frequency_hz > max_hz {
                break;
            }
            out.push(mode);
            n += 1;
        }
        m += 1;
    }
    out.sort_by(|p, q| p.frequency_hz.total_cmp(&q.frequency_hz));
    out
}

/// The plate's (m, n) mode: its frequency, the plate's loss factor, a
/// quarter of its mass (a shape of unit peak).
pub fn mode(plate: &Plate, m: u32, n: u32) -> BodyMode {
    BodyMode {
        frequency_hz: plate.mode_frequency_hz(m, n),
        loss_factor: plate.loss_factor,
        modal_mass_kg: plate.mass_kg() / 4.0,
        m,
        n,
        net_volume: 1.0,
    }
}

/// Mode shape at (x, y), fractions of the sides: sin(m pi x) sin(n pi y) (a
/// box's coupled top-and-air modes are in the top's (1, 1) shape).
pub fn shape_at(mode: &BodyMode, x: f64, y: f64) -> f64 {
    (f64::from(mode.m) * PI * x).sin() * (f64::from(mode.n) * PI * y).sin()
}

/// One mode's contribution to the drive-point mobility at angular frequency w:
/// i w phi^2 / (m (wk^2 - w^2 + i eta wk w)), returned as (re, im).
pub fn modal_term(phi2_over_m: f64, wk: f64, eta: f64, w: f64) -> (f64, f64) {
    let a = wk * wk - w * w;
    let b = eta * wk * w;
    let den = a * a + b * b;
    (phi2_over_m * w * b / den, phi2_over_m * w * a / den)
}

/// Drive-point mobility Y = v/F at `point` (fractions) and `f_hz`, s/kg, as
/// (re, im): the sum over `modes`, plus a smooth residual for the modes above
/// `max_hz` that the list does not carry.
///
/// The residual treats the modes above `max_hz` as a continuum with the plate's
/// mean weight n(f) <phi^2/m> = 4 Y_mean(f) per Hz (so that its real part is the
/// Skudrzyk mean, Y_mean = `skeleton_mobility`), integrated on a log grid to
/// 64 max(max_hz, f), with a spring-like tail i w 4 Y_mean / (4 pi^2 F) beyond.
/// Below `max_hz` it is a small, nearly pure stiffness term (positive imaginary
/// part rising as f); above `max_hz` it *is* the mean mobility, including the
/// inter-rib rise. Without it a truncated sum would fall like a spring above
/// its last mode and misstate Im Y below it.
pub fn mobility(plate: &Plate, modes: &[BodyMode], max_hz: f64, point: (f64, f64), f_hz: f64) -> (f64, f64) {
    let w = 2.0 * PI * f_hz;
    let (mut re, mut im) = (0.0, 0.0);
    for mode in modes {
        let phi = shape_at(mode, point.0, point.1);
        let (r, i) = modal_term(phi * phi / mode.modal_mass_kg, 2.0 * PI * mode.frequency_hz, mode.loss_factor, w);
        re += r;
        im += i;
    }
    let (r, i) = residual_mobility(plate, max_hz, f_hz);
    (re + r, im + i)
}

/// The continuum of modes above `from_hz` (see [`mobility`]), (re, im), s/kg.
pub fn residual_mobility(plate: &Plate, from_hz: f64, f_hz: f64) -> (f64, f64) {
    let w = 2.0 * PI * f_hz;
    let top_hz = 64.0 * from_hz.max(f_hz);
    let step = (plate.loss_factor / 8.0).min(0.005);
    let steps = ((top_hz / from_hz).ln() / step).ceil().max(1.0) as usize;
    let dl = (top_hz / from_hz).ln() / steps as f64;
    let skeleton = Skeleton::new(plate);
    let (mut re, mut im) = (0.0, 0.0);
    for j in 0..steps {
        let fk = from_hz * ((j as f64 + 0.5) * dl).exp();
        let weight = 4.0 * skeleton.at(fk) * fk * dl; // per-Hz weight times df
        let (r, i) = modal_term(weight, 2.0 * PI * fk, plate.loss_factor, w);
        re += r;
        im += i;
    }
    let tail = 4.0 * skeleton.at(top_hz) * w / (4.0 * PI * PI * top_hz);
    (re, im + tail)
}

/// Skudrzyk mean (infinite-plate) mobility of the smeared-rib plate, s/kg:
/// Y = 1/(8 sqrt(D rho h)) = n(f)/(4 M), with D = sqrt(D1 D2) (geometric mean;
/// exact for the orthotropic plate when D3 = sqrt(D1 D2)) and rho h including the
/// smeared ribs.
pub fn mean_mobility(plate: &Plate) -> f64 {
    1.0 / (8.0 * (plate.mean_stiffness() * plate.mass_per_area()).sqrt())
}

/// Mean mobility of the bare panel between two ribs, s/kg: the level the board
/// tends to once waves are confined between ribs.
pub fn inter_rib_mobility(plate: &Plate) -> f64 {
    let d = plate.panel_stiffness();
    1.0 / (8.0 * ((d.d1 * d.d2).sqrt() * plate.panel_mass_per_area()).sqrt())
}

/// The smooth "skeleton" of the mobility at `f_hz`, s/kg (real): the Skudrzyk
/// mean of the smeared plate below the inter-rib frequency f_r, moving towards the
/// bare panel's mean above it with weight 1 - (f_r/f)^2 (zero at f_r, 3/4 an
/// octave above). The shape of this transition is our assumption; its direction
/// (mobility rising above ~1 kHz) and its cause are Ege & Boutillon's.
pub fn skeleton_mobility(plate: &Plate, f_hz: f64) -> f64 {
    Skeleton::new(plate).at(f_hz)
}

/// [`skeleton_mobility`] of one plate, its levels and the inter-rib
/// frequency worked out once (the continuum's integral asks at thousands
/// of frequencies).
struct Skeleton {
    low: f64,
    /// The inter-rib frequency and the bare panel's level (none without ribs).
    ribs: Option<(f64, f64)>,
}

impl Skeleton {
    fn new(plate: &Plate) -> Self {
        Self { low: mean_mobility(plate), ribs: plate.inter_rib_hz().map(|fr| (fr, inter_rib_mobility(plate))) }
    }

    fn at(&self, f_hz: f64) -> f64 {
        let low = self.low;
        match self.ribs {
            Some((fr, panel)) if f_hz > fr => low + (panel - low) * (1.0 - (fr / f_hz).powi(2)),
            _ => low,
        }
    }
}

/// Asymptotic modal density of the smeared plate, modes per Hz:
/// n = (S/2) sqrt(rho h / D), D = sqrt(D1 D2) (Cremer & Heckl's thin-plate result
/// with the geometric-mean stiffness). Independent of frequency; the boundary
/// only shifts the count by a term growing as sqrt(f) (clamped: fewer modes).
pub fn modal_density(plate: &Plate, _f_hz: f64) -> f64 {
    0.5 * plate.area_m2() * (plate.mass_per_area() / plate.mean_stiffness()).sqrt()
}

/// The plate's own bending wavenumber at `f_hz`, rad/m, for the smeared
/// plate's geometric-mean stiffness, its loss factor taken as a complex
/// stiffness D (1 + i eta) (so the imaginary part is negative: e^(i(wt - kx))
/// decays as it goes).
pub fn plate_wavenumber(plate: &Plate, f_hz: f64) -> Complex64 {
    let w = 2.0 * PI * f_hz;
    (Complex64::new(w * w * plate.mass_per_area(), 0.0) / complex_stiffness(plate)).powf(0.25)
}

fn complex_stiffness(plate: &Plate) -> Complex64 {
    let d = plate.mean_stiffness();
    Complex64::new(d, d * plate.loss_factor)
}

/// The board's line mobility to a line force of trace wavenumber `k` along
/// it, (velocity) / (force per length), s/kg: Y = w / (4 D kp^2) (1/a - i/b)
/// with a = sqrt(kp^2 - k^2), b = sqrt(kp^2 + k^2). From the plate equation
/// D (d^2/dy^2 - k^2)^2 W - rho h w^2 W = F delta(y): on each side
/// W = A e^(-i a y) + B e^(-b y), no slope at the line, and the jump of the shear force,
/// 2 D W'''(0+) = F. A real a is a wave carried off into the board (the
/// real part, the power taken), an imaginary one only a near field. For k = 0
/// it is the line-driven plate's (1 - i) w / (4 D kp^3).
pub fn line_mobility(plate: &Plate, k: Complex64, f_hz: f64) -> Complex64 {
    LineMobility::new(plate, f_hz).at(k)
}

/// [`line_mobility`] at one frequency, what does not hang on the trace
/// wavenumber worked out once (a root search asks for many).
struct LineMobility {
    kp: Complex64,
    scale: Complex64,
}

impl LineMobility {
    fn new(plate: &Plate, f_hz: f64) -> Self {
        let w = 2.0 * PI * f_hz;
        let kp = plate_wavenumber(plate, f_hz);
        Self { kp, scale: w / (4.0 * complex_stiffness(plate) * kp * kp) }
    }

    fn at(&self, k: Complex64) -> Complex64 {
        let kp = self.kp;
        // A trace faster than the board's own wave sheds it outward (Re a > 0: a
        // leaky wave, whose field grows away from the line as it was shed
        // further back); a slower one is held as a near field (Im a < 0).
        let mut a = (kp * kp - k * k).sqrt();
        if (k.re < kp.re && a.re < 0.0) || (k.re >= kp.re && a.im > 0.0) {
            a = -a;
        }
        let mut b = (kp * kp + k * k).sqrt();
        if b.re < 0.0 {
            b = -b;
        }
        self.scale * (1.0 / a - Complex64::i() / b)
    }
}

/// A bending wave along a beam on the board ([`beam_wave`]).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct BeamWave {
    /// Wavenumber, rad/m, Re > 0 > Im.
    pub k: Complex64,
    /// 1 / (EI k^3), the driven point's mobility over (1 - i) w / 4: its phase
    /// is what the transfer keeps.
    scale: Complex64,
}

impl BeamWave {
    /// The wave `t` (0..=1) of the way to `other` (a nearby frequency's).
    pub fn towards(&self, other: &Self, t: f64) -> Self {
        Self { k: self.k + (other.k - self.k) * t, scale: self.scale + (other.scale - self.scale) * t }
    }

    /// The transfer from a driven point to one `distance_m` along the beam,
    /// over the driven point's resistance (its real part is 1 there): the
    /// Green's function of an infinite beam whose every root is k's,
    /// (e^(-ikx) - i e^(-kx)) / (EI k^3). A passive beam's, so the real parts
    /// between any set of points form a positive semi-definite matrix.
    pub fn transfer(&self, distance_m: f64) -> Complex64 {
        let x = distance_m.abs();
        let shape = |x: f64| (-Complex64::i() * self.k * x).exp() - Complex64::i() * (-self.k * x).exp();
        self.scale * shape(x) / (self.scale * shape(0.0)).re
    }
}

/// The bending wave along a beam that lies on the board (a bridge) at `f_hz`.
/// The beam of bending stiffness `ei` (N m^2) and mass `rho_a` (kg/m) is held by
/// the board along its length, which answers its motion with
/// [`line_mobility`]: EI k^4 - rho_A w^2 + i w / Y(k) = 0, solved by Newton's
/// method from about the bare beam's k. A beam whose bare wave is faster than
/// the board's (k under kp) sheds it into the board as it goes (a leaky
/// wave); one slower keeps it but for the loss factor, taken by both as a
/// complex stiffness. None when the board overwhelms the beam: every root
/// decays within a radian of travel (a light bridge on a heavy board, low
/// down), and the board, not the bridge, carries the motion.
pub fn beam_wave(plate: &Plate, ei: f64, rho_a: f64, f_hz: f64) -> Option<BeamWave> {
    let w = 2.0 * PI * f_hz;
    let ei = Complex64::new(ei, ei * plate.loss_factor);
    let bare = (Complex64::new(rho_a * w * w, 0.0) / ei).powf(0.25);
    let line = LineMobility::new(plate, f_hz);
    let balance = |k: Complex64| ei * k.powi(4) - rho_a * w * w + Complex64::i() * w / line.at(k);
    let scale = rho_a * w * w;
    let solve = |start: Complex64| {
        let mut k = start;
        for _ in 0..80 {
            let f = balance(k);
            let h = k * 1e-7;
            let step = f / ((balance(k + h) - f) / h);
            if !step.is_finite() {
                return None;
            }
            k -= step;
            if step.norm() < 1e-13 * k.norm() {
                break;
            }
        }
        // Of the root's two signs, the one travelling outward.
        let k = if k.re < 0.0 { -k } else { k };
        (k.is_finite() && k.im <= 0.0 && balance(k).norm() < 1e-9 * scale).then_some(k)
    };
    [1.0, 0.9, 1.2, 0.7, 1.5]
        .iter()
        .flat_map(|s| [Complex64::new(*s, 0.0), Complex64::new(*s, -0.3 * s)])
        .filter_map(|s| solve(bare * s))
        .filter(|k| -k.im < k.re)
        .min_by(|p, q| (-p.im / p.re).total_cmp(&(-q.im / q.re)))
        .map(|k| BeamWave { k, scale: 1.0 / (ei * k.powi(3)) })
}

/// The transfer across the board from a driven point to one `distance_m`
/// away at `f_hz`, over the driven point's own: the infinite plate's
/// J0(x) - i (Y0(x) + (2/pi) K0(x)), x = kp r (Cremer & Heckl's point-driven
/// plate; its real part, J0, is the correlation of a diffuse field, so the
/// real parts between any points form a positive semi-definite matrix), its
/// decay by the loss factor, e^(Im kp r), a positive-definite factor too.
pub fn across_plate(plate: &Plate, distance_m: f64, f_hz: f64) -> Complex64 {
    let kp = plate_wavenumber(plate, f_hz);
    let r = distance_m.abs();
    let (j0, y0, k0) = bessel_zero(kp.re * r);
    Complex64::new(j0, -(y0 + 2.0 / PI * k0)) * (kp.im * r).exp()
}

/// The Bessel functions J0, Y0 and K0 at x >= 0. At x = 0, where Y0 and K0
/// are infinite but Y0 + (2/pi) K0 -> 0, they are given as (1, 0, 0). Power
/// series (Abramowitz & Stegun 9.1.12-13, 9.6.12-13) up to x = 25, where they
/// still hold 1e-9; beyond, Hankel's asymptotic series (9.2.5-10, two terms)
/// and K0 ~ 0 (under 1e-11).
fn bessel_zero(x: f64) -> (f64, f64, f64) {
    const GAMMA: f64 = 0.577_215_664_901_532_9;
    if x <= 0.0 {
        return (1.0, 0.0, 0.0);
    }
    if x <= 25.0 {
        let q = 0.25 * x * x;
        let (mut term, mut harmonic) = (1.0, 0.0);
        let (mut j0, mut i0, mut yj, mut ki) = (1.0, 1.0, 0.0, 0.0);
        for k in 1..200 {
            let kf = k as f64;
            term *= q / (kf * kf);
            harmonic += 1.0 / kf;
            let sign = if k % 2 == 0 { 1.0 } else { -1.0 };
            j0 += sign * term;
            i0 += term;
            yj -= sign * harmonic * term;
            ki += harmonic * term;
            if term < 1e-17 * i0 {
                break;
            }
        }
        let log = (0.5 * x).ln() + GAMMA;
        let y0 = 2.0 / PI * (log * j0 + yj);
        let k0 = -log * i0 + ki;
        return (j0, y0, k0);
    }
    let (p, q) = (1.0 - 9.0 / (128.0 * x * x), -1.0 / (8.0 * x));
    let (phase, size) = (x - PI / 4.0, (2.0 / (PI * x)).sqrt());
    (size * (p * phase.cos() - q * phase.sin()), size * (p * phase.sin() + q * phase.cos()), 0.0)
}

/// Geometric mean of |Y| over a band (`points` log-spaced samples), s/kg.
pub fn log_mean_abs_mobility(
    plate: &Plate,
    modes: &[BodyMode],
    max_hz: f64,
    point: (f64, f64),
    band_hz: (f64, f64),
    points: usize,
) -> f64 {
    let ratio = band_hz.1 / band_hz.0;
    let sum: f64 = (0..points)
        .map(|j| {
            let f = band_hz.0 * ratio.powf((j as f64 + 0.5) / points as f64);
            let (re, im) = mobility(plate, modes, max_hz, point, f);
            re.hypot(im).max(1e-12).ln()
        })
        .sum();
    (sum / points as f64).exp()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn spruce() -> Wood {
        Wood { density_kg_m3: 420.0, e_along_pa: 9.05e9, e_across_pa: 0.817e9, shear_pa: 1.196e9, poisson_along: 0.438 }
    }

    fn bare(boundary: Boundary) -> Plate {
        Plate {
            length_m: 1.0,
            width_m: 0.7,
            thickness_m: 0.008,
            wood: spruce(),
            ribs: None,
            boundary,
            loss_factor: 0.02,
            bridge_mass_kg: 0.0,
        }
    }

    #[test]
    fn simply_supported_frequencies_follow_the_closed_form() {
        let p = bare(Boundary::SimplySupported);
        let d = p.stiffness();
        for (m, n) in [(1u32, 1u32), (2, 3), (5, 1)] {
            let (mf, nf) = (f64::from(m), f64::from(n));
            let w = PI * PI / p.mass_per_area().sqrt()
                * (d.d1 * (mf / 1.0).powi(4) + 2.0 * d.d3 * (mf * nf / 0.7).powi(2) + d.d2 * (nf / 0.7).powi(4)).sqrt();
            assert!((p.mode_frequency_hz(m, n) / (w / (2.0 * PI)) - 1.0).abs() < 1e-12);
        }
    }

    #[test]
    fn clamped_modes_lie_above_simply_supported_ones() {
        let (ss, cl) = (bare(Boundary::SimplySupported), bare(Boundary::Clamped));
        let r = cl.mode_frequency_hz(1, 1) / ss.mode_frequency_hz(1, 1);
        // A clamped square isotropic plate's first mode is 1.83 times the simply
        // supported one (Leissa); an orthotropic rectangle lands nearby.
        assert!((1.6..2.4).contains(&r), "{r}");
    }

    #[test]
    fn modes_are_sorted_and_complete() {
        let p = bare(Boundary::SimplySupported);
        let list = modes(&p, 2000.0);
        assert!(list.windows(2).all(|w| w[0].frequency_hz <= w[1].frequency_hz));
        assert!(list.iter().all(|m| m.frequency_hz <= 2000.0));
        let brute = (1..200)
            .flat_map(|m| (1..200).map(move |n| (m, n)))
            .filter(|&(m, n)| p.mode_frequency_hz(m, n) <= 2000.0)
            .count();
        assert_eq!(list.len(), brute);
    }

    #[test]
    fn ribs_stiffen_across_the_grain_only_and_add_mass() {
        let mut p = bare(Boundary::Clamped);
        let before = p.stiffness();
        p.ribs = Some(Ribs { spacing_m: 0.15, width_m: 0.025, depth_m: 0.02, e_pa: 9.05e9, density_kg_m3: 420.0 });
        let after = p.stiffness();
        assert_eq!(before.d1, after.d1);
        assert!(after.d2 > 10.0 * before.d2);
        // The T-section's stiffness is at least that of the rib bending about its
        // own centroid plus the panel strip: parallel-axis terms only add.
        let lower = before.d2 + 9.05e9 * 0.025 * 0.02f64.powi(3) / 12.0 / 0.15;
        assert!(after.d2 > lower);
        assert!((p.mass_per_area() - 420.0 * (0.008 + 0.025 * 0.02 / 0.15)).abs() < 1e-9);
    }

    #[test]
    fn isotropic_skudrzyk_identity_holds() {
        // n/(4M) = 1/(8 sqrt(D rho h)) for the same D.
        let p = bare(Boundary::SimplySupported);
        let y = modal_density(&p, 500.0) / (4.0 * p.mass_kg());
        assert!((y / mean_mobility(&p) - 1.0).abs() < 1e-12);
    }

    #[test]
    fn the_residual_is_a_spring_below_and_the_mean_above() {
        let p = bare(Boundary::SimplySupported);
        let (re_lo, im_lo) = residual_mobility(&p, 2000.0, 200.0);
        assert!(im_lo > 0.0 && re_lo.abs() < 0.05 * im_lo, "{re_lo} {im_lo}");
        let (re_hi, _) = residual_mobility(&p, 2000.0, 8000.0);
        assert!((re_hi / mean_mobility(&p) - 1.0).abs() < 0.1, "{re_hi}");
    }

    /// Whether a real symmetric matrix is positive semi-definite, to `tol`
    /// of its largest diagonal term (it has a Cholesky factor once shifted
    /// by that much).
    fn semi_definite(m: &[Vec<f64>], tol: f64) -> bool {
        let n = m.len();
        let shift = tol * m.iter().enumerate().map(|(i, r)| r[i]).fold(0.0, f64::max);
        let shifted = nalgebra::DMatrix::from_fn(n, n, |i, j| m[i][j] + if i == j { shift } else { 0.0 });
        shifted.cholesky().is_some()
    }

    #[test]
    fn a_line_driven_plate_takes_cremer_and_heckls_mobility() {
        // An infinite plate driven along a line (no trace wave): Y' = (1 - i)
        // / (4 rho h c_B) per metre, c_B = w / kp (Cremer & Heckl, line force).
        let mut plate = bare(Boundary::Clamped);
        plate.loss_factor = 0.0;
        for f in [100.0, 1000.0, 5000.0] {
            let w = 2.0 * PI * f;
            let kp = (w * w * plate.mass_per_area() / plate.mean_stiffness()).powf(0.25);
            let expected = Complex64::new(1.0, -1.0) * kp / (4.0 * plate.mass_per_area() * w);
            let y = line_mobility(&plate, Complex64::new(0.0, 0.0), f);
            assert!((y / expected - 1.0).norm() < 1e-9, "{f} Hz: {y} against {expected}");
            // A trace wave slower than the plate's own makes only a near field:
            // it takes no power.
            assert!(line_mobility(&plate, Complex64::new(1.5 * kp, 0.0), f).re.abs() < 1e-12 * y.norm());
        }
    }

    #[test]
    fn a_bridge_on_the_board_carries_a_wave_that_gives_itself_to_the_board() {
        let plate = bare(Boundary::Clamped);
        // A 40 mm maple bridge.
        let (area, e, rho) = (0.04 * 0.04, 12.6e9, 705.0);
        let (ei, rho_a) = (e * area * area / 12.0, rho * area);
        for f in [700.0, 1500.0, 4000.0] {
            let w = 2.0 * PI * f;
            let wave = beam_wave(&plate, ei, rho_a, f).unwrap();
            let k = wave.k;
            let balance = Complex64::new(ei, ei * plate.loss_factor) * k.powi(4) - rho_a * w * w
                + Complex64::i() * w / line_mobility(&plate, k, f);
            assert!(balance.norm() < 1e-8 * rho_a * w * w, "{f} Hz: {balance}");
            // Faster than the board's own wave: it sheds itself as it goes.
            let bare_k = (rho_a * w * w / ei).powf(0.25);
            assert!(bare_k < plate_wavenumber(&plate, f).re);
            assert!(k.im < 0.0 && (k.re / bare_k - 1.0).abs() < 0.3, "{f} Hz: {k} against {bare_k}");
            // From the driven point outward it falls at e^(Im k x) once the
            // near field has gone.
            assert!((wave.transfer(0.0).re - 1.0).abs() < 1e-12);
            let far = wave.transfer(1.5).norm() / wave.transfer(1.0).norm();
            assert!((far / (0.5 * k.im).exp() - 1.0).abs() < 0.02, "{f} Hz: {far}");
        }
        // A bridge over a board it outweighs keeps its own wave.
        let feather = Plate { thickness_m: 0.0005, ..bare(Boundary::Clamped) };
        let k = beam_wave(&feather, ei, rho_a, 1000.0).unwrap().k;
        let bare_k = (rho_a * (2.0 * PI * 1000.0f64).powi(2) / ei).powf(0.25);
        assert!((k.re / bare_k - 1.0).abs() < 0.05, "{k} against {bare_k}");
    }

    #[test]
    fn bessel_functions_of_order_zero_take_their_tabulated_values() {
        // Abramowitz & Stegun, tables 9.1 and 9.8 (K0 as e^x K0 there).
        for (x, j0, y0, k0) in [
            (1.0, 0.765_197_686_6, 0.088_256_964_2, 0.421_024_438_2),
            (5.0, -0.177_596_771_3, -0.308_517_625_2, 0.003_691_098_3),
            (10.0, -0.245_935_764_5, 0.055_671_167_3, 1.778_006_232e-5),
        ] {
            let (a, b, c) = bessel_zero(x);
            assert!((a - j0).abs() < 1e-9 && (b - y0).abs() < 1e-9 && (c - k0).abs() < 1e-9, "{x}: {a} {b} {c}");
        }
        // Series and asymptote meet.
        let (lo, hi) = (bessel_zero(25.0), bessel_zero(25.000_001));
        assert!((lo.0 - hi.0).abs() < 1e-6 && (lo.1 - hi.1).abs() < 1e-6, "{lo:?} {hi:?}");
        // The transfer across the plate starts at the drive point's own.
        assert!((across_plate(&bare(Boundary::Clamped), 1e-9, 500.0) - 1.0).norm() < 1e-6);
    }

    #[test]
    fn the_direct_field_between_points_is_passive() {
        // The transfers between n points form a matrix whose real (Hermitian)
        // part must be positive semi-definite: no set of forces may draw
        // power out of the board. Along a bridge, and across the plate.
        let plate = bare(Boundary::Clamped);
        let (ei, rho_a) = (12.6e9 * 0.04f64.powi(4) / 12.0, 705.0 * 0.0016);
        let along: Vec<f64> = (0..24).map(|i| 0.014 * i as f64).collect();
        let across: Vec<(f64, f64)> = (0..20).map(|i| (0.05 * i as f64, 0.3 * (0.7 * i as f64).sin())).collect();
        for f in [150.0, 700.0, 1500.0, 4000.0] {
            if let Some(wave) = beam_wave(&plate, ei, rho_a, f) {
                let m: Vec<Vec<f64>> =
                    along.iter().map(|x| along.iter().map(|y| wave.transfer(x - y).re).collect()).collect();
                assert!(semi_definite(&m, 1e-9), "{f} Hz along the bridge");
            }
            let m: Vec<Vec<f64>> = across
                .iter()
                .map(|p| across.iter().map(|q| across_plate(&plate, (p.0 - q.0).hypot(p.1 - q.1), f).re).collect())
                .collect();
            assert!(semi_definite(&m, 1e-9), "{f} Hz across the plate");
        }
    }
}
