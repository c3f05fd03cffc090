//! Tracks files (`.dtt`): a recorded stream of feature tracks, byte for byte what goes over the
//! link.
//!
//! # Format
//!
//! The file is the link's byte stream itself: wire frames (`0x00 COBS(version | postcard |
//! CRC-32) 0x00`, see [`dynotraj_core::wire`]) one after another, with no header of its own:
//!
//! 1. one [`Message::CameraInfo`] (the camera model the tracks are measured with);
//! 2. per camera frame, in frame order, its [`Message::FrameTracks`] parts as
//!    [`wire::frame_parts`] makes them;
//! 3. last, the end-of-recording mark: the host's goodbye, a [`Message::LinkStats`] whose
//!    `frames_sent` counts every wire frame of the file, itself included.
//!
//! So a tracks file can be replayed onto a socket or a serial port unchanged (the edge ends
//! its session at the mark), and a recording of the host's side of the link is a valid tracks
//! file. The protocol version travels in every frame. Reading is strict: a frame that does not
//! decode, another message, a missing camera model, a frame's parts out of order, or a missing
//! or miscounting end mark (a file cut at a frame boundary) is an error that names the file
//! and the byte offset, since a file (unlike a live link) has no excuse for damage.

use std::fs::File;
use std::io::{BufWriter, Write};
use std::path::{Path, PathBuf};

use dynotraj_core::wire::{
    self, CameraInfo, DecoderStats, FrameBuf, FrameDecoder, FrameTracks, LinkStats, MAX_FRAME_LEN, Message, Track,
};

/// File name extension of tracks files.
pub const EXTENSION: &str = "dtt";

/// What can go wrong reading or writing a tracks file.
#[derive(Debug, thiserror::Error)]
pub enum TracksFileError {
    /// The file could not be opened, read or written.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The cause (in the message, not a `source`: shown once).
        cause: std::io::Error,
    },
    /// The content is not a valid tracks file.
    #[error("{path}: byte {offset}: {what}")]
    Format {
        /// The file.
        path: PathBuf,
        /// Byte offset of the end of the offending frame (or of the file).
        offset: usize,
        /// What was found and what was expected.
        what: String,
    },
    /// A frame had more tracks than the wire allows.
    #[error("{path}: frame {frame}: {source}")]
    Wire {
        /// The file.
        path: PathBuf,
        /// The camera frame.
        frame: u32,
        /// The cause.
        source: wire::WireError,
    },
}

/// One camera frame of a tracks file.
#[derive(Debug, Clone, PartialEq)]
pub struct TracksFrame {
    /// Camera frame index.
    pub frame: u32,
    /// Capture time, microseconds.
    pub timestamp_us: u64,
    /// The frame's parts, in order, as they travel on the link.
    pub parts: Vec<FrameTracks>,
}

impl TracksFrame {
    /// Frame `frame`'s `tracks` split into the wire's parts ([`wire::frame_parts`]): the one
    /// way a camera frame becomes what the link, a tracks file and the estimator take.
    ///
    /// # Errors
    /// More tracks than [`wire::MAX_FRAME_TRACKS`].
    pub fn split(frame: u32, timestamp_us: u64, tracks: &[Track]) -> Result<Self, wire::WireError> {
        Ok(Self { frame, timestamp_us, parts: wire::frame_parts(frame, timestamp_us, tracks)?.collect() })
    }

    /// Every track of the frame, in the sender's order.
    pub fn tracks(&self) -> impl Iterator<Item = &Track> {
        self.parts.iter().flat_map(|p| p.tracks.iter())
    }
}

/// A whole tracks file in memory.
#[derive(Debug, Clone, PartialEq)]
pub struct Tracks {
    /// The camera model of the stream.
    pub camera: CameraInfo,
    /// The camera frames, in order.
    pub frames: Vec<TracksFrame>,
}

/// Writes a tracks file frame by frame.
#[derive(Debug)]
pub struct TracksWriter {
    path: PathBuf,
    out: BufWriter<File>,
    buf: FrameBuf,
    /// Wire frames written so far.
    written: u32,
}

impl TracksWriter {
    /// Creates `path` (under its temporary name, [`crate::atomic::partial_path`], until
    /// [`Self::finish`]) and writes the camera model.
    ///
    /// # Errors
    /// Something other than a regular file at `path` ([`crate::atomic::replaceable`]), or the
    /// file cannot be created or written.
    pub fn create(path: &Path, camera: &CameraInfo) -> Result<Self, TracksFileError> {
        let io = |source| TracksFileError::Io { path: path.to_path_buf(), cause: source };
        crate::atomic::replaceable(path).map_err(io)?;
        let out = BufWriter::new(File::create(crate::atomic::partial_path(path)).map_err(io)?);
        let mut w = Self { path: path.to_path_buf(), out, buf: [0; MAX_FRAME_LEN], written: 0 };
        w.write_message(&Message::CameraInfo(*camera))?;
        Ok(w)
    }

    /// Appends one camera frame's tracks (split into parts).
    ///
    /// # Errors
    /// More tracks than [`wire::MAX_FRAME_TRACKS`], or a write failure.
    pub fn write_frame(&mut self, frame: u32, timestamp_us: u64, tracks: &[Track]) -> Result<(), TracksFileError> {
        let wire_err = |source| TracksFileError::Wire { path: self.path.clone(), frame, source };
        for part in TracksFrame::split(frame, timestamp_us, tracks).map_err(wire_err)?.parts {
            self.write_message(&Message::FrameTracks(part))?;
        }
        Ok(())
    }

    fn write_message(&mut self, msg: &Message) -> Result<(), TracksFileError> {
        let n = wire::encode(msg, &mut self.buf).map_err(|source| TracksFileError::Wire {
            path: self.path.clone(),
            frame: 0,
            source,
        })?;
        let bytes = self.buf.get(..n).unwrap_or_default();
        self.written = self.written.saturating_add(1);
        self.out.write_all(bytes).map_err(|source| TracksFileError::Io { path: self.path.clone(), cause: source })
    }

    /// Writes the end-of-recording mark, flushes and closes the file, and gives it its name.
    ///
    /// # Errors
    /// When the final writes or the rename fail.
    pub fn finish(mut self) -> Result<(), TracksFileError> {
        let mark = LinkStats { frames_sent: self.written.saturating_add(1), received: DecoderStats::default() };
        self.write_message(&Message::LinkStats(mark))?;
        let io = |source| TracksFileError::Io { path: self.path.clone(), cause: source };
        self.out.flush().map_err(io)?;
        std::fs::rename(crate::atomic::partial_path(&self.path), &self.path).map_err(io)
    }
}

/// The largest tracks file this build reads, bytes: about three hours of a KITTI drive's
/// tracks at 10 Hz. A larger file, or a device or pipe that never ends, is refused once this
/// much has been read; the file is parsed as it is read, so memory holds its frames, not its
/// bytes.
pub const MAX_TRACKS_FILE_BYTES: u64 = 1 << 31;

/// Reads and checks a whole tracks file, wire frame by wire frame.
///
/// # Errors
/// An unreadable file, one over [`MAX_TRACKS_FILE_BYTES`], or content that is not a tracks file
/// (see the module docs).
pub fn read(path: &Path) -> Result<Tracks, TracksFileError> {
    use std::io::{BufRead as _, Read as _};
    let io = |source| TracksFileError::Io { path: path.to_path_buf(), cause: source };
    let mut reader = std::io::BufReader::new(File::open(path).map_err(io)?).take(MAX_TRACKS_FILE_BYTES + 1);
    let mut parser = Parser::new(path);
    let mut chunk = Vec::new();
    loop {
        chunk.clear();
        // At most one wire frame and its delimiter: a longer run is a damaged frame, and the
        // decoder says so without this buffer growing.
        let n = (&mut reader).take(MAX_FRAME_LEN as u64 + 1).read_until(wire::DELIMITER, &mut chunk).map_err(io)?;
        if n == 0 {
            break;
        }
        parser.chunk(&chunk)?;
    }
    if parser.offset as u64 > MAX_TRACKS_FILE_BYTES {
        return Err(parser
            .fail(format!("more than {MAX_TRACKS_FILE_BYTES} bytes: longer than any tracks file this build reads")));
    }
    parser.finish()
}

/// Parses the bytes of a tracks file; `path` only names it in errors.
///
/// # Errors
/// Content that is not a tracks file (see the module docs).
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Tracks, TracksFileError> {
    let mut parser = Parser::new(path);
    for chunk in bytes.split_inclusive(|&b| b == wire::DELIMITER) {
        parser.chunk(chunk)?;
    }
    parser.finish()
}

/// A tracks file being parsed, one delimited wire frame at a time.
struct Parser<'p> {
    path: &'p Path,
    decoder: FrameDecoder,
    camera: Option<CameraInfo>,
    frames: Vec<TracksFrame>,
    /// Wire frames read.
    read: u32,
    /// Where the end mark ended.
    end_mark: Option<usize>,
    /// Bytes read so far: where an error is.
    offset: usize,
    /// Delimiters in a row with no frame between them.
    empty_run: u32,
}

impl<'p> Parser<'p> {
    fn new(path: &'p Path) -> Self {
        Self {
            path,
            decoder: FrameDecoder::new(),
            camera: None,
            frames: Vec::new(),
            read: 0,
            end_mark: None,
            offset: 0,
            empty_run: 0,
        }
    }

    fn fail(&self, what: String) -> TracksFileError {
        TracksFileError::Format { path: self.path.to_path_buf(), offset: self.offset, what }
    }

    /// One byte range ending in a delimiter (or the file's last bytes).
    fn chunk(&mut self, chunk: &[u8]) -> Result<(), TracksFileError> {
        self.offset += chunk.len();
        // The writer puts a delimiter before and after each frame, so at most two stand in a
        // row; more (a device of zeros, say) is no tracks file, said at once.
        self.empty_run = if chunk == [wire::DELIMITER] { self.empty_run.saturating_add(1) } else { 0 };
        if self.empty_run > 2 {
            return Err(self.fail("delimiters in a row with no wire frame between them: not a tracks file".into()));
        }
        let before = self.decoder.stats();
        let msg = self.decoder.feed(chunk).next();
        let after = self.decoder.stats();
        if after != before && msg.is_none() {
            return Err(self.fail(format!("a damaged wire frame ({after:?})")));
        }
        if msg.is_some() {
            if let Some(at) = self.end_mark {
                return Err(self.fail(format!("a wire frame after the end-of-recording mark (at byte {at})")));
            }
            self.read = self.read.saturating_add(1);
        }
        match msg {
            None => {}
            Some(Message::LinkStats(mark)) => {
                if mark.frames_sent != self.read {
                    return Err(self.fail(format!(
                        "the end-of-recording mark counts {} wire frames, the file holds {}: frames are missing",
                        mark.frames_sent, self.read
                    )));
                }
                self.end_mark = Some(self.offset);
            }
            Some(Message::CameraInfo(info)) => {
                if self.camera.is_some() || !self.frames.is_empty() {
                    return Err(self.fail("a second camera model; expected one, first".into()));
                }
                self.camera = Some(info);
            }
            Some(Message::FrameTracks(part)) => {
                if self.camera.is_none() {
                    return Err(self.fail("tracks before the camera model".into()));
                }
                push_part(&mut self.frames, part).map_err(|what| self.fail(what))?;
            }
            Some(other) => {
                return Err(
                    self.fail(format!("a {} message; expected camera model, tracks or the end mark", kind(&other)))
                );
            }
        }
        Ok(())
    }

    /// The tracks, once the whole file has been fed.
    fn finish(self) -> Result<Tracks, TracksFileError> {
        if self.decoder.pending_len() > 0 {
            return Err(self.fail("a truncated last wire frame".into()));
        }
        if let Some(last) = self.frames.last() {
            let want = last.parts.first().map_or(1, |p| usize::from(p.parts));
            if last.parts.len() != want {
                return Err(self.fail(format!("frame {} ends after {} of {want} parts", last.frame, last.parts.len())));
            }
        }
        let Some(camera) = self.camera else { return Err(self.fail("no camera model; expected one first".into())) };
        if self.end_mark.is_none() {
            return Err(self.fail(format!(
                "no end-of-recording mark after {} frames: the file was cut (at a frame boundary), or written by a \
                 dynotraj from before the mark (record it again)",
                self.frames.len()
            )));
        }
        Ok(Tracks { camera, frames: self.frames })
    }
}

/// Appends `part` to the frame it belongs to, checking the parts' order.
fn push_part(frames: &mut Vec<TracksFrame>, part: FrameTracks) -> Result<(), String> {
    if let Some(last) = frames.last_mut() {
        let have = last.parts.len();
        let want = last.parts.first().map_or(1, |p| usize::from(p.parts));
        if have < want {
            if part.frame != last.frame || usize::from(part.part) != have {
                return Err(format!(
                    "part {}/{} of frame {}; expected part {have}/{want} of frame {}",
                    part.part, part.parts, part.frame, last.frame
                ));
            }
            last.parts.push(part);
            return Ok(());
        }
        if part.frame <= last.frame {
            return Err(format!("frame {} after frame {}; expected increasing frames", part.frame, last.frame));
        }
    }
    if part.part != 0 {
        return Err(format!("part {} of frame {}; expected its part 0", part.part, part.frame));
    }
    frames.push(TracksFrame { frame: part.frame, timestamp_us: part.timestamp_us, parts: vec![part] });
    Ok(())
}

fn kind(msg: &Message) -> &'static str {
    match msg {
        Message::FrameTracks(_) => "FrameTracks",
        Message::ObjectStates(_) => "ObjectStates",
        Message::Prediction(_) => "Prediction",
        Message::ModelChunk(_) => "ModelChunk",
        Message::LinkStats(_) => "LinkStats",
        Message::CameraInfo(_) => "CameraInfo",
        Message::FrameStats(_) => "FrameStats",
        Message::Notice(_) => "Notice",
    }
}

/// The tracks file of sequence `id` in the folder `out` (`dynotraj track` writes it there,
/// `dynotraj estimate --tracks` reads it from there).
#[must_use]
pub fn tracks_path(out: &Path, id: &str) -> PathBuf {
    out.join(format!("{id}.dtt"))
}

#[cfg(test)]
mod tests {
    use dynotraj_core::wire::{ObjectClass, STATIC_OBJECT_ID};

    use super::*;

    fn camera() -> CameraInfo {
        CameraInfo {
            fx: 721.5,
            fy: 721.5,
            cx: 609.6,
            cy: 172.9,
            stereo_fb: 387.6,
            width: 1242,
            height: 375,
            frame_rate_hz: 20.0,
        }
    }

    fn tracks(n: usize) -> Vec<Track> {
        (0..n)
            .map(|i| Track {
                track_id: i as u32,
                object_id: if i % 3 == 0 { 7 } else { STATIC_OBJECT_ID },
                class: if i % 3 == 0 { ObjectClass::Car } else { ObjectClass::Background },
                u: i as f32,
                v: 2.0 * i as f32,
                depth: 5.0 + i as f32,
            })
            .collect()
    }

    fn write(dir: &Path, frames: &[(u32, usize)]) -> PathBuf {
        let path = dir.join("t.dtt");
        let mut w = TracksWriter::create(&path, &camera()).unwrap();
        for &(f, n) in frames {
            w.write_frame(f, u64::from(f) * 50_000, &tracks(n)).unwrap();
        }
        w.finish().unwrap();
        path
    }

    #[test]
    fn round_trips_frames_of_every_size() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), &[(0, 0), (1, 64), (2, 65), (5, 300)]);
        let t = read(&path).unwrap();
        assert_eq!(t.camera, camera());
        let got: Vec<_> = t.frames.iter().map(|f| (f.frame, f.parts.len(), f.tracks().count())).collect();
        assert_eq!(got, [(0, 1, 0), (1, 1, 64), (2, 2, 65), (5, 5, 300)]);
        assert_eq!(t.frames[3].tracks().copied().collect::<Vec<_>>(), tracks(300));
        assert_eq!(t.frames[3].timestamp_us, 250_000);
    }

    #[test]
    fn damage_is_an_error_naming_file_and_offset() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), &[(0, 10), (1, 10)]);
        let mut bytes = std::fs::read(&path).unwrap();
        let at = bytes.len() - 20;
        bytes[at] ^= 0x55;
        let err = parse(&path, &bytes).unwrap_err().to_string();
        assert!(err.contains("t.dtt: byte") && err.contains("damaged"), "{err}");
        let err = parse(&path, &bytes[..bytes.len() - 5]).unwrap_err().to_string();
        assert!(err.contains("truncated") || err.contains("damaged"), "{err}");
    }

    #[test]
    fn an_endless_device_or_random_bytes_are_refused_at_once_and_reading_streams() {
        // /dev/zero reads as delimiters without end; random bytes are damaged frames.
        let err = read(Path::new("/dev/zero")).unwrap_err().to_string();
        assert!(err.starts_with("/dev/zero: byte 3:") && err.contains("not a tracks file"), "{err}");
        let err = read(Path::new("/dev/urandom")).unwrap_err().to_string();
        assert!(err.starts_with("/dev/urandom: byte") && err.contains("damaged"), "{err}");
        // Read as a stream or parsed whole, a file gives the same tracks.
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), &[(0, 3), (1, 200), (2, 7)]);
        let whole = parse(&path, &std::fs::read(&path).unwrap()).unwrap();
        let streamed = read(&path).unwrap();
        assert_eq!((streamed.camera, streamed.frames), (whole.camera, whole.frames));
    }

    #[test]
    fn missing_camera_model_and_disorder_are_errors() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), &[(3, 10), (2, 10)]);
        let err = read(&path).unwrap_err().to_string();
        assert!(err.contains("frame 2 after frame 3"), "{err}");
        let mut buf = [0; MAX_FRAME_LEN];
        let n =
            wire::encode(&Message::FrameTracks(wire::frame_parts(0, 0, &tracks(3)).unwrap().next().unwrap()), &mut buf)
                .unwrap();
        let err = parse(&path, &buf[..n]).unwrap_err().to_string();
        assert!(err.contains("before the camera model"), "{err}");
        let err = parse(&path, &[]).unwrap_err().to_string();
        assert!(err.contains("no camera model"), "{err}");
    }

    /// The byte offsets just after each wire frame of `bytes`.
    fn frame_ends(bytes: &[u8]) -> Vec<usize> {
        // Every frame is 0x00 COBS 0x00: ends are the delimiters that close a non-empty frame.
        (1..bytes.len()).filter(|&i| bytes[i] == 0 && bytes[i - 1] != 0).map(|i| i + 1).collect()
    }

    #[test]
    fn a_file_cut_at_a_frame_boundary_or_missing_frames_is_an_error() {
        let dir = tempfile::tempdir().unwrap();
        let path = write(dir.path(), &[(0, 10), (1, 10), (2, 10)]);
        let bytes = std::fs::read(&path).unwrap();
        let ends = frame_ends(&bytes);
        assert_eq!(ends.len(), 5, "camera, three frames, end mark");
        assert_eq!(ends.last(), Some(&bytes.len()));
        // Cut after the second frame: every frame whole, the mark gone.
        let err = parse(&path, &bytes[..ends[2]]).unwrap_err().to_string();
        assert!(err.contains("no end-of-recording mark after 2 frames: the file was cut"), "{err}");
        // The middle frame taken out: the mark's count disagrees.
        let gapped = [&bytes[..ends[1]], &bytes[ends[2]..]].concat();
        let err = parse(&path, &gapped).unwrap_err().to_string();
        assert!(err.contains("the end-of-recording mark counts 5 wire frames, the file holds 4"), "{err}");
        // Two recordings glued together: frames after the mark.
        let glued = [&bytes[..], &bytes[..]].concat();
        let err = parse(&path, &glued).unwrap_err().to_string();
        assert!(err.contains("after the end-of-recording mark"), "{err}");
    }
}
