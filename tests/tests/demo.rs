//! `struck demo --quick`: the seed's lab redone, checked as a person would check
//! it. Every file is there and is what it claims to be, the page's links all
//! resolve, Sound 12 goes quiet clavichord < louder clavichord < harpsichord,
//! C2's hammer leaves before the far end's reflection is back, and the hammer
//! chart's contact time rises with mass and falls with stiffness.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::OnceLock;

use struck_lab::strike::seed;
use struck_tests::{stderr, stdout, struck};

/// The demo, run once for every test here.
fn demo() -> &'static Path {
    static DIR: OnceLock<(tempfile::TempDir, PathBuf)> = OnceLock::new();
    let (_, out) = DIR.get_or_init(|| {
        let dir = tempfile::tempdir().unwrap();
        let out = dir.path().join("demo");
        let run = struck(&["demo", "--quick", "--out", out.to_str().unwrap()]);
        assert!(run.status.success(), "struck demo failed: {}\n{}", stderr(&run), stdout(&run));
        (dir, out)
    });
    out
}

/// The files the page links to, in order (src= and href= attributes).
fn links(html: &str) -> Vec<String> {
    let mut found = Vec::new();
    for attribute in ["src=\"", "href=\""] {
        let mut rest = html;
        while let Some(i) = rest.find(attribute) {
            rest = &rest[i + attribute.len()..];
            let end = rest.find('"').expect("a closed attribute");
            found.push(rest[..end].to_string());
            rest = &rest[end..];
        }
    }
    found
}

#[test]
fn every_linked_file_is_there_and_is_what_it_claims() {
    let dir = demo();
    let html = std::fs::read_to_string(dir.join("index.html")).unwrap();
    let links = links(&html);
    let count = |ext: &str| links.iter().filter(|l| l.ends_with(ext)).collect::<std::collections::BTreeSet<_>>().len();
    assert_eq!(count(".wav"), 12, "Sounds 1-12");
    assert_eq!(count(".gif"), 5, "Figs. 2, 23, 24, 25 and 32");
    // Figs. 3-5, 8-10, 12-22, 26, 29-31, 33-35.
    assert_eq!(count(".png"), 3 + 3 + 11 + 1 + 3 + 3);
    for link in &links {
        assert!(!link.contains("..") && !link.starts_with('/') && !link.contains("://"), "{link} is not local");
        let path = dir.join(link);
        let bytes = std::fs::read(&path).unwrap_or_else(|e| panic!("{link}: {e}"));
        let kind = link.rsplit('.').next().unwrap();
        match kind {
            "png" => {
                assert!(bytes.starts_with(b"\x89PNG\r\n\x1a\n"), "{link}");
                assert!(bytes.len() > 10_000, "{link}: {} bytes", bytes.len());
            }
            "gif" => {
                assert!(bytes.starts_with(b"GIF89a"), "{link}");
                assert!(bytes.len() > 20_000, "{link}: {} bytes", bytes.len());
            }
            "csv" => {
                let text = String::from_utf8(bytes).unwrap();
                assert!(text.lines().count() > 5, "{link}");
            }
            "wav" => {
                let reader = hound::WavReader::open(&path).unwrap();
                let seconds = reader.duration() as f64 / reader.spec().sample_rate as f64;
                assert!(seconds >= 1.5, "{link}: {seconds} s");
                let peak = reader.into_samples::<i16>().map(|s| s.unwrap().unsigned_abs()).max().unwrap();
                // Normalised to -1 dBFS.
                assert!((29_000..=29_300).contains(&peak), "{link}: peak {peak}");
            }
            other => panic!("{link}: unexpected .{other}"),
        }
    }
    // In the seed's order: Fig. 2 first, Sound 12 last.
    let first_figure = html.find("fig02").unwrap();
    assert!(first_figure < html.find("sound01").unwrap());
    assert!(html.rfind("sound12").unwrap() > html.rfind("fig35").unwrap());
}

fn segment_rms(samples: &[f64], parts: usize) -> Vec<f64> {
    let n = samples.len() / parts;
    (0..parts).map(|i| (samples[i * n..(i + 1) * n].iter().map(|v| v * v).sum::<f64>() / n as f64).sqrt()).collect()
}

fn wav(path: &Path) -> Vec<f64> {
    hound::WavReader::open(path).unwrap().into_samples::<i16>().map(|s| s.unwrap() as f64 / 32768.0).collect()
}

/// The file in `dir` whose name starts with `prefix` and ends with `ext`.
fn file_starting(dir: &Path, prefix: &str, ext: &str) -> PathBuf {
    std::fs::read_dir(dir)
        .unwrap()
        .map(|e| e.unwrap().path())
        .find(|p| {
            let name = p.file_name().unwrap().to_string_lossy();
            name.starts_with(prefix) && name.ends_with(ext)
        })
        .unwrap_or_else(|| panic!("no {prefix}*{ext}"))
}

#[test]
fn sound_12_keeps_the_seeds_order_of_loudness() {
    let samples = wav(&file_starting(demo(), "sound12-", ".wav"));
    let rms = segment_rms(&samples, 3);
    let db: Vec<f64> = rms.iter().map(|r| 20.0 * r.log10()).collect();
    println!("Sound 12: quiet clavichord {:.1} dB, louder {:.1} dB, harpsichord {:.1} dB", db[0], db[1], db[2]);
    assert!(db[0] + 6.0 < db[1], "{db:?}");
    assert!(db[1] + 3.0 < db[2], "{db:?}");
}

#[test]
fn sound_7_gets_louder_note_by_note() {
    let samples = wav(&file_starting(demo(), "sound07-", ".wav"));
    let rms = segment_rms(&samples, 5);
    assert!(rms.windows(2).all(|w| w[1] > w[0] * 1.5), "{rms:?}");
}

/// A tidy line-plot CSV: series name to its (x, y) points.
fn series(path: &Path) -> BTreeMap<String, Vec<(f64, f64)>> {
    let text = std::fs::read_to_string(path).unwrap();
    let mut lines = text.lines();
    assert_eq!(lines.next(), Some("series,x,y"), "{}", path.display());
    let mut out: BTreeMap<String, Vec<(f64, f64)>> = BTreeMap::new();
    for line in lines {
        let mut fields = line.rsplitn(3, ',');
        let y: f64 = fields.next().unwrap().parse().unwrap();
        let x: f64 = fields.next().unwrap().parse().unwrap();
        let name = fields.next().unwrap().trim_matches('"').to_string();
        out.entry(name).or_default().push((x, y));
    }
    out
}

#[test]
fn c2s_hammer_leaves_before_the_far_ends_reflection_returns() {
    let forces = series(&file_starting(demo(), "fig12-", ".csv"));
    assert_eq!(forces.len(), 5, "five speeds");
    let string = seed::piano_c_string(2, true).build().unwrap();
    let beta = seed::piano_c_hammer(2, 1.0).position;
    let c = 2.0 * string.length_m * string.f0_hz;
    // From the strike point to the far end and back.
    let far_ms = 2.0 * (1.0 - beta) * string.length_m / c * 1e3;
    let near_ms = 2.0 * beta * string.length_m / c * 1e3;
    for (speed, points) in &forces {
        let last = points.iter().filter(|p| p.1 > 0.0).map(|p| p.0).fold(0.0, f64::max);
        println!(
            "{speed}: contact ends at {last:.2} ms; near end's reflection {near_ms:.2} ms, far end's {far_ms:.2} ms"
        );
        assert!(last > near_ms, "{speed}: {last} ms");
        assert!(last < far_ms, "{speed}: {last} ms");
    }
}

/// Cells of a heatmap by (x index, y index); None for no data.
type Cells = BTreeMap<(usize, usize), Option<f64>>;

/// A heatmap CSV: its x and y axes and its cells.
fn grid(path: &Path) -> (Vec<f64>, Vec<f64>, Cells) {
    let text = std::fs::read_to_string(path).unwrap();
    let mut rows: Vec<(f64, f64, Option<f64>)> = Vec::new();
    for line in text.lines().skip(1) {
        let f: Vec<&str> = line.split(',').collect();
        let value = f[2].parse::<f64>().ok().filter(|v| v.is_finite());
        rows.push((f[0].parse().unwrap(), f[1].parse().unwrap(), value));
    }
    let axis = |pick: fn(&(f64, f64, Option<f64>)) -> f64| {
        let mut v: Vec<f64> = rows.iter().map(pick).collect();
        v.sort_by(f64::total_cmp);
        v.dedup();
        v
    };
    let (xs, ys) = (axis(|r| r.0), axis(|r| r.1));
    let index = |axis: &[f64], v: f64| axis.iter().position(|&a| a == v).unwrap();
    let cells = rows.iter().map(|r| ((index(&xs, r.0), index(&ys, r.1)), r.2)).collect();
    (xs, ys, cells)
}

#[test]
fn the_hammer_charts_contact_time_rises_with_mass_and_falls_with_stiffness() {
    let dir = demo();
    let (xs, ys, time) = grid(&file_starting(dir, "fig15-", ".csv"));
    let (_, _, contacts) = grid(&file_starting(dir, "fig16-", ".csv"));
    assert_eq!(xs.len() * ys.len(), time.len());
    let single = |ix: usize, iy: usize| contacts[&(ix, iy)] == Some(1.0);
    let (mut checked, mut agree) = (0, 0);
    for ix in 0..xs.len() {
        for iy in 0..ys.len() {
            let Some(t) = time[&(ix, iy)] else { continue };
            if !single(ix, iy) {
                continue;
            }
            if ix + 1 < xs.len()
                && single(ix + 1, iy)
                && let Some(heavier) = time[&(ix + 1, iy)]
            {
                checked += 1;
                agree += usize::from(heavier > t);
            }
            if iy + 1 < ys.len()
                && single(ix, iy + 1)
                && let Some(stiffer) = time[&(ix, iy + 1)]
            {
                checked += 1;
                agree += usize::from(stiffer < t);
            }
        }
    }
    println!("{agree} of {checked} neighbouring single-contact pairs follow the trend");
    assert!(checked >= 100, "{checked}");
    assert!(agree as f64 >= 0.95 * checked as f64, "{agree} of {checked}");
}

/// `struck chart` and `struck animate` refuse bad arguments with status 2 and one
/// line naming the argument, and write nothing.
#[test]
fn chart_and_animate_refuse_bad_input() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("charts");
    let out_arg = out.to_str().unwrap();
    let missing = dir.path().join("missing.json");
    let gif = dir.path().join("a.gif");
    let cases: Vec<(Vec<&str>, &str)> = vec![
        (vec!["chart", "hammer", "--instrument", "clavichord", "--key", "D2", "--out", out_arg], "--instrument"),
        (vec!["chart", "hammer", "--instrument", "banjo", "--out", out_arg], "--instrument"),
        (vec!["chart", "hammer", "--key", "H9", "--out", out_arg], "--key"),
        (vec!["chart", "hammer", "--key", "C1", "--instrument", "santoor", "--out", out_arg], "--key"),
        (vec!["chart", "hammer", "--grid", "1", "--out", out_arg], "--grid"),
        (vec!["chart", "hammer", "--speed", "-1", "--out", out_arg], "--speed"),
        (vec!["chart", "universal", "--grid", "100000", "--out", out_arg], "--grid"),
        (vec!["chart", "strike", missing.to_str().unwrap(), "--out", out_arg], "missing.json"),
        (vec!["animate", missing.to_str().unwrap(), "--out", gif.to_str().unwrap()], "missing.json"),
    ];
    for (args, names) in cases {
        let run = struck(&args);
        let message = stderr(&run);
        assert_eq!(run.status.code(), Some(2), "{args:?}: {message}");
        assert_eq!(message.lines().count(), 1, "{args:?}: {message:?}");
        assert!(message.contains(names), "{args:?}: {message:?} should name {names}");
        assert!(!out.exists() && !gif.exists(), "{args:?} wrote something");
    }
}

/// The chart commands draw what they say, for keys of other instruments and for
/// case files.
#[test]
fn charts_and_animations_of_any_key_or_case() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("charts");
    let out_arg = out.to_str().unwrap();
    let case = dir.path().join("case.json");
    std::fs::write(&case, struck_tests::SANTOOR_CASE).unwrap();
    let case_arg = case.to_str().unwrap();
    let gif = dir.path().join("gifs").join("santoor.gif");
    for args in [
        vec!["chart", "hammer", "--instrument", "cimbalom", "--key", "A3", "--grid", "6", "--out", out_arg],
        vec!["chart", "hammer", "--case", case_arg, "--grid", "5", "--log-mass", "--out", out_arg],
        vec!["chart", "strike", case_arg, "--speeds", "0.5,2", "--per-speed", "--out", out_arg],
        vec!["chart", "stringing", "--instrument", "dulcimer", "--out", out_arg],
        vec!["chart", "clavichord", "--out", out_arg],
        vec!["chart", "body", "--instrument", "piano", "--out", out_arg],
        vec!["chart", "universal", "--grid", "4", "--out", out_arg],
        vec!["animate", case_arg, "--frames", "20", "--out", gif.to_str().unwrap()],
    ] {
        let run = struck(&args);
        assert!(run.status.success(), "{args:?}: {}", stderr(&run));
    }
    let mut names: Vec<String> =
        std::fs::read_dir(&out).unwrap().map(|e| e.unwrap().file_name().to_string_lossy().into_owned()).collect();
    names.sort();
    for expected in [
        "hammer-contact-time.png",
        "hammer-contacts.csv",
        "hammer-centroid.png",
        "contact-force.png",
        "bridge-force-spectrum.csv",
        "stringing-dulcimer-impedance.png",
        "fig29-clavichord-pitch-rise.png",
        "fig22-universal-centroid.png",
        "body-piano-mobility.png",
        "body-piano-microphones.csv",
        "body-piano-modes.png",
    ] {
        assert!(names.iter().any(|n| n == expected), "{expected} not in {names:?}");
    }
    // Two speeds drawn, force divided by each.
    let contact = series(&out.join("contact-force.csv"));
    assert_eq!(contact.len(), 2, "{:?}", contact.keys());
    assert!(std::fs::read(&gif).unwrap().starts_with(b"GIF89a"));
    // The board's mobility near 100 Hz is Wogram's order of magnitude.
    let mobility = series(&out.join("body-piano-mobility.csv"));
    let middle = mobility.iter().find(|(k, _)| k.contains("|Y| at key 64")).map(|(_, v)| v).unwrap();
    let near_100: Vec<f64> = middle.iter().filter(|(f, _)| (70.0..140.0).contains(f)).map(|p| p.1).collect();
    let mean = (near_100.iter().map(|y| y.ln()).sum::<f64>() / near_100.len() as f64).exp();
    assert!((3e-4..3e-3).contains(&mean), "{mean}");
}
