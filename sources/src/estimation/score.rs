//! Scores of an estimator run against the simulator's truth: RPE (translation in metres,
//! rotation in radians; delta = 1 frame, as evo computes it) of the camera and of the moving
//! objects, per output kind; and the smoothness of object trajectories.
//!
//! Object RPE pools the frame pairs of every moving object (each pair weighs the same): a pair
//! is two consecutive frames in which the object has both an estimate (of the same orientation:
//! an object whose frame was turned starts a new one) and a truth pose. The estimate's object
//! frame (origin at the centroid of its first points, x along its direction of travel) differs from
//! the truth's box frame by a fixed offset, which RPE does not see except through rotation.

use std::collections::{BTreeMap, BTreeSet};

use dynotraj_core::BevState;
use dynotraj_core::estimate::{ObjectEstimate, PoseEstimate};
use dynotraj_core::geometry::angle_diff;
use dynotraj_core::metrics::{PairError, RpeAccumulator, RpeResult};
use dynotraj_sim::track_sim::SimFrame;

use super::runner::{EstimatorRun, Kind};

/// RPE of one output kind.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct KindScores {
    /// Camera RPE.
    pub camera: Option<RpeResult>,
    /// Moving objects' RPE, pairs pooled.
    pub object: Option<RpeResult>,
    /// Moving objects with at least one scored pair.
    pub objects: usize,
}

/// Scores of a run, per kind in [`Kind::ALL`] order.
#[derive(Debug, Clone, Copy, PartialEq, Default, serde::Serialize, serde::Deserialize)]
pub struct RunScores {
    /// Per kind: frame-to-frame, causal, smoothed.
    pub kinds: [KindScores; 3],
    /// Moving objects in the truth.
    pub moving_objects: usize,
}

/// Ids of the objects whose truth moves at least `min_step_m` per frame on average.
#[must_use]
pub fn moving_objects(frames: &[SimFrame], min_step_m: f64) -> BTreeSet<u16> {
    dynotraj_sim::track_sim::moving_objects(frames.iter().map(|f| f.objects.as_slice()), min_step_m)
        .into_keys()
        .collect()
}

/// RPE of every kind of `run` against the truth in `frames`, objects restricted to `moving`.
#[must_use]
pub fn score_run(frames: &[SimFrame], run: &EstimatorRun, moving: &BTreeSet<u16>) -> RunScores {
    let mut out = RunScores { moving_objects: moving.len(), ..RunScores::default() };
    for (slot, kind) in out.kinds.iter_mut().zip(Kind::ALL) {
        *slot = score_kind(frames, run.of(kind), moving, &mut |_, _, _| {});
    }
    out
}

/// Whose pair of frames an error is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Entity {
    Camera,
    Object,
}

/// RPE of one kind's estimates `est` against the truth in `frames`, objects restricted to
/// `moving`; tells `on_pair` every pair it counts: (index into `frames` of the pair's later
/// frame, whose pair, its error).
fn score_kind(
    frames: &[SimFrame],
    est: &[Option<PoseEstimate>],
    moving: &BTreeSet<u16>,
    on_pair: &mut dyn FnMut(usize, Entity, PairError),
) -> KindScores {
    let mut cam = RpeAccumulator::new();
    for (k, (f, e)) in frames.iter().zip(est).enumerate() {
        match e {
            Some(e) => {
                if let Some(pair) = cam.push(&f.camera.cast::<f32>(), &e.camera) {
                    on_pair(k, Entity::Camera, pair);
                }
            }
            None => cam.break_segment(),
        }
    }
    let mut all = RpeAccumulator::new();
    let mut objects = 0;
    for &id in moving {
        let acc = object_rpe_with(frames, est, id, &mut |k, _, pair| on_pair(k, Entity::Object, pair));
        if acc.result().is_some() {
            objects += 1;
            all.merge(&acc);
        }
    }
    KindScores { camera: cam.result(), object: all.result(), objects }
}

/// The translational RPE of the pairs of frames that end at one frame: what Table III's RPE
/// averages, followed over time.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FrameRpe {
    /// Frame index (the pairs' later frame).
    pub frame: u32,
    /// The camera's pair error, metres, when the camera has a pair ending here.
    pub camera: Option<f64>,
    /// Root mean square of the moving objects' pair errors ending here, metres.
    pub objects: Option<f64>,
    /// Object pairs ending here.
    pub object_pairs: u32,
}

/// Per frame, the translational errors of the pairs [`score_run`] counts for `est` (one kind's
/// estimates) against the truth in `frames`, objects restricted to `moving`; frames with no
/// pair are left out. Table III's camera RPE_t is the root mean square of `camera` over the
/// frames, its object RPE_t that of `objects` weighted by `object_pairs`.
#[must_use]
pub fn rpe_over_time(frames: &[SimFrame], est: &[Option<PoseEstimate>], moving: &BTreeSet<u16>) -> Vec<FrameRpe> {
    let mut by_frame: BTreeMap<usize, (Option<f64>, f64, u32)> = BTreeMap::new();
    score_kind(frames, est, moving, &mut |k, entity, pair| {
        let slot = by_frame.entry(k).or_insert((None, 0.0, 0));
        match entity {
            Entity::Camera => slot.0 = Some(pair.translation),
            Entity::Object => {
                slot.1 += pair.translation * pair.translation;
                slot.2 += 1;
            }
        }
    });
    by_frame
        .into_iter()
        .filter_map(|(k, (camera, sum2, n))| {
            Some(FrameRpe {
                frame: frames.get(k)?.frame,
                camera,
                objects: (n > 0).then(|| (sum2 / f64::from(n)).sqrt()),
                object_pairs: n,
            })
        })
        .collect()
}

/// RPE of object `id` in `est`: the pairs of consecutive frames within each of its
/// [`object_runs`], with the truth of `frames`.
#[must_use]
pub fn object_rpe(frames: &[SimFrame], est: &[Option<PoseEstimate>], id: u16) -> RpeAccumulator {
    object_rpe_with(frames, est, id, &mut |_, _, _| {})
}

/// [`object_rpe`], telling `on_pair` each pair it counts: (index into `frames` of the pair's
/// later frame, the pair's place in its run (0: the run's first pair), its error).
fn object_rpe_with(
    frames: &[SimFrame],
    est: &[Option<PoseEstimate>],
    id: u16,
    on_pair: &mut dyn FnMut(usize, usize, PairError),
) -> RpeAccumulator {
    let mut acc = RpeAccumulator::new();
    let truth = |k: usize| frames.get(k).and_then(|f| f.objects.iter().find(|o| o.object_id == id));
    for run in object_runs(est, id, |k| truth(k).is_some()) {
        acc.break_segment();
        let mut place = 0;
        for (k, _, o) in run {
            if let Some(t) = truth(k)
                && let Some(pair) = acc.push(&t.pose.cast::<f32>(), &o.pose)
            {
                on_pair(k, place, pair);
                place += 1;
            }
        }
    }
    acc
}

/// One object pair of frames that RPE counts, with where it was seen from.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ObjectPair {
    /// The pair's place in its run of consecutive estimates (0: the run's first pair).
    pub place: usize,
    /// The true distance from the camera to the object at the pair's later frame, metres.
    pub range_m: f64,
    /// The estimated object frame's bird's-eye heading against the true one at the later frame,
    /// radians in [0, pi]: RPE compares motions in each object's own frame, so a frame turned
    /// by a constant angle turns every motion by it (half a turn doubles a motion's error).
    pub heading_error_rad: f64,
    /// Its error.
    pub error: PairError,
}

/// Every pair of frames [`object_rpe`] counts for the objects `moving` in `est`, with its place
/// in its run, its true range and its heading error: what a table of where RPE comes from groups.
#[must_use]
pub fn object_pairs(frames: &[SimFrame], est: &[Option<PoseEstimate>], moving: &BTreeSet<u16>) -> Vec<ObjectPair> {
    let heading = |pose: &nalgebra::Isometry3<f64>| {
        let x_axis = pose.rotation * nalgebra::Vector3::x();
        x_axis.z.atan2(x_axis.x)
    };
    let mut out = Vec::new();
    for &id in moving {
        object_rpe_with(frames, est, id, &mut |k, place, error| {
            let estimate =
                est.get(k).and_then(Option::as_ref).and_then(|e| e.objects.iter().find(|o| o.object_id == id));
            let seen = frames.get(k).and_then(|f| Some((f, f.objects.iter().find(|o| o.object_id == id)?)));
            if let (Some(e), Some((f, truth))) = (estimate, seen) {
                let turned = heading(&e.pose.cast::<f64>()) - heading(&truth.pose);
                out.push(ObjectPair {
                    place,
                    range_m: (truth.pose.translation.vector - f.camera.translation.vector).norm(),
                    heading_error_rad: turned.sin().atan2(turned.cos()).abs(),
                    error,
                });
            }
        });
    }
    out
}

/// The runs of object `id` in `est` whose consecutive frames RPE pairs: maximal stretches of
/// consecutive frames `k` with an estimate of `id` of one orientation with a known heading (before
/// its heading is known an object's frame keeps the world's orientation, a placeholder that RPE
/// would read as a rotation error) and `has_truth(k)`. Each entry: (k, the frame's estimate, the
/// object's).
pub fn object_runs(
    est: &[Option<PoseEstimate>],
    id: u16,
    has_truth: impl Fn(usize) -> bool,
) -> Vec<Vec<(usize, &PoseEstimate, &ObjectEstimate)>> {
    let mut runs = vec![Vec::new()];
    let mut orientation = None;
    for (k, e) in est.iter().enumerate() {
        let found =
            e.as_ref().and_then(|e| e.objects.iter().find(|o| o.object_id == id && o.heading_known).map(|o| (e, o)));
        match found {
            Some((e, o)) if has_truth(k) => {
                if orientation.is_some_and(|s| s != o.orientation) {
                    runs.push(Vec::new());
                }
                orientation = Some(o.orientation);
                if let Some(run) = runs.last_mut() {
                    run.push((k, e, o));
                }
            }
            _ => {
                if orientation.take().is_some() {
                    runs.push(Vec::new());
                }
            }
        }
    }
    runs.retain(|r| !r.is_empty());
    runs
}

/// Smoothness of bird's-eye trajectories: mean absolute change between consecutive frames.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct TrajectorySmoothness {
    /// Mean |delta heading|, radians.
    pub heading: f64,
    /// Mean |delta speed|, m/s.
    pub speed: f64,
    /// Consecutive pairs counted.
    pub pairs: usize,
}

/// Accumulates smoothness over pairs of consecutive states.
#[derive(Debug, Clone, Copy, PartialEq, Default)]
pub struct SmoothnessSum {
    heading: f64,
    speed: f64,
    pairs: usize,
}

impl SmoothnessSum {
    /// Adds the pair (`a` at frame k, `b` at frame k+1).
    pub fn push(&mut self, a: &BevState, b: &BevState) {
        let dh = f64::from(angle_diff(b.heading, a.heading).abs());
        let dv = f64::from((b.speed - a.speed).abs());
        if dh.is_finite() && dv.is_finite() {
            self.heading += dh;
            self.speed += dv;
            self.pairs += 1;
        }
    }

    /// Merges another sum.
    pub fn merge(&mut self, o: &Self) {
        self.heading += o.heading;
        self.speed += o.speed;
        self.pairs += o.pairs;
    }

    /// The means.
    #[must_use]
    pub fn result(&self) -> TrajectorySmoothness {
        let n = self.pairs.max(1) as f64;
        TrajectorySmoothness { heading: self.heading / n, speed: self.speed / n, pairs: self.pairs }
    }
}

/// Smoothness of the `moving` objects' estimates in `est`, over pairs of consecutive frames of
/// one segment with a known heading. Also returns the pairs used, as (object id, frame index of
/// the first frame), so that a reference can be measured on the same pairs.
#[must_use]
pub fn smoothness(est: &[Option<PoseEstimate>], moving: &BTreeSet<u16>) -> (SmoothnessSum, Vec<(u16, usize)>) {
    let mut sum = SmoothnessSum::default();
    let mut pairs = Vec::new();
    for (i, w) in est.windows(2).enumerate() {
        let (Some(a), Some(b)) = (&w[0], &w[1]) else { continue };
        for oa in a.objects.iter().filter(|o| moving.contains(&o.object_id) && o.heading_known) {
            if let Some(ob) =
                b.objects.iter().find(|o| o.object_id == oa.object_id && o.segment == oa.segment && o.heading_known)
            {
                sum.push(&oa.bev, &ob.bev);
                pairs.push((oa.object_id, i));
            }
        }
    }
    (sum, pairs)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::estimation::simulated::{EvalOptions, evaluate_sequence};
    use dynotraj_formats::kitti::TrackingDir;
    use dynotraj_sim::drive::{DriveSpec, generate};
    use dynotraj_sim::kitti_layout::write_sequence;

    #[test]
    fn the_rpe_over_time_is_the_pairs_table_iii_averages() {
        let dir = tempfile::tempdir().unwrap();
        write_sequence(dir.path(), "0000", &generate(&DriveSpec::default())).unwrap();
        let data = TrackingDir::open(dir.path()).unwrap().load_sequence("0000").unwrap();
        let r = evaluate_sequence("0000", &data, &EvalOptions::kitti(0.1));
        let moving = moving_objects(&r.sim, r.min_step_m);
        for (kind, scores) in Kind::ALL.iter().zip(&r.scores.kinds) {
            let frames = rpe_over_time(&r.sim, r.run.of(*kind), &moving);
            let camera: Vec<f64> = frames.iter().filter_map(|f| f.camera).collect();
            let want = scores.camera.unwrap();
            assert_eq!(camera.len(), want.pairs as usize, "{}", kind.name());
            let rms = (camera.iter().map(|t| t * t).sum::<f64>() / camera.len() as f64).sqrt();
            assert!((rms - want.translation).abs() < 1e-9, "{}: {rms} vs {}", kind.name(), want.translation);
            let want = scores.object.unwrap();
            let pairs: u32 = frames.iter().map(|f| f.object_pairs).sum();
            let sum2: f64 =
                frames.iter().filter_map(|f| Some(f.objects? * f.objects? * f64::from(f.object_pairs))).sum();
            assert_eq!(pairs, want.pairs, "{}", kind.name());
            assert!(((sum2 / f64::from(pairs)).sqrt() - want.translation).abs() < 1e-9, "{}", kind.name());
            assert!(frames.windows(2).all(|w| w[0].frame < w[1].frame), "in frame order");
        }
    }

    #[test]
    fn object_pairs_are_table_iii_s_pairs_and_see_a_frame_turned_half_a_turn() {
        let dir = tempfile::tempdir().unwrap();
        write_sequence(dir.path(), "0000", &generate(&DriveSpec::default())).unwrap();
        let data = TrackingDir::open(dir.path()).unwrap().load_sequence("0000").unwrap();
        let r = evaluate_sequence("0000", &data, &EvalOptions::kitti(0.1));
        let moving = moving_objects(&r.sim, r.min_step_m);
        let causal = r.run.of(Kind::Causal);
        let pairs = object_pairs(&r.sim, causal, &moving);
        let want = r.scores.kinds[1].object.unwrap();
        assert_eq!(pairs.len(), want.pairs as usize);
        let rms =
            |p: &[ObjectPair]| (p.iter().map(|p| p.error.translation.powi(2)).sum::<f64>() / p.len() as f64).sqrt();
        assert!((rms(&pairs) - want.translation).abs() < 1e-9);
        assert!(pairs.iter().all(|p| p.range_m > 0.0 && p.range_m < 200.0));
        assert!(pairs.iter().filter(|p| p.heading_error_rad < 0.5).count() > pairs.len() * 9 / 10);
        // Every object frame turned half a turn about the vertical: the same positions, the
        // motions read backwards in the object's frame.
        let half_turn = dynotraj_core::geometry::Pose3::from_parts(
            nalgebra::Translation3::identity(),
            nalgebra::UnitQuaternion::from_axis_angle(&nalgebra::Vector3::y_axis(), std::f32::consts::PI),
        );
        let turned: Vec<Option<PoseEstimate>> = causal
            .iter()
            .map(|e| {
                e.clone().map(|mut e| {
                    for o in &mut e.objects {
                        o.pose *= half_turn;
                    }
                    e
                })
            })
            .collect();
        let flipped = object_pairs(&r.sim, &turned, &moving);
        assert_eq!(flipped.len(), pairs.len());
        assert!(flipped.iter().filter(|p| p.heading_error_rad > 2.5).count() > pairs.len() * 9 / 10);
        assert!(rms(&flipped) > 1.5 * rms(&pairs), "{} vs {}", rms(&flipped), rms(&pairs));
    }
}
