//! Output files written whole or not at all: under a temporary name beside the file
//! (`<name>.partial`), renamed to the name once complete, so that an interrupted run or a full
//! disk never leaves a file that looks complete.

use std::ffi::OsString;
use std::path::{Path, PathBuf};

/// The temporary name `path` is written under until it is complete: its file name with
/// `.partial` appended, in the same folder (so the rename stays on one file system).
#[must_use]
pub fn partial_path(path: &Path) -> PathBuf {
    let mut name = path.file_name().map(OsString::from).unwrap_or_default();
    name.push(".partial");
    path.with_file_name(name)
}

/// Checks that an output may be written at `path` by [`write_file`]'s rename: nothing is there
/// yet, or a regular file is. A device, a FIFO, a socket, a folder or a symbolic link is never
/// replaced by a regular file (as root, `--record /dev/null` turned the device into a file): the
/// rule is to refuse, naming what is there.
///
/// # Errors
/// `path` is something other than a regular file, named.
pub fn replaceable(path: &Path) -> std::io::Result<()> {
    match std::fs::symlink_metadata(path) {
        // Nothing there, or nothing that can be looked at (a parent that is a file): the write
        // itself then says what is wrong, naming its file.
        Err(_) => Ok(()),
        Ok(m) if m.file_type().is_file() => Ok(()),
        Ok(m) => {
            let what = if m.file_type().is_symlink() {
                "a symbolic link"
            } else if m.is_dir() {
                "a folder"
            } else {
                "a device, FIFO or socket"
            };
            Err(std::io::Error::other(format!(
                "{}: {what} is there; an output replaces only a regular file (give another path)",
                path.display()
            )))
        }
    }
}

/// Writes `bytes` as the file `path`: to [`partial_path`], then renamed. On an error the
/// temporary file is removed.
///
/// # Errors
/// Something other than a regular file at `path` ([`replaceable`]), or the write or the rename
/// failed.
pub fn write_file(path: &Path, bytes: impl AsRef<[u8]>) -> std::io::Result<()> {
    replaceable(path)?;
    let partial = partial_path(path);
    let written = std::fs::write(&partial, bytes).and_then(|()| std::fs::rename(&partial, path));
    if written.is_err() {
        // Best effort: the error returned says what failed.
        let _ = std::fs::remove_file(&partial);
    }
    written
}

/// Checks, before a command's work starts, that `dir` (the output folder named by `flag`) can
/// be made a folder: neither it nor any ancestor is a file. A training or a soak of minutes must
/// not end in `File exists`; nothing is created, so a refused command leaves nothing behind.
///
/// # Errors
/// `dir` or an ancestor is not a folder, naming the flag and the file.
pub fn output_folder(flag: &str, dir: &std::path::Path) -> anyhow::Result<()> {
    for p in dir.ancestors().filter(|p| !p.as_os_str().is_empty()) {
        if p.exists() {
            anyhow::ensure!(
                p.is_dir(),
                "{flag} {}: expected a folder for the outputs, found a file at {}",
                dir.display(),
                p.display()
            );
            return Ok(());
        }
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn only_a_regular_file_is_replaced() {
        let dir = tempfile::tempdir().unwrap();
        let file = dir.path().join("out.mcap");
        write_file(&file, b"one").unwrap();
        write_file(&file, b"two").unwrap();
        assert_eq!(std::fs::read(&file).unwrap(), b"two");
        let link = dir.path().join("link.mcap");
        std::os::unix::fs::symlink(&file, &link).unwrap();
        let socket = dir.path().join("socket.mcap");
        let _listener = std::os::unix::net::UnixListener::bind(&socket).unwrap();
        for (path, what) in
            [(&link, "a symbolic link"), (&socket, "a device, FIFO or socket"), (&dir.path().to_path_buf(), "a folder")]
        {
            let e = write_file(path, b"three").unwrap_err().to_string();
            assert!(e.contains(what) && e.contains("replaces only a regular file"), "{e}");
        }
        assert_eq!(std::fs::read(&file).unwrap(), b"two", "the link's target is untouched");
        assert!(std::fs::symlink_metadata(&link).unwrap().file_type().is_symlink());
        let e = replaceable(Path::new("/dev/null")).unwrap_err().to_string();
        assert!(e.starts_with("/dev/null: a device, FIFO or socket"), "{e}");
    }

    #[test]
    fn a_file_is_there_whole_or_not_at_all() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("table.csv");
        write_file(&path, "a,b\n1,2\n").unwrap();
        assert_eq!(std::fs::read_to_string(&path).unwrap(), "a,b\n1,2\n");
        assert!(!partial_path(&path).exists());
        assert_eq!(partial_path(&path), dir.path().join("table.csv.partial"));
        // A write that fails (the folder is gone) leaves nothing behind.
        let gone = dir.path().join("gone").join("x.md");
        assert!(write_file(&gone, "x").is_err());
        assert!(!gone.exists() && !partial_path(&gone).exists());
        // A full disk: the old file stays as it was, no partial file is left.
        let full = Path::new("/dev/full");
        if full.exists() {
            assert!(std::fs::write(full, "x").is_err());
        }
    }
}
