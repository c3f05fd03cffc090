//! Parameters of the estimator: camera model, robust-fit budgets and thresholds, smoother noise.
//!
//! Every value is documented with its unit and why it has its default. The defaults suit a
//! KITTI-like stereo rig (fx about 720 px, baseline x focal about 388 px m) at 10 Hz.

/// Default Gauss-Seidel sweeps per frame (objects then camera), before the final object solve
/// ([`EstimatorParams::joint_sweeps`]; docs/results.md has the figures per setting).
pub const JOINT_SWEEPS: usize = 6;

use super::bev_track::BevTrackParams;

/// Pinhole intrinsics of the reference (left) camera, plus the stereo constant that turns depth
/// into disparity.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Intrinsics {
    /// Focal length along u, pixels.
    pub fx: f32,
    /// Focal length along v, pixels.
    pub fy: f32,
    /// Principal point u, pixels.
    pub cx: f32,
    /// Principal point v, pixels.
    pub cy: f32,
    /// Stereo baseline times fx, pixel metres (disparity = `stereo_fb / depth`). Zero or less
    /// turns the disparity residual off (a depth sensor without a stereo noise model).
    pub stereo_fb: f32,
}

impl From<&crate::wire::CameraInfo> for Intrinsics {
    fn from(info: &crate::wire::CameraInfo) -> Self {
        Self { fx: info.fx, fy: info.fy, cx: info.cx, cy: info.cy, stereo_fb: info.stereo_fb }
    }
}

impl Intrinsics {
    /// KITTI 2011_09_26 rectified camera 0 (the calibration of tracking sequences 0000-0013).
    pub const KITTI_0926: Self = Self { fx: 721.5377, fy: 721.5377, cx: 609.5593, cy: 172.854, stereo_fb: 387.5744 };

    /// The camera-frame point (x right, y down, z forward, metres) of pixel (u, v) at `depth`.
    #[must_use]
    pub fn back_project(&self, u: f32, v: f32, depth: f32) -> [f32; 3] {
        crate::geometry::back_project([u, v], depth, [self.fx, self.fy], [self.cx, self.cy])
    }
}

/// Budget and thresholds of one robust fit (minimal-set RANSAC, then Gauss-Newton/LM).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FitParams {
    /// Most RANSAC hypotheses (3-point samples). The loop stops earlier once the standard
    /// bound log(1 - confidence) / log(1 - w^3) for the best inlier share w is met.
    pub ransac_iterations: u16,
    /// RANSAC stopping confidence, in (0, 1).
    pub confidence: f32,
    /// Inlier threshold on a point's stereo reprojection residual norm (u, v, u_right), pixels.
    pub inlier_px: f32,
    /// Fewest inliers for a fit to count; fewer means the fit fails and the motion is held.
    pub min_inliers: u16,
    /// Levenberg-Marquardt iterations after RANSAC (each solves one 6x6 system; the source-depth
    /// corrections converge in about 8 when the object is far and its depths noisy).
    pub refine_iterations: u8,
    /// Huber kernel width on the residual norm, pixels: quadratic below, linear above.
    pub huber_px: f32,
    /// Lower bound of the residual standard deviation used to weight a fit's information,
    /// pixels: the a-posteriori scale of a lucky, tiny residual would otherwise overstate it.
    pub min_sigma_px: f32,
    /// Largest plausible rotation between consecutive frames, radians: a fit turning more is
    /// rejected (a wrong minimal set can fit a few nearly collinear points with a flipped pose).
    pub max_rotation: f32,
    /// Largest plausible translation between consecutive frames, metres.
    pub max_translation: f32,
    /// Disparity error shared by every point of one fit, pixels (a surface's stereo bias from
    /// one frame to the next): averaging over points does not remove it, so it puts a floor
    /// under the fit's depth uncertainty, `depth^2 * this / (f b)` along the viewing ray of the
    /// fitted frame's origin. 0 leaves the information as the points give it.
    pub shared_disparity_px: f32,
}

/// Noise of the constant-motion prior between consecutive body-frame motions (one frame
/// apart): how much the per-frame motion may change from one frame to the next.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct SmootherParams {
    /// Standard deviation of the change of the per-frame translation, metres.
    pub sigma_translation: f32,
    /// Standard deviation of the change of the per-frame rotation, radians.
    pub sigma_rotation: f32,
}

/// How a road vehicle moves in its own frame (x along its heading, y down, z to its side): per
/// frame, hardly sideways or vertically, and hardly rolling or pitching. A prior on each body
/// motion of a vehicle whose heading is known, with mean zero on those components.
///
/// Why: the fitted motions of a far object are noisy in rotation, and their yaw integrates into
/// a heading that wanders away from the direction it travels (measured on rendered KITTI 0004: a
/// car 40-48 m ahead for 300 frames drifted to 0.8 rad from its path, its relative-pose error
/// 1.3 m per frame). A car cannot crab, so its direction of travel pins its heading.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct KinematicPrior {
    /// Standard deviation of the sideways and vertical translation per frame, metres: the box
    /// centre of a car turning at 0.3 rad/s slides about 0.04 m a frame at 10 Hz.
    pub sigma_side_m: f32,
    /// Standard deviation of roll and pitch per frame, radians.
    pub sigma_tilt_rad: f32,
}

impl KinematicPrior {
    /// Road vehicles at KITTI's frame rate.
    pub const ROAD_VEHICLE: Self = Self { sigma_side_m: 0.05, sigma_tilt_rad: 0.005 };

    /// The prior's diagonal information on a body twist `[rho; omega]`.
    #[must_use]
    pub fn information(&self) -> [f32; 6] {
        let inv = |s: f32| if s > 0.0 && s.is_finite() { 1.0 / (s * s) } else { 0.0 };
        let (side, tilt) = (inv(self.sigma_side_m), inv(self.sigma_tilt_rad));
        [0.0, side, side, tilt, 0.0, tilt]
    }
}

impl SmootherParams {
    /// DynoSAM's smoothing factor between consecutive object motions: rotation 0.01 rad,
    /// translation 0.2 m (docs/decisions.md, "DynoSAM's noise values"). DynoSAM applies it to
    /// world-frame motions, whose translation also moves with the rotation's lever arm, hence
    /// its looseness.
    pub const DYNOSAM_OBJECT: Self = Self { sigma_translation: 0.2, sigma_rotation: 0.01 };
    /// This estimator's default for objects: body-frame motions, whose change per frame is the
    /// vehicle's own dynamics: 0.02 m (2 m/s^2 at 10 Hz) and 0.002 rad (0.2 rad/s^2 of yaw
    /// acceleration at 10 Hz). On the KITTI-driven simulator (`dynotraj estimate`) it gives
    /// smoothed object RPE 0.110 m / 0.37 deg against 0.138 m / 0.49 deg with DynoSAM's values,
    /// and speeds that change 0.17 m/s per frame instead of 1.1 (the labels: 0.62).
    pub const VEHICLE_OBJECT: Self = Self { sigma_translation: 0.02, sigma_rotation: 0.002 };
}

/// Largest plausible rotation of a road user or the ego vehicle between frames: 0.3 rad is
/// 3 rad/s at 10 Hz, beyond any vehicle's yaw rate.
pub const PLAUSIBLE_ROTATION: f32 = 0.3;
/// Largest plausible translation between frames: 5 m is 50 m/s (180 km/h) at 10 Hz.
pub const PLAUSIBLE_TRANSLATION: f32 = 5.0;

/// A vehicle's frame whose measured travel leaves its x axis by more than this is turned onto
/// it (radians): a quarter turn, so only a frame pointing backwards is. The first heading comes
/// from a 0.5-2 m baseline; for an object approaching along the viewing ray at range that
/// baseline is within the depth noise and the frame can start reversed, which reverses every
/// motion read in it (on the renderings, 15 % of the object pairs RPE scores and two thirds of
/// its squared error). A smaller bound also chases the noise of a 2 m baseline
/// (docs/decisions.md "Reversed object frames").
pub const REALIGN_REVERSED_RAD: f32 = core::f32::consts::FRAC_PI_2;

/// All parameters of the [`super::Estimator`].
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct EstimatorParams {
    /// Camera model.
    pub intrinsics: Intrinsics,
    /// Frame period used when two timestamps are unusable (equal, decreasing or more than
    /// [`EstimatorParams::max_dt`] apart), seconds.
    pub nominal_dt: f32,
    /// Longest plausible time between frames, seconds.
    pub max_dt: f32,
    /// Nearest usable depth, metres; closer or non-positive depths are rejected.
    pub min_depth: f32,
    /// Farthest usable depth, metres. Stereo depth noise grows with depth squared (about 5 m
    /// per point at 60 m on KITTI's rig, half a pixel of disparity noise) and the point model
    /// weighs each point by it, so far points add little information but keep an object (or,
    /// on an open road, the camera) measured at all: with 40 m, rendered KITTI lost most objects
    /// until they came within 40 m and 0001's camera had too few static points (docs/results.md).
    pub max_depth: f32,
    /// Standard deviation of pixel positions, pixels (the residual weights).
    pub pixel_sigma: f32,
    /// Standard deviation of stereo disparity, pixels.
    pub disparity_sigma: f32,
    /// Ego-motion fit from static tracks.
    pub camera_fit: FitParams,
    /// Object-motion fit from an object's tracks.
    pub object_fit: FitParams,
    /// Fewest tracked points for an object to be initialised or measured.
    pub object_min_points: u16,
    /// An object's heading is taken from its motion once its reference point has moved this far
    /// on the bird's-eye plane, metres; before that its frame keeps the world's orientation.
    /// The heading error is about the position noise over this distance, and every later
    /// relative pose of the object is seen through it, so 2 m (two frames of a car at 10 Hz):
    /// about 1 degree for 3 cm of position noise.
    pub heading_baseline_m: f32,
    /// The wait for a heading is bounded: once a run has this many frames, a displacement of
    /// [`EstimatorParams::heading_min_baseline_m`] is enough (a slow object, 0.1 m a frame,
    /// would otherwise wait 20 frames for 2 m and lose them all from its trajectory).
    pub heading_max_wait_frames: u8,
    /// The least displacement a heading is taken from after the bounded wait, metres: the
    /// heading error is then about 3 degrees for 3 cm of position noise.
    pub heading_min_baseline_m: f32,
    /// Once its heading is known, a vehicle's frame is turned onto its measured direction of
    /// travel (over `heading_baseline_m`) when the two differ by more than this, radians; `None`
    /// keeps the first heading. The default, [`REALIGN_REVERSED_RAD`], turns only a frame that
    /// points backwards.
    pub heading_realign_rad: Option<f32>,
    /// Fuse an object's points into its landmarks at the pose its fit found (true) rather than
    /// at the smoother's pose (false, the default): the smoother's pose lags a changing motion
    /// and landmarks fused there carry the lag into later fits, but fits fused as they are cost
    /// coverage (docs/decisions.md "Following the object").
    pub fuse_at_fit: bool,
    /// The bird's-eye track a causal estimate reports (position, speed, heading): a filter
    /// fusing the centroid of the object's points with its motion's velocity
    /// ([`super::bev_track`]); `None` reports the pose's origin and the motion's speed.
    pub bev_track: Option<BevTrackParams>,
    /// Constant-motion prior of the object smoother.
    pub object_smoother: SmootherParams,
    /// Constant-motion prior of the camera smoother.
    pub camera_smoother: SmootherParams,
    /// The motion prior of vehicles (not pedestrians) once their heading is known; `None`
    /// turns it off.
    pub vehicle_kinematics: Option<KinematicPrior>,
    /// Block Gauss-Seidel sweeps of the joint camera-object solve per frame
    /// ([`super::joint`]; default [`JOINT_SWEEPS`]). 0 turns the coupling off:
    /// objects are then smoothed against the frame-to-frame camera and the camera alone (the
    /// estimator before the joint solve, kept for comparison).
    pub joint_sweeps: u8,
}

impl EstimatorParams {
    /// Defaults for a KITTI-like stereo rig with `intrinsics`, frames `nominal_dt` apart.
    #[must_use]
    pub const fn kitti(intrinsics: Intrinsics, nominal_dt: f32) -> Self {
        Self {
            intrinsics,
            nominal_dt,
            max_dt: 1.0,
            min_depth: 0.5,
            max_depth: 80.0,
            pixel_sigma: 0.5,
            disparity_sigma: 0.5,
            camera_fit: FitParams {
                ransac_iterations: 64,
                confidence: 0.995,
                inlier_px: 3.0,
                min_inliers: 12,
                refine_iterations: 6,
                huber_px: 1.5,
                min_sigma_px: 0.3,
                max_rotation: PLAUSIBLE_ROTATION,
                max_translation: PLAUSIBLE_TRANSLATION,
                shared_disparity_px: 0.0,
            },
            object_fit: FitParams {
                ransac_iterations: 32,
                confidence: 0.995,
                inlier_px: 3.0,
                min_inliers: 6,
                refine_iterations: 10,
                huber_px: 1.5,
                min_sigma_px: 0.3,
                max_rotation: PLAUSIBLE_ROTATION,
                max_translation: PLAUSIBLE_TRANSLATION,
                shared_disparity_px: 0.0,
            },
            object_min_points: 6,
            heading_baseline_m: 2.0,
            heading_max_wait_frames: 5,
            heading_min_baseline_m: 0.5,
            heading_realign_rad: Some(REALIGN_REVERSED_RAD),
            fuse_at_fit: false,
            bev_track: Some(BevTrackParams::ROAD),
            object_smoother: SmootherParams::VEHICLE_OBJECT,
            // The ego vehicle's motion changes smoothly: 0.05 m and 0.005 rad per frame of change
            // (about 5 m/s^2 and 0.5 rad/s^2 at 10 Hz) are loose bounds on a car's dynamics.
            camera_smoother: SmootherParams { sigma_translation: 0.05, sigma_rotation: 0.005 },
            vehicle_kinematics: Some(KinematicPrior::ROAD_VEHICLE),
            joint_sweeps: JOINT_SWEEPS as u8,
        }
    }
}
