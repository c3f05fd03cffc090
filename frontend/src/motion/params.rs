//! The motion segmentation's settings and their defaults (how they were chosen:
//! docs/decisions.md).

use dynotraj_core::wire::ObjectClass;

use crate::features::DetectParams;
use crate::klt::KltParams;

/// Settings of the motion segmentation.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct MotionParams {
    /// Probe corners held.
    pub probes: usize,
    /// Probe detection (spread on a grid).
    pub detect: DetectParams,
    /// Probe tracking: a smaller window and fewer iterations than the tracker's, since a
    /// probe only has to follow its corner for a few frames. On the training sequences 15
    /// pixels and 10 iterations tracked the probes in two thirds of the time of 21 and 30,
    /// with as many objects found (docs/decisions.md).
    pub klt: KltParams,
    /// Frames between the two positions a probe is judged on (fewer while it is younger).
    pub baseline_frames: usize,
    /// Frames of a second, longer baseline a probe is also judged on once it is that old (0:
    /// none, the default), under the camera's motion fitted directly between its ends: motion
    /// along the viewing ray, which an object driving ahead at the camera's speed mostly has,
    /// grows with the baseline while the stereo noise does not. On the training sequences 6
    /// frames gained about a point of recall for half a point of precision, and lost some of
    /// both on the synthetic drive (docs/decisions.md), so it is off.
    pub long_baseline_frames: usize,
    /// Standard deviation of a probe's image position, pixels.
    pub pixel_sigma: f32,
    /// Standard deviation of a probe's disparity, pixels.
    pub disparity_sigma: f32,
    /// A probe moves when its normalised residual exceeds this many standard deviations.
    pub moving_sigmas: f32,
    /// Farthest a probe is judged, metres (beyond, stereo cannot tell motion from noise).
    pub max_depth_m: f32,
    /// Largest gap between two probes of one object across the viewing ray, metres.
    pub link_m: f32,
    /// Fewest moving probes that make an object.
    pub min_points: usize,
    /// A box grows by this share of its size on each side.
    pub grow: f32,
    /// Frames an object must be found in a row before it is reported.
    pub confirm_frames: u32,
    /// The least box of a vehicle, width and height, metres at its depth (0: the probes' box
    /// as it is). The moving probes often hold only part of an object, its textured part or
    /// the part with depth, and a segment of a box around them covered less than half the
    /// object. On the training sequences 1.6 m x 1.2 m (a small car from behind, short of its
    /// roof) raised recall within 40 m by 2 points and the estimated source's instances on 0004
    /// and 0011 by 6 %, with precision within 40 m at 90 %; 2 m x 1.5 m found no more and lost a
    /// point of precision.
    pub min_vehicle_box_m: (f32, f32),
    /// The least box of a pedestrian, width and height, metres at its depth.
    pub min_pedestrian_box_m: (f32, f32),
    /// Frames a reported object that is not found is still reported, boxed around the probes
    /// it held while they are followed (0: none). Its id and its points downstream then
    /// survive the frames in which its probes lose their depth or their streak, where each gap
    /// ended the object's run (docs/decisions.md).
    pub coast_frames: u32,
    /// Frames in a row an object must have been found before it coasts: a false cluster at a
    /// depth edge, once reported, would be followed as faithfully as a car. On the training
    /// sequences 24 frames after 8 found raised recall within 40 m by 3 points for 1 of
    /// precision, and the estimated source's objects on 0004 and 0011 from 3 to 4 and their
    /// instances from 307 to 348; coasting every reported object lost 12 points of precision.
    pub coast_after_frames: u32,
    /// Frames a forgotten object waits for a new cluster where it would be to take its id back
    /// (0: never). It is then reported and coasted as a new object would be, so the segments
    /// are the same and only ids differ: on the training sequences 24 frames took id switches
    /// from 86 to 74. Downstream it keeps no more runs (on 0004 and 0011): the estimator holds a
    /// missing object for a few frames only, found again or not.
    pub reacquire_frames: u32,
    /// Frames a probe must be judged moving in a row before it counts as moving.
    pub probe_confirm_frames: u8,
    /// How far around a probe its depth must agree, pixels: at a depth edge a corner's depth
    /// is as often the other surface's.
    pub edge_radius_px: f32,
    /// How much the depth around a probe may differ from its own, as a share of it.
    pub edge_share: f32,
    /// Least length of the mean of a cluster's residual directions (1: all alike, 0: at
    /// random): the probes of one rigid object disagree with the camera's motion alike, noise
    /// does not.
    pub min_coherence: f32,
    /// Probes added in the box of each cluster of moving probes whose directions agree, until
    /// it holds this many (0: none, the default): an object with few probes is rarely found,
    /// and the grid spreads probes evenly over the image, however small the object. On the
    /// training sequences 30 gained 3 points of recall and lost 8 of precision: probes added
    /// around a false cluster keep it moving (docs/decisions.md), so it is off.
    pub dense_probes: usize,
    /// Spacing of the grid of samples judged on dense optical flow instead of the probes,
    /// pixels (0: the probes, the default). The probes still give the camera's motion. On the
    /// training sequences a 6-pixel grid found objects two frames sooner but no more of them,
    /// and the flow's errors at the static scene's edges formed false objects (precision 85 %
    /// at 6 standard deviations, against the probes' 97 % at 4), at 2.5 times the probes' cost
    /// (docs/decisions.md), so it is off.
    pub dense_step_px: usize,
    /// Standard deviation of a sample's position followed back through the flow, pixels.
    pub flow_sigma_px: f32,
    /// Farthest a flow step may miss its way back (forth after back), pixels: beyond, the
    /// pixel was occluded or the flow is wrong there.
    pub flow_check_px: f32,
    /// Fewest moving samples that make an object, with the dense flow.
    pub dense_min_samples: usize,
    /// How far around a probe its depth hypotheses are looked for, pixels (0: none, the
    /// default, and the edge test drops probes at depth edges instead): a probe is moving only
    /// if no pair of its own, the nearest and the farthest depth around it, then and now,
    /// explains its motion. On all frames of the training sequences 4 pixels gained 0.6 points
    /// of recall within 40 m for 1.4 of precision, and at 3 standard deviations 3.2 for 7.4
    /// (docs/decisions.md), so it is off.
    pub depth_hypotheses_px: f32,
}

impl MotionParams {
    /// Observations a probe keeps: enough for the longer baseline.
    pub(super) const fn history(&self) -> usize {
        if self.long_baseline_frames > self.baseline_frames {
            self.long_baseline_frames + 1
        } else {
            self.baseline_frames + 1
        }
    }

    /// The least box of an object of `class`, width and height, metres.
    #[must_use]
    pub fn min_box_m(&self, class: ObjectClass) -> (f32, f32) {
        if class == ObjectClass::Pedestrian { self.min_pedestrian_box_m } else { self.min_vehicle_box_m }
    }
}

impl Default for MotionParams {
    fn default() -> Self {
        Self {
            probes: 1500,
            detect: DetectParams { grid_cols: 16, grid_rows: 4, min_distance: 7.0, quality: 0.005 },
            klt: KltParams { window: 15, iterations: 10, ..KltParams::default() },
            baseline_frames: 3,
            long_baseline_frames: 0,
            pixel_sigma: 0.5,
            disparity_sigma: 0.5,
            moving_sigmas: 4.0,
            max_depth_m: 80.0,
            link_m: 1.5,
            min_points: 5,
            grow: 0.2,
            confirm_frames: 2,
            min_vehicle_box_m: (1.6, 1.2),
            min_pedestrian_box_m: (0.6, 1.6),
            coast_frames: 24,
            coast_after_frames: 8,
            reacquire_frames: 24,
            probe_confirm_frames: 2,
            edge_radius_px: 2.0,
            edge_share: 0.1,
            min_coherence: 0.7,
            dense_probes: 0,
            dense_step_px: 0,
            flow_sigma_px: 0.5,
            flow_check_px: 2.0,
            dense_min_samples: 8,
            depth_hypotheses_px: 0.0,
        }
    }
}
