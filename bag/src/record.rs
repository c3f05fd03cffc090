//! Recordings of what the pipeline computed, for a standard viewer: MCAP files whose messages
//! use Foxglove's well-known schemas (`foxglove.SceneUpdate`, `foxglove.FrameTransform`,
//! `foxglove.PosesInFrame`, `foxglove.PointCloud`, `foxglove.CompressedImage`,
//! `foxglove.ImageAnnotations`) in the JSON
//! encoding (schema encoding `jsonschema`, message encoding `json`), so that Foxglove, the
//! `mcap` tool and Python's `mcap` package all read them without code of ours.
//!
//! [`Recorder`] writes one file: each method adds one message at a log time (nanoseconds,
//! also the message's `timestamp`), creating its topic on first use.
//! [`Recorder::finish`] must be called: until then the data lives under a temporary name
//! ([`partial_path`]), so that an interrupted run leaves no file that looks complete.
//!
//! Frames: [`WORLD_FRAME`] is the pipeline's bird's-eye world with z up (x, y: the bird's-eye
//! coordinates, i.e. x and z of the camera-convention world of the first frame);
//! [`CAMERA_FRAME`] is the camera, in the camera convention (x right, y down, z forward).
//! [`Pose::from_camera_world`] turns a camera-convention world pose into [`WORLD_FRAME`].
//!
//! The schemas are written here, compact and fully inlined (Foxglove's JSON-schema reader does
//! not follow `$ref`); bytes fields are base64 strings with `contentEncoding: base64`, which is
//! how Foxglove knows to decode them.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use base64::Engine as _;
use serde_json::{Value, json};

/// The fixed frame every line and path is drawn in.
pub const WORLD_FRAME: &str = "world";
/// The camera's frame, placed in [`WORLD_FRAME`] by [`Recorder::camera_transform`].
pub const CAMERA_FRAME: &str = "camera";

/// Schema name of a set of lines and other primitives.
pub const SCENE_UPDATE: &str = "foxglove.SceneUpdate";
/// Schema name of one frame placed in another.
pub const FRAME_TRANSFORM: &str = "foxglove.FrameTransform";
/// Schema name of a list of poses (a path).
pub const POSES_IN_FRAME: &str = "foxglove.PosesInFrame";
/// Schema name of a point cloud.
pub const POINT_CLOUD: &str = "foxglove.PointCloud";
/// Schema name of an encoded image.
pub const COMPRESSED_IMAGE: &str = "foxglove.CompressedImage";
/// Schema name of 2D annotations drawn over an image.
pub const IMAGE_ANNOTATIONS: &str = "foxglove.ImageAnnotations";

/// The MCAP schema encoding of every schema written.
pub const SCHEMA_ENCODING: &str = "jsonschema";
/// The MCAP message encoding of every channel written.
pub const MESSAGE_ENCODING: &str = "json";

/// The `foxglove.PointCloud` numeric type of a 32-bit float field (its `NumericType` enum).
const FLOAT32: u32 = 7;
/// The `foxglove.PointCloud` numeric type of an unsigned 32-bit integer field.
const UINT32: u32 = 5;
/// `foxglove.PointsAnnotation` type: each point drawn on its own.
const POINTS: u32 = 1;
/// `foxglove.LinePrimitive` type: a polyline through the points in order.
const LINE_STRIP: u32 = 0;
/// `foxglove.SceneEntityDeletion` type: every entity older than the deletion's timestamp.
const DELETE_ALL: u32 = 1;

/// A pose: position, metres, and orientation as a unit quaternion `[x, y, z, w]`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pose {
    /// Position, metres.
    pub position: [f64; 3],
    /// Orientation, unit quaternion `[x, y, z, w]`.
    pub orientation: [f64; 4],
}

impl Pose {
    /// The identity.
    pub const IDENTITY: Pose = Pose { position: [0.0; 3], orientation: [0.0, 0.0, 0.0, 1.0] };

    /// The pose in [`WORLD_FRAME`] of a pose given in the pipeline's camera-convention world
    /// (x right, y down, z forward): the world turned so that its z points up, `(x, y, z)` ->
    /// `(x, z, -y)`, which puts the bird's-eye coordinates in x and y. The body frame (e.g. the
    /// camera's optical frame) is left as it is.
    #[must_use]
    pub fn from_camera_world(translation: [f64; 3], rotation: [f64; 4]) -> Pose {
        let [x, y, z] = translation;
        // A quarter turn about x, -90 degrees: (x, y, z) -> (x, z, -y).
        let h = std::f64::consts::FRAC_1_SQRT_2;
        let turn = [-h, 0.0, 0.0, h];
        Pose { position: [x, z, -y], orientation: quaternion_product(turn, rotation) }
    }

    fn to_json(self) -> Value {
        let [x, y, z] = self.position;
        let [qx, qy, qz, qw] = self.orientation;
        json!({
            "position": {"x": x, "y": y, "z": z},
            "orientation": {"x": qx, "y": qy, "z": qz, "w": qw},
        })
    }
}

/// The Hamilton product `a * b` of quaternions `[x, y, z, w]`.
fn quaternion_product(a: [f64; 4], b: [f64; 4]) -> [f64; 4] {
    let [ax, ay, az, aw] = a;
    let [bx, by, bz, bw] = b;
    [
        aw * bx + ax * bw + ay * bz - az * by,
        aw * by - ax * bz + ay * bw + az * bx,
        aw * bz + ax * by - ay * bx + az * bw,
        aw * bw - ax * bx - ay * by - az * bz,
    ]
}

/// A colour, each channel in [0, 1].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Rgba {
    /// Red.
    pub r: f64,
    /// Green.
    pub g: f64,
    /// Blue.
    pub b: f64,
    /// Opacity.
    pub a: f64,
}

impl Rgba {
    /// An opaque colour.
    #[must_use]
    pub const fn opaque(r: f64, g: f64, b: f64) -> Rgba {
        Rgba { r, g, b, a: 1.0 }
    }

    fn to_json(self) -> Value {
        json!({"r": self.r, "g": self.g, "b": self.b, "a": self.a})
    }
}

/// One entity of a [`Recorder::lines`] update: a polyline in [`WORLD_FRAME`].
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    /// The entity's id (e.g. the object id): an update replaces the entity of the same id.
    pub id: String,
    /// Points, metres, in order.
    pub points: Vec<[f64; 3]>,
    /// Colour.
    pub color: Rgba,
    /// Width, metres.
    pub thickness: f64,
    /// Key-value pairs shown with the entity (e.g. class).
    pub metadata: Vec<(String, String)>,
}

/// One group of a [`Recorder::image_points`] message: points drawn over an image in one colour.
#[derive(Debug, Clone, PartialEq)]
pub struct ImagePoints {
    /// Pixel coordinates `[column, row]`, the top-left pixel's centre at `(0, 0)` (OpenCV's
    /// convention, the tracks').
    pub points: Vec<[f64; 2]>,
    /// Colour.
    pub color: Rgba,
    /// Diameter of each point, pixels.
    pub size: f64,
}

/// What [`Recorder::finish`] wrote.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordingSummary {
    /// The file.
    pub path: PathBuf,
    /// Its size, bytes.
    pub bytes: u64,
    /// Messages per topic.
    pub messages: BTreeMap<String, u64>,
}

/// The log time, nanoseconds, of frame `frame` at `rate_hz` frames per second.
///
/// # Errors
/// A rate that is not a positive finite number.
pub fn frame_time_ns(frame: u32, rate_hz: f64) -> anyhow::Result<u64> {
    anyhow::ensure!(rate_hz.is_finite() && rate_hz > 0.0, "frame rate {rate_hz} Hz: expected a positive rate");
    // Rounded: 1/rate is rarely a whole number of nanoseconds, and truncation would put
    // frames a nanosecond early.
    Ok((f64::from(frame) * 1e9 / rate_hz).round() as u64)
}

/// The temporary name a recording is written under until [`Recorder::finish`].
pub use dynotraj_formats::atomic::partial_path;

/// A recording being written. Dropped without [`Recorder::finish`], it removes its temporary
/// file.
pub struct Recorder {
    path: PathBuf,
    partial: PathBuf,
    writer: Option<mcap::Writer<BufWriter<File>>>,
    schemas: BTreeMap<&'static str, u16>,
    /// Topic -> (channel id, schema name).
    channels: BTreeMap<String, (u16, &'static str)>,
    counts: BTreeMap<String, u64>,
    sequence: u32,
}

impl std::fmt::Debug for Recorder {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Recorder").field("path", &self.path).field("counts", &self.counts).finish_non_exhaustive()
    }
}

impl Recorder {
    /// Starts a recording to be written to `path` (its folder is created if needed).
    ///
    /// # Errors
    /// The folder or the temporary file cannot be created, named.
    pub fn create(path: &Path) -> anyhow::Result<Recorder> {
        anyhow::ensure!(path.file_name().is_some(), "recording {}: expected a file name", path.display());
        if let Some(dir) = path.parent().filter(|d| !d.as_os_str().is_empty()) {
            std::fs::create_dir_all(dir)
                .with_context(|| format!("recording {}: creating its folder {}", path.display(), dir.display()))?;
        }
        let partial = partial_path(path);
        let file = File::create(&partial).with_context(|| format!("recording {}: creating", partial.display()))?;
        let writer = mcap::WriteOptions::new()
            .profile("")
            .library(concat!("dynotraj ", env!("CARGO_PKG_VERSION")))
            .create(BufWriter::new(file))
            .with_context(|| format!("recording {}: writing the header", partial.display()))?;
        Ok(Recorder {
            path: path.to_path_buf(),
            partial,
            writer: Some(writer),
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            counts: BTreeMap::new(),
            sequence: 0,
        })
    }

    /// The file the recording becomes on [`Recorder::finish`].
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Places [`CAMERA_FRAME`] in [`WORLD_FRAME`] at `time_ns`: a `foxglove.FrameTransform`
    /// on `topic` (e.g. `/tf`).
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn camera_transform(&mut self, topic: &str, time_ns: u64, camera: &Pose) -> anyhow::Result<()> {
        let p = camera.to_json();
        let message = json!({
            "timestamp": time(time_ns),
            "parent_frame_id": WORLD_FRAME,
            "child_frame_id": CAMERA_FRAME,
            "translation": p["position"],
            "rotation": p["orientation"],
        });
        self.write(topic, FRAME_TRANSFORM, time_ns, &message)
    }

    /// A path: `poses` in `frame_id`, as a `foxglove.PosesInFrame` on `topic`.
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn poses(&mut self, topic: &str, time_ns: u64, frame_id: &str, poses: &[Pose]) -> anyhow::Result<()> {
        let message = json!({
            "timestamp": time(time_ns),
            "frame_id": frame_id,
            "poses": poses.iter().map(|p| p.to_json()).collect::<Vec<_>>(),
        });
        self.write(topic, POSES_IN_FRAME, time_ns, &message)
    }

    /// The whole scene of `topic` at `time_ns`: a `foxglove.SceneUpdate` that first deletes
    /// every older entity, then adds one line-strip entity per [`Line`] in [`WORLD_FRAME`].
    /// Deleting first makes each message the complete state at its time, so an object that left
    /// does not linger when scrubbing.
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn lines(&mut self, topic: &str, time_ns: u64, lines: &[Line]) -> anyhow::Result<()> {
        let entities: Vec<Value> = lines
            .iter()
            .map(|l| {
                json!({
                    "timestamp": time(time_ns),
                    "frame_id": WORLD_FRAME,
                    "id": l.id,
                    "lifetime": time(0),
                    "frame_locked": false,
                    "metadata": l.metadata.iter().map(|(k, v)| json!({"key": k, "value": v})).collect::<Vec<_>>(),
                    "lines": [{
                        "type": LINE_STRIP,
                        "pose": Pose::IDENTITY.to_json(),
                        "thickness": l.thickness,
                        "scale_invariant": false,
                        "points": l.points.iter().map(|&[x, y, z]| json!({"x": x, "y": y, "z": z})).collect::<Vec<_>>(),
                        "color": l.color.to_json(),
                        "colors": [],
                        "indices": [],
                    }],
                })
            })
            .collect();
        let message = json!({
            "deletions": [{"timestamp": time(time_ns), "type": DELETE_ALL, "id": ""}],
            "entities": entities,
        });
        self.write(topic, SCENE_UPDATE, time_ns, &message)
    }

    /// Points (x, y, z, metres, in `frame_id`) as a `foxglove.PointCloud` on `topic`: packed
    /// little-endian 32-bit floats, 12 bytes a point.
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn points(&mut self, topic: &str, time_ns: u64, frame_id: &str, points: &[[f32; 3]]) -> anyhow::Result<()> {
        let data: Vec<u8> = points.iter().flatten().flat_map(|v| v.to_le_bytes()).collect();
        let fields = [float_field("x", 0), float_field("y", 4), float_field("z", 8)];
        self.point_cloud(topic, time_ns, frame_id, 12, &fields, &data)
    }

    /// Points each carrying an unsigned integer (e.g. the object id) as a `foxglove.PointCloud`
    /// on `topic`: x, y, z (metres, in `frame_id`) as little-endian 32-bit floats, then the
    /// integer as a little-endian `uint32` field named `label`; 16 bytes a point. Foxglove can
    /// colour the points by that field, so each object stands out without a colour chosen here.
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn labelled_points(
        &mut self,
        topic: &str,
        time_ns: u64,
        frame_id: &str,
        label: &str,
        points: &[([f32; 3], u32)],
    ) -> anyhow::Result<()> {
        let data: Vec<u8> = points
            .iter()
            .flat_map(|([x, y, z], id)| {
                [x.to_le_bytes(), y.to_le_bytes(), z.to_le_bytes(), id.to_le_bytes()].into_iter().flatten()
            })
            .collect();
        let fields = [
            float_field("x", 0),
            float_field("y", 4),
            float_field("z", 8),
            json!({"name": label, "offset": 12, "type": UINT32}),
        ];
        self.point_cloud(topic, time_ns, frame_id, 16, &fields, &data)
    }

    /// A `foxglove.PointCloud` of packed points `data`, `stride` bytes each, laid out as `fields`.
    fn point_cloud(
        &mut self,
        topic: &str,
        time_ns: u64,
        frame_id: &str,
        stride: u32,
        fields: &[Value],
        data: &[u8],
    ) -> anyhow::Result<()> {
        let message = json!({
            "timestamp": time(time_ns),
            "frame_id": frame_id,
            "pose": Pose::IDENTITY.to_json(),
            "point_stride": stride,
            "fields": fields,
            "data": base64::engine::general_purpose::STANDARD.encode(data),
        });
        self.write(topic, POINT_CLOUD, time_ns, &message)
    }

    /// Points drawn over an image, one group per [`ImagePoints`], as a
    /// `foxglove.ImageAnnotations` on `topic` (Foxglove's image panel lists it for the image
    /// topics). Foxglove places the origin at the top-left pixel's corner, not its centre, so
    /// the points are written half a pixel further right and down than given.
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn image_points(&mut self, topic: &str, time_ns: u64, groups: &[ImagePoints]) -> anyhow::Result<()> {
        let annotations: Vec<Value> = groups
            .iter()
            .map(|g| {
                json!({
                    "timestamp": time(time_ns),
                    "type": POINTS,
                    "points": g.points.iter().map(|&[x, y]| json!({"x": x + 0.5, "y": y + 0.5})).collect::<Vec<_>>(),
                    "outline_color": g.color.to_json(),
                    "outline_colors": [],
                    "fill_color": g.color.to_json(),
                    "thickness": g.size,
                })
            })
            .collect();
        // Circles and texts are written empty rather than left out: every field of the schema
        // is there, as Foxglove's own writers do.
        let message = json!({"circles": [], "points": annotations, "texts": []});
        self.write(topic, IMAGE_ANNOTATIONS, time_ns, &message)
    }

    /// An encoded image (`format`: `png`, `jpeg`, ...) seen from `frame_id`, as a
    /// `foxglove.CompressedImage` on `topic`.
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn image(
        &mut self,
        topic: &str,
        time_ns: u64,
        frame_id: &str,
        format: &str,
        data: &[u8],
    ) -> anyhow::Result<()> {
        let message = json!({
            "timestamp": time(time_ns),
            "frame_id": frame_id,
            "data": base64::engine::general_purpose::STANDARD.encode(data),
            "format": format,
        });
        self.write(topic, COMPRESSED_IMAGE, time_ns, &message)
    }

    /// Writes the summary, closes the file and gives it its name.
    ///
    /// # Errors
    /// Writing or renaming errors, named.
    pub fn finish(mut self) -> anyhow::Result<RecordingSummary> {
        let partial = self.partial.clone();
        let mut writer = self.writer.take().context("recording already finished")?;
        writer.finish().with_context(|| format!("recording {}: writing the summary", partial.display()))?;
        let mut buffered = writer.into_inner();
        buffered.flush().with_context(|| format!("recording {}: writing", partial.display()))?;
        let file = buffered
            .into_inner()
            .map_err(|e| e.into_error())
            .with_context(|| format!("recording {}: writing", partial.display()))?;
        file.sync_all().with_context(|| format!("recording {}: writing", partial.display()))?;
        drop(file);
        std::fs::rename(&partial, &self.path)
            .with_context(|| format!("recording {}: renaming {} to it", self.path.display(), partial.display()))?;
        let bytes = std::fs::metadata(&self.path)
            .with_context(|| format!("recording {}: reading its size", self.path.display()))?
            .len();
        Ok(RecordingSummary { path: self.path.clone(), bytes, messages: std::mem::take(&mut self.counts) })
    }

    /// Writes `message` on `topic` (schema `schema`) at `time_ns`.
    fn write(&mut self, topic: &str, schema: &'static str, time_ns: u64, message: &Value) -> anyhow::Result<()> {
        let partial = &self.partial;
        let name = || format!("recording {}: topic {topic}", partial.display());
        let writer = self.writer.as_mut().with_context(|| format!("{}: already finished", name()))?;
        let channel_id = match self.channels.get(topic) {
            Some(&(id, s)) if s == schema => id,
            Some(&(_, s)) => anyhow::bail!("{}: holds {s}, not {schema}", name()),
            None => {
                let schema_id = match self.schemas.get(schema) {
                    Some(&id) => id,
                    None => {
                        let text = serde_json::to_vec(&schema_of(schema)?).with_context(name)?;
                        let id = writer.add_schema(schema, SCHEMA_ENCODING, &text).with_context(name)?;
                        self.schemas.insert(schema, id);
                        id
                    }
                };
                let id = writer.add_channel(schema_id, topic, MESSAGE_ENCODING, &BTreeMap::new()).with_context(name)?;
                self.channels.insert(topic.to_string(), (id, schema));
                id
            }
        };
        let data = serde_json::to_vec(message).with_context(name)?;
        let header = mcap::records::MessageHeader {
            channel_id,
            sequence: self.sequence,
            log_time: time_ns,
            publish_time: time_ns,
        };
        writer.write_to_known_channel(&header, &data).with_context(name)?;
        self.sequence = self.sequence.wrapping_add(1);
        *self.counts.entry(topic.to_string()).or_insert(0) += 1;
        Ok(())
    }
}

impl Drop for Recorder {
    fn drop(&mut self) {
        if let Some(writer) = self.writer.take() {
            // Not finished: the writer's own drop completes the temporary file, which then goes,
            // so that no complete-looking recording is left behind. Nothing to report from a drop.
            drop(writer);
            let _ = std::fs::remove_file(&self.partial);
        }
    }
}

/// A 32-bit float field of a `foxglove.PointCloud` at byte `offset` of each point.
fn float_field(name: &str, offset: u32) -> Value {
    json!({"name": name, "offset": offset, "type": FLOAT32})
}

/// A `Time` (or `Duration`) of `ns` nanoseconds.
fn time(ns: u64) -> Value {
    json!({"sec": ns / 1_000_000_000, "nsec": ns % 1_000_000_000})
}

/// The JSON schema of Foxglove's schema `name`, of the fields written here.
fn schema_of(name: &str) -> anyhow::Result<Value> {
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
            ("circles", array(circle_annotation())),
            ("points", array(points_annotation())),
            ("texts", array(text_annotation())),
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
        ("metadata", array(object(&[("key", string()), ("value", string())]))),
        ("lines", array(line_primitive())),
    ])
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Checks `value` against the subset of JSON Schema written here (type, properties,
    /// required, items, enum, minimum, maximum), naming the path of the first mismatch.
    fn conforms(schema: &Value, value: &Value, at: &str) -> Result<(), String> {
        let ty = schema["type"].as_str().ok_or(format!("{at}: schema without type"))?;
        let ok = match ty {
            "object" => value.is_object(),
            "array" => value.is_array(),
            "string" => value.is_string(),
            "number" => value.is_number(),
            "integer" => value.is_u64() || value.is_i64(),
            "boolean" => value.is_boolean(),
            other => return Err(format!("{at}: unknown type {other}")),
        };
        if !ok {
            return Err(format!("{at}: expected {ty}, found {value}"));
        }
        if let Some(options) = schema["enum"].as_array()
            && !options.contains(value)
        {
            return Err(format!("{at}: {value} not in {options:?}"));
        }
        if let Some(min) = schema["minimum"].as_i64()
            && value.as_i64().is_some_and(|v| v < min)
        {
            return Err(format!("{at}: {value} below {min}"));
        }
        if let Some(max) = schema["maximum"].as_i64()
            && value.as_i64().is_some_and(|v| v > max)
        {
            return Err(format!("{at}: {value} above {max}"));
        }
        if let (Some(props), Some(fields)) = (schema["properties"].as_object(), value.as_object()) {
            for key in fields.keys() {
                let sub = props.get(key).ok_or(format!("{at}.{key}: not in the schema"))?;
                conforms(sub, &fields[key], &format!("{at}.{key}"))?;
            }
            for key in schema["required"].as_array().into_iter().flatten() {
                let key = key.as_str().ok_or(format!("{at}: required holds a non-string"))?;
                if !fields.contains_key(key) {
                    return Err(format!("{at}.{key}: required, missing"));
                }
            }
        }
        if let (Some(items), Some(list)) = (schema.get("items"), value.as_array()) {
            for (i, v) in list.iter().enumerate() {
                conforms(items, v, &format!("{at}[{i}]"))?;
            }
        }
        Ok(())
    }

    fn line(id: &str, n: usize) -> Line {
        Line {
            id: id.to_string(),
            points: (0..n).map(|i| [i as f64, 2.0 * i as f64, 0.0]).collect(),
            color: Rgba::opaque(1.0, 0.5, 0.0),
            thickness: 0.2,
            metadata: vec![("class".into(), "car".into())],
        }
    }

    /// Writes three frames on every kind of topic.
    fn write_sample(path: &Path) -> RecordingSummary {
        let mut rec = Recorder::create(path).unwrap();
        for frame in 0..3u32 {
            let t = frame_time_ns(frame, 20.0).unwrap();
            let camera = Pose::from_camera_world([0.0, 0.0, f64::from(frame)], [0.0, 0.0, 0.0, 1.0]);
            rec.camera_transform("/tf", t, &camera).unwrap();
            rec.poses("/camera/path", t, WORLD_FRAME, &vec![camera; frame as usize + 1]).unwrap();
            rec.lines("/objects/tracks", t, &[line("1", frame as usize + 1), line("2", 2)]).unwrap();
            rec.lines("/forecasts/cv", t, &[]).unwrap();
            rec.points("/points/static", t, CAMERA_FRAME, &[[1.0, 2.0, 3.0], [4.0, 5.0, 6.0]]).unwrap();
            rec.image("/camera/image", t, CAMERA_FRAME, "png", &[0x89, b'P', b'N', b'G']).unwrap();
            let labelled = [([1.0, 2.0, 3.0], 7), ([4.0, 5.0, 6.0], u32::from(u16::MAX))];
            rec.labelled_points("/points/objects", t, CAMERA_FRAME, "object_id", &labelled).unwrap();
            let dots = |x: f64, color| ImagePoints { points: vec![[x, 0.0], [x, 149.0]], color, size: 3.0 };
            let groups = [dots(0.0, Rgba::opaque(0.0, 1.0, 0.0)), dots(10.0, Rgba::opaque(1.0, 0.0, 0.0))];
            rec.image_points("/camera/annotations", t, &groups).unwrap();
        }
        rec.finish().unwrap()
    }

    #[test]
    fn a_recording_reads_back_with_foxglove_schemas_and_json_messages() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("sub").join("rec.mcap");
        let summary = write_sample(&path);
        assert_eq!(summary.path, path);
        assert!(!partial_path(&path).exists(), "the temporary file is renamed");
        let bytes = std::fs::read(&path).unwrap();
        assert_eq!(summary.bytes, bytes.len() as u64);

        let expected = [
            ("/tf", FRAME_TRANSFORM),
            ("/camera/path", POSES_IN_FRAME),
            ("/objects/tracks", SCENE_UPDATE),
            ("/forecasts/cv", SCENE_UPDATE),
            ("/points/static", POINT_CLOUD),
            ("/camera/image", COMPRESSED_IMAGE),
            ("/points/objects", POINT_CLOUD),
            ("/camera/annotations", IMAGE_ANNOTATIONS),
        ];
        let info = mcap::Summary::read(&bytes).unwrap().expect("a summary section");
        let stats = info.stats.as_ref().expect("statistics");
        assert_eq!(stats.message_count, 24);
        assert_eq!((stats.message_start_time, stats.message_end_time), (0, 100_000_000));
        let mut counts: BTreeMap<String, u64> = BTreeMap::new();
        let mut times: Vec<u64> = Vec::new();
        for m in mcap::MessageStream::new(&bytes).unwrap() {
            let m = m.unwrap();
            let schema = m.channel.schema.as_ref().expect("every channel has a schema");
            let want = expected.iter().find(|(t, _)| *t == m.channel.topic).expect("a known topic").1;
            assert_eq!(schema.name, want, "{}", m.channel.topic);
            assert_eq!(schema.encoding, SCHEMA_ENCODING);
            assert_eq!(m.channel.message_encoding, MESSAGE_ENCODING);
            assert_eq!(m.log_time, m.publish_time);
            let schema: Value = serde_json::from_slice(&schema.data).unwrap();
            let msg: Value = serde_json::from_slice(&m.data).unwrap();
            conforms(&schema, &msg, &m.channel.topic).unwrap();
            // The stamp inside is the log time.
            let stamp = if schema["title"] == SCENE_UPDATE {
                &msg["deletions"][0]["timestamp"]
            } else if schema["title"] == IMAGE_ANNOTATIONS {
                &msg["points"][0]["timestamp"]
            } else {
                &msg["timestamp"]
            };
            assert_eq!(stamp["sec"].as_u64().unwrap() * 1_000_000_000 + stamp["nsec"].as_u64().unwrap(), m.log_time);
            match m.channel.topic.as_str() {
                "/tf" => {
                    assert_eq!(msg["parent_frame_id"], WORLD_FRAME);
                    assert_eq!(msg["child_frame_id"], CAMERA_FRAME);
                }
                "/objects/tracks" => {
                    let entities = msg["entities"].as_array().unwrap();
                    assert_eq!(entities.len(), 2);
                    assert_eq!(entities[0]["id"], "1");
                    assert_eq!(entities[0]["frame_id"], WORLD_FRAME);
                    let frame = (m.log_time / 50_000_000) as usize;
                    assert_eq!(entities[0]["lines"][0]["points"].as_array().unwrap().len(), frame + 1);
                    assert_eq!(entities[0]["lines"][0]["points"][frame]["y"], 2.0 * frame as f64);
                }
                "/points/static" => {
                    let data = base64::engine::general_purpose::STANDARD.decode(msg["data"].as_str().unwrap()).unwrap();
                    assert_eq!(data.len(), 2 * 12);
                    assert_eq!(f32::from_le_bytes(data[12..16].try_into().unwrap()), 4.0);
                    assert_eq!(msg["fields"][2]["name"], "z");
                }
                "/camera/image" => assert_eq!(msg["format"], "png"),
                "/points/objects" => {
                    let data = base64::engine::general_purpose::STANDARD.decode(msg["data"].as_str().unwrap()).unwrap();
                    assert_eq!(msg["point_stride"], 16);
                    assert_eq!(data.len(), 2 * 16);
                    assert_eq!(f32::from_le_bytes(data[16..20].try_into().unwrap()), 4.0);
                    assert_eq!(u32::from_le_bytes(data[12..16].try_into().unwrap()), 7);
                    assert_eq!(u32::from_le_bytes(data[28..32].try_into().unwrap()), 65_535);
                    assert_eq!(msg["fields"][3], json!({"name": "object_id", "offset": 12, "type": UINT32}));
                }
                "/camera/annotations" => {
                    let groups = msg["points"].as_array().unwrap();
                    assert_eq!(groups.len(), 2);
                    assert_eq!(groups[1]["type"], POINTS);
                    // Shifted half a pixel: Foxglove's origin is the top-left pixel's corner.
                    assert_eq!(groups[1]["points"][1], json!({"x": 10.5, "y": 149.5}));
                    assert_eq!(groups[1]["outline_color"]["r"], 1.0);
                    assert_eq!(groups[1]["thickness"], 3.0);
                    assert_eq!(
                        (msg["circles"].as_array().unwrap().len(), msg["texts"].as_array().unwrap().len()),
                        (0, 0)
                    );
                }
                _ => {}
            }
            *counts.entry(m.channel.topic.to_string()).or_insert(0) += 1;
            times.push(m.log_time);
        }
        assert_eq!(counts, summary.messages);
        assert_eq!(counts.len(), expected.len());
        assert!(counts.values().all(|&n| n == 3), "{counts:?}");
        assert!(times.windows(2).all(|w| w[0] <= w[1]), "log times in order");
    }

    #[test]
    fn a_recording_dropped_before_finish_leaves_no_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rec.mcap");
        let mut rec = Recorder::create(&path).unwrap();
        rec.lines("/objects/tracks", 0, &[line("1", 2)]).unwrap();
        assert!(partial_path(&path).exists(), "written under the temporary name");
        drop(rec);
        assert!(!path.exists());
        assert!(!partial_path(&path).exists());
    }

    #[test]
    fn a_topic_keeps_its_schema_and_errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("rec.mcap");
        let mut rec = Recorder::create(&path).unwrap();
        rec.lines("/objects/tracks", 0, &[]).unwrap();
        let err = format!("{:#}", rec.points("/objects/tracks", 0, CAMERA_FRAME, &[]).unwrap_err());
        assert!(err.contains("rec.mcap") && err.contains(SCENE_UPDATE), "{err}");
        let err = format!("{:#}", Recorder::create(&partial_path(&path).join("x.mcap")).unwrap_err());
        assert!(err.contains("x.mcap"), "{err}");
        assert!(frame_time_ns(1, 0.0).is_err());
        assert_eq!(frame_time_ns(3, 10.0).unwrap(), 300_000_000);
    }

    #[test]
    fn camera_world_poses_turn_so_that_z_is_up() {
        // A camera 2 m forward and 1 m below the first one (y down) sits at (0, 2, -1).
        let p = Pose::from_camera_world([0.0, 1.0, 2.0], [0.0, 0.0, 0.0, 1.0]);
        assert_eq!(p.position, [0.0, 2.0, -1.0]);
        // Its optical axis (body z) points along the world's y, the bird's-eye forward.
        let [x, y, z, w] = p.orientation;
        // Third column of the rotation matrix: body z in the world.
        let axis = [2.0 * (x * z + w * y), 2.0 * (y * z - w * x), 1.0 - 2.0 * (x * x + y * y)];
        assert!((axis[0]).abs() < 1e-12 && (axis[1] - 1.0).abs() < 1e-12 && axis[2].abs() < 1e-12, "{axis:?}");
    }
}
