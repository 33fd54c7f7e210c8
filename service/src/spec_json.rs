//! A scene spec read from JSON, with errors that name the field, body or pair that is wrong.
//!
//! serde's own message for a spec that does not parse names a type, not a place ("unknown
//! variant `inside`"); a client needs to know which body or pair it came from. The spec is read
//! whole first, and only when that fails is it walked part by part to find the first bad one.

use lumen_proto::{BodySpec, PairSpec, SceneSpec};
use serde::de::DeserializeOwned;
use serde::Deserialize;
use serde_json::Value;

/// The fields a scene spec may have; any other is refused.
const FIELDS: [&str; 8] = ["bodies", "pairs", "precision", "alpha", "margin", "method", "nearest", "refine"];

/// The scene spec in `value`, or what is wrong with it, naming the field, body or pair.
pub fn parse(value: Value) -> Result<SceneSpec, String> {
    match serde_json::from_value::<SceneSpec>(value.clone()) {
        Ok(spec) => Ok(spec),
        Err(whole) => Err(locate(&value).unwrap_or_else(|| whole.to_string())),
    }
}

/// The first part of `value` that does not parse, said with its place.
fn locate(value: &Value) -> Option<String> {
    let object = match serde_json::Map::<String, Value>::deserialize(value) {
        Ok(o) => o,
        Err(e) => return Some(format!("the spec must be a JSON object: {e}")),
    };
    if let Some(unknown) = object.keys().find(|k| !FIELDS.contains(&k.as_str())) {
        return Some(format!("unknown field {unknown:?}; a spec has the fields {}", FIELDS.join(", ")));
    }
    for required in ["bodies", "pairs"] {
        if !object.contains_key(required) {
            return Some(format!("missing field {required:?}"));
        }
    }
    let list = |field: &str| Vec::<Value>::deserialize(&object[field]).map_err(|e| format!("{field:?} must be an array: {e}"));
    let bodies = match list("bodies") {
        Ok(b) => b,
        Err(e) => return Some(e),
    };
    for (i, body) in bodies.iter().enumerate() {
        if let Err(e) = read::<BodySpec>(body) {
            let name = body.get("name").and_then(Value::as_str).map_or_else(|| format!("#{i}"), |n| format!("{n:?}"));
            return Some(format!("body {name}: {e}"));
        }
    }
    let pairs = match list("pairs") {
        Ok(p) => p,
        Err(e) => return Some(e),
    };
    for (i, pair) in pairs.iter().enumerate() {
        if let Err(e) = read::<PairSpec>(pair) {
            let name = |side: &str| pair.get(side).and_then(Value::as_str).map_or_else(|| "?".to_owned(), |n| format!("{n:?}"));
            return Some(format!("pair #{i} ({}, {}): {e}", name("a"), name("b")));
        }
    }
    let field = |name: &str, read: fn(&Value) -> Result<(), String>| object.get(name).and_then(|v| read(v).err().map(|e| format!("{name}: {e}")));
    field("precision", read::<u32>)
        .or_else(|| field("refine", read::<u32>))
        .or_else(|| field("alpha", read::<f32>))
        .or_else(|| field("margin", read::<f32>))
        .or_else(|| field("method", read::<lumen_proto::Method>))
        .or_else(|| field("nearest", read::<bool>))
}

/// Whether `value` parses as a `T`, and serde's reason if not.
fn read<T: DeserializeOwned>(value: &Value) -> Result<(), String> {
    T::deserialize(value).map(drop).map_err(|e| e.to_string())
}

#[cfg(test)]
mod tests {
    use super::*;

    const GOOD: &str = r#"{"bodies":[{"name":"colon","shape":{"tube":{"rings":20,"spokes":8}}},
        {"name":"scope","shape":{"rod":{"points":5,"radius":[1.0]}}}],
        "pairs":[{"a":"scope","b":"colon","kind":"interior"}]}"#;

    /// `GOOD` with `path` (a JSON pointer) set to `to`.
    fn with(path: &str, to: Value) -> Value {
        let mut v: Value = serde_json::from_str(GOOD).unwrap();
        *v.pointer_mut(path).unwrap_or_else(|| panic!("{path}")) = to;
        v
    }

    fn error_of(v: Value) -> String {
        parse(v).expect_err("the spec parsed")
    }

    #[test]
    fn a_good_spec_parses_with_its_defaults() {
        let spec = parse(serde_json::from_str(GOOD).unwrap()).unwrap();
        assert_eq!((spec.bodies.len(), spec.pairs.len(), spec.precision, spec.nearest), (2, 1, 4, true));
    }

    #[test]
    fn each_bad_field_is_named_with_its_body_or_pair() {
        let cases: [(&str, Value, &str); 9] = [
            ("/pairs/0/kind", "inside".into(), "pair #0 (\"scope\", \"colon\"): unknown variant `inside`"),
            ("/bodies/0/shape/tube/rings", (-1).into(), "body \"colon\": invalid value: integer `-1`"),
            ("/bodies/0/shape/tube/rings", 20.5.into(), "body \"colon\": invalid type: floating point `20.5`"),
            ("/bodies/0/shape/tube/rings", "20".into(), "body \"colon\": invalid type: string \"20\""),
            ("/bodies/1/shape", serde_json::json!({"sphere":{"radius":1}}), "body \"scope\": unknown variant `sphere`"),
            ("/bodies/1/name", 7.into(), "body #1: invalid type: integer `7`"),
            ("/pairs", "scope".into(), "\"pairs\" must be an array: invalid type: string \"scope\", expected a sequence"),
            ("/bodies/0/shape/tube/spokes", serde_json::json!(null), "body \"colon\": invalid type: null"),
            ("/pairs/0/a", serde_json::json!(["scope"]), "pair #0 (?, \"colon\"): invalid type: sequence"),
        ];
        for (path, to, expected) in cases {
            let e = error_of(with(path, to.clone()));
            assert!(e.starts_with(expected), "{path} = {to}: {e:?} does not start with {expected:?}");
        }
    }

    #[test]
    fn top_level_fields_of_the_wrong_type_or_value_are_named() {
        let mut base: Value = serde_json::from_str(GOOD).unwrap();
        let cases: [(&str, Value, &str); 5] = [
            ("method", "fast".into(), "method: unknown variant `fast`"),
            ("nearest", "yes".into(), "nearest: invalid type: string \"yes\""),
            ("precision", 2.5.into(), "precision: invalid type: floating point `2.5`"),
            ("alpha", "half".into(), "alpha: invalid type: string \"half\""),
            ("colour", "red".into(), "unknown field \"colour\""),
        ];
        for (field, to, expected) in cases {
            let mut v = base.clone();
            v.as_object_mut().unwrap().insert(field.into(), to.clone());
            let e = error_of(v);
            assert!(e.starts_with(expected), "{field} = {to}: {e:?} does not start with {expected:?}");
        }
        base.as_object_mut().unwrap().remove("pairs");
        assert_eq!(error_of(base), "missing field \"pairs\"");
        assert_eq!(error_of(Value::from(3)), "the spec must be a JSON object: invalid type: integer `3`, expected a map");
    }
}
