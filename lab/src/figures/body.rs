//! `struck chart body`: an instrument's body as the engine builds it. The
//! board's drive-point mobility at three keys' bridge points against the
//! published measurements, how the two microphones hear a newton there, and
//! how many modes the board has (all of them, and those the running body
//! carries).

use std::path::Path;

use struck_engine::body::boards;
use struck_engine::body::plate::{self, BodyMode};
use struck_engine::body::soundboard::{BODY_TOP_HZ, HeardModes, MicPlacement};
use struck_engine::design::InstrumentKind;

use super::{Drawn, draw_line, plot};
use crate::plot::{Colour, Corner, MarkerShape, Scale, Series};

/// The mobility is charted up to here, Hz (the published measurements reach 10 kHz).
const TOP_HZ: f64 = 10_000.0;

/// Log-spaced frequencies from `low` to `high`, `per_octave` a octave.
fn sweep(low: f64, high: f64, per_octave: usize) -> Vec<f64> {
    let steps = ((high / low).log2() * per_octave as f64).ceil() as usize;
    (0..=steps).map(|i| low * (high / low).powf(i as f64 / steps as f64)).collect()
}

/// The three charts for `kind` in `dir`.
pub fn body(kind: InstrumentKind, dir: &Path) -> anyhow::Result<Vec<Drawn>> {
    let board = boards::design(kind);
    let name = kind.name();
    let all = board.modes(TOP_HZ);
    let range = kind.key_range();
    let keys = [*range.start(), board.middle_key(), *range.end()];
    let colours = [Colour::BLUE, Colour::GREEN, Colour::MAGENTA];
    let frequencies = sweep(20.0, TOP_HZ, 48);
    let mut drawn = Vec::new();

    // 1. Drive-point mobility |Y| at three keys' bridge points.
    let mut series = Vec::new();
    for (key, colour) in keys.into_iter().zip(colours) {
        let points = frequencies
            .iter()
            .map(|&f| {
                let (re, im) = board.bridge_mobility(&all, TOP_HZ, key, f);
                (f, re.hypot(im))
            })
            .collect();
        series.push(Series::line(format!("|Y| at key {key}'s bridge point"), colour, points));
    }
    let mean = plate::mean_mobility(&board.plate);
    series.push(Series::line(
        format!("Skudrzyk mean n/(4M) = {mean:.2e} s/kg"),
        Colour::BLACK,
        vec![(20.0, mean), (TOP_HZ, mean)],
    ));
    if kind == InstrumentKind::Piano {
        series.push(wogram_points());
    }
    let mut p =
        plot(format!("{name}: bridge mobility, {} modes to 10 kHz", all.len()), "frequency (Hz)", "|Y| (s/kg)", series);
    p.x_scale = Scale::Log;
    p.y_scale = Scale::Log;
    p.legend = Corner::LowerRight;
    drawn.push(draw_line(&p, dir, &format!("body-{name}-mobility"))?);

    // 2. What the microphones hear of a newton at the middle key's bridge point.
    let mics = MicPlacement::default().positions(&board);
    let heard = HeardModes::new(&board, BODY_TOP_HZ, mics);
    let point = board.bridge_point(board.middle_key());
    let mut left = Vec::new();
    let mut right = Vec::new();
    for &f in &frequencies {
        let [l, r] = heard.transfer_pa_per_n(point, f);
        left.push((f, 20.0 * l.norm().max(1e-12).log10()));
        right.push((f, 20.0 * r.norm().max(1e-12).log10()));
    }
    let mut p = plot(
        format!("{name}: the microphones (close) per newton at key {}'s bridge point", board.middle_key()),
        "frequency (Hz)",
        "pressure per force (dB re 1 Pa/N)",
        vec![Series::line("left", Colour::BLUE, left), Series::line("right", Colour::RED, right)],
    );
    p.x_scale = Scale::Log;
    drawn.push(draw_line(&p, dir, &format!("body-{name}-microphones"))?);

    // 3. Mode count: the board's and the running body's.
    let running = board.running_modes(BODY_TOP_HZ);
    let count = |modes: &[BodyMode]| -> Vec<(f64, f64)> {
        modes.iter().enumerate().map(|(i, m)| (m.frequency_hz, (i + 1) as f64)).collect()
    };
    let density = plate::modal_density(&board.plate, 500.0);
    let mut p = plot(
        format!("{name}: modes below f (board: {density:.3} /Hz; running body: {} modes)", running.len()),
        "frequency (Hz)",
        "modes below",
        vec![
            Series::line("the board's modes", Colour::BLUE, count(&all)),
            Series::line("the running body's", Colour::RED, count(&running)),
        ],
    );
    p.x_scale = Scale::Log;
    p.y_scale = Scale::Log;
    p.legend = Corner::UpperLeft;
    drawn.push(draw_line(&p, dir, &format!("body-{name}-modes"))?);
    Ok(drawn)
}

/// Wogram's input impedance of an upright's bridge (KTH, five lectures on the
/// acoustics of the piano) as mobility 1/Z: about 1000 kg/s at 100 Hz, a
/// continual fall, then 6 dB an octave from 1 kHz to 10 kg/s at 10 kHz.
fn wogram_points() -> Series {
    Series::markers(
        "Wogram, upright (1/Z)",
        Colour::RED,
        MarkerShape::Star,
        vec![(100.0, 1e-3), (1000.0, 1e-2), (10_000.0, 0.1)],
    )
}
