//! KITTI file formats: readers (and writers where the project produces such files) for the
//! tracking benchmark layout.
//!
//! | file | module | reader | writer |
//! |---|---|---|---|
//! | `label_02/NNNN.txt` labels / tracking results | [`label`] | [`read_labels`] | [`write_labels`] |
//! | `calib/NNNN.txt` (both key spellings) | [`calib`] | [`read_calib`] | |
//! | KITTI pose files (3x4 per line), TUM trajectories | [`poses`] | [`read_poses`], [`read_tum`] | [`write_poses`], [`write_tum`] |
//! | `oxts/NNNN.txt` GPS/IMU | [`oxts`] | [`read_oxts`] | |
//! | a tracking split directory | [`layout`] | [`TrackingDir`] | |
//!
//! Conventions, shared by all modules:
//! - All numbers are `f64`. Frame indices are 0-based; line numbers in errors are 1-based.
//! - "Camera 0" is the *rectified* left grey camera (x right, y down, z forward). Labels are in
//!   this frame, and camera poses are `T_world_cam0`, with the world usually camera 0 at frame 0.
//! - Every error ([`KittiError`]) names the file; parse errors also name the line, the field (the
//!   KITTI column name) and what was expected. Non-finite numbers (`nan`, `inf`) are rejected.
//! - Rotations read from files are re-orthonormalised when off by rounding only, and rejected when
//!   they are not rotations ([`rigid`]).
//! - KITTI data is never copied into the repository: tests read it from `../shared/kitti` or from
//!   `$DYNOTRAJ_KITTI`, and skip with a printed message when it is absent.

pub mod calib;
pub mod error;
pub mod label;
pub mod layout;
pub mod oxts;
pub mod poses;
pub mod rigid;
mod text;

#[cfg(test)]
mod test_support;

pub use calib::{Calib, parse_calib, read_calib, stereo_calib_text};
pub use error::{KittiError, SequenceIdError, checked_sequence_id};
pub use label::{LabelRow, format_label_row, label_frame_count, parse_labels, read_labels, write_labels};
pub use layout::{PoseSource, SequenceData, TrackingDir};
pub use oxts::{OxtsPacket, camera_poses_from_oxts, oxts_to_imu_poses, parse_oxts, read_oxts};
pub use poses::{
    format_pose_line, format_tum_line, parse_poses, parse_tum, read_poses, read_tum, write_poses, write_tum,
    write_tum_noted,
};
