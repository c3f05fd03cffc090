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
use std::path::{Path, PathBuf};

use anyhow::{Context as _, ensure};
use dynotraj_formats::kitti::{LabelRow, write_labels};

use crate::ros2::{self, CAMERA_INFO, CameraInfo, CompressedImage, Detection2DArray, IMAGE, Image};
use pixels::{compressed_pixels, raw_pixels};
pub use topics::bag_files;
use topics::{Chosen, choose_topics, for_each_message, topics};

pub mod container;
mod pixels;
#[cfg(test)]
mod tests;
mod topics;

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

/// The stamp tolerance of an import unless told otherwise: 1 ms, so that a stereo pair's
/// messages meet whatever the transport's delay.
pub const DEFAULT_SYNC_TOLERANCE_NS: i64 = 1_000_000;

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
    Ok(dynotraj_formats::kitti::stereo_calib_text(&left.p, &right_p))
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

/// The size of a compressed image (PNG or JPEG) as the import decodes it, within its limits
/// (8192 pixels a side): what a bag's `CompressedImage` data must pass.
///
/// # Errors
/// Bytes that are no image, or one over the limits, in words.
pub fn decode_compressed_image(bytes: &[u8]) -> Result<(u32, u32), String> {
    let image = pixels::decode_bounded(bytes).map_err(|e| e.to_string())?;
    Ok((image.width(), image.height()))
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
    // Once per file, before either pass over its messages reads a record.
    for file in &files {
        container::check_lengths(file)?;
    }
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
    remove_abandoned_staging(out);
    let result = import_into(&files, seq, &staging, &chosen, opt).and_then(|summary| {
        // Another process importing the same bag may have renamed its folder first: this one
        // then fails, and its copy goes.
        std::fs::rename(&staging, out)
            .with_context(|| format!("renaming {} to {}", staging.display(), out.display()))?;
        Ok(summary)
    });
    if result.is_err() {
        // Best effort: the error says what failed.
        let _ = std::fs::remove_dir_all(&staging);
    }
    result
}

/// Removes the staging folders of `out` (`.<name>.partial-<pid>`) whose process is gone: what an
/// interrupted import left. Where processes cannot be looked up (no /proc), nothing is removed.
fn remove_abandoned_staging(out: &Path) {
    let (Some(parent), Some(name)) = (out.parent(), out.file_name().and_then(|n| n.to_str())) else { return };
    let parent = if parent.as_os_str().is_empty() { Path::new(".") } else { parent };
    if !Path::new("/proc/self").exists() {
        return;
    }
    let prefix = format!(".{name}.partial-");
    let Ok(entries) = std::fs::read_dir(parent) else { return };
    for entry in entries.filter_map(Result::ok) {
        let file_name = entry.file_name();
        let Some(pid) = file_name.to_str().and_then(|n| n.strip_prefix(&prefix)) else { continue };
        if pid.parse::<u32>().is_ok() && !Path::new("/proc").join(pid).exists() {
            let _ = std::fs::remove_dir_all(entry.path());
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
        let data = container::payload(&m.data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
        if let Some(&role) = role_of.get(name) {
            let (header, pixels) = if topic.schema == IMAGE {
                let img: Image = ros2::decode(&data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
                (img.header.clone(), raw_pixels(&img, role))
            } else {
                let img: CompressedImage = ros2::decode(&data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
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
                let info: CameraInfo = ros2::decode(&data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
                infos.insert(name.to_string(), info);
            }
        } else {
            let d: Detection2DArray = ros2::decode(&data).map_err(|e| anyhow::anyhow!("{}: {e}", at()))?;
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
    // What is written is read back by the reader that consumes it, under its rules: a layout
    // that a later command would refuse fails the import, not that command.
    dynotraj_formats::kitti::read_calib(dir.join("calib").join(format!("{seq}.txt"))).map_err(|e| {
        anyhow::anyhow!(
            "camera info of {} (and of the right camera): field `p` makes a calibration the layout's reader \
             refuses: {e}",
            chosen.left_info
        )
    })?;
    let t0 = frames.first().map_or(0, |(l, _)| l.stamp);
    let mut times = String::new();
    for (l, _) in &frames {
        let since = l.stamp.checked_sub(t0).filter(|d| *d >= 0).with_context(|| {
            format!(
                "{left_topic}: message {}: header stamp {} ns is before the first frame's {t0} ns or too far from it",
                l.index, l.stamp
            )
        })?;
        times.push_str(&format!("{:.9}\n", since as f64 / 1e9));
    }
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
        dynotraj_formats::kitti::read_labels(&path).map_err(|e| {
            anyhow::anyhow!(
                "detections of {}: they make labels the layout's reader refuses: {e}",
                chosen.detections.as_deref().unwrap_or_default()
            )
        })?;
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
