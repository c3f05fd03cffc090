//! The import on bags of the committed fixture, whole and damaged.

use std::collections::BTreeMap;
use std::io::BufWriter;

use super::pixels::depth_units;
use super::*;
use crate::from_layout::{DETECTIONS, LEFT, RIGHT, layout_to_bag};
use crate::ros2::COMPRESSED_IMAGE;
use image::RgbImage;
use std::fs::File;

fn fixture() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("../sim/data/image_sim")
}

fn options() -> ImportOptions {
    ImportOptions { sync_tolerance_ns: 1_000_000, ..ImportOptions::default() }
}

/// The fixture as a bag in `dir`, each message passed through `edit` (topic, payload ->
/// payload, or `None` to leave it out).
fn bag(dir: &Path, mut edit: impl FnMut(&str, Vec<u8>) -> Option<Vec<u8>>) -> PathBuf {
    bag_with(dir, |topic, schema, p| edit(topic, p).map(|p| (topic.to_string(), schema.to_string(), p)))
}

/// As [`bag`], `edit` also choosing each message's topic and schema name.
fn bag_with(dir: &Path, mut edit: impl FnMut(&str, &str, Vec<u8>) -> Option<(String, String, Vec<u8>)>) -> PathBuf {
    let plain = dir.join("plain");
    layout_to_bag(&fixture(), "0000", &plain, 10.0, crate::from_layout::BagContents::Everything).unwrap();
    let files = bag_files(&plain).unwrap();
    let out = dir.join("edited.mcap");
    let mut w = mcap::Writer::new(BufWriter::new(File::create(&out).unwrap())).unwrap();
    let mut channels: BTreeMap<String, u16> = BTreeMap::new();
    for_each_message(&files, |t, _, m| {
        let Some((topic, schema_name, payload)) = edit(&t.name, &t.schema, m.data.to_vec()) else { return Ok(()) };
        let id = match channels.get(&topic) {
            Some(&id) => id,
            None => {
                let schema = w.add_schema(&schema_name, "ros2msg", b"")?;
                let id = w.add_channel(schema, &topic, &t.encoding, &BTreeMap::new())?;
                channels.insert(topic, id);
                id
            }
        };
        let header = mcap::records::MessageHeader {
            channel_id: id,
            sequence: m.sequence,
            log_time: m.log_time,
            publish_time: m.publish_time,
        };
        w.write_to_known_channel(&header, &payload)?;
        Ok(())
    })
    .unwrap();
    w.finish().unwrap();
    out
}

/// The image `name` of the imported layout `out` has the fixture's pixels; depth beyond
/// 16UC1's 65.535 m (the fixture's sky) comes back as that limit.
fn same_pixels(name: &str, out: &Path) {
    let (a, b) =
        (image::open(fixture().join(name)).unwrap().to_rgb16(), image::open(out.join(name)).unwrap().to_rgb16());
    assert_eq!(a.dimensions(), b.dimensions(), "{name}");
    let limit = if name.starts_with("depth_02") { depth_units(65.535) } else { u16::MAX };
    let differ = a.as_raw().iter().zip(b.as_raw()).filter(|(p, q)| (**p).min(limit) != **q).count();
    assert_eq!(differ, 0, "{name}: {differ} values differ");
}

fn error(bag: &Path, opt: &ImportOptions) -> String {
    let dir = bag.parent().unwrap().join("out");
    let e = format!("{:#}", import(bag, "0000", &dir, opt).unwrap_err());
    assert!(!dir.exists(), "a failed import leaves no folder: {e}");
    e
}

#[test]
fn the_fixture_round_trips_through_a_bag() {
    let tmp = tempfile::tempdir().unwrap();
    let b = bag(tmp.path(), |_, p| Some(p));
    let out = tmp.path().join("layout");
    let s = import(&b, "0000", &out, &options()).unwrap();
    assert_eq!(s.frames, 24);
    assert!((s.rate_hz - 10.0).abs() < 1e-6, "{}", s.rate_hz);
    assert!(s.unmatched.iter().all(|(_, n)| *n == 0), "{:?}", s.unmatched);
    for folder in ["image_02", "image_03", "instance_02", "depth_02"] {
        for k in [0, 23] {
            same_pixels(&format!("{folder}/0000/{k:06}.png"), &out);
        }
    }
    let calib = |dir: &Path| read_calib(dir.join("calib/0000.txt")).unwrap().p;
    assert_eq!(calib(&fixture()), calib(&out));
    let times = std::fs::read_to_string(out.join("times/0000.txt")).unwrap();
    assert_eq!(times.lines().nth(3), Some("0.300000000"));
    let rows = dynotraj_formats::kitti::read_labels(out.join("label_02/0000.txt")).unwrap();
    let truth = dynotraj_formats::kitti::read_labels(fixture().join("label_02/0000.txt")).unwrap();
    assert_eq!(rows.len(), truth.len());
    assert_eq!(s.boxes, rows.len());
    for (r, t) in rows.iter().zip(&truth) {
        assert!(r.is_box_only());
        assert_eq!((r.frame, r.track_id, r.object_type.as_str()), (t.frame, t.track_id, t.object_type.as_str()));
        assert_eq!(
            (r.bbox_left, r.bbox_top, r.bbox_right, r.bbox_bottom),
            (t.bbox_left, t.bbox_top, t.bbox_right, t.bbox_bottom)
        );
    }
    // A ROS 2 bag folder of the same file imports the same way.
    let folder = tmp.path().join("rosbag2");
    std::fs::create_dir(&folder).unwrap();
    std::fs::copy(&b, folder.join("rosbag2_0.mcap")).unwrap();
    assert_eq!(import(&folder, "0000", &tmp.path().join("again"), &options()).unwrap().frames, 24);
}

use dynotraj_formats::kitti::read_calib;

#[test]
fn an_rgbd_bag_with_compressed_images_imports_the_same_pixels_and_depth() {
    let tmp = tempfile::tempdir().unwrap();
    let left = format!("{LEFT}/image_raw");
    let b = bag_with(tmp.path(), |topic, schema, p| {
        if topic.starts_with(RIGHT) {
            return None;
        }
        if topic != left {
            return Some((topic.to_string(), schema.to_string(), p));
        }
        // The left camera as image_transport's compressed PNG, under image_transport's name:
        // its CameraInfo is found one level up, beside `image_raw`.
        let m: Image = ros2::decode(&p).unwrap();
        let rgb = RgbImage::from_raw(m.width, m.height, m.data).unwrap();
        let mut png = Vec::new();
        rgb.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
        let c = CompressedImage { header: m.header, format: "rgb8; png compressed rgb8".into(), data: png };
        Some((format!("{left}/compressed"), COMPRESSED_IMAGE.to_string(), ros2::encode(&c).unwrap()))
    });
    let out = tmp.path().join("layout");
    let s = import(&b, "0000", &out, &ImportOptions { rgbd: true, ..options() }).unwrap();
    assert_eq!(s.frames, 24);
    assert!(s.topics.iter().any(|(r, t)| r == "depth" && t == "/stereo/left/depth"), "{:?}", s.topics);
    assert!(s.topics.iter().any(|(_, t)| t == "/stereo/left/image_raw/compressed"), "{:?}", s.topics);
    assert!(!out.join("image_03").exists(), "an RGB-D import has no right images");
    for folder in ["image_02", "depth_02"] {
        same_pixels(&format!("{folder}/0000/000011.png"), &out);
    }
    // Without the right camera and without --rgbd the depth topic makes it RGB-D all the same;
    // without depth either, the import says what is missing.
    let dir = tmp.path().join("mono");
    std::fs::create_dir(&dir).unwrap();
    let mono = bag(&dir, |t, p| (!t.starts_with(RIGHT) && !t.ends_with("/depth")).then_some(p));
    let e = error(&mono, &options());
    assert!(e.contains("no right image topic and no depth topic"), "{e}");
}

#[test]
fn bad_bags_are_named_by_file_topic_message_and_field() {
    let tmp = tempfile::tempdir().unwrap();
    let good = bag(tmp.path(), |_, p| Some(p));
    // Truncated.
    let cut = tmp.path().join("cut.mcap");
    let bytes = std::fs::read(&good).unwrap();
    dynotraj_formats::atomic::write_file(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = error(&cut, &options());
    assert!(e.contains("cut.mcap: byte") && e.contains("truncated"), "{e}");
    // A topic that is not there, and one of the wrong type.
    let e = error(&good, &ImportOptions { left: Some("/nope".into()), ..options() });
    assert!(
        e.contains("--left /nope: no such topic") && e.contains("/stereo/right/image_raw (sensor_msgs/msg/Image"),
        "{e}"
    );
    let e = error(&good, &ImportOptions { left: Some(DETECTIONS.into()), ..options() });
    assert!(e.contains("a vision_msgs/msg/Detection2DArray topic, expected sensor_msgs/msg/Image"), "{e}");
    // No right camera info.
    let dir = tmp.path().join("noinfo");
    std::fs::create_dir(&dir).unwrap();
    let right_info = format!("{RIGHT}/camera_info");
    let b = bag(&dir, |t, p| (t != right_info).then_some(p));
    let e = error(&b, &options());
    assert!(e.contains("--right-info"), "{e}");
    // Unsynchronised stereo: the right camera 50 ms late.
    let dir = tmp.path().join("late");
    std::fs::create_dir(&dir).unwrap();
    let right = format!("{RIGHT}/image_raw");
    let b = bag(&dir, |t, p| {
        if t != right {
            return Some(p);
        }
        let mut m: Image = ros2::decode(&p).unwrap();
        m.header.stamp = ros2::Time::from_nanos(m.header.stamp.nanos() + 50_000_000);
        Some(ros2::encode(&m).unwrap())
    });
    let e = error(&b, &options());
    assert!(
        e.contains("24 of 24 images of /stereo/left/image_raw have no /stereo/right/image_raw image within 1 ms"),
        "{e}"
    );
    assert!(e.contains("not synchronised"), "{e}");
    // With the tolerance widened it imports.
    let ok = ImportOptions { sync_tolerance_ns: 60_000_000, ..options() };
    assert_eq!(import(&b, "0000", &dir.join("ok"), &ok).unwrap().frames, 24);
    // An encoding the import does not know, in message 5.
    let dir = tmp.path().join("yuv");
    std::fs::create_dir(&dir).unwrap();
    let left = format!("{LEFT}/image_raw");
    let mut n = 0;
    let b = bag(&dir, |t, p| {
        if t != left {
            return Some(p);
        }
        n += 1;
        if n != 6 {
            return Some(p);
        }
        let mut m: Image = ros2::decode(&p).unwrap();
        m.encoding = "yuv422".into();
        Some(ros2::encode(&m).unwrap())
    });
    let e = error(&b, &options());
    assert!(
        e.contains(
            "topic /stereo/left/image_raw (sensor_msgs/msg/Image), message 5: field `encoding`: `yuv422` is not one of"
        ),
        "{e}"
    );
    // Pixels that do not fill the image.
    let dir = tmp.path().join("short");
    std::fs::create_dir(&dir).unwrap();
    let b = bag(&dir, |t, p| {
        if t != left {
            return Some(p);
        }
        let mut m: Image = ros2::decode(&p).unwrap();
        m.data.truncate(100);
        Some(ros2::encode(&m).unwrap())
    });
    let e = error(&b, &options());
    assert!(e.contains("message 0: field `data`: 100 bytes, expected step 1491 x height 150"), "{e}");
}

/// The byte offset of the first chunk record of an MCAP file's bytes.
fn first_chunk(bytes: &[u8]) -> usize {
    let mut at = 8;
    while bytes[at] != 0x06 {
        at += 9 + u64::from_le_bytes(bytes[at + 1..at + 9].try_into().unwrap()) as usize;
    }
    at
}

#[test]
fn lengths_the_container_claims_are_checked_before_anything_is_read() {
    let tmp = tempfile::tempdir().unwrap();
    // A 66-byte bag whose record claims 4 GiB, and one whose schema claims 2^50 bytes: refused
    // at once (they took 4.25 GB, or aborted the process, before).
    for (name, opcode, claim) in [("claims-4g.mcap", 0x05u8, 4u64 << 30), ("schema.mcap", 0x03, 1 << 50)] {
        let mut bytes = b"\x89MCAP0\r\n".to_vec();
        bytes.push(opcode);
        bytes.extend(claim.to_le_bytes());
        bytes.resize(66, 7);
        let path = tmp.path().join(name);
        std::fs::write(&path, &bytes).unwrap();
        let e = error(&path, &options());
        assert!(
            e.contains(name) && e.contains(&format!("claims {claim} bytes")) && e.contains("truncated or damaged"),
            "{e}"
        );
    }
    // A whole bag whose chunk says it decompresses to 2 GiB.
    let good = bag(tmp.path(), |_, p| Some(p));
    let mut bytes = std::fs::read(&good).unwrap();
    let at = first_chunk(&bytes);
    bytes[at + 9 + 16..at + 9 + 24].copy_from_slice(&(2u64 << 30).to_le_bytes());
    let bomb = tmp.path().join("bomb.mcap");
    std::fs::write(&bomb, &bytes).unwrap();
    let e = error(&bomb, &options());
    assert!(e.contains("bomb.mcap") && e.contains("a chunk that decompresses to 2147483648 bytes"), "{e}");
}

#[test]
fn an_image_whose_header_claims_a_huge_size_is_refused_before_it_is_decoded() {
    // A 1 x 1 PNG whose header is made to say 20000 x 20000 (with its CRC mended).
    let mut png = Vec::new();
    RgbImage::new(1, 1).write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
    png[16..20].copy_from_slice(&20_000u32.to_be_bytes());
    png[20..24].copy_from_slice(&20_000u32.to_be_bytes());
    let crc = dynotraj_core::crc::crc32(&png[12..29]);
    png[29..33].copy_from_slice(&crc.to_be_bytes());
    let m = CompressedImage { header: ros2::Header::default(), format: "png".into(), data: png };
    let started = std::time::Instant::now();
    let Err(e) = super::pixels::compressed_pixels(&m, Role::Left) else { panic!("a 20000 x 20000 image was decoded") };
    assert!(e.starts_with("field `data`: not a png image") && e.contains("limit"), "{e}");
    assert!(started.elapsed() < std::time::Duration::from_secs(2), "refused from its header");
}

#[test]
fn an_import_that_its_readers_would_refuse_fails() {
    let tmp = tempfile::tempdir().unwrap();
    // A camera info whose focal length no single-precision camera holds.
    let dir = tmp.path().join("fx");
    std::fs::create_dir(&dir).unwrap();
    let b = bag(&dir, |t, p| {
        if !t.ends_with("camera_info") {
            return Some(p);
        }
        let mut m: CameraInfo = ros2::decode(&p).unwrap();
        m.p[0] = 1e39;
        Some(ros2::encode(&m).unwrap())
    });
    let e = error(&b, &options());
    assert!(
        e.contains("field `p` makes a calibration the layout's reader refuses")
            && e.contains("found focal lengths 1000000000000000000000000000000000000000"),
        "{e}"
    );
    // Detections that label one object twice in a frame.
    let dir = tmp.path().join("twice");
    std::fs::create_dir(&dir).unwrap();
    let b = bag(&dir, |t, p| {
        if t != DETECTIONS {
            return Some(p);
        }
        let mut m: Detection2DArray = ros2::decode(&p).unwrap();
        if let Some(first) = m.detections.first().cloned() {
            m.detections.push(first);
        }
        Some(ros2::encode(&m).unwrap())
    });
    let e = error(&b, &options());
    assert!(e.contains("detections of") && e.contains("labels the layout's reader refuses"), "{e}");
}

#[test]
fn an_import_leaves_no_staging_copy_and_clears_those_of_interrupted_ones() {
    let tmp = tempfile::tempdir().unwrap();
    let good = bag(tmp.path(), |_, p| Some(p));
    // What an interrupted import (a process long gone) left beside the output.
    let abandoned = tmp.path().join(".out.partial-4194304999");
    std::fs::create_dir_all(abandoned.join("image_02")).unwrap();
    import(&good, "0000", &tmp.path().join("out"), &options()).unwrap();
    let left: Vec<String> = std::fs::read_dir(tmp.path())
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .filter(|n| n.contains(".partial"))
        .collect();
    assert!(left.is_empty(), "staging copies left: {left:?}");
    // A second import of the same output: refused, and nothing of it stays.
    let e = format!("{:#}", import(&good, "0000", &tmp.path().join("out"), &options()).unwrap_err());
    assert!(e.contains("already exists"), "{e}");
    assert!(
        std::fs::read_dir(tmp.path()).unwrap().all(|e| !e.unwrap().file_name().to_string_lossy().contains(".partial"))
    );
}

/// Every file of the folder `dir`, by path within it, with its bytes.
fn folder_bytes(dir: &Path) -> BTreeMap<PathBuf, Vec<u8>> {
    let mut out = BTreeMap::new();
    let mut stack = vec![dir.to_path_buf()];
    while let Some(d) = stack.pop() {
        for e in std::fs::read_dir(&d).unwrap() {
            let p = e.unwrap().path();
            if p.is_dir() {
                stack.push(p);
            } else {
                out.insert(p.strip_prefix(dir).unwrap().to_path_buf(), std::fs::read(&p).unwrap());
            }
        }
    }
    out
}

#[test]
fn bags_compressed_as_rosbag2_compresses_them_import_as_the_plain_one() {
    let tmp = tempfile::tempdir().unwrap();
    let plain = bag(tmp.path(), |_, p| Some(p));
    let imported = |b: &Path, name: &str| {
        let out = tmp.path().join(name);
        import(b, "0000", &out, &options()).unwrap();
        folder_bytes(&out)
    };
    let expected = imported(&plain, "plain-layout");
    // compression_mode: file, the file compressed whole.
    let whole = tmp.path().join("whole/whole_0.mcap.zstd");
    std::fs::create_dir(whole.parent().unwrap()).unwrap();
    std::fs::write(&whole, zstd::encode_all(std::fs::read(&plain).unwrap().as_slice(), 3).unwrap()).unwrap();
    assert!(expected == imported(&whole, "whole-layout"), "a .mcap.zstd file imports as its MCAP");
    assert!(expected == imported(whole.parent().unwrap(), "folder-layout"), "so does a folder of them");
    // compression_mode: message, each payload compressed alone.
    let dir = tmp.path().join("per-message");
    std::fs::create_dir(&dir).unwrap();
    let each = bag(&dir, |_, p| Some(zstd::encode_all(p.as_slice(), 3).unwrap()));
    assert!(expected == imported(&each, "message-layout"), "compressed messages import as plain ones");
    // A cut compressed file is named as such; a payload that is not zstd past its magic too.
    let cut = tmp.path().join("cut.mcap.zstd");
    let bytes = std::fs::read(&whole).unwrap();
    std::fs::write(&cut, &bytes[..bytes.len() / 2]).unwrap();
    let e = error(&cut, &options());
    assert!(e.contains("cut.mcap.zstd"), "{e}");
    let dir = tmp.path().join("bad-frames");
    std::fs::create_dir(&dir).unwrap();
    let bad = bag(&dir, |_, p| Some([&[0x28, 0xb5, 0x2f, 0xfd][..], &p].concat()));
    let e = error(&bad, &options());
    assert!(e.contains("message 0: a zstd-compressed message that does not decompress"), "{e}");
    // An sqlite3 bag is named, with the conversion to use.
    let db3 = tmp.path().join("old.db3");
    std::fs::write(&db3, b"SQLite format 3\0and more").unwrap();
    let e = error(&db3, &options());
    assert!(e.contains("old.db3: a rosbag2 bag in sqlite3 storage, not MCAP: convert it first"), "{e}");
}
