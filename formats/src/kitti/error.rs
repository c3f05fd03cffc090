//! The one error type of the KITTI readers and writers.
//!
//! Every message names the file it is about. Parse errors also give the 1-based line number,
//! the field (the KITTI column name, e.g. `rotation_y`, `P2`, `tz`), the 1-based column where
//! that is meaningful, what was expected and what was found, so that a user can open the file and
//! go straight to the offending token:
//!
//! ```text
//! label_02/0003.txt line 17, field `rotation_y` (column 17): expected a number, found `abc`
//! ```

use std::fmt;
use std::path::PathBuf;

/// Error of every KITTI reader and writer in [`crate::kitti`].
#[derive(Debug, thiserror::Error)]
pub enum KittiError {
    /// The operating system refused to read or write `path` (other than "not found", which is
    /// [`KittiError::Missing`]).
    #[error("{}: {cause}", path.display())]
    Io {
        /// File or directory the operation was about.
        path: PathBuf,
        /// The underlying I/O error (in the message, not a `source`: shown once).
        cause: std::io::Error,
    },

    /// A token or line of `path` does not have the expected form.
    #[error("{} line {line}, field `{field}`{}: expected {expected}, found {found}", path.display(), ColumnNote(*column))]
    Parse {
        /// The file being parsed.
        path: PathBuf,
        /// 1-based line number.
        line: usize,
        /// Name of the field (KITTI column name or calibration key).
        field: String,
        /// 1-based whitespace-separated column of the field, where meaningful.
        column: Option<usize>,
        /// What the reader expected, e.g. "a number".
        expected: String,
        /// What it found; a token from the file is quoted with backticks.
        found: String,
    },

    /// The number of ego poses does not cover exactly the labelled frames of a sequence.
    ///
    /// The rule is `pose count == highest labelled frame + 1`; the readers never truncate or pad
    /// silently.
    #[error(
        "frame count mismatch: {} labels {label_frames} frames (0..={}), but {} has {pose_count} poses; \
         the pose count must equal the highest labelled frame + 1",
        labels_path.display(), label_frames.saturating_sub(1), poses_path.display()
    )]
    FrameCountMismatch {
        /// The label file.
        labels_path: PathBuf,
        /// Highest frame index in the labels + 1.
        label_frames: usize,
        /// The pose (or oxts) file.
        poses_path: PathBuf,
        /// Number of poses in it.
        pose_count: usize,
    },

    /// A sequence id that is no plain name: ids name files and folders (`label_02/<id>.txt`),
    /// so one holding a path separator or `..` could reach outside the tracking directory.
    #[error("{}: sequence `{id}`: {}", root.display(), SEQUENCE_ID_EXPECTED)]
    BadSequenceId {
        /// The tracking directory.
        root: PathBuf,
        /// The id given.
        id: String,
    },
    /// The path of the tracking directory names something that exists but is not a folder.
    #[error("{}: not a folder (the KITTI tracking directory holds label_02/, calib/, ...)", path.display())]
    NotADirectory {
        /// The path given.
        path: PathBuf,
    },
    /// A required file, directory or entry does not exist.
    #[error("{}: {what} not found", path.display())]
    Missing {
        /// The file or directory that is missing, or the file in which `what` is missing.
        path: PathBuf,
        /// What is missing, e.g. "label file" or "calibration key `R_rect` (or `R0_rect`)".
        what: String,
    },
}

/// What a sequence id must be.
pub const SEQUENCE_ID_EXPECTED: &str =
    "expected a sequence id of 1 to 64 letters, digits, `_` or `-` (it names files), e.g. 0003";

/// A sequence id that is no plain name ([`checked_sequence_id`]).
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("{SEQUENCE_ID_EXPECTED}, found `{0}`")]
pub struct SequenceIdError(pub String);

/// `id` when it is a plain name: 1 to 64 ASCII letters, digits, `_` or `-`. Sequence ids name
/// files and folders, in the tracking directory and in outputs.
///
/// # Errors
/// Anything else ([`SequenceIdError`]).
pub fn checked_sequence_id(id: &str) -> Result<&str, SequenceIdError> {
    let plain = (1..=64).contains(&id.len()) && id.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
    if plain { Ok(id) } else { Err(SequenceIdError(id.to_string())) }
}

impl KittiError {
    /// The file or directory this error is about.
    #[must_use]
    pub fn path(&self) -> &std::path::Path {
        match self {
            KittiError::Io { path, .. }
            | KittiError::Parse { path, .. }
            | KittiError::Missing { path, .. }
            | KittiError::NotADirectory { path } => path,
            KittiError::BadSequenceId { root, .. } => root,
            KittiError::FrameCountMismatch { poses_path, .. } => poses_path,
        }
    }
}

/// Formats ` (column N)` or nothing.
struct ColumnNote(Option<usize>);

impl fmt::Display for ColumnNote {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.0 {
            Some(c) => write!(f, " (column {c})"),
            None => Ok(()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn sequence_ids_are_plain_names() {
        for good in ["0003", "drive_2026-12-04", "a"] {
            assert_eq!(checked_sequence_id(good), Ok(good));
        }
        let long = "x".repeat(65);
        for bad in ["", "../../escape", "a/b", "..", ".", "x y", "a\\b", "0003\n", long.as_str()] {
            let e = checked_sequence_id(bad).unwrap_err();
            assert!(e.to_string().contains("expected a sequence id") && e.0 == bad, "{bad}: {e}");
        }
        let tmp = tempfile::tempdir().unwrap();
        std::fs::create_dir(tmp.path().join("label_02")).unwrap();
        let dir = crate::kitti::TrackingDir::open(tmp.path()).unwrap();
        let e = dir.load_sequence("../../etc").unwrap_err();
        assert!(matches!(&e, KittiError::BadSequenceId { id, .. } if id == "../../etc"), "{e}");
        assert!(e.to_string().contains("sequence `../../etc`: expected a sequence id"), "{e}");
    }

    #[test]
    fn parse_message_names_file_line_field_column() {
        let e = KittiError::Parse {
            path: PathBuf::from("label_02/0003.txt"),
            line: 17,
            field: "rotation_y".into(),
            column: Some(17),
            expected: "a number".into(),
            found: "`abc`".into(),
        };
        assert_eq!(
            e.to_string(),
            "label_02/0003.txt line 17, field `rotation_y` (column 17): expected a number, found `abc`"
        );
    }

    #[test]
    fn missing_and_mismatch_messages_name_paths() {
        let e = KittiError::Missing { path: PathBuf::from("calib/0003.txt"), what: "calibration file".into() };
        assert_eq!(e.to_string(), "calib/0003.txt: calibration file not found");
        let e = KittiError::FrameCountMismatch {
            labels_path: PathBuf::from("label_02/0003.txt"),
            label_frames: 144,
            poses_path: PathBuf::from("poses/0003.txt"),
            pose_count: 140,
        };
        let m = e.to_string();
        assert!(
            m.contains("label_02/0003.txt") && m.contains("144") && m.contains("poses/0003.txt") && m.contains("140"),
            "{m}"
        );
    }
}
