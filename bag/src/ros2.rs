//! The ROS 2 messages a camera bag brings, as serde types, and their CDR payloads.
//!
//! A ROS 2 message in a bag is XCDR1: a 4-byte encapsulation header (`00 01`: little-endian,
//! `00 00`: big-endian, then two option bytes) and the CDR body, aligned from the byte after the
//! header. The field order and types below are those of the ROS 2 message definitions
//! (`sensor_msgs`, `std_msgs`, `builtin_interfaces`, `vision_msgs` 4), which the CDR
//! encoding follows one to one.

use byteorder::{BigEndian, LittleEndian};
use serde::de::DeserializeOwned;
use serde::{Deserialize, Serialize};
use serde_big_array::BigArray;

/// Schema name of `sensor_msgs/msg/Image`.
pub const IMAGE: &str = "sensor_msgs/msg/Image";
/// Schema name of `sensor_msgs/msg/CompressedImage`.
pub const COMPRESSED_IMAGE: &str = "sensor_msgs/msg/CompressedImage";
/// Schema name of `sensor_msgs/msg/CameraInfo`.
pub const CAMERA_INFO: &str = "sensor_msgs/msg/CameraInfo";
/// Schema name of `vision_msgs/msg/Detection2DArray`.
pub const DETECTION_2D_ARRAY: &str = "vision_msgs/msg/Detection2DArray";
/// The message encoding of ROS 2 bags.
pub const CDR: &str = "cdr";

/// The separator between a message definition and each definition it uses, as rosbag2 writes
/// the `ros2msg` schema of a channel.
const DEFINITION_SEPARATOR: &str = "================================================================================";

/// The message definitions (ROS 2 `.msg` field lists) the bag's messages are built from, by
/// full type name: what a `ros2msg` schema carries so that ROS 2 tools decode the payloads.
const DEFINITIONS: [(&str, &str); 17] = [
    ("builtin_interfaces/Time", "int32 sec\nuint32 nanosec"),
    ("std_msgs/Header", "builtin_interfaces/Time stamp\nstring frame_id"),
    (
        "sensor_msgs/Image",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data",
    ),
    ("sensor_msgs/CompressedImage", "std_msgs/Header header\nstring format\nuint8[] data"),
    ("sensor_msgs/RegionOfInterest", "uint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify"),
    (
        "sensor_msgs/CameraInfo",
        "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\n\
         float64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi",
    ),
    ("geometry_msgs/Point", "float64 x\nfloat64 y\nfloat64 z"),
    ("geometry_msgs/Quaternion", "float64 x\nfloat64 y\nfloat64 z\nfloat64 w"),
    ("geometry_msgs/Pose", "geometry_msgs/Point position\ngeometry_msgs/Quaternion orientation"),
    ("geometry_msgs/PoseWithCovariance", "geometry_msgs/Pose pose\nfloat64[36] covariance"),
    ("vision_msgs/ObjectHypothesis", "string class_id\nfloat64 score"),
    (
        "vision_msgs/ObjectHypothesisWithPose",
        "vision_msgs/ObjectHypothesis hypothesis\ngeometry_msgs/PoseWithCovariance pose",
    ),
    ("vision_msgs/Point2D", "float64 x\nfloat64 y"),
    ("vision_msgs/Pose2D", "vision_msgs/Point2D position\nfloat64 theta"),
    ("vision_msgs/BoundingBox2D", "vision_msgs/Pose2D center\nfloat64 size_x\nfloat64 size_y"),
    (
        "vision_msgs/Detection2D",
        "std_msgs/Header header\nvision_msgs/ObjectHypothesisWithPose[] results\nvision_msgs/BoundingBox2D bbox\nstring id",
    ),
    ("vision_msgs/Detection2DArray", "std_msgs/Header header\nvision_msgs/Detection2D[] detections"),
];

/// The `ros2msg` schema text of `schema` (`sensor_msgs/msg/Image`, ...): its definition, then
/// every definition it uses, each after a separator line and `MSG: <type>`; `None` for a type
/// this crate does not know.
#[must_use]
pub fn schema_text(schema: &str) -> Option<String> {
    let name = schema.replacen("/msg/", "/", 1);
    let definition = |n: &str| DEFINITIONS.iter().find(|(t, _)| *t == n).map(|(_, d)| *d);
    let mut text = definition(&name)?.to_string();
    // Every type used, depth first, each once.
    let mut pending = vec![name];
    let mut seen: Vec<String> = Vec::new();
    while let Some(t) = pending.pop() {
        for line in definition(&t).unwrap_or_default().lines() {
            let used = line.split_whitespace().next().unwrap_or_default();
            let used = used.split('[').next().unwrap_or_default();
            if used.contains('/') && !seen.iter().any(|s| s == used) {
                seen.push(used.to_string());
                pending.push(used.to_string());
            }
        }
    }
    for t in &seen {
        text.push_str(&format!("\n{DEFINITION_SEPARATOR}\nMSG: {t}\n{}", definition(t)?));
    }
    Some(text)
}

/// `builtin_interfaces/Time`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Default, Serialize, Deserialize)]
pub struct Time {
    /// Seconds.
    pub sec: i32,
    /// Nanoseconds within the second.
    pub nanosec: u32,
}

impl Time {
    /// Nanoseconds since the epoch (negative before it).
    #[must_use]
    pub fn nanos(&self) -> i64 {
        i64::from(self.sec) * 1_000_000_000 + i64::from(self.nanosec)
    }

    /// The time `nanos` nanoseconds after the epoch (saturating at the i32 range of seconds).
    #[must_use]
    pub fn from_nanos(nanos: i64) -> Self {
        let sec = nanos.div_euclid(1_000_000_000).clamp(i64::from(i32::MIN), i64::from(i32::MAX));
        Self { sec: sec as i32, nanosec: nanos.rem_euclid(1_000_000_000) as u32 }
    }
}

/// `std_msgs/Header`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Header {
    /// Capture time.
    pub stamp: Time,
    /// The sensor's frame.
    pub frame_id: String,
}

/// `sensor_msgs/Image`: raw pixels.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Image {
    /// Header.
    pub header: Header,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Pixel encoding (`rgb8`, `bgr8`, `mono8`, `16UC1`, `32FC1`, ...).
    pub encoding: String,
    /// 1 when multi-byte pixels are big-endian.
    pub is_bigendian: u8,
    /// Bytes per row.
    pub step: u32,
    /// Pixels, row after row.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `sensor_msgs/CompressedImage`: a PNG or JPEG file's bytes.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CompressedImage {
    /// Header.
    pub header: Header,
    /// `png`, `jpeg`, or image_transport's `bgr8; jpeg compressed bgr8` form.
    pub format: String,
    /// The compressed bytes.
    #[serde(with = "serde_bytes")]
    pub data: Vec<u8>,
}

/// `sensor_msgs/RegionOfInterest`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
pub struct RegionOfInterest {
    /// Left column.
    pub x_offset: u32,
    /// Top row.
    pub y_offset: u32,
    /// Rows.
    pub height: u32,
    /// Columns.
    pub width: u32,
    /// Whether the region is to be rectified.
    pub do_rectify: bool,
}

/// `sensor_msgs/CameraInfo`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct CameraInfo {
    /// Header.
    pub header: Header,
    /// Rows of the calibrated image.
    pub height: u32,
    /// Columns of the calibrated image.
    pub width: u32,
    /// `plumb_bob`, `rational_polynomial`, ...
    pub distortion_model: String,
    /// Distortion coefficients.
    pub d: Vec<f64>,
    /// Intrinsics of the raw image, row-major 3 x 3.
    pub k: [f64; 9],
    /// Rectifying rotation, row-major 3 x 3.
    pub r: [f64; 9],
    /// Projection of the rectified image, row-major 3 x 4; for the right camera of a stereo
    /// pair `p[3]` is `-fx * baseline`.
    pub p: [f64; 12],
    /// Horizontal binning.
    pub binning_x: u32,
    /// Vertical binning.
    pub binning_y: u32,
    /// Region of interest.
    pub roi: RegionOfInterest,
}

/// `geometry_msgs/Point`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
}

/// `geometry_msgs/Quaternion`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Quaternion {
    /// x.
    pub x: f64,
    /// y.
    pub y: f64,
    /// z.
    pub z: f64,
    /// w.
    pub w: f64,
}

/// `geometry_msgs/Pose`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose {
    /// Position.
    pub position: Point,
    /// Orientation.
    pub orientation: Quaternion,
}

/// `geometry_msgs/PoseWithCovariance`.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct PoseWithCovariance {
    /// Pose.
    pub pose: Pose,
    /// Row-major 6 x 6 covariance.
    #[serde(with = "BigArray")]
    pub covariance: [f64; 36],
}

impl Default for PoseWithCovariance {
    fn default() -> Self {
        Self { pose: Pose::default(), covariance: [0.0; 36] }
    }
}

/// `vision_msgs/ObjectHypothesis`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ObjectHypothesis {
    /// Class name or number, as the detector says it.
    pub class_id: String,
    /// Confidence.
    pub score: f64,
}

/// `vision_msgs/ObjectHypothesisWithPose`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct ObjectHypothesisWithPose {
    /// Class and score.
    pub hypothesis: ObjectHypothesis,
    /// Pose (unused here).
    pub pose: PoseWithCovariance,
}

/// `vision_msgs/Point2D`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Point2D {
    /// Column, pixels.
    pub x: f64,
    /// Row, pixels.
    pub y: f64,
}

/// `vision_msgs/Pose2D`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct Pose2D {
    /// Centre.
    pub position: Point2D,
    /// Rotation, radians.
    pub theta: f64,
}

/// `vision_msgs/BoundingBox2D`.
#[derive(Debug, Clone, Copy, PartialEq, Default, Serialize, Deserialize)]
pub struct BoundingBox2D {
    /// Centre.
    pub center: Pose2D,
    /// Width, pixels.
    pub size_x: f64,
    /// Height, pixels.
    pub size_y: f64,
}

/// `vision_msgs/Detection2D`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Detection2D {
    /// Header.
    pub header: Header,
    /// Class hypotheses, best first.
    pub results: Vec<ObjectHypothesisWithPose>,
    /// The box.
    pub bbox: BoundingBox2D,
    /// A tracker's id of the object, when the detector tracks.
    pub id: String,
}

/// `vision_msgs/Detection2DArray`.
#[derive(Debug, Clone, PartialEq, Default, Serialize, Deserialize)]
pub struct Detection2DArray {
    /// Header.
    pub header: Header,
    /// The detections.
    pub detections: Vec<Detection2D>,
}

/// Why a payload did not decode.
#[derive(Debug, thiserror::Error)]
pub enum CdrError {
    /// Fewer than 4 bytes: no encapsulation header.
    #[error("{0} bytes: too short for the 4-byte CDR encapsulation header")]
    NoHeader(usize),
    /// An encapsulation other than plain CDR.
    #[error("encapsulation {0:#04x} {1:#04x}: expected plain CDR (00 00 or 00 01)")]
    Encapsulation(u8, u8),
    /// The body does not hold the message (truncated, or another type).
    #[error("{0}")]
    Body(String),
}

/// Decodes a ROS 2 CDR payload (encapsulation header and body).
///
/// # Errors
/// [`CdrError`]: no header, another encapsulation, or a body that is not a `T`.
pub fn decode<T: DeserializeOwned>(payload: &[u8]) -> Result<T, CdrError> {
    let (Some(head), Some(body)) = (payload.get(..4), payload.get(4..)) else {
        return Err(CdrError::NoHeader(payload.len()));
    };
    let decoded = match (head.first(), head.get(1)) {
        (Some(0), Some(1)) => cdr_encoding::from_bytes::<T, LittleEndian>(body),
        (Some(0), Some(0)) => cdr_encoding::from_bytes::<T, BigEndian>(body),
        (Some(&a), Some(&b)) => return Err(CdrError::Encapsulation(a, b)),
        _ => return Err(CdrError::NoHeader(payload.len())),
    };
    decoded.map(|(v, _)| v).map_err(|e| CdrError::Body(e.to_string()))
}

/// Encodes `value` as a little-endian ROS 2 CDR payload (what a ROS 2 publisher writes).
///
/// # Errors
/// A value serde cannot encode as CDR.
pub fn encode<T: Serialize>(value: &T) -> Result<Vec<u8>, CdrError> {
    let body = cdr_encoding::to_vec::<T, LittleEndian>(value).map_err(|e| CdrError::Body(e.to_string()))?;
    let mut out = Vec::with_capacity(body.len() + 4);
    out.extend_from_slice(&[0, 1, 0, 0]);
    out.extend_from_slice(&body);
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The bytes a ROS 2 publisher (rclcpp, Fast DDS) writes for a 2 x 1 `rgb8` image with
    /// stamp 3.5 s and frame "cam": written out by hand from the CDR rules, so that the types
    /// are checked against the wire, not only against themselves.
    const IMAGE_2X1: [u8; 54] = [
        0, 1, 0, 0, // encapsulation: CDR little-endian
        3, 0, 0, 0, 0x00, 0x65, 0xCD, 0x1D, // stamp: sec 3, nanosec 500,000,000
        4, 0, 0, 0, b'c', b'a', b'm', 0, // frame_id "cam" with its terminating 0
        1, 0, 0, 0, 2, 0, 0, 0, // height 1, width 2
        5, 0, 0, 0, b'r', b'g', b'b', b'8', 0, // encoding "rgb8"
        0, // is_bigendian
        0, 0, // padding to 4
        6, 0, 0, 0, // step 6
        6, 0, 0, 0, 1, 2, 3, 4, 5, 6, // data
    ];

    #[test]
    fn an_image_decodes_from_the_bytes_a_publisher_writes_and_encodes_back_to_them() {
        let image: Image = decode(&IMAGE_2X1).unwrap();
        assert_eq!(image.header.stamp, Time { sec: 3, nanosec: 500_000_000 });
        assert_eq!(image.header.stamp.nanos(), 3_500_000_000);
        assert_eq!((image.header.frame_id.as_str(), image.width, image.height), ("cam", 2, 1));
        assert_eq!((image.encoding.as_str(), image.step, image.data.as_slice()), ("rgb8", 6, &[1, 2, 3, 4, 5, 6][..]));
        assert_eq!(encode(&image).unwrap(), IMAGE_2X1);
    }

    #[test]
    fn schema_texts_hold_every_definition_used_once() {
        let text = schema_text(CAMERA_INFO).unwrap();
        assert!(text.starts_with("std_msgs/Header header\nuint32 height"), "{text}");
        for t in ["std_msgs/Header", "builtin_interfaces/Time", "sensor_msgs/RegionOfInterest"] {
            assert_eq!(text.matches(&format!("MSG: {t}\n")).count(), 1, "{t} in {text}");
        }
        let text = schema_text(DETECTION_2D_ARRAY).unwrap();
        assert_eq!(text.matches("MSG: ").count(), 12, "{text}");
        assert_eq!(schema_text("sensor_msgs/msg/Imu"), None);
    }

    #[test]
    fn every_message_round_trips_and_bad_payloads_are_named() {
        let info = CameraInfo {
            height: 375,
            width: 1242,
            distortion_model: "plumb_bob".into(),
            d: vec![0.0; 5],
            p: [721.5, 0.0, 609.6, -387.6, 0.0, 721.5, 172.9, 0.0, 0.0, 0.0, 1.0, 0.0],
            ..CameraInfo::default()
        };
        assert_eq!(decode::<CameraInfo>(&encode(&info).unwrap()).unwrap(), info);
        let det = Detection2DArray {
            header: Header { stamp: Time { sec: 1, nanosec: 2 }, frame_id: "left".into() },
            detections: vec![Detection2D {
                results: vec![ObjectHypothesisWithPose {
                    hypothesis: ObjectHypothesis { class_id: "car".into(), score: 0.9 },
                    ..ObjectHypothesisWithPose::default()
                }],
                bbox: BoundingBox2D {
                    center: Pose2D { position: Point2D { x: 10.0, y: 20.0 }, theta: 0.0 },
                    size_x: 4.0,
                    size_y: 2.0,
                },
                id: "7".into(),
                ..Detection2D::default()
            }],
        };
        assert_eq!(decode::<Detection2DArray>(&encode(&det).unwrap()).unwrap(), det);
        let c = CompressedImage { format: "png".into(), data: vec![9; 3], ..CompressedImage::default() };
        assert_eq!(decode::<CompressedImage>(&encode(&c).unwrap()).unwrap(), c);
        assert!(matches!(decode::<Image>(&[0, 1]), Err(CdrError::NoHeader(2))));
        assert!(matches!(decode::<Image>(&[0, 3, 0, 0, 1]), Err(CdrError::Encapsulation(0, 3))));
        let cut = &IMAGE_2X1[..IMAGE_2X1.len() - 3];
        assert!(matches!(decode::<Image>(cut), Err(CdrError::Body(_))));
        assert_eq!(Time::from_nanos(-1), Time { sec: -1, nanosec: 999_999_999 });
    }
}
