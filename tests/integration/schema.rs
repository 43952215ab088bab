//! The JSON document matches `schema/imunoise-output.schema.json` for every command, ok and failed
//! files alike. The checker covers the subset of JSON Schema the file uses (type, const, enum,
//! required, properties, items, oneOf, $ref), so the schema cannot drift from the output unnoticed.

use serde_json::Value;

use super::support::*;

fn resolve<'a>(root: &'a Value, schema: &'a Value) -> &'a Value {
    match schema.get("$ref").and_then(Value::as_str) {
        Some(r) => {
            let pointer = r.strip_prefix('#').expect("local $ref");
            resolve(root, root.pointer(pointer).expect("$ref target"))
        }
        None => schema,
    }
}

fn type_ok(t: &str, v: &Value) -> bool {
    match t {
        "object" => v.is_object(),
        "array" => v.is_array(),
        "string" => v.is_string(),
        "number" => v.is_number(),
        "integer" => v.is_u64() || v.is_i64(),
        "boolean" => v.is_boolean(),
        "null" => v.is_null(),
        other => panic!("schema uses type {other}"),
    }
}

/// Returns the first violation as "path: reason".
fn check(root: &Value, schema: &Value, v: &Value, path: &str) -> Result<(), String> {
    let s = resolve(root, schema);
    if let Some(t) = s.get("type") {
        let ok = match t {
            Value::String(t) => type_ok(t, v),
            Value::Array(ts) => ts.iter().any(|t| type_ok(t.as_str().unwrap(), v)),
            _ => panic!("bad type keyword"),
        };
        if !ok {
            return Err(format!("{path}: {v} is not of type {t}"));
        }
    }
    if let Some(c) = s.get("const") {
        if c != v {
            return Err(format!("{path}: {v} != const {c}"));
        }
    }
    if let Some(Value::Array(options)) = s.get("enum") {
        if !options.contains(v) {
            return Err(format!("{path}: {v} not in {options:?}"));
        }
    }
    if let Some(Value::Array(options)) = s.get("oneOf") {
        let passing = options
            .iter()
            .filter(|o| check(root, o, v, path).is_ok())
            .count();
        if passing != 1 {
            return Err(format!("{path}: matches {passing} of oneOf"));
        }
    }
    if let (Some(Value::Array(required)), Some(obj)) = (s.get("required"), v.as_object()) {
        for key in required {
            if !obj.contains_key(key.as_str().unwrap()) {
                return Err(format!("{path}: missing required {key}"));
            }
        }
    }
    if let (Some(Value::Object(props)), Some(obj)) = (s.get("properties"), v.as_object()) {
        for (key, sub) in props {
            if let Some(value) = obj.get(key) {
                check(root, sub, value, &format!("{path}.{key}"))?;
            }
        }
    }
    if let (Some(items), Some(arr)) = (s.get("items"), v.as_array()) {
        for (i, item) in arr.iter().enumerate() {
            check(root, items, item, &format!("{path}[{i}]"))?;
        }
    }
    Ok(())
}

/// `doc` against the committed output schema (`schema/imunoise-output.schema.json`).
pub fn matches_schema(doc: &Value) -> Result<(), String> {
    let schema: Value = serde_json::from_str(
        &std::fs::read_to_string(repo_root().join("schema/imunoise-output.schema.json")).unwrap(),
    )
    .unwrap();
    check(&schema, &schema, doc, "report")
}

#[test]
fn every_command_writes_documents_that_match_the_schema() {
    let root = repo_root();
    let schema: Value = serde_json::from_str(
        &std::fs::read_to_string(root.join("schema/imunoise-output.schema.json")).unwrap(),
    )
    .unwrap();
    let dir = tempfile::tempdir().unwrap();
    let mut values = noise(20_000, 5);
    values[7] = f64::NAN;
    let bad = dir.path().join("bad.arrow");
    write_ipc_file(
        &bad,
        &batch(&[f64_col("g", values, Some("deg/h"))], Some(10.0)),
        4096,
    );
    let sample = root.join("data/sample_imu.arrow");
    for command in ["info", "psd", "avar", "analyze"] {
        let mut args = vec![
            command,
            sample.to_str().unwrap(),
            bad.to_str().unwrap(),
            "--json",
        ];
        if command == "avar" || command == "analyze" {
            args.extend(["--stat", "oadev,hdev"]);
        }
        if command == "info" {
            // `info` counts non-finite samples unless told to stop at them.
            args.extend(["--on-nonfinite", "error"]);
        }
        let out = imunoise(&args, dir.path());
        assert_eq!(
            out.status.code(),
            Some(1),
            "{command}: {}",
            String::from_utf8_lossy(&out.stderr)
        );
        let doc: Value = serde_json::from_slice(&out.stdout).unwrap();
        check(&schema, &schema, &doc, command).unwrap_or_else(|e| panic!("{command}: {e}"));
        assert_eq!(doc["files"][0]["status"], "ok");
        assert_eq!(doc["files"][1]["status"], "error");
        let has = |k: &str| doc["files"][0].get(k).is_some();
        assert_eq!(
            has("psd"),
            command == "psd" || command == "analyze",
            "{command}"
        );
        assert_eq!(
            has("avar"),
            command == "avar" || command == "analyze",
            "{command}"
        );
    }
}

#[test]
fn the_checker_rejects_a_document_that_breaks_the_schema() {
    let schema: Value = serde_json::from_str(
        &std::fs::read_to_string(repo_root().join("schema/imunoise-output.schema.json")).unwrap(),
    )
    .unwrap();
    let doc = serde_json::json!({
        "schema_version": 1, "tool": "imunoise", "version": "0", "command": "psd", "backend": "cpu",
        "options": {}, "summary": {"files": 1, "ok": 0, "failed": 1, "elapsed_s": 0.1},
        "files": [{"path": "x", "status": "error", "error": {"message": "m", "column": 3, "row": null}}]
    });
    let e = check(&schema, &schema, &doc, "doc").unwrap_err();
    assert!(e.contains("files[0]"), "{e}");
}
