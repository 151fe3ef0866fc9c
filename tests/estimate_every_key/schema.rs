//! Every numeric key of the spec schema, found through the spec's own errors rather than a
//! list kept by hand: a struct's fields from the error for an unknown field (serde lists them
//! all: "unknown field `zzz_probe`, expected one of `a`, `b`, ..."; a dataset entry those of its
//! kind, so the bases' lists are joined), a field's type from the
//! error for a string in its place ("expected usize", "expected struct PlantParams", "expected
//! a sequence", ...), recursively through nested structs, lists and tuples, and through the
//! sections the spec parses late (a plant's `scene`, a metric's parameters). A key that is
//! added to the schema is found here without anyone listing it.

use serde_yaml_ng::{Mapping, Value};
use std::collections::BTreeSet;
use std::path::PathBuf;

/// One step of a YAML path.
#[derive(Clone, Debug, PartialEq)]
enum Step {
    /// A mapping key.
    Key(String),
    /// A list index.
    Index(usize),
}

/// `datasets[0].scene.plant` -> its steps.
fn steps(path: &str) -> Vec<Step> {
    let mut out = vec![];
    for part in path.split('.').filter(|p| !p.is_empty()) {
        let (key, rest) = part.split_at(part.find('[').unwrap_or(part.len()));
        if !key.is_empty() {
            out.push(Step::Key(key.to_string()));
        }
        for index in rest.split('[').filter(|s| !s.is_empty()) {
            out.push(Step::Index(index.trim_end_matches(']').parse().unwrap()));
        }
    }
    out
}

/// Sets the value at `path` in `doc`, making the mappings and list items on the way (a scalar
/// in the way is replaced).
pub fn set(doc: &mut Value, path: &str, value: Value) {
    let mut at = doc;
    for step in steps(path) {
        at = match step {
            Step::Key(k) => {
                if !at.is_mapping() {
                    *at = Value::Mapping(Mapping::new());
                }
                let m = at.as_mapping_mut().unwrap();
                let key = Value::String(k);
                if !m.contains_key(&key) {
                    m.insert(key.clone(), Value::Null);
                }
                m.get_mut(&key).unwrap()
            }
            Step::Index(i) => {
                if !at.is_sequence() {
                    *at = Value::Sequence(vec![]);
                }
                let s = at.as_sequence_mut().unwrap();
                while s.len() <= i {
                    s.push(Value::Null);
                }
                &mut s[i]
            }
        };
    }
    *at = value;
}

/// A valid spec (with the files it reads in its folder) that probes start from.
pub struct Base {
    /// Short name (`noise`, `plant`, ...).
    pub name: &'static str,
    /// The folder of the spec and its files.
    pub dir: PathBuf,
    /// The spec.
    pub doc: Value,
}

impl Base {
    /// Writes `doc` as `name.yaml` in the base's folder and returns its path.
    pub fn write(&self, name: &str, doc: &Value) -> PathBuf {
        let path = self.dir.join(format!("{name}.yaml"));
        std::fs::write(&path, serde_yaml_ng::to_string(doc).unwrap()).unwrap();
        path
    }

    /// The error (YAML path, message) of the base with `path` set to `value`, validated by
    /// the library as `validate` does; `None` when the spec is valid.
    fn error_with(&self, path: &str, value: &Value) -> Option<(String, String)> {
        let mut doc = self.doc.clone();
        set(&mut doc, path, value.clone());
        let file = self.write("probe", &doc);
        isar_clutter::run::plan::load(&file)
            .err()
            .map(|e| (e.path, e.message))
    }
}

/// The first error over `bases` that `accept`s (path, message) when `path` is set to `value`.
fn probe(
    bases: &[Base],
    path: &str,
    value: Value,
    accept: impl Fn(&str, &str) -> bool,
) -> Option<String> {
    bases.iter().find_map(|b| {
        b.error_with(path, &value)
            .filter(|(p, m)| accept(p, m))
            .map(|(_, m)| m)
    })
}

/// Whether `p` lies at or under `path`.
fn under(p: &str, path: &str) -> bool {
    p == path || p.starts_with(&format!("{path}.")) || p.starts_with(&format!("{path}["))
}

/// Whether an error at `p` concerns the probed `path`: at it, under it, or at a section above
/// it (a parameter parsed as a whole reports its parent's path).
fn related(p: &str, path: &str) -> bool {
    under(p, path) || (!p.is_empty() && p != "." && under(path, p))
}

/// The names in backquotes after `expected` in an unknown-field error.
fn expected_names(message: &str) -> Vec<String> {
    let Some((_, tail)) = message.split_once("expected") else {
        return vec![];
    };
    tail.split('`')
        .skip(1)
        .step_by(2)
        .map(str::to_string)
        .collect()
}

/// What a string in a field's place says about the field.
#[derive(Debug, PartialEq)]
enum Kind {
    /// A number (maybe also a mapping, like a scalar-or-pattern parameter).
    Number { mapping: bool },
    /// A struct: recurse into its fields.
    Struct,
    /// A fixed-length array (`[H, W]`) or a tuple.
    Array,
    /// A list.
    List,
    /// An untagged enum: try a number and a list of numbers.
    Untagged,
    /// A metric (a name of those listed).
    Names(Vec<String>),
    /// Anything else: strings, booleans, enums, free mappings.
    Other,
}

fn kind(message: &str) -> Kind {
    const NUMBERS: [&str; 10] = [
        "expected usize",
        "expected u64",
        "expected u32",
        "expected u16",
        "expected u8",
        "expected i64",
        "expected i32",
        "expected f64",
        "expected f32",
        "expected a number",
    ];
    if NUMBERS.iter().any(|n| message.contains(n)) {
        Kind::Number {
            mapping: message.contains("mapping"),
        }
    } else if message.contains("expected struct") {
        Kind::Struct
    } else if message.contains("expected an array") || message.contains("expected a tuple") {
        Kind::Array
    } else if message.contains("expected a sequence") {
        Kind::List
    } else if message.contains("untagged enum") {
        Kind::Untagged
    } else if let Some((_, known)) = message.split_once("known: ") {
        Kind::Names(known.split(", ").map(str::to_string).collect())
    } else {
        Kind::Other
    }
}

/// `datasets[0].scene` -> `datasets[].scene`: a key independent of list positions.
fn generic(path: &str) -> String {
    let mut out = String::new();
    let mut skipping = false;
    for c in path.chars() {
        match c {
            '[' => {
                out.push('[');
                skipping = true;
            }
            ']' => {
                out.push(']');
                skipping = false;
            }
            _ if skipping => {}
            _ => out.push(c),
        }
    }
    out
}

/// Every numeric key of the schema, as generic paths (`datasets[].scene.plant.n_stems`,
/// `classification.train_sizes[]`), found from the top level of `bases`.
pub fn numeric_keys(bases: &[Base]) -> BTreeSet<String> {
    let mut keys = BTreeSet::new();
    walk_struct(bases, "", &mut keys, 0);
    keys
}

fn join(path: &str, field: &str) -> String {
    if path.is_empty() {
        field.to_string()
    } else {
        format!("{path}.{field}")
    }
}

/// The fields of the struct at `path`, each classified.
fn walk_struct(bases: &[Base], path: &str, keys: &mut BTreeSet<String>, depth: usize) {
    assert!(
        depth < 10,
        "the schema nests deeper than expected at {path}"
    );
    let unknown = join(path, "zzz_probe");
    // Every base's refusal: a dataset entry lists the fields of its own kind only.
    let mut fields: Vec<String> = vec![];
    for b in bases {
        let Some((p, m)) = b.error_with(&unknown, &Value::from(1)) else {
            continue;
        };
        if related(&p, &unknown) && m.contains("unknown field `zzz_probe`") {
            for f in expected_names(&m) {
                if !fields.contains(&f) {
                    fields.push(f);
                }
            }
        }
    }
    assert!(
        !fields.is_empty(),
        "no base refuses an unknown field at {path:?}"
    );
    for field in fields {
        walk_value(bases, &join(path, &field), keys, depth + 1);
    }
}

/// Whether an error message says the value had the wrong type.
fn typed(m: &str) -> bool {
    m.contains("invalid type") || m.contains("untagged") || m.contains("known: ")
}

/// Classifies the value at `path` by the error for a string in its place (and, where a string
/// is welcome, for a list of one string: a list of numbers or a file name).
fn walk_value(bases: &[Base], path: &str, keys: &mut BTreeSet<String>, depth: usize) {
    let refusal = |value: Value| probe(bases, path, value, |p, m| related(p, path) && typed(m));
    let message =
        refusal(Value::from("zzz")).or_else(|| refusal(Value::Sequence(vec![Value::from("zzz")])));
    let Some(message) = message else {
        return; // anything is welcome: a free value
    };
    match kind(&message) {
        Kind::Number { mapping } => {
            keys.insert(generic(path));
            if mapping {
                walk_struct(bases, path, keys, depth);
            }
        }
        Kind::Struct => walk_struct(bases, path, keys, depth),
        Kind::Array => {
            // A pair of strings: the first element's error gives the element type.
            let pair = Value::Sequence(vec![Value::from("zzz"), Value::from("zzz")]);
            if let Some(m) = refusal(pair) {
                if matches!(kind(&m), Kind::Number { .. }) {
                    keys.insert(generic(&format!("{path}[]")));
                } else {
                    walk_value(bases, &format!("{path}[0]"), keys, depth + 1);
                }
            }
        }
        Kind::List => walk_value(bases, &format!("{path}[0]"), keys, depth + 1),
        Kind::Untagged => {
            let numbers = [Value::from(7), Value::Sequence(vec![Value::from(7)])];
            for (value, key) in numbers
                .into_iter()
                .zip([path.to_string(), format!("{path}[]")])
            {
                if refusal(value).is_none() {
                    keys.insert(generic(&key));
                    break;
                }
            }
        }
        Kind::Names(names) => {
            for name in names {
                walk_struct(bases, &join(path, &name), keys, depth + 1);
            }
        }
        Kind::Other => {}
    }
}

#[test]
fn paths_are_set_and_made_generic() {
    let mut doc: Value = serde_yaml_ng::from_str("a: [x, {b: 1}]").unwrap();
    set(&mut doc, "a[1].b", Value::from(2));
    set(&mut doc, "a[0].c.d", Value::from(3));
    set(&mut doc, "e[1]", Value::from(4));
    let want: Value = serde_yaml_ng::from_str("a: [{c: {d: 3}}, {b: 2}]\ne: [null, 4]").unwrap();
    assert_eq!(doc, want);
    assert_eq!(
        generic("datasets[12].r_h[0].value"),
        "datasets[].r_h[].value"
    );
    assert_eq!(
        expected_names("unknown field `zzz_probe`, expected one of `a`, `b`, `c`"),
        ["a", "b", "c"]
    );
    assert_eq!(
        expected_names("unknown field `zzz_probe`, expected `a` or `b`"),
        ["a", "b"]
    );
}
