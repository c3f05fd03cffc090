//! KITTI calibration files (`calib/NNNN.txt` of the tracking benchmark).
//!
//! Two spellings of the keys are in use, and both are accepted (with or without a trailing
//! colon after the key):
//!
//! | quantity | numbers | tracking devkit | object-detection style |
//! |---|---|---|---|
//! | projection matrices of cameras 0-3 | 12 each | `P0:` .. `P3:` | `P0:` .. `P3:` |
//! | rectifying rotation of camera 0 | 9 | `R_rect` | `R0_rect:` |
//! | velodyne -> camera 0 (unrectified) | 12 | `Tr_velo_cam` | `Tr_velo_to_cam:` |
//! | IMU -> velodyne | 12 | `Tr_imu_velo` | `Tr_imu_to_velo:` |
//!
//! All matrices are row-major. Other keys (e.g. `Tr_cam_to_road`) are ignored; a key given twice
//! (also under both spellings) is an error, as is a missing required key or a wrong number count.
//! The rotation blocks of `R_rect`, `Tr_velo_cam` and `Tr_imu_velo` must be rotations up to
//! rounding ([`super::rigid::ORTHONORMAL_TOLERANCE`]); they are stored as read.
//!
//! Frames: "camera 0" below means the *rectified* left grey camera, the frame of the KITTI labels
//! and poses (x right, y down, z forward). A point `X` in it projects into image `i` as
//! `P_i * [X; 1]`.

use std::path::Path;

use nalgebra::{Isometry3, Matrix3, Matrix3x4, Matrix4};

use super::error::KittiError;
use super::rigid::{ROTATION_EXPECTED, checked_rotation, homogeneous_3x3, homogeneous_3x4, project_to_isometry};
use super::text::{LineCtx, read_text};

/// Calibration of one KITTI drive.
#[derive(Debug, Clone, PartialEq)]
pub struct Calib {
    /// Projection matrices `P0..P3` of the rectified cameras (0, 1 grey; 2, 3 colour).
    pub p: [Matrix3x4<f64>; 4],
    /// Rectifying rotation of camera 0 (`R_rect` / `R0_rect`).
    pub r_rect: Matrix3<f64>,
    /// Velodyne -> unrectified camera 0 (`Tr_velo_cam` / `Tr_velo_to_cam`).
    pub tr_velo_cam: Matrix3x4<f64>,
    /// IMU -> velodyne (`Tr_imu_velo` / `Tr_imu_to_velo`).
    pub tr_imu_velo: Matrix3x4<f64>,
}

/// The required entries and their spellings.
#[derive(Clone, Copy, PartialEq, Eq, Debug)]
enum Key {
    P(usize),
    RRect,
    TrVeloCam,
    TrImuVelo,
}

impl Key {
    fn from_token(tok: &str) -> Option<Key> {
        Some(match tok.strip_suffix(':').unwrap_or(tok) {
            "P0" => Key::P(0),
            "P1" => Key::P(1),
            "P2" => Key::P(2),
            "P3" => Key::P(3),
            "R_rect" | "R0_rect" => Key::RRect,
            "Tr_velo_cam" | "Tr_velo_to_cam" => Key::TrVeloCam,
            "Tr_imu_velo" | "Tr_imu_to_velo" => Key::TrImuVelo,
            _ => return None,
        })
    }

    fn count(self) -> usize {
        match self {
            Key::RRect => 9,
            _ => 12,
        }
    }

    fn slot(self) -> usize {
        match self {
            Key::P(i) => i,
            Key::RRect => 4,
            Key::TrVeloCam => 5,
            Key::TrImuVelo => 6,
        }
    }

    fn describe(self) -> String {
        match self {
            Key::P(i) => format!("calibration key `P{i}`"),
            Key::RRect => "calibration key `R_rect` (or `R0_rect`)".into(),
            Key::TrVeloCam => "calibration key `Tr_velo_cam` (or `Tr_velo_to_cam`)".into(),
            Key::TrImuVelo => "calibration key `Tr_imu_velo` (or `Tr_imu_to_velo`)".into(),
        }
    }
}

const ALL_KEYS: [Key; 7] = [Key::P(0), Key::P(1), Key::P(2), Key::P(3), Key::RRect, Key::TrVeloCam, Key::TrImuVelo];

/// The calibration text of a rectified stereo pair (`right` = `left` for one camera): P0 = P2
/// = `left`, P1 = P3 = `right` (row-major 3 x 4 projections, the right one's `[3]` being
/// `-fx * baseline`), identity rectification, and the tracking files' velodyne and IMU axes.
#[must_use]
pub fn stereo_calib_text(left: &[f64; 12], right: &[f64; 12]) -> String {
    let row = |p: &[f64; 12]| p.iter().map(|v| format!("{v:e}")).collect::<Vec<_>>().join(" ");
    let (l, r) = (row(left), row(right));
    format!(
        "P0: {l}\nP1: {r}\nP2: {l}\nP3: {r}\nR0_rect: 1 0 0 0 1 0 0 0 1\nTr_velo_to_cam: 0 -1 0 0 0 0 -1 0 1 0 0 0\n\
         Tr_imu_to_velo: 1 0 0 0 0 1 0 0 0 0 1 0\n"
    )
}

/// Parses the text of a calibration file in either spelling; `path` is only used in messages.
///
/// # Errors
/// [`KittiError::Parse`] for a wrong number count, a non-finite number, a duplicate key or a
/// rotation block that is not a rotation; [`KittiError::Missing`] for a missing required key.
pub fn parse_calib(text: &str, path: &Path) -> Result<Calib, KittiError> {
    // (values, line number) per slot.
    let mut found: [Option<(Vec<f64>, usize)>; 7] = Default::default();
    for (i, line) in text.lines().enumerate() {
        let ctx = LineCtx { path, line: i + 1 };
        let toks: Vec<&str> = line.split_whitespace().collect();
        let Some(&key_tok) = toks.first() else {
            continue;
        };
        let Some(key) = Key::from_token(key_tok) else {
            log::debug!("{}: line {}: ignoring calibration key `{key_tok}`", path.display(), i + 1);
            continue;
        };
        let field = key_tok.strip_suffix(':').unwrap_or(key_tok);
        if let Some((_, first)) = &found[key.slot()] {
            return Err(ctx.error(
                field,
                None,
                "each calibration entry once",
                format!("a second {} (first on line {first})", key.describe()),
            ));
        }
        let nums = &toks[1..];
        if nums.len() != key.count() {
            return Err(ctx.error(field, None, &format!("{} numbers", key.count()), format!("{} numbers", nums.len())));
        }
        let values = nums
            .iter()
            .enumerate()
            .map(|(j, tok)| ctx.finite(tok, field, Some(j + 2)))
            .collect::<Result<Vec<f64>, _>>()?;
        let m = &values;
        if let Key::P(_) = key
            && let Some(defect) = projection_defect(m)
        {
            return Err(ctx.error(field, None, PROJECTION_EXPECTED, defect));
        }
        let rotation_ok = match key {
            Key::P(_) => Ok(()),
            Key::RRect => checked_rotation(&Matrix3::from_row_slice(m)).map(|_| ()),
            Key::TrVeloCam | Key::TrImuVelo => {
                checked_rotation(&Matrix3x4::from_row_slice(m).fixed_view::<3, 3>(0, 0).into_owned()).map(|_| ())
            }
        };
        if let Err(defect) = rotation_ok {
            return Err(ctx.error(field, None, ROTATION_EXPECTED, defect.to_string()));
        }
        found[key.slot()] = Some((values, i + 1));
    }

    let mut get = |key: Key| -> Result<Vec<f64>, KittiError> {
        found[key.slot()]
            .take()
            .map(|(v, _)| v)
            .ok_or_else(|| KittiError::Missing { path: path.to_path_buf(), what: key.describe() })
    };
    let mut vals: Vec<Vec<f64>> = Vec::with_capacity(ALL_KEYS.len());
    for key in ALL_KEYS {
        vals.push(get(key)?);
    }
    Ok(Calib {
        p: [
            Matrix3x4::from_row_slice(&vals[0]),
            Matrix3x4::from_row_slice(&vals[1]),
            Matrix3x4::from_row_slice(&vals[2]),
            Matrix3x4::from_row_slice(&vals[3]),
        ],
        r_rect: Matrix3::from_row_slice(&vals[4]),
        tr_velo_cam: Matrix3x4::from_row_slice(&vals[5]),
        tr_imu_velo: Matrix3x4::from_row_slice(&vals[6]),
    })
}

/// What a rectified camera's projection matrix `K [I | t]` must look like.
const PROJECTION_EXPECTED: &str = "a rectified projection matrix: focal lengths P[0][0], P[1][1] from 1 to 100000 px, \
     every entry within 1e7, P[2][2] = 1";

/// Focal lengths a camera can have, pixels: a 1 px focal length is a pinhole the size of a
/// pixel, 100,000 px a telescope; outside, the estimator's f32 arithmetic would be garbage.
const FOCAL_RANGE_PX: std::ops::RangeInclusive<f64> = 1.0..=100_000.0;
/// Largest magnitude of any projection entry (principal points, `-f x baseline`): f32-safe.
const PROJECTION_MAX_ABS: f64 = 1e7;

/// Why the 12 row-major numbers `m` are not a rectified camera's projection matrix, if they
/// are not (an all-zero P0 would otherwise give every depth as zero, and a nonsense ego-motion;
/// a focal length of 1e39 or 1e-300 overflows or vanishes in the estimator's f32).
fn projection_defect(m: &[f64]) -> Option<String> {
    let (fx, fy, w) = (m.first()?, m.get(5)?, m.get(10)?);
    if !FOCAL_RANGE_PX.contains(fx) || !FOCAL_RANGE_PX.contains(fy) {
        return Some(format!("focal lengths {fx} and {fy}"));
    }
    if let Some((j, v)) = m.iter().enumerate().find(|(_, v)| v.abs() > PROJECTION_MAX_ABS) {
        return Some(format!("P[{}][{}] = {v}", j / 4, j % 4));
    }
    ((w - 1.0).abs() > 1e-6).then(|| format!("P[2][2] = {w}"))
}

/// Reads and parses a calibration file.
///
/// # Errors
/// As [`parse_calib`]; a file that does not exist is [`KittiError::Missing`], other read
/// failures [`KittiError::Io`].
pub fn read_calib(path: impl AsRef<Path>) -> Result<Calib, KittiError> {
    let path = path.as_ref();
    parse_calib(&read_text(path, "calibration file")?, path)
}

impl Calib {
    /// Focal length in pixels of the rectified cameras (`P0[0,0]`; all four share it).
    #[must_use]
    pub fn fx(&self) -> f64 {
        self.p[0][(0, 0)]
    }

    /// Vertical focal length in pixels (`P0[1,1]`).
    #[must_use]
    pub fn fy(&self) -> f64 {
        self.p[0][(1, 1)]
    }

    /// Principal point `(cx, cy)` of rectified camera `cam` (0..=3), pixels.
    ///
    /// # Panics
    /// If `cam > 3`.
    #[must_use]
    pub fn principal_point(&self, cam: usize) -> (f64, f64) {
        (self.p[cam][(0, 2)], self.p[cam][(1, 2)])
    }

    /// Horizontal position of rectified camera `cam` (0..=3) in camera-0 coordinates, metres:
    /// `-P[0,3] / P[0,0]` (camera 1 sits at about +0.54 m, camera 2 at about -0.06 m).
    ///
    /// # Panics
    /// If `cam > 3`.
    #[must_use]
    pub fn camera_x_m(&self, cam: usize) -> f64 {
        -self.p[cam][(0, 3)] / self.p[cam][(0, 0)]
    }

    /// Stereo baseline of the grey pair (cameras 0/1), metres: `-P1[0,3] / P1[0,0]`
    /// (P0 has a zero offset). About 0.537 m on KITTI.
    #[must_use]
    pub fn baseline_m(&self) -> f64 {
        self.camera_x_m(1) - self.camera_x_m(0)
    }

    /// Stereo baseline of the colour pair (cameras 2/3), metres: `(P2[0,3] - P3[0,3]) / P2[0,0]`.
    /// About 0.532 m on KITTI.
    #[must_use]
    pub fn baseline_color_m(&self) -> f64 {
        self.camera_x_m(3) - self.camera_x_m(2)
    }

    /// Velodyne -> rectified camera 0 as a 4x4 matrix: `R_rect * Tr_velo_cam`.
    #[must_use]
    pub fn t_cam_velo(&self) -> Matrix4<f64> {
        homogeneous_3x3(&self.r_rect) * homogeneous_3x4(&self.tr_velo_cam)
    }

    /// IMU -> rectified camera 0 as a 4x4 matrix: `R_rect * Tr_velo_cam * Tr_imu_velo`.
    #[must_use]
    pub fn t_cam_imu(&self) -> Matrix4<f64> {
        self.t_cam_velo() * homogeneous_3x4(&self.tr_imu_velo)
    }

    /// [`Calib::t_cam_imu`] as a rigid transform, its rotation block projected onto the nearest
    /// rotation (it is one up to rounding after [`parse_calib`]'s checks).
    #[must_use]
    pub fn t_cam_imu_isometry(&self) -> Isometry3<f64> {
        project_to_isometry(&self.t_cam_imu())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::path::PathBuf;

    use crate::kitti::test_support::{BASELINE, FX, calib_devkit_style, calib_object_style};

    /// Text with line `n` (1-based) replaced by `f(line)`.
    fn edit_line(text: &str, n: usize, f: impl Fn(&str) -> String) -> String {
        text.lines().enumerate().map(|(i, l)| if i + 1 == n { f(l) + "\n" } else { format!("{l}\n") }).collect()
    }

    fn p() -> PathBuf {
        PathBuf::from("calib/0003.txt")
    }

    #[test]
    fn both_spellings_give_identical_calib() {
        let object = calib_object_style();
        let devkit = calib_devkit_style();
        assert!(object.contains("R0_rect:") && devkit.contains("R_rect ") && devkit.contains("Tr_imu_velo "));
        let a = parse_calib(&object, &p()).unwrap();
        let b = parse_calib(&devkit, &p()).unwrap();
        assert_eq!(a, b);
        // Keys with colons in the devkit spelling, and without colons on P lines, also work.
        let c = parse_calib(&devkit.replace("R_rect", "R_rect:").replace("P2:", "P2"), &p()).unwrap();
        assert_eq!(a, c);
        assert_eq!(a.p[1][(0, 3)], -FX * BASELINE);
        assert_eq!(a.p[2][(2, 3)], 0.0027);
        assert_eq!(a.tr_imu_velo[(2, 3)], -0.8);
        assert!((a.r_rect[(1, 0)] - 0.0098).abs() < 1e-4);
    }

    #[test]
    fn a_projection_that_is_no_camera_is_refused_naming_the_line() {
        let text = calib_object_style();
        let zero = "P0: 0 0 0 0 0 0 0 0 0 0 0 0".to_string();
        let e = parse_calib(&edit_line(&text, 1, |_| zero.clone()), &p()).unwrap_err().to_string();
        assert!(e.contains("line 1") && e.contains("focal lengths 0 and 0"), "{e}");
        let flat = "P2: 720 0 610 0 0 720 173 0 0 0 0 0".to_string();
        let e = parse_calib(&edit_line(&text, 3, |_| flat.clone()), &p()).unwrap_err().to_string();
        assert!(e.contains("line 3") && e.contains("P[2][2] = 0"), "{e}");
        // Focal lengths that overflow or vanish in f32, and an entry no camera has.
        for (fx, shown) in [("1e39", "focal lengths 1000000000000"), ("1e-300", "focal lengths 0.000")] {
            let bad = format!("P0: {fx} 0 610 0 0 720 173 0 0 0 1 0");
            let e = parse_calib(&edit_line(&text, 1, |_| bad.clone()), &p()).unwrap_err().to_string();
            assert!(e.contains("line 1") && e.contains(shown) && e.contains("from 1 to 100000 px"), "{e}");
        }
        let far = "P1: 720 0 610 -3e12 0 720 173 0 0 0 1 0".to_string();
        let e = parse_calib(&edit_line(&text, 2, |_| far.clone()), &p()).unwrap_err().to_string();
        assert!(e.contains("line 2") && e.contains("P[0][3] = -3000000000000"), "{e}");
    }

    #[test]
    fn helpers() {
        let c = parse_calib(&calib_object_style(), &p()).unwrap();
        assert_eq!(c.fx(), FX);
        assert_eq!(c.fy(), FX);
        assert!((c.baseline_m() - BASELINE).abs() < 1e-12);
        assert!((c.baseline_color_m() - BASELINE).abs() < 1e-12);
        assert!((c.camera_x_m(2) - -0.06).abs() < 1e-12);
        assert_eq!(c.principal_point(2), (610.0, 173.0));
        // t_cam_imu is the product of the three transforms, and its isometry agrees with it.
        let t = c.t_cam_imu();
        assert_eq!(t.fixed_view::<1, 4>(3, 0), nalgebra::Matrix1x4::new(0.0, 0.0, 0.0, 1.0));
        let iso = c.t_cam_imu_isometry();
        assert!((iso.to_homogeneous() - t).norm() < 1e-5);
        // IMU is behind/above camera and x_imu (forward) maps to z_cam (forward).
        let fwd = t.fixed_view::<3, 3>(0, 0) * nalgebra::Vector3::x();
        assert!(fwd.z > 0.99, "{fwd}");
    }

    #[test]
    fn missing_key_names_key_and_file() {
        let text: String =
            calib_object_style().lines().filter(|l| !l.starts_with("Tr_imu")).map(|l| format!("{l}\n")).collect();
        let m = parse_calib(&text, &p()).unwrap_err().to_string();
        assert!(m.contains("calib/0003.txt") && m.contains("Tr_imu_velo") && m.contains("not found"), "{m}");
        let m = parse_calib("", &p()).unwrap_err().to_string();
        assert!(m.contains("calib/0003.txt") && m.contains("`P0`"), "{m}");
    }

    #[test]
    fn wrong_count_and_bad_number_name_line_and_key() {
        let text = edit_line(&calib_object_style(), 5, |l| l.rsplit_once(' ').unwrap().0.to_string());
        let m = parse_calib(&text, &p()).unwrap_err().to_string();
        assert!(m.contains("calib/0003.txt line 5, field `R0_rect`: expected 9 numbers, found 8 numbers"), "{m}");
        let text = edit_line(&calib_object_style(), 3, |l| {
            let mut t: Vec<&str> = l.split_whitespace().collect();
            t[2] = "zero";
            t.join(" ")
        });
        let m = parse_calib(&text, &p()).unwrap_err().to_string();
        assert!(m.contains("line 3, field `P2` (column 3): expected a number, found `zero`"), "{m}");
    }

    #[test]
    fn duplicates_and_non_rotations_rejected_unknown_ignored() {
        let text = format!("{}R_rect 1 0 0 0 1 0 0 0 1\n", calib_object_style());
        let m = parse_calib(&text, &p()).unwrap_err().to_string();
        assert!(m.contains("line 8") && m.contains("first on line 5"), "{m}");
        let text = edit_line(&calib_object_style(), 5, |l| {
            l.replacen("R0_rect: ", "R0_rect: 2.0 ", 1).rsplit_once(' ').unwrap().0.to_string()
        });
        let m = parse_calib(&text, &p()).unwrap_err().to_string();
        assert!(m.contains("line 5, field `R0_rect`") && m.contains("R^T R"), "{m}");
        let text = format!("Tr_cam_to_road: 1 2 3\n\n{}", calib_object_style());
        assert!(parse_calib(&text, &p()).is_ok());
    }

    #[test]
    fn real_calib_in_both_spellings() {
        let Some(split) = crate::kitti::test_support::kitti_split("real_calib_in_both_spellings") else {
            return;
        };
        let path = split.join("calib/0000.txt");
        let text = std::fs::read_to_string(&path).unwrap();
        let devkit = text
            .replace("R0_rect:", "R_rect")
            .replace("Tr_velo_to_cam:", "Tr_velo_cam")
            .replace("Tr_imu_to_velo:", "Tr_imu_velo");
        let a = parse_calib(&text, &path).unwrap();
        assert_eq!(a, parse_calib(&devkit, &path).unwrap());
        assert!((a.baseline_m() - 0.537).abs() < 1e-3, "{}", a.baseline_m());
        assert!((a.baseline_color_m() - 0.532).abs() < 2e-3, "{}", a.baseline_color_m());
        let fwd = a.t_cam_imu().fixed_view::<3, 3>(0, 0) * nalgebra::Vector3::x();
        assert!(fwd.z > 0.99, "{fwd}");
    }

    #[test]
    fn missing_file() {
        let dir = tempfile::tempdir().unwrap();
        let m = read_calib(dir.path().join("0042.txt")).unwrap_err().to_string();
        assert!(m.contains("0042.txt: calibration file not found"), "{m}");
    }
}
