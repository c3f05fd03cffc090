//! Splitting payloads bigger than one message: a frame's tracks, a model blob.

use heapless::Vec;

use super::{FrameTracks, MODEL_CHUNK_LEN, ModelChunk, TRACKS_PER_MESSAGE, Track, WireError, crc32};
use crate::limits::{MAX_OBJECTS, MAX_POINTS_PER_OBJECT, MAX_STATIC_TRACKS};

/// Most tracks of one camera frame: every static track and every point of every object.
pub const MAX_FRAME_TRACKS: usize = MAX_STATIC_TRACKS + MAX_OBJECTS * MAX_POINTS_PER_OBJECT;
/// Most [`FrameTracks`] parts of one camera frame.
pub const MAX_FRAME_PARTS: usize = MAX_FRAME_TRACKS.div_ceil(TRACKS_PER_MESSAGE);

// `part` and `parts` are u16 on the wire.
const _: () = assert!(MAX_FRAME_PARTS <= u16::MAX as usize);

/// Splits one camera frame's `tracks` into its [`FrameTracks`] parts (see there for the
/// scheme), borrowing the tracks and allocating nothing.
///
/// # Errors
/// [`WireError::TooManyTracks`] for more than [`MAX_FRAME_TRACKS`] tracks.
pub fn frame_parts(frame: u32, timestamp_us: u64, tracks: &[Track]) -> Result<FrameParts<'_>, WireError> {
    if tracks.len() > MAX_FRAME_TRACKS {
        return Err(WireError::TooManyTracks);
    }
    // A frame without tracks is still one (empty) part.
    let parts = tracks.len().div_ceil(TRACKS_PER_MESSAGE).max(1);
    let parts = u16::try_from(parts).map_err(|_| WireError::TooManyTracks)?;
    Ok(FrameParts { frame, timestamp_us, rest: tracks, part: 0, parts })
}

/// The parts of one camera frame, in order; see [`frame_parts`].
#[derive(Debug, Clone)]
pub struct FrameParts<'a> {
    /// Frame index of every part.
    frame: u32,
    /// Timestamp of every part.
    timestamp_us: u64,
    /// Tracks not yet sent.
    rest: &'a [Track],
    /// Index of the next part.
    part: u16,
    /// Number of parts.
    parts: u16,
}

impl Iterator for FrameParts<'_> {
    type Item = FrameTracks;

    fn next(&mut self) -> Option<FrameTracks> {
        if self.part >= self.parts {
            return None;
        }
        let (head, tail) = self.rest.split_at_checked(self.rest.len().min(TRACKS_PER_MESSAGE))?;
        let msg = FrameTracks {
            frame: self.frame,
            timestamp_us: self.timestamp_us,
            part: self.part,
            parts: self.parts,
            tracks: Vec::from_slice(head).ok()?,
        };
        self.rest = tail;
        self.part += 1;
        Some(msg)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        let n = usize::from(self.parts - self.part.min(self.parts));
        (n, Some(n))
    }
}

impl ExactSizeIterator for FrameParts<'_> {}

/// Splits a model `blob` into [`ModelChunk`]s of at most [`MODEL_CHUNK_LEN`] bytes, in order,
/// each carrying the blob's length and CRC. An empty blob gives no chunks.
///
/// # Errors
/// [`WireError::BlobTooLarge`] for a blob longer than `u32::MAX` bytes.
pub fn model_chunks(blob: &[u8]) -> Result<ModelChunks<'_>, WireError> {
    let blob_len = u32::try_from(blob.len()).map_err(|_| WireError::BlobTooLarge)?;
    Ok(ModelChunks { blob_len, blob_crc: crc32(blob), chunks: blob.chunks(MODEL_CHUNK_LEN), offset: 0 })
}

/// The chunks of one model blob, in order; see [`model_chunks`].
#[derive(Debug, Clone)]
pub struct ModelChunks<'a> {
    /// Length of the blob.
    blob_len: u32,
    /// CRC of the blob.
    blob_crc: u32,
    /// The blob's pieces not yet sent.
    chunks: core::slice::Chunks<'a, u8>,
    /// Offset of the next piece.
    offset: u32,
}

impl Iterator for ModelChunks<'_> {
    type Item = ModelChunk;

    fn next(&mut self) -> Option<ModelChunk> {
        let data = self.chunks.next()?;
        let msg = ModelChunk {
            blob_len: self.blob_len,
            blob_crc: self.blob_crc,
            offset: self.offset,
            data: Vec::from_slice(data).ok()?,
        };
        // Cannot saturate: offsets stay within blob_len, a u32.
        self.offset = self.offset.saturating_add(u32::try_from(data.len()).ok()?);
        Some(msg)
    }

    fn size_hint(&self) -> (usize, Option<usize>) {
        self.chunks.size_hint()
    }
}

impl ExactSizeIterator for ModelChunks<'_> {}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::indexing_slicing)]
mod tests {
    use super::*;
    use crate::wire::ObjectClass;

    fn tracks<const N: usize>() -> [Track; N] {
        core::array::from_fn(|i| Track {
            track_id: i as u32,
            object_id: (i % 3) as u16,
            class: ObjectClass::Car,
            u: i as f32,
            v: 0.5,
            depth: 10.0,
        })
    }

    /// Checks that the parts of `tracks` number 0..parts, are full but the last, and carry
    /// every track exactly once, in order.
    fn check(tracks: &[Track], expected_parts: usize) {
        let parts = frame_parts(7, 123, tracks).unwrap();
        assert_eq!(parts.len(), expected_parts);
        let mut next = 0;
        for (i, p) in parts.enumerate() {
            assert_eq!((p.frame, p.timestamp_us), (7, 123));
            assert_eq!((usize::from(p.part), usize::from(p.parts)), (i, expected_parts));
            assert!(p.is_well_formed());
            if i + 1 < expected_parts {
                assert_eq!(p.tracks.len(), TRACKS_PER_MESSAGE);
            }
            assert_eq!(&p.tracks[..], &tracks[next..next + p.tracks.len()]);
            next += p.tracks.len();
        }
        assert_eq!(next, tracks.len());
    }

    #[test]
    fn frame_parts_cover_every_track_once() {
        let all = tracks::<MAX_FRAME_TRACKS>();
        check(&[], 1);
        for n in [1, TRACKS_PER_MESSAGE - 1, TRACKS_PER_MESSAGE, TRACKS_PER_MESSAGE + 1] {
            check(&all[..n], n.div_ceil(TRACKS_PER_MESSAGE));
        }
        check(&all[..3 * TRACKS_PER_MESSAGE], 3);
        check(&all, MAX_FRAME_PARTS);
        assert_eq!(MAX_FRAME_PARTS, 36);
    }

    #[test]
    fn too_many_tracks_is_an_error() {
        let all = tracks::<{ MAX_FRAME_TRACKS + 1 }>();
        assert_eq!(frame_parts(0, 0, &all).err(), Some(WireError::TooManyTracks));
    }

    #[test]
    fn model_chunks_rebuild_the_blob() {
        let blob: [u8; 3 * MODEL_CHUNK_LEN + 5] = core::array::from_fn(|i| (i * 7) as u8);
        let mut rebuilt = [0u8; 3 * MODEL_CHUNK_LEN + 5];
        let chunks = model_chunks(&blob).unwrap();
        assert_eq!(chunks.len(), 4);
        for c in chunks {
            assert!(c.is_within_blob());
            assert_eq!((c.blob_len as usize, c.blob_crc), (blob.len(), crc32(&blob)));
            let at = c.offset as usize;
            rebuilt[at..at + c.data.len()].copy_from_slice(&c.data);
        }
        assert_eq!(rebuilt, blob);
        assert_eq!(model_chunks(&[]).unwrap().len(), 0);
    }
}
