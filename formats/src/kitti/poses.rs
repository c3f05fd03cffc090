//! Pose files: the KITTI odometry format (read and write) and the TUM format (write and read).
//!
//! **KITTI**: line `k` holds the 3x4 matrix `[R | t]` of `T_world_cam(k)`, row-major, 12 numbers:
//! `r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz`. The camera is rectified camera 0; the world
//! frame is usually camera 0 at frame 0, so that the first pose is the identity (true for the
//! odometry ground truth and the ORB-SLAM3 estimates here; the reader does not enforce it).
//! Line `k` is frame `k`, so blank lines are only accepted at the end of the file.
//!
//! Rotations are re-orthonormalised (nearest rotation, by SVD) when they deviate from one by
//! rounding only, and rejected beyond [`ORTHONORMAL_TOLERANCE`](super::rigid::ORTHONORMAL_TOLERANCE).
//!
//! **TUM** (Sturm et al. benchmark, also read by `evo`): `timestamp tx ty tz qx qy qz qw`, the
//! pose `T_world_cam` as translation and unit quaternion (scalar last), `#` comment lines.

use std::path::Path;

use nalgebra::{Isometry3, Quaternion, Translation3, UnitQuaternion, Vector3};

use super::error::KittiError;
use super::rigid::{ROTATION_EXPECTED, checked_isometry, isometry_to_3x4};
use super::text::{LineCtx, c_exp, read_text, write_text};

/// Column names of a KITTI pose line.
pub const POSE_COLUMNS: [&str; 12] = ["r11", "r12", "r13", "tx", "r21", "r22", "r23", "ty", "r31", "r32", "r33", "tz"];

/// Column names of a TUM line.
pub const TUM_COLUMNS: [&str; 8] = ["timestamp", "tx", "ty", "tz", "qx", "qy", "qz", "qw"];

/// Largest accepted `| |q| - 1 |` of a TUM quaternion before normalisation.
pub const QUATERNION_NORM_TOLERANCE: f64 = 1e-3;

/// Parses the text of a KITTI pose file; `path` is only used in error messages.
///
/// # Errors
/// [`KittiError::Parse`] naming the line and field for a line without exactly 12 numbers (an
/// empty line before the last pose included), a non-finite number, or a rotation block that is
/// not a rotation up to rounding.
pub fn parse_poses(text: &str, path: &Path) -> Result<Vec<Isometry3<f64>>, KittiError> {
    let lines: Vec<&str> = text.lines().collect();
    let last = lines.iter().rposition(|l| !l.trim().is_empty()).map_or(0, |i| i + 1);
    let mut poses = Vec::with_capacity(last);
    for (i, line) in lines[..last].iter().enumerate() {
        let ctx = LineCtx { path, line: i + 1 };
        let toks: Vec<&str> = line.split_whitespace().collect();
        if toks.len() != 12 {
            let found = if toks.is_empty() { "an empty line".to_string() } else { format!("{} numbers", toks.len()) };
            return Err(ctx.error("pose", None, "12 numbers (a 3x4 row-major matrix; one line per frame)", found));
        }
        let mut m = [0.0; 12];
        for (j, tok) in toks.iter().enumerate() {
            m[j] = ctx.finite(tok, POSE_COLUMNS[j], Some(j + 1))?;
        }
        let iso = checked_isometry(&nalgebra::Matrix3x4::from_row_slice(&m))
            .map_err(|d| ctx.error("rotation", None, ROTATION_EXPECTED, d.to_string()))?;
        poses.push(iso);
    }
    Ok(poses)
}

/// Reads a KITTI pose file: `T_world_cam` per frame.
///
/// # Errors
/// As [`parse_poses`]; a file that does not exist is [`KittiError::Missing`], other read
/// failures [`KittiError::Io`].
pub fn read_poses(path: impl AsRef<Path>) -> Result<Vec<Isometry3<f64>>, KittiError> {
    let path = path.as_ref();
    parse_poses(&read_text(path, "pose file")?, path)
}

/// One KITTI pose line (no newline): the 12 numbers of `[R | t]` in C `%.9e` style, which keeps
/// about 1e-9 relative precision.
#[must_use]
pub fn format_pose_line(pose: &Isometry3<f64>) -> String {
    let m = isometry_to_3x4(pose);
    let mut s = String::with_capacity(12 * 17);
    for r in 0..3 {
        for c in 0..4 {
            if !s.is_empty() {
                s.push(' ');
            }
            s.push_str(&c_exp(m[(r, c)], 9));
        }
    }
    s
}

/// Writes a KITTI pose file, one line per pose.
///
/// # Errors
/// [`KittiError::Io`] when the file cannot be written.
pub fn write_poses(path: impl AsRef<Path>, poses: &[Isometry3<f64>]) -> Result<(), KittiError> {
    let mut text = String::with_capacity(poses.len() * 200);
    for pose in poses {
        text.push_str(&format_pose_line(pose));
        text.push('\n');
    }
    write_text(path.as_ref(), &text)
}

/// One TUM line (no newline): `timestamp tx ty tz qx qy qz qw`, 9 decimals.
#[must_use]
pub fn format_tum_line(timestamp: f64, pose: &Isometry3<f64>) -> String {
    let t = pose.translation.vector;
    let q = pose.rotation.coords; // (x, y, z, w)
    format!("{timestamp:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9} {:.9}", t.x, t.y, t.z, q.x, q.y, q.z, q.w)
}

/// Writes a TUM trajectory file from `(timestamp in seconds, T_world_cam)` pairs.
///
/// # Errors
/// [`KittiError::Io`] when the file cannot be written.
pub fn write_tum(path: impl AsRef<Path>, poses: &[(f64, Isometry3<f64>)]) -> Result<(), KittiError> {
    write_tum_noted(path, &[], poses)
}

/// [`write_tum`] with `notes` as `#` comment lines under the column header (readers of TUM
/// files, evo among them, skip them).
///
/// # Errors
/// [`KittiError::Io`] when the file cannot be written.
pub fn write_tum_noted(
    path: impl AsRef<Path>,
    notes: &[&str],
    poses: &[(f64, Isometry3<f64>)],
) -> Result<(), KittiError> {
    let mut text = String::from("# timestamp tx ty tz qx qy qz qw\n");
    for note in notes {
        text.push_str("# ");
        text.push_str(note);
        text.push('\n');
    }
    for (t, pose) in poses {
        text.push_str(&format_tum_line(*t, pose));
        text.push('\n');
    }
    write_text(path.as_ref(), &text)
}

/// Parses the text of a TUM trajectory file (blank and `#` lines skipped); quaternions are
/// normalised.
///
/// # Errors
/// [`KittiError::Parse`] naming the line and field for a line without 8 numbers, a non-finite
/// number, or a quaternion whose norm is off by more than [`QUATERNION_NORM_TOLERANCE`].
pub fn parse_tum(text: &str, path: &Path) -> Result<Vec<(f64, Isometry3<f64>)>, KittiError> {
    let mut out = Vec::new();
    for (i, line) in text.lines().enumerate() {
        let ctx = LineCtx { path, line: i + 1 };
        let line = line.trim();
        if line.is_empty() || line.starts_with('#') {
            continue;
        }
        let toks: Vec<&str> = line.split_whitespace().collect();
        if toks.len() != 8 {
            return Err(ctx.error(
                "pose",
                None,
                "8 numbers (timestamp tx ty tz qx qy qz qw)",
                format!("{} numbers", toks.len()),
            ));
        }
        let mut v = [0.0; 8];
        for (j, tok) in toks.iter().enumerate() {
            v[j] = ctx.finite(tok, TUM_COLUMNS[j], Some(j + 1))?;
        }
        let q = Quaternion::new(v[7], v[4], v[5], v[6]);
        let norm = q.norm();
        if (norm - 1.0).abs() > QUATERNION_NORM_TOLERANCE {
            return Err(ctx.error("qw", None, "a unit quaternion (qx qy qz qw)", format!("norm {norm:.6}")));
        }
        let pose = Isometry3::from_parts(
            Translation3::from(Vector3::new(v[1], v[2], v[3])),
            UnitQuaternion::from_quaternion(q),
        );
        out.push((v[0], pose));
    }
    Ok(out)
}

/// Reads a TUM trajectory file.
///
/// # Errors
/// As [`parse_tum`]; a file that does not exist is [`KittiError::Missing`], other read
/// failures [`KittiError::Io`].
pub fn read_tum(path: impl AsRef<Path>) -> Result<Vec<(f64, Isometry3<f64>)>, KittiError> {
    let path = path.as_ref();
    parse_tum(&read_text(path, "TUM trajectory file")?, path)
}

#[cfg(test)]
mod tests {
    use super::*;
    use nalgebra::Matrix3;
    use std::path::PathBuf;

    fn p() -> PathBuf {
        PathBuf::from("poses/0003.txt")
    }

    fn sample() -> Vec<Isometry3<f64>> {
        (0..5)
            .map(|k| {
                let k = k as f64;
                Isometry3::new(
                    Vector3::new(0.3 * k, -0.01 * k, 1.1 * k + 1234.5),
                    Vector3::new(0.01 * k, 0.2 * k - 0.3, -0.05 * k),
                )
            })
            .collect()
    }

    fn close(a: &Isometry3<f64>, b: &Isometry3<f64>, tol: f64) -> bool {
        (a.to_homogeneous() - b.to_homogeneous()).norm() < tol
    }

    #[test]
    fn write_read_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("poses.txt");
        let poses = sample();
        write_poses(&path, &poses).unwrap();
        let back = read_poses(&path).unwrap();
        assert_eq!(back.len(), poses.len());
        for (a, b) in poses.iter().zip(&back) {
            assert!(close(a, b, 1e-8), "{a} vs {b}");
        }
        assert_eq!(
            format_pose_line(&Isometry3::identity()),
            "1.000000000e+00 0.000000000e+00 0.000000000e+00 0.000000000e+00 \
             0.000000000e+00 1.000000000e+00 0.000000000e+00 0.000000000e+00 \
             0.000000000e+00 0.000000000e+00 1.000000000e+00 0.000000000e+00"
        );
    }

    #[test]
    fn reads_kitti_style_and_reorthonormalises() {
        let text = "1.000000 0.000000 0.000000 0.000000 0.000000 1.000000 0.000000 0.000000 0.000000 0.000000 1.000000 0.000000\n\
                    0.999887 -0.000125 -0.015012 -0.012500 0.000193 0.999990 0.004500 0.004000 0.015011 -0.004502 0.999877 0.375000\n\n\n";
        let poses = parse_poses(text, &p()).unwrap();
        assert_eq!(poses.len(), 2);
        assert!(close(&poses[0], &Isometry3::identity(), 1e-15));
        let r = poses[1].rotation.to_rotation_matrix().into_inner();
        assert!((r.transpose() * r - Matrix3::identity()).norm() < 1e-12);
        assert!((poses[1].translation.vector.z - 0.375).abs() < 1e-15);
        assert!((r[(0, 2)] - -0.015012).abs() < 1e-5);
    }

    #[test]
    fn malformed_lines_name_line_and_field() {
        let id = "1 0 0 0 0 1 0 0 0 0 1 0";
        let m = parse_poses(&format!("{id}\n1 0 0 0 0 1 0 0 0 0 1\n"), &p()).unwrap_err().to_string();
        assert!(
            m.contains("poses/0003.txt line 2, field `pose`: expected 12 numbers") && m.contains("found 11 numbers"),
            "{m}"
        );
        let m = parse_poses(&format!("{id}\n1 0 0 0 0 1 0 0 0 0 1 x\n"), &p()).unwrap_err().to_string();
        assert_eq!(m, "poses/0003.txt line 2, field `tz` (column 12): expected a number, found `x`");
        let m = parse_poses(&format!("{id}\n\n{id}\n"), &p()).unwrap_err().to_string();
        assert!(m.contains("line 2") && m.contains("an empty line"), "{m}");
        let m = parse_poses("1 0 0 0 0 1 0 0 0 0 1 nan\n", &p()).unwrap_err().to_string();
        assert!(m.contains("field `tz`") && m.contains("finite"), "{m}");
    }

    #[test]
    fn far_from_orthonormal_rejected() {
        let m = parse_poses("1 0 0 0 0 1 0 0 0 0 1 0\n1.2 0 0 0 0 1 0 0 0 0 1 0\n", &p()).unwrap_err().to_string();
        assert!(m.contains("poses/0003.txt line 2, field `rotation`") && m.contains("R^T R"), "{m}");
        let m = parse_poses("-1 0 0 0 0 1 0 0 0 0 1 0\n", &p()).unwrap_err().to_string();
        assert!(m.contains("line 1") && m.contains("det R"), "{m}");
    }

    #[test]
    fn tum_round_trip() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("traj.tum");
        let data: Vec<(f64, Isometry3<f64>)> =
            sample().into_iter().enumerate().map(|(k, p)| (k as f64 * 0.1, p)).collect();
        write_tum(&path, &data).unwrap();
        let back = read_tum(&path).unwrap();
        assert_eq!(back.len(), data.len());
        for ((ta, a), (tb, b)) in data.iter().zip(&back) {
            assert!((ta - tb).abs() < 1e-9);
            assert!(close(a, b, 1e-7), "{a} vs {b}");
        }
        let line = format_tum_line(1.5, &Isometry3::translation(1.0, 2.0, 3.0));
        assert_eq!(
            line,
            "1.500000000 1.000000000 2.000000000 3.000000000 0.000000000 0.000000000 0.000000000 1.000000000"
        );
        let m = parse_tum("0 0 0 0 0 0 0 2\n", &p()).unwrap_err().to_string();
        assert!(m.contains("line 1") && m.contains("unit quaternion"), "{m}");
    }

    #[test]
    fn missing_file() {
        let dir = tempfile::tempdir().unwrap();
        let m = read_poses(dir.path().join("0009.txt")).unwrap_err().to_string();
        assert!(m.contains("0009.txt: pose file not found"), "{m}");
    }
}
