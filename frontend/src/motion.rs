//! Moving objects found by geometry alone (motion segmentation from stereo scene flow), for
//! drives that carry no masks, boxes or detections.
//!
//! Probe corners are followed over the left images (KLT with the forward-backward check) and
//! given depth from the frame's depth map. The camera's motion between consecutive frames is the
//! robust fit of the probes ([`dynotraj_core::estimate::fit_pose`]): the static scene is the
//! majority. A probe is moving when its position now disagrees with where the camera's motion
//! over the last [`MotionParams::baseline_frames`] frames puts its position then, by more than
//! [`MotionParams::moving_sigmas`] standard deviations of the stereo point model: across the
//! viewing ray in pixels, along it in disparity, so that far points, whose depth is poor, are
//! judged on what their stereo can tell. A longer baseline lets slow and along-the-ray motion
//! grow above the noise, which does not grow with it.
//!
//! Moving probes are linked in 3D (across the ray within [`MotionParams::link_m`], along it
//! within that plus the stereo depth error) into clusters; a cluster of at least
//! [`MotionParams::min_points`] probes is an object. Its id is the one most of its probes had in
//! the previous frame, else a fresh one; its class (pedestrian or car) is read from its size and
//! kept by its id. An object found for long that is then missed is followed on the probes it
//! held for up to [`MotionParams::coast_frames`] frames (`coast`). Each object becomes a box
//! around its probes, grown by [`MotionParams::grow`] and to at least its class's size at its
//! depth ([`MotionParams::min_box_m`]), which [`super::masks::from_boxes`] then turns into a
//! mask by depth consistency, as for detector boxes.

use std::collections::{BTreeMap, VecDeque};

use dynotraj_core::estimate::fit::FitFailure;
use dynotraj_core::estimate::{Correspondence, EstimatorParams, Intrinsics, Pcg32, PointModel, fit_pose};
use dynotraj_core::geometry::Pose3;
use dynotraj_core::wire::ObjectClass;
use opencv::core::{CV_8UC1, Mat, Point2f, Scalar};
use opencv::prelude::*;

use super::depth::DepthMap;
use super::error::{FrontEndError, cv};
use super::features::{DetectParams, detect};
use super::klt::{Pyramid, Tracked, track};
use super::masks::Detection;
use super::stats::FrontEndStats;

mod cluster;
mod coast;
mod dense;
mod one_ended;
mod params;
mod reacquire;
mod residual;
use cluster::{Extent, class_of, clusters, coherent, grown_box};
pub use one_ended::{OneEndedCorner, OneEndedSegments, segments_one_ended};
pub use params::MotionParams;
use residual::{least_residual, normalised_residual, step};

/// A probe judged in the last frame: where it is, how deep, and its residual against the
/// camera's motion, pixels (the disparity part scaled as the point model does).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Judged {
    /// Pixel column.
    pub u: f32,
    /// Pixel row.
    pub v: f32,
    /// Depth, metres.
    pub depth: f32,
    /// Residual across the viewing ray (image), pixels.
    pub across_px: f32,
    /// Residual along it (disparity, scaled), pixels.
    pub along_px: f32,
    /// The residual in standard deviations (Mahalanobis distance under both observations'
    /// noise).
    pub sigmas: f32,
}

/// What became of a probe in the last frame.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord)]
pub enum Fate {
    /// No depth (none in the map, or at a depth edge), now or back then, or beyond the range.
    NoDepth,
    /// Seen in one frame only since the camera's motion was last lost.
    Young,
    /// Judged static.
    Static,
    /// Judged moving, not yet in enough frames in a row.
    Unconfirmed,
    /// Moving, in no cluster large enough.
    Unclustered,
    /// Moving, in an object.
    InObject,
}

/// One observation of a probe: pixel and depth (when the map has one).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Seen {
    u: f32,
    v: f32,
    /// Depth, metres, when the map has one there and the depth around agrees with it
    /// ([`smooth_depth`]), or with [`MotionParams::depth_hypotheses_px`] wherever it has one.
    depth: Option<f32>,
    /// With [`MotionParams::depth_hypotheses_px`], the nearest and farthest depths around:
    /// near a depth edge, the surfaces the stereo may have given the probe.
    around: Option<(f32, f32)>,
}

impl Seen {
    /// The observation at `(u, v)` in `depth`.
    fn observe(depth: &DepthMap, u: f32, v: f32, p: &MotionParams) -> Self {
        let r = p.depth_hypotheses_px;
        if r <= 0.0 {
            return Self { u, v, depth: smooth_depth(depth, u, v, p), around: None };
        }
        let z = depth.at(u, v);
        let mut range = z.map(|z| (z, z));
        for (du, dv) in [(-r, -r), (0.0, -r), (r, -r), (-r, 0.0), (r, 0.0), (-r, r), (0.0, r), (r, r)] {
            if let (Some((lo, hi)), Some(n)) = (&mut range, depth.at(u + du, v + dv)) {
                *lo = lo.min(n);
                *hi = hi.max(n);
            }
        }
        Self { u, v, depth: z, around: range }
    }
}

/// The depth of `depth` at `(u, v)` where the depth around it agrees ([`Seen::depth`]): within
/// `p.edge_share` of it at the eight pixels `p.edge_radius_px` away that have a depth.
fn smooth_depth(depth: &DepthMap, u: f32, v: f32, p: &MotionParams) -> Option<f32> {
    let z = depth.at(u, v)?;
    let r = p.edge_radius_px;
    for (du, dv) in [(-r, -r), (0.0, -r), (r, -r), (-r, 0.0), (r, 0.0), (-r, r), (0.0, r), (r, r)] {
        if depth.at(u + du, v + dv).is_some_and(|n| (n - z).abs() > p.edge_share * z) {
            return None;
        }
    }
    Some(z)
}

/// A probe corner with its recent observations, newest last.
#[derive(Debug, Clone)]
struct Probe {
    seen: VecDeque<Seen>,
    /// The object it belonged to in the previous frame.
    object: Option<u16>,
    /// Frames in a row it was judged moving, up to now.
    streak: u8,
}

/// An object the segmentation follows.
#[derive(Debug, Clone, Copy)]
struct Followed {
    class: ObjectClass,
    /// Frames in a row it was found, up to its last find (coasting keeps it).
    streak: u32,
    /// Frames since it was last found (0: found this frame).
    missed: u32,
    /// Where it is, once found.
    place: Option<reacquire::Place>,
}

/// The motion segmentation's state between frames.
#[derive(Debug)]
pub struct MotionSegmenter {
    params: MotionParams,
    previous: Option<Pyramid>,
    probes: Vec<Probe>,
    /// Camera motions `T_{k, k-1}` of the last frames, newest last.
    motions: VecDeque<Pose3>,
    objects: BTreeMap<u16, Followed>,
    /// Objects forgotten lately, which a new cluster where they would be takes the id of.
    lost: Vec<reacquire::Lost>,
    next_id: u16,
    rng: Pcg32,
    /// The probes judged in the last frame.
    pub judged: Vec<Judged>,
    /// Every probe of the last frame: its pixel and fate.
    pub fates: Vec<(f32, f32, Fate)>,
    /// The boxes of the last frame's clusters of moving probes, where probes are added.
    cluster_boxes: Vec<[f32; 4]>,
    /// The dense flow's history, with [`MotionParams::dense_step_px`].
    dense: Option<dense::DenseFlow>,
    /// The last frame's dense samples, row by row: 0 static or unjudged, [`dense::MOVING`]
    /// moving, else the id of the object they were in.
    dense_labels: Vec<u16>,
}

/// Fresh ids start here, apart from the ids labels give (KITTI track id + 1) and from those of
/// [`super::masks::IdAssigner`].
const FIRST_ID: u16 = 20_000;

impl MotionSegmenter {
    /// A segmenter with `params`, before its first frame.
    #[must_use]
    pub fn new(params: MotionParams) -> Self {
        Self {
            params,
            previous: None,
            probes: Vec::new(),
            motions: VecDeque::new(),
            objects: BTreeMap::new(),
            lost: Vec::new(),
            next_id: FIRST_ID,
            rng: Pcg32::new(0x6d6f_7469_6f6e),
            judged: Vec::new(),
            fates: Vec::new(),
            cluster_boxes: Vec::new(),
            dense: None,
            dense_labels: Vec::new(),
        }
    }

    /// The moving objects of the frame `grey` with depth `depth`, seen by a camera with
    /// `intrinsics`, as boxes with their ids and classes.
    ///
    /// # Errors
    /// An OpenCV failure.
    pub fn objects(
        &mut self,
        grey: &Mat,
        depth: &DepthMap,
        intrinsics: &Intrinsics,
        stats: &mut FrontEndStats,
    ) -> Result<Vec<Detection>, FrontEndError> {
        let p = self.params;
        let pyramid = Pyramid::new(grey, &p.klt)?;
        if let Some(previous) = &self.previous {
            let points: Vec<Point2f> =
                self.probes.iter().filter_map(|q| q.seen.back().map(|s| Point2f::new(s.u, s.v))).collect();
            let moved = track(previous, &pyramid, &points, &p.klt)?;
            let mut kept = Vec::with_capacity(self.probes.len());
            for (mut probe, t) in std::mem::take(&mut self.probes).into_iter().zip(moved) {
                if let Tracked::At(at) = t {
                    probe.seen.push_back(Seen::observe(depth, at.x, at.y, &p));
                    while probe.seen.len() > p.history() {
                        probe.seen.pop_front();
                    }
                    kept.push(probe);
                }
            }
            self.probes = kept;
        }
        if p.dense_step_px > 0 {
            if self.dense.is_none() {
                self.dense = Some(dense::DenseFlow::new(dense::PRESET)?);
            }
            if let Some(flow) = &mut self.dense {
                flow.push(grey, depth, p.history())?;
            }
        }
        self.judged.clear();
        self.fates.clear();
        let size = (grey.cols(), grey.rows());
        let found = if self.previous.is_some() { self.segment(intrinsics, size, stats) } else { Vec::new() };
        self.replenish(grey, depth)?;
        self.densify(grey, depth)?;
        self.previous = Some(pyramid);
        Ok(found)
    }

    /// Fits the camera's motion, judges the probes and clusters the moving ones.
    fn segment(&mut self, intrinsics: &Intrinsics, size: (i32, i32), stats: &mut FrontEndStats) -> Vec<Detection> {
        let p = self.params;
        let mut params = EstimatorParams::kitti(*intrinsics, 0.1);
        params.pixel_sigma = p.pixel_sigma;
        params.disparity_sigma = p.disparity_sigma;
        let model = &PointModel::new(&params);
        let corrs: Vec<Correspondence> = self.probes.iter().filter_map(|q| step(q, 1, model)).collect();
        let fit_params = params.camera_fit;
        let guess = self.motions.back().copied();
        let motion = match fit_pose(&corrs, guess.as_ref(), &fit_params, model, &mut self.rng) {
            Ok(fit) => fit.pose,
            Err(FitFailure::TooFewPoints | FitFailure::TooFewInliers | FitFailure::Numerical) => {
                stats.motion_ego_failed += 1;
                self.motions.clear();
                for q in &mut self.probes {
                    q.seen.drain(..q.seen.len().saturating_sub(1));
                    q.object = None;
                }
                self.objects.clear();
                self.lost.clear();
                self.dense_labels.clear();
                if let Some(flow) = &mut self.dense {
                    flow.restart();
                }
                return Vec::new();
            }
        };
        self.motions.push_back(motion);
        self.advance_places(&motion);
        while self.motions.len() > p.history() - 1 {
            self.motions.pop_front();
        }
        // Camera motion from each of the last frames to now: `since[j - 1]` = T_{k, k-j}.
        let mut since = Vec::with_capacity(self.motions.len());
        let mut acc = Pose3::identity();
        for m in self.motions.iter().rev() {
            acc *= m;
            since.push(acc);
        }
        let long = self.long_motion(&since, model, &fit_params);
        since.truncate(p.baseline_frames);
        if self.dense.is_some() {
            return self.segment_dense(&since, model, intrinsics, size, stats);
        }
        let mut moving: Vec<(usize, nalgebra::Point3<f32>)> = Vec::new();
        let mut directions: Vec<nalgebra::Vector3<f32>> = Vec::new();
        // A probe not judged this frame starts its streak again.
        let mut streaks = vec![0u8; self.probes.len()];
        let mut fates = vec![Fate::NoDepth; self.probes.len()];
        for (i, q) in self.probes.iter().enumerate() {
            let Some(now) = q.seen.back() else { continue };
            let Some(z) = now.depth.filter(|z| *z <= p.max_depth_m) else { continue };
            let back = (q.seen.len() - 1).min(since.len());
            if back == 0
                && let Some(f) = fates.get_mut(i)
            {
                *f = Fate::Young;
            }
            let Some(pose) = back.checked_sub(1).and_then(|j| since.get(j)) else { continue };
            let Some(then) = q.seen.len().checked_sub(1 + back).and_then(|j| q.seen.get(j)) else { continue };
            let Some((short_r, short_m2)) = least_residual(model, pose, (then, now), intrinsics.stereo_fb, &p) else {
                continue;
            };
            // The longer baseline's verdict where the probe is old enough, the stronger of the two.
            let long_judged = long.as_ref().and_then(|(n, pose)| {
                let then = q.seen.len().checked_sub(1 + n).and_then(|j| q.seen.get(j))?;
                least_residual(model, pose, (then, now), intrinsics.stereo_fb, &p)
            });
            let (r, m2) = match long_judged {
                Some((r, m2)) if m2 > short_m2 => (r, m2),
                _ => (short_r, short_m2),
            };
            stats.motion_probes_judged += 1;
            self.judged.push(Judged {
                u: now.u,
                v: now.v,
                depth: z,
                across_px: r.x.hypot(r.y),
                along_px: r.z.abs(),
                sigmas: m2.sqrt(),
            });
            let is_moving = m2 > p.moving_sigmas * p.moving_sigmas;
            let streak = if is_moving { q.streak.saturating_add(1) } else { 0 };
            if let Some(slot) = streaks.get_mut(i) {
                *slot = streak;
            }
            if let Some(f) = fates.get_mut(i) {
                *f = if is_moving { Fate::Unconfirmed } else { Fate::Static };
            }
            if is_moving && streak >= p.probe_confirm_frames {
                stats.motion_probes_moving += 1;
                moving.push((i, model.back_project(now.u, now.v, z)));
                directions.push(r.try_normalize(1e-6).unwrap_or_else(nalgebra::Vector3::zeros));
                if let Some(f) = fates.get_mut(i) {
                    *f = Fate::Unclustered;
                }
            }
        }
        for (q, streak) in self.probes.iter_mut().zip(streaks) {
            q.streak = streak;
        }
        let clusters = clusters(&moving, model, p.link_m);
        self.cluster_boxes.clear();
        let mut out = Vec::new();
        let mut ids_now = Vec::new();
        let mut members_of: Vec<(u16, Vec<usize>)> = Vec::new();
        for members in clusters {
            let agree = coherent(&members, &directions, p.min_coherence);
            // A coherent cluster's extent, once: the dense probes' boxes and the objects share it.
            let probes: Vec<usize> = members.iter().filter_map(|&m| moving.get(m).map(|(i, _)| *i)).collect();
            let extent = if agree { self.extent(&probes, intrinsics) } else { None };
            if p.dense_probes > 0
                && let Some(extent) = &extent
            {
                self.cluster_boxes.push(extent.bbox);
            }
            if members.len() < p.min_points || !agree {
                stats.motion_probes_unclustered += members.len() as u64;
                continue;
            }
            let Some(extent) = extent else { continue };
            let centre: nalgebra::Point3<f32> =
                (members.iter().filter_map(|&m| moving.get(m)).map(|(_, x)| x.coords).sum::<nalgebra::Vector3<f32>>()
                    / members.len() as f32)
                    .into();
            let id = self.id_of(&probes, &ids_now, &centre, stats);
            ids_now.push(id);
            out.extend(self.follow(id, extent, intrinsics, stats));
            self.place_found(id, centre);
            members_of.push((id, probes));
        }
        // A probe keeps its object only while the object coasts: a found object's id goes to
        // its members alone (kept longer, the id drifts onto the static edges beside it).
        for q in &mut self.probes {
            if q.object.is_some_and(|id| ids_now.contains(&id)) {
                q.object = None;
            }
        }
        for (id, probes) in members_of {
            for i in probes {
                if let Some(q) = self.probes.get_mut(i) {
                    q.object = Some(id);
                }
                if let Some(f) = fates.get_mut(i) {
                    *f = Fate::InObject;
                }
            }
        }
        self.fates = self.probes.iter().zip(fates).filter_map(|(q, f)| q.seen.back().map(|s| (s.u, s.v, f))).collect();
        out.extend(self.coast(&ids_now, intrinsics, stats));
        out
    }

    /// The camera's motion over the longer baseline, fitted on the probes seen at both its
    /// ends (chained frame-to-frame motions would add up their errors), with its length.
    fn long_motion(
        &mut self,
        since: &[Pose3],
        model: &PointModel,
        fit_params: &dynotraj_core::estimate::FitParams,
    ) -> Option<(usize, Pose3)> {
        let n = self.params.long_baseline_frames;
        if n <= self.params.baseline_frames {
            return None;
        }
        let guess = since.get(n.checked_sub(1)?)?;
        let corrs: Vec<Correspondence> = self.probes.iter().filter_map(|q| step(q, n, model)).collect();
        fit_pose(&corrs, Some(guess), fit_params, model, &mut self.rng).ok().map(|fit| (n, fit.pose))
    }

    /// The id of the cluster of `probes` centred at `centre`: the one most of them had, when no
    /// cluster of this frame took it already, else a forgotten object's found again there
    /// ([`MotionParams::reacquire_frames`]), else a fresh one.
    fn id_of(
        &mut self,
        probes: &[usize],
        taken: &[u16],
        centre: &nalgebra::Point3<f32>,
        stats: &mut FrontEndStats,
    ) -> u16 {
        let mut votes: BTreeMap<u16, usize> = BTreeMap::new();
        for q in probes.iter().filter_map(|&i| self.probes.get(i)) {
            if let Some(id) = q.object {
                *votes.entry(id).or_default() += 1;
            }
        }
        if votes.keys().all(|id| taken.contains(id))
            && let Some(id) = self.reacquire(centre)
        {
            stats.motion_objects_reacquired += 1;
            return id;
        }
        self.id_by_votes(votes, taken)
    }

    /// The id most `votes` went to, when no cluster of this frame took it already, else a
    /// fresh one.
    fn id_by_votes(&mut self, votes: BTreeMap<u16, usize>, taken: &[u16]) -> u16 {
        let best = votes.into_iter().filter(|(id, _)| !taken.contains(id)).max_by_key(|&(id, n)| (n, u16::MAX - id));
        best.map_or_else(
            || {
                let id = self.next_id;
                self.next_id = self.next_id.checked_add(1).unwrap_or(FIRST_ID);
                id
            },
            |(id, _)| id,
        )
    }

    /// The grown box of `probes`, the object's width and height, metres, and its depth.
    fn extent(&self, probes: &[usize], intrinsics: &Intrinsics) -> Option<Extent> {
        let seen = probes.iter().filter_map(|&i| self.probes.get(i)?.seen.back().copied());
        grown_box(seen, self.params.grow, intrinsics)
    }

    /// Counts a cluster found this frame as object `id` at `extent`, and reports it once it was
    /// found in enough frames in a row, boxed at least as large as its class
    /// ([`MotionParams::min_box_m`]).
    fn follow(
        &mut self,
        id: u16,
        extent: Extent,
        intrinsics: &Intrinsics,
        stats: &mut FrontEndStats,
    ) -> Option<Detection> {
        let followed = self.objects.entry(id).or_insert(Followed {
            class: class_of(extent.size_m),
            streak: 0,
            missed: 0,
            place: None,
        });
        followed.streak += 1;
        followed.missed = 0;
        (followed.streak >= self.params.confirm_frames).then(|| {
            stats.motion_objects += 1;
            extent.reported(id, followed.class, &self.params, intrinsics)
        })
    }

    /// Probes added in each box of [`MotionSegmenter::cluster_boxes`] up to
    /// [`MotionParams::dense_probes`] in it.
    fn densify(&mut self, grey: &Mat, depth: &DepthMap) -> Result<(), FrontEndError> {
        let p = self.params;
        for b in std::mem::take(&mut self.cluster_boxes) {
            let inside = |s: &Seen| s.u >= b[0] && s.u <= b[2] && s.v >= b[1] && s.v <= b[3];
            let held = self.probes.iter().filter(|q| q.seen.back().is_some_and(inside)).count();
            let want = p.dense_probes.saturating_sub(held);
            if want == 0 {
                continue;
            }
            let mut allowed = Mat::new_rows_cols_with_default(grey.rows(), grey.cols(), CV_8UC1, Scalar::all(0.0))
                .map_err(cv("allocating a probe mask"))?;
            let (x0, y0) = (b[0].max(0.0) as i32, b[1].max(0.0) as i32);
            let (x1, y1) = ((b[2] as i32).min(grey.cols() - 1), (b[3] as i32).min(grey.rows() - 1));
            if x1 <= x0 || y1 <= y0 {
                continue;
            }
            opencv::imgproc::rectangle(
                &mut allowed,
                opencv::core::Rect::new(x0, y0, x1 - x0 + 1, y1 - y0 + 1),
                Scalar::all(255.0),
                opencv::imgproc::FILLED,
                opencv::imgproc::LINE_8,
                0,
            )
            .map_err(cv("drawing a probe mask"))?;
            let existing: Vec<Point2f> =
                self.probes.iter().filter_map(|q| q.seen.back().map(|s| Point2f::new(s.u, s.v))).collect();
            let dense = DetectParams { grid_cols: 1, grid_rows: 1, min_distance: 3.0, ..p.detect };
            let found = detect(grey, &allowed, &existing, want, &dense)?;
            self.probes.extend(found.points.into_iter().map(|at| Probe {
                seen: VecDeque::from([Seen::observe(depth, at.x, at.y, &p)]),
                streak: 0,
                object: None,
            }));
        }
        Ok(())
    }

    /// New probes where there are none, up to [`MotionParams::probes`].
    fn replenish(&mut self, grey: &Mat, depth: &DepthMap) -> Result<(), FrontEndError> {
        let want = self.params.probes.saturating_sub(self.probes.len());
        if want == 0 {
            return Ok(());
        }
        let allowed = Mat::new_rows_cols_with_default(grey.rows(), grey.cols(), CV_8UC1, Scalar::all(255.0))
            .map_err(cv("allocating a probe mask"))?;
        let existing: Vec<Point2f> =
            self.probes.iter().filter_map(|q| q.seen.back().map(|s| Point2f::new(s.u, s.v))).collect();
        let found = detect(grey, &allowed, &existing, want, &self.params.detect)?;
        let p = self.params;
        self.probes.extend(found.points.into_iter().map(|at| Probe {
            seen: VecDeque::from([Seen::observe(depth, at.x, at.y, &p)]),
            streak: 0,
            object: None,
        }));
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::motion_scores::MotionScores;
    use crate::rendered::track_motion_scored;
    use crate::{StereoParams, TrackerParams};
    use dynotraj_sim::drive::{DriveSpec, generate};
    use dynotraj_sim::image_sim::{Camera, ImageSim};
    use dynotraj_sim::track_sim::{LabelBox, moving_objects};

    #[test]
    fn the_synthetic_drive_s_moving_objects_are_found_and_the_static_scene_is_not() {
        let drive = generate(&DriveSpec { frames: 16, ..DriveSpec::default() });
        let sim = ImageSim::new(Camera::kitti(1.0), &drive.camera_poses, &LabelBox::of_drive(&drive), 1);
        let moving = moving_objects(sim.truth.iter().map(Vec::as_slice), 0.1);
        assert!(!moving.is_empty(), "the drive has moving objects");
        let stereo = StereoParams { downscale: 2, ..StereoParams::kitti_at_scale(1.0) };
        // The default, and with the longer baseline (judged on probes at least 7 frames old) and
        // probes added around motion.
        let both = MotionParams { long_baseline_frames: 6, dense_probes: 30, ..MotionParams::default() };
        // Samples on the dense flow in place of the probes.
        let dense = MotionParams { dense_step_px: 6, moving_sigmas: 6.0, ..MotionParams::default() };
        // Depth hypotheses around each probe in place of the edge test.
        let hypotheses = MotionParams { depth_hypotheses_px: 4.0, ..MotionParams::default() };
        for motion in [MotionParams::default(), both, dense, hypotheses] {
            let mut scores = MotionScores::default();
            let tracked =
                track_motion_scored(&sim, sim.len(), (stereo, TrackerParams::default(), motion), 0.1, &mut scores)
                    .unwrap();
            let recall = scores.recall_within(80.0).unwrap_or(0.0);
            let precision = scores.precision_within(80.0).unwrap_or(0.0);
            eprintln!(
                "long baseline {}, dense probes {}, dense flow step {}, depth hypotheses {}: recall {recall:.3}, \
                 precision {precision:.3}",
                motion.long_baseline_frames, motion.dense_probes, motion.dense_step_px, motion.depth_hypotheses_px
            );
            assert!(recall >= 0.5 && precision >= 0.7, "recall {recall:.3}, precision {precision:.3}");
            assert!(
                tracked.frames.iter().flat_map(|f| &f.tracks).any(|t| t.object_id != 0),
                "objects reach the tracks"
            );
        }
    }
}
