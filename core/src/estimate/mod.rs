//! The DynoSAM-style estimator: camera ego-motion, world-centric object motion, object poses and
//! an incremental fixed-lag smoother, all in fixed memory with fixed iteration budgets.
//!
//! # Data flow per frame
//!
//! 1. **Assembly** ([`FrameAssembler`]): the [`crate::wire::FrameTracks`] parts of one frame
//!    are collected into fixed, id-sorted arrays (one static list, one list per object).
//! 2. **Ego-motion** (`camera::CameraTrack`): static tracks matched by id between frames k-1 and k;
//!    3-point TRIAD RANSAC (fixed budget, deterministic [`Pcg32`] seeded by the caller), then
//!    Levenberg-Marquardt on the stereo reprojection error `(u, v, disparity)` under a truncated
//!    Huber kernel. The fit's information (J^T W J over the a-posteriori residual variance) is
//!    the measurement of the camera motion.
//! 3. **Object motion** ([`ObjectRun`]): each object keeps its tracked points as landmarks in its
//!    own frame, running means over the frames they were seen in (`landmarks::Landmark`); the same
//!    robust fit between the landmarks and the object's tracks at frame k gives its pose at k,
//!    hence the body motion `delta_k = L_(k-1)^-1 L_k` and the world-centric motion
//!    `H_k = L_(k-1) delta_k L_(k-1)^-1` (DynoSAM's `H = X_k G^-1`), `L_k = H_k L_(k-1)`.
//!    Fitting against landmarks rather than frame k-1's raw points matters: a single stereo point
//!    30 m away is a metre off in depth, and noise in the source points both adds to every motion
//!    and shrinks fitted rotations (see [`fit`]). The first pose `L_0` comes from the object's
//!    own points, never from ground truth: origin at their robust centroid, world-aligned; once
//!    the object has moved `heading_baseline_m` (2 m), or `heading_min_baseline_m` (0.5 m) once
//!    its run has `heading_max_wait_frames` (5) frames, the frame is turned once, upright with x
//!    along the displacement (its heading), which starts a new output segment. Before that its
//!    heading is unknown (`heading_known == false`).
//! 4. **Smoothing** ([`ChainSmoother`], `path::SmoothedPath`): over the last `W` frames, per object
//!    (and for the camera), the body motions are estimated jointly from the per-frame
//!    measurements and a constant-motion prior between consecutive motions. DynoSAM's smoothing
//!    factor (0.01 rad, 0.2 m, on world-frame motions) was the starting point; on body-frame
//!    motions the vehicle's own dynamics give 0.002 rad and 0.02 m per frame
//!    ([`SmootherParams::VEHICLE_OBJECT`], the default; the figures are there). The normal
//!    equations are block-tridiagonal with 6x6 blocks and are solved exactly in O(W); a frame
//!    leaving the window is fixed and the information it carried is marginalised exactly into a
//!    prior on the next.
//!
//! The point measurements enter the smoother through each frame's Gaussian (Laplace) summary
//! rather than point by point: that is what makes the memory fixed (33 floats per chain and
//! frame instead of hundreds of points).
//! 5. **Joint solve** ([`joint`]): camera and object chains are refined together. Each object's
//!    fit is a measurement of `C_k^-1 L_k`, so its motion depends on the camera motion of the
//!    same frame, to first order `xi_k = z_k + B_k (c_k - c̄_k)`; block Gauss-Seidel
//!    ([`EstimatorParams::joint_sweeps`] sweeps, default [`joint::JOINT_SWEEPS`]) over exact
//!    chain solves converges to the joint optimum of the window in fixed memory. Objects are
//!    measured against the camera's current estimate moved by the newest ego-motion. With
//!    `joint_sweeps = 0` the camera and each object are smoothed apart (objects against the
//!    frame-to-frame camera), as before the joint solve.
//!
//! # Outputs ([`PoseEstimate`], labelled as the wire's [`crate::wire::EstimateKind`])
//!
//! - frame-to-frame ([`Estimator::frame_to_frame`]): DynoSAM's front-end estimate, causal;
//! - causal ([`Estimator::causal`]): from frames up to the newest only
//!   ([`crate::wire::EstimateKind::Causal`]); each object's pose is its filtered trajectory,
//!   extended by the newest motion as the smoother sees it then and never revised, and the
//!   camera is its current estimate, the pose the objects were placed against (a chain of the
//!   camera's newest motions drifts away from that world and would misplace every object
//!   relative to the vehicle);
//! - smoothed ([`Estimator::smoothed`]): a frame as it leaves the window, having seen `W - 1`
//!   later frames ([`crate::wire::EstimateKind::Smoothed`]); never a forecast input.
//!
//! Each gives the camera pose, object poses and world motions and a bird's-eye state per object
//! (x, y, heading, speed, heading rate); the causal one's bird's-eye position, speed and
//! heading come from the object's [`bev_track`] (its points' centroid fused with its motion's
//! velocity) when [`EstimatorParams::bev_track`] is set, the default;
//! [`Estimator::map_points`] gives the bounded map of the
//! newest frame's static points.
//!
//! # Conventions
//!
//! World = the first camera frame, camera convention (x right, y down, z forward). Bird's-eye
//! plane = world (x, z), z-up after DynoSAM's `(x, y, z) -> (x, z, -y)`, as
//! [`crate::geometry::bev_point`]; heading is counter-clockwise from world x seen from above,
//! as [`crate::geometry::bev_heading_of_rotation_y`]. Twists are `[rho; omega]`, body motions
//! are perturbed on the right.
//!
//! # Bad input: rules (each counted in [`EstimatorStats`], never a panic)
//!
//! | input | rule | counter |
//! |---|---|---|
//! | depth zero, negative, non-finite or below `min_depth` | skip the track | `tracks_bad_depth` |
//! | depth beyond `max_depth` | skip the track | `tracks_too_far` |
//! | pixel non-finite or outside [0, 4096) px | skip the track | `tracks_bad_pixel` |
//! | track id repeated in a frame (static list or one object) | keep one, the smallest by (pixel, depth), whatever the arrival order | `tracks_duplicate` |
//! | more than 256 static / 128 per-object tracks | drop the excess (arrival order; repeated ids count until the frame completes) | `static_tracks_dropped`, `object_points_dropped` |
//! | more than 16 objects in a frame | drop the later objects' tracks (the sender orders by priority) | `object_tracks_dropped`, `frames_with_objects_dropped` |
//! | fewer static matches than `min_inliers`, or RANSAC/LM fails | hold the previous ego-motion; the smoother gets no measurement | `camera_motion_held` |
//! | fewer object matches than `object_min_points`, or the fit fails | hold the previous object motion; after [`MAX_HELD_FRAMES`] consecutive holds the run ends | `object_motion_held`, `runs_ended_fit_failed` |
//! | an object's tracks beyond `max_depth` | the object is out of range: held as a failed fit | `tracks_too_far`, `runs_ended_out_of_range` |
//! | object with fewer than `object_min_points` points when first seen | not initialised; tried again next frame | `objects_not_initialised` |
//! | tracking object missing from a frame | it coasts on its last motion (no measurement) for up to [`MAX_HELD_FRAMES`] frames and resumes when seen again; after that its run ends (its window frames up to the last measured one are still emitted smoothed) and on return it is re-initialised from its points | `object_frames_coasted`, `objects_resumed`, `runs_ended_lost`, `objects_returned`, `objects_initialised` |
//! | a new object with every run slot in use | evict the ended run with the fewest frames still to emit | `runs_evicted`, `smoothed_frames_lost` |
//! | parts: malformed, repeated, stale, or a newer frame before completion | reject / ignore / abandon the incomplete frame | `parts_*`, `frames_incomplete` |
//! | timestamps equal, decreasing or over `max_dt` apart | use `nominal_dt` for speeds | `timestamps_replaced` |
//! | singular or non-finite normal equations | hold | `numerical_failures` |

pub mod bev_track;
mod camera;
mod estimator;
pub mod fit;
pub mod frame;
pub mod joint;
pub mod landmarks;
mod lie;
mod matching;
mod measure;
mod motion_smoother;
mod object_run;
mod output;
mod params;
mod path;
mod point_model;
pub mod profile;
mod rng;
mod stats;
mod triad;

pub use bev_track::{BevTrack, BevTrackParams};
pub use estimator::{Estimator, Pushed};
pub use fit::fit_pose;
pub use frame::{FrameAssembler, FrameBuffer, MAX_PIXEL, ObjectPoints, Obs};
pub use landmarks::Landmarks;
pub use lie::{ad_matrix, adjoint};
pub use motion_smoother::{ChainScratch, ChainSmoother, Smoothness};
pub use object_run::{MAX_HELD_FRAMES, NewestFit, ObjectRun, moves_like_a_vehicle};
pub use output::{ObjectEstimate, PoseEstimate, bev_heading};
pub use params::{EstimatorParams, FitParams, Intrinsics, KinematicPrior, REALIGN_REVERSED_RAD, SmootherParams};
pub use point_model::{Correspondence, PointModel};
pub use profile::{DEFAULT_WINDOW, EDGE_PROFILE, EDGE_WINDOW, EstimatorProfile, HOST_PROFILE, PROFILES};
pub use rng::Pcg32;
pub use stats::EstimatorStats;
pub use triad::rigid_from_three;
