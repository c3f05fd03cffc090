//! Recordings written and read back with the mcap crate, checked against their schemas.

use super::*;
use base64::Engine as _;
use serde_json::{Value, json};

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
fn write_sample(path: &Path, encoding: RecordingEncoding) -> RecordingSummary {
    let mut rec = Recorder::create_with(path, encoding).unwrap();
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
    let summary = write_sample(&path, RecordingEncoding::Json);
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
        assert_eq!(schema.encoding, "jsonschema");
        assert_eq!(m.channel.message_encoding, "json");
        assert_eq!(m.log_time, m.publish_time);
        let schema: Value = serde_json::from_slice(&schema.data).unwrap();
        let msg: Value = serde_json::from_slice(&m.data).unwrap();
        conforms(&schema, &msg, &m.channel.topic).unwrap();
        // The stamp inside is the log time.
        let stamp = if schema["title"] == SCENE_UPDATE { &msg["deletions"][0]["timestamp"] } else { &msg["timestamp"] };
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
                assert_eq!(msg["fields"][3], json!({"name": "object_id", "offset": 12, "type": 5}));
            }
            "/camera/annotations" => {
                let groups = msg["points"].as_array().unwrap();
                assert_eq!(groups.len(), 2);
                assert_eq!(groups[1]["type"], 1, "POINTS");
                // Shifted half a pixel: Foxglove's origin is the top-left pixel's corner.
                assert_eq!(groups[1]["points"][1], json!({"x": 10.5, "y": 149.5}));
                assert_eq!(groups[1]["outline_color"]["r"], 1.0);
                assert_eq!(groups[1]["thickness"], 3.0);
                assert_eq!((msg["circles"].as_array().unwrap().len(), msg["texts"].as_array().unwrap().len()), (0, 0));
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

#[test]
fn a_recording_never_replaces_a_device_or_a_link() {
    let dir = tempfile::tempdir().unwrap();
    let target = dir.path().join("target.mcap");
    std::fs::write(&target, b"kept").unwrap();
    let link = dir.path().join("link.mcap");
    std::os::unix::fs::symlink(&target, &link).unwrap();
    for path in [link.as_path(), Path::new("/dev/null")] {
        let e = Recorder::create(path).unwrap_err().to_string();
        assert!(e.contains("an output replaces only a regular file"), "{e}");
    }
    assert_eq!(std::fs::read(&target).unwrap(), b"kept");
    assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
    assert!(!dir.path().join("link.mcap.partial").exists(), "nothing left behind");
}

/// The Protobuf recording holds what the JSON one does: every message decoded with the schema
/// types of the `foxglove` crate, written out in the JSON encoding, is the JSON recording's
/// message; each schema is the FileDescriptorSet of its type.
#[test]
fn a_protobuf_recording_holds_the_json_recordings_messages() {
    use foxglove::Decode;

    fn json_of<M: Decode + ToJson>(data: &[u8]) -> Value
    where
        M::Error: std::fmt::Debug,
    {
        M::decode(data).unwrap().to_json()
    }

    let dir = tempfile::tempdir().unwrap();
    let (pb, js) = (dir.path().join("pb.mcap"), dir.path().join("js.mcap"));
    assert_eq!(
        write_sample(&pb, RecordingEncoding::Protobuf).messages,
        write_sample(&js, RecordingEncoding::Json).messages
    );
    let (pb, js) = (std::fs::read(&pb).unwrap(), std::fs::read(&js).unwrap());
    let pairs = mcap::MessageStream::new(&pb).unwrap().zip(mcap::MessageStream::new(&js).unwrap());
    let mut n = 0;
    for (p, j) in pairs {
        let (p, j) = (p.unwrap(), j.unwrap());
        assert_eq!((&p.channel.topic, p.log_time), (&j.channel.topic, j.log_time));
        let schema = p.channel.schema.as_ref().unwrap();
        assert_eq!((schema.encoding.as_str(), p.channel.message_encoding.as_str()), ("protobuf", "protobuf"));
        let decoded = match schema.name.as_str() {
            SCENE_UPDATE => json_of::<SceneUpdate>(&p.data),
            FRAME_TRANSFORM => json_of::<FrameTransform>(&p.data),
            POSES_IN_FRAME => json_of::<PosesInFrame>(&p.data),
            POINT_CLOUD => json_of::<PointCloud>(&p.data),
            COMPRESSED_IMAGE => json_of::<CompressedImage>(&p.data),
            IMAGE_ANNOTATIONS => json_of::<ImageAnnotations>(&p.data),
            other => panic!("unexpected schema {other}"),
        };
        let expected: Value = serde_json::from_slice(&j.data).unwrap();
        assert_eq!(decoded, expected, "{} at {}", p.channel.topic, p.log_time);
        let descriptor = match schema.name.as_str() {
            SCENE_UPDATE => SceneUpdate::get_schema(),
            FRAME_TRANSFORM => FrameTransform::get_schema(),
            POSES_IN_FRAME => PosesInFrame::get_schema(),
            POINT_CLOUD => PointCloud::get_schema(),
            COMPRESSED_IMAGE => CompressedImage::get_schema(),
            _ => ImageAnnotations::get_schema(),
        };
        assert_eq!(schema.data.as_ref(), descriptor.unwrap().data.as_ref(), "{}", schema.name);
        n += 1;
    }
    assert_eq!(n, 24);
}
