//! Input files read with a limit that the format sets, never one the file reports: a device or
//! a pipe reports length 0 (`/dev/zero` never ends), so the limit is applied to what is read.

use std::io::Read as _;
use std::path::Path;

use anyhow::Context as _;

/// The bytes of the file (or device, or pipe) at `path`, when it holds at most `limit` bytes;
/// `what` names the kind of file in the error. At most `limit + 1` bytes are read.
///
/// # Errors
/// The file cannot be opened or read, or holds more than `limit` bytes, named.
pub fn read_at_most(path: &Path, limit: u64, what: &str) -> anyhow::Result<Vec<u8>> {
    let file = std::fs::File::open(path).with_context(|| format!("reading {}", path.display()))?;
    let mut bytes = Vec::new();
    file.take(limit.saturating_add(1))
        .read_to_end(&mut bytes)
        .with_context(|| format!("reading {}", path.display()))?;
    anyhow::ensure!(
        bytes.len() as u64 <= limit,
        "{}: expected {what} of at most {limit} bytes, found more",
        path.display()
    );
    Ok(bytes)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_endless_device_is_refused_after_the_limit() {
        let e = read_at_most(Path::new("/dev/zero"), 1000, "a model file").unwrap_err();
        assert_eq!(e.to_string(), "/dev/zero: expected a model file of at most 1000 bytes, found more");
    }

    #[test]
    fn a_file_at_the_limit_is_read_and_one_past_it_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("f");
        std::fs::write(&path, [7u8; 10]).unwrap();
        assert_eq!(read_at_most(&path, 10, "a file").unwrap(), [7u8; 10]);
        assert!(read_at_most(&path, 9, "a file").is_err());
    }
}
