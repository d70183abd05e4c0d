//! Filming a strike: the string's shape over time with the hammer and the struck
//! point, for the seed's animations (Euphonics 12.2, Figs. 2, 23-25 and 32).
//!
//! The case is run on the same [`StruckString`] the lab and the instrument use;
//! every sample's state is available, and `frames` of them, equally spaced in
//! time, are kept. A hammer is filmed until it has been thrown clear of the
//! string (flying away, out of contact, further from the string than the
//! string's largest excursion so far), then a tenth as long again: just long
//! enough to see it thrown off, as the seed's animations end. A tangent or a
//! pluck is filmed for a given number of periods of the string.

use crate::strike::case::{ExciterSpec, StrikeCase};
use struck_engine::struck_string::{DEFAULT_SUBSTEPS, StruckString};

/// Points along the string in each frame.
pub const SHAPE_POINTS: usize = 161;
/// Longest film, s (a hammer that never leaves).
pub const MAX_FILM_S: f64 = 0.2;

/// One frame.
#[derive(Clone, Debug, PartialEq)]
pub struct FilmFrame {
    pub time_s: f64,
    /// Displacement at [`SHAPE_POINTS`] equally spaced points from the bridge
    /// (x = 0) to the far end, m.
    pub shape_m: Vec<f64>,
    /// The hammer's (or tangent's) position, m; None for a pluck.
    pub exciter_m: Option<f64>,
    /// The string's displacement at the struck point, m.
    pub struck_point_m: f64,
}

/// A filmed strike.
#[derive(Clone, Debug, PartialEq)]
pub struct Film {
    pub length_m: f64,
    /// Where the exciter acts, m from the bridge (the far end for a tangent).
    pub exciter_x_m: f64,
    /// Period of the string's first partial, s.
    pub period_s: f64,
    pub frames: Vec<FilmFrame>,
}

/// Film `case` in `frames` frames (at least 2). A tangent or a pluck is filmed
/// for `periods` periods of the string.
pub fn film(case: &StrikeCase, frames: usize, periods: f64) -> Film {
    let string = case.build_string();
    let fs = case.sample_rate_hz;
    let period_s = 1.0 / string.partial_hz(1);
    let length_m = string.length_m;
    let mut s = StruckString::new(string, fs, DEFAULT_SUBSTEPS);
    let exciter_x_m = match case.exciter {
        ExciterSpec::Hammer(h) => {
            s.strike(h);
            h.position * length_m
        }
        ExciterSpec::Tangent(t) => {
            s.press_tangent(t);
            length_m
        }
        ExciterSpec::Pluck(p) => {
            s.pluck(p);
            p.position * length_m
        }
    };
    let is_hammer = matches!(case.exciter, ExciterSpec::Hammer(_));
    let max_rows = (MAX_FILM_S * fs).ceil() as usize;
    let fixed_rows = ((periods * period_s * fs).ceil() as usize).clamp(2, max_rows);
    let mut shape = vec![0f32; SHAPE_POINTS];
    let mut all: Vec<FilmFrame> = Vec::new();
    let mut excursion_m: f64 = 0.0;
    let mut clear_at: Option<usize> = None;
    let mut tick = s.current();
    for row in 0..max_rows {
        if row > 0 {
            tick = s.tick();
        }
        s.shape_m(&mut shape);
        excursion_m = shape.iter().fold(excursion_m, |m, &y| m.max(y.abs() as f64));
        all.push(FilmFrame {
            time_s: row as f64 / fs,
            shape_m: shape.iter().map(|&y| y as f64).collect(),
            exciter_m: tick.exciter_position_m,
            struck_point_m: tick.string_position_m,
        });
        if is_hammer {
            if clear_at.is_none() && row >= 2 && s.hammer_gone(excursion_m, 0.0) {
                clear_at = Some(row);
            }
            if let Some(clear) = clear_at
                && row >= clear + (clear / 10).max(2)
            {
                break;
            }
        } else if row + 1 >= fixed_rows {
            break;
        }
    }
    let frames = frames.max(2);
    let picked = if all.len() <= frames {
        all
    } else {
        let last = all.len() - 1;
        (0..frames).map(|i| all[i * last / (frames - 1)].clone()).collect()
    };
    Film { length_m, exciter_x_m, period_s, frames: picked }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::strike::seed;

    #[test]
    fn the_santoor_film_ends_with_the_mallet_thrown_clear() {
        let case = seed::santoor_mallet(1e-3, 0.4, 96_000.0, 0.5);
        let f = film(&case, 100, 0.0);
        assert_eq!(f.frames.len(), 100);
        let last = f.frames.last().unwrap();
        // Contact lasts about 2.3 ms; the film stops soon after, hammer below the string.
        assert!(last.time_s > 2.3e-3 && last.time_s < 10e-3, "{}", last.time_s);
        assert!(last.exciter_m.unwrap() < last.struck_point_m);
        // The string is moving: the largest excursion is a good fraction of a mm
        // and the struck point of the shape matches the contact point's reading.
        let mid = &f.frames[50];
        let j = (0.4 * (SHAPE_POINTS - 1) as f64).round() as usize;
        assert!(mid.shape_m[j].abs() > 1e-5);
        assert!((mid.shape_m[j] - mid.struck_point_m).abs() < 0.1 * mid.struck_point_m.abs() + 1e-6);
        // Both ends stay pinned.
        assert!(f.frames.iter().all(|fr| fr.shape_m[0] == 0.0 && fr.shape_m[SHAPE_POINTS - 1].abs() < 1e-9));
    }

    #[test]
    fn a_tangent_film_runs_its_periods_and_lifts_the_far_end() {
        let case = seed::clavichord_case(0.5, 48_000.0, 1.0);
        let f = film(&case, 60, 2.0);
        let last = f.frames.last().unwrap();
        assert!((last.time_s - 2.0 * f.period_s).abs() < 2.0 / 48_000.0, "{}", last.time_s);
        let end = *last.shape_m.last().unwrap();
        assert!(end > 1.5e-3 && end <= 2.0e-3, "{end}");
        assert_eq!(f.exciter_x_m, f.length_m);
    }
}
