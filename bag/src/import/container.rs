//! The MCAP container's lengths checked against the file and against limits before any record
//! is read: an MCAP reader allocates what a record says it holds, so a 66-byte file whose record
//! claims 4 GiB would take 4 GiB before it is found truncated, and a small chunk can claim a
//! decompressed size of gigabytes. Every record must fit in what is left of the file, and no
//! record or chunk may hold more than [`MAX_RECORD_BYTES`].

use std::fs::File;
use std::io::{BufReader, Read};
use std::path::Path;

use anyhow::{Context as _, bail, ensure};

/// The most bytes one record (a message, a schema, an attachment) or one chunk decompressed may
/// hold: 512 MiB, more than a raw 8K colour image and about twenty times a 4K one.
pub const MAX_RECORD_BYTES: u64 = 512 << 20;

/// The magic that opens and closes an MCAP file.
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// The opcode of a chunk record.
const CHUNK: u8 = 0x06;
/// The opcode of the footer, the last record.
const FOOTER: u8 = 0x02;

/// Walks the records of the MCAP file at `path`, checking that each fits in the file and in
/// [`MAX_RECORD_BYTES`], and that no chunk decompresses to more than that.
///
/// # Errors
/// A file that is not MCAP, a record longer than what is left of the file (truncated or
/// damaged) or than the limit, or a chunk whose decompressed size is over the limit; each named
/// with the file and the record's byte offset.
pub fn check_lengths(path: &Path) -> anyhow::Result<()> {
    let file = File::open(path).with_context(|| format!("opening {}", path.display()))?;
    let size = file.metadata().with_context(|| format!("reading {}", path.display()))?.len();
    let mut r = BufReader::new(file);
    let mut magic = [0u8; 8];
    let read = r.read(&mut magic).with_context(|| format!("reading {}", path.display()))?;
    ensure!(read == 8 && &magic == MAGIC, "{}: not an MCAP file (no MCAP magic at its start)", path.display());
    let mut at: u64 = 8;
    loop {
        let mut head = [0u8; 9];
        if size.saturating_sub(at) < 9 {
            bail!("{}: byte {at}: the file ends before its footer (truncated?)", path.display());
        }
        r.read_exact(&mut head).with_context(|| format!("reading {} at byte {at}", path.display()))?;
        let [opcode, length @ ..] = head;
        let length = u64::from_le_bytes(length);
        let left = size - at - 9;
        ensure!(
            length <= left,
            "{}: byte {at}: a record (opcode {opcode:#04x}) claims {length} bytes, the file has {left} left (truncated \
             or damaged)",
            path.display()
        );
        ensure!(
            length <= MAX_RECORD_BYTES,
            "{}: byte {at}: a record (opcode {opcode:#04x}) of {length} bytes, over the {MAX_RECORD_BYTES} bytes this \
             build reads in one record",
            path.display()
        );
        if opcode == CHUNK && length >= 24 {
            // message_start_time, message_end_time, uncompressed_size.
            let mut fields = [0u8; 24];
            r.read_exact(&mut fields).with_context(|| format!("reading {} at byte {at}", path.display()))?;
            let uncompressed = u64::from_le_bytes(fields[16..24].try_into().unwrap_or_default());
            ensure!(
                uncompressed <= MAX_RECORD_BYTES,
                "{}: byte {at}: a chunk that decompresses to {uncompressed} bytes, over the {MAX_RECORD_BYTES} bytes \
                 this build reads in one chunk",
                path.display()
            );
            r.seek_relative(i64::try_from(length - 24).unwrap_or(i64::MAX))
                .with_context(|| format!("reading {} at byte {at}", path.display()))?;
        } else {
            r.seek_relative(i64::try_from(length).unwrap_or(i64::MAX))
                .with_context(|| format!("reading {} at byte {at}", path.display()))?;
        }
        at += 9 + length;
        if opcode == FOOTER {
            return Ok(());
        }
    }
}
