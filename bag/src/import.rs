//! A ROS 2 camera bag in MCAP to a sequence in the KITTI tracking layout, which `dynotraj
//! track` reads:
//!
//! ```text
//! <out>/image_02/<seq>/NNNNNN.png     left images (the left topic; the RGB image of RGB-D)
//! <out>/image_03/<seq>/NNNNNN.png     right images (stereo)
//! <out>/depth_02/<seq>/NNNNNN.png     depth, uint16, value / 256 = metres (RGB-D)
//! <out>/instance_02/<seq>/NNNNNN.png  instance ids, uint16, 0 = background (mask topic)
//! <out>/label_02/<seq>.txt            the detector's 2D boxes as KITTI label rows
//! <out>/calib/<seq>.txt               P0 = P2 = left, P1 = P3 = right, from CameraInfo
//! <out>/times/<seq>.txt               each frame's capture time, seconds from the first
//! ```
//!
//! A frame is a left image; its right image, depth map, mask and detections are the ones whose
//! header stamps are nearest to it within a tolerance. Images are written as they are read
//! (memory does not grow with the bag), under a temporary folder renamed to `<out>` at the end:
//! an interrupted import leaves no folder that looks complete.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufReader;
use std::path::{Path, PathBuf};

use anyhow::{Context as _, bail, ensure};
use dynotraj_formats::kitti::{LabelRow, write_labels};
use image::{DynamicImage, GrayImage, ImageBuffer, Luma, RgbImage};

use crate::ros2::{
    self, CAMERA_INFO, COMPRESSED_IMAGE, CameraInfo, CompressedImage, DETECTION_2D_ARRAY, Detection2DArray, IMAGE,
    Image,
};

/// What each image topic holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
enum Role {
    Left,
    Right,
    Depth,
    Mask,
}

impl Role {
    const fn folder(self) -> &'static str {
        match self {
            Self::Left => "image_02",
            Self::Right => "image_03",
            Self::Depth => "depth_02",
            Self::Mask => "instance_02",
        }
    }
}

/// Topics and settings of an import; a topic left `None` is found by its schema and name.
#[derive(Debug, Clone, Default)]
pub struct ImportOptions {
    /// Left (or RGB) image topic.
    pub left: Option<String>,
    /// Right image topic (stereo).
    pub right: Option<String>,
    /// Depth image topic (RGB-D).
    pub depth: Option<String>,
    /// Instance-mask image topic.
    pub masks: Option<String>,
    /// `vision_msgs/Detection2DArray` topic.
    pub detections: Option<String>,
    /// Left camera's `CameraInfo` topic.
    pub left_info: Option<String>,
    /// Right camera's `CameraInfo` topic.
    pub right_info: Option<String>,
    /// Largest stamp difference of two messages of one frame, nanoseconds.
    pub sync_tolerance_ns: i64,
    /// Stereo baseline, metres, where the right camera's projection does not carry it.
    pub baseline_m: Option<f64>,
    /// Only the first N frames.
    pub max_frames: Option<usize>,
    /// RGB-D only: no right topic even where one could be found.
    pub rgbd: bool,
}

/// What an import wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct ImportSummary {
    /// Frames written.
    pub frames: usize,
    /// The topics used, by role (`left`, `right`, ...).
    pub topics: Vec<(String, String)>,
    /// Frame rate measured from the left stamps (median period), Hz.
    pub rate_hz: f64,
    /// Images of each topic that matched no frame (dropped), by topic.
    pub unmatched: Vec<(String, usize)>,
    /// Detection boxes written.
    pub boxes: usize,
}

/// One topic of the bag.
#[derive(Debug, Clone)]
struct Topic {
    name: String,
    schema: String,
    encoding: String,
}

/// The `.mcap` files of a bag: the file itself, or a ROS 2 bag folder's files by name.
///
/// # Errors
/// A path that is neither, or a folder without `.mcap` files.
pub fn bag_files(path: &Path) -> anyhow::Result<Vec<PathBuf>> {
    if path.is_file() {
        return Ok(vec![path.to_path_buf()]);
    }
    ensure!(path.is_dir(), "{}: no such file or folder (expected an .mcap file or a ROS 2 bag folder)", path.display());
    let mut files: Vec<PathBuf> = std::fs::read_dir(path)
        .with_context(|| format!("reading {}", path.display()))?
        .filter_map(Result::ok)
        .map(|e| e.path())
        .filter(|p| p.extension().is_some_and(|e| e == "mcap"))
        .collect();
    files.sort();
    ensure!(
        !files.is_empty(),
        "{}: a folder without .mcap files (expected a ROS 2 bag in MCAP storage)",
        path.display()
    );
    Ok(files)
}

/// Calls `each` with every message of `files` in file order, with its index on its topic.
fn for_each_message(
    files: &[PathBuf],
    mut each: impl FnMut(&Topic, usize, &mcap::Message<'_>) -> anyhow::Result<()>,
) -> anyhow::Result<()> {
    let mut counts: BTreeMap<String, usize> = BTreeMap::new();
    for file in files {
        let f = File::open(file).with_context(|| format!("opening {}", file.display()))?;
        for (read, m) in mcap::io::MessageReader::new(BufReader::new(f)).enumerate() {
            let m = m.map_err(|e| {
                anyhow::anyhow!(
                    "{}: not a readable MCAP file after {read} messages: {e} (truncated or damaged?)",
                    file.display()
                )
            })?;
            let topic = Topic {
                name: m.channel.topic.clone(),
                schema: m.channel.schema.as_ref().map(|s| s.name.clone()).unwrap_or_default(),
                encoding: m.channel.message_encoding.clone(),
            };
            let index = counts.entry(topic.name.clone()).or_default();
            each(&topic, *index, &m)?;
            *index += 1;
        }
    }
    Ok(())
}

/// Every topic of the bag with its schema and message count.
fn topics(files: &[PathBuf]) -> anyhow::Result<Vec<(Topic, usize)>> {
    let mut out: BTreeMap<String, (Topic, usize)> = BTreeMap::new();
    for_each_message(files, |t, _, _| {
        out.entry(t.name.clone()).or_insert_with(|| (t.clone(), 0)).1 += 1;
        Ok(())
    })?;
    Ok(out.into_values().collect())
}

fn listing(topics: &[(Topic, usize)]) -> String {
    topics.iter().map(|(t, n)| format!("{} ({}, {n} messages)", t.name, t.schema)).collect::<Vec<_>>().join(", ")
}

/// The topic for `flag`: the given one (checked to exist with one of `schemas`), else the one
/// candidate of `schemas` whose name `matches`; `None` when there is none and it is optional.
fn choose(
    all: &[(Topic, usize)],
    given: Option<&str>,
    schemas: &[&str],
    matches: impl Fn(&str) -> bool,
    flag: &str,
    required: bool,
) -> anyhow::Result<Option<String>> {
    if let Some(name) = given {
        let Some((t, _)) = all.iter().find(|(t, _)| t.name == name) else {
            bail!("{flag} {name}: no such topic in the bag; it has {}", listing(all));
        };
        ensure!(
            schemas.contains(&t.schema.as_str()),
            "{flag} {name}: a {} topic, expected {}",
            t.schema,
            schemas.join(" or ")
        );
        return Ok(Some(name.to_string()));
    }
    let found: Vec<&str> = all
        .iter()
        .filter(|(t, _)| schemas.contains(&t.schema.as_str()) && matches(&t.name.to_lowercase()))
        .map(|(t, _)| t.name.as_str())
        .collect();
    match found.as_slice() {
        [one] => Ok(Some((*one).to_string())),
        [] if !required => Ok(None),
        [] => bail!(
            "no {} topic for {flag} found; the bag has {}: choose one with {flag}",
            schemas.join(" or "),
            listing(all)
        ),
        many => bail!("{flag}: {} topics could be it ({}): choose one with {flag}", many.len(), many.join(", ")),
    }
}

/// The namespace of a topic (`/cam/left/image_raw` -> `/cam/left`).
fn namespace(topic: &str) -> &str {
    topic.rsplit_once('/').map_or("", |(ns, _)| ns)
}

/// The topics of every role, chosen as the module docs say.
#[derive(Debug, Clone)]
struct Chosen {
    images: Vec<(Role, String)>,
    left_info: String,
    right_info: Option<String>,
    detections: Option<String>,
}

fn choose_topics(all: &[(Topic, usize)], opt: &ImportOptions) -> anyhow::Result<Chosen> {
    let images = [IMAGE, COMPRESSED_IMAGE];
    let is_depth = |n: &str| n.contains("depth");
    let is_mask = |n: &str| n.contains("mask") || n.contains("instance") || n.contains("segment");
    let depth = choose(all, opt.depth.as_deref(), &images, is_depth, "--depth", false)?;
    let masks = choose(all, opt.masks.as_deref(), &images, is_mask, "--masks-topic", false)?;
    let plain = |n: &str| !is_depth(n) && !is_mask(n);
    let right = if opt.rgbd {
        None
    } else {
        choose(all, opt.right.as_deref(), &images, |n| plain(n) && n.contains("right"), "--right", false)?
    };
    let left = match (&opt.left, &right) {
        (Some(_), _) | (None, Some(_)) => {
            choose(all, opt.left.as_deref(), &images, |n| plain(n) && n.contains("left"), "--left", true)?
        }
        // RGB-D: the one colour topic.
        (None, None) => choose(all, None, &images, |n| plain(n) && !n.contains("right"), "--left", true)?,
    }
    .unwrap_or_default();
    ensure!(
        right.is_some() || depth.is_some(),
        "no right image topic and no depth topic: a stereo pair (--left, --right) or RGB-D (--left, --depth) is needed; the bag has {}",
        listing(all)
    );
    let info_of = |image: &str, given: Option<&str>, flag: &str, required: bool| {
        let ns = namespace(image).to_lowercase();
        choose(all, given, &[CAMERA_INFO], |n| namespace(n) == ns, flag, required)
    };
    let left_info = info_of(&left, opt.left_info.as_deref(), "--left-info", true)?.unwrap_or_default();
    let right_info = match &right {
        Some(r) => info_of(r, opt.right_info.as_deref(), "--right-info", true)?,
        None => None,
    };
    let detections = choose(all, opt.detections.as_deref(), &[DETECTION_2D_ARRAY], |_| true, "--detections", false)?;
    let mut chosen = vec![(Role::Left, left)];
    chosen.extend(right.map(|t| (Role::Right, t)));
    chosen.extend(depth.map(|t| (Role::Depth, t)));
    chosen.extend(masks.map(|t| (Role::Mask, t)));
    Ok(Chosen { images: chosen, left_info, right_info, detections })
}

/// Pixels in the form the layout stores them.
enum Pixels {
    Rgb(RgbImage),
    Grey(GrayImage),
    Wide(ImageBuffer<Luma<u16>, Vec<u16>>),
}

impl Pixels {
    fn size(&self) -> (u32, u32) {
        match self {
            Self::Rgb(i) => i.dimensions(),
            Self::Grey(i) => i.dimensions(),
            Self::Wide(i) => i.dimensions(),
        }
    }

    fn save(&self, path: &Path) -> anyhow::Result<()> {
        let r = match self {
            Self::Rgb(i) => i.save_with_format(path, image::ImageFormat::Png),
            Self::Grey(i) => i.save_with_format(path, image::ImageFormat::Png),
            Self::Wide(i) => i.save_with_format(path, image::ImageFormat::Png),
        };
        r.with_context(|| format!("writing {}", path.display()))
    }
}

/// Depth in the layout's units (1/256 m) from millimetres or metres; 0 where unknown.
fn depth_units(metres: f64) -> u16 {
    if metres.is_finite() && metres > 0.0 { (metres * 256.0).round().min(65535.0) as u16 } else { 0 }
}

/// A raw image's pixels for `role`; errors name the field.
fn raw_pixels(m: &Image, role: Role) -> Result<Pixels, String> {
    let (w, h) = (m.width as usize, m.height as usize);
    let bytes_per_pixel = match m.encoding.as_str() {
        "rgb8" | "bgr8" => 3,
        "rgba8" | "bgra8" => 4,
        "mono8" | "8UC1" => 1,
        "mono16" | "16UC1" => 2,
        "32FC1" => 4,
        e => {
            return Err(format!(
                "field `encoding`: `{e}` is not one of rgb8, bgr8, rgba8, bgra8, mono8, 8UC1, mono16, 16UC1, 32FC1"
            ));
        }
    };
    let step = m.step as usize;
    ensure_field(step >= w * bytes_per_pixel, || {
        format!("field `step`: {step} bytes for {w} pixels of {bytes_per_pixel} bytes")
    })?;
    ensure_field(m.data.len() >= step * h, || {
        format!("field `data`: {} bytes, expected step {step} x height {h} = {}", m.data.len(), step * h)
    })?;
    let row = |y: usize| m.data.get(y * step..y * step + w * bytes_per_pixel).unwrap_or_default();
    let u16_at = |px: &[u8]| {
        let b = [px.first().copied().unwrap_or(0), px.get(1).copied().unwrap_or(0)];
        if m.is_bigendian == 0 { u16::from_le_bytes(b) } else { u16::from_be_bytes(b) }
    };
    let (w32, h32) = (m.width, m.height);
    let wide = |f: &dyn Fn(&[u8]) -> u16| {
        let v: Vec<u16> =
            (0..h).flat_map(|y| row(y).chunks_exact(bytes_per_pixel).map(f).collect::<Vec<_>>()).collect();
        ImageBuffer::from_raw(w32, h32, v).map(Pixels::Wide).ok_or_else(|| "field `data`: too few pixels".to_string())
    };
    match (role, m.encoding.as_str()) {
        (Role::Depth, "16UC1" | "mono16") => wide(&|px| depth_units(f64::from(u16_at(px)) / 1000.0)),
        (Role::Depth, "32FC1") => wide(&|px| {
            let b: [u8; 4] = px.try_into().unwrap_or_default();
            let v = if m.is_bigendian == 0 { f32::from_le_bytes(b) } else { f32::from_be_bytes(b) };
            depth_units(f64::from(v))
        }),
        (Role::Depth, e) => {
            Err(format!("field `encoding`: a depth image must be 16UC1 (mm) or 32FC1 (m), found `{e}`"))
        }
        (Role::Mask, "16UC1" | "mono16") => wide(&|px| u16_at(px)),
        (Role::Mask, "mono8" | "8UC1") => wide(&|px| u16::from(px.first().copied().unwrap_or(0))),
        (Role::Mask, e) => {
            Err(format!("field `encoding`: an instance mask must be mono8, 8UC1, mono16 or 16UC1, found `{e}`"))
        }
        (_, "mono8" | "8UC1") => {
            let v: Vec<u8> = (0..h).flat_map(|y| row(y).to_vec()).collect();
            GrayImage::from_raw(w32, h32, v).map(Pixels::Grey).ok_or_else(|| "field `data`: too few pixels".into())
        }
        (_, e @ ("rgb8" | "bgr8" | "rgba8" | "bgra8")) => {
            let bgr = e.starts_with('b');
            let v: Vec<u8> = (0..h)
                .flat_map(|y| {
                    row(y)
                        .chunks_exact(bytes_per_pixel)
                        .flat_map(|p| {
                            let (r, g, b) = (p.first(), p.get(1), p.get(2));
                            let (r, b) = if bgr { (b, r) } else { (r, b) };
                            [r, g, b].map(|c| c.copied().unwrap_or(0))
                        })
                        .collect::<Vec<_>>()
                })
                .collect();
            RgbImage::from_raw(w32, h32, v).map(Pixels::Rgb).ok_or_else(|| "field `data`: too few pixels".into())
        }
        (_, e) => {
            Err(format!("field `encoding`: a camera image must be rgb8, bgr8, rgba8, bgra8 or mono8, found `{e}`"))
        }
    }
}

fn ensure_field(ok: bool, message: impl FnOnce() -> String) -> Result<(), String> {
    if ok { Ok(()) } else { Err(message()) }
}

/// A compressed image's pixels for `role`; errors name the field.
fn compressed_pixels(m: &CompressedImage, role: Role) -> Result<Pixels, String> {
    let format = m.format.to_lowercase();
    if format.contains("compresseddepth") {
        return Err(format!(
            "field `format`: `{}` (compressed_depth_image_transport) is not supported: record depth as sensor_msgs/Image 16UC1 or 32FC1",
            m.format
        ));
    }
    ensure_field(format.contains("png") || format.contains("jpeg") || format.contains("jpg"), || {
        format!("field `format`: `{}`: expected png or jpeg", m.format)
    })?;
    let decoded =
        image::load_from_memory(&m.data).map_err(|e| format!("field `data`: not a {} image: {e}", m.format))?;
    Ok(match role {
        Role::Left | Role::Right => Pixels::Rgb(decoded.to_rgb8()),
        Role::Mask => Pixels::Wide(decoded.to_luma16()),
        Role::Depth => match decoded {
            DynamicImage::ImageLuma16(d) => {
                let (w, h) = d.dimensions();
                let v = d.pixels().map(|p| depth_units(f64::from(p.0[0]) / 1000.0)).collect();
                Pixels::Wide(ImageBuffer::from_raw(w, h, v).ok_or_else(|| "field `data`: too few pixels".to_string())?)
            }
            _ => return Err("field `data`: a compressed depth image must be a 16-bit PNG in millimetres".into()),
        },
    })
}

/// An image written to the staging folder, waiting for its frame.
#[derive(Debug, Clone)]
struct Staged {
    stamp: i64,
    index: usize,
    path: PathBuf,
    size: (u32, u32),
}

/// The stamp of a message: its header's, else (a zero stamp) its log time.
fn stamp_of(header: &ros2::Header, log_time: u64) -> i64 {
    let s = header.stamp.nanos();
    if s == 0 { i64::try_from(log_time).unwrap_or(i64::MAX) } else { s }
}

/// Index into `sorted` (by stamp) of the unused entry nearest to `stamp` within `tolerance`.
fn nearest(sorted: &[Staged], used: &[bool], stamp: i64, tolerance: i64) -> Option<usize> {
    let at = sorted.partition_point(|s| s.stamp < stamp);
    [at.checked_sub(1), Some(at)]
        .into_iter()
        .flatten()
        .filter(|&i| {
            sorted.get(i).is_some_and(|s| (s.stamp - stamp).abs() <= tolerance) && !used.get(i).copied().unwrap_or(true)
        })
        .min_by_key(|&i| sorted.get(i).map_or(i64::MAX, |s| (s.stamp - stamp).abs()))
}

/// The calibration text of a stereo pair or an RGB-D camera.
fn calib_text(
    left: &CameraInfo,
    right: Option<&CameraInfo>,
    baseline_m: Option<f64>,
    right_topic: &str,
) -> anyhow::Result<String> {
    let fmt = |p: &[f64; 12]| p.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(" ");
    ensure!(
        left.p[0] > 0.0 && left.p[5] > 0.0,
        "camera info of the left camera: field `p`: fx = {} and fy = {} must be positive (a calibrated camera)",
        left.p[0],
        left.p[5]
    );
    let mut right_p = right.map_or(left.p, |r| r.p);
    if right.is_some() {
        let fb = left.p[3] - right_p[3];
        match baseline_m {
            Some(b) => right_p[3] = left.p[3] - left.p[0] * b,
            None => ensure!(
                fb > 0.0,
                "camera info of {right_topic}: field `p`: p[3] = {} gives no stereo baseline (expected -fx * baseline < 0); pass --baseline METRES",
                right_p[3]
            ),
        }
    }
    let (l, r) = (fmt(&left.p), fmt(&right_p));
    Ok(format!(
        "P0: {l}\nP1: {r}\nP2: {l}\nP3: {r}\nR0_rect: 1 0 0 0 1 0 0 0 1\nTr_velo_to_cam: 0 -1 0 0 0 0 -1 0 1 0 0 0\nTr_imu_to_velo: 1 0 0 0 0 1 0 0 0 0 1 0\n"
    ))
}

/// The KITTI type of a detector's class name.
fn kitti_type(class_id: &str) -> &'static str {
    match class_id.to_lowercase().as_str() {
        "car" | "vehicle" | "2" => "Car",
        "van" => "Van",
        "truck" | "bus" | "7" | "5" => "Truck",
        "tram" | "train" | "6" => "Tram",
        "bicycle" | "cyclist" | "bike" | "motorcycle" | "1" | "3" => "Cyclist",
        "person" | "pedestrian" | "0" => "Pedestrian",
        _ => "Misc",
    }
}

/// Imports the bag at `bag` as sequence `seq` into the new folder `out`.
///
/// # Errors
/// A bag that is not readable, a topic missing or ambiguous, a message that does not decode or
/// holds what its role cannot use (named by topic, message index and field), unsynchronised
/// stereo, or an output that cannot be written.
pub fn import(bag: &Path, seq: &str, out: &Path, opt: &ImportOptions) -> anyhow::Result<ImportSummary> {
    ensure!(!out.exists(), "--out {}: already exists (an import writes a new folder)", out.display());
    let files = bag_files(bag)?;
    let all = topics(&files)?;
    let chosen = choose_topics(&all, opt)?;
    let staging = out.with_file_name(format!(
        ".{}.partial-{}",
        out.file_name().and_then(|n| n.to_str()).unwrap_or("import"),
        std::process::id()
    ));
    if staging.exists() {
        std::fs::remove_dir_all(&staging).with_context(|| format!("removing {}", staging.display()))?;
    }
    let result = import_into(&files, seq, &staging, &chosen, opt);
    match result {
        Ok(summary) => {
            std::fs::rename(&staging, out)
                .with_context(|| format!("renaming {} to {}", staging.display(), out.display()))?;
            Ok(summary)
        }
        Err(e) => {
            // Best effort: the error says what failed; a staging folder left behind is hidden.
            let _ = std::fs::remove_dir_all(&staging);
            Err(e)
        }
    }
}

fn import_into(
    files: &[PathBuf],
    seq: &str,
    dir: &Path,
    chosen: &Chosen,
    opt: &ImportOptions,
) -> anyhow::Result<ImportSummary> {
    let stage = dir.join("staging");
    for (role, _) in &chosen.images {
        std::fs::create_dir_all(stage.join(role.folder())).with_context(|| format!("creating {}", stage.display()))?;
    }
    let mut staged: BTreeMap<Role, Vec<Staged>> = BTreeMap::new();
    let mut infos: BTreeMap<String, CameraInfo> = BTreeMap::new();
    let mut detections: Vec<(i64, Detection2DArray)> = Vec::new();
    let role_of: BTreeMap<&str, Role> = chosen.images.iter().map(|(r, t)| (t.as_str(), *r)).collect();
    for_each_message(files, |topic, index, m| {
        let name = topic.name.as_str();
        let wanted = role_of.contains_key(name)
            || name == chosen.left_info
            || chosen.right_info.as_deref() == Some(name)
            || chosen.detections.as_deref() == Some(name);
        if !wanted {
            return Ok(());
        }
        let at = || format!("topic {name} ({}), message {index}", topic.schema);
        ensure!(
            topic.encoding == ros2::CDR,
            "{}: message encoding `{}`, expected cdr (a ROS 2 bag)",
            at(),
            topic.encoding
        );
        if let Some(&role) = role_of.get(name) {
            let (header, pixels) = if topic.schema == IMAGE {
                let img: Image = ros2::decode(&m.data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
                (img.header.clone(), raw_pixels(&img, role))
            } else {
                let img: CompressedImage = ros2::decode(&m.data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
                (img.header.clone(), compressed_pixels(&img, role))
            };
            let pixels = pixels.map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
            let path = stage.join(role.folder()).join(format!("{index:08}.png"));
            pixels.save(&path)?;
            staged.entry(role).or_default().push(Staged {
                stamp: stamp_of(&header, m.log_time),
                index,
                path,
                size: pixels.size(),
            });
        } else if topic.schema == CAMERA_INFO {
            if !infos.contains_key(name) {
                let info: CameraInfo = ros2::decode(&m.data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
                infos.insert(name.to_string(), info);
            }
        } else {
            let d: Detection2DArray = ros2::decode(&m.data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
            detections.push((stamp_of(&d.header, m.log_time), d));
        }
        Ok(())
    })?;
    for list in staged.values_mut() {
        list.sort_by_key(|s| s.stamp);
    }
    let left_topic = chosen.images.first().map(|(_, t)| t.clone()).unwrap_or_default();
    let lefts = staged.remove(&Role::Left).unwrap_or_default();
    ensure!(!lefts.is_empty(), "topic {left_topic}: no images");
    let left_info =
        infos.get(&chosen.left_info).with_context(|| format!("topic {}: no CameraInfo message", chosen.left_info))?;
    let right_info = match &chosen.right_info {
        Some(t) => Some(infos.get(t).with_context(|| format!("topic {t}: no CameraInfo message"))?),
        None => None,
    };
    // Each frame: a left image and, for every other role, the unused image nearest in time.
    let tolerance = opt.sync_tolerance_ns;
    let others: Vec<(Role, String)> = chosen.images.iter().skip(1).cloned().collect();
    let mut used: BTreeMap<Role, Vec<bool>> =
        others.iter().map(|(r, _)| (*r, vec![false; staged.get(r).map_or(0, Vec::len)])).collect();
    let mut frames: Vec<(Staged, Vec<(Role, Staged)>)> = Vec::new();
    let mut unmatched_left = 0usize;
    let mut first_unmatched: Option<(Role, usize)> = None;
    for l in &lefts {
        if opt.max_frames.is_some_and(|m| frames.len() >= m) {
            break;
        }
        let mut parts = Vec::new();
        for (role, _) in &others {
            let list = staged.get(role).map_or(&[][..], Vec::as_slice);
            let u = used.get(role).map_or(&[][..], Vec::as_slice);
            if let Some(i) = nearest(list, u, l.stamp, tolerance) {
                parts.push((*role, i));
            }
        }
        if parts.len() < others.len() {
            unmatched_left += 1;
            first_unmatched.get_or_insert((
                others.iter().map(|(r, _)| *r).find(|r| !parts.iter().any(|(p, _)| p == r)).unwrap_or(Role::Right),
                l.index,
            ));
            continue;
        }
        let mut owned = Vec::new();
        for (role, i) in parts {
            if let Some(flag) = used.get_mut(&role).and_then(|u| u.get_mut(i)) {
                *flag = true;
            }
            if let Some(s) = staged.get(&role).and_then(|list| list.get(i)) {
                owned.push((role, s.clone()));
            }
        }
        frames.push((l.clone(), owned));
    }
    if let Some((role, index)) = first_unmatched {
        let topic = others.iter().find(|(r, _)| *r == role).map_or("", |(_, t)| t.as_str());
        let share = unmatched_left as f64 / lefts.len() as f64;
        let what = format!(
            "{unmatched_left} of {} images of {left_topic} have no {topic} image within {} ms (the first: message {index})",
            lefts.len(),
            tolerance as f64 / 1e6
        );
        ensure!(
            share <= 0.5,
            "{what}: the topics are not synchronised; compare their header stamps, or widen --sync-tolerance-ms"
        );
        log::warn!("{what}: those frames are dropped");
    }
    ensure!(!frames.is_empty(), "no frame has all its images");
    // The layout.
    let (w, h) = lefts.first().map_or((0, 0), |l| l.size);
    ensure!(
        left_info.width == 0 || (left_info.width, left_info.height) == (w, h),
        "topic {}: field `width`/`height`: {} x {} but the images of {left_topic} are {w} x {h}",
        chosen.left_info,
        left_info.width,
        left_info.height
    );
    for (k, (l, parts)) in frames.iter().enumerate() {
        for (role, s) in std::iter::once((Role::Left, l)).chain(parts.iter().map(|(r, s)| (*r, s))) {
            ensure!(
                s.size == (w, h),
                "{}: message {}: {} x {} pixels, but the left images are {w} x {h}",
                chosen.images.iter().find(|(r, _)| *r == role).map_or("", |(_, t)| t.as_str()),
                s.index,
                s.size.0,
                s.size.1
            );
            let folder = dir.join(role.folder()).join(seq);
            std::fs::create_dir_all(&folder).with_context(|| format!("creating {}", folder.display()))?;
            let to = folder.join(format!("{k:06}.png"));
            std::fs::rename(&s.path, &to)
                .with_context(|| format!("moving {} to {}", s.path.display(), to.display()))?;
        }
    }
    std::fs::remove_dir_all(&stage).with_context(|| format!("removing {}", stage.display()))?;
    let write = |sub: &str, text: &str| -> anyhow::Result<()> {
        let path = dir.join(sub).join(format!("{seq}.txt"));
        std::fs::create_dir_all(dir.join(sub)).with_context(|| format!("creating {}", dir.join(sub).display()))?;
        dynotraj_formats::atomic::write_file(&path, text).with_context(|| format!("writing {}", path.display()))
    };
    let right_topic = chosen.right_info.clone().unwrap_or_default();
    write("calib", &calib_text(left_info, right_info, opt.baseline_m, &right_topic)?)?;
    let t0 = frames.first().map_or(0, |(l, _)| l.stamp);
    let times: String = frames.iter().map(|(l, _)| format!("{:.9}\n", (l.stamp - t0) as f64 / 1e9)).collect();
    write("times", &times)?;
    let mut periods: Vec<i64> =
        frames.windows(2).filter_map(|p| Some(p.get(1)?.0.stamp - p.first()?.0.stamp)).collect();
    periods.sort_unstable();
    let rate_hz = periods.get(periods.len() / 2).map_or(0.0, |&p| if p > 0 { 1e9 / p as f64 } else { 0.0 });
    let mut boxes = 0;
    if chosen.detections.is_some() {
        let mut rows = Vec::new();
        let mut ids: BTreeMap<String, i64> = BTreeMap::new();
        for (k, (l, _)) in frames.iter().enumerate() {
            let Some((_, d)) = detections
                .iter()
                .filter(|(s, _)| (s - l.stamp).abs() <= tolerance)
                .min_by_key(|(s, _)| (s - l.stamp).abs())
            else {
                continue;
            };
            for det in &d.detections {
                let next = ids.len() as i64;
                // A tracker's numeric id is kept; other ids are numbered in order of appearance.
                let track_id = det
                    .id
                    .parse::<i64>()
                    .ok()
                    .filter(|v| *v >= 0)
                    .unwrap_or_else(|| *ids.entry(det.id.clone()).or_insert(next));
                let b = det.bbox;
                let (left, top) = (b.center.position.x - b.size_x / 2.0, b.center.position.y - b.size_y / 2.0);
                rows.push(LabelRow {
                    frame: k,
                    track_id,
                    object_type: det.results.first().map_or("Misc", |r| kitti_type(&r.hypothesis.class_id)).to_string(),
                    truncated: 0.0,
                    occluded: 0,
                    alpha: -10.0,
                    bbox_left: left,
                    bbox_top: top,
                    bbox_right: left + b.size_x,
                    bbox_bottom: top + b.size_y,
                    height: -1.0,
                    width: -1.0,
                    length: -1.0,
                    x: -1000.0,
                    y: -1000.0,
                    z: -1000.0,
                    rotation_y: -10.0,
                    score: det.results.first().map(|r| r.hypothesis.score),
                });
            }
        }
        boxes = rows.len();
        let path = dir.join("label_02").join(format!("{seq}.txt"));
        std::fs::create_dir_all(dir.join("label_02")).with_context(|| format!("creating {}", dir.display()))?;
        write_labels(&path, &rows)?;
    }
    let mut topics = vec![];
    for (role, t) in &chosen.images {
        topics.push((format!("{role:?}").to_lowercase(), t.clone()));
    }
    topics.push(("left camera info".into(), chosen.left_info.clone()));
    topics.extend(chosen.right_info.clone().map(|t| ("right camera info".to_string(), t)));
    topics.extend(chosen.detections.clone().map(|t| ("detections".to_string(), t)));
    let mut unmatched = vec![(left_topic, unmatched_left)];
    for (role, t) in &others {
        unmatched.push((t.clone(), used.get(role).map_or(0, |u| u.iter().filter(|x| !**x).count())));
    }
    Ok(ImportSummary { frames: frames.len(), topics, rate_hz, unmatched, boxes })
}

#[cfg(test)]
mod tests {
    use std::collections::BTreeMap;
    use std::io::BufWriter;

    use super::*;
    use crate::from_layout::{DETECTIONS, LEFT, RIGHT, layout_to_bag};

    fn fixture() -> PathBuf {
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../sim/data/image_sim")
    }

    fn options() -> ImportOptions {
        ImportOptions { sync_tolerance_ns: 1_000_000, ..ImportOptions::default() }
    }

    /// The fixture as a bag in `dir`, each message passed through `edit` (topic, payload ->
    /// payload, or `None` to leave it out).
    fn bag(dir: &Path, mut edit: impl FnMut(&str, Vec<u8>) -> Option<Vec<u8>>) -> PathBuf {
        bag_with(dir, |topic, schema, p| edit(topic, p).map(|p| (schema.to_string(), p)))
    }

    /// As [`bag`], `edit` also choosing each message's schema name.
    fn bag_with(dir: &Path, mut edit: impl FnMut(&str, &str, Vec<u8>) -> Option<(String, Vec<u8>)>) -> PathBuf {
        let plain = dir.join("plain.mcap");
        layout_to_bag(&fixture(), "0000", &plain, 10.0).unwrap();
        let out = dir.join("edited.mcap");
        let mut w = mcap::Writer::new(BufWriter::new(File::create(&out).unwrap())).unwrap();
        let mut channels: BTreeMap<String, u16> = BTreeMap::new();
        for_each_message(&[plain], |t, _, m| {
            let Some((schema_name, payload)) = edit(&t.name, &t.schema, m.data.to_vec()) else { return Ok(()) };
            let id = match channels.get(&t.name) {
                Some(&id) => id,
                None => {
                    let schema = w.add_schema(&schema_name, "ros2msg", b"")?;
                    let id = w.add_channel(schema, &t.name, &t.encoding, &BTreeMap::new())?;
                    channels.insert(t.name.clone(), id);
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
                return Some((schema.to_string(), p));
            }
            // The left camera as image_transport's compressed PNG.
            let m: Image = ros2::decode(&p).unwrap();
            let rgb = RgbImage::from_raw(m.width, m.height, m.data).unwrap();
            let mut png = Vec::new();
            rgb.write_to(&mut std::io::Cursor::new(&mut png), image::ImageFormat::Png).unwrap();
            let c = CompressedImage { header: m.header, format: "rgb8; png compressed rgb8".into(), data: png };
            Some((COMPRESSED_IMAGE.to_string(), ros2::encode(&c).unwrap()))
        });
        let out = tmp.path().join("layout");
        let s = import(&b, "0000", &out, &ImportOptions { rgbd: true, ..options() }).unwrap();
        assert_eq!(s.frames, 24);
        assert!(s.topics.iter().any(|(r, t)| r == "depth" && t == "/stereo/left/depth"), "{:?}", s.topics);
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
        assert!(e.contains("cut.mcap: not a readable MCAP file after") && e.contains("truncated"), "{e}");
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
            e.contains("topic /stereo/left/image_raw (sensor_msgs/msg/Image), message 5: field `encoding`: `yuv422` is not one of"),
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
}
