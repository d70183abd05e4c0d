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
//! with Gx = m, Hx = m^2 for simply supported edges (the brief's formula
//! omega = pi^2/sqrt(rho h) sqrt(D1 (m/a)^4 + 2 D3 (mn/ab)^2 + D2 (n/b)^4)), and
//! for clamped edges G = 1.506 (first mode) or m + 1/2, H = G^2 (1 - 2/(G pi)).
//! Mode shapes are sin(m pi x) sin(n pi y) with unit peak for both boundaries
//! (exact for simply supported; for clamped the beam functions are replaced by
//! the same sines, an approximation that keeps the drive-point mean and the
//! modal mass M/4). Ege & Boutillon (arXiv:1210.5688) found the upright board
//! behaves as a *clamped* homogeneous plate below 1.1 kHz, so the instruments use
//! `Boundary::Clamped`; `Boundary::SimplySupported` is the closed form.

use std::f64::consts::PI;

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
    /// Half-waves along x (0 marks the air mode, see `instruments`).
    pub m: u32,
    /// Half-waves along y (0 marks the air mode).
    pub n: u32,
}

impl BodyMode {
    /// True for the Helmholtz air mode, which is not a plate mode.
    pub fn is_air(&self) -> bool {
        self.m == 0 || self.n == 0
    }
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
    let modal_mass_kg = plate.mass_kg() / 4.0;
    let mut out = Vec::new();
    let mut m = 1;
    while plate.mode_frequency_hz(m, 1) <= max_hz {
        let mut n = 1;
        loop {
            let frequency_hz = plate.mode_frequency_hz(m, n);
            if frequency_hz > max_hz {
                break;
            }
            out.push(BodyMode { frequency_hz, loss_factor: plate.loss_factor, modal_mass_kg, m, n });
            n += 1;
        }
        m += 1;
    }
    out.sort_by(|p, q| p.frequency_hz.total_cmp(&q.frequency_hz));
    out
}

/// Mode shape at (x, y), fractions of the sides: sin(m pi x) sin(n pi y). The
/// air mode (m = n = 0) couples through the top's net volume motion, so it takes
/// the shape of the plate's (1, 1) mode.
pub fn shape_at(mode: &BodyMode, x: f64, y: f64) -> f64 {
    let (m, n) = if mode.is_air() { (1, 1) } else { (mode.m, mode.n) };
    (f64::from(m) * PI * x).sin() * (f64::from(n) * PI * y).sin()
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
    let (mut re, mut im) = (0.0, 0.0);
    for j in 0..steps {
        let fk = from_hz * ((j as f64 + 0.5) * dl).exp();
        let weight = 4.0 * skeleton_mobility(plate, fk) * fk * dl; // per-Hz weight times df
        let (r, i) = modal_term(weight, 2.0 * PI * fk, plate.loss_factor, w);
        re += r;
        im += i;
    }
    let tail = 4.0 * skeleton_mobility(plate, top_hz) * w / (4.0 * PI * PI * top_hz);
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
    let low = mean_mobility(plate);
    match plate.inter_rib_hz() {
        Some(fr) if f_hz > fr => low + (inter_rib_mobility(plate) - low) * (1.0 - (fr / f_hz).powi(2)),
        _ => low,
    }
}

/// Asymptotic modal density of the smeared plate, modes per Hz:
/// n = (S/2) sqrt(rho h / D), D = sqrt(D1 D2) (Cremer & Heckl's thin-plate result
/// with the geometric-mean stiffness). Independent of frequency; the boundary
/// only shifts the count by a term growing as sqrt(f) (clamped: fewer modes).
pub fn modal_density(plate: &Plate, _f_hz: f64) -> f64 {
    0.5 * plate.area_m2() * (plate.mass_per_area() / plate.mean_stiffness()).sqrt()
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
}
