//! The one file format of every cache (estimated tracks, rendered front-end frames, trained folds):
//! `[key: u64 LE][postcard value][CRC-32 LE of what precedes it]`, written under a temporary
//! name and renamed. A file whose checksum does not match, that holds another key's entry or
//! that does not decode is a miss, never an error.

use std::path::Path;

use anyhow::Context as _;
use crc::{CRC_32_ISO_HDLC, Crc};

/// The checksum every cache file ends in.
const FILE_CRC: Crc<u32> = Crc::<u32>::new(&CRC_32_ISO_HDLC);

/// The value a cache file at `path` holds for `key`, if it is readable, its checksum matches,
/// it was stored under `key` and it decodes; else a miss, with a warning when the file is there
/// but damaged or holds another key's entry.
pub fn load_file<T: serde::de::DeserializeOwned>(path: &Path, key: u64) -> Option<T> {
    let bytes = std::fs::read(path).ok()?;
    let value = decode(&bytes, key);
    if let Err(why) = &value {
        log::warn!("{}: {why}; computed again", path.display());
    }
    value.ok()
}

/// The value of a cache file's bytes for `key`: `[key: u64 LE][postcard value][CRC-32 LE of
/// what precedes it]`.
///
/// # Errors
/// What is wrong with the bytes, in words: a checksum that does not match, another key's
/// entry, or a value that does not decode.
pub fn decode<T: serde::de::DeserializeOwned>(bytes: &[u8], key: u64) -> Result<T, &'static str> {
    let (body, crc) = bytes.split_last_chunk::<4>().ok_or("a damaged cache file (too short)")?;
    if FILE_CRC.checksum(body) != u32::from_le_bytes(*crc) {
        return Err("a damaged cache file (checksum)");
    }
    let (stored_key, payload) = body.split_first_chunk::<8>().ok_or("a damaged cache file (no key)")?;
    if u64::from_le_bytes(*stored_key) != key {
        return Err("a cache file holding another key's entry (renamed or copied)");
    }
    postcard::from_bytes(payload).map_err(|_| "a damaged cache file (contents)")
}

/// Writes `value` under `key` as the cache file `path` in `dir` (created if missing); `what`
/// names it in an encoding error.
///
/// # Errors
/// The folder or the file cannot be written, or the value cannot be encoded, named.
pub fn store_file<T: serde::Serialize>(dir: &Path, path: &Path, key: u64, value: &T, what: &str) -> anyhow::Result<()> {
    std::fs::create_dir_all(dir).with_context(|| format!("creating {}", dir.display()))?;
    let mut bytes = key.to_le_bytes().to_vec();
    bytes.extend(postcard::to_stdvec(value).with_context(|| format!("encoding {what}"))?);
    bytes.extend_from_slice(&FILE_CRC.checksum(&bytes).to_le_bytes());
    dynotraj_formats::atomic::write_file(path, bytes).with_context(|| format!("writing {}", path.display()))
}
