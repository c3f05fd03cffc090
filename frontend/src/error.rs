//! Front-end errors: every one names the file (and what was expected of it).

use std::path::PathBuf;

/// What can go wrong feeding images to the front-end.
#[derive(Debug, thiserror::Error)]
pub enum FrontEndError {
    /// An expected image file does not exist (a missing frame, a missing right image).
    #[error("{path}: missing file ({what})")]
    Missing {
        /// The file.
        path: PathBuf,
        /// Which input it was.
        what: String,
    },
    /// A file exists but does not decode as an image of the expected kind.
    #[error("{path}: cannot decode as {expected}")]
    Unreadable {
        /// The file.
        path: PathBuf,
        /// What kind of image was expected.
        expected: String,
    },
    /// Two images of one frame differ in size.
    #[error("{path}: image is {found_w}x{found_h}, expected {want_w}x{want_h} like {other}")]
    SizeMismatch {
        /// The offending file.
        path: PathBuf,
        /// Its size.
        found_w: i32,
        /// Its size.
        found_h: i32,
        /// The size it must have.
        want_w: i32,
        /// The size it must have.
        want_h: i32,
        /// The file that set the size.
        other: String,
    },
    /// A folder could not be listed or a file could not be read.
    #[error("{path}: {cause}")]
    Io {
        /// The file or folder.
        path: PathBuf,
        /// The cause (in the message, not a `source`: shown once).
        cause: std::io::Error,
    },
    /// An OpenCV call failed (with what the front-end was doing).
    #[error("OpenCV: {context}: {source}")]
    OpenCv {
        /// What was being done.
        context: String,
        /// The cause.
        source: opencv::Error,
    },
    /// A stage failed outside OpenCV: its thread panicked, or it lacked an input it needs.
    #[error("front-end: {0}")]
    Stage(&'static str),
}

/// Wraps an OpenCV error with context.
pub(crate) fn cv(context: &str) -> impl FnOnce(opencv::Error) -> FrontEndError + '_ {
    move |source| FrontEndError::OpenCv { context: context.to_string(), source }
}
