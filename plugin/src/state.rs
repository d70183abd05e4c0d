//! A saved state (a host's session or preset, in CLAP and VST3 alike) checked
//! before it is applied: every parameter's value and every persisted field.
//!
//! nice-plug applies a state's plain values as they come: an enum's index out
//! of range is kept and later indexed (a panic in the host's next save, which
//! aborts the host), and a number beyond its parameter's range is kept beyond
//! it (the engine would be asked for 10^38 dB). [`repair`] runs first, from
//! [`Plugin::filter_state`]: a value that is not one its parameter can take,
//! or of another type, becomes the parameter's default, and a persisted field
//! that does not read as what it holds becomes its default, each with a line
//! for the log. A state that is not JSON at all never gets here: the wrapper
//! refuses it whole, and nothing changes. See docs/upstream-notes.md.

use nice_plug::plugin::ParamValue;
use nice_plug::prelude::*;
use struck_engine::tuning::{Temperament, TuningSettings};

use crate::params::StruckParams;

/// What a parameter takes, read off a fresh [`StruckParams`].
#[derive(Clone, Debug, PartialEq)]
enum Takes {
    /// A finite number from `lo` to `hi`.
    Float {
        lo: f32,
        hi: f32,
        default: f32,
    },
    Int {
        lo: i32,
        hi: i32,
        default: i32,
    },
    Bool {
        default: bool,
    },
    /// One of `ids` (saved by id), or an index into them; `default` is an index.
    Enum {
        ids: Vec<&'static str>,
        default: usize,
    },
}

/// One parameter: its id, its name and what it takes.
#[derive(Clone, Debug)]
struct Rule {
    id: String,
    name: String,
    takes: Takes,
}

/// What every parameter takes. Reads (and, for an enum's ids, moves) the
/// parameters of `params`, which must be a throwaway nobody else sees.
fn rules(params: &StruckParams) -> Vec<Rule> {
    params
        .param_map()
        .into_iter()
        .map(|(id, ptr, _)| {
            // SAFETY: `ptr` points into `params`, alive for the call; it is
            // used from this thread only, as a host would.
            let (name, takes) = unsafe { (ptr.name().to_string(), takes(ptr)) };
            Rule { id, name, takes }
        })
        .collect()
}

/// # Safety
/// `ptr` must point at a live parameter no other thread touches.
unsafe fn takes(ptr: ParamPtr) -> Takes {
    unsafe {
        let ends = (ptr.preview_plain(0.0), ptr.preview_plain(1.0));
        let (lo, hi) = (ends.0.min(ends.1), ends.0.max(ends.1));
        let default = ptr.default_plain_value();
        match ptr {
            ParamPtr::FloatParam(_) => Takes::Float { lo, hi, default },
            ParamPtr::IntParam(_) => {
                Takes::Int { lo: lo.round() as i32, hi: hi.round() as i32, default: default.round() as i32 }
            }
            // (A bool's default_plain_value through a ParamPtr is its value
            // now; a fresh parameter's is its default, but ask for the default.)
            ParamPtr::BoolParam(_) => Takes::Bool { default: ptr.default_normalized_value() > 0.5 },
            ParamPtr::EnumParam(inner) => {
                // The ids are read by setting each index in turn (the throwaway's).
                let ids = (0..(*inner).len())
                    .filter_map(|i| {
                        ptr._internal_set_normalized_value(ptr.preview_normalized(i as f32));
                        (*inner).unmodulated_plain_id()
                    })
                    .collect();
                ptr._internal_set_normalized_value(ptr.default_normalized_value());
                Takes::Enum { ids, default: default.round() as usize }
            }
        }
    }
}

impl Takes {
    /// Why `value` is not one this parameter takes, or None when it is.
    fn refuses(&self, value: &ParamValue) -> Option<String> {
        match (self, value) {
            (Takes::Float { lo, hi, .. }, ParamValue::F32(v)) => {
                // (Plain values come back from their range's own arithmetic: a
                // hair's rounding past an end is no damage.)
                let slack = (hi - lo) * 1e-6;
                let inside = v.is_finite() && *v >= lo - slack && *v <= hi + slack;
                (!inside).then(|| format!("{} is not a number from {lo} to {hi}", quoted(value)))
            }
            (Takes::Int { lo, hi, .. }, ParamValue::I32(v)) => {
                (!(lo..=hi).contains(&v)).then(|| format!("{v} is not a whole number from {lo} to {hi}"))
            }
            (Takes::Bool { .. }, ParamValue::Bool(_)) => None,
            (Takes::Enum { ids, .. }, ParamValue::String(id)) => (!ids.iter().any(|known| known == id))
                .then(|| format!("{} is not one of {}", quoted(value), ids.join(", "))),
            (Takes::Enum { ids, .. }, ParamValue::I32(index)) => {
                let count = ids.len().max(1) as i64;
                (!(0..count).contains(&i64::from(*index)))
                    .then(|| format!("choice {index} is not one of its {count} (0 to {})", count - 1))
            }
            (_, value) => Some(format!("{} is {}, where it takes {}", quoted(value), kind(value), self.kind())),
        }
    }

    /// The default, as a state holds it.
    fn default_value(&self) -> ParamValue {
        match self {
            Takes::Float { default, .. } => ParamValue::F32(*default),
            Takes::Int { default, .. } => ParamValue::I32(*default),
            Takes::Bool { default } => ParamValue::Bool(*default),
            Takes::Enum { ids, default } => match ids.get(*default) {
                Some(id) => ParamValue::String((*id).to_string()),
                None => ParamValue::I32(*default as i32),
            },
        }
    }

    fn kind(&self) -> &'static str {
        match self {
            Takes::Float { .. } => "a number",
            Takes::Int { .. } => "a whole number",
            Takes::Bool { .. } => "on or off",
            Takes::Enum { .. } => "a choice",
        }
    }
}

fn kind(value: &ParamValue) -> &'static str {
    match value {
        ParamValue::F32(_) => "a number",
        ParamValue::I32(_) => "a whole number",
        ParamValue::Bool(_) => "on or off",
        ParamValue::String(_) => "text",
    }
}

/// A value as the log quotes it: short, on one line.
fn quoted(value: &ParamValue) -> String {
    match value {
        // (Written short at any size: 3e38, not 39 digits.)
        ParamValue::F32(v) if *v != 0.0 && v.is_finite() && !(1e-6..1e9).contains(&v.abs()) => format!("{v:e}"),
        ParamValue::F32(v) => format!("{v}"),
        ParamValue::I32(v) => format!("{v}"),
        ParamValue::Bool(v) => format!("{v}"),
        ParamValue::String(s) => format!("\"{}\"", short(s, 40)),
    }
}

/// At most `chars` characters of `text`, its control characters escaped.
fn short(text: &str, chars: usize) -> String {
    let cut: String = text.chars().take(chars).collect();
    let ellipsis = if cut.len() < text.len() { "..." } else { "" };
    format!("{}{ellipsis}", struck_engine::printable(&cut))
}

/// Why a persisted field's JSON is not what `key` holds, or None when it is.
fn field_refused(key: &str, data: &str) -> Option<String> {
    let not = |what: &str, e: serde_json::Error| Some(format!("is not {what} ({e})"));
    match key {
        "scala-scale" => match serde_json::from_str::<Option<struck_engine::tuning::ScalaScale>>(data) {
            Err(e) => not("a Scala scale", e),
            Ok(None) => None,
            Ok(Some(scale)) => {
                let tuning =
                    TuningSettings { temperament: Temperament::Scala, scale: Some(scale), ..TuningSettings::default() };
                tuning.validate().err().map(|e| format!("is not a scale Struck can play ({e})"))
            }
        },
        "scala-files" => serde_json::from_str::<String>(data).err().and_then(|e| not("text", e)),
        "state-version" => serde_json::from_str::<u32>(data).err().and_then(|e| not("a version number", e)),
        _ => None,
    }
}

/// Set every parameter value and persisted field of `state` that the plugin
/// would not take to its default; one line for each, naming it and why (for
/// the log). Allocates: for the main thread, where hosts load state.
pub fn repair(state: &mut PluginState) -> Vec<String> {
    let params = StruckParams::default();
    let mut said = Vec::new();
    for rule in rules(&params) {
        let Some(value) = state.params.get_mut(&rule.id) else { continue };
        if let Some(why) = rule.takes.refuses(value) {
            let default = rule.takes.default_value();
            said.push(format!(
                "Struck: the saved \"{}\" ({}): {why}; it is set to its default, {}",
                rule.id,
                rule.name,
                quoted(&default)
            ));
            *value = default;
        }
    }
    let defaults = params.serialize_fields();
    for (key, data) in state.fields.iter_mut() {
        let Some(default) = defaults.get(key) else { continue };
        if let Some(why) = field_refused(key, data) {
            said.push(format!(
                "Struck: the saved \"{key}\" {}; it is set to its default, {}",
                short(&why, 200),
                short(default, 40)
            ));
            data.clone_from(default);
        }
    }
    said
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;

    use nice_plug::params::InternalParamMut;

    use super::*;
    use crate::params::InstrumentChoice;

    /// A state holding every parameter's default (as a host saves a fresh instance).
    fn default_state() -> PluginState {
        let params = StruckParams::default();
        let values = rules(&params).into_iter().map(|r| (r.id, r.takes.default_value())).collect();
        PluginState { version: "0.1.0".into(), params: values, fields: params.serialize_fields() }
    }

    fn rule(id: &str) -> Rule {
        rules(&StruckParams::default()).into_iter().find(|r| r.id == id).unwrap()
    }

    /// Apply `state` as nice-plug's wrappers do (`wrapper/state.rs`,
    /// `deserialize_object`, after `filter_state`), then read every parameter
    /// back as they save it (`serialize_object`: an enum by its id) and show
    /// it: what panicked in the host.
    fn apply_and_save(state: &PluginState) -> (StruckParams, BTreeMap<String, String>) {
        let params = StruckParams::default();
        let map = params.param_map();
        for (id, value) in &state.params {
            let Some((_, ptr, _)) = map.iter().find(|(i, _, _)| i == id) else { continue };
            // SAFETY: the pointers point into `params`, alive here, and this thread alone uses them.
            unsafe {
                match (*ptr, value) {
                    (ParamPtr::FloatParam(p), ParamValue::F32(v)) => _ = (*p)._internal_set_plain_value(*v),
                    (ParamPtr::IntParam(p), ParamValue::I32(v)) => _ = (*p)._internal_set_plain_value(*v),
                    (ParamPtr::BoolParam(p), ParamValue::Bool(v)) => _ = (*p)._internal_set_plain_value(*v),
                    (ParamPtr::EnumParam(p), ParamValue::I32(v)) => _ = (*p)._internal_set_plain_value(*v),
                    (ParamPtr::EnumParam(p), ParamValue::String(id)) => _ = (*p).set_from_id(id),
                    _ => {}
                }
            }
        }
        params.deserialize_fields(&state.fields);
        let saved = map
            .iter()
            .map(|(id, ptr, _)| {
                // SAFETY: as above.
                let shown = unsafe {
                    match ptr {
                        ParamPtr::EnumParam(p) => format!("{} {}", (**p).unmodulated_plain_id().unwrap_or(""), **p),
                        ParamPtr::FloatParam(p) => format!("{} {}", (**p).unmodulated_plain_value(), **p),
                        ParamPtr::IntParam(p) => format!("{} {}", (**p).unmodulated_plain_value(), **p),
                        ParamPtr::BoolParam(p) => format!("{} {}", (**p).unmodulated_plain_value(), **p),
                    }
                };
                (id.clone(), shown)
            })
            .collect();
        (params, saved)
    }

    /// A session saved before the coincident pair was added loads its
    /// microphones as they were, named by id or by index; the coincident
    /// pair saves and loads as the others do.
    #[test]
    fn a_saved_microphone_choice_loads_where_it_was() {
        use struck_engine::body::soundboard::Perspective;
        let ids = ["close", "player", "lid", "coincident"];
        assert_eq!(<crate::params::PerspectiveChoice as Enum>::ids(), Some(&ids[..]));
        for (index, (id, perspective)) in ids.into_iter().zip(Perspective::ALL).enumerate() {
            for value in [ParamValue::String(id.to_string()), ParamValue::I32(index as i32)] {
                let mut state = default_state();
                state.params.insert("mic".to_string(), value);
                assert!(repair(&mut state).is_empty(), "{id}");
                let (params, shown) = apply_and_save(&state);
                assert_eq!(params.mics().perspective, perspective, "{id}");
                assert!(shown["mic"].starts_with(id), "{}", shown["mic"]);
            }
        }
    }

    #[test]
    fn a_sound_state_is_left_as_it_is() {
        let mut state = default_state();
        assert_eq!(state.params.len(), StruckParams::default().param_map().len());
        let before = format!("{state:?}");
        assert_eq!(repair(&mut state), Vec::<String>::new());
        assert_eq!(format!("{state:?}"), before);
        // Every value a parameter can take is kept: each end of every range, every choice.
        for r in rules(&StruckParams::default()) {
            let values = match &r.takes {
                Takes::Float { lo, hi, .. } => vec![ParamValue::F32(*lo), ParamValue::F32(*hi)],
                Takes::Int { lo, hi, .. } => vec![ParamValue::I32(*lo), ParamValue::I32(*hi)],
                Takes::Bool { .. } => vec![ParamValue::Bool(false), ParamValue::Bool(true)],
                Takes::Enum { ids, .. } => ids
                    .iter()
                    .map(|id| ParamValue::String(id.to_string()))
                    .chain((0..ids.len()).map(|i| ParamValue::I32(i as i32)))
                    .collect(),
            };
            for value in values {
                assert_eq!(r.takes.refuses(&value), None, "{}: {value:?}", r.id);
            }
        }
        // And a scale that plays.
        let scale = struck_engine::tuning::ScalaScale::parse("! x.scl\nfifths\n 2\n!\n 700.0\n 2/1\n").unwrap();
        let mut state = default_state();
        state.fields.insert("scala-scale".into(), serde_json::to_string(&Some(scale)).unwrap());
        let before = format!("{state:?}");
        assert_eq!(repair(&mut state), Vec::<String>::new());
        assert_eq!(format!("{state:?}"), before);
    }

    #[test]
    fn the_rules_are_read_off_the_parameters() {
        let Takes::Enum { ids, default } = rule("inst").takes else { panic!("inst is not a choice") };
        assert_eq!(ids, ["piano", "fortepiano", "santoor", "dulcimer", "cimbalom", "clavichord", "harpsichord"]);
        assert_eq!((ids.len(), default), (InstrumentChoice::ALL.len(), 0));
        assert_eq!(rule("poly").takes, Takes::Int { lo: 1, hi: 128, default: 64 });
        assert_eq!(rule("gain").takes, Takes::Float { lo: -60.0, hi: 12.0, default: 0.0 });
        assert_eq!(rule("pace").takes, Takes::Bool { default: true });
        let Takes::Float { lo, hi, default } = rule("hmass").takes else { panic!() };
        assert!((lo - 0.25).abs() < 1e-6 && (hi - 4.0).abs() < 1e-5 && default == 1.0, "{lo} {hi} {default}");
    }

    #[test]
    fn every_enum_out_of_range_falls_back_to_its_default_with_a_line() {
        let enums: Vec<Rule> =
            rules(&StruckParams::default()).into_iter().filter(|r| matches!(r.takes, Takes::Enum { .. })).collect();
        assert_eq!(enums.len(), 4, "{enums:?}");
        let bad = [
            ParamValue::I32(99),
            ParamValue::I32(-1),
            ParamValue::I32(i32::MIN),
            ParamValue::I32(i32::MAX),
            ParamValue::String("organ".into()),
            ParamValue::String(String::new()),
            ParamValue::F32(1.0),
            ParamValue::Bool(true),
        ];
        for value in bad {
            let mut state = default_state();
            for r in &enums {
                state.params.insert(r.id.clone(), value.clone());
            }
            // Without the repair, what the host does next panics.
            let unrepaired = state.clone();
            if matches!(value, ParamValue::I32(_)) {
                let panicked = std::panic::catch_unwind(|| apply_and_save(&unrepaired)).is_err();
                assert!(panicked, "{value:?} applied unrepaired did not panic: no test");
            }
            let said = repair(&mut state);
            assert_eq!(said.len(), enums.len(), "{value:?}: {said:?}");
            for (r, line) in enums.iter().zip(&said) {
                assert!(line.contains(&format!("\"{}\"", r.id)) && line.contains("default"), "{line}");
                assert!(!line.contains('\n'), "{line}");
                assert_eq!(format!("{:?}", state.params[&r.id]), format!("{:?}", r.takes.default_value()));
            }
            let (_, saved) = apply_and_save(&state);
            assert!(saved["inst"].starts_with("piano Piano"), "{}", saved["inst"]);
            assert!(saved["temp"].starts_with("equal Equal"), "{}", saved["temp"]);
        }
    }

    #[test]
    fn numbers_that_are_not_in_range_fall_back_to_their_defaults() {
        let bad_floats = [f32::NAN, f32::INFINITY, f32::NEG_INFINITY, 1e30, -1e30, f32::MAX, 13.0];
        for v in bad_floats {
            let mut state = default_state();
            state.params.insert("gain".into(), ParamValue::F32(v));
            state.params.insert("hmass".into(), ParamValue::F32(v));
            let said = repair(&mut state);
            assert_eq!(said.len(), 2, "{v}: {said:?}");
            let gain = said.iter().find(|l| l.contains("\"gain\" (Level)")).unwrap();
            if v == 1e30 {
                assert!(gain.contains(": 1e30 is not"), "{gain}");
            }
            assert!(gain.contains("is not a number from -60 to 12; it is set to its default, 0"), "{gain}");
            assert!(matches!(state.params["gain"], ParamValue::F32(0.0)));
            assert!(matches!(state.params["hmass"], ParamValue::F32(1.0)));
            let (params, _) = apply_and_save(&state);
            assert_eq!(params.controls(), struck_engine::synth::Controls::default());
            assert_eq!(params.voicing(), struck_engine::design::Voicing::default());
        }
        for (id, v) in [("poly", 0), ("poly", 129), ("poly", -1), ("poly", i32::MAX), ("bend", 25), ("root", 12)] {
            let mut state = default_state();
            state.params.insert(id.into(), ParamValue::I32(v));
            let said = repair(&mut state);
            assert_eq!(said.len(), 1, "{id} {v}: {said:?}");
            assert!(said[0].contains(&format!("{v} is not a whole number")), "{}", said[0]);
            assert_eq!(format!("{:?}", state.params[id]), format!("{:?}", rule(id).takes.default_value()));
        }
    }

    #[test]
    fn values_of_the_wrong_type_fall_back_to_their_defaults() {
        for (id, value) in [
            ("gain", ParamValue::String("loud".into())),
            ("gain", ParamValue::I32(3)),
            ("gain", ParamValue::Bool(false)),
            ("poly", ParamValue::F32(64.0)),
            ("poly", ParamValue::String("64".into())),
            ("mpe", ParamValue::I32(1)),
            ("mpe", ParamValue::String("on".into())),
            ("temp", ParamValue::F32(2.0)),
        ] {
            let mut state = default_state();
            state.params.insert(id.into(), value.clone());
            let said = repair(&mut state);
            assert_eq!(said.len(), 1, "{id} {value:?}: {said:?}");
            assert!(said[0].contains(", where it takes "), "{}", said[0]);
            assert_eq!(format!("{:?}", state.params[id]), format!("{:?}", rule(id).takes.default_value()));
        }
        // An id the plugin does not know is left for the wrapper (which skips it).
        let mut state = default_state();
        state.params.insert("nope".into(), ParamValue::I32(99));
        assert!(repair(&mut state).is_empty());
    }

    #[test]
    fn persisted_fields_that_do_not_read_fall_back_to_their_defaults() {
        let defaults = StruckParams::default().serialize_fields();
        let cases: &[(&str, &str)] = &[
            ("scala-scale", "42"),
            ("scala-scale", "\"a scale\""),
            ("scala-scale", "{"),
            ("scala-scale", ""),
            ("scala-scale", r#"{"degrees_cents": []}"#),
            ("scala-scale", r#"{"degrees_cents": [700.0, -1200.0]}"#),
            ("scala-scale", r#"{"degrees_cents": [1200.0], "colour": "red"}"#),
            ("scala-scale", r#"{"degrees_cents": ["1200"]}"#),
            ("scala-files", "42"),
            ("scala-files", "null"),
            ("state-version", "\"one\""),
            ("state-version", "-1"),
            ("state-version", "1.5"),
            ("state-version", "1e300"),
        ];
        // Every persisted field is checked (a new one must be added to `field_refused`).
        for key in defaults.keys() {
            assert!(field_refused(key, "{").is_some(), "{key} is not checked");
            assert_eq!(field_refused(key, &defaults[key]), None, "{key}'s default is refused");
        }
        for (key, data) in cases {
            let mut state = default_state();
            state.fields.insert(key.to_string(), data.to_string());
            let said = repair(&mut state);
            assert_eq!(said.len(), 1, "{key} = {data}: {said:?}");
            assert!(said[0].contains(&format!("\"{key}\" is not")), "{}", said[0]);
            assert!(!said[0].contains('\n'), "{}", said[0]);
            assert_eq!(state.fields[*key], defaults[*key], "{key} = {data}");
            let (params, _) = apply_and_save(&state);
            assert_eq!(params.tuning(), TuningSettings::default());
        }
    }

    #[test]
    fn a_state_read_from_json_with_numbers_out_of_range_is_repaired() {
        let text = r#"{"version":"0.1.0","params":{"gain":{"f32":3e38},"a4":{"f32":-3e38},"inst":{"i32":99},
            "mic":{"i32":-1},"poly":{"i32":2147483647}},"fields":{"state-version":"1e300"}}"#;
        let mut state: PluginState = serde_json::from_str(text).unwrap();
        let said = repair(&mut state);
        assert_eq!(said.len(), 6, "{said:#?}");
        let (params, shown) = apply_and_save(&state);
        assert_eq!(params.tuning(), TuningSettings::default());
        assert_eq!(params.controls(), struck_engine::synth::Controls::default());
        assert!(shown["mic"].starts_with("close Close"), "{}", shown["mic"]);
        // A number no f32 holds makes the whole state unreadable: the wrapper
        // refuses it before the plugin sees it, and nothing changes.
        assert!(serde_json::from_str::<PluginState>(&text.replace("3e38", "1e300")).is_err());
    }
}
