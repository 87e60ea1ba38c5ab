//! JSON Schemas (OpenAPI document) of the machine fields whose rules utoipa's field
//! attributes cannot state: the topology (X, Y and Z each exactly once across the two
//! stacks), the travel (axes X, Y, Z; two ends within [`MAX_TRAVEL_MM`]) and the tags
//! (the store's text rules); and the one-line text fields (a machine's name and
//! site, a profile's target, a key's label), written once here for every type that has
//! one. The API's routes refuse what these refuse.

use crate::limits::{
    LABEL_MAX, MAX_TRAVEL_MM, NAME_MAX, SITE_MAX, TAG_MAX, TAGS_BYTES_MAX, TAGS_MAX,
};
use serde_json::{Value, json};
use utoipa::openapi::schema::Schema;

/// The pattern of a one-line text field (the store's `check_line`): not blank, no
/// control character.
pub const LINE_PATTERN: &str = "^[^\\u0000-\\u001f\\u007f-\\u009f]*[^\\s\\u0000-\\u001f\\u007f-\\u009f][^\\u0000-\\u001f\\u007f-\\u009f]*$";

/// The pattern of a value without control characters (Unicode category Cc): what the
/// service's edge requires of every path and query value.
pub const NO_CONTROL_PATTERN: &str = "^[^\\u0000-\\u001f\\u007f-\\u009f]*$";

/// The pattern of a free-text field (the store's `check_free_text`): not blank, no
/// control character but line feeds and tabs.
pub const FREE_TEXT_PATTERN: &str = "^[^\\u0000-\\u0008\\u000b-\\u001f\\u007f-\\u009f]*[^\\s\\u0000-\\u001f\\u007f-\\u009f][^\\u0000-\\u0008\\u000b-\\u001f\\u007f-\\u009f]*$";

fn read(v: Value) -> Schema {
    serde_json::from_value(v).expect("a schema")
}

/// Every topology there is: X, Y and Z split between the workpiece and the tool stacks,
/// each stack in its order from the bed outward (6 orders × 4 splits).
fn topologies() -> Vec<Value> {
    let orders = [
        ["X", "Y", "Z"],
        ["X", "Z", "Y"],
        ["Y", "X", "Z"],
        ["Y", "Z", "X"],
        ["Z", "X", "Y"],
        ["Z", "Y", "X"],
    ];
    let mut all = Vec::new();
    for o in orders {
        for split in 0..=3 {
            all.push(json!({"workpiece": o[..split], "tool": o[split..]}));
        }
    }
    all
}

/// A machine's topology, or `null` (the default, `{"workpiece": ["X", "Y"], "tool":
/// ["Z"]}`).
pub fn topology() -> Schema {
    let mut values = topologies();
    values.push(Value::Null);
    read(json!({
        "type": ["object", "null"],
        "description": "Axes on the workpiece and on the tool side, each from the bed \
                        outward; X, Y and Z each exactly once (null: the default \
                        `{\"workpiece\": [\"X\", \"Y\"], \"tool\": [\"Z\"]}`).",
        "enum": values,
    }))
}

fn travel_of(types: Value) -> Schema {
    read(json!({
        "type": types,
        "description": format!("Travel per axis, mm, e.g. `{{\"X\": [-250, 250]}}`: axes X, Y, Z, \
                        [min, max] with min < max and |min|, |max| <= {MAX_TRAVEL_MM} mm."),
        "propertyNames": {"type": "string", "enum": ["X", "Y", "Z"]},
        "additionalProperties": {
            "type": "array",
            "items": {"type": "number", "minimum": -MAX_TRAVEL_MM, "maximum": MAX_TRAVEL_MM},
            "minItems": 2,
            "maxItems": 2,
        },
    }))
}

/// A machine's travel per axis.
pub fn travel() -> Schema {
    travel_of(json!("object"))
}

/// A machine's travel per axis, or `null` (keep).
pub fn travel_or_null() -> Schema {
    travel_of(json!(["object", "null"]))
}

fn tags_of(types: Value) -> Schema {
    read(json!({
        "type": types,
        "description": format!("At most {TAGS_MAX}, each not blank, at most {TAG_MAX} characters, \
                                no control character, none twice; together at most \
                                {TAGS_BYTES_MAX} bytes as stored (a JSON list, UTF-8)."),
        "items": {"type": "string", "maxLength": TAG_MAX, "pattern": LINE_PATTERN},
        "maxItems": TAGS_MAX,
        "uniqueItems": true,
    }))
}

/// A machine's tags.
pub fn tags() -> Schema {
    tags_of(json!("array"))
}

/// A machine's tags, or `null` (keep).
pub fn tags_or_null() -> Schema {
    tags_of(json!(["array", "null"]))
}

/// A one-line text field (the store's `check_line`: not blank, at most `max`
/// characters, no control character), with `null` too when `nullable`.
fn line(max: usize, nullable: bool) -> Schema {
    let types = if nullable {
        json!(["string", "null"])
    } else {
        json!("string")
    };
    read(json!({
        "type": types,
        "description": format!("Not blank, at most {max} characters, no control character."),
        "maxLength": max,
        "pattern": LINE_PATTERN,
    }))
}

/// A machine's name.
pub fn name() -> Schema {
    line(NAME_MAX, false)
}

/// A machine's name, or `null` (keep).
pub fn name_or_null() -> Schema {
    line(NAME_MAX, true)
}

/// A machine's site, or `null` (none; in an update: keep).
pub fn site_or_null() -> Schema {
    line(SITE_MAX, true)
}

/// An API key's label.
pub fn label() -> Schema {
    line(LABEL_MAX, false)
}

#[cfg(test)]
mod tests {
    /// 24 topologies, none twice, each with X, Y and Z once.
    #[test]
    fn every_topology_once() {
        let all = super::topologies();
        assert_eq!(all.len(), 24);
        let mut seen = std::collections::BTreeSet::new();
        for t in &all {
            let mut axes: Vec<&str> = t["workpiece"]
                .as_array()
                .unwrap()
                .iter()
                .chain(t["tool"].as_array().unwrap())
                .map(|a| a.as_str().unwrap())
                .collect();
            axes.sort();
            assert_eq!(axes, ["X", "Y", "Z"], "{t}");
            assert!(seen.insert(t.to_string()), "{t} twice");
        }
    }
}
