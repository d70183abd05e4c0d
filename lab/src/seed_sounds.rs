//! The seed's Sounds 1-12 (Euphonics 12.2): bridge force, rendered by the lab.
//!
//! Each sound is one or more strikes played one after another, each for a fixed
//! time and faded out over its last 30 ms. The bridge force is what is heard, as
//! in the seed (there is no soundboard); a 5 Hz high-pass takes away the static
//! push of a tangent or a hammer resting on the string, which a loudspeaker
//! could not play. A file's loudest sample is set to -1 dBFS and every strike in
//! it keeps its level relative to the others (Sound 7's first note is meant to be
//! barely audible; Sound 12 is quiet clavichord, louder clavichord, harpsichord).

use crate::strike::seed::{self, boutillon_speeds};
use crate::strike::{self, StrikeCase};
use rayon::prelude::*;

/// Sample rate of the sounds, Hz.
pub const SOUND_RATE_HZ: f64 = 48_000.0;
/// Peak of each file: -1 dBFS.
const PEAK: f64 = 0.891_250_938;
/// Fade at the end of each strike, s.
const FADE_S: f64 = 0.03;
/// Corner of the high-pass, Hz.
const HIGH_PASS_HZ: f64 = 5.0;

/// One of the seed's sounds.
pub struct Sound {
    pub number: u8,
    /// File name, e.g. "sound01-santoor-1g-at-2-5.wav".
    pub file: String,
    /// What it is, for the index page.
    pub caption: String,
    /// The strikes, in order; each lasts its case's duration.
    pub strikes: Vec<StrikeCase>,
}

fn sound(number: u8, slug: &str, caption: impl Into<String>, strikes: Vec<StrikeCase>) -> Sound {
    Sound { number, file: format!("sound{number:02}-{slug}.wav"), caption: caption.into(), strikes }
}

/// Sounds 1 to 12.
pub fn sounds() -> Vec<Sound> {
    let fs = SOUND_RATE_HZ;
    let santoor_s = 2.0;
    let piano_s = 2.5;
    let speeds = boutillon_speeds();
    let speed_list = speeds.iter().map(|v| format!("{v:.2}")).collect::<Vec<_>>().join(", ");
    let c2_at = |hammer: u8| -> Vec<StrikeCase> {
        speeds.iter().map(|&v| seed::piano_c_case(2, hammer, v, true, fs, 2.0)).collect()
    };
    let c1_to_c6 = |inharmonic: bool| -> Vec<StrikeCase> {
        (1..=6).map(|o| seed::piano_c_case(o, 4, seed::PIANO_MEZZO_SPEED_M_S, inharmonic, fs, piano_s)).collect()
    };
    let [quiet, typical, _] = seed::CLAVICHORD_SPEEDS_M_S;
    vec![
        sound(
            1,
            "santoor-1g-at-2-5",
            "Santoor string (steel, 0.5 mm, 0.4 m, 440 Hz, Q 1000) struck at 2/5 of its length by a 1 g mallet at 1 m/s.",
            vec![seed::santoor_mallet(1e-3, 0.4, fs, santoor_s)],
        ),
        sound(
            2,
            "santoor-3g-at-2-5",
            "The same string and place, a 3 g mallet.",
            vec![seed::santoor_mallet(3e-3, 0.4, fs, santoor_s)],
        ),
        sound(
            3,
            "santoor-pluck-at-2-5",
            "The same string plucked at 2/5 (an ideal wire-break pluck, 1 mm high).",
            vec![seed::santoor_pluck(0.4, fs, santoor_s)],
        ),
        sound(
            4,
            "santoor-1g-at-1-10",
            "The 1 g mallet striking at 1/10 of the length, nearer the bridge, as players do.",
            vec![seed::santoor_mallet(1e-3, 0.1, fs, santoor_s)],
        ),
        sound(5, "santoor-pluck-at-1-10", "A pluck at 1/10.", vec![seed::santoor_pluck(0.1, fs, santoor_s)]),
        sound(
            6,
            "piano-c1-c6-c4-hammer",
            "Piano C1 to C6 (the Broadwood's C strings, each course as one string, Q 2000), all with the C4 hammer \
             (9 g, K 4.5e9, alpha 2.5) at 1 m/s.",
            c1_to_c6(true),
        ),
        sound(
            7,
            "piano-c2-c4-hammer-five-speeds",
            format!("C2 with the C4 hammer at {speed_list} m/s (Boutillon's pianissimo to fortissimo)."),
            c2_at(4),
        ),
        sound(
            8,
            "piano-c2-c2-hammer-five-speeds",
            "C2 with its own hammer (11 g, K 4e8, alpha 2.3) at the same five speeds.",
            c2_at(2),
        ),
        sound(
            9,
            "piano-c2-c7-hammer-five-speeds",
            "C2 with the C7 hammer (6 g, K 1e12, alpha 3) at the same five speeds: a hard, fortepiano-like sound.",
            c2_at(7),
        ),
        sound(
            10,
            "piano-c1-c6-harmonic",
            "Sound 6 again with the strings' bending stiffness left out: every partial exactly harmonic.",
            c1_to_c6(false),
        ),
        sound(
            11,
            "piano-c7-three-times",
            "C7 with its own hammer at 1 m/s, three times.",
            (0..3).map(|_| seed::piano_c_case(7, 7, seed::PIANO_MEZZO_SPEED_M_S, true, fs, 1.0)).collect(),
        ),
        sound(
            12,
            "clavichord-and-harpsichord",
            format!(
                "Clavichord D2, tangent at {quiet} m/s then at {typical} m/s (each to 2 mm), then a harpsichord pluck \
                 2 mm high at 1/7.8 on the same string; relative levels kept."
            ),
            vec![
                seed::clavichord_case(quiet, fs, 1.5),
                seed::clavichord_case(typical, fs, 1.5),
                seed::harpsichord_case(fs, 1.5),
            ],
        ),
    ]
}

/// The strikes of `sound` one after another, high-passed and faded, before
/// normalising; and the sample where each strike starts.
pub fn render_raw(sound: &Sound) -> (Vec<f64>, Vec<usize>) {
    let parts: Vec<Vec<f64>> = sound.strikes.par_iter().map(|case| strike::run(case).trace.bridge_force_n).collect();
    let mut out = Vec::with_capacity(parts.iter().map(Vec::len).sum());
    let mut starts = Vec::with_capacity(parts.len());
    let fade = (FADE_S * SOUND_RATE_HZ) as usize;
    for part in parts {
        starts.push(out.len());
        let n = part.len();
        out.extend(part.iter().enumerate().map(|(i, &v)| {
            let left = n - i;
            if left < fade { v * 0.5 * (1.0 - (std::f64::consts::PI * left as f64 / fade as f64).cos()) } else { v }
        }));
    }
    high_pass(&mut out, HIGH_PASS_HZ, SOUND_RATE_HZ);
    (out, starts)
}

/// `sound` as samples at -1 dBFS peak.
pub fn render(sound: &Sound) -> Vec<f32> {
    let (raw, _) = render_raw(sound);
    let peak = raw.iter().fold(0.0f64, |m, v| m.max(v.abs()));
    let gain = if peak > 0.0 { PEAK / peak } else { 1.0 };
    raw.iter().map(|v| (v * gain) as f32).collect()
}

/// A one-pole DC-blocking high-pass, in place.
fn high_pass(signal: &mut [f64], corner_hz: f64, sample_rate_hz: f64) {
    let r = (-2.0 * std::f64::consts::PI * corner_hz / sample_rate_hz).exp();
    let (mut x1, mut y1) = (signal.first().copied().unwrap_or(0.0), 0.0);
    // Start from the first sample's value so a signal that starts off zero does not click.
    for v in signal.iter_mut() {
        let y = *v - x1 + r * y1;
        x1 = *v;
        y1 = y;
        *v = y;
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn there_are_twelve_sounds_in_order_with_distinct_files() {
        let all = sounds();
        assert_eq!(all.iter().map(|s| s.number).collect::<Vec<_>>(), (1..=12).collect::<Vec<_>>());
        let mut files: Vec<_> = all.iter().map(|s| s.file.clone()).collect();
        files.dedup();
        assert_eq!(files.len(), 12);
        assert_eq!(all[5].strikes.len(), 6);
        assert_eq!(all[6].strikes.len(), 5);
        assert_eq!(all[10].strikes.len(), 3);
        assert_eq!(all[11].strikes.len(), 3);
    }

    #[test]
    fn the_high_pass_removes_a_step_and_keeps_a_tone() {
        let fs = SOUND_RATE_HZ;
        let mut step = vec![1.0; fs as usize];
        high_pass(&mut step, HIGH_PASS_HZ, fs);
        assert!(step.last().unwrap().abs() < 1e-3);
        let mut tone: Vec<f64> =
            (0..fs as usize).map(|i| (2.0 * std::f64::consts::PI * 100.0 * i as f64 / fs).sin()).collect();
        high_pass(&mut tone, HIGH_PASS_HZ, fs);
        let peak = tone[fs as usize / 2..].iter().fold(0.0f64, |m, v| m.max(v.abs()));
        assert!((peak - 1.0).abs() < 0.01, "{peak}");
    }
}
