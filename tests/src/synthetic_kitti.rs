//! KITTI tracking layouts written from the simulators' synthetic drives
//! ([`dynotraj_sim::kitti_layout`]), for tests that run the commands end to end.

use std::path::Path;

use dynotraj_sim::drive::{DriveSpec, SyntheticDrive, generate};

/// The four synthetic drives the benchmark's end-to-end tests share: sequence ids and seeds.
pub const FOUR_DRIVES: [(&str, u64); 4] = [("0000", 1), ("0001", 8), ("0002", 9), ("0003", 4)];

/// Writes `drive` as sequence `id` of a KITTI tracking layout under `root`.
///
/// # Panics
/// When a file cannot be written (a test's temporary folder).
pub fn write_sequence(root: &Path, id: &str, drive: &SyntheticDrive) {
    dynotraj_sim::kitti_layout::write_sequence(root, id, drive).expect("writing a synthetic KITTI sequence");
}

/// Writes each `(id, seed)` of `drives` as that sequence of a KITTI tracking layout under
/// `root`: the synthetic drive of that seed with labels 5 cm off the truth.
///
/// # Panics
/// When a file cannot be written (a test's temporary folder).
pub fn write_drives(root: &Path, drives: &[(&str, u64)]) {
    for &(id, seed) in drives {
        write_sequence(root, id, &generate(&DriveSpec { seed, label_noise_m: 0.05, ..DriveSpec::default() }));
    }
}
