//! One frame through every stage: depth (stereo or given), instance masks (PNG, boxes refined by
//! depth, or none), tracking; with the wall time of each stage.

use std::collections::BTreeMap;
use std::time::Instant;

use dynotraj_core::wire::{ObjectClass, Track};
use opencv::core::{CV_16UC1, Mat, Scalar};
use opencv::prelude::*;

use super::depth::DepthMap;
use super::error::{FrontEndError, cv};
use super::masks::{Detection, IdAssigner, Instances, from_boxes, from_label_image};
use super::stereo::{Stereo, StereoParams};
use super::tracker::{Tracker, TrackerParams};

/// Where a frame's depth comes from.
#[derive(Debug, Clone)]
pub enum DepthInput {
    /// The right image of a rectified pair (grey, same size as the left).
    Right(Mat),
    /// A depth map in metres (`f32`).
    Depth(Mat),
}

/// Where a frame's instance masks come from.
#[derive(Debug, Clone)]
pub enum MaskInput {
    /// A 16-bit label image (0 background, else the wire object id) and each id's class.
    Labels(Mat, BTreeMap<u16, ObjectClass>),
    /// 2D boxes, refined by depth into masks.
    Boxes(Vec<Detection>),
    /// No objects: everything is background.
    None,
}

/// One frame's inputs.
#[derive(Debug, Clone)]
pub struct FrameInput {
    /// Left image, 8-bit grey.
    pub left: Mat,
    /// Depth source.
    pub depth: DepthInput,
    /// Mask source.
    pub masks: MaskInput,
}

/// Seconds spent per stage, summed over frames: wall time, and the CPU time of the whole
/// process (all of OpenCV's threads), which is what the work costs when other jobs share the
/// cores.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Frames timed.
    pub frames: usize,
    /// Stereo matching (or depth conversion), wall.
    pub stereo: f64,
    /// Instance masks, wall.
    pub masks: f64,
    /// KLT, detection, sampling and emission, wall.
    pub tracking: f64,
    /// CPU seconds of the same stages (process, all threads).
    pub cpu: [f64; 3],
}

/// CPU time of this process (all threads), seconds.
#[must_use]
pub fn process_cpu_seconds() -> f64 {
    let mut ts = libc::timespec { tv_sec: 0, tv_nsec: 0 };
    // SAFETY: clock_gettime only writes the timespec we own; CLOCK_PROCESS_CPUTIME_ID is
    // supported on every Linux.
    let rc = unsafe { libc::clock_gettime(libc::CLOCK_PROCESS_CPUTIME_ID, &raw mut ts) };
    if rc == 0 { ts.tv_sec as f64 + 1e-9 * ts.tv_nsec as f64 } else { 0.0 }
}

impl StageTimes {
    /// Frames per second over all stages.
    #[must_use]
    pub fn fps(&self) -> f64 {
        let t = self.stereo + self.masks + self.tracking;
        if t > 0.0 { self.frames as f64 / t } else { 0.0 }
    }
}

/// The front-end: stereo, masks, tracker.
#[derive(Debug)]
pub struct FrontEnd {
    stereo: Stereo,
    /// The tracking stage (its counters are the front-end's).
    pub tracker: Tracker,
    ids: IdAssigner,
    fb: f32,
    /// Time per stage.
    pub times: StageTimes,
}

impl FrontEnd {
    /// A front-end for a camera with stereo `fb` (baseline x focal length, pixel metres).
    ///
    /// # Errors
    /// OpenCV refusing the stereo parameters.
    pub fn new(stereo: StereoParams, tracker: TrackerParams, fb: f32) -> Result<Self, FrontEndError> {
        Ok(Self {
            stereo: Stereo::new(stereo)?,
            tracker: Tracker::new(tracker),
            ids: IdAssigner::default(),
            fb,
            times: StageTimes::default(),
        })
    }

    /// Processes one frame; returns its tracks (wire order, within the capacities).
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn process(&mut self, input: FrameInput) -> Result<Vec<Track>, FrontEndError> {
        let t0 = Instant::now();
        let c0 = process_cpu_seconds();
        let depth = match input.depth {
            DepthInput::Right(right) => {
                let disparity = self.stereo.disparity(&input.left, &right)?;
                DepthMap::Stereo { disparity, fb: self.fb, pair: Some((input.left.clone(), right)) }
            }
            DepthInput::Depth(d) => DepthMap::Given(d),
        };
        let t1 = Instant::now();
        let c1 = process_cpu_seconds();
        let (w, h) = (input.left.cols(), input.left.rows());
        let instances = match input.masks {
            MaskInput::Labels(labels, classes) => {
                from_label_image(labels, |id| classes.get(&id).copied().unwrap_or(ObjectClass::Misc))?
            }
            MaskInput::Boxes(dets) => {
                let with_ids = self.ids.assign(&dets);
                from_boxes(w, h, &with_ids, &depth)?
            }
            MaskInput::None => Instances {
                labels: Mat::new_rows_cols_with_default(h, w, CV_16UC1, Scalar::all(0.0)).map_err(cv("label image"))?,
                objects: Vec::new(),
                empty: 0,
            },
        };
        let t2 = Instant::now();
        let c2 = process_cpu_seconds();
        let tracks = self.tracker.process(&input.left, &depth, &instances)?;
        let t3 = Instant::now();
        let c3 = process_cpu_seconds();
        for (slot, dt) in self.times.cpu.iter_mut().zip([c1 - c0, c2 - c1, c3 - c2]) {
            *slot += dt;
        }
        self.times.frames += 1;
        self.times.stereo += (t1 - t0).as_secs_f64();
        self.times.masks += (t2 - t1).as_secs_f64();
        self.times.tracking += (t3 - t2).as_secs_f64();
        Ok(tracks)
    }
}
