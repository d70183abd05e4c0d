//! What the fuzzing tests share: how many cases a property runs, and inputs made
//! by damaging valid ones (bytes flipped, cut, inserted, removed or repeated;
//! a JSON value replaced somewhere in its tree).
//!
//! The lab's fuzzing tests include this file too (`#[path]`), so it uses only
//! proptest and serde_json, which both crates have.

#![allow(dead_code)]

use proptest::prelude::*;
use proptest::test_runner::Config;
use serde_json::Value;

/// Cases for one property: `STRUCK_FUZZ_CASES` when set (for a longer run on
/// a developer's machine), else `default`, chosen so the whole suite stays
/// within about a minute. No failure files are written: a crasher found is kept
/// as a named regression test instead.
pub fn config(default: u32) -> Config {
    let cases = std::env::var("STRUCK_FUZZ_CASES").ok().and_then(|v| v.trim().parse().ok()).unwrap_or(default);
    Config { cases, failure_persistence: None, ..Config::default() }
}

/// One way of damaging a byte string. Positions are taken modulo the length
/// of the input at that point, so any position fits any input.
#[derive(Clone, Debug)]
pub enum Mutation {
    /// Flip one bit.
    Flip { at: usize, bit: u8 },
    /// Set one byte (often to a boundary value: 0, 0x7f, 0x80, 0xff).
    Set { at: usize, value: u8 },
    /// Cut the input short.
    Truncate { at: usize },
    /// Put bytes in.
    Insert { at: usize, bytes: Vec<u8> },
    /// Take a stretch out.
    Remove { at: usize, len: usize },
    /// Repeat a stretch in place.
    Repeat { at: usize, len: usize, times: usize },
}

fn boundary_byte() -> impl Strategy<Value = u8> {
    prop_oneof![Just(0u8), Just(0x7f), Just(0x80), Just(0xff), Just(b'\n'), Just(b'.'), Just(b'-'), any::<u8>()]
}

/// A mutation, any kind.
pub fn mutation() -> impl Strategy<Value = Mutation> {
    prop_oneof![
        (any::<usize>(), 0u8..8).prop_map(|(at, bit)| Mutation::Flip { at, bit }),
        (any::<usize>(), boundary_byte()).prop_map(|(at, value)| Mutation::Set { at, value }),
        any::<usize>().prop_map(|at| Mutation::Truncate { at }),
        (any::<usize>(), proptest::collection::vec(boundary_byte(), 1..16))
            .prop_map(|(at, bytes)| Mutation::Insert { at, bytes }),
        (any::<usize>(), 1usize..64).prop_map(|(at, len)| Mutation::Remove { at, len }),
        (any::<usize>(), 1usize..64, 1usize..8).prop_map(|(at, len, times)| Mutation::Repeat { at, len, times }),
    ]
}

/// `input` with `mutations` applied in turn.
pub fn mutate(input: &[u8], mutations: &[Mutation]) -> Vec<u8> {
    let mut bytes = input.to_vec();
    for m in mutations {
        let place = |at: usize, n: usize| at % (n + 1);
        let n = bytes.len();
        match m {
            Mutation::Flip { at, bit } if n > 0 => bytes[at % n] ^= 1 << bit,
            Mutation::Set { at, value } if n > 0 => bytes[at % n] = *value,
            Mutation::Flip { .. } | Mutation::Set { .. } => {}
            Mutation::Truncate { at } => bytes.truncate(place(*at, n)),
            Mutation::Insert { at, bytes: new } => {
                let at = place(*at, n);
                bytes.splice(at..at, new.iter().copied());
            }
            Mutation::Remove { at, len } => {
                let at = place(*at, n);
                bytes.drain(at..(at + len).min(n));
            }
            Mutation::Repeat { at, len, times } => {
                let at = place(*at, n);
                let stretch = bytes[at..(at + len).min(n)].to_vec();
                for _ in 0..*times {
                    bytes.splice(at..at, stretch.iter().copied());
                }
            }
        }
    }
    bytes
}

/// One of `seeds`, damaged by one to eight mutations.
pub fn mutated(seeds: Vec<Vec<u8>>) -> impl Strategy<Value = Vec<u8>> {
    (proptest::sample::select(seeds), proptest::collection::vec(mutation(), 1..8))
        .prop_map(|(seed, mutations)| mutate(&seed, &mutations))
}

/// A JSON value of the kinds that break readers: extreme and odd numbers, text
/// with control characters and line breaks, empty and nested containers.
pub fn odd_json() -> impl Strategy<Value = Value> {
    let number = prop_oneof![
        Just(0.0),
        Just(-0.0),
        Just(1.0),
        Just(-1.0),
        Just(0.5),
        Just(1e-320),
        Just(f64::MIN_POSITIVE),
        Just(f64::MAX),
        Just(-f64::MAX),
        Just(1e22),
        Just(1e-22),
        any::<f64>().prop_filter("JSON numbers are finite", |v| v.is_finite()),
    ]
    .prop_map(|v| serde_json::Number::from_f64(v).map_or(Value::Null, Value::Number));
    let leaf = prop_oneof![
        number,
        any::<i64>().prop_map(Value::from),
        any::<u64>().prop_map(Value::from),
        Just(Value::Null),
        any::<bool>().prop_map(Value::Bool),
        "[a-z_]{0,12}".prop_map(Value::String),
        "\\PC{0,8}[\n\r\t\u{1b}\u{7}]\\PC{0,8}".prop_map(Value::String),
        any::<String>().prop_map(Value::String),
    ];
    leaf.prop_recursive(3, 24, 4, |inner| {
        prop_oneof![
            proptest::collection::vec(inner.clone(), 0..4).prop_map(Value::Array),
            proptest::collection::btree_map("[a-z_\n]{0,10}", inner, 0..4)
                .prop_map(|m| Value::Object(m.into_iter().collect())),
        ]
    })
}

/// Where in a JSON tree to make a change, and what: replace the node, remove a
/// field, or add a field (possibly one of `names`, a reader's own field names).
#[derive(Clone, Debug)]
pub enum Tweak {
    Replace { path: Vec<usize>, with: Value },
    Remove { path: Vec<usize> },
    Add { path: Vec<usize>, name: String, value: Value },
}

/// A tweak, with field names drawn from `names` half of the time.
pub fn tweak(names: &'static [&'static str]) -> impl Strategy<Value = Tweak> {
    let path = proptest::collection::vec(any::<usize>(), 0..4);
    let name = prop_oneof![proptest::sample::select(names).prop_map(str::to_string), "\\PC{0,10}"];
    prop_oneof![
        (path.clone(), odd_json()).prop_map(|(path, with)| Tweak::Replace { path, with }),
        path.clone().prop_map(|path| Tweak::Remove { path }),
        (path, name, odd_json()).prop_map(|(path, name, value)| Tweak::Add { path, name, value }),
    ]
}

/// The node at `path`, each step choosing a child modulo the node's size (the
/// walk stops early at a leaf).
fn walk<'a>(node: &'a mut Value, path: &[usize]) -> &'a mut Value {
    let Some((&step, rest)) = path.split_first() else { return node };
    let children = match &*node {
        Value::Array(items) => items.len(),
        Value::Object(map) => map.len(),
        _ => 0,
    };
    if children == 0 {
        return node;
    }
    match node {
        Value::Array(items) => walk(&mut items[step % children], rest),
        Value::Object(map) => walk(map.values_mut().nth(step % children).expect("a child of the object"), rest),
        leaf => leaf,
    }
}

/// `tweaks` applied to `value`.
pub fn apply(mut value: Value, tweaks: &[Tweak]) -> Value {
    for t in tweaks {
        match t {
            Tweak::Replace { path, with } => *walk(&mut value, path) = with.clone(),
            Tweak::Remove { path } => {
                if let Value::Object(map) = walk(&mut value, path)
                    && !map.is_empty()
                {
                    let i = path.last().copied().unwrap_or(0) % map.len();
                    let key = map.keys().nth(i).cloned().unwrap_or_default();
                    map.remove(&key);
                }
            }
            Tweak::Add { path, name, value: new } => {
                if let Value::Object(map) = walk(&mut value, path) {
                    map.insert(name.clone(), new.clone());
                }
            }
        }
    }
    value
}

/// A refusal's message is one line of text: not empty, with no line break and
/// no other control character (an escape sequence quoted from a file would
/// drive the terminal).
pub fn one_line(message: &str) -> Result<(), TestCaseError> {
    prop_assert!(!message.trim().is_empty(), "an empty message");
    prop_assert!(!message.contains(['\n', '\r']), "a message of more than one line: {message:?}");
    prop_assert!(!message.contains(char::is_control), "a control character in a message: {message:?}");
    Ok(())
}
