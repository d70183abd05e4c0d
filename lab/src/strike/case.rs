//! The strike case: one string excited once, as a JSON file (the contract is
//! `strike-case.md`: units SI, x = 0 at the bridge, y along the exciter's push).
//!
//! Parsing goes through a JSON tree so that every refusal names the field it is
//! about (`string.q[2]`, `exciter.position`) and so `--set path=value` can edit the
//! tree before it is checked. A case is either entirely valid or refused with one
//! [`CaseError`]; nothing is half-built.

use serde_json::{Map, Value};

use struck_engine::exciter::hammer::contact::ContactLaw;
use struck_engine::exciter::hammer::{HammerSpec, Hysteresis};
use struck_engine::exciter::pluck::PluckSpec;
use struck_engine::exciter::tangent::TangentSpec;
use struck_engine::string::damping::{Damping, PhysicalLoss};
use struck_engine::string::{MAX_MODES, Mass, Stiffness, StringError, StringModes, StringSpec, Tuning};

/// Lowest and highest sample rates the lab accepts, Hz.
pub const SAMPLE_RATE_RANGE_HZ: (f64, f64) = (8_000.0, 1_536_000.0);
/// Longest case, s (a trace row per sample must fit in memory and on disk).
pub const MAX_DURATION_S: f64 = 60.0;
/// Default mode cut-off of the lab, as a fraction of the sample rate.
pub const LAB_CUTOFF_FRACTION: f64 = 0.45;
/// Largest felt exponent accepted (measured hammers lie between 1.5 and 5).
pub const MAX_EXPONENT: f64 = 10.0;

/// A refused case: the field and why (shown with the control characters of
/// what they quote from the case escaped).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[error("{}: {}", struck_engine::printable(.field), struck_engine::printable(.reason))]
pub struct CaseError {
    pub field: String,
    pub reason: String,
}

fn refuse<T>(field: impl Into<String>, reason: impl Into<String>) -> Result<T, CaseError> {
    Err(CaseError { field: field.into(), reason: reason.into() })
}

/// What excites the string.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum ExciterSpec {
    Hammer(HammerSpec),
    Tangent(TangentSpec),
    Pluck(PluckSpec),
}

/// A checked strike case.
#[derive(Clone, Debug, PartialEq)]
pub struct StrikeCase {
    pub name: Option<String>,
    pub sample_rate_hz: f64,
    pub duration_s: f64,
    pub string: StringSpec,
    pub exciter: ExciterSpec,
}

impl StrikeCase {
    /// Number of samples (trace rows), t = 0 included.
    pub fn sample_count(&self) -> usize {
        (self.duration_s * self.sample_rate_hz).round() as usize
    }

    /// The string with everything derived (cannot fail for a parsed case).
    pub fn build_string(&self) -> StringModes {
        self.string.build().expect("checked when the case was parsed")
    }
}

/// Parse and check a case from JSON text, after applying `sets` (each
/// `path=value`, as given to `--set`).
pub fn parse_case(text: &str, sets: &[String]) -> Result<StrikeCase, CaseError> {
    let mut root =
        struck_engine::preset::strict_json(text).or_else(|e| refuse("case", format!("not valid JSON: {e}")))?;
    for set in sets {
        apply_set(&mut root, set)?;
    }
    case_from_value(&root)
}

/// Apply one `path=value` edit. The value is read as JSON when it parses as JSON
/// (a number, an array, true, "text"), otherwise as a bare string.
pub fn apply_set(root: &mut Value, set: &str) -> Result<(), CaseError> {
    let field = format!("--set {set}");
    let Some((path, raw)) = set.split_once('=') else {
        return refuse(field, "expected path=value, e.g. exciter.speed_m_s=2.5");
    };
    let value = serde_json::from_str(raw.trim()).unwrap_or_else(|_| Value::String(raw.to_string()));
    let keys: Vec<&str> = path.trim().split('.').collect();
    if keys.iter().any(|k| k.is_empty()) {
        return refuse(field, "the path has an empty part");
    }
    let mut node = root;
    for (depth, key) in keys.iter().enumerate() {
        let last = depth + 1 == keys.len();
        let here = keys[..depth].join(".");
        node = match node {
            Value::Object(map) if last => {
                map.insert(key.to_string(), value);
                return Ok(());
            }
            Value::Object(map) => match map.get_mut(*key) {
                Some(next) => next,
                None => return refuse(field, format!("{} does not exist", keys[..=depth].join("."))),
            },
            Value::Array(items) => match key.parse::<usize>().ok().filter(|i| *i < items.len()) {
                Some(i) if last => {
                    items[i] = value;
                    return Ok(());
                }
                Some(i) => &mut items[i],
                None => return refuse(field, format!("{here} has no element {key}")),
            },
            _ => return refuse(field, format!("{here} is not an object")),
        };
    }
    unreachable!("the loop returns at the last key")
}

/// Reads the fields of one JSON object, refusing unknown ones.
struct Fields<'a> {
    path: String,
    map: &'a Map<String, Value>,
}

impl<'a> Fields<'a> {
    fn new(path: &str, value: Option<&'a Value>, allowed: &[&str]) -> Result<Self, CaseError> {
        let map = match value {
            Some(Value::Object(map)) => map,
            Some(_) => return refuse(path, "must be an object"),
            None => return refuse(path, "missing"),
        };
        if let Some(key) = map.keys().find(|k| !allowed.contains(&k.as_str())) {
            return refuse(Self::join(path, key), format!("unknown field (known here: {})", allowed.join(", ")));
        }
        Ok(Self { path: path.to_string(), map })
    }

    fn join(path: &str, key: &str) -> String {
        if path.is_empty() { key.to_string() } else { format!("{path}.{key}") }
    }

    fn name(&self, key: &str) -> String {
        Self::join(&self.path, key)
    }

    fn has(&self, key: &str) -> bool {
        self.map.contains_key(key)
    }

    fn number(&self, key: &str) -> Result<Option<f64>, CaseError> {
        match self.map.get(key) {
            None => Ok(None),
            Some(Value::Number(n)) => match n.as_f64() {
                Some(v) if v.is_finite() => Ok(Some(v)),
                _ => refuse(self.name(key), "must be a finite number"),
            },
            Some(other) => refuse(self.name(key), format!("must be a number (got {other})")),
        }
    }

    fn required(&self, key: &str) -> Result<f64, CaseError> {
        self.number(key)?.map_or_else(|| refuse(self.name(key), "missing"), Ok)
    }

    fn check(&self, key: &str, value: f64, ok: bool, rule: &str) -> Result<f64, CaseError> {
        if ok { Ok(value) } else { refuse(self.name(key), format!("{rule} (got {})", struck_engine::readable(value))) }
    }

    fn positive(&self, key: &str) -> Result<f64, CaseError> {
        let v = self.required(key)?;
        self.check(key, v, v > 0.0, "must be positive")
    }

    fn optional_positive(&self, key: &str) -> Result<Option<f64>, CaseError> {
        match self.number(key)? {
            Some(v) => self.check(key, v, v > 0.0, "must be positive").map(Some),
            None => Ok(None),
        }
    }

    fn fraction(&self, key: &str) -> Result<f64, CaseError> {
        let v = self.required(key)?;
        self.check(
            key,
            v,
            v > 0.0 && v < 1.0,
            "must lie strictly between 0 and 1 (a fraction of the length from the bridge)",
        )
    }

    /// Refuse `key` when `other` is also given.
    fn exclusive(&self, key: &str, other: &str, advice: &str) -> Result<(), CaseError> {
        if self.has(key) && self.has(other) {
            return refuse(self.name(key), format!("contradicts {}: {advice}", self.name(other)));
        }
        Ok(())
    }
}

const CASE_FIELDS: &[&str] = &["name", "sample_rate_hz", "duration_s", "string", "exciter"];
const STRING_FIELDS: &[&str] = &[
    "length_m",
    "f1_hz",
    "tension_n",
    "mass_per_length_kg_m",
    "diameter_m",
    "density_kg_m3",
    "inharmonicity",
    "youngs_modulus_pa",
    "core_diameter_m",
    "q",
    "internal_loss_factor",
    "bridge_admittance_s_kg",
    "max_frequency_hz",
];
const HAMMER_FIELDS: &[&str] = &["kind", "mass_kg", "stiffness", "exponent", "speed_m_s", "position", "hysteresis"];
const HYSTERESIS_FIELDS: &[&str] = &["epsilon", "tau_s"];
const TANGENT_FIELDS: &[&str] = &["kind", "speed_m_s", "displacement_m"];
const PLUCK_FIELDS: &[&str] = &["kind", "displacement_m", "position"];

/// Every field name a case may hold, at any depth, once each (for tools that
/// edit cases, and tests that damage them).
pub fn field_names() -> Vec<&'static str> {
    let mut names: Vec<&'static str> =
        [CASE_FIELDS, STRING_FIELDS, HAMMER_FIELDS, HYSTERESIS_FIELDS, TANGENT_FIELDS, PLUCK_FIELDS].concat();
    names.sort_unstable();
    names.dedup();
    names
}

fn case_from_value(root: &Value) -> Result<StrikeCase, CaseError> {
    let top = Fields::new("", Some(root), CASE_FIELDS)
        .map_err(|e| if e.field.is_empty() { CaseError { field: "case".into(), reason: e.reason } } else { e })?;
    let name = match root.get("name") {
        None => None,
        Some(Value::String(s)) => Some(s.clone()),
        Some(_) => return refuse("name", "must be a string"),
    };
    let fs = top.required("sample_rate_hz")?;
    let (lo, hi) = SAMPLE_RATE_RANGE_HZ;
    top.check("sample_rate_hz", fs, (lo..=hi).contains(&fs), &format!("must lie between {lo} and {hi} Hz"))?;
    let duration_s = top.positive("duration_s")?;
    top.check("duration_s", duration_s, duration_s <= MAX_DURATION_S, &format!("must be at most {MAX_DURATION_S} s"))?;
    if (duration_s * fs).round() < 1.0 {
        return refuse("duration_s", format!("shorter than one sample at {fs} Hz"));
    }
    let string = string_from_value(root.get("string"), fs)?;
    let exciter = exciter_from_value(root.get("exciter"))?;
    Ok(StrikeCase { name, sample_rate_hz: fs, duration_s, string, exciter })
}

fn string_from_value(value: Option<&Value>, fs: f64) -> Result<StringSpec, CaseError> {
    let s = Fields::new("string", value, STRING_FIELDS)?;
    let length_m = s.positive("length_m")?;

    s.exclusive("tension_n", "f1_hz", "give exactly one of them")?;
    let tuning = match (s.optional_positive("f1_hz")?, s.optional_positive("tension_n")?) {
        (Some(f1), None) => Tuning::FirstPartialHz(f1),
        (None, Some(t)) => Tuning::TensionN(t),
        _ => return refuse("string.f1_hz", "missing (give f1_hz or tension_n)"),
    };

    s.exclusive("density_kg_m3", "mass_per_length_kg_m", "give the mass one way")?;
    let diameter = s.optional_positive("diameter_m")?;
    let mass = match (s.optional_positive("mass_per_length_kg_m")?, s.optional_positive("density_kg_m3")?) {
        (Some(mu), None) => Mass::PerLengthKgM(mu),
        (None, Some(rho)) => match diameter {
            Some(d) => Mass::SolidWire { diameter_m: d, density_kg_m3: rho },
            None => return refuse("string.density_kg_m3", "needs string.diameter_m to give the mass"),
        },
        _ if diameter.is_some() => {
            return refuse("string.density_kg_m3", "missing (diameter_m gives the mass only with a density)");
        }
        _ => {
            return refuse(
                "string.mass_per_length_kg_m",
                "missing (give mass_per_length_kg_m, or diameter_m and density_kg_m3)",
            );
        }
    };

    s.exclusive("youngs_modulus_pa", "inharmonicity", "give at most one of them")?;
    let core = s.optional_positive("core_diameter_m")?;
    let stiffness = match (s.number("inharmonicity")?, s.optional_positive("youngs_modulus_pa")?) {
        (Some(b), None) => {
            s.check("inharmonicity", b, b >= 0.0, "must not be negative")?;
            if core.is_some() {
                return refuse("string.core_diameter_m", "only used with youngs_modulus_pa");
            }
            Stiffness::Inharmonicity(b)
        }
        (None, Some(e)) => {
            if let (Some(c), Some(d)) = (core, diameter)
                && c > d
            {
                return refuse("string.core_diameter_m", format!("larger than string.diameter_m ({c} > {d})"));
            }
            match core.or(diameter) {
                Some(d) => Stiffness::YoungsModulus { modulus_pa: e, bending_diameter_m: d },
                None => return refuse("string.youngs_modulus_pa", "needs string.diameter_m or string.core_diameter_m"),
            }
        }
        _ => {
            if core.is_some() {
                return refuse("string.core_diameter_m", "only used with youngs_modulus_pa");
            }
            Stiffness::Flexible
        }
    };

    let damping = match s.map.get("q") {
        Some(q) => {
            for key in ["internal_loss_factor", "bridge_admittance_s_kg"] {
                if s.has(key) {
                    return refuse(
                        s.name(key),
                        "contradicts string.q: the physical loss model applies only when q is absent",
                    );
                }
            }
            q_from_value(q)?
        }
        None => {
            let mut loss = PhysicalLoss::default();
            if let Some(eta) = s.number("internal_loss_factor")? {
                loss.internal_loss_factor = s.check("internal_loss_factor", eta, eta >= 0.0, "must not be negative")?;
            }
            if let Some(y) = s.number("bridge_admittance_s_kg")? {
                loss.bridge_admittance_s_kg = s.check("bridge_admittance_s_kg", y, y >= 0.0, "must not be negative")?;
            }
            Damping::Physical(loss)
        }
    };

    let nyquist = fs / 2.0;
    let max_frequency_hz = match s.optional_positive("max_frequency_hz")? {
        Some(f) => s.check(
            "max_frequency_hz",
            f,
            f <= nyquist,
            &format!("must not exceed the Nyquist frequency {nyquist} Hz"),
        )?,
        None => LAB_CUTOFF_FRACTION * fs,
    };

    let spec = StringSpec { length_m, tuning, mass, stiffness, damping, max_frequency_hz, outer_diameter_m: diameter };
    match spec.build() {
        Ok(modes) if modes.mode_count() >= MAX_MODES => {
            refuse("string.max_frequency_hz", format!("keeps more than {} modes; lower it", MAX_MODES - 1))
        }
        Ok(_) => Ok(spec),
        Err(e @ StringError::TooStiffToTune { .. }) => refuse("string.f1_hz", e.to_string()),
        Err(e @ StringError::NoModes { .. }) => refuse(
            if s.has("max_frequency_hz") { "string.max_frequency_hz" } else { "sample_rate_hz" },
            format!("the mode grid is empty: {e}"),
        ),
        Err(e @ StringError::Overdamped { .. }) => refuse("string.q", e.to_string()),
        Err(e @ StringError::NotPositive(_)) => refuse("string", e.to_string()),
    }
}

fn q_from_value(q: &Value) -> Result<Damping, CaseError> {
    let check = |field: String, v: &Value| -> Result<f64, CaseError> {
        match v.as_f64() {
            Some(q) if q.is_finite() && q > 0.5 => Ok(q),
            Some(q) => refuse(
                field,
                format!("must be a number greater than 0.5, an underdamped mode (got {})", struck_engine::readable(q)),
            ),
            None => refuse(field, format!("must be a number (got {v})")),
        }
    };
    match q {
        Value::Array(items) if items.is_empty() => refuse("string.q", "an empty list; give at least one Q"),
        Value::Array(items) => Ok(Damping::PerModeQ(
            items.iter().enumerate().map(|(i, v)| check(format!("string.q[{i}]"), v)).collect::<Result<_, _>>()?,
        )),
        other => Ok(Damping::UniformQ(check("string.q".into(), other)?)),
    }
}

fn exciter_from_value(value: Option<&Value>) -> Result<ExciterSpec, CaseError> {
    let kind = match value {
        Some(Value::Object(map)) => match map.get("kind") {
            Some(Value::String(kind)) => kind.as_str(),
            Some(other) => return refuse("exciter.kind", format!("must be a string (got {other})")),
            None => return refuse("exciter.kind", "missing (hammer, tangent or pluck)"),
        },
        Some(_) => return refuse("exciter", "must be an object"),
        None => return refuse("exciter", "missing"),
    };
    match kind {
        "hammer" => {
            let e = Fields::new("exciter", value, HAMMER_FIELDS)?;
            let exponent = e.required("exponent")?;
            e.check(
                "exponent",
                exponent,
                (1.0..=MAX_EXPONENT).contains(&exponent),
                &format!("must lie between 1 and {MAX_EXPONENT}"),
            )?;
            Ok(ExciterSpec::Hammer(HammerSpec {
                mass_kg: e.positive("mass_kg")?,
                law: ContactLaw { stiffness: e.positive("stiffness")?, exponent },
                speed_m_s: e.positive("speed_m_s")?,
                position: e.fraction("position")?,
                hysteresis: hysteresis_from(&e)?,
            }))
        }
        "tangent" => {
            let e = Fields::new("exciter", value, TANGENT_FIELDS)?;
            Ok(ExciterSpec::Tangent(TangentSpec {
                speed_m_s: e.positive("speed_m_s")?,
                displacement_m: e.positive("displacement_m")?,
            }))
        }
        "pluck" => {
            let e = Fields::new("exciter", value, PLUCK_FIELDS)?;
            Ok(ExciterSpec::Pluck(PluckSpec {
                displacement_m: e.positive("displacement_m")?,
                position: e.fraction("position")?,
            }))
        }
        other => refuse("exciter.kind", format!("unknown kind \"{other}\" (hammer, tangent or pluck)")),
    }
}

/// A hammer's optional `hysteresis`, `{"epsilon": e, "tau_s": t}`: the felt
/// F = K [C^alpha - (e / t) int_0^now C(s)^alpha exp(-(now - s) / t) ds]
/// (Stulov 1995), 0 <= e < 1, t > 0 s. Absent: elastic.
fn hysteresis_from(hammer: &Fields) -> Result<Option<Hysteresis>, CaseError> {
    let Some(value) = hammer.map.get("hysteresis") else { return Ok(None) };
    let h = Fields::new(&hammer.name("hysteresis"), Some(value), HYSTERESIS_FIELDS)?;
    let epsilon = h.required("epsilon")?;
    h.check(
        "epsilon",
        epsilon,
        (0.0..1.0).contains(&epsilon),
        "must lie in [0, 1) (the share of the force the felt's memory takes back)",
    )?;
    let tau_s = h.positive("tau_s")?;
    Ok(Some(Hysteresis { epsilon, tau_s }))
}

#[cfg(test)]
mod tests {
    use super::*;

    const S1: &str = r#"{
        "name": "S1", "sample_rate_hz": 96000, "duration_s": 0.5,
        "string": { "length_m": 0.4, "f1_hz": 440.0, "diameter_m": 0.0005,
                    "density_kg_m3": 7850.0, "youngs_modulus_pa": 2.0e11, "q": 1000.0 },
        "exciter": { "kind": "hammer", "mass_kg": 0.001, "stiffness": 1.0e6, "exponent": 1.0,
                     "speed_m_s": 1.0, "position": 0.4 }
    }"#;

    fn refused(sets: &[&str]) -> CaseError {
        let sets: Vec<String> = sets.iter().map(|s| s.to_string()).collect();
        parse_case(S1, &sets).expect_err("should be refused")
    }

    #[test]
    fn the_spec_example_parses() {
        let case = parse_case(S1, &[]).unwrap();
        assert_eq!(case.sample_count(), 48_000);
        let s = case.build_string();
        assert!((s.partial_hz(1) - 440.0).abs() < 1e-9);
        assert!(matches!(case.exciter, ExciterSpec::Hammer(h) if h.position == 0.4));
    }

    #[test]
    fn set_edits_before_checking() {
        let case = parse_case(S1, &["exciter.speed_m_s=2.5".into(), "string.q=[300, 400]".into()]).unwrap();
        assert!(matches!(case.exciter, ExciterSpec::Hammer(h) if h.speed_m_s == 2.5));
        assert_eq!(case.string.damping, Damping::PerModeQ(vec![300.0, 400.0]));
        let case = parse_case(S1, &["string.q=[300, 400]".into(), "string.q.1=500".into()]).unwrap();
        assert_eq!(case.string.damping, Damping::PerModeQ(vec![300.0, 500.0]));
    }

    #[test]
    fn a_hammer_may_have_a_hysteretic_felt() {
        let case = parse_case(S1, &[]).unwrap();
        assert!(matches!(case.exciter, ExciterSpec::Hammer(h) if h.hysteresis.is_none()));
        let set = r#"exciter.hysteresis={"epsilon": 0.2, "tau_s": 2e-5}"#.to_string();
        let case = parse_case(S1, &[set]).unwrap();
        let expected = Some(Hysteresis { epsilon: 0.2, tau_s: 2e-5 });
        assert!(matches!(case.exciter, ExciterSpec::Hammer(h) if h.hysteresis == expected));
        // Zero is allowed: the elastic felt.
        let set = r#"exciter.hysteresis={"epsilon": 0, "tau_s": 2e-5}"#.to_string();
        assert!(parse_case(S1, &[set]).is_ok());
    }

    #[test]
    fn each_rule_names_its_field() {
        let cases: &[(&[&str], &str)] = &[
            (&["exciter.position=1.2"], "exciter.position"),
            (&["exciter.exponent=0.5"], "exciter.exponent"),
            (&["exciter.mass_kg=-1"], "exciter.mass_kg"),
            (&["string.tension_n=100"], "string.tension_n"),
            (&["string.mass_per_length_kg_m=0.001"], "string.density_kg_m3"),
            (&["string.inharmonicity=1e-4"], "string.youngs_modulus_pa"),
            (&["string.max_frequency_hz=100"], "string.max_frequency_hz"),
            (&["string.diamter_m=0.001"], "string.diamter_m"),
            (&["string.q=0.2"], "string.q"),
            (&["string.q=[]"], "string.q"),
            (&["string.q=[1000, \"x\"]"], "string.q[1]"),
            (&["exciter.kind=bow"], "exciter.kind"),
            (&["exciter.hysteresis=0.9"], "exciter.hysteresis"),
            (&["exciter.hysteresis=null"], "exciter.hysteresis"),
            (&[r#"exciter.hysteresis={"epsilon": 1.0, "tau_s": 1e-5}"#], "exciter.hysteresis.epsilon"),
            (&[r#"exciter.hysteresis={"epsilon": -0.1, "tau_s": 1e-5}"#], "exciter.hysteresis.epsilon"),
            (&[r#"exciter.hysteresis={"epsilon": "x", "tau_s": 1e-5}"#], "exciter.hysteresis.epsilon"),
            (&[r#"exciter.hysteresis={"tau_s": 1e-5}"#], "exciter.hysteresis.epsilon"),
            (&[r#"exciter.hysteresis={"epsilon": 0.2, "tau_s": 0}"#], "exciter.hysteresis.tau_s"),
            (&[r#"exciter.hysteresis={"epsilon": 0.2, "tau_s": -1e-5}"#], "exciter.hysteresis.tau_s"),
            (&[r#"exciter.hysteresis={"epsilon": 0.2}"#], "exciter.hysteresis.tau_s"),
            (&[r#"exciter.hysteresis={"epsilon": 0.2, "tau": 1e-5}"#], "exciter.hysteresis.tau"),
            (&["sample_rate_hz=10"], "sample_rate_hz"),
            (&["duration_s=0"], "duration_s"),
            (&["string.max_frequency_hz=60000"], "string.max_frequency_hz"),
            (&["string.bridge_admittance_s_kg=0.001"], "string.bridge_admittance_s_kg"),
            (&["exciter.kind=tangent"], "exciter.exponent"),
            (&["nonsense"], "--set nonsense"),
            (&["string.nothing.deeper=1"], "--set string.nothing.deeper=1"),
        ];
        for (sets, field) in cases {
            assert_eq!(refused(sets).field, *field, "{sets:?}");
        }
        assert_eq!(parse_case("{", &[]).unwrap_err().field, "case");
        assert_eq!(parse_case("[1]", &[]).unwrap_err().field, "case");
    }
}
