//! A camera sequence in the KITTI tracking layout, as front-end input:
//!
//! ```text
//! <dir>/image_02/<seq>/NNNNNN.png     left images (colour or grey)            required
//! <dir>/image_03/<seq>/NNNNNN.png     right images                            for stereo depth
//! <dir>/depth_02/<seq>/NNNNNN.png     16-bit depth, value / 256 = metres      for given depth
//! <dir>/instance_02/<seq>/NNNNNN.png  16-bit instance ids (0 = background,    masks, first choice
//!                                     else KITTI track id + 1)
//! <dir>/label_02/<seq>.txt            KITTI labels: classes, and 2D boxes     masks, second choice
//! <dir>/calib/<seq>.txt               P2, P3 (left and right colour cameras)  required
//! <dir>/times/<seq>.txt               capture time of each frame, seconds     optional
//! ```
//!
//! With times/ (what `dynotraj import` writes from a bag's stamps), each frame's capture time
//! and the frame rate come from it; without, frame / rate.
//!
//! The frames are those of image_02 from the first to the last number; a gap is a missing frame
//! and an error naming the missing file, as is a missing right image or depth map. The
//! simulator's output (`dynotraj simulate`) has every folder.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::ObjectClass;
use opencv::core::{CV_32F, Mat};
use opencv::prelude::*;

use super::error::{FrontEndError, cv};
use super::image_io::{read_grey, read_u16, same_size};
use super::masks::Detection;
use super::pipeline::{DepthInput, FrameInput, FrontEnd, MaskInput};
use dynotraj_core::wire::Track;
use dynotraj_formats::kitti::{LabelRow, read_calib, read_labels};

/// How to get depth.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DepthMode {
    /// Stereo matching of image_02 and image_03.
    Stereo,
    /// The depth maps of depth_02.
    Given,
}

impl DepthMode {
    /// Every mode with its name on the command line and what it does.
    pub const CHOICES: [(Self, &'static str, &'static str); 2] = [
        (Self::Stereo, "stereo", "Stereo matching of image_02 and image_03"),
        (Self::Given, "given", "The depth maps of depth_02"),
    ];
}

/// How to get masks.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum MaskMode {
    /// instance_02 when present, else the boxes of label_02, else motion segmentation.
    Auto,
    /// instance_02 PNGs.
    Png,
    /// label_02 2D boxes refined by depth (ids from the labels).
    Boxes,
    /// label_02 2D boxes refined by depth, ids dropped and re-made by IoU association.
    Detections,
    /// The moving objects the front-end finds itself ([`crate::motion`]): no labels, no
    /// detector.
    Motion,
    /// No objects.
    None,
}

impl MaskMode {
    /// Every mode with its name on the command line and what it does.
    pub const CHOICES: [(Self, &'static str, &'static str); 6] = [
        (Self::Auto, "auto", "instance_02 when present, else the boxes of label_02, else motion segmentation"),
        (Self::Png, "png", "instance_02 PNGs"),
        (Self::Boxes, "boxes", "label_02 2D boxes refined by depth (ids from the labels)"),
        (
            Self::Detections,
            "detections",
            "label_02 2D boxes refined by depth, ids dropped and re-made by IoU association",
        ),
        (Self::Motion, "motion", "Moving objects found by motion segmentation (no labels, no detector)"),
        (Self::None, "none", "No objects"),
    ];
}

/// A sequence on disk.
#[derive(Debug, Clone)]
pub struct ImageSequence {
    dir: PathBuf,
    seq: String,
    /// Frame numbers, consecutive.
    pub frames: Vec<u32>,
    /// Left camera: fx, fy, cx, cy.
    pub intrinsics: [f64; 4],
    /// Baseline x fx, pixel metres.
    pub fb: f64,
    /// Image size of the first frame (width, height).
    pub size: (i32, i32),
    /// Capture times from times/<seq>.txt, seconds, one per frame from the first.
    pub times_s: Option<Vec<f64>>,
    labels: BTreeMap<u32, Vec<LabelRow>>,
    depth: DepthMode,
    masks: MaskMode,
}

fn list_frames(folder: &Path) -> Result<Vec<u32>, FrontEndError> {
    let io = |source| FrontEndError::Io { path: folder.to_path_buf(), cause: source };
    let mut frames = Vec::new();
    for e in std::fs::read_dir(folder).map_err(io)? {
        let name = e.map_err(io)?.file_name();
        let name = name.to_string_lossy();
        if let Some(n) = name.strip_suffix(".png").and_then(|s| s.parse::<u32>().ok()) {
            frames.push(n);
        }
    }
    frames.sort_unstable();
    Ok(frames)
}

/// The capture times of `path`, when it exists: one number of seconds per line, increasing,
/// at least one per frame.
fn read_times(path: &Path, frames: usize) -> Result<Option<Vec<f64>>, FrontEndError> {
    if !path.is_file() {
        return Ok(None);
    }
    let text = std::fs::read_to_string(path).map_err(|cause| FrontEndError::Io { path: path.to_path_buf(), cause })?;
    let bad = |line: usize, found: &str| FrontEndError::Unreadable {
        path: path.to_path_buf(),
        expected: format!("line {line}: a capture time in seconds, later than the line before, found `{found}`"),
    };
    let mut times: Vec<f64> = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let t: f64 = line.trim().parse().map_err(|_| bad(i + 1, line))?;
        if !t.is_finite() || times.last().is_some_and(|&last| t <= last) {
            return Err(bad(i + 1, line));
        }
        times.push(t);
    }
    if times.len() < frames {
        return Err(FrontEndError::Unreadable {
            path: path.to_path_buf(),
            expected: format!("a capture time for each of the {frames} frames, found {}", times.len()),
        });
    }
    Ok(Some(times))
}

impl ImageSequence {
    /// Opens sequence `seq` of `dir`.
    ///
    /// # Errors
    /// No images, a gap in the frame numbers, a missing or bad calibration or label file, named.
    pub fn open(dir: &Path, seq: &str, depth: DepthMode, masks: MaskMode) -> Result<Self, FrontEndError> {
        let left_dir = dir.join("image_02").join(seq);
        let frames = list_frames(&left_dir)?;
        let (Some(&first), Some(&last)) = (frames.first(), frames.last()) else {
            return Err(FrontEndError::Missing { path: left_dir, what: "left images NNNNNN.png".into() });
        };
        if let Some(gap) = (first..=last).find(|k| frames.binary_search(k).is_err()) {
            return Err(FrontEndError::Missing {
                path: left_dir.join(format!("{gap:06}.png")),
                what: format!("frame {gap} of {first}..={last}"),
            });
        }
        let calib_path = dir.join("calib").join(format!("{seq}.txt"));
        let calib = read_calib(&calib_path).map_err(|e| FrontEndError::Unreadable {
            path: calib_path.clone(),
            expected: format!("KITTI calibration ({e})"),
        })?;
        let (p2, p3) = (calib.p[2], calib.p[3]);
        let intrinsics = [p2[(0, 0)], p2[(1, 1)], p2[(0, 2)], p2[(1, 2)]];
        let fb = p2[(0, 3)] - p3[(0, 3)];
        let labels_path = dir.join("label_02").join(format!("{seq}.txt"));
        let mut labels: BTreeMap<u32, Vec<LabelRow>> = BTreeMap::new();
        let need_labels = matches!(masks, MaskMode::Boxes | MaskMode::Detections);
        if labels_path.is_file() || need_labels {
            let rows = read_labels(&labels_path).map_err(|e| FrontEndError::Unreadable {
                path: labels_path.clone(),
                expected: format!("KITTI labels ({e})"),
            })?;
            for r in rows.into_iter().filter(|r| !r.is_dont_care()) {
                labels.entry(r.frame as u32).or_default().push(r);
            }
        }
        let masks = match masks {
            MaskMode::Auto if dir.join("instance_02").join(seq).is_dir() => MaskMode::Png,
            MaskMode::Auto if labels_path.is_file() => MaskMode::Boxes,
            MaskMode::Auto => MaskMode::Motion,
            m => m,
        };
        let times_s = read_times(&dir.join("times").join(format!("{seq}.txt")), frames.len())?;
        let first_path = left_dir.join(format!("{first:06}.png"));
        let m = read_grey(&first_path, "left image")?;
        let mut s = Self {
            dir: dir.to_path_buf(),
            seq: seq.to_string(),
            frames,
            intrinsics,
            fb,
            size: (m.cols(), m.rows()),
            times_s,
            labels,
            depth,
            masks,
        };
        if s.fb <= 0.0 && depth == DepthMode::Stereo {
            return Err(FrontEndError::Unreadable {
                path: calib_path,
                expected: "P2 and P3 of a stereo pair (P2[0][3] - P3[0][3] > 0)".into(),
            });
        }
        s.fb = s.fb.max(0.0);
        Ok(s)
    }

    fn path(&self, folder: &str, frame: u32) -> PathBuf {
        self.dir.join(folder).join(&self.seq).join(format!("{frame:06}.png"))
    }

    /// The camera model of the left images.
    #[must_use]
    pub fn camera(&self) -> Intrinsics {
        let [fx, fy, cx, cy] = self.intrinsics.map(|v| v as f32);
        Intrinsics { fx, fy, cx, cy, stereo_fb: self.fb as f32 }
    }

    /// The mask mode in use.
    #[must_use]
    pub const fn masks(&self) -> MaskMode {
        self.masks
    }

    /// The frame rate the capture times give (the median period), when the sequence has them.
    #[must_use]
    pub fn measured_rate_hz(&self) -> Option<f64> {
        let t = self.times_s.as_ref()?;
        let mut periods: Vec<f64> = t.windows(2).filter_map(|w| Some(w.get(1)? - w.first()?)).collect();
        periods.sort_by(f64::total_cmp);
        periods.get(periods.len() / 2).filter(|p| **p > 0.0).map(|p| 1.0 / p)
    }

    /// Tracks the first `frames` frames with `fe` and hands each frame's tracks to `each` with
    /// its number and capture time (from times/, else frame / `rate_hz`; microseconds);
    /// returns the frames done.
    ///
    /// # Errors
    /// An unreadable frame or a front-end failure, with the frame named; what `each` returns.
    pub fn track(
        &self,
        fe: &mut FrontEnd,
        frames: usize,
        rate_hz: f64,
        mut each: impl FnMut(u32, u64, &[Track]) -> anyhow::Result<()>,
    ) -> anyhow::Result<usize> {
        let n = frames.min(self.frames.len());
        for (k, &frame) in self.frames.iter().take(n).enumerate() {
            let tracks = fe
                .process(self.load(frame)?)
                .map_err(|e| anyhow::anyhow!("{}: image_02/{}/{frame:06}.png: {e}", self.dir.display(), self.seq))?;
            let seconds = self.times_s.as_ref().and_then(|t| t.get(k).copied()).unwrap_or(f64::from(frame) / rate_hz);
            let timestamp_us = (seconds * 1e6).round() as u64;
            each(frame, timestamp_us, &tracks)?;
        }
        Ok(n)
    }

    /// Loads frame `frame`.
    ///
    /// # Errors
    /// A missing or unreadable image, or images of different sizes, named.
    pub fn load(&self, frame: u32) -> Result<FrameInput, FrontEndError> {
        let lp = self.path("image_02", frame);
        let left = read_grey(&lp, "left image")?;
        let depth = match self.depth {
            DepthMode::Stereo => {
                let rp = self.path("image_03", frame);
                let right = read_grey(&rp, "right image")?;
                same_size(&right, &rp, &left, &lp)?;
                DepthInput::Right(right)
            }
            DepthMode::Given => {
                let dp = self.path("depth_02", frame);
                let raw = read_u16(&dp, "depth map")?;
                same_size(&raw, &dp, &left, &lp)?;
                let mut metres = Mat::default();
                raw.convert_to(&mut metres, CV_32F, 1.0 / 256.0, 0.0).map_err(cv("converting a depth map"))?;
                DepthInput::Depth(metres)
            }
        };
        let rows = self.labels.get(&frame).map_or(&[][..], Vec::as_slice);
        let class_of = |r: &LabelRow| ObjectClass::from_kitti_name(&r.object_type).unwrap_or(ObjectClass::Misc);
        let masks = match self.masks {
            MaskMode::Png => {
                let mp = self.path("instance_02", frame);
                let ids = read_u16(&mp, "instance mask")?;
                same_size(&ids, &mp, &left, &lp)?;
                let classes =
                    rows.iter().filter_map(|r| Some((u16::try_from(r.track_id + 1).ok()?, class_of(r)))).collect();
                MaskInput::Labels(ids, classes)
            }
            MaskMode::Boxes | MaskMode::Detections => MaskInput::Boxes(
                rows.iter()
                    .map(|r| Detection {
                        bbox: [r.bbox_left as f32, r.bbox_top as f32, r.bbox_right as f32, r.bbox_bottom as f32],
                        class: class_of(r),
                        object_id: if self.masks == MaskMode::Boxes {
                            u16::try_from(r.track_id + 1).ok()
                        } else {
                            None
                        },
                    })
                    .collect(),
            ),
            MaskMode::Motion => MaskInput::Motion(self.camera()),
            MaskMode::None | MaskMode::Auto => MaskInput::None,
        };
        Ok(FrameInput { left, depth, masks })
    }
}
