//! Drive manifests: the text file that lists where a run's drives are.
//!
//! One source of drives per line: a path (a KITTI-layout folder, a ROS 2 bag file or bag
//! folder, or a folder holding such entries), optionally followed by the comma-separated
//! sequence ids to take from a layout folder. `#` starts a comment; blank lines are skipped.
//! Relative paths are taken from the manifest's own folder, so a manifest kept beside its data
//! moves with it. What each path holds is decided by whoever opens it; this module only reads
//! the text.
//!
//! ```text
//! # drives of the November run
//! ../kitti/tracking/training  0000,0003
//! /data/bags/2026-11-03-run7.mcap
//! ```

use std::path::{Path, PathBuf};

use crate::kitti::checked_sequence_id;
use crate::line_file::LineFileError;

/// One line of a manifest that names a source of drives.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ManifestEntry {
    /// The line number (1-based), for errors about this entry.
    pub line: usize,
    /// The path, joined to the manifest's folder when it was relative.
    pub path: PathBuf,
    /// The sequences to take from a layout folder (empty: every one it holds).
    pub sequences: Vec<String>,
}

/// A manifest that cannot be used, naming the file and line.
pub type ManifestError = LineFileError;

/// What an empty manifest is told it lacks.
const NO_DRIVE: &str = "no drive (expected a path per line: a KITTI-layout folder, a ROS 2 bag, or a folder of them)";

/// Reads the manifest at `path`.
///
/// # Errors
/// An unreadable file, a line with more than a path and a sequence list, a bad sequence id or
/// one given twice on a line, or a manifest without any entry, named by file and line.
pub fn read_manifest(path: &Path) -> Result<Vec<ManifestEntry>, ManifestError> {
    let text = std::fs::read_to_string(path).map_err(|source| LineFileError::Io {
        path: path.to_path_buf(),
        kind: "drive manifest",
        source,
    })?;
    let base = path.parent().unwrap_or_else(|| Path::new(""));
    parse_manifest(&text, base)
        .map_err(|(line, what)| LineFileError::Line { path: path.to_path_buf(), line, what })?
        .ok_or_else(|| LineFileError::Empty { path: path.to_path_buf(), expected: NO_DRIVE })
}

/// The entries of manifest text whose relative paths are taken from `base`; `None` when it
/// holds none.
///
/// # Errors
/// The line number and what is wrong with it.
pub fn parse_manifest(text: &str, base: &Path) -> Result<Option<Vec<ManifestEntry>>, (usize, String)> {
    // A byte-order mark (editors on some systems write one) is no part of the first path.
    let text = text.strip_prefix('\u{feff}').unwrap_or(text);
    let mut out = Vec::new();
    for (k, raw) in text.lines().enumerate() {
        let line = k + 1;
        let content = raw.split_once('#').map_or(raw, |(before, _)| before).trim();
        let mut fields = content.split_whitespace();
        let Some(first) = fields.next() else { continue };
        let sequences = match fields.next() {
            Some(list) => sequence_list(list).map_err(|what| (line, what))?,
            None => Vec::new(),
        };
        if let Some(extra) = fields.next() {
            return Err((
                line,
                format!(
                    "expected a path and at most a comma-separated sequence list, found a third field `{extra}` (a path \
                     with spaces is not supported)"
                ),
            ));
        }
        let given = Path::new(first);
        let path = if given.is_absolute() { given.to_path_buf() } else { base.join(given) };
        out.push(ManifestEntry { line, path, sequences });
    }
    Ok((!out.is_empty()).then_some(out))
}

/// The ids of a sequence list `0000,0003`.
fn sequence_list(list: &str) -> Result<Vec<String>, String> {
    let mut ids: Vec<String> = Vec::new();
    for id in list.split(',') {
        let id = checked_sequence_id(id).map_err(|_| {
            format!(
                "sequence `{id}`: expected ids of 1 to 64 letters, digits, `_` or `-`, comma-separated (e.g. 0000,0003)"
            )
        })?;
        if ids.iter().any(|x| x == id) {
            return Err(format!("sequence {id} is given twice (each drive counts once)"));
        }
        ids.push(id.to_string());
    }
    Ok(ids)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn entries_keep_their_lines_and_relative_paths_start_at_the_manifest() {
        let text = "# the drives\n\n../kitti/training  0000,0003   # two of them\n/data/run7.mcap\n";
        let got = parse_manifest(text, Path::new("/m")).unwrap().unwrap();
        assert_eq!(
            got,
            vec![
                ManifestEntry {
                    line: 3,
                    path: PathBuf::from("/m/../kitti/training"),
                    sequences: vec!["0000".into(), "0003".into()]
                },
                ManifestEntry { line: 4, path: PathBuf::from("/data/run7.mcap"), sequences: vec![] },
            ]
        );
    }

    #[test]
    fn a_byte_order_mark_is_no_part_of_the_first_path() {
        let got = parse_manifest("\u{feff}kA 0000\r\nkB\r\n", Path::new("/m")).unwrap().unwrap();
        let paths: Vec<_> = got.iter().map(|e| e.path.clone()).collect();
        assert_eq!(paths, [PathBuf::from("/m/kA"), PathBuf::from("/m/kB")]);
    }

    #[test]
    fn bad_lines_are_named_with_what_was_expected() {
        let err = |text: &str| parse_manifest(text, Path::new("")).unwrap_err();
        assert_eq!(err("a\nb 0000 extra\n").0, 2);
        assert!(err("b 0000 extra").1.contains("third field `extra`"));
        assert!(err("b 00/1").1.contains("sequence `00/1`: expected ids"));
        assert!(err("b 0001,,0002").1.contains("sequence ``"));
        assert!(err("b 0001,0001").1.contains("0001 is given twice"));
        assert_eq!(parse_manifest("# nothing\n  \n", Path::new("")).unwrap(), None);
    }

    #[test]
    fn a_missing_or_empty_manifest_names_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("drives.txt");
        assert!(read_manifest(&path).unwrap_err().to_string().contains("drives.txt: cannot read the drive manifest"));
        std::fs::write(&path, "# none yet\n").unwrap();
        assert!(read_manifest(&path).unwrap_err().to_string().contains("drives.txt: no drive"));
        std::fs::write(&path, "x\nx 0000 y\n").unwrap();
        assert!(read_manifest(&path).unwrap_err().to_string().contains("drives.txt line 2: expected a path"));
    }
}
