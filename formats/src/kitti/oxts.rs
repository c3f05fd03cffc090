//! KITTI oxts (GPS/IMU) files and their conversion to ego poses.
//!
//! A packet is one line of 30 whitespace-separated numbers (KITTI raw data `dataformat.txt`):
//! `lat lon alt roll pitch yaw vn ve vf vl vu ax ay az af al au wx wy wz wf wl wu pos_accuracy
//! vel_accuracy navstat numsats posmode velmode orimode`. In the tracking benchmark layout,
//! `oxts/NNNN.txt` holds one packet per frame, line `k` = frame `k` (so blank lines are only
//! accepted at the end). The raw-data layout (`oxts/data/%010d.txt`, one packet per file) can be
//! read file by file with [`parse_oxts`] and concatenated.
//!
//! Conversion to poses follows the devkit's `convertOxtsToPose.m`: a Mercator projection with
//! scale `cos(lat0)` taken from the first packet gives the IMU position (east, north, up) in
//! metres, the attitude is `R = Rz(yaw) Ry(pitch) Rx(roll)`, and poses are expressed relative to
//! the first one, so `T_imu0_imuk` starts at the identity. The IMU frame is x forward, y left,
//! z up.

use std::f64::consts::PI;
use std::path::Path;

use nalgebra::{Isometry3, Translation3, UnitQuaternion, Vector3};

use super::calib::Calib;
use super::error::KittiError;
use super::text::{LineCtx, quote, read_text};

/// Earth radius of the devkit's Mercator projection, metres.
pub const EARTH_RADIUS_M: f64 = 6_378_137.0;

/// Column names of an oxts line.
pub const OXTS_COLUMNS: [&str; 30] = [
    "lat",
    "lon",
    "alt",
    "roll",
    "pitch",
    "yaw",
    "vn",
    "ve",
    "vf",
    "vl",
    "vu",
    "ax",
    "ay",
    "az",
    "af",
    "al",
    "au",
    "wx",
    "wy",
    "wz",
    "wf",
    "wl",
    "wu",
    "pos_accuracy",
    "vel_accuracy",
    "navstat",
    "numsats",
    "posmode",
    "velmode",
    "orimode",
];

/// One oxts packet. Units as in the KITTI raw data `dataformat.txt`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct OxtsPacket {
    /// Latitude, degrees.
    pub lat: f64,
    /// Longitude, degrees.
    pub lon: f64,
    /// Altitude, metres.
    pub alt: f64,
    /// Roll, radians (0 = level, positive = left side up).
    pub roll: f64,
    /// Pitch, radians (0 = level, positive = front down).
    pub pitch: f64,
    /// Heading, radians (0 = east, positive = counter-clockwise).
    pub yaw: f64,
    /// Velocity towards north, m/s.
    pub vn: f64,
    /// Velocity towards east, m/s.
    pub ve: f64,
    /// Forward velocity, m/s.
    pub vf: f64,
    /// Leftward velocity, m/s.
    pub vl: f64,
    /// Upward velocity, m/s.
    pub vu: f64,
    /// Acceleration in x (vehicle frame), m/s².
    pub ax: f64,
    /// Acceleration in y, m/s².
    pub ay: f64,
    /// Acceleration in z, m/s².
    pub az: f64,
    /// Forward acceleration, m/s².
    pub af: f64,
    /// Leftward acceleration, m/s².
    pub al: f64,
    /// Upward acceleration, m/s².
    pub au: f64,
    /// Angular rate around x, rad/s.
    pub wx: f64,
    /// Angular rate around y, rad/s.
    pub wy: f64,
    /// Angular rate around z, rad/s.
    pub wz: f64,
    /// Angular rate around forward axis, rad/s.
    pub wf: f64,
    /// Angular rate around leftward axis, rad/s.
    pub wl: f64,
    /// Angular rate around upward axis, rad/s.
    pub wu: f64,
    /// Position accuracy (north/east), metres.
    pub pos_accuracy: f64,
    /// Velocity accuracy (north/east), m/s.
    pub vel_accuracy: f64,
    /// Navigation status.
    pub navstat: i32,
    /// Number of satellites tracked by the primary GPS receiver.
    pub numsats: i32,
    /// Position mode of the primary GPS receiver.
    pub posmode: i32,
    /// Velocity mode of the primary GPS receiver.
    pub velmode: i32,
    /// Orientation mode of the primary GPS receiver.
    pub orimode: i32,
}

impl OxtsPacket {
    fn from_values(v: &[f64; 25], s: [i32; 5]) -> OxtsPacket {
        OxtsPacket {
            lat: v[0],
            lon: v[1],
            alt: v[2],
            roll: v[3],
            pitch: v[4],
            yaw: v[5],
            vn: v[6],
            ve: v[7],
            vf: v[8],
            vl: v[9],
            vu: v[10],
            ax: v[11],
            ay: v[12],
            az: v[13],
            af: v[14],
            al: v[15],
            au: v[16],
            wx: v[17],
            wy: v[18],
            wz: v[19],
            wf: v[20],
            wl: v[21],
            wu: v[22],
            pos_accuracy: v[23],
            vel_accuracy: v[24],
            navstat: s[0],
            numsats: s[1],
            posmode: s[2],
            velmode: s[3],
            orimode: s[4],
        }
    }
}

/// Parses oxts text, one packet per line; `path` is only used in error messages. The five
/// status fields must be integers (`4` or `4.0`); all others finite numbers.
///
/// # Errors
/// [`KittiError::Parse`] naming the line and field for a column count other than 30 (an empty
/// line before the last packet included), a non-finite number or a non-integer status field.
pub fn parse_oxts(text: &str, path: &Path) -> Result<Vec<OxtsPacket>, KittiError> {
    let lines: Vec<&str> = text.lines().collect();
    let last = lines.iter().rposition(|l| !l.trim().is_empty()).map_or(0, |i| i + 1);
    let mut out = Vec::with_capacity(last);
    for (i, line) in lines[..last].iter().enumerate() {
        let ctx = LineCtx { path, line: i + 1 };
        let toks: Vec<&str> = line.split_whitespace().collect();
        if toks.len() != OXTS_COLUMNS.len() {
            let (field, column) = if toks.len() < OXTS_COLUMNS.len() {
                (OXTS_COLUMNS[toks.len()], toks.len() + 1)
            } else {
                ("(extra column)", OXTS_COLUMNS.len() + 1)
            };
            let found = if toks.is_empty() { "an empty line".to_string() } else { format!("{} columns", toks.len()) };
            return Err(ctx.error(
                field,
                Some(column),
                "30 whitespace-separated columns (one packet per frame)",
                found,
            ));
        }
        let mut v = [0.0; 25];
        for (j, slot) in v.iter_mut().enumerate() {
            *slot = ctx.finite(toks[j], OXTS_COLUMNS[j], Some(j + 1))?;
        }
        let mut s = [0i32; 5];
        for (k, slot) in s.iter_mut().enumerate() {
            let j = 25 + k;
            let n = ctx.integral(toks[j], OXTS_COLUMNS[j], Some(j + 1))?;
            *slot = i32::try_from(n)
                .map_err(|_| ctx.error(OXTS_COLUMNS[j], Some(j + 1), "a 32-bit integer", quote(toks[j])))?;
        }
        out.push(OxtsPacket::from_values(&v, s));
    }
    Ok(out)
}

/// Reads an oxts file (tracking layout: one packet per frame).
///
/// # Errors
/// As [`parse_oxts`]; a file that does not exist is [`KittiError::Missing`], other read
/// failures [`KittiError::Io`].
pub fn read_oxts(path: impl AsRef<Path>) -> Result<Vec<OxtsPacket>, KittiError> {
    let path = path.as_ref();
    parse_oxts(&read_text(path, "oxts file")?, path)
}

/// Devkit Mercator projection: `(x east, y north)` in metres for latitude/longitude in degrees
/// and the projection scale `cos(lat0)`.
#[must_use]
pub fn lat_lon_to_mercator(lat: f64, lon: f64, scale: f64) -> (f64, f64) {
    let x = scale * lon * PI * EARTH_RADIUS_M / 180.0;
    let y = scale * EARTH_RADIUS_M * ((90.0 + lat) * PI / 360.0).tan().ln();
    (x, y)
}

/// Absolute pose of the IMU in the Mercator frame (east, north, up) for one packet.
fn imu_pose_mercator(p: &OxtsPacket, scale: f64) -> Isometry3<f64> {
    let (x, y) = lat_lon_to_mercator(p.lat, p.lon, scale);
    let rot = UnitQuaternion::from_axis_angle(&Vector3::z_axis(), p.yaw)
        * UnitQuaternion::from_axis_angle(&Vector3::y_axis(), p.pitch)
        * UnitQuaternion::from_axis_angle(&Vector3::x_axis(), p.roll);
    Isometry3::from_parts(Translation3::new(x, y, p.alt), rot)
}

/// IMU poses `T_imu0_imuk` the devkit way (see the module docs); the first is the identity.
/// Empty input gives an empty output.
#[must_use]
pub fn oxts_to_imu_poses(packets: &[OxtsPacket]) -> Vec<Isometry3<f64>> {
    let Some(first) = packets.first() else {
        return Vec::new();
    };
    let scale = (first.lat * PI / 180.0).cos();
    let t0_inv = imu_pose_mercator(first, scale).inverse();
    packets.iter().map(|p| t0_inv * imu_pose_mercator(p, scale)).collect()
}

/// Rectified camera-0 poses `T_world_cam(k)` from oxts, with the world frame = camera 0 at the
/// first packet (so the first pose is the identity):
/// `T_cam_imu * T_imu0_imuk * T_cam_imu⁻¹`, with `T_cam_imu` from [`Calib::t_cam_imu_isometry`].
#[must_use]
pub fn camera_poses_from_oxts(packets: &[OxtsPacket], calib: &Calib) -> Vec<Isometry3<f64>> {
    let t_cam_imu = calib.t_cam_imu_isometry();
    let t_imu_cam = t_cam_imu.inverse();
    oxts_to_imu_poses(packets).into_iter().map(|p| t_cam_imu * p * t_imu_cam).collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kitti::calib::parse_calib;
    use nalgebra::Rotation3;
    use std::path::PathBuf;

    fn p() -> PathBuf {
        PathBuf::from("oxts/0003.txt")
    }

    /// A level packet at `(lat, lon)` heading `yaw`.
    fn packet(lat: f64, lon: f64, yaw: f64) -> OxtsPacket {
        let mut v = [0.0; 25];
        (v[0], v[1], v[2], v[5]) = (lat, lon, 112.5, yaw);
        OxtsPacket::from_values(&v, [4, 10, 4, 4, 4])
    }

    fn line(p: &OxtsPacket) -> String {
        let mut s = format!("{} {} {} {} {} {}", p.lat, p.lon, p.alt, p.roll, p.pitch, p.yaw);
        for _ in 6..25 {
            s.push_str(" 0.01");
        }
        s.push_str(" 4 10 4 4 4");
        s
    }

    /// Camera frame (x right, y down, z forward) from velodyne/IMU (x forward, y left, z up).
    const AXES_CALIB: &str = "P0: 700 0 600 0 0 700 180 0 0 0 1 0\nP1: 700 0 600 -378 0 700 180 0 0 0 1 0\n\
        P2: 700 0 600 0 0 700 180 0 0 0 1 0\nP3: 700 0 600 -378 0 700 180 0 0 0 1 0\n\
        R_rect 1 0 0 0 1 0 0 0 1\nTr_velo_cam 0 -1 0 0 0 0 -1 -0.08 1 0 0 -0.27\n\
        Tr_imu_velo 1 0 0 -0.81 0 1 0 0.32 0 0 1 -0.80\n";

    #[test]
    fn parses_packets_and_status_fields() {
        let pk = packet(48.98765432101, 8.39876543211, -1.25);
        let text = format!("{}\n{}\n\n", line(&pk), line(&pk).replace(" 4 10 4 4 4", " 4.0 9 4 4 4"));
        let packets = parse_oxts(&text, &p()).unwrap();
        assert_eq!(packets.len(), 2);
        assert_eq!(packets[0].lat, 48.98765432101);
        assert_eq!(packets[0].yaw, -1.25);
        assert_eq!(packets[0].vel_accuracy, 0.01);
        assert_eq!((packets[0].navstat, packets[0].numsats, packets[0].orimode), (4, 10, 4));
        assert_eq!((packets[1].navstat, packets[1].numsats), (4, 9));
    }

    #[test]
    fn malformed_lines_name_line_and_field() {
        let good = line(&packet(49.0, 8.4, 0.0));
        let short: Vec<&str> = good.split_whitespace().take(29).collect();
        let m = parse_oxts(&format!("{good}\n{}\n", short.join(" ")), &p()).unwrap_err().to_string();
        assert!(m.contains("oxts/0003.txt line 2, field `orimode` (column 30)") && m.contains("29 columns"), "{m}");
        let m = parse_oxts(&format!("{good}\n{}\n", good.replacen("112.5", "high", 1)), &p()).unwrap_err().to_string();
        assert_eq!(m, "oxts/0003.txt line 2, field `alt` (column 3): expected a number, found `high`");
        let m = parse_oxts(&good.replace(" 4 10 ", " 4 10.5 "), &p()).unwrap_err().to_string();
        assert!(m.contains("line 1, field `numsats` (column 27): expected an integer"), "{m}");
        let m = parse_oxts(&format!("{good}\n\n{good}\n"), &p()).unwrap_err().to_string();
        assert!(m.contains("line 2") && m.contains("empty line"), "{m}");
    }

    #[test]
    fn rotation_is_rz_ry_rx() {
        let mut pk = packet(49.0, 8.4, 0.3);
        (pk.roll, pk.pitch) = (0.1, -0.2);
        let r = imu_pose_mercator(&pk, 1.0).rotation.to_rotation_matrix();
        let expected = Rotation3::from_axis_angle(&Vector3::z_axis(), 0.3)
            * Rotation3::from_axis_angle(&Vector3::y_axis(), -0.2)
            * Rotation3::from_axis_angle(&Vector3::x_axis(), 0.1);
        assert!((r.matrix() - expected.matrix()).norm() < 1e-12);
    }

    #[test]
    fn straight_drive_north_one_metre_per_frame() {
        let lat0 = 48.98765432101;
        let dlat = 180.0 / (PI * EARTH_RADIUS_M); // one metre north, in degrees
        let packets: Vec<OxtsPacket> =
            (0..20).map(|k| packet(lat0 + k as f64 * dlat, 8.39876543211, PI / 2.0)).collect();

        let imu = oxts_to_imu_poses(&packets);
        assert_eq!(imu.len(), 20);
        assert!((imu[0].to_homogeneous() - nalgebra::Matrix4::identity()).norm() < 1e-12);
        // Heading north = IMU x axis: the IMU moves along its own x. The Mercator scale drifts
        // by tan(lat) * dlat (~2e-7 per metre here), hence the 1e-4 m tolerance over 20 m.
        for (k, pose) in imu.iter().enumerate() {
            let t = pose.translation.vector;
            assert!((t - Vector3::new(k as f64, 0.0, 0.0)).norm() < 1e-4, "{k}: {t}");
            assert!(pose.rotation.angle() < 1e-12);
        }

        // Axis-permutation calibration: camera z = IMU x, so the camera moves along its z.
        let calib = parse_calib(AXES_CALIB, &p()).unwrap();
        let cams = camera_poses_from_oxts(&packets, &calib);
        assert!((cams[0].to_homogeneous() - nalgebra::Matrix4::identity()).norm() < 1e-12);
        for (k, pose) in cams.iter().enumerate() {
            let t = pose.translation.vector;
            assert!((t - Vector3::new(0.0, 0.0, k as f64)).norm() < 1e-4, "{k}: {t}");
        }
        // With a KITTI-like calibration (small tilts, offsets) the steps are still ~1 m and the
        // first pose the identity.
        let real = parse_calib(&crate::kitti::test_support::calib_object_style(), &p()).unwrap();
        let cams = camera_poses_from_oxts(&packets, &real);
        assert!((cams[0].to_homogeneous() - nalgebra::Matrix4::identity()).norm() < 1e-9);
        for w in cams.windows(2) {
            let step = (w[1].translation.vector - w[0].translation.vector).norm();
            assert!((step - 1.0).abs() < 1e-4, "{step}");
            assert!(w[1].translation.vector.z > w[0].translation.vector.z + 0.99);
        }
    }

    #[test]
    fn turning_left_rotates_about_camera_minus_y() {
        let packets: Vec<OxtsPacket> = (0..5).map(|k| packet(49.0, 8.4, 0.5 + 0.1 * k as f64)).collect();
        let calib = parse_calib(AXES_CALIB, &p()).unwrap();
        let cams = camera_poses_from_oxts(&packets, &calib);
        for (k, pose) in cams.iter().enumerate().skip(1) {
            let (axis, angle) = pose.rotation.axis_angle().unwrap();
            assert!((angle - 0.1 * k as f64).abs() < 1e-9);
            assert!((axis.into_inner() - -Vector3::y()).norm() < 1e-9, "{axis:?}");
        }
        assert!(oxts_to_imu_poses(&[]).is_empty());
    }
}
