//! Shared helpers of the workspace-level integration tests.

pub mod alloc_counter;
pub mod synthetic_kitti;

use std::path::PathBuf;

/// The KITTI tracking training folder: `$DYNOTRAJ_KITTI`, else `../shared/kitti/tracking/training`
/// beside the workspace. `None` (with a note on stderr) when it is absent, so that tests which
/// need real data skip clearly instead of failing on a machine without it.
#[must_use]
pub fn kitti_training_dir() -> Option<PathBuf> {
    let dir = std::env::var_os("DYNOTRAJ_KITTI").map_or_else(
        || PathBuf::from(concat!(env!("CARGO_MANIFEST_DIR"), "/../../shared/kitti/tracking/training")),
        PathBuf::from,
    );
    if dir.join("label_02").is_dir() {
        Some(dir)
    } else {
        eprintln!("SKIPPED: real KITTI data not found at {} (set DYNOTRAJ_KITTI)", dir.display());
        None
    }
}
