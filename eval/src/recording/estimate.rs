//! The recording of an estimator run: the camera's path, the objects' estimated (and true)
//! trails, and the tracks the estimator measured, back-projected.

use dynotraj_bag::record::{
    CAMERA_FRAME, Pose, Recorder, RecordingEncoding, RecordingSummary, Rgba, Trails, WORLD_FRAME, meta,
};
use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::wire::Track;
use dynotraj_sim::track_sim::SimFrame;
use dynotraj_sources::estimation::runner::EstimatorRun;

/// What a recording of an estimate is made from.
#[derive(Debug, Clone, Copy)]
pub struct RecordInput<'a> {
    /// Per frame estimated: its index and the tracks the estimator got.
    pub frames: &'a [(u32, &'a [Track])],
    /// The estimator's outputs, indexed like `frames`.
    pub run: &'a EstimatorRun,
    /// The simulator's frames, indexed like `frames`, for their truth; empty without truth.
    pub truth: &'a [SimFrame],
    /// The camera the tracks were measured with.
    pub intrinsics: Intrinsics,
    /// Frames per second: a frame's log time is its index over it.
    pub rate_hz: f64,
}

/// Colour of the estimated object trajectories.
const ESTIMATED_COLOR: Rgba = Rgba::opaque(1.0, 0.55, 0.1);
/// Colour of the true object trajectories.
const TRUTH_COLOR: Rgba = Rgba::opaque(0.2, 0.85, 0.3);

/// Writes the recording of an estimator run to `path`: per frame (log time: frame index over
/// the rate), the causal camera pose (`/tf`, `/camera/path`), each object's causal bird's-eye
/// trajectory so far (`/objects/estimated`), with truth the true ones (`/objects/truth`,
/// `/camera/truth`), and the frame's tracks back-projected into the camera frame, static and
/// object points apart (`/points/static`, `/points/objects`). The estimator keeps its
/// landmarks to itself; these points are its measurements, placed by the estimated camera.
/// Every frame has one message on each topic but `/tf`, which has one per estimated frame.
///
/// # Errors
/// Writing errors, named.
pub fn record_estimate(
    path: &std::path::Path,
    encoding: RecordingEncoding,
    input: &RecordInput<'_>,
) -> anyhow::Result<RecordingSummary> {
    let mut rec = Recorder::create_with(path, encoding)?;
    let mut camera_path: Vec<Pose> = Vec::new();
    let mut truth_path: Vec<Pose> = Vec::new();
    let mut estimated = Trails::new(ESTIMATED_COLOR);
    let mut truth = Trails::new(TRUTH_COLOR);
    for (i, &(frame, tracks)) in input.frames.iter().enumerate() {
        let t = rec.frame_time(frame, input.rate_hz)?;
        let mut lines = Vec::new();
        if let Some(e) = input.run.causal.get(i).and_then(Option::as_ref) {
            let (p, q) = (e.camera.translation.vector, e.camera.rotation.coords);
            let pose = Pose::from_camera_world([p.x, p.y, p.z].map(f64::from), [q.x, q.y, q.z, q.w].map(f64::from));
            rec.camera_transform("/tf", t, &pose)?;
            camera_path.push(pose);
            for o in e.objects.iter().filter(|o| o.bev.is_finite()) {
                let point = [f64::from(o.bev.x), f64::from(o.bev.y), 0.0];
                lines.push(estimated.extend(o.object_id, point, meta("class", format!("{:?}", o.class))));
            }
        }
        rec.poses("/camera/path", t, WORLD_FRAME, &camera_path)?;
        rec.lines("/objects/estimated", t, &lines)?;
        if let Some(f) = input.truth.get(i) {
            let (p, q) = (f.camera.translation.vector, f.camera.rotation.coords);
            truth_path.push(Pose::from_camera_world([p.x, p.y, p.z], [q.x, q.y, q.z, q.w]));
            rec.poses("/camera/truth", t, WORLD_FRAME, &truth_path)?;
            let lines: Vec<_> = f
                .objects
                .iter()
                .map(|o| {
                    let c = o.pose.translation.vector;
                    truth.extend(o.object_id, [c.x, c.z, 0.0], meta("class", format!("{:?}", o.class)))
                })
                .collect();
            rec.lines("/objects/truth", t, &lines)?;
        }
        let (statics, objects): (Vec<&Track>, Vec<&Track>) = tracks.iter().partition(|k| k.is_static());
        rec.points("/points/static", t, CAMERA_FRAME, &super::back_project(&statics, &input.intrinsics))?;
        rec.points("/points/objects", t, CAMERA_FRAME, &super::back_project(&objects, &input.intrinsics))?;
    }
    rec.finish()
}
