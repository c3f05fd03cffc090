//! The JSON Schemas registered for Foxglove's message types: compact, of the fields the
//! recorder writes, every type inlined (Foxglove's reader does not follow `$ref`).

use serde_json::{Value, json};

use super::{COMPRESSED_IMAGE, FRAME_TRANSFORM, IMAGE_ANNOTATIONS, POINT_CLOUD, POSES_IN_FRAME, SCENE_UPDATE};

/// The JSON schema of Foxglove's schema `name`, of the fields written here.
pub(super) fn schema_of(name: &str) -> anyhow::Result<Value> {
    let body = match name {
        SCENE_UPDATE => object(&[("deletions", array(deletion())), ("entities", array(entity()))]),
        FRAME_TRANSFORM => object(&[
            ("timestamp", time_schema()),
            ("parent_frame_id", string()),
            ("child_frame_id", string()),
            ("translation", vector3()),
            ("rotation", quaternion()),
        ]),
        POSES_IN_FRAME => {
            object(&[("timestamp", time_schema()), ("frame_id", string()), ("poses", array(pose_schema()))])
        }
        POINT_CLOUD => object(&[
            ("timestamp", time_schema()),
            ("frame_id", string()),
            ("pose", pose_schema()),
            ("point_stride", integer(0)),
            ("fields", array(object(&[("name", string()), ("offset", integer(0)), ("type", integer(0))]))),
            ("data", bytes()),
        ]),
        COMPRESSED_IMAGE => {
            object(&[("timestamp", time_schema()), ("frame_id", string()), ("data", bytes()), ("format", string())])
        }
        IMAGE_ANNOTATIONS => object(&[
            ("timestamp", time_schema()),
            ("circles", array(circle_annotation())),
            ("points", array(points_annotation())),
            ("texts", array(text_annotation())),
            ("metadata", array(key_value())),
        ]),
        _ => anyhow::bail!("no schema for {name}"),
    };
    let mut schema = body;
    schema["$schema"] = json!("https://json-schema.org/draft/2020-12/schema");
    schema["title"] = json!(name);
    Ok(schema)
}

fn object(properties: &[(&str, Value)]) -> Value {
    let props: serde_json::Map<String, Value> = properties.iter().map(|(k, v)| ((*k).to_string(), v.clone())).collect();
    let required: Vec<&str> = properties.iter().map(|(k, _)| *k).collect();
    json!({"type": "object", "properties": props, "required": required})
}

fn array(items: Value) -> Value {
    json!({"type": "array", "items": items})
}

fn string() -> Value {
    json!({"type": "string"})
}

fn number() -> Value {
    json!({"type": "number"})
}

fn boolean() -> Value {
    json!({"type": "boolean"})
}

fn integer(minimum: i64) -> Value {
    json!({"type": "integer", "minimum": minimum})
}

/// Bytes: base64 in the JSON encoding.
fn bytes() -> Value {
    json!({"type": "string", "contentEncoding": "base64"})
}

fn time_schema() -> Value {
    object(&[("sec", integer(0)), ("nsec", json!({"type": "integer", "minimum": 0, "maximum": 999_999_999}))])
}

fn vector3() -> Value {
    object(&[("x", number()), ("y", number()), ("z", number())])
}

fn quaternion() -> Value {
    object(&[("x", number()), ("y", number()), ("z", number()), ("w", number())])
}

fn pose_schema() -> Value {
    object(&[("position", vector3()), ("orientation", quaternion())])
}

fn color() -> Value {
    object(&[("r", number()), ("g", number()), ("b", number()), ("a", number())])
}

fn deletion() -> Value {
    object(&[("timestamp", time_schema()), ("type", json!({"type": "integer", "enum": [0, 1]})), ("id", string())])
}

fn line_primitive() -> Value {
    object(&[
        ("type", json!({"type": "integer", "enum": [0, 1, 2]})),
        ("pose", pose_schema()),
        ("thickness", number()),
        ("scale_invariant", boolean()),
        ("points", array(vector3())),
        ("color", color()),
        ("colors", array(color())),
        ("indices", array(integer(0))),
    ])
}

fn point2() -> Value {
    object(&[("x", number()), ("y", number())])
}

fn points_annotation() -> Value {
    object(&[
        ("timestamp", time_schema()),
        ("type", json!({"type": "integer", "enum": [0, 1, 2, 3, 4]})),
        ("points", array(point2())),
        ("outline_color", color()),
        ("outline_colors", array(color())),
        ("fill_color", color()),
        ("thickness", number()),
        ("metadata", array(key_value())),
    ])
}

fn circle_annotation() -> Value {
    object(&[
        ("timestamp", time_schema()),
        ("position", point2()),
        ("diameter", number()),
        ("thickness", number()),
        ("fill_color", color()),
        ("outline_color", color()),
    ])
}

fn text_annotation() -> Value {
    object(&[
        ("timestamp", time_schema()),
        ("position", point2()),
        ("text", string()),
        ("font_size", number()),
        ("text_color", color()),
        ("background_color", color()),
    ])
}

fn entity() -> Value {
    object(&[
        ("timestamp", time_schema()),
        ("frame_id", string()),
        ("id", string()),
        ("lifetime", time_schema()),
        ("frame_locked", boolean()),
        ("metadata", array(key_value())),
        // The primitives the recordings do not draw: always empty, present as the schema
        // requires.
        ("arrows", array(json!({"type": "object"}))),
        ("cubes", array(json!({"type": "object"}))),
        ("spheres", array(json!({"type": "object"}))),
        ("cylinders", array(json!({"type": "object"}))),
        ("lines", array(line_primitive())),
        ("triangles", array(json!({"type": "object"}))),
        ("texts", array(json!({"type": "object"}))),
        ("models", array(json!({"type": "object"}))),
    ])
}

fn key_value() -> Value {
    object(&[("key", string()), ("value", string())])
}
