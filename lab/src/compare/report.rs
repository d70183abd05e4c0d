//! Each source's features set against the recording's, note by note, and
//! summed up per feature as the median and 90th percentile of the errors.
//!
//! Ratios (B, decay rates, centroids, fall times) give an error of
//! max(r, 1/r) (1 is perfect); levels give the absolute difference in dB
//! (0 is perfect).

use std::collections::BTreeMap;
use std::io::{self, Write};

use serde::Serialize;

use super::measure::{DECAY_PARTIALS, ENVELOPE_PARTIALS, Features, MIN_DECAY_DB_S, median, quantile};
use super::note_name;
use super::sources::Source;

/// The features compared.
#[derive(Clone, Copy, Debug, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Feature {
    Inharmonicity,
    DecayEarly,
    DecayLate,
    Envelope,
    Centroid,
    CentroidGrowth,
    Dynamics,
    Balance,
    FallTime,
    AttackNoise,
}

impl Feature {
    pub const ALL: [Feature; 10] = [
        Feature::Inharmonicity,
        Feature::DecayEarly,
        Feature::DecayLate,
        Feature::Envelope,
        Feature::Centroid,
        Feature::CentroidGrowth,
        Feature::Dynamics,
        Feature::Balance,
        Feature::FallTime,
        Feature::AttackNoise,
    ];

    pub fn key(self) -> &'static str {
        match self {
            Feature::Inharmonicity => "inharmonicity",
            Feature::DecayEarly => "decay_early",
            Feature::DecayLate => "decay_late",
            Feature::Envelope => "envelope",
            Feature::Centroid => "centroid",
            Feature::CentroidGrowth => "centroid_growth",
            Feature::Dynamics => "dynamics",
            Feature::Balance => "balance",
            Feature::FallTime => "fall_time",
            Feature::AttackNoise => "attack_noise",
        }
    }

    pub fn title(self) -> &'static str {
        match self {
            Feature::Inharmonicity => "F1  inharmonicity B (ratio)",
            Feature::DecayEarly => "F2a decay 0.3-2 s, partials 1-8 (ratio)",
            Feature::DecayLate => "F2b decay 2-6 s, partials 1-8 (ratio)",
            Feature::Envelope => "F3  partials 1-12 re strongest (dB)",
            Feature::Centroid => "F4a centroid 0-0.2 s (ratio)",
            Feature::CentroidGrowth => "F4b centroid growth soft->loud (ratio)",
            Feature::Dynamics => "F5  level re loudest layer (dB)",
            Feature::Balance => "F6  level re keyboard mean (dB)",
            Feature::FallTime => "F7  time to fall 40 dB (ratio)",
            Feature::AttackNoise => "F8  attack noise, first 30 ms (dB)",
        }
    }

    /// Whether the error is a ratio (else a difference in dB).
    pub fn is_ratio(self) -> bool {
        !matches!(self, Feature::Envelope | Feature::Dynamics | Feature::Balance | Feature::AttackNoise)
    }
}

/// One note in one layer: the recording's features and each source's.
#[derive(Clone, Debug, Serialize)]
pub struct Take {
    pub note: String,
    pub key: u8,
    pub layer: u8,
    pub velocity: u8,
    /// Everything is measured below this, Hz (the recording's cutoff, less 10 %).
    pub band_hz: f64,
    /// Seconds of every source measured, from its onset.
    pub measured_s: f64,
    pub recording: Features,
    /// Each compared source: its features, or why it has none.
    #[serde(serialize_with = "features_or_error")]
    pub sources: BTreeMap<Source, Result<Features, String>>,
    /// Each compared source's errors against the recording.
    pub errors: BTreeMap<Source, BTreeMap<Feature, Option<f64>>>,
}

/// A source's features as JSON: the features, or {"error": why}.
fn features_or_error<S: serde::Serializer>(
    sources: &BTreeMap<Source, Result<Features, String>>,
    serializer: S,
) -> Result<S::Ok, S::Error> {
    #[derive(Serialize)]
    #[serde(untagged)]
    enum Shown<'a> {
        Measured(&'a Features),
        Failed { error: &'a str },
    }
    serializer.collect_map(sources.iter().map(|(s, f)| {
        (
            s,
            match f {
                Ok(f) => Shown::Measured(f),
                Err(e) => Shown::Failed { error: e },
            },
        )
    }))
}

/// max(r, 1/r) of two positive values.
pub fn ratio_error(a: f64, b: f64) -> Option<f64> {
    (a > 0.0 && b > 0.0 && a.is_finite() && b.is_finite()).then(|| (a / b).max(b / a))
}

/// The median over partials of the ratio errors of decay rates (each rate
/// taken as at least [`MIN_DECAY_DB_S`]).
pub fn decay_error(source: &[Option<f64>], recording: &[Option<f64>]) -> Option<f64> {
    let errors: Vec<f64> = source
        .iter()
        .zip(recording)
        .filter_map(|(s, r)| ratio_error(s.as_ref()?.max(MIN_DECAY_DB_S), r.as_ref()?.max(MIN_DECAY_DB_S)))
        .collect();
    median(&errors)
}

/// The mean absolute difference of the partials' levels where both have one.
pub fn envelope_error(source: &[Option<f64>], recording: &[Option<f64>]) -> Option<f64> {
    let d: Vec<f64> =
        source.iter().zip(recording).filter_map(|(s, r)| Some((s.as_ref()? - r.as_ref()?).abs())).collect();
    (!d.is_empty()).then(|| d.iter().sum::<f64>() / d.len() as f64)
}

/// The errors of one take that need nothing but its own features.
fn own_errors(source: &Features, recording: &Features) -> BTreeMap<Feature, Option<f64>> {
    let mut e = BTreeMap::new();
    e.insert(
        Feature::Inharmonicity,
        ratio_error(source.inharmonicity.unwrap_or(0.0), recording.inharmonicity.unwrap_or(0.0)),
    );
    e.insert(Feature::DecayEarly, decay_error(&source.decay_early_db_s, &recording.decay_early_db_s));
    e.insert(Feature::DecayLate, decay_error(&source.decay_late_db_s, &recording.decay_late_db_s));
    e.insert(Feature::Envelope, envelope_error(&source.envelope_db, &recording.envelope_db));
    e.insert(Feature::Centroid, ratio_error(source.centroid_hz.unwrap_or(0.0), recording.centroid_hz.unwrap_or(0.0)));
    e.insert(Feature::FallTime, ratio_error(source.fall_time_s.unwrap_or(0.0), recording.fall_time_s.unwrap_or(0.0)));
    e.insert(Feature::AttackNoise, source.attack_noise_db.zip(recording.attack_noise_db).map(|(s, r)| (s - r).abs()));
    e
}

/// Fill every take's errors: its own, then those that compare layers of a
/// note (F4b on the loudest layer's take, F5 on the others') and notes of
/// a layer (F6).
pub fn compare(takes: &mut [Take]) {
    for take in takes.iter_mut() {
        take.errors = take
            .sources
            .iter()
            .map(|(&source, f)| {
                let mut e = match f {
                    Ok(f) => own_errors(f, &take.recording),
                    Err(_) => Feature::ALL.iter().map(|&x| (x, None)).collect(),
                };
                for x in [Feature::CentroidGrowth, Feature::Dynamics, Feature::Balance] {
                    e.insert(x, None);
                }
                (source, e)
            })
            .collect();
    }
    let features = |t: &Take, s: Source| -> Option<Features> {
        if s == Source::Recording { Some(t.recording.clone()) } else { t.sources.get(&s)?.as_ref().ok().cloned() }
    };
    let sources: Vec<Source> = takes
        .iter()
        .flat_map(|t| t.sources.keys().copied())
        .collect::<std::collections::BTreeSet<_>>()
        .into_iter()
        .collect();
    let keys: Vec<u8> = takes.iter().map(|t| t.key).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    let layers: Vec<u8> =
        takes.iter().map(|t| t.layer).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    let find = |takes: &[Take], key: u8, layer: u8| takes.iter().position(|t| t.key == key && t.layer == layer);

    for &source in &sources {
        // F4b and F5: across the layers of each note.
        for &key in &keys {
            let (Some(&soft), Some(&loud)) = (layers.first(), layers.last()) else { continue };
            let (Some(i_soft), Some(i_loud)) = (find(takes, key, soft), find(takes, key, loud)) else { continue };
            if soft != loud {
                let growth = |s: Source| -> Option<f64> {
                    let (a, b) = (features(&takes[i_soft], s)?, features(&takes[i_loud], s)?);
                    Some(b.centroid_hz? / a.centroid_hz?)
                };
                let e = growth(source).zip(growth(Source::Recording)).and_then(|(s, r)| ratio_error(s, r));
                if let Some(errors) = takes[i_loud].errors.get_mut(&source) {
                    errors.insert(Feature::CentroidGrowth, e);
                }
            }
            for &layer in &layers[..layers.len() - 1] {
                let Some(i) = find(takes, key, layer) else { continue };
                let relative = |s: Source| -> Option<f64> {
                    Some(features(&takes[i], s)?.level_db - features(&takes[i_loud], s)?.level_db)
                };
                let e = relative(source).zip(relative(Source::Recording)).map(|(s, r)| (s - r).abs());
                if let Some(errors) = takes[i].errors.get_mut(&source) {
                    errors.insert(Feature::Dynamics, e);
                }
            }
        }
        // F6: across the notes of each layer, over the notes both have.
        for &layer in &layers {
            let both: Vec<(usize, f64, f64)> = takes
                .iter()
                .enumerate()
                .filter(|(_, t)| t.layer == layer)
                .filter_map(|(i, t)| Some((i, features(t, source)?.level_db, t.recording.level_db)))
                .collect();
            if both.len() < 2 {
                continue;
            }
            let mean_s = both.iter().map(|b| b.1).sum::<f64>() / both.len() as f64;
            let mean_r = both.iter().map(|b| b.2).sum::<f64>() / both.len() as f64;
            for (i, s, r) in both {
                if let Some(errors) = takes[i].errors.get_mut(&source) {
                    errors.insert(Feature::Balance, Some(((s - mean_s) - (r - mean_r)).abs()));
                }
            }
        }
    }
}

/// A feature's errors for one source, summed up.
#[derive(Clone, Copy, Debug, Serialize)]
pub struct Summary {
    pub median: Option<f64>,
    pub p90: Option<f64>,
    /// How many errors were measured.
    pub n: usize,
}

/// Every feature's summary for every source.
pub fn summarize(takes: &[Take]) -> BTreeMap<Feature, BTreeMap<Source, Summary>> {
    let mut out = BTreeMap::new();
    for feature in Feature::ALL {
        let mut per = BTreeMap::new();
        for source in Source::COMPARED {
            let values: Vec<f64> = takes.iter().filter_map(|t| *t.errors.get(&source)?.get(&feature)?).collect();
            if takes.iter().any(|t| t.sources.contains_key(&source)) {
                per.insert(source, Summary { median: median(&values), p90: quantile(&values, 0.9), n: values.len() });
            }
        }
        out.insert(feature, per);
    }
    out
}

fn cell(feature: Feature, s: Option<&Summary>) -> String {
    match s {
        Some(Summary { median: Some(m), p90: Some(p), n }) if feature.is_ratio() => format!("{m:.2} [{p:.2}] {n}"),
        Some(Summary { median: Some(m), p90: Some(p), n }) => format!("{m:.1} [{p:.1}] {n}"),
        Some(_) => "-".into(),
        None => "not run".into(),
    }
}

/// The table: features down, sources across, "median [p90] n", each an error
/// against `reference` (what the recordings are: "Yamaha C5").
pub fn table(
    summary: &BTreeMap<Feature, BTreeMap<Source, Summary>>,
    unavailable: &BTreeMap<Source, String>,
    reference: &str,
) -> Vec<String> {
    let mut lines = Vec::new();
    let header = Source::COMPARED.iter().map(|s| format!("{:>20}", s.title())).collect::<String>();
    lines.push(format!("{:<42}{header}", format!("error vs {reference}: median [p90] n")));
    for feature in Feature::ALL {
        let cells: String = Source::COMPARED
            .iter()
            .map(|s| {
                let text = if let Some(why) = unavailable.get(s) {
                    if why.starts_with("left out") { "left out" } else { "not available" }.to_string()
                } else {
                    cell(feature, summary.get(&feature).and_then(|m| m.get(s)))
                };
                format!("{text:>20}")
            })
            .collect();
        lines.push(format!("{:<42}{cells}", feature.title()));
    }
    lines
}

/// The medians as a Markdown table, sources down and features across (a
/// ratio as `x1.10`, a difference as `8.5 dB`): the table the validation
/// document keeps between its `real grand` markers.
pub fn markdown_table(
    summary: &BTreeMap<Feature, BTreeMap<Source, Summary>>,
    unavailable: &BTreeMap<Source, String>,
) -> String {
    const HEADS: [&str; 10] = [
        "inharmonicity",
        "early decay",
        "late decay",
        "partials' levels",
        "centroid",
        "its growth",
        "dynamics",
        "balance",
        "40 dB fall",
        "attack noise",
    ];
    let mut out = format!("| | {} |\n", HEADS.join(" | "));
    out += &format!("|{}\n", " --- |".repeat(HEADS.len() + 1));
    for source in Source::COMPARED {
        if unavailable.get(&source).is_some_and(|why| why.starts_with("left out")) {
            continue;
        }
        let cells: Vec<String> = Feature::ALL
            .iter()
            .map(|&feature| match summary.get(&feature).and_then(|m| m.get(&source)) {
                _ if unavailable.contains_key(&source) => "not available".to_string(),
                Some(Summary { median: Some(m), .. }) if feature.is_ratio() => format!("x{m:.2}"),
                Some(Summary { median: Some(m), .. }) => format!("{m:.1} dB"),
                _ => "-".to_string(),
            })
            .collect();
        out += &format!("| {} | {} |\n", source.title(), cells.join(" | "));
    }
    out
}

/// `text` (a Markdown document) with what stands between its lines
/// `<!-- table: NAME -->` and `<!-- /table: NAME -->` replaced by `table`,
/// set off by a blank line on each side; an error naming what is missing
/// when the markers are not there once each, in that order.
pub fn with_table(text: &str, name: &str, table: &str) -> Result<String, String> {
    let (open, close) = (format!("<!-- table: {name} -->"), format!("<!-- /table: {name} -->"));
    let at = |marker: &str| {
        let lines: Vec<usize> = text
            .match_indices(marker)
            .map(|(i, _)| i)
            .filter(|&i| text[..i].ends_with('\n') || i == 0)
            .filter(|&i| text[i + marker.len()..].starts_with('\n'))
            .collect();
        match lines[..] {
            [i] => Ok(i),
            [] => Err(format!("has no line `{marker}`")),
            _ => Err(format!("has `{marker}` more than once")),
        }
    };
    let (start, end) = (at(&open)?, at(&close)?);
    if end < start {
        return Err(format!("has `{close}` before `{open}`"));
    }
    Ok(format!("{}{open}\n\n{table}\n{}", &text[..start], &text[end..]))
}

/// Per-source figures that are not errors: the "boom" share, growing
/// early decays, extrapolated fall times; the recordings' column headed
/// `reference`.
pub fn checks(takes: &[Take], reference: &str) -> Vec<String> {
    let mut lines = Vec::new();
    let all = [Source::Recording, Source::Struck, Source::Fluid, Source::FaustStk];
    let present: Vec<Source> = all
        .into_iter()
        .filter(|&s| s == Source::Recording || takes.iter().any(|t| matches!(t.sources.get(&s), Some(Ok(_)))))
        .collect();
    let of = |t: &Take, s: Source| -> Option<Features> {
        if s == Source::Recording { Some(t.recording.clone()) } else { t.sources.get(&s)?.as_ref().ok().cloned() }
    };
    let heads: String = present
        .iter()
        .map(|&s| format!("{:>20}", if s == Source::Recording { reference } else { s.title() }))
        .collect();
    lines.push(format!("{:<42}{heads}", "checks"));
    let row = |title: &str, f: &dyn Fn(&[Features]) -> String| {
        let cells: String = present
            .iter()
            .map(|&s| {
                let fs: Vec<Features> = takes.iter().filter_map(|t| of(t, s)).collect();
                format!("{:>20}", f(&fs))
            })
            .collect();
        format!("{title:<42}{cells}")
    };
    lines.push(row("energy below 0.8 f0, 0-0.3 s: median, max %", &|fs| {
        let v: Vec<f64> = fs.iter().map(|f| 100.0 * f.boom_share).collect();
        format!("{:.2} {:.2}", median(&v).unwrap_or(f64::NAN), v.iter().copied().fold(0.0, f64::max))
    }));
    lines.push(row("partial fits growing 0.3-2 s (of 8/take)", &|fs| {
        let grow: usize = fs.iter().map(|f| f.growing_early).sum();
        let fitted: usize = fs.iter().map(|f| f.decay_early_db_s.iter().flatten().count()).sum();
        format!("{grow} of {fitted}")
    }));
    // The softest layer's level re the loudest's, note by note.
    let layers: Vec<u8> =
        takes.iter().map(|t| t.layer).collect::<std::collections::BTreeSet<_>>().into_iter().collect();
    if let (Some(&soft), Some(&loud)) = (layers.first(), layers.last())
        && soft != loud
    {
        let cells: String = present
            .iter()
            .map(|&s| {
                let spans: Vec<f64> = takes
                    .iter()
                    .filter(|t| t.layer == soft)
                    .filter_map(|t| {
                        let l = takes.iter().find(|u| u.key == t.key && u.layer == loud)?;
                        Some(of(t, s)?.level_db - of(l, s)?.level_db)
                    })
                    .collect();
                let text = match (
                    median(&spans),
                    spans.iter().copied().reduce(f64::min),
                    spans.iter().copied().reduce(f64::max),
                ) {
                    (Some(m), Some(lo), Some(hi)) => format!("{m:.1} ({lo:.0} to {hi:.0})"),
                    _ => "-".into(),
                };
                format!("{text:>20}")
            })
            .collect();
        let title = format!(
            "level v{} re v{}: median dB (range)",
            takes.iter().find(|t| t.layer == soft).map_or(0, |t| t.velocity),
            takes.iter().find(|t| t.layer == loud).map_or(0, |t| t.velocity)
        );
        lines.push(format!("{title:<42}{cells}"));
    }
    lines.push(row("fall times extrapolated", &|fs| {
        format!("{} of {}", fs.iter().filter(|f| f.fall_extrapolated).count(), fs.len())
    }));
    lines
}

/// The takes furthest off for `source`: for each feature, the `n` worst.
pub fn worst(takes: &[Take], source: Source, n: usize) -> Vec<String> {
    let mut lines = Vec::new();
    for feature in Feature::ALL {
        let mut e: Vec<(f64, &Take)> =
            takes.iter().filter_map(|t| Some(((*t.errors.get(&source)?.get(&feature)?)?, t))).collect();
        e.sort_by(|a, b| b.0.total_cmp(&a.0));
        let items: Vec<String> = e
            .iter()
            .take(n)
            .map(|(v, t)| {
                let v = if feature.is_ratio() { format!("{v:.2}") } else { format!("{v:.1}") };
                format!("{} v{} {v}", t.note, t.velocity)
            })
            .collect();
        if !items.is_empty() {
            lines.push(format!("{:<42}{}", feature.title(), items.join(", ")));
        }
    }
    lines
}

fn opt(v: Option<f64>) -> String {
    v.map_or(String::new(), |v| format!("{v:e}"))
}

/// The per-note CSV: one row per note, layer and source (the recording's
/// rows too), every feature and, for the compared sources, every error.
pub fn write_csv(out: &mut impl Write, takes: &[Take]) -> io::Result<()> {
    let mut header = vec![
        "note".to_string(),
        "key".into(),
        "layer".into(),
        "velocity".into(),
        "source".into(),
        "band_hz".into(),
        "status".into(),
        "onset_s".into(),
        "cutoff_hz".into(),
        "f0_hz".into(),
        "inharmonicity".into(),
        "fitted_partials".into(),
    ];
    header.extend((1..=DECAY_PARTIALS).map(|n| format!("decay_early_p{n}_db_s")));
    header.extend((1..=DECAY_PARTIALS).map(|n| format!("decay_late_p{n}_db_s")));
    header.extend((1..=ENVELOPE_PARTIALS).map(|n| format!("envelope_p{n}_db")));
    header.extend(
        [
            "centroid_hz",
            "level_db",
            "fall_time_s",
            "fall_extrapolated",
            "attack_noise_db",
            "boom_share",
            "growing_early",
        ]
        .map(String::from),
    );
    header.extend(Feature::ALL.iter().map(|f| format!("error_{}", f.key())));
    writeln!(out, "{}", header.join(","))?;
    for t in takes {
        let mut rows: Vec<(Source, Result<&Features, &String>)> = vec![(Source::Recording, Ok(&t.recording))];
        rows.extend(t.sources.iter().map(|(&s, f)| (s, f.as_ref())));
        for (source, f) in rows {
            let mut cells = vec![
                t.note.clone(),
                t.key.to_string(),
                t.layer.to_string(),
                t.velocity.to_string(),
                source.key().to_string(),
                format!("{:.0}", t.band_hz),
            ];
            match f {
                Ok(f) => {
                    cells.push("ok".into());
                    cells.push(format!("{:e}", f.onset_s));
                    cells.push(format!("{:.0}", f.cutoff_hz));
                    cells.push(opt(f.f0_hz));
                    cells.push(opt(f.inharmonicity));
                    cells.push(f.fitted_partials.to_string());
                    let padded = |v: &[Option<f64>], n: usize| {
                        (0..n).map(|i| opt(v.get(i).copied().flatten())).collect::<Vec<_>>()
                    };
                    cells.extend(padded(&f.decay_early_db_s, DECAY_PARTIALS));
                    cells.extend(padded(&f.decay_late_db_s, DECAY_PARTIALS));
                    cells.extend(padded(&f.envelope_db, ENVELOPE_PARTIALS));
                    cells.push(opt(f.centroid_hz));
                    cells.push(format!("{:e}", f.level_db));
                    cells.push(opt(f.fall_time_s));
                    cells.push(f.fall_extrapolated.to_string());
                    cells.push(opt(f.attack_noise_db));
                    cells.push(format!("{:e}", f.boom_share));
                    cells.push(f.growing_early.to_string());
                }
                Err(e) => {
                    cells.push(format!("\"{}\"", e.replace('"', "'")));
                    cells.extend(std::iter::repeat_n(String::new(), 5 + 2 * DECAY_PARTIALS + ENVELOPE_PARTIALS + 7));
                }
            }
            let errors = t.errors.get(&source);
            cells.extend(Feature::ALL.iter().map(|f| opt(errors.and_then(|e| *e.get(f)?))));
            writeln!(out, "{}", cells.join(","))?;
        }
    }
    Ok(())
}

/// A take with no sources yet.
pub fn take(key: u8, layer: u8, velocity: u8, band_hz: f64, measured_s: f64, recording: Features) -> Take {
    Take {
        note: note_name(key),
        key,
        layer,
        velocity,
        band_hz,
        measured_s,
        recording,
        sources: BTreeMap::new(),
        errors: BTreeMap::new(),
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn features(level_db: f64, centroid_hz: f64, b: f64) -> Features {
        Features {
            level_db,
            centroid_hz: Some(centroid_hz),
            inharmonicity: Some(b),
            decay_early_db_s: vec![Some(2.0), Some(4.0), None, Some(-1.0)],
            ..Features::default()
        }
    }

    #[test]
    fn ratio_and_decay_errors() {
        assert_eq!(ratio_error(2.0, 1.0), Some(2.0));
        assert_eq!(ratio_error(1.0, 4.0), Some(4.0));
        assert_eq!(ratio_error(0.0, 4.0), None);
        // Partials 1, 2 and 4 are compared; a growing partial counts as 0.2 dB/s.
        let e = decay_error(&[Some(4.0), Some(4.0), Some(3.0), Some(0.4)], &[Some(2.0), Some(4.0), None, Some(-1.0)]);
        assert_eq!(e, Some(2.0));
        assert_eq!(envelope_error(&[Some(0.0), Some(-6.0), None], &[Some(0.0), Some(-10.0), Some(-3.0)]), Some(2.0));
    }

    #[test]
    fn layers_and_notes_are_compared_across() {
        // Two notes, two layers; the source is 6 dB too quiet when soft on
        // the low note, and its centroid grows half as much as the recording's.
        let rec = |key: u8, layer: u8| {
            features(
                if layer == 4 { -30.0 } else { -10.0 } + f64::from(key) / 10.0,
                if layer == 4 { 500.0 } else { 2000.0 },
                1e-4,
            )
        };
        let src = |key: u8, layer: u8| {
            let soft_low = key == 21 && layer == 4;
            features(
                if layer == 4 { -30.0 } else { -10.0 } + f64::from(key) / 10.0 - if soft_low { 6.0 } else { 0.0 },
                if layer == 4 { 1000.0 } else { 2000.0 },
                2e-4,
            )
        };
        let mut takes = Vec::new();
        for key in [21u8, 60] {
            for layer in [4u8, 16] {
                let mut t = take(key, layer, 40, 10_000.0, 6.0, rec(key, layer));
                t.sources.insert(Source::Struck, Ok(src(key, layer)));
                t.sources.insert(Source::Fluid, Err("not run".into()));
                takes.push(t);
            }
        }
        compare(&mut takes);
        let e = |i: usize, f: Feature| takes[i].errors[&Source::Struck][&f];
        // takes: (21,4), (21,16), (60,4), (60,16)
        assert_eq!(e(0, Feature::Dynamics), Some(6.0));
        assert_eq!(e(2, Feature::Dynamics), Some(0.0));
        assert_eq!(e(1, Feature::Dynamics), None);
        assert_eq!(e(1, Feature::CentroidGrowth), Some(2.0));
        assert_eq!(e(0, Feature::CentroidGrowth), None);
        // Layer 4's mean is 3 dB low: the low note 3 dB under, the high 3 dB over.
        assert!((e(0, Feature::Balance).unwrap() - 3.0).abs() < 1e-9);
        assert!((e(2, Feature::Balance).unwrap() - 3.0).abs() < 1e-9);
        assert!(e(1, Feature::Balance).unwrap().abs() < 1e-9);
        assert_eq!(e(0, Feature::Inharmonicity), Some(2.0));
        assert_eq!(e(0, Feature::Centroid), Some(2.0));
        assert_eq!(takes[0].errors[&Source::Fluid][&Feature::Inharmonicity], None);

        let summary = summarize(&takes);
        let s = summary[&Feature::Dynamics][&Source::Struck];
        assert_eq!((s.median, s.n), (Some(3.0), 2));
        assert_eq!(summary[&Feature::Dynamics][&Source::Fluid].n, 0);
        assert!(!summary[&Feature::Dynamics].contains_key(&Source::FaustStk));
        let table = table(&summary, &BTreeMap::from([(Source::FaustStk, "no faust".to_string())]), "Yamaha C5");
        assert!(table[1].contains("2.00 [2.00] 4") && table[1].contains("not available"), "{}", table[1]);

        let json = serde_json::to_value(&takes[0]).unwrap();
        assert_eq!(json["sources"]["fluid"]["error"], "not run");
        assert_eq!(json["sources"]["struck"]["level_db"], takes[0].sources[&Source::Struck].as_ref().unwrap().level_db);
        assert_eq!(json["errors"]["struck"]["dynamics"], 6.0);

        let mut csv = Vec::new();
        write_csv(&mut csv, &takes).unwrap();
        let text = String::from_utf8(csv).unwrap();
        let lines: Vec<&str> = text.lines().collect();
        // A header and three rows per take (recording, Struck, FluidR3).
        assert_eq!(lines.len(), 1 + 3 * takes.len());
        let columns = lines[0].split(',').count();
        assert!(lines.iter().all(|l| l.split(',').count() == columns), "{text}");
    }

    #[test]
    fn the_medians_make_a_markdown_table() {
        let summary: BTreeMap<Feature, BTreeMap<Source, Summary>> = Feature::ALL
            .iter()
            .map(|&f| {
                let one = |m: f64| Summary { median: Some(m), p90: Some(m), n: 3 };
                (f, BTreeMap::from([(Source::Struck, one(1.104)), (Source::Fluid, one(8.46))]))
            })
            .collect();
        let unavailable = BTreeMap::from([(Source::FaustStk, "not installed".to_string())]);
        let table = markdown_table(&summary, &unavailable);
        let lines: Vec<&str> = table.lines().collect();
        assert_eq!(lines.len(), 5, "{table}");
        assert!(lines[0].starts_with("| | inharmonicity | early decay |") && lines[0].ends_with("attack noise |"));
        assert_eq!(lines[1], format!("|{}", " --- |".repeat(11)));
        assert!(lines[2].starts_with("| Struck | x1.10 | x1.10 | x1.10 | 1.1 dB |"), "{}", lines[2]);
        assert!(lines[3].starts_with("| FluidR3 | x8.46 |") && lines[3].ends_with("| 8.5 dB |"), "{}", lines[3]);
        assert!(lines[4].starts_with("| Faust-STK | not available |"), "{}", lines[4]);
        // Left out: no row at all.
        let left_out = BTreeMap::from([(Source::FaustStk, "left out (--no-yardsticks)".to_string())]);
        assert_eq!(markdown_table(&summary, &left_out).lines().count(), 4);
    }

    #[test]
    fn a_table_replaces_only_what_stands_between_its_markers() {
        let doc = "# Title\n\n<!-- table: real grand -->\n\n| old |\n\n<!-- /table: real grand -->\n\nAfter.\n";
        let new = with_table(doc, "real grand", "| new |\n").unwrap();
        assert_eq!(new, "# Title\n\n<!-- table: real grand -->\n\n| new |\n\n<!-- /table: real grand -->\n\nAfter.\n");
        // Written again, the same.
        assert_eq!(with_table(&new, "real grand", "| new |\n").unwrap(), new);
        assert!(with_table("no markers\n", "real grand", "").unwrap_err().contains("has no line"));
        let twice = format!("{doc}{doc}");
        assert!(with_table(&twice, "real grand", "").unwrap_err().contains("more than once"));
        let reversed = "<!-- /table: real grand -->\n<!-- table: real grand -->\n";
        assert!(with_table(reversed, "real grand", "").unwrap_err().contains("before"));
        // A marker quoted inside a line is not a marker.
        let quoted = "see `<!-- table: real grand -->` here\n";
        assert!(with_table(quoted, "real grand", "").is_err());
    }
}
