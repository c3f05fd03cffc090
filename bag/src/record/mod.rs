//! Recordings of what the pipeline computed, for a standard viewer: MCAP files whose messages
//! use Foxglove's well-known schemas (`foxglove.SceneUpdate`, `foxglove.FrameTransform`,
//! `foxglove.PosesInFrame`, `foxglove.PointCloud`, `foxglove.CompressedImage`,
//! `foxglove.ImageAnnotations`), so that Foxglove, rerun, the `mcap` tool and Python's `mcap`
//! package all read them without code of ours. [`RecordingEncoding::Protobuf`] (the default)
//! writes them as Foxglove's SDKs do, with the schemas as Protobuf FileDescriptorSets (from
//! the `foxglove` crate): Foxglove and rerun both display it. [`RecordingEncoding::Json`]
//! writes Foxglove's JSON encoding, every field of the schema present.
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
//! The JSON schemas are written here, compact and fully inlined (Foxglove's JSON-schema reader
//! does not follow `$ref`); bytes fields are base64 strings with `contentEncoding: base64`,
//! which is how Foxglove knows to decode them.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufWriter, Write as _};
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use foxglove::Encode;
use foxglove::messages::{
    self as fg, CompressedImage, FrameTransform, ImageAnnotations, KeyValuePair, LinePrimitive, PackedElementField,
    PointCloud, PointsAnnotation, PosesInFrame, SceneEntity, SceneEntityDeletion, SceneUpdate, Timestamp,
};

use fg::packed_element_field::NumericType;
use json::ToJson;
pub use lines::{FORECAST_THICKNESS, TRAIL_THICKNESS, Trails, forecast_line, meta, trail_line};
use schemas::schema_of;

mod json;
mod lines;
mod schemas;
#[cfg(test)]
mod tests;

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

/// How a recording's messages are encoded.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum RecordingEncoding {
    /// Protobuf, the schemas as FileDescriptorSets: what Foxglove's SDKs write, displayed by
    /// Foxglove and by rerun.
    #[default]
    Protobuf,
    /// JSON, the schemas as JSON Schemas: readable without a Protobuf library; Foxglove displays
    /// it, rerun does not.
    Json,
}

impl RecordingEncoding {
    /// The MCAP schema encoding (`protobuf` or `jsonschema`).
    #[must_use]
    pub const fn schema_encoding(self) -> &'static str {
        match self {
            Self::Protobuf => "protobuf",
            Self::Json => "jsonschema",
        }
    }

    /// The MCAP message encoding (`protobuf` or `json`).
    #[must_use]
    pub const fn message_encoding(self) -> &'static str {
        match self {
            Self::Protobuf => "protobuf",
            Self::Json => "json",
        }
    }
}

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

    fn message(self) -> fg::Pose {
        let [x, y, z] = self.position;
        let [qx, qy, qz, qw] = self.orientation;
        fg::Pose {
            position: Some(fg::Vector3 { x, y, z }),
            orientation: Some(fg::Quaternion { x: qx, y: qy, z: qz, w: qw }),
        }
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

    fn message(self) -> fg::Color {
        fg::Color { r: self.r, g: self.g, b: self.b, a: self.a }
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

/// A bird's-eye position (the pipeline's world x, y) on the recording's ground plane (z = 0
/// in [`WORLD_FRAME`]).
#[must_use]
pub fn ground(x: f32, y: f32) -> [f64; 3] {
    [f64::from(x), f64::from(y), 0.0]
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
    encoding: RecordingEncoding,
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
    /// Starts a recording to be written to `path` (its folder is created if needed) in the
    /// default encoding.
    ///
    /// # Errors
    /// The folder or the temporary file cannot be created, named.
    pub fn create(path: &Path) -> anyhow::Result<Recorder> {
        Self::create_with(path, RecordingEncoding::default())
    }

    /// Starts a recording to be written to `path` (its folder is created if needed) in
    /// `encoding`.
    ///
    /// # Errors
    /// The folder or the temporary file cannot be created, named.
    pub fn create_with(path: &Path, encoding: RecordingEncoding) -> anyhow::Result<Recorder> {
        anyhow::ensure!(path.file_name().is_some(), "recording {}: expected a file name", path.display());
        dynotraj_formats::atomic::replaceable(path)?;
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
            encoding,
            writer: Some(writer),
            schemas: BTreeMap::new(),
            channels: BTreeMap::new(),
            counts: BTreeMap::new(),
            sequence: 0,
        })
    }

    /// The log time of frame `frame` at `rate_hz` ([`frame_time_ns`]), errors naming this
    /// recording.
    ///
    /// # Errors
    /// A rate that is not a positive finite number.
    pub fn frame_time(&self, frame: u32, rate_hz: f64) -> anyhow::Result<u64> {
        frame_time_ns(frame, rate_hz).with_context(|| format!("recording {}", self.path.display()))
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
        let p = camera.message();
        let message = FrameTransform {
            timestamp: Some(time(time_ns)),
            parent_frame_id: WORLD_FRAME.into(),
            child_frame_id: CAMERA_FRAME.into(),
            translation: p.position,
            rotation: p.orientation,
        };
        self.write(topic, FRAME_TRANSFORM, time_ns, &message)
    }

    /// A path: `poses` in `frame_id`, as a `foxglove.PosesInFrame` on `topic`.
    ///
    /// # Errors
    /// Writing errors, or `topic` already used with another schema; named.
    pub fn poses(&mut self, topic: &str, time_ns: u64, frame_id: &str, poses: &[Pose]) -> anyhow::Result<()> {
        let message = PosesInFrame {
            timestamp: Some(time(time_ns)),
            frame_id: frame_id.into(),
            poses: poses.iter().map(|p| p.message()).collect(),
        };
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
        let entities = lines
            .iter()
            .map(|l| SceneEntity {
                timestamp: Some(time(time_ns)),
                frame_id: WORLD_FRAME.into(),
                id: l.id.clone(),
                lifetime: Some(fg::Duration::new(0, 0)),
                frame_locked: false,
                metadata: l.metadata.iter().map(|(k, v)| KeyValuePair { key: k.clone(), value: v.clone() }).collect(),
                lines: vec![LinePrimitive {
                    r#type: fg::line_primitive::Type::LineStrip as i32,
                    pose: Some(Pose::IDENTITY.message()),
                    thickness: l.thickness,
                    scale_invariant: false,
                    points: l.points.iter().map(|&[x, y, z]| fg::Point3 { x, y, z }).collect(),
                    color: Some(l.color.message()),
                    colors: Vec::new(),
                    indices: Vec::new(),
                }],
                ..SceneEntity::default()
            })
            .collect();
        let message = SceneUpdate {
            deletions: vec![SceneEntityDeletion {
                timestamp: Some(time(time_ns)),
                r#type: fg::scene_entity_deletion::Type::All as i32,
                id: String::new(),
            }],
            entities,
        };
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
        self.point_cloud(topic, time_ns, frame_id, 12, &fields, data)
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
            PackedElementField { name: label.into(), offset: 12, r#type: NumericType::Uint32 as i32 },
        ];
        self.point_cloud(topic, time_ns, frame_id, 16, &fields, data)
    }

    /// A `foxglove.PointCloud` of packed points `data`, `stride` bytes each, laid out as `fields`.
    fn point_cloud(
        &mut self,
        topic: &str,
        time_ns: u64,
        frame_id: &str,
        stride: u32,
        fields: &[PackedElementField],
        data: Vec<u8>,
    ) -> anyhow::Result<()> {
        let message = PointCloud {
            timestamp: Some(time(time_ns)),
            frame_id: frame_id.into(),
            pose: Some(Pose::IDENTITY.message()),
            point_stride: stride,
            fields: fields.to_vec(),
            data: data.into(),
        };
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
        let points = groups
            .iter()
            .map(|g| PointsAnnotation {
                timestamp: Some(time(time_ns)),
                r#type: fg::points_annotation::Type::Points as i32,
                points: g.points.iter().map(|&[x, y]| fg::Point2 { x: x + 0.5, y: y + 0.5 }).collect(),
                outline_color: Some(g.color.message()),
                outline_colors: Vec::new(),
                fill_color: Some(g.color.message()),
                thickness: g.size,
                metadata: Vec::new(),
            })
            .collect();
        let message = ImageAnnotations { timestamp: Some(time(time_ns)), points, ..ImageAnnotations::default() };
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
        let message = CompressedImage {
            timestamp: Some(time(time_ns)),
            frame_id: frame_id.into(),
            data: data.to_vec().into(),
            format: format.into(),
        };
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

    /// Writes `message` on `topic` (schema `schema`) at `time_ns`, in the recording's encoding.
    fn write<M: Encode + ToJson>(
        &mut self,
        topic: &str,
        schema: &'static str,
        time_ns: u64,
        message: &M,
    ) -> anyhow::Result<()> {
        let encoding = self.encoding;
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
                        let text = match encoding {
                            RecordingEncoding::Json => serde_json::to_vec(&schema_of(schema)?).with_context(name)?,
                            RecordingEncoding::Protobuf => {
                                let s =
                                    M::get_schema().with_context(|| format!("{}: no schema of {schema}", name()))?;
                                anyhow::ensure!(s.name == schema, "{}: schema {} for {schema}", name(), s.name);
                                s.data.to_vec()
                            }
                        };
                        let id = writer.add_schema(schema, encoding.schema_encoding(), &text).with_context(name)?;
                        self.schemas.insert(schema, id);
                        id
                    }
                };
                let id = writer
                    .add_channel(schema_id, topic, encoding.message_encoding(), &BTreeMap::new())
                    .with_context(name)?;
                self.channels.insert(topic.to_string(), (id, schema));
                id
            }
        };
        let data = match encoding {
            RecordingEncoding::Json => serde_json::to_vec(&message.to_json()).with_context(name)?,
            RecordingEncoding::Protobuf => {
                let mut buf = Vec::with_capacity(message.encoded_len().unwrap_or(0));
                message.encode(&mut buf).map_err(|e| anyhow::anyhow!("{}: {e}", name()))?;
                buf
            }
        };
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
fn float_field(name: &str, offset: u32) -> PackedElementField {
    PackedElementField { name: name.into(), offset, r#type: NumericType::Float32 as i32 }
}

/// The time `ns` nanoseconds after the epoch (saturating past 2106).
fn time(ns: u64) -> Timestamp {
    let sec = u32::try_from(ns / 1_000_000_000).unwrap_or(u32::MAX);
    // The remainder is below 10^9, which fits.
    Timestamp::new(sec, u32::try_from(ns % 1_000_000_000).unwrap_or(0))
}
