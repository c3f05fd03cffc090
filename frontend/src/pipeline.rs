//! One frame through every stage: depth (stereo or given), instance masks (PNG, boxes refined by
//! depth, or none), tracking; with the wall time of each stage.

use std::collections::BTreeMap;
use std::time::Instant;

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::{ObjectClass, Track};
use opencv::core::{CV_16UC1, Mat, Scalar};
use opencv::prelude::*;

use super::depth::DepthMap;
use super::error::{FrontEndError, cv};
use super::masks::{Detection, IdAssigner, Instances, from_boxes, from_label_image};
use super::motion::{MotionParams, MotionSegmenter};
use super::stats::FrontEndStats;
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
    /// The moving objects the front-end finds itself ([`MotionSegmenter`]), seen by a camera
    /// with these intrinsics; refined by depth into masks as boxes are.
    Motion(Intrinsics),
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
/// cores. Where the dense matcher runs beside the tracker ([`FrontEnd::process`]) their walls
/// overlap and their CPU time is one figure.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct StageTimes {
    /// Frames timed.
    pub frames: usize,
    /// Frames whose dense matcher ran beside the tracker's KLT.
    pub concurrent_frames: usize,
    /// Stereo matching (or depth conversion), wall.
    pub stereo: f64,
    /// Instance masks, wall.
    pub masks: f64,
    /// KLT, detection and sampling (what needs no depth), wall.
    pub points: f64,
    /// Point depth and emission, wall.
    pub emission: f64,
    /// Whole frames, wall.
    pub wall: f64,
    /// CPU seconds (process, all threads) of stereo, masks, KLT with detection and sampling,
    /// point depth with emission; stereo and KLT as one figure, in the first slot, where they
    /// ran side by side.
    pub cpu: [f64; 4],
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
    /// Frames per second, wall.
    #[must_use]
    pub fn fps(&self) -> f64 {
        if self.wall > 0.0 { self.frames as f64 / self.wall } else { 0.0 }
    }
}

/// The front-end: stereo, masks, tracker.
#[derive(Debug)]
pub struct FrontEnd {
    stereo: Stereo,
    /// The tracking stage (its counters are the front-end's).
    pub tracker: Tracker,
    ids: IdAssigner,
    /// The motion segmentation, for frames with [`MaskInput::Motion`].
    pub motion: MotionSegmenter,
    fb: f32,
    /// Time per stage.
    pub times: StageTimes,
    /// The last frame's instance label image (`CV_16UC1`, 0 background), for scoring masks.
    pub last_masks: Mat,
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
            motion: MotionSegmenter::new(MotionParams::default()),
            fb,
            times: StageTimes::default(),
            last_masks: Mat::default(),
        })
    }

    /// Processes one frame; returns its tracks (wire order, within the capacities). With
    /// [`StereoParams::row_match`] and masks that need no depth, no dense map is computed: each
    /// point is matched along its row when its depth is needed. Otherwise, with a
    /// right image, masks that need no depth and a downscaled matcher, the dense matcher runs on
    /// a second thread while this one follows the points (KLT, detection, sampling need no
    /// depth); the tracks are the same as one after the other. At full size the matcher is
    /// itself spread over the cores by OpenCV and beside the tracker it took twice as long
    /// (docs/results.md "The front-end's stages side by side"), so it runs first.
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn process(&mut self, input: FrameInput) -> Result<Vec<Track>, FrontEndError> {
        let (t0, c0) = (Instant::now(), process_cpu_seconds());
        let FrameInput { left, depth, masks } = input;
        let Self { stereo, tracker, ids, motion, fb, times, last_masks } = self;
        let fb = *fb;
        let needs_depth = matches!(masks, MaskInput::Boxes(_) | MaskInput::Motion(_));
        let rows = stereo.row_search().filter(|_| !needs_depth);
        let beside = rows.is_none() && !needs_depth && stereo.downscale() > 1;
        let (tracks, cpu) = match depth {
            DepthInput::Right(right) if beside => {
                let instances = instances_of(masks, (ids, motion, &mut tracker.stats), &left, None)?;
                let (t1, c1) = (Instant::now(), process_cpu_seconds());
                let (disparity, points) = std::thread::scope(|s| {
                    let matcher = s.spawn(|| {
                        let start = Instant::now();
                        stereo.disparity(&left, &right).map(|d| (d, start.elapsed().as_secs_f64()))
                    });
                    let start = Instant::now();
                    let points = tracker.follow(&left, &instances).map(|p| (p, start.elapsed().as_secs_f64()));
                    (matcher.join(), points)
                });
                let (disparity, stereo_wall) =
                    disparity.map_err(|_| FrontEndError::Stage("the dense matcher's thread panicked"))??;
                let (points, points_wall) = points?;
                let (t2, c2) = (Instant::now(), process_cpu_seconds());
                let depth = DepthMap::Stereo { disparity, fb, pair: Some((left, right)) };
                let tracks = tracker.finish(points, &depth, &instances);
                *last_masks = instances.labels;
                let (t3, c3) = (Instant::now(), process_cpu_seconds());
                times.concurrent_frames += 1;
                times.masks += (t1 - t0).as_secs_f64();
                times.stereo += stereo_wall;
                times.points += points_wall;
                times.emission += (t3 - t2).as_secs_f64();
                (tracks, [c2 - c1, c1 - c0, 0.0, c3 - c2])
            }
            depth => {
                let depth = match (depth, rows) {
                    (DepthInput::Right(right), Some(search)) => {
                        DepthMap::Rows { fb, pair: (left.clone(), right), search }
                    }
                    (DepthInput::Right(right), None) => {
                        let disparity = stereo.disparity(&left, &right)?;
                        DepthMap::Stereo { disparity, fb, pair: Some((left.clone(), right)) }
                    }
                    (DepthInput::Depth(d), _) => DepthMap::Given(d),
                };
                let (t1, c1) = (Instant::now(), process_cpu_seconds());
                let instances = instances_of(masks, (ids, motion, &mut tracker.stats), &left, Some(&depth))?;
                let (t2, c2) = (Instant::now(), process_cpu_seconds());
                let points = tracker.follow(&left, &instances)?;
                let (t3, c3) = (Instant::now(), process_cpu_seconds());
                let tracks = tracker.finish(points, &depth, &instances);
                *last_masks = instances.labels;
                let (t4, c4) = (Instant::now(), process_cpu_seconds());
                times.stereo += (t1 - t0).as_secs_f64();
                times.masks += (t2 - t1).as_secs_f64();
                times.points += (t3 - t2).as_secs_f64();
                times.emission += (t4 - t3).as_secs_f64();
                (tracks, [c1 - c0, c2 - c1, c3 - c2, c4 - c3])
            }
        };
        for (slot, dt) in times.cpu.iter_mut().zip(cpu) {
            *slot += dt;
        }
        times.frames += 1;
        times.wall += t0.elapsed().as_secs_f64();
        Ok(tracks)
    }
}

/// The instance masks of `masks` for the image `left`: boxes and moving objects are refined by
/// `depth` (which they need), labels and none are not.
fn instances_of(
    masks: MaskInput,
    (ids, motion, stats): (&mut IdAssigner, &mut MotionSegmenter, &mut FrontEndStats),
    left: &Mat,
    depth: Option<&DepthMap>,
) -> Result<Instances, FrontEndError> {
    let (w, h) = (left.cols(), left.rows());
    match masks {
        MaskInput::Labels(labels, classes) => {
            from_label_image(labels, |id| classes.get(&id).copied().unwrap_or(ObjectClass::Misc))
        }
        MaskInput::Boxes(dets) => {
            let depth = depth.ok_or(FrontEndError::Stage("masks from boxes need the depth map"))?;
            from_boxes(w, h, &ids.assign(&dets), depth)
        }
        MaskInput::Motion(intrinsics) => {
            let depth = depth.ok_or(FrontEndError::Stage("motion segmentation needs the depth map"))?;
            let found = motion.objects(left, depth, &intrinsics, stats)?;
            let boxes: Vec<(u16, Detection)> = found.into_iter().filter_map(|d| Some((d.object_id?, d))).collect();
            from_boxes(w, h, &boxes, depth)
        }
        MaskInput::None => Ok(Instances {
            labels: Mat::new_rows_cols_with_default(h, w, CV_16UC1, Scalar::all(0.0)).map_err(cv("label image"))?,
            objects: Vec::new(),
            empty: 0,
        }),
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::cost::input_of;
    use dynotraj_sim::drive::{DriveSpec, generate};
    use dynotraj_sim::image_sim::{Camera, ImageSim};
    use dynotraj_sim::track_sim::LabelBox;

    #[test]
    fn the_matcher_beside_the_tracker_gives_the_tracks_of_one_after_the_other() {
        let drive = generate(&DriveSpec { frames: 4, ..DriveSpec::default() });
        let sim = ImageSim::new(Camera::kitti(0.5), &drive.camera_poses, &LabelBox::of_drive(&drive), 1);
        let fb = sim.camera.fb() as f32;
        let stereo_params = StereoParams { downscale: 2, ..StereoParams::kitti_at_scale(0.5) };
        let tracker_params = TrackerParams::default();
        let mut beside = FrontEnd::new(stereo_params, tracker_params, fb).unwrap();
        let (mut stereo, mut tracker) = (Stereo::new(stereo_params).unwrap(), Tracker::new(tracker_params));
        let mut sent = 0;
        for k in 0..sim.len() {
            let f = sim.frame(k).unwrap();
            let input = input_of(&f, &sim.camera).unwrap();
            let (DepthInput::Right(right), MaskInput::Labels(labels, classes)) = (&input.depth, &input.masks) else {
                panic!("a rendered frame has a right image and labels")
            };
            let depth = DepthMap::Stereo {
                disparity: stereo.disparity(&input.left, right).unwrap(),
                fb,
                pair: Some((input.left.clone(), right.clone())),
            };
            let inst =
                from_label_image(labels.clone(), |id| classes.get(&id).copied().unwrap_or(ObjectClass::Misc)).unwrap();
            let serial = tracker.process(&input.left, &depth, &inst).unwrap();
            let concurrent = beside.process(input).unwrap();
            assert_eq!(concurrent, serial, "frame {k}");
            sent += serial.len();
        }
        assert!(sent > 100, "{sent} tracks");
        assert_eq!(beside.times.concurrent_frames, sim.len());
        assert!(beside.times.wall > 0.0 && beside.times.fps() > 0.0);
    }

    #[test]
    fn points_matched_along_their_rows_get_the_dense_path_s_depths_without_a_dense_map() {
        let drive = generate(&DriveSpec { frames: 4, ..DriveSpec::default() });
        let sim = ImageSim::new(Camera::kitti(0.5), &drive.camera_poses, &LabelBox::of_drive(&drive), 1);
        let fb = sim.camera.fb() as f32;
        let dense_params = StereoParams::kitti_at_scale(0.5);
        let mut dense = FrontEnd::new(dense_params, TrackerParams::default(), fb).unwrap();
        let mut rows =
            FrontEnd::new(StereoParams { row_match: true, ..dense_params }, TrackerParams::default(), fb).unwrap();
        let (mut both, mut dense_only, mut errors) = (0, 0, Vec::new());
        for k in 0..sim.len() {
            let f = sim.frame(k).unwrap();
            let a = dense.process(input_of(&f, &sim.camera).unwrap()).unwrap();
            let b = rows.process(input_of(&f, &sim.camera).unwrap()).unwrap();
            for t in &a {
                match b.iter().find(|o| o.track_id == t.track_id && o.object_id == t.object_id) {
                    Some(o) => {
                        both += 1;
                        errors.push((fb / o.depth - fb / t.depth).abs());
                    }
                    None => dense_only += 1,
                }
            }
        }
        errors.sort_by(f32::total_cmp);
        let median = errors.get(errors.len() / 2).copied().unwrap_or(f32::NAN);
        assert!(both > 100 && both >= 2 * dense_only, "{both} tracks in both, {dense_only} in the dense path's only");
        assert!(median < 0.1, "median disparity difference {median} px over {both} tracks");
        assert!(
            rows.times.stereo < 0.1 * dense.times.stereo,
            "{} s against {} s",
            rows.times.stereo,
            dense.times.stereo
        );
    }
}
