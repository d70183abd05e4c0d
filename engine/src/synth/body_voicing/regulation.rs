//! A key's regulation through the body (its gain by touch, so a crescendo
//! keeps rising) and the evening of neighbours that ring apart.

use super::{
    Asked, Body, Key, REGULATION_CLOSER_DB, REGULATION_REFINEMENTS, REGULATION_RISE_DB, REGULATION_TOUCHES, Touch,
    TouchRange, Voiced, regulated, ring_through_body,
};

/// A key's regulation: how much each touch (by its value, as
/// [`Key::regulate`] takes it) must be turned down so that its ring through the
/// body never falls as the touch grows, gain 1 at `ringing`. A felt hammer's
/// spectrum changes with its speed, and a hard strike can all but miss a
/// partial a gentler one rings with: a technician regulates such a key so a
/// crescendo keeps rising, here by holding each touch's ring under the ring of
/// every harder touch, by [`REGULATION_RISE_DB`] a step (never louder than the
/// physics gives; at worst a stretch of the crescendo rising slowly).
pub(super) fn regulation(
    key: &mut Key,
    range: TouchRange,
    ringing: Touch,
    body: &mut Body,
    force: &mut [f64],
) -> Regulation {
    let lo = range.bounds().0;
    let step = regulation_step(range);
    let mut weigh = |t: f64, peak: bool| {
        ring_through_body(key, range.with(t), body.reborrow(), 1.0, force, Asked { bridge: false, peak })
    };
    // Every other regulated touch first, the hardest among them (whose
    // strike's peak through the body the voicing needs as well).
    let mut loudest_peak_per_scale = None;
    let mut points: Vec<(f64, f64)> = (0..REGULATION_TOUCHES)
        .step_by(2)
        .map(|i| {
            let t = lo * step.powi(i as i32);
            let weighed = weigh(t, i == REGULATION_TOUCHES - 1);
            loudest_peak_per_scale = loudest_peak_per_scale.or(weighed.peak_per_scale);
            (t, weighed.mics)
        })
        .collect();
    let mut ring_at = |t: f64| weigh(t, false).mics;
    // Where the ring strays from the key's own rise between two touches (a
    // hard strike's spectrum swinging through a partial), look closer: the
    // rise expected is the key's median (over two regulation steps, halved
    // to one), in proportion to the touches' spacing.
    let db = |(a, b): (f64, f64)| 10.0 * (b.max(1e-300) / a.max(1e-300)).log10();
    let mut steps: Vec<f64> = points.windows(2).map(|w| db((w[0].1, w[1].1))).collect();
    steps.sort_by(f64::total_cmp);
    let rise = steps.get(steps.len() / 2).copied().unwrap_or(0.0) / 2.0;
    for _ in 0..REGULATION_REFINEMENTS {
        let mut finer = Vec::with_capacity(2 * points.len());
        for pair in points.windows(2) {
            finer.push(pair[0]);
            let expected = rise * (pair[1].0 / pair[0].0).ln() / step.ln();
            if (db((pair[0].1, pair[1].1)) - expected).abs() > REGULATION_CLOSER_DB {
                let t = (pair[0].0 * pair[1].0).sqrt();
                finer.push((t, ring_at(t)));
            }
        }
        finer.extend(points.last().copied());
        if finer.len() == points.len() {
            break;
        }
        points = finer;
    }
    // From the hardest touch down, each held under the next by the margin.
    let mut held = vec![0.0; points.len()];
    let mut ceiling = f64::INFINITY;
    for i in (0..points.len()).rev() {
        let margin = points.get(i + 1).map_or(0.0, |next| rise_margin_db(points[i].0, next.0, step));
        ceiling = (ceiling * 10f64.powf(-margin / 10.0)).min(points[i].1);
        held[i] = ceiling;
    }
    let mut table: Vec<(f64, f64)> = points
        .iter()
        .zip(&held)
        .map(|(&(t, r), &h)| (t, if r > 0.0 && h > 0.0 { (h / r).sqrt() } else { 1.0 }))
        .collect();
    let at_ringing = regulated(&table, ringing.value());
    if at_ringing > 0.0 {
        table.iter_mut().for_each(|(_, g)| *g /= at_ringing);
    }
    table.iter_mut().for_each(|(_, g)| *g = g.clamp(1.0 / MOST_REGULATED, MOST_REGULATED));
    Regulation { table, rings: points, loudest_peak_per_scale }
}

/// The ratio of one regulated touch to the next over `range`.
pub(super) fn regulation_step(range: TouchRange) -> f64 {
    let (lo, hi) = range.bounds();
    (hi / lo).powf(1.0 / (REGULATION_TOUCHES - 1) as f64)
}

/// How far under the ring of touch `harder` the ring of touch `softer` is
/// held, dB: [`REGULATION_RISE_DB`] a regulation step (`step`), in proportion.
pub(super) fn rise_margin_db(softer: f64, harder: f64, step: f64) -> f64 {
    REGULATION_RISE_DB * (harder / softer).ln() / step.ln()
}

/// A key's regulation ([`regulation`]): its gain by touch, the ring power
/// through the body it was weighed with at those touches, and its hardest
/// touch's peak through the body ([`Weighed::peak_per_scale`]).
pub(super) struct Regulation {
    pub(super) table: Vec<(f64, f64)>,
    pub(super) rings: Vec<(f64, f64)>,
    pub(super) loudest_peak_per_scale: Option<f64>,
}

/// How far a key may ring over (or under) the mean of its two neighbours at
/// any touch, dB, before it is turned down (or up) there.
pub(super) const EVEN_DB: f64 = 3.0;

/// The most a key is voiced down and up through the body, times its
/// bridge-force gain (-40 to +26 dB): what a technician can do to a key's
/// hammer and a maker to its stringing. Equal temperament voices every key
/// of every instrument between 0.16 and 13.4; a scale that tunes a key where
/// the body or its free partners ring absurdly against its bridge force
/// (strings pulled tens of times over their tension) stays in it.
pub(super) const VOICING_RANGE: (f64, f64) = (0.01, 20.0);

/// The most a key's regulation turns a touch up or down, times (12 dB):
/// equal temperament regulates every key within -8.6 and +7.6 dB; a string
/// tuned to a fraction of a hertz rings at one touch as it does at no other.
pub(super) const MOST_REGULATED: f64 = 4.0;

/// The most a key is turned up at a touch to meet its neighbours, dB.
pub(super) const MAX_RAISE_DB: f64 = 12.0;

/// The most a key is turned down at a touch to meet its neighbours, dB: a
/// technician's needle softens a hammer, it does not silence it (equal
/// temperament's deepest cut is 4.7 dB, the piano's top key; a scale that
/// puts a key's neighbours in pitch where the body barely hears them would
/// have it cut by hundreds of dB).
pub(super) const MAX_CUT_DB: f64 = 12.0;

/// Even out `keys` (in key order, each with its voicing, every key turned
/// down at least by `headroom`) touch by touch, as a technician voices a
/// scale: where a key rings more than [`EVEN_DB`] over the mean of its
/// neighbours in pitch (`pitch_hz` by MIDI key) at a touch (a treble hammer
/// whose spectrum leaps at a softer touch than theirs), it is turned down
/// there to that (by at most [`MAX_CUT_DB`]), and where it rings more than
/// that under them, below its loudest touch, turned up to that (by at most
/// [`MAX_RAISE_DB`]); then each touch is held under every harder one again,
/// so a crescendo still never falls.
pub(in crate::synth) fn even_out(
    keys: &mut [(u8, &mut Key, Voiced)],
    pitch_hz: &[f64; 128],
    headroom: f64,
    range: TouchRange,
) {
    let step = regulation_step(range);
    // Each key's ring by touch as heard: its rings times its regulation and
    // its gain onto the body, squared.
    let heard: Vec<Vec<(f64, f64)>> = keys
        .iter()
        .map(|(_, key, v)| {
            let gain = v.level * v.peak_cut().min(headroom);
            v.rings.iter().map(|&(t, r)| (t, r * (regulated(key.regulation(), t) * gain).powi(2))).collect()
        })
        .collect();
    // The keys in order of pitch (a scale may tune them in any order).
    let mut by_pitch: Vec<usize> = (0..keys.len()).collect();
    by_pitch.sort_by(|&a, &b| pitch_hz[keys[a].0 as usize & 127].total_cmp(&pitch_hz[keys[b].0 as usize & 127]));
    for (place, &i) in by_pitch.iter().enumerate() {
        if heard[i].is_empty() {
            continue;
        }
        let neighbours: Vec<&Vec<(f64, f64)>> = [place.checked_sub(1), Some(place + 1)]
            .into_iter()
            .flatten()
            .filter_map(|p| heard.get(*by_pitch.get(p)?))
            .filter(|h| !h.is_empty())
            .collect();
        if neighbours.is_empty() {
            continue;
        }
        let key = &mut keys[i].1;
        let mut table = key.regulation().to_vec();
        let last = table.len().saturating_sub(1);
        for (j, ((t, g), &(_, own))) in table.iter_mut().zip(&heard[i]).enumerate() {
            let rings: Vec<f64> = neighbours.iter().map(|h| regulated(h, *t)).filter(|&r| r > 0.0).collect();
            if rings.is_empty() {
                continue;
            }
            let mean_db = rings.iter().map(|r| 10.0 * r.log10()).sum::<f64>() / rings.len() as f64;
            let own_db = 10.0 * own.max(1e-300).log10();
            let over_db = own_db - mean_db - EVEN_DB;
            let under_db = mean_db - EVEN_DB - own_db;
            if over_db > 0.0 {
                *g *= 10f64.powf(-over_db.min(MAX_CUT_DB) / 20.0);
            } else if under_db > 0.0 && j < last && own > 0.0 {
                // Under them (its share of what rings with it, or a partial
                // it all but misses, smaller at this touch than at the touch
                // it is voiced at): raised to that, below its loudest touch
                // (whose peak the headroom holds).
                *g *= 10f64.powf(under_db.min(MAX_RAISE_DB) / 20.0);
            }
        }
        // From the hardest touch down, each held under the next by the
        // regulation's margin.
        let rings = &keys[i].2.rings;
        let mut ceiling = f64::INFINITY;
        for j in (0..table.len()).rev() {
            if let Some(&(harder, _)) = table.get(j + 1) {
                ceiling *= 10f64.powf(-rise_margin_db(table[j].0, harder, step) / 10.0);
            }
            let own = rings.get(j).map_or(0.0, |r| r.1);
            let g = &mut table[j].1;
            let ring = own * *g * *g;
            if ring > ceiling && ring > 0.0 {
                *g *= (ceiling / ring).sqrt();
            }
            ceiling = ceiling.min(own * *g * *g);
        }
        keys[i].1.regulate(table);
    }
}
