//! The MCAP container's lengths checked against the file and against limits before any record
//! is read: an MCAP reader allocates what a record says it holds, so a 66-byte file whose record
//! claims 4 GiB would take 4 GiB before it is found truncated, and a small chunk can claim a
//! decompressed size of gigabytes. Every record must fit in what is left of the file, and no
//! record or chunk may hold more than [`MAX_RECORD_BYTES`].
//!
//! rosbag2 also compresses whole files (`<name>_0.mcap.zstd`) and single messages with zstd:
//! [`open`] reads a file either way as a stream, and [`payload`] decompresses a message, both
//! within the same limit.

use std::borrow::Cow;
use std::fs::File;
use std::io::{BufRead as _, BufReader, Read, Seek, SeekFrom};
use std::path::Path;

use anyhow::{Context as _, bail, ensure};

/// The most bytes one record (a message, a schema, an attachment) or one chunk decompressed may
/// hold: 512 MiB, more than a raw 8K colour image and about twenty times a 4K one.
pub const MAX_RECORD_BYTES: u64 = 512 << 20;

/// The magic that opens and closes an MCAP file.
const MAGIC: &[u8; 8] = b"\x89MCAP0\r\n";
/// The magic that opens a zstd frame.
const ZSTD_MAGIC: [u8; 4] = [0x28, 0xb5, 0x2f, 0xfd];
/// The header that opens an SQLite database (rosbag2's older `.db3` storage).
const SQLITE_MAGIC: &[u8; 16] = b"SQLite format 3\0";

/// The file at `path`, buffered, with its first bytes looked at (not consumed): a regular
/// file's first read fills the buffer, so they hold every magic checked here.
fn peeked(path: &Path) -> anyhow::Result<(BufReader<File>, Vec<u8>)> {
    let mut file = BufReader::new(File::open(path).with_context(|| format!("opening {}", path.display()))?);
    let head = file.fill_buf().with_context(|| format!("reading {}", path.display()))?;
    let head = head.get(..head.len().min(SQLITE_MAGIC.len())).unwrap_or_default().to_vec();
    Ok((file, head))
}

/// `file` as a stream of MCAP bytes: as it is, or decompressed when its first bytes `head`
/// are zstd's magic (rosbag2's `compression_mode: file`).
fn stream(file: BufReader<File>, head: &[u8], path: &Path) -> anyhow::Result<Box<dyn Read>> {
    if head.starts_with(&ZSTD_MAGIC) {
        let decoder = zstd::stream::read::Decoder::with_buffer(file)
            .with_context(|| format!("{}: starting zstd decompression", path.display()))?;
        return Ok(Box::new(decoder));
    }
    Ok(Box::new(file))
}

/// The MCAP bytes of the file at `path` as a stream: the file, or its zstd decompression.
///
/// # Errors
/// The file cannot be opened.
pub fn open(path: &Path) -> anyhow::Result<Box<dyn Read>> {
    let (file, head) = peeked(path)?;
    stream(file, &head, path)
}

/// A message's CDR payload: as it is, or decompressed when rosbag2 compressed it alone
/// (`compression_mode: message`), within [`MAX_RECORD_BYTES`].
///
/// # Errors
/// A zstd frame that does not decompress, or decompresses to more than the limit.
pub fn payload(data: &[u8]) -> Result<Cow<'_, [u8]>, String> {
    if !data.starts_with(&ZSTD_MAGIC) {
        return Ok(Cow::Borrowed(data));
    }
    // A frame that declares its size is refused before anything is decompressed.
    if let Ok(Some(size)) = zstd::zstd_safe::get_frame_content_size(data)
        && size > MAX_RECORD_BYTES
    {
        return Err(format!(
            "a zstd-compressed message that declares {size} bytes, over the {MAX_RECORD_BYTES} bytes this build reads"
        ));
    }
    let mut out = Vec::new();
    zstd::stream::read::Decoder::new(data)
        .and_then(|d| d.take(MAX_RECORD_BYTES + 1).read_to_end(&mut out))
        .map_err(|e| format!("a zstd-compressed message that does not decompress: {e}"))?;
    if out.len() as u64 > MAX_RECORD_BYTES {
        return Err(format!(
            "a zstd-compressed message of over {MAX_RECORD_BYTES} bytes decompressed, the most this build reads"
        ));
    }
    Ok(Cow::Owned(out))
}
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
    let name = path.display().to_string();
    let (file, head) = peeked(path)?;
    ensure!(
        head != SQLITE_MAGIC,
        "{name}: a rosbag2 bag in sqlite3 storage, not MCAP: convert it first (`ros2 bag convert`, or \
         `rosbags-convert --src BAG_FOLDER --dst NEW_FOLDER --dst-storage mcap`)"
    );
    if head.starts_with(&ZSTD_MAGIC) {
        // Decompressed as a stream: the size is not known before the end, so each record is
        // bounded by the limit alone, and a cut stream is found where it ends.
        return walk(Stream(stream(file, &head, path)?), u64::MAX, &name);
    }
    let size = file.get_ref().metadata().with_context(|| format!("reading {}", path.display()))?.len();
    walk(file, size, &name)
}

/// A stream that skips forward by reading: a decompression cannot seek.
struct Stream(Box<dyn Read>);

impl Read for Stream {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        self.0.read(buf)
    }
}

impl Seek for Stream {
    fn seek(&mut self, pos: SeekFrom) -> std::io::Result<u64> {
        let SeekFrom::Current(skip) = pos else {
            return Err(std::io::Error::other("a decompressed stream only skips forward"));
        };
        let skip =
            u64::try_from(skip).map_err(|_| std::io::Error::other("a decompressed stream only skips forward"))?;
        let skipped = std::io::copy(&mut self.0.by_ref().take(skip), &mut std::io::sink())?;
        if skipped < skip {
            return Err(std::io::Error::new(std::io::ErrorKind::UnexpectedEof, "the stream ends inside a record"));
        }
        Ok(0)
    }
}

/// [`check_lengths`] of an MCAP file's bytes (named `bytes` in errors).
///
/// # Errors
/// As [`check_lengths`].
pub fn check_bytes(bytes: &[u8]) -> anyhow::Result<()> {
    walk(std::io::Cursor::new(bytes), bytes.len() as u64, "bytes")
}

/// What the import does with a file's bytes, on bytes in memory: [`check_bytes`], then every
/// message read in file order and its payload taken ([`payload`]); returns the messages read.
///
/// # Errors
/// As [`check_bytes`], a record the MCAP reader refuses, or a payload that does not decompress.
pub fn read_messages(bytes: &[u8]) -> anyhow::Result<usize> {
    check_bytes(bytes)?;
    let mut n = 0;
    for m in mcap::io::MessageReader::new(std::io::Cursor::new(bytes)) {
        let m = m.map_err(|e| anyhow::anyhow!("bytes: not a readable MCAP file after {n} messages: {e}"))?;
        payload(&m.data).map_err(|e| anyhow::anyhow!("bytes: message {n}: {e}"))?;
        n += 1;
    }
    Ok(n)
}

/// Reads a chunk's fields after its sizes (CRC, compression, records' length), `left` bytes
/// of the chunk remaining, and, when the records are stored uncompressed, walks them: each must
/// end within the chunk (the MCAP reader subtracts a record's length from what the chunk has
/// left without checking, and wraps past its end). Returns the bytes read.
fn check_chunk_records(r: &mut impl Read, left: u64, name: &str) -> anyhow::Result<u64> {
    let mut chunk = ChunkReader { r, read: 0, left, name };
    let head = chunk.take(8, "CRC and compression")?;
    let compression_len =
        u64::from(u32::from_le_bytes(head.get(4..8).and_then(|b| b.try_into().ok()).unwrap_or_default()));
    // A compression name is a word (`zstd`, `lz4`); anything longer is damage.
    ensure!(compression_len <= 64, "{name}: a compression name of {compression_len} bytes (damaged)");
    let compression = chunk.take(compression_len, "compression")?;
    let records_len = u64::from_le_bytes(chunk.take(8, "records' length")?.try_into().unwrap_or_default());
    let rest = left - chunk.read;
    ensure!(records_len <= rest, "{name} claims {records_len} bytes of records, it has {rest} left (damaged)");
    if !compression.is_empty() {
        return Ok(chunk.read);
    }
    let mut inner = records_len;
    while inner > 0 {
        ensure!(inner >= 9, "{name} ends its records inside a record's header (damaged)");
        let head = chunk.take(9, "records")?;
        let length = u64::from_le_bytes(head.get(1..9).and_then(|b| b.try_into().ok()).unwrap_or_default());
        inner -= 9;
        ensure!(length <= inner, "{name} holds a record of {length} bytes with {inner} left in it (damaged)");
        chunk.skip(length)?;
        inner -= length;
    }
    Ok(chunk.read)
}

/// Reads within a chunk of `left` bytes, counting what it read.
struct ChunkReader<'a, R> {
    r: &'a mut R,
    read: u64,
    left: u64,
    name: &'a str,
}

impl<R: Read> ChunkReader<'_, R> {
    fn take(&mut self, n: u64, what: &str) -> anyhow::Result<Vec<u8>> {
        ensure!(self.read + n <= self.left, "{} ends inside its {what} (damaged)", self.name);
        let mut bytes = vec![0u8; usize::try_from(n).unwrap_or(usize::MAX)];
        self.r.read_exact(&mut bytes).with_context(|| format!("{}: reading its {what}", self.name))?;
        self.read += n;
        Ok(bytes)
    }

    fn skip(&mut self, n: u64) -> anyhow::Result<()> {
        let skipped = std::io::copy(&mut self.r.by_ref().take(n), &mut std::io::sink())
            .with_context(|| format!("{}: reading its records", self.name))?;
        ensure!(skipped == n, "{} ends inside its records (truncated)", self.name);
        self.read += n;
        Ok(())
    }
}

/// Walks the records of `size` bytes read from `r`, `name` naming them in errors.
fn walk(mut r: impl Read + Seek, size: u64, name: &str) -> anyhow::Result<()> {
    let mut magic = [0u8; 8];
    let read = r.read_exact(&mut magic).is_ok();
    ensure!(read && &magic == MAGIC, "{name}: not an MCAP file (no MCAP magic at its start)");
    let mut at: u64 = 8;
    loop {
        let mut head = [0u8; 9];
        if size.saturating_sub(at) < 9 {
            bail!("{name}: byte {at}: the file ends before its footer (truncated?)");
        }
        r.read_exact(&mut head).with_context(|| format!("reading {name} at byte {at}"))?;
        let [opcode, length @ ..] = head;
        let length = u64::from_le_bytes(length);
        let left = size - at - 9;
        ensure!(
            length <= left,
            "{name}: byte {at}: a record (opcode {opcode:#04x}) claims {length} bytes, the file has {left} left \
             (truncated or damaged)"
        );
        ensure!(
            length <= MAX_RECORD_BYTES,
            "{name}: byte {at}: a record (opcode {opcode:#04x}) of {length} bytes, over the {MAX_RECORD_BYTES} bytes \
             this build reads in one record"
        );
        let mut skip = length;
        if opcode == CHUNK && length >= 24 {
            // message_start_time, message_end_time, uncompressed_size.
            let mut fields = [0u8; 24];
            r.read_exact(&mut fields).with_context(|| format!("reading {name} at byte {at}"))?;
            let uncompressed = u64::from_le_bytes(fields[16..24].try_into().unwrap_or_default());
            ensure!(
                uncompressed <= MAX_RECORD_BYTES,
                "{name}: byte {at}: a chunk that decompresses to {uncompressed} bytes, over the {MAX_RECORD_BYTES} \
                 bytes this build reads in one chunk"
            );
            skip -= 24;
            skip -= check_chunk_records(&mut r, skip, &format!("{name}: byte {at}: a chunk"))?;
        }
        r.seek(SeekFrom::Current(i64::try_from(skip).unwrap_or(i64::MAX)))
            .with_context(|| format!("reading {name} at byte {at}"))?;
        at += 9 + length;
        if opcode == FOOTER {
            return Ok(());
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A small MCAP file: one channel, `n` messages, in chunks.
    fn small_mcap(n: u32) -> Vec<u8> {
        let mut out = Vec::new();
        let mut w = mcap::Writer::new(std::io::Cursor::new(&mut out)).unwrap();
        let schema = w.add_schema("std_msgs/msg/String", "ros2msg", b"string data").unwrap();
        let channel = w.add_channel(schema, "/t", "cdr", &std::collections::BTreeMap::new()).unwrap();
        for k in 0..n {
            let header = mcap::records::MessageHeader {
                channel_id: channel,
                sequence: k,
                log_time: u64::from(k),
                publish_time: 0,
            };
            w.write_to_known_channel(&header, &[0, 1, 0, 0, 3, 0, 0, 0, b'h', b'i', 0]).unwrap();
        }
        w.finish().unwrap();
        drop(w);
        out
    }

    #[test]
    fn a_whole_file_passes_and_any_cut_of_it_is_named() {
        let bytes = small_mcap(20);
        check_bytes(&bytes).unwrap();
        for cut in [8, 9, 20, bytes.len() / 2, bytes.len() - 9] {
            let e = check_bytes(&bytes[..cut]).unwrap_err().to_string();
            assert!(e.starts_with("bytes: byte") && e.contains("truncated"), "cut at {cut}: {e}");
        }
        let e = check_bytes(b"not mcap").unwrap_err().to_string();
        assert!(e.contains("not an MCAP file"), "{e}");
        assert_eq!(read_messages(&bytes).unwrap(), 20);
    }

    /// An uncompressed chunk whose inner record claims more than the chunk holds (found by the
    /// fuzzer: the MCAP reader's count of the chunk's bytes went below zero).
    #[test]
    fn a_record_longer_than_its_chunk_is_refused() {
        let mut out = Vec::new();
        let options = mcap::WriteOptions::new().compression(None);
        let mut w = options.create(std::io::Cursor::new(&mut out)).unwrap();
        let schema = w.add_schema("s", "ros2msg", b"").unwrap();
        let channel = w.add_channel(schema, "/t", "cdr", &std::collections::BTreeMap::new()).unwrap();
        let header = mcap::records::MessageHeader { channel_id: channel, sequence: 0, log_time: 0, publish_time: 0 };
        w.write_to_known_channel(&header, b"abcd").unwrap();
        w.finish().unwrap();
        drop(w);
        read_messages(&out).unwrap();
        // The chunk's first inner record: grow its length past the chunk's end.
        let chunk = (8..out.len()).find(|&i| out[i] == CHUNK && out[i + 1..i + 9] != [0; 8]).unwrap();
        let records = chunk + 9 + 24 + 4 + 4 + 8;
        let len = u64::from_le_bytes(out[records + 1..records + 9].try_into().unwrap());
        out[records + 1..records + 9].copy_from_slice(&(len + 1000).to_le_bytes());
        let e = read_messages(&out).unwrap_err().to_string();
        assert!(e.contains("a chunk holds a record of") && e.contains("(damaged)"), "{e}");
        let crash = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../fuzz/regressions/mcap_container/crash-252c1f3457c36f5804e4a59c9be347a798645de0");
        assert!(read_messages(&std::fs::read(crash).unwrap()).is_err());
    }

    #[test]
    fn a_compressed_message_over_the_limit_is_refused_before_it_is_decompressed() {
        // 600 MiB of zeros compress to a few kilobytes, and the frame says how many there are.
        let mut enc = zstd::stream::write::Encoder::new(Vec::new(), 3).unwrap();
        enc.set_pledged_src_size(Some(600 << 20)).unwrap();
        let chunk = vec![0u8; 1 << 20];
        for _ in 0..600 {
            std::io::Write::write_all(&mut enc, &chunk).unwrap();
        }
        let bomb = enc.finish().unwrap();
        assert!(bomb.len() < 1 << 20, "{} bytes", bomb.len());
        let e = payload(&bomb).unwrap_err();
        assert!(e.contains("declares 629145600 bytes, over the 536870912"), "{e}");
        let small = zstd::encode_all(&b"cdr"[..], 3).unwrap();
        assert_eq!(payload(&small).unwrap().as_ref(), b"cdr");
    }
}
