//! Dense motion evidence: optical flow over the whole left image (DIS), so that an object is
//! judged on samples spread over its pixels rather than on the corners it happens to carry.
//!
//! Every frame, the flow to the previous frame and back is computed; a sample on a regular grid
//! is followed back through the flows (each step checked forward and backward, so that pixels
//! that an edge occludes drop out) for up to the baseline's frames, and judged against the
//! camera's motion as a probe is. Far and young objects carry few corners; their pixels are
//! sampled all the same.

use std::collections::{BTreeMap, VecDeque};

use dynotraj_core::estimate::{Intrinsics, PointModel};
use dynotraj_core::geometry::Pose3;
use opencv::core::{Mat, Ptr, Vec2f};
use opencv::prelude::*;
use opencv::video::DISOpticalFlow;

use super::super::depth::DepthMap;
use super::super::error::{FrontEndError, cv};
use super::super::masks::Detection;
use super::super::stats::FrontEndStats;
use super::cluster::{clusters, coherent, grown_box};
use super::{FIRST_ID, Fate, Judged, MotionParams, MotionSegmenter, Seen, normalised_residual, smooth_depth};

/// DIS's preset: the slowest and most accurate of OpenCV's three (on the training sequences
/// `PRESET_FAST`'s static pixels reached 27 standard deviations at the 99th percentile within
/// 20 m, `PRESET_MEDIUM`'s 8: docs/decisions.md).
pub(super) const PRESET: i32 = opencv::video::DISOpticalFlow_PRESET_MEDIUM;

/// A sample's label in [`MotionSegmenter::dense_labels`] when it moved but was in no object.
pub(super) const MOVING: u16 = 1;

/// One frame of the flow's history.
#[derive(Debug)]
struct FlowFrame {
    depth: DepthMap,
    /// Flow from this frame to the one before (`CV_32FC2`), and from that one to this.
    flows: Option<(Mat, Mat)>,
}

/// A sample of the current frame followed back `positions.len() - 1` frames.
#[derive(Debug, Clone, PartialEq)]
pub(super) struct Traced {
    /// Its pixel in this frame and the frames before, newest first.
    pub positions: Vec<(f32, f32)>,
}

/// The dense flow's state between frames.
pub(super) struct DenseFlow {
    dis: Ptr<DISOpticalFlow>,
    previous_grey: Option<Mat>,
    frames: VecDeque<FlowFrame>,
}

impl std::fmt::Debug for DenseFlow {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("DenseFlow").field("frames", &self.frames.len()).finish_non_exhaustive()
    }
}

/// The depth of a map without what only point refinement needs (the grey pair).
fn depth_only(depth: &DepthMap) -> DepthMap {
    match depth {
        DepthMap::Stereo { disparity, fb, .. } => {
            DepthMap::Stereo { disparity: disparity.clone(), fb: *fb, pair: None }
        }
        other => other.clone(),
    }
}

/// The flow at the pixel nearest `(u, v)`.
fn flow_at(flow: &Mat, u: f32, v: f32) -> Option<(f32, f32)> {
    let (x, y) = (u.round() as i32, v.round() as i32);
    if x < 0 || y < 0 || x >= flow.cols() || y >= flow.rows() {
        return None;
    }
    let f = flow.at_2d::<Vec2f>(y, x).ok()?;
    let (du, dv) = (f[0], f[1]);
    (du.is_finite() && dv.is_finite()).then_some((du, dv))
}

impl DenseFlow {
    /// Flow with DIS at `preset` (OpenCV's `DISOpticalFlow::PRESET_*`).
    ///
    /// # Errors
    /// An OpenCV failure.
    pub(super) fn new(preset: i32) -> Result<Self, FrontEndError> {
        let dis = DISOpticalFlow::create(preset).map_err(cv("creating the dense flow"))?;
        Ok(Self { dis, previous_grey: None, frames: VecDeque::new() })
    }

    /// Adds the frame `grey` with `depth`, keeping `keep` frames.
    ///
    /// # Errors
    /// An OpenCV failure.
    pub(super) fn push(&mut self, grey: &Mat, depth: &DepthMap, keep: usize) -> Result<(), FrontEndError> {
        let flows = match &self.previous_grey {
            Some(previous) => {
                let (mut back, mut forth) = (Mat::default(), Mat::default());
                self.dis.calc(grey, previous, &mut back).map_err(cv("computing the flow back"))?;
                self.dis.calc(previous, grey, &mut forth).map_err(cv("computing the flow forth"))?;
                Some((back, forth))
            }
            None => None,
        };
        self.frames.push_back(FlowFrame { depth: depth_only(depth), flows });
        while self.frames.len() > keep.max(1) {
            self.frames.pop_front();
        }
        self.previous_grey = Some(grey.try_clone().map_err(cv("keeping the previous image"))?);
        Ok(())
    }

    /// Forgets every frame but the newest: the camera's motion to them was lost.
    pub(super) fn restart(&mut self) {
        while self.frames.len() > 1 {
            self.frames.pop_front();
        }
        if let Some(newest) = self.frames.back_mut() {
            newest.flows = None;
        }
    }

    /// The depth map `back` frames before the newest.
    pub(super) fn depth(&self, back: usize) -> Option<&DepthMap> {
        self.frames.get(self.frames.len().checked_sub(1 + back)?).map(|f| &f.depth)
    }

    /// `(u, v)` of the newest frame followed back up to `frames` frames (fewer where the
    /// history is shorter or a step fails its check: back then forth must return within
    /// `check_px`).
    pub(super) fn trace(&self, u: f32, v: f32, frames: usize, check_px: f32) -> Traced {
        let mut positions = vec![(u, v)];
        // A frame's flows lead to the one before it, which must still be held.
        for j in 0..frames.min(self.frames.len().saturating_sub(1)) {
            let Some(frame) = self.frames.len().checked_sub(1 + j).and_then(|i| self.frames.get(i)) else { break };
            let Some((back, forth)) = &frame.flows else { break };
            let Some(&(pu, pv)) = positions.last() else { break };
            let Some((bu, bv)) = flow_at(back, pu, pv) else { break };
            let (qu, qv) = (pu + bu, pv + bv);
            let Some((fu, fv)) = flow_at(forth, qu, qv) else { break };
            if (qu + fu - pu).hypot(qv + fv - pv) > check_px {
                break;
            }
            positions.push((qu, qv));
        }
        Traced { positions }
    }
}

/// A moving sample of this frame.
#[derive(Debug, Clone, Copy)]
struct Moving {
    /// Its index in the grid, row by row.
    cell: usize,
    now: Seen,
    /// Its pixel one frame before.
    before: (f32, f32),
}

/// The samples' grid over an image: a sample every `step` pixels, at the centres of the
/// cells, numbered row by row.
#[derive(Debug, Clone, Copy)]
struct SampleGrid {
    step: usize,
    cols: usize,
    rows: usize,
}

impl SampleGrid {
    /// The grid of an image of `size` (width, height) with samples `step` pixels apart.
    fn new(size: (i32, i32), step: usize) -> Self {
        let step = step.max(1);
        Self { step, cols: size.0.max(0) as usize / step, rows: size.1.max(0) as usize / step }
    }

    /// How many samples it holds.
    const fn len(self) -> usize {
        self.cols * self.rows
    }

    /// The pixel of sample `cell`.
    fn pixel(self, cell: usize) -> (f32, f32) {
        let centre = |i: usize| (i * self.step + self.step / 2) as f32;
        (centre(cell % self.cols.max(1)), centre(cell / self.cols.max(1)))
    }

    /// The sample nearest `(u, v)`.
    fn cell_of(self, (u, v): (f32, f32)) -> Option<usize> {
        let (half, step) = ((self.step / 2) as f32, self.step as f32);
        let (x, y) = (((u - half) / step).round(), ((v - half) / step).round());
        (x >= 0.0 && y >= 0.0 && (x as usize) < self.cols && (y as usize) < self.rows)
            .then(|| y as usize * self.cols + x as usize)
    }
}

impl MotionSegmenter {
    /// Judges the dense samples of the newest frame against the camera motions `since`
    /// (`since[j - 1]` = T_{k, k-j}) and clusters the moving ones, as [`Self::segment`] does
    /// the probes.
    pub(super) fn segment_dense(
        &mut self,
        since: &[Pose3],
        model: &PointModel,
        intrinsics: &Intrinsics,
        size: (i32, i32),
        stats: &mut FrontEndStats,
    ) -> Vec<Detection> {
        let p = self.params;
        let grid = SampleGrid::new(size, p.dense_step_px);
        let judge = MotionParams { pixel_sigma: p.flow_sigma_px, ..p };
        let previous = std::mem::take(&mut self.dense_labels);
        let mut labels = vec![0u16; grid.len()];
        let mut moving: Vec<Moving> = Vec::new();
        let mut points = Vec::new();
        let mut directions = Vec::new();
        let Some(flow) = &self.dense else { return Vec::new() };
        let Some(now_depth) = flow.depth(0) else { return Vec::new() };
        for cell in 0..grid.len() {
            let (u, v) = grid.pixel(cell);
            let Some(z) = smooth_depth(now_depth, u, v, &p).filter(|z| *z <= p.max_depth_m) else { continue };
            let traced = flow.trace(u, v, since.len(), p.flow_check_px);
            let back = traced.positions.len() - 1;
            let (Some(pose), Some(&(tu, tv))) =
                (back.checked_sub(1).and_then(|j| since.get(j)), traced.positions.last())
            else {
                self.fates.push((u, v, Fate::Young));
                continue;
            };
            let then =
                Seen { u: tu, v: tv, depth: flow.depth(back).and_then(|d| smooth_depth(d, tu, tv, &p)), around: None };
            let now = Seen { u, v, depth: Some(z), around: None };
            let Some((r, m2)) = normalised_residual(model, pose, (&then, &now), intrinsics.stereo_fb, &judge) else {
                self.fates.push((u, v, Fate::NoDepth));
                continue;
            };
            stats.motion_probes_judged += 1;
            self.judged.push(Judged {
                u,
                v,
                depth: z,
                across_px: r.x.hypot(r.y),
                along_px: r.z.abs(),
                sigmas: m2.sqrt(),
            });
            if m2 <= p.moving_sigmas * p.moving_sigmas {
                self.fates.push((u, v, Fate::Static));
                continue;
            }
            if let Some(l) = labels.get_mut(cell) {
                *l = MOVING;
            }
            let before = traced.positions.get(1).copied().unwrap_or((u, v));
            // Moving in the frame before too, where the confirmation asks for it.
            let confirmed = p.probe_confirm_frames < 2
                || grid.cell_of(before).and_then(|c| previous.get(c)).is_some_and(|&l| l != 0);
            if !confirmed {
                self.fates.push((u, v, Fate::Unconfirmed));
                continue;
            }
            stats.motion_probes_moving += 1;
            points.push((moving.len(), model.back_project(u, v, z)));
            directions.push(r.try_normalize(1e-6).unwrap_or_else(nalgebra::Vector3::zeros));
            moving.push(Moving { cell, now, before });
        }
        let mut out = Vec::new();
        let mut ids_now = Vec::new();
        let mut in_object = vec![false; moving.len()];
        for members in clusters(&points, model, p.link_m) {
            if members.len() < p.dense_min_samples || !coherent(&members, &directions, p.min_coherence) {
                stats.motion_probes_unclustered += members.len() as u64;
                continue;
            }
            let samples: Vec<Moving> = members.iter().filter_map(|&m| moving.get(m).copied()).collect();
            let Some(extent) = grown_box(samples.iter().map(|s| s.now), p.grow, intrinsics) else { continue };
            let mut votes: BTreeMap<u16, usize> = BTreeMap::new();
            for s in &samples {
                if let Some(&l) = grid.cell_of(s.before).and_then(|c| previous.get(c))
                    && l >= FIRST_ID
                {
                    *votes.entry(l).or_default() += 1;
                }
            }
            let id = self.id_by_votes(votes, &ids_now);
            ids_now.push(id);
            out.extend(self.follow(id, extent, intrinsics, stats));
            for (&m, s) in members.iter().zip(&samples) {
                if let Some(l) = labels.get_mut(s.cell) {
                    *l = id;
                }
                if let Some(f) = in_object.get_mut(m) {
                    *f = true;
                }
            }
        }
        for (s, found) in moving.iter().zip(in_object) {
            self.fates.push((s.now.u, s.now.v, if found { Fate::InObject } else { Fate::Unclustered }));
        }
        self.dense_labels = labels;
        out.extend(self.coast(&ids_now, intrinsics, stats));
        out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use opencv::core::{CV_8UC1, Rect, Scalar, Size};

    /// A smooth random texture, `w` x `h`.
    fn texture(w: i32, h: i32) -> Mat {
        let mut noise = Mat::new_rows_cols_with_default(h, w, CV_8UC1, Scalar::all(0.0)).unwrap();
        opencv::core::randu(&mut noise, &Scalar::all(0.0), &Scalar::all(255.0)).unwrap();
        let mut out = Mat::default();
        opencv::imgproc::gaussian_blur_def(&noise, &mut out, Size::new(5, 5), 1.5).unwrap();
        out
    }

    #[test]
    fn a_sample_is_followed_back_through_a_known_shift_and_only_as_far_as_the_history() {
        let big = texture(240, 120);
        // The scene moves 3 px right and 2 px down each frame.
        let frame = |k: i32| Mat::roi(&big, Rect::new(40 - 3 * k, 30 - 2 * k, 160, 80)).unwrap().try_clone().unwrap();
        let depth =
            DepthMap::Given(Mat::new_rows_cols_with_default(80, 160, opencv::core::CV_32F, Scalar::all(10.0)).unwrap());
        let mut flow = DenseFlow::new(PRESET).unwrap();
        for k in 0..3 {
            flow.push(&frame(k), &depth, 4).unwrap();
        }
        let traced = flow.trace(80.0, 40.0, 5, 1.0);
        // Two flows in the history: the sample goes back two frames and no further.
        assert_eq!(traced.positions.len(), 3, "{traced:?}");
        for (j, &(u, v)) in traced.positions.iter().enumerate() {
            let (eu, ev) = (80.0 - 3.0 * j as f32, 40.0 - 2.0 * j as f32);
            assert!((u - eu).abs() < 0.5 && (v - ev).abs() < 0.5, "step {j}: ({u}, {v}) against ({eu}, {ev})");
        }
        assert!(flow.depth(2).is_some() && flow.depth(3).is_none());
        flow.restart();
        assert_eq!(flow.trace(80.0, 40.0, 5, 1.0).positions.len(), 1, "no history after a restart");
    }
}
