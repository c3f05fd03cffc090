//! Foxglove's JSON encoding of the message types a recording writes: every field of the
//! schema present (empty arrays included, as the official JSON Schemas require), enums as
//! their numbers, bytes as base64, times as `{sec, nsec}`.

use base64::Engine as _;
use foxglove::messages::{
    Color, CompressedImage, Duration, FrameTransform, ImageAnnotations, KeyValuePair, LinePrimitive,
    PackedElementField, Point2, Point3, PointCloud, PointsAnnotation, Pose, PosesInFrame, Quaternion, SceneEntity,
    SceneEntityDeletion, SceneUpdate, Timestamp, Vector3,
};
use serde_json::{Value, json};

/// A message or field in Foxglove's JSON encoding.
pub(super) trait ToJson {
    /// The JSON value.
    fn to_json(&self) -> Value;
}

impl<T: ToJson> ToJson for Option<T> {
    fn to_json(&self) -> Value {
        self.as_ref().map_or(Value::Null, ToJson::to_json)
    }
}

fn list<T: ToJson>(items: &[T]) -> Value {
    Value::Array(items.iter().map(ToJson::to_json).collect())
}

impl ToJson for Timestamp {
    fn to_json(&self) -> Value {
        json!({"sec": self.sec(), "nsec": self.nsec()})
    }
}

impl ToJson for Duration {
    fn to_json(&self) -> Value {
        json!({"sec": self.sec(), "nsec": self.nsec()})
    }
}

impl ToJson for Vector3 {
    fn to_json(&self) -> Value {
        json!({"x": self.x, "y": self.y, "z": self.z})
    }
}

impl ToJson for Point3 {
    fn to_json(&self) -> Value {
        json!({"x": self.x, "y": self.y, "z": self.z})
    }
}

impl ToJson for Point2 {
    fn to_json(&self) -> Value {
        json!({"x": self.x, "y": self.y})
    }
}

impl ToJson for Quaternion {
    fn to_json(&self) -> Value {
        json!({"x": self.x, "y": self.y, "z": self.z, "w": self.w})
    }
}

impl ToJson for Pose {
    fn to_json(&self) -> Value {
        json!({"position": self.position.to_json(), "orientation": self.orientation.to_json()})
    }
}

impl ToJson for Color {
    fn to_json(&self) -> Value {
        json!({"r": self.r, "g": self.g, "b": self.b, "a": self.a})
    }
}

impl ToJson for KeyValuePair {
    fn to_json(&self) -> Value {
        json!({"key": self.key, "value": self.value})
    }
}

impl ToJson for LinePrimitive {
    fn to_json(&self) -> Value {
        json!({
            "type": self.r#type,
            "pose": self.pose.to_json(),
            "thickness": self.thickness,
            "scale_invariant": self.scale_invariant,
            "points": list(&self.points),
            "color": self.color.to_json(),
            "colors": list(&self.colors),
            "indices": self.indices,
        })
    }
}

impl ToJson for SceneEntity {
    /// Only line primitives are drawn by the recordings; the other primitive arrays are written
    /// empty (the recorder never fills them).
    fn to_json(&self) -> Value {
        json!({
            "timestamp": self.timestamp.to_json(),
            "frame_id": self.frame_id,
            "id": self.id,
            "lifetime": self.lifetime.to_json(),
            "frame_locked": self.frame_locked,
            "metadata": list(&self.metadata),
            "arrows": [],
            "cubes": [],
            "spheres": [],
            "cylinders": [],
            "lines": list(&self.lines),
            "triangles": [],
            "texts": [],
            "models": [],
        })
    }
}

impl ToJson for SceneEntityDeletion {
    fn to_json(&self) -> Value {
        json!({"timestamp": self.timestamp.to_json(), "type": self.r#type, "id": self.id})
    }
}

impl ToJson for SceneUpdate {
    fn to_json(&self) -> Value {
        json!({"deletions": list(&self.deletions), "entities": list(&self.entities)})
    }
}

impl ToJson for FrameTransform {
    fn to_json(&self) -> Value {
        json!({
            "timestamp": self.timestamp.to_json(),
            "parent_frame_id": self.parent_frame_id,
            "child_frame_id": self.child_frame_id,
            "translation": self.translation.to_json(),
            "rotation": self.rotation.to_json(),
        })
    }
}

impl ToJson for PosesInFrame {
    fn to_json(&self) -> Value {
        json!({"timestamp": self.timestamp.to_json(), "frame_id": self.frame_id, "poses": list(&self.poses)})
    }
}

impl ToJson for PackedElementField {
    fn to_json(&self) -> Value {
        json!({"name": self.name, "offset": self.offset, "type": self.r#type})
    }
}

impl ToJson for PointCloud {
    fn to_json(&self) -> Value {
        json!({
            "timestamp": self.timestamp.to_json(),
            "frame_id": self.frame_id,
            "pose": self.pose.to_json(),
            "point_stride": self.point_stride,
            "fields": list(&self.fields),
            "data": base64::engine::general_purpose::STANDARD.encode(&self.data),
        })
    }
}

impl ToJson for PointsAnnotation {
    fn to_json(&self) -> Value {
        json!({
            "timestamp": self.timestamp.to_json(),
            "type": self.r#type,
            "points": list(&self.points),
            "outline_color": self.outline_color.to_json(),
            "outline_colors": list(&self.outline_colors),
            "fill_color": self.fill_color.to_json(),
            "thickness": self.thickness,
            "metadata": list(&self.metadata),
        })
    }
}

impl ToJson for ImageAnnotations {
    /// Only point annotations are drawn by the recordings; circles and texts are written empty.
    fn to_json(&self) -> Value {
        json!({
            "timestamp": self.timestamp.to_json(),
            "circles": [],
            "points": list(&self.points),
            "texts": [],
            "metadata": list(&self.metadata),
        })
    }
}

impl ToJson for CompressedImage {
    fn to_json(&self) -> Value {
        json!({
            "timestamp": self.timestamp.to_json(),
            "frame_id": self.frame_id,
            "data": base64::engine::general_purpose::STANDARD.encode(&self.data),
            "format": self.format,
        })
    }
}
