//! Pose files and the per-frame log of an estimator run, laid out for `evo`:
//!
//! ```text
//! <dir>/camera_truth.{tum,kitti}            true camera poses, every frame
//! <dir>/camera_<kind>.{tum,kitti}           estimated camera poses (kind: f2f, causal, smoothed)
//! <dir>/objects/<id>_truth.tum              true object poses, frames labelled
//! <dir>/objects/<id>_<kind>_<n>.tum         estimated object poses, run n = 1, 2, ... (below)
//! <dir>/objects/<id>_smoothed.kitti         smoothed poses on the frames with a truth pose,
//! <dir>/objects/<id>_truth.kitti            and the truth on the same frames (KITTI files have
//!                                           no timestamps, so evo pairs them by line)
//! <dir>/log.csv                             one row per frame, kind and entity
//! <dir>/README.txt                          the frame rate of the timestamps, evo command lines
//! ```
//!
//! Timestamps are the stream's: frame index over the frame rate the run used (`--rate` for a
//! simulated run, the tracks file's camera rate for a replay; the paper's 20 Hz by default,
//! while KITTI's cameras record at 10 Hz). Every TUM file and the README say which rate, so
//! that speeds read from them (evo's among them) can be taken for what they are.
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
use dynotraj_core::estimate::PoseEstimate;
use dynotraj_core::geometry::Pose3;
use dynotraj_sim::track_sim::SimFrame;
use nalgebra::Isometry3;

use dynotraj_formats::kitti::{write_poses, write_tum_noted};
use dynotraj_sources::estimation::runner::{EstimatorRun, Kind};
use dynotraj_sources::estimation::score::object_runs;

fn f64_pose(p: &Pose3) -> Isometry3<f64> {
    p.cast::<f64>()
}

fn seconds(us: u64) -> f64 {
    us as f64 * 1e-6
}

/// Writes the pose files and the log of `run` on `frames` into `dir` (created if needed).
///
/// # Errors
/// A file or folder that cannot be written, named.
pub fn write_run(dir: &Path, frames: &[SimFrame], run: &EstimatorRun) -> anyhow::Result<()> {
    let objects_dir = dir.join("objects");
    std::fs::create_dir_all(&objects_dir).with_context(|| format!("creating {}", objects_dir.display()))?;
    let meta: Vec<(u32, u64)> = frames.iter().map(|f| (f.frame, f.timestamp_us)).collect();
    let rate = RateNote::of(&meta);
    write_readme(dir, &rate, true)?;
    let truth: Vec<(f64, Isometry3<f64>)> = frames.iter().map(|f| (seconds(f.timestamp_us), f.camera)).collect();
    write_tum_noted(dir.join("camera_truth.tum"), &[&rate.0], &truth)?;
    write_poses(dir.join("camera_truth.kitti"), &truth.iter().map(|p| p.1).collect::<Vec<_>>())?;
    write_estimate_poses(dir, run, &rate, &|k, id| {
        frames.get(k).is_some_and(|f| f.objects.iter().any(|o| o.object_id == id))
    })?;
    let ids: BTreeSet<u16> = frames.iter().flat_map(|f| f.objects.iter().map(|o| o.object_id)).collect();
    for id in ids {
        let truth: Vec<(f64, Isometry3<f64>)> = frames
            .iter()
            .filter_map(|f| f.objects.iter().find(|o| o.object_id == id).map(|o| (seconds(f.timestamp_us), o.pose)))
            .collect();
        write_tum_noted(objects_dir.join(format!("{id}_truth.tum")), &[&rate.0], &truth)?;
        let (mut est, mut tru) = (Vec::new(), Vec::new());
        for (f, e) in frames.iter().zip(run.of(Kind::Smoothed)) {
            let t = f.objects.iter().find(|o| o.object_id == id);
            let p = e.as_ref().and_then(|e| e.objects.iter().find(|o| o.object_id == id));
            if let (Some(t), Some(p)) = (t, p) {
                tru.push(t.pose);
                est.push(f64_pose(&p.pose));
            }
        }
        if !est.is_empty() {
            write_poses(objects_dir.join(format!("{id}_smoothed.kitti")), &est)?;
            write_poses(objects_dir.join(format!("{id}_truth.kitti")), &tru)?;
        }
    }
    write_log(&dir.join("log.csv"), &meta, Some(frames), run)
}

/// Writes the estimated pose files and the log of a run without truth (a recorded tracks file):
/// the files of [`write_run`] less every `*_truth*` file and the log's truth rows. `frames` are
/// (frame index, timestamp in microseconds) in the run's order.
///
/// # Errors
/// A file or folder that cannot be written, named.
pub fn write_estimates(dir: &Path, frames: &[(u32, u64)], run: &EstimatorRun) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let rate = RateNote::of(frames);
    write_readme(dir, &rate, false)?;
    write_estimate_poses(dir, run, &rate, &|_, _| true)?;
    write_log(&dir.join("log.csv"), frames, None, run)
}

/// Camera and object pose files of every estimate kind; `has_truth(k, id)`: whether frame `k`
/// (an index into the run) has a truth pose of object `id` (runs also end where it has none).
fn write_estimate_poses(
    dir: &Path,
    run: &EstimatorRun,
    rate: &RateNote,
    has_truth: &dyn Fn(usize, u16) -> bool,
) -> anyhow::Result<()> {
    let objects_dir = dir.join("objects");
    std::fs::create_dir_all(&objects_dir).with_context(|| format!("creating {}", objects_dir.display()))?;
    for kind in Kind::ALL {
        let est: Vec<(f64, Isometry3<f64>)> =
            run.of(kind).iter().flatten().map(|e| (seconds(e.timestamp_us), f64_pose(&e.camera))).collect();
        write_tum_noted(dir.join(format!("camera_{}.tum", kind.name())), &[&rate.0], &est)?;
        write_poses(dir.join(format!("camera_{}.kitti", kind.name())), &est.iter().map(|p| p.1).collect::<Vec<_>>())?;
    }
    let ids: BTreeSet<u16> = Kind::ALL
        .iter()
        .flat_map(|k| run.of(*k).iter().flatten().flat_map(|e| e.objects.iter().map(|o| o.object_id)))
        .collect();
    for id in ids {
        for kind in Kind::ALL {
            for (n, poses) in object_run_poses(run.of(kind), id, |k| has_truth(k, id)).iter().enumerate() {
                let note = format!(
                    "object {id}, {}: run {} (consecutive frames of one segment with a known heading)",
                    kind.name(),
                    n + 1
                );
                let path = objects_dir.join(format!("{id}_{}_{}.tum", kind.name(), n + 1));
                write_tum_noted(path, &[&note, &rate.0], poses)?;
            }
        }
    }
    Ok(())
}

/// The comment line that says at what rate a file's timestamps advance.
struct RateNote(String);

impl RateNote {
    /// The note for frames `(index, timestamp in microseconds)`: the rate of the mean step
    /// between the first and the last frame.
    fn of(frames: &[(u32, u64)]) -> Self {
        let span = match (frames.first(), frames.last()) {
            (Some(a), Some(b)) if b.0 > a.0 && b.1 > a.1 => Some((b.1 - a.1) as f64 * 1e-6 / f64::from(b.0 - a.0)),
            _ => None,
        };
        Self(match span {
            Some(dt) => format!(
                "timestamps: seconds at {:.3} Hz (one frame every {:.4} s), the rate this run used; KITTI's \
                    cameras record at 10 Hz",
                1.0 / dt,
                dt
            ),
            None => "timestamps: seconds of the stream (fewer than two frames: no rate)".to_string(),
        })
    }
}

/// README.txt beside the pose files: the rate of their timestamps and the evo command lines
/// that read them (`truth`: whether the truth files are there).
fn write_readme(dir: &Path, rate: &RateNote, truth: bool) -> anyhow::Result<()> {
    let mut text = format!(
        "dynotraj estimator output (layout: dynotraj-sources src/estimation/files.rs).\n{}.\n\n\
         Poses are T_world_x in the camera convention of the first frame; object ids are the wire ids\n\
         (KITTI track id + 1). Each objects/<id>_<kind>_<n>.tum holds one run of consecutive frames\n\
         that dynotraj's RPE pairs.\n\nevo command lines (pip install evo):\n",
        rate.0
    );
    if truth {
        text.push_str(
            "  evo_rpe tum camera_truth.tum camera_smoothed.tum --delta 1 --delta_unit f   # camera RPE, 1 frame\n\
             evo_ape tum camera_truth.tum camera_causal.tum --align                     # camera drift\n\
             evo_traj tum camera_f2f.tum camera_causal.tum camera_smoothed.tum --ref camera_truth.tum -p\n\
             evo_rpe tum objects/<id>_truth.tum objects/<id>_smoothed_1.tum --delta 1 --delta_unit f\n\
             evo_rpe kitti objects/<id>_truth.kitti objects/<id>_smoothed.kitti --delta 1 --delta_unit f\n",
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

/// The runs of object `id` in a kind's estimates that RPE pairs ([`object_runs`]), as (seconds,
/// pose); runs of one pose (no pair) are left out.
fn object_run_poses(
    est: &[Option<PoseEstimate>],
    id: u16,
    has_truth: impl Fn(usize) -> bool,
) -> Vec<Vec<(f64, Isometry3<f64>)>> {
    object_runs(est, id, has_truth)
        .into_iter()
        .filter(|r| r.len() >= 2)
        .map(|r| r.into_iter().map(|(_, e, o)| (seconds(e.timestamp_us), f64_pose(&o.pose))).collect())
        .collect()
}

/// Formats a pose as `tx,ty,tz,qx,qy,qz,qw`.
fn pose_cols(p: &Isometry3<f64>) -> String {
    let t = p.translation.vector;
    let q = p.rotation.coords;
    format!("{:.6},{:.6},{:.6},{:.9},{:.9},{:.9},{:.9}", t.x, t.y, t.z, q.x, q.y, q.z, q.w)
}

/// The per-frame CSV log: for every frame, the truth (when known) and each estimate kind, one row
/// for the camera and one per object, with pose, world motion and bird's-eye state.
fn write_log(path: &Path, frames: &[(u32, u64)], truth: Option<&[SimFrame]>, run: &EstimatorRun) -> anyhow::Result<()> {
    let mut s = String::from(
        "frame,time_s,kind,entity,segment,tx,ty,tz,qx,qy,qz,qw,motion_tx,motion_ty,motion_tz,motion_qx,motion_qy,motion_qz,motion_qw,bev_x,bev_y,heading,speed,heading_rate\n",
    );
    let empty_motion = ",,,,,,";
    let empty_bev = ",,,,";
    for (i, &(frame, timestamp_us)) in frames.iter().enumerate() {
        let t = seconds(timestamp_us);
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
