//! KITTI tracking layouts written from the simulators' synthetic drives
//! ([`dynotraj_sim::kitti_layout`]), for tests that run the commands end to end.

use std::path::Path;

use dynotraj_sim::drive::Drive;

/// Writes `drive` as sequence `id` of a KITTI tracking layout under `root`.
///
/// # Panics
/// When a file cannot be written (a test's temporary folder).
pub fn write_sequence(root: &Path, id: &str, drive: &Drive) {
    dynotraj_sim::kitti_layout::write_sequence(root, id, drive).expect("writing a synthetic KITTI sequence");
}
