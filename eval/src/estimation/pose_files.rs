//! Pose files and the per-frame log of an estimator run, laid out for `evo`:
//!
//! ```text
//! <dir>/camera_truth.{tum,kitti}            true camera poses, every frame
//! <dir>/camera_<kind>.{tum,kitti}           estimated camera poses (kind: f2f, causal, smoothed)
//! <dir>/objects/<id>_truth.tum              true object poses, frames labelled
//! <dir>/objects/<id>_<kind>_<n>.tum         estimated object poses, run n = 1, 2, ... (below)
//! <dir>/objects/<id>_smoothed_<n>.kitti     smoothed poses of run n (the frames of
//! <dir>/objects/<id>_truth_<n>.kitti        <id>_smoothed_<n>.tum), and the truth on the same
//!                                           frames: KITTI files have no timestamps, so evo pairs
//!                                           them by line, and one file a run keeps every pair
//!                                           within a run
//! <dir>/objects/runs.csv                    each run's frames and its RPE as dynotraj scores it
//! <dir>/log.csv                             one row per frame, kind and entity
//! <dir>/README.txt                          the frame rate of the timestamps, evo command lines
//! ```
//!
//! Timestamps are capture times: frame index over the sequence's capture rate ([`FileClock`]:
//! KITTI's cameras record at 10 Hz; a tracks file carries its camera's rate, measured from a
//! bag's stamps when `track` read an imported bag). The rate the estimator ran at (the paper's
//! 20 Hz reading of KITTI by default) is a setting of the run, not of the files: the README and
//! every TUM file say both, so that durations and speeds evo reads from the files are real.
//!
//! `<id>` is the wire object id (KITTI track id + 1). Poses are `T_world_x` in the camera
//! convention of the first frame.
//!
//! An estimated object file holds one run: consecutive frames of one segment (the object's
//! frame is re-oriented, and a new segment starts, when its heading becomes known or it
//! restarts) with a known heading and, where the truth is known, a truth pose. So every pair of
//! consecutive lines is a pair that dynotraj's RPE counts, and evo on a file against
//! `<id>_truth.tum` agrees with it. Frames whose heading is not known yet keep the world's
//! orientation as a placeholder: they are only in log.csv (flagged there), never in a pose file.

use std::collections::BTreeSet;
use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context as _;
use dynotraj_core::geometry::Pose3;
use dynotraj_core::metrics::RpeAccumulator;
use dynotraj_sim::track_sim::SimFrame;
use nalgebra::Isometry3;

use dynotraj_formats::kitti::{write_poses, write_tum_noted};
use dynotraj_sources::estimation::runner::{EstimatorRun, Kind};
use dynotraj_sources::estimation::score::object_runs;

fn f64_pose(p: &Pose3) -> Isometry3<f64> {
    p.cast::<f64>()
}

/// The capture clock of the files: frame `k` is at `k / rate_hz` seconds.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct FileClock {
    /// The sequence's capture rate, Hz.
    pub rate_hz: f64,
}

impl FileClock {
    /// KITTI's cameras: 10 Hz.
    pub const KITTI: Self = Self { rate_hz: 10.0 };

    /// The capture time of frame `frame`, seconds.
    #[must_use]
    pub fn seconds(&self, frame: u32) -> f64 {
        f64::from(frame) / self.rate_hz
    }
}

/// Writes the pose files and the log of `run` on `frames` into `dir` (created if needed), with
/// timestamps of `clock`.
///
/// # Errors
/// A file or folder that cannot be written, named.
pub fn write_run(dir: &Path, frames: &[SimFrame], run: &EstimatorRun, clock: FileClock) -> anyhow::Result<()> {
    let objects_dir = dir.join("objects");
    std::fs::create_dir_all(&objects_dir).with_context(|| format!("creating {}", objects_dir.display()))?;
    let meta: Vec<(u32, u64)> = frames.iter().map(|f| (f.frame, f.timestamp_us)).collect();
    let rate = RateNote::of(&meta, clock);
    write_readme(dir, &rate, true)?;
    let seconds = |frame: u32| clock.seconds(frame);
    let truth: Vec<(f64, Isometry3<f64>)> = frames.iter().map(|f| (seconds(f.frame), f.camera)).collect();
    write_tum_noted(dir.join("camera_truth.tum"), &[&rate.0], &truth)?;
    write_poses(dir.join("camera_truth.kitti"), &truth.iter().map(|p| p.1).collect::<Vec<_>>())?;
    let truth_of = |k: usize, id: u16| frames.get(k).and_then(|f| f.objects.iter().find(|o| o.object_id == id));
    write_estimate_poses(dir, run, &rate, clock, Some(&|k, id| truth_of(k, id).map(|o| o.pose)))?;
    let ids: BTreeSet<u16> = frames.iter().flat_map(|f| f.objects.iter().map(|o| o.object_id)).collect();
    for id in ids {
        let truth: Vec<(f64, Isometry3<f64>)> = frames
            .iter()
            .filter_map(|f| f.objects.iter().find(|o| o.object_id == id).map(|o| (seconds(f.frame), o.pose)))
            .collect();
        write_tum_noted(objects_dir.join(format!("{id}_truth.tum")), &[&rate.0], &truth)?;
    }
    write_log(&dir.join("log.csv"), &meta, Some(frames), run, clock)
}

/// Writes the estimated pose files and the log of a run without truth (a recorded tracks file):
/// the files of [`write_run`] less every `*_truth*` file and the log's truth rows. `frames` are
/// (frame index, timestamp in microseconds) in the run's order.
///
/// # Errors
/// A file or folder that cannot be written, named.
pub fn write_estimates(dir: &Path, frames: &[(u32, u64)], run: &EstimatorRun, clock: FileClock) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let rate = RateNote::of(frames, clock);
    write_readme(dir, &rate, false)?;
    write_estimate_poses(dir, run, &rate, clock, None)?;
    write_log(&dir.join("log.csv"), frames, None, run, clock)
}

/// The truth pose of object `id` at frame `k` (an index into the run), when known.
type TruthOf<'a> = &'a dyn Fn(usize, u16) -> Option<Isometry3<f64>>;

/// Camera and object pose files of every estimate kind, and the runs' table; with `truth`,
/// runs also end where it has no pose of the object.
fn write_estimate_poses(
    dir: &Path,
    run: &EstimatorRun,
    rate: &RateNote,
    clock: FileClock,
    truth: Option<TruthOf<'_>>,
) -> anyhow::Result<()> {
    let objects_dir = dir.join("objects");
    std::fs::create_dir_all(&objects_dir).with_context(|| format!("creating {}", objects_dir.display()))?;
    let truth_at = |k: usize, id: u16| truth.and_then(|t| t(k, id));
    let has_truth = |k: usize, id: u16| truth.is_none() || truth_at(k, id).is_some();
    let mut runs_csv = String::from("object,kind,run,first_frame,last_frame,poses,rpe_t_m,rpe_r_deg\n");
    for kind in Kind::ALL {
        let est: Vec<(f64, Isometry3<f64>)> =
            run.of(kind).iter().flatten().map(|e| (clock.seconds(e.frame), f64_pose(&e.camera))).collect();
        write_tum_noted(dir.join(format!("camera_{}.tum", kind.name())), &[&rate.0], &est)?;
        write_poses(dir.join(format!("camera_{}.kitti", kind.name())), &est.iter().map(|p| p.1).collect::<Vec<_>>())?;
    }
    let ids: BTreeSet<u16> = Kind::ALL
        .iter()
        .flat_map(|k| run.of(*k).iter().flatten().flat_map(|e| e.objects.iter().map(|o| o.object_id)))
        .collect();
    for id in ids {
        for kind in Kind::ALL {
            let runs = object_runs(run.of(kind), id, |k| has_truth(k, id));
            for (n, r) in runs.iter().filter(|r| r.len() >= 2).enumerate() {
                let n = n + 1;
                let name = kind.name();
                let poses: Vec<(f64, Isometry3<f64>)> =
                    r.iter().map(|(_, e, o)| (clock.seconds(e.frame), f64_pose(&o.pose))).collect();
                let note =
                    format!("object {id}, {name}: run {n} (consecutive frames of one segment with a known heading)");
                write_tum_noted(objects_dir.join(format!("{id}_{name}_{n}.tum")), &[&note, &rate.0], &poses)?;
                let truths: Vec<Isometry3<f64>> = r.iter().filter_map(|(k, _, _)| truth_at(*k, id)).collect();
                let (first, last) = (r.first().map_or(0, |x| x.1.frame), r.last().map_or(0, |x| x.1.frame));
                let mut rpe = ",".to_string();
                if truth.is_some() && truths.len() == r.len() {
                    let mut acc = RpeAccumulator::new();
                    for ((_, _, o), t) in r.iter().zip(&truths) {
                        acc.push(&t.cast::<f32>(), &o.pose);
                    }
                    if let Some(x) = acc.result() {
                        rpe = format!("{:.6},{:.6}", x.translation, x.rotation.to_degrees());
                    }
                    if kind == Kind::Smoothed {
                        let est: Vec<Isometry3<f64>> = poses.iter().map(|p| p.1).collect();
                        write_poses(objects_dir.join(format!("{id}_smoothed_{n}.kitti")), &est)?;
                        write_poses(objects_dir.join(format!("{id}_truth_{n}.kitti")), &truths)?;
                    }
                }
                let _ = writeln!(runs_csv, "{id},{name},{n},{first},{last},{},{rpe}", r.len());
            }
        }
    }
    let path = objects_dir.join("runs.csv");
    dynotraj_formats::atomic::write_file(&path, runs_csv).with_context(|| format!("writing {}", path.display()))
}

/// The comment line that says at what rate a file's timestamps advance.
struct RateNote(String);

impl RateNote {
    /// The note for files of `clock` from a run over frames `(index, timestamp in
    /// microseconds)`: the capture rate, and the rate the run used (its mean step between the
    /// first and the last frame).
    fn of(frames: &[(u32, u64)], clock: FileClock) -> Self {
        let span = match (frames.first(), frames.last()) {
            (Some(a), Some(b)) if b.0 > a.0 && b.1 > a.1 => Some((b.1 - a.1) as f64 * 1e-6 / f64::from(b.0 - a.0)),
            _ => None,
        };
        let ran = span.map_or(String::new(), |dt| format!("; the estimator ran at {:.3} Hz", 1.0 / dt));
        Self(format!(
            "timestamps: seconds at the camera's rate, {:.3} Hz (one frame every {:.4} s){ran}",
            clock.rate_hz,
            1.0 / clock.rate_hz
        ))
    }
}

/// README.txt beside the pose files: the rate of their timestamps and the evo command lines
/// that read them (`truth`: whether the truth files are there).
fn write_readme(dir: &Path, rate: &RateNote, truth: bool) -> anyhow::Result<()> {
    let mut text = format!(
        "dynotraj estimator output (layout: dynotraj-eval src/estimation/pose_files.rs).\n{}.\n\n\
         Poses are T_world_x in the camera convention of the first frame; object ids are the wire ids\n\
         (KITTI track id + 1). Each objects/<id>_<kind>_<n>.tum holds one run of consecutive frames\n\
         that dynotraj's RPE pairs; objects/runs.csv gives each run's frames and RPE.\n\n\
         evo command lines (pip install evo):\n",
        rate.0
    );
    if truth {
        text.push_str(
            "  evo_rpe tum camera_truth.tum camera_smoothed.tum --delta 1 --delta_unit f   # camera RPE, 1 frame\n\
             evo_ape tum camera_truth.tum camera_causal.tum --align                     # camera drift\n\
             evo_traj tum camera_f2f.tum camera_causal.tum camera_smoothed.tum --ref camera_truth.tum -p\n\
             evo_rpe tum objects/<id>_truth.tum objects/<id>_smoothed_1.tum --delta 1 --delta_unit f\n\
             evo_rpe kitti objects/<id>_truth_<n>.kitti objects/<id>_smoothed_<n>.kitti --delta 1 --delta_unit f\n",
        );
    } else {
        text.push_str(
            "  evo_traj tum camera_f2f.tum camera_causal.tum camera_smoothed.tum -p\n\
             evo_traj tum objects/*_smoothed_*.tum -p   # no truth in a tracks file: no RPE\n",
        );
    }
    let path = dir.join("README.txt");
    dynotraj_formats::atomic::write_file(&path, text).with_context(|| format!("writing {}", path.display()))
}

/// Formats a pose as `tx,ty,tz,qx,qy,qz,qw`.
fn pose_cols(p: &Isometry3<f64>) -> String {
    let t = p.translation.vector;
    let q = p.rotation.coords;
    format!("{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.9}", t.x, t.y, t.z, q.x, q.y, q.z, q.w)
}

/// The per-frame CSV log: for every frame, the truth (when known) and each estimate kind, one row
/// for the camera and one per object, with pose, world motion and bird's-eye state.
fn write_log(
    path: &Path,
    frames: &[(u32, u64)],
    truth: Option<&[SimFrame]>,
    run: &EstimatorRun,
    clock: FileClock,
) -> anyhow::Result<()> {
    let mut s = String::from(
        "frame,time_s,kind,entity,segment,tx,ty,tz,qx,qy,qz,qw,motion_tx,motion_ty,motion_tz,motion_qx,motion_qy,motion_qz,motion_qw,bev_x,bev_y,heading,speed,heading_rate\n",
    );
    let empty_motion = ",,,,,,";
    let empty_bev = ",,,,";
    for (i, &(frame, _)) in frames.iter().enumerate() {
        let t = clock.seconds(frame);
        if let Some(f) = truth.and_then(|tr| tr.get(i)) {
            let _ = writeln!(s, "{frame},{t:.6},truth,camera,,{},{empty_motion},{empty_bev}", pose_cols(&f.camera));
            for o in &f.objects {
                let _ = writeln!(
                    s,
                    "{frame},{t:.6},truth,{},,{},{empty_motion},{empty_bev}",
                    o.object_id,
                    pose_cols(&o.pose)
                );
            }
        }
        for kind in Kind::ALL {
            let Some(Some(e)) = run.of(kind).get(i) else { continue };
            let _ = writeln!(
                s,
                "{frame},{t:.6},{},camera,,{},{empty_motion},{empty_bev}",
                kind.name(),
                pose_cols(&f64_pose(&e.camera))
            );
            for o in &e.objects {
                let b = o.bev;
                let _ = writeln!(
                    s,
                    "{frame},{t:.6},{},{},{},{},{},{:.6},{:.6},{:.6},{:.6},{:.6}",
                    kind.name(),
                    o.object_id,
                    o.segment,
                    pose_cols(&f64_pose(&o.pose)),
                    pose_cols(&f64_pose(&o.motion)),
                    b.x,
                    b.y,
                    b.heading,
                    b.speed,
                    o.heading_rate
                );
            }
        }
    }
    dynotraj_formats::atomic::write_file(path, s).with_context(|| format!("writing {}", path.display()))
}
