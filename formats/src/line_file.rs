//! The error of a line-oriented text file (drive manifests, pedestrian recordings): the file,
//! and the line with what was expected and found there.

use std::path::PathBuf;

/// A line-oriented text file that cannot be used, naming the file and line.
#[derive(Debug, thiserror::Error)]
pub enum LineFileError {
    /// The file cannot be read.
    #[error("{}: cannot read the {kind}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// What the file was to be (`drive manifest`).
        kind: &'static str,
        /// The error.
        source: std::io::Error,
    },
    /// A line does not hold what a line of this file holds.
    #[error("{} line {line}: {what}", path.display())]
    Line {
        /// The file.
        path: PathBuf,
        /// The line number (1-based).
        line: usize,
        /// What was expected and found.
        what: String,
    },
    /// No line holds anything.
    #[error("{}: {expected}", path.display())]
    Empty {
        /// The file.
        path: PathBuf,
        /// What an entry is and what lines were expected.
        expected: &'static str,
    },
}
