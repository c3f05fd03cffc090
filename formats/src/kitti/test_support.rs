//! Synthetic inputs shared by the unit tests of the KITTI readers. The numbers are made up to
//! look like a KITTI drive (they are not copied from KITTI files, which may not enter the repo),
//! and the real data is read from `../shared/kitti` instead (see [`kitti_split`]).

use std::path::PathBuf;

use nalgebra::{Matrix3, Rotation3, Vector3};

use super::text::c_exp;

/// Focal length of the synthetic calibration, pixels.
pub const FX: f64 = 720.0;
/// Grey stereo baseline of the synthetic calibration, metres.
pub const BASELINE: f64 = 0.54;

fn row(key: &str, m: &[f64]) -> String {
    let nums: Vec<String> = m.iter().map(|v| c_exp(*v, 12)).collect();
    format!("{key} {}\n", nums.join(" "))
}

fn rt(r: &Matrix3<f64>, t: Vector3<f64>) -> Vec<f64> {
    let mut v = Vec::with_capacity(12);
    for i in 0..3 {
        v.extend_from_slice(&[r[(i, 0)], r[(i, 1)], r[(i, 2)], t[i]]);
    }
    v
}

/// A synthetic KITTI calibration in the object-detection spelling (`R0_rect:`,
/// `Tr_velo_to_cam:`, `Tr_imu_to_velo:`), rotations rounded to 7 digits like the real files.
pub fn calib_object_style() -> String {
    let round = |m: Matrix3<f64>| m.map(|v| (v * 1e7).round() / 1e7);
    let p = |tx: f64, ty: f64, tz: f64| [FX, 0.0, 610.0, tx, 0.0, FX, 173.0, ty, 0.0, 0.0, 1.0, tz];
    // velodyne (x fwd, y left, z up) -> camera (x right, y down, z fwd), slightly tilted.
    let axes = Matrix3::new(0.0, -1.0, 0.0, 0.0, 0.0, -1.0, 1.0, 0.0, 0.0);
    let r_rect = round(*Rotation3::from_euler_angles(0.0043, -0.0074, 0.0098).matrix());
    let r_velo_cam = round(axes * Rotation3::from_euler_angles(0.0007, 0.0148, -0.0075).matrix());
    let r_imu_velo = round(*Rotation3::from_euler_angles(0.0148, -0.002, -0.0008).matrix());
    let mut s = String::new();
    s += &row("P0:", &p(0.0, 0.0, 0.0));
    s += &row("P1:", &p(-FX * BASELINE, 0.0, 0.0));
    s += &row("P2:", &p(43.2, 0.2, 0.0027));
    s += &row("P3:", &p(43.2 - FX * BASELINE, 2.2, 0.0027));
    s += &row("R0_rect:", r_rect.as_slice_row_major().as_slice());
    s += &row("Tr_velo_to_cam:", &rt(&r_velo_cam, Vector3::new(-0.004, -0.076, -0.27)));
    s += &row("Tr_imu_to_velo:", &rt(&r_imu_velo, Vector3::new(-0.81, 0.32, -0.80)));
    s
}

/// The same calibration in the official tracking devkit spelling (`R_rect`, `Tr_velo_cam`,
/// `Tr_imu_velo`, no colons on those keys).
pub fn calib_devkit_style() -> String {
    calib_object_style()
        .replace("R0_rect:", "R_rect")
        .replace("Tr_velo_to_cam:", "Tr_velo_cam")
        .replace("Tr_imu_to_velo:", "Tr_imu_velo")
}

trait RowMajor {
    fn as_slice_row_major(&self) -> Vec<f64>;
}

impl RowMajor for Matrix3<f64> {
    fn as_slice_row_major(&self) -> Vec<f64> {
        self.transpose().as_slice().to_vec()
    }
}

/// The real KITTI tracking split (the folder holding `label_02/`): `DYNOTRAJ_KITTI`, which names
/// that folder for the scripts, the tests and the CLI alike, else `../shared/kitti/tracking/training`.
/// `None` (after printing why the caller skips) when it is not there.
pub fn kitti_split(test: &str) -> Option<PathBuf> {
    let given = std::env::var_os("DYNOTRAJ_KITTI").map(PathBuf::from).unwrap_or_else(|| {
        // Read at run time first: a reused test binary's compile-time value may name another
        // checkout (see dynotraj_tests::manifest_dir).
        std::env::var_os("CARGO_MANIFEST_DIR")
            .map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")), PathBuf::from)
            .join("../../shared/kitti/tracking/training")
    });
    let split = given.join("label_02").is_dir().then(|| given.clone());
    if split.is_none() {
        dynotraj_testkit::skipped(
            test,
            &format!(
                "real KITTI data not found at {} (expected label_02/ there; set DYNOTRAJ_KITTI \
                    to the tracking split)",
                given.display()
            ),
        );
    }
    split
}
