//! KITTI tracking layouts written from the fixtures' synthetic drives (made-up numbers, no KITTI
//! file content), for tests that run the commands end to end where the right answers are known.

use std::fs;
use std::path::Path;

use super::{LabelRow, write_labels, write_poses};
use dynotraj_fixtures::drive::{Drive, INTRINSICS, ObjectLabel};

fn label_row(l: &ObjectLabel) -> LabelRow {
    LabelRow {
        frame: l.frame as usize,
        track_id: i64::from(l.track_id),
        object_type: l.class.kitti_name().to_string(),
        truncated: 0.0,
        occluded: 0,
        alpha: 0.0,
        bbox_left: 100.0,
        bbox_top: 100.0,
        bbox_right: 200.0,
        bbox_bottom: 200.0,
        height: l.size[0],
        width: l.size[1],
        length: l.size[2],
        x: l.location_cam.x,
        y: l.location_cam.y,
        z: l.location_cam.z,
        rotation_y: l.rotation_y,
        score: None,
    }
}

/// Writes `drive` as sequence `id` of a KITTI tracking layout under `root` (labels,
/// calibration, ego poses).
///
/// # Errors
/// A file or folder that cannot be written, named.
pub fn write_sequence(root: &Path, id: &str, drive: &Drive) -> anyhow::Result<()> {
    use anyhow::Context as _;
    for sub in ["label_02", "calib", "ego_poses_orbslam3"] {
        fs::create_dir_all(root.join(sub)).with_context(|| format!("creating {}", root.join(sub).display()))?;
    }
    let rows: Vec<LabelRow> = drive.labels.iter().map(label_row).collect();
    write_labels(root.join(format!("label_02/{id}.txt")), &rows)?;
    write_poses(root.join(format!("ego_poses_orbslam3/{id}.txt")), &drive.camera_poses)?;
    let [fx, _, cx, cy] = INTRINSICS;
    let p = |tx: f64| format!("{fx} 0 {cx} {tx} 0 {fx} {cy} 0 0 0 1 0");
    let calib = format!(
        "P0: {}\nP1: {}\nP2: {}\nP3: {}\nR0_rect: 1 0 0 0 1 0 0 0 1\nTr_velo_to_cam: 0 -1 0 0 0 0 -1 0 1 0 0 \
            0\nTr_imu_to_velo: 1 0 0 0 0 1 0 0 0 0 1 0\n",
        p(0.0),
        p(-0.54 * fx),
        p(0.0),
        p(-0.54 * fx)
    );
    let path = root.join(format!("calib/{id}.txt"));
    fs::write(&path, calib).with_context(|| format!("writing {}", path.display()))
}
