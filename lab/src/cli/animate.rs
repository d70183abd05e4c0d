//! `struck animate CASE.json --out FILE.gif`: the string's shape over time, the
//! vertical scale exaggerated, the hammer as a red star and the struck point as
//! a green star, until the hammer is thrown clear (the seed's Figs. 2, 23-25;
//! a tangent or a pluck for a few periods, as Fig. 32).

use std::path::{Path, PathBuf};

use crate::strike::film::{self, SHAPE_POINTS};
use crate::strike::{ExciterSpec, StrikeCase};

use crate::cli::Failure;
use crate::cli::chart::read_case;
use crate::console;
use crate::plot::{Animation, AnimationFrame};

/// Most frames accepted.
pub const MAX_FRAMES: usize = 1000;
/// How long an animation plays, s (whatever the time it shows).
const PLAY_S: f64 = 6.0;

#[derive(clap::Args)]
pub struct AnimateArgs {
    /// The strike case (JSON).
    pub case: PathBuf,
    /// The GIF to write.
    #[arg(long, value_name = "FILE.gif")]
    pub out: PathBuf,
    /// Change one field of the case first, e.g. --set exciter.mass_kg=0.003 (repeatable).
    #[arg(long = "set", value_name = "PATH=VALUE")]
    pub sets: Vec<String>,
    /// Frames in the animation.
    #[arg(long, default_value_t = 120, value_name = "N")]
    pub frames: usize,
    /// For a tangent or a pluck: how many periods of the string to show.
    #[arg(long, default_value_t = 2.0, value_name = "P", allow_negative_numbers = true)]
    pub periods: f64,
}

/// How a film is drawn.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct FilmOptions {
    pub frames: usize,
}

/// Film `case` and draw it as a GIF at `gif`.
pub fn draw_film(
    case: &StrikeCase,
    periods: f64,
    title: &str,
    options: &FilmOptions,
    gif: &Path,
) -> anyhow::Result<()> {
    let film = film::film(case, options.frames, periods);
    let xs: Vec<f64> = (0..SHAPE_POINTS).map(|j| film.length_m * j as f64 / (SHAPE_POINTS - 1) as f64).collect();
    let is_tangent = matches!(case.exciter, ExciterSpec::Tangent(_));
    // Drawn as the seed draws them: a hammer comes down onto the string (the lab's
    // +y, the push, is down on the screen); a tangent rises from below.
    let sign = if is_tangent { 1.0 } else { -1.0 };
    let frames: Vec<AnimationFrame> = film
        .frames
        .iter()
        .map(|f| AnimationFrame {
            time_s: f.time_s,
            string_x_m: xs.clone(),
            string_y_m: f.shape_m.iter().map(|y| sign * y).collect(),
            hammer: if is_tangent { None } else { f.exciter_m.map(|y| (film.exciter_x_m, sign * y)) },
            struck_point: Some((film.exciter_x_m, sign * f.struck_point_m)),
        })
        .collect();
    // The scale is the string's: a hammer pressing far into its felt, or flying
    // off, leaves the picture (as in the seed's Fig. 25).
    let (low, high) = frames
        .iter()
        .flat_map(|f| f.string_y_m.iter().copied().chain(f.struck_point.map(|p| p.1)))
        .fold((0.0f64, 0.0f64), |(l, h), y| (l.min(y), h.max(y)));
    let pad = 0.25 * (high - low).max(1e-9);
    let count = frames.len().max(1) as f64;
    let animation = Animation {
        frame_delay_ms: ((PLAY_S * 1e3 / count).round() as u32).clamp(20, 500),
        y_label: "displacement (mm, exaggerated)".into(),
        y_range_m: Some((low - pad, high + pad)),
        ..Animation::new(title, frames)
    };
    animation.draw_gif(gif)?;
    Ok(())
}

pub fn run(args: &AnimateArgs) -> Result<(), Failure> {
    let case = read_case(&args.case, &args.sets)?;
    if !(2..=MAX_FRAMES).contains(&args.frames) {
        return Err(Failure::bad_input(format!("--frames: must lie between 2 and {MAX_FRAMES} (got {})", args.frames)));
    }
    if !(args.periods.is_finite() && args.periods > 0.0 && args.periods <= 100.0) {
        return Err(Failure::bad_input(format!(
            "--periods: must lie above 0 and at most 100 (got {})",
            struck_engine::readable(args.periods)
        )));
    }
    super::output::check_writable(&args.out, &[args.case.as_path()])?;
    let title = case.name.clone().unwrap_or_else(|| args.case.display().to_string());
    // Drawn beside --out and put there once whole (folders made for it are
    // removed if it fails).
    let mut staged = super::output::Staged::reading(&[args.case.as_path()]);
    staged.write_at(&args.out, |gif| {
        draw_film(&case, args.periods, &title, &FilmOptions { frames: args.frames }, gif)
            .map_err(|e| std::io::Error::other(format!("{e:#}")))
    })?;
    staged.commit()?;
    console::out(format!("wrote {}", super::shown(&args.out)));
    Ok(())
}
