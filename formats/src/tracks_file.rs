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
    /// When the file cannot be created or written.
    pub fn create(path: &Path, camera: &CameraInfo) -> Result<Self, TracksFileError> {
        let io = |source| TracksFileError::Io { path: path.to_path_buf(), cause: source };
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

/// Reads and checks a whole tracks file.
///
/// # Errors
/// An unreadable file, or content that is not a tracks file (see the module docs).
pub fn read(path: &Path) -> Result<Tracks, TracksFileError> {
    let bytes =
        std::fs::read(path).map_err(|source| TracksFileError::Io { path: path.to_path_buf(), cause: source })?;
    parse(path, &bytes)
}

/// Parses the bytes of a tracks file; `path` only names it in errors.
///
/// # Errors
/// Content that is not a tracks file (see the module docs).
pub fn parse(path: &Path, bytes: &[u8]) -> Result<Tracks, TracksFileError> {
    let fail = |offset: usize, what: String| TracksFileError::Format { path: path.to_path_buf(), offset, what };
    let mut decoder = FrameDecoder::new();
    let mut camera = None;
    let mut frames: Vec<TracksFrame> = Vec::new();
    // Wire frames read, and where the end mark ended.
    let mut read = 0u32;
    let mut end_mark = None;
    // Feed one byte range at a time so an error can name where it happened.
    let mut offset = 0;
    for chunk in bytes.split_inclusive(|&b| b == wire::DELIMITER) {
        offset += chunk.len();
        let before = decoder.stats();
        let msg = decoder.feed(chunk).next();
        let after = decoder.stats();
        if after != before && msg.is_none() {
            return Err(fail(offset, format!("a damaged wire frame ({after:?})")));
        }
        if msg.is_some() {
            if let Some(at) = end_mark {
                return Err(fail(offset, format!("a wire frame after the end-of-recording mark (at byte {at})")));
            }
            read = read.saturating_add(1);
        }
        match msg {
            None => {}
            Some(Message::LinkStats(mark)) => {
                if mark.frames_sent != read {
                    return Err(fail(
                        offset,
                        format!(
                            "the end-of-recording mark counts {} wire frames, the file holds {read}: frames are \
                                missing",
                            mark.frames_sent
                        ),
                    ));
                }
                end_mark = Some(offset);
            }
            Some(Message::CameraInfo(info)) => {
                if camera.is_some() || !frames.is_empty() {
                    return Err(fail(offset, "a second camera model; expected one, first".into()));
                }
                camera = Some(info);
            }
            Some(Message::FrameTracks(part)) => {
                if camera.is_none() {
                    return Err(fail(offset, "tracks before the camera model".into()));
                }
                push_part(&mut frames, part).map_err(|what| fail(offset, what))?;
            }
            Some(other) => {
                return Err(fail(
                    offset,
                    format!("a {} message; expected camera model, tracks or the end mark", kind(&other)),
                ));
            }
        }
    }
    if decoder.pending_len() > 0 {
        return Err(fail(offset, "a truncated last wire frame".into()));
    }
    if let Some(last) = frames.last() {
        let want = last.parts.first().map_or(1, |p| usize::from(p.parts));
        if last.parts.len() != want {
            return Err(fail(offset, format!("frame {} ends after {} of {want} parts", last.frame, last.parts.len())));
        }
    }
    let camera = camera.ok_or_else(|| fail(offset, "no camera model; expected one first".into()))?;
    if end_mark.is_none() {
        return Err(fail(
            offset,
            format!(
                "no end-of-recording mark after {} frames: the file was cut (at a frame boundary), or written by a \
                    dynotraj from before the mark (record it again)",
                frames.len()
            ),
        ));
    }
    Ok(Tracks { camera, frames })
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
