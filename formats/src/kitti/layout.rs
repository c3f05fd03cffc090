//! A KITTI tracking split directory (e.g. `kitti/tracking/training`) and loading one sequence.
//!
//! ```text
//! <split>/label_02/NNNN.txt             object labels (required)
//! <split>/calib/NNNN.txt                calibration (required)
//! <split>/oxts/NNNN.txt                 GPS/IMU, one packet per frame   } ego poses, first one
//! <split>/ego_poses_orbslam3/NNNN.txt   ORB-SLAM3 camera-0 estimates    } present in this order
//! <split>/poses/NNNN.txt                camera-0 poses, KITTI format    } of preference
//! ```
//!
//! `oxts/` is preferred because it is real GPS/IMU; `ego_poses_orbslam3/` holds visual SLAM
//! *estimates*, not ground truth (see `shared/kitti/README.md`); `poses/` is any KITTI-format
//! pose file (e.g. written by this project). [`SequenceData::pose_source`] says which was used.
//!
//! Frame count rule: the number of poses must equal the highest labelled frame + 1 (the labels
//! of KITTI tracking sequences reach the last frame, with `DontCare` rows if nothing else).
//! Anything else is [`KittiError::FrameCountMismatch`]; nothing is truncated or padded.

use std::fmt;
use std::path::{Path, PathBuf};

use nalgebra::Isometry3;

use super::calib::{Calib, read_calib};
use super::error::KittiError;
use super::label::{LabelRow, label_frame_count, read_labels};
use super::oxts::{camera_poses_from_oxts, read_oxts};
use super::poses::read_poses;
use super::text::io_error;

/// Where the camera poses of a sequence came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum PoseSource {
    /// `oxts/NNNN.txt`: GPS/IMU converted with the devkit's method and the calibration.
    Oxts,
    /// `ego_poses_orbslam3/NNNN.txt`: ORB-SLAM3 stereo estimates (not ground truth).
    OrbSlam3,
    /// `poses/NNNN.txt`: a KITTI-format pose file.
    PoseFile,
}

impl PoseSource {
    /// All sources in order of preference.
    pub const PREFERENCE: [PoseSource; 3] = [PoseSource::Oxts, PoseSource::OrbSlam3, PoseSource::PoseFile];

    /// The sub-folder of the split directory that holds this source.
    #[must_use]
    pub fn folder(self) -> &'static str {
        match self {
            PoseSource::Oxts => "oxts",
            PoseSource::OrbSlam3 => "ego_poses_orbslam3",
            PoseSource::PoseFile => "poses",
        }
    }

    /// Whether the poses are measurements (GPS/IMU) rather than estimates from images.
    #[must_use]
    pub fn is_measured(self) -> bool {
        self == PoseSource::Oxts
    }
}

impl fmt::Display for PoseSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            PoseSource::Oxts => "oxts (GPS/IMU)",
            PoseSource::OrbSlam3 => "ORB-SLAM3 estimate",
            PoseSource::PoseFile => "pose file",
        })
    }
}

/// Everything loaded for one tracking sequence.
#[derive(Debug, Clone)]
pub struct SequenceData {
    /// Sequence id, e.g. `"0003"`.
    pub id: String,
    /// All label rows, `DontCare` included (see [`LabelRow::is_dont_care`]).
    pub labels: Vec<LabelRow>,
    /// Calibration.
    pub calib: Calib,
    /// Camera poses `T_world_cam0(k)` for every frame `k` (rectified camera 0).
    pub poses: Vec<Isometry3<f64>>,
    /// Where `poses` came from.
    pub pose_source: PoseSource,
    /// Number of frames: `poses.len()` == highest labelled frame + 1.
    pub frame_count: usize,
    /// The label file read.
    pub labels_path: PathBuf,
    /// The calibration file read.
    pub calib_path: PathBuf,
    /// The pose (or oxts) file read.
    pub poses_path: PathBuf,
}

/// A KITTI tracking split directory such as `kitti/tracking/training`.
#[derive(Debug, Clone)]
pub struct TrackingDir {
    root: PathBuf,
}

impl TrackingDir {
    /// Opens a split directory.
    ///
    /// # Errors
    /// [`KittiError::Missing`] when the directory or its `label_02/` folder does not exist.
    pub fn open(path: impl AsRef<Path>) -> Result<TrackingDir, KittiError> {
        let root = path.as_ref().to_path_buf();
        if root.exists() && !root.is_dir() {
            return Err(KittiError::NotADirectory { path: root });
        }
        if !root.is_dir() {
            return Err(KittiError::Missing { path: root, what: "KITTI tracking directory".into() });
        }
        let labels = root.join("label_02");
        if !labels.is_dir() {
            return Err(KittiError::Missing {
                path: labels,
                what: "label folder `label_02/` of the KITTI tracking directory".into(),
            });
        }
        Ok(TrackingDir { root })
    }

    /// The split directory.
    #[must_use]
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// Ids of the sequences with a label file (`label_02/<digits>.txt`), sorted: `"0000"`, ...
    ///
    /// # Errors
    /// [`KittiError::Missing`] / [`KittiError::Io`] when `label_02/` cannot be listed.
    pub fn sequences(&self) -> Result<Vec<String>, KittiError> {
        let dir = self.root.join("label_02");
        let entries = std::fs::read_dir(&dir).map_err(|e| io_error(&dir, "label folder", e))?;
        let mut ids = Vec::new();
        for entry in entries {
            let entry = entry.map_err(|e| io_error(&dir, "label folder", e))?;
            let name = entry.file_name();
            let Some(name) = name.to_str() else { continue };
            if let Some(stem) = name.strip_suffix(".txt")
                && !stem.is_empty()
                && stem.bytes().all(|b| b.is_ascii_digit())
            {
                ids.push(stem.to_string());
            }
        }
        ids.sort();
        Ok(ids)
    }

    /// Path of `<folder>/<id>.txt`.
    fn file(&self, folder: &str, id: &str) -> PathBuf {
        self.root.join(folder).join(format!("{id}.txt"))
    }

    /// Label file of sequence `id`.
    #[must_use]
    pub fn labels_path(&self, id: &str) -> PathBuf {
        self.file("label_02", id)
    }

    /// Calibration file of sequence `id`.
    #[must_use]
    pub fn calib_path(&self, id: &str) -> PathBuf {
        self.file("calib", id)
    }

    /// The pose file of sequence `id` for `source` (whether or not it exists).
    #[must_use]
    pub fn poses_path(&self, id: &str, source: PoseSource) -> PathBuf {
        self.file(source.folder(), id)
    }

    /// `id` as a plain name, or the error that names the folder and the id.
    fn checked_id<'a>(&self, id: &'a str) -> Result<&'a str, KittiError> {
        super::checked_sequence_id(id).map_err(|e| KittiError::BadSequenceId { root: self.root.clone(), id: e.0 })
    }

    /// The pose sources present for sequence `id`, in order of preference.
    #[must_use]
    pub fn pose_sources(&self, id: &str) -> Vec<PoseSource> {
        PoseSource::PREFERENCE.into_iter().filter(|s| self.poses_path(id, *s).is_file()).collect()
    }

    /// Loads sequence `id` with the preferred pose source present (oxts, then ORB-SLAM3, then
    /// poses/).
    ///
    /// # Errors
    /// [`KittiError::Missing`] when no pose source exists, otherwise as
    /// [`TrackingDir::load_sequence_with`].
    pub fn load_sequence(&self, id: &str) -> Result<SequenceData, KittiError> {
        self.checked_id(id)?;
        let Some(source) = self.pose_sources(id).first().copied() else {
            return Err(KittiError::Missing {
                path: self.root.clone(),
                what: format!(
                    "ego poses for sequence {id} (none of oxts/{id}.txt, ego_poses_orbslam3/{id}.txt, poses/{id}.txt)"
                ),
            });
        };
        self.load_sequence_with(id, source)
    }

    /// Loads sequence `id` with the given pose source.
    ///
    /// # Errors
    /// Any error of reading the label, calibration or pose file (missing, unreadable,
    /// malformed), and [`KittiError::FrameCountMismatch`] unless the pose count equals the highest
    /// labelled frame + 1; [`KittiError::Missing`] when the label file has no rows.
    pub fn load_sequence_with(&self, id: &str, source: PoseSource) -> Result<SequenceData, KittiError> {
        self.checked_id(id)?;
        let labels_path = self.labels_path(id);
        let calib_path = self.calib_path(id);
        let poses_path = self.poses_path(id, source);
        let labels = read_labels(&labels_path)?;
        let calib = read_calib(&calib_path)?;
        let poses = match source {
            PoseSource::Oxts => camera_poses_from_oxts(&read_oxts(&poses_path)?, &calib),
            PoseSource::OrbSlam3 | PoseSource::PoseFile => read_poses(&poses_path)?,
        };
        let Some(label_frames) = label_frame_count(&labels) else {
            return Err(KittiError::Missing {
                path: labels_path,
                what: "label rows (the file is empty, so the frame count is unknown)".into(),
            });
        };
        if poses.len() != label_frames {
            return Err(KittiError::FrameCountMismatch {
                labels_path,
                label_frames,
                poses_path,
                pose_count: poses.len(),
            });
        }
        Ok(SequenceData {
            id: id.to_string(),
            labels,
            calib,
            frame_count: poses.len(),
            poses,
            pose_source: source,
            labels_path,
            calib_path,
            poses_path,
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::kitti::poses::write_poses;
    use crate::kitti::test_support::{calib_object_style, kitti_split};
    use nalgebra::Vector3;

    /// A synthetic split directory with one sequence of `frames` labelled frames and `poses` poses
    /// in `folder`.
    fn synthetic_split(frames: usize, poses: usize, folder: &str) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        for sub in ["label_02", "calib", folder] {
            std::fs::create_dir_all(dir.path().join(sub)).unwrap();
        }
        let mut labels = String::new();
        for k in 0..frames {
            labels += &format!("{k} 0 Car 0 0 -1.5 100 150 200 250 1.5 1.6 4.0 2.0 1.7 {} -1.57\n", 10.0 + k as f64);
        }
        std::fs::write(dir.path().join("label_02/0007.txt"), labels).unwrap();
        std::fs::write(dir.path().join("label_02/README.txt"), "not a sequence").unwrap();
        std::fs::write(dir.path().join("calib/0007.txt"), calib_object_style()).unwrap();
        let ps: Vec<Isometry3<f64>> = (0..poses).map(|k| Isometry3::translation(0.0, 0.0, k as f64)).collect();
        write_poses(dir.path().join(folder).join("0007.txt"), &ps).unwrap();
        dir
    }

    #[test]
    fn open_errors_name_the_path() {
        let dir = tempfile::tempdir().unwrap();
        let m = TrackingDir::open(dir.path().join("nope")).unwrap_err().to_string();
        assert!(m.contains("nope") && m.contains("KITTI tracking directory not found"), "{m}");
        let m = TrackingDir::open(dir.path()).unwrap_err().to_string();
        assert!(m.contains("label_02") && m.contains("not found"), "{m}");
        let file = dir.path().join("a.txt");
        std::fs::write(&file, "x").unwrap();
        let m = TrackingDir::open(&file).unwrap_err().to_string();
        assert!(m.contains("a.txt: not a folder"), "{m}");
    }

    #[test]
    fn loads_synthetic_sequence() {
        let dir = synthetic_split(5, 5, "poses");
        let split = TrackingDir::open(dir.path()).unwrap();
        assert_eq!(split.sequences().unwrap(), vec!["0007".to_string()]);
        assert_eq!(split.pose_sources("0007"), vec![PoseSource::PoseFile]);
        let seq = split.load_sequence("0007").unwrap();
        assert_eq!(seq.frame_count, 5);
        assert_eq!(seq.pose_source, PoseSource::PoseFile);
        assert_eq!(seq.labels.len(), 5);
        assert!((seq.poses[4].translation.vector - Vector3::new(0.0, 0.0, 4.0)).norm() < 1e-9);
        assert!(seq.poses_path.ends_with("poses/0007.txt"));
        // ORB-SLAM3 poses are preferred over poses/.
        let orb = dir.path().join("ego_poses_orbslam3");
        std::fs::create_dir_all(&orb).unwrap();
        std::fs::copy(dir.path().join("poses/0007.txt"), orb.join("0007.txt")).unwrap();
        assert_eq!(split.load_sequence("0007").unwrap().pose_source, PoseSource::OrbSlam3);
    }

    #[test]
    fn truncated_pose_file_is_a_frame_count_mismatch() {
        let dir = synthetic_split(5, 4, "ego_poses_orbslam3");
        let split = TrackingDir::open(dir.path()).unwrap();
        let err = split.load_sequence("0007").unwrap_err();
        assert!(matches!(err, KittiError::FrameCountMismatch { label_frames: 5, pose_count: 4, .. }), "{err:?}");
        let m = err.to_string();
        assert!(m.contains("label_02/0007.txt") && m.contains("ego_poses_orbslam3/0007.txt"), "{m}");
        assert!(m.contains("5 frames") && m.contains("4 poses"), "{m}");
        // Too many poses is an error as well.
        let dir = synthetic_split(5, 6, "poses");
        let err = TrackingDir::open(dir.path()).unwrap().load_sequence("0007").unwrap_err();
        assert!(matches!(err, KittiError::FrameCountMismatch { label_frames: 5, pose_count: 6, .. }), "{err:?}");
    }

    #[test]
    fn missing_pieces_are_named() {
        let dir = synthetic_split(3, 3, "poses");
        let split = TrackingDir::open(dir.path()).unwrap();
        std::fs::write(dir.path().join("label_02/0007.txt"), "\n").unwrap();
        let m = split.load_sequence("0007").unwrap_err().to_string();
        assert!(m.contains("label_02/0007.txt: label rows"), "{m}");
        let m = split.load_sequence("0008").unwrap_err().to_string();
        assert!(m.contains("ego poses for sequence 0008"), "{m}");
        std::fs::remove_file(dir.path().join("calib/0007.txt")).unwrap();
        let m = split.load_sequence("0007").unwrap_err().to_string();
        assert!(m.contains("calib/0007.txt: calibration file not found"), "{m}");
    }

    /// Frame counts of the sequences of the KITTI tracking training set (label max frame + 1 = pose count).
    const REAL_FRAMES: [(&str, usize); 16] = [
        ("0000", 154),
        ("0001", 447),
        ("0002", 233),
        ("0003", 144),
        ("0004", 314),
        ("0005", 297),
        ("0006", 270),
        ("0007", 800),
        ("0008", 390),
        ("0009", 803),
        ("0010", 294),
        ("0011", 373),
        ("0012", 78),
        ("0013", 340),
        ("0018", 339),
        ("0020", 837),
    ];

    #[test]
    fn real_kitti_sequences_load() {
        let Some(root) = kitti_split("real_kitti_sequences_load") else {
            return;
        };
        let split = TrackingDir::open(root).unwrap();
        let ids = split.sequences().unwrap();
        // Every sequence the folder holds is one of those below (a download may hold more of
        // KITTI's 21; the sixteen used here).
        for (id, _) in REAL_FRAMES {
            assert!(ids.iter().any(|i| i == id), "sequence {id} missing from {ids:?}");
        }
        for (id, frames) in REAL_FRAMES {
            let seq = split.load_sequence(id).unwrap_or_else(|e| panic!("sequence {id}: {e}"));
            assert_eq!(seq.frame_count, frames, "sequence {id}");
            assert_eq!(seq.poses.len(), frames);
            assert!(seq.labels.iter().any(|r| !r.is_dont_care()));
            // The ORB-SLAM3 files start at the identity; oxts-derived poses do by construction.
            assert!((seq.poses[0].to_homogeneous() - nalgebra::Matrix4::identity()).norm() < 1e-6);
            assert!((seq.calib.baseline_m() - 0.54).abs() < 0.01, "{id}: {}", seq.calib.baseline_m());
            // Ego motion between frames is a plausible car motion (< 4 m per 0.1 s).
            for w in seq.poses.windows(2) {
                assert!((w[1].translation.vector - w[0].translation.vector).norm() < 4.0, "{id}");
            }
            if !split.pose_sources(id).contains(&PoseSource::Oxts) {
                assert_eq!(seq.pose_source, PoseSource::OrbSlam3);
            }
        }
    }

    #[test]
    fn real_kitti_truncated_poses_mismatch() {
        let Some(real) = kitti_split("real_kitti_truncated_poses_mismatch") else {
            return;
        };
        // Copy (into a temp dir, never into the repo) labels + calib of 0003 and a truncated pose file.
        let dir = tempfile::tempdir().unwrap();
        for sub in ["label_02", "calib", "poses"] {
            std::fs::create_dir_all(dir.path().join(sub)).unwrap();
        }
        for sub in ["label_02", "calib"] {
            std::fs::copy(real.join(sub).join("0003.txt"), dir.path().join(sub).join("0003.txt")).unwrap();
        }
        let poses = read_poses(real.join("ego_poses_orbslam3/0003.txt")).unwrap();
        write_poses(dir.path().join("poses/0003.txt"), &poses[..100]).unwrap();
        let err = TrackingDir::open(dir.path()).unwrap().load_sequence("0003").unwrap_err();
        assert!(matches!(err, KittiError::FrameCountMismatch { label_frames: 144, pose_count: 100, .. }), "{err:?}");
        let m = err.to_string();
        assert!(
            m.contains("144") && m.contains("100") && m.contains("poses/0003.txt") && m.contains("label_02/0003.txt"),
            "{m}"
        );
    }
}
