//! Loading a model blob sent over the link in [`ModelChunk`]s into a caller's buffer.

use dynotraj_core::wire::{ModelChunk, ModelRefusal, crc32};

/// What happened to one chunk.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ChunkOutcome {
    /// Stored; more bytes are expected.
    Stored,
    /// The blob is complete and its CRC matches.
    Complete,
    /// The chunk does not fit the blob, the buffer, or the blob begun; ignored. Says why as
    /// the host is told ([`ModelRefusal::TooLarge`] or [`ModelRefusal::OutOfOrder`]).
    Rejected(ModelRefusal),
    /// Every byte arrived but the CRC does not match: the load starts over.
    CrcMismatch,
}

/// Reassembles one blob into a fixed buffer. Chunks come in order (as
/// [`dynotraj_core::wire::model_chunks`] makes them); a chunk at offset 0, or of another blob
/// (length or CRC), starts the load over, and a chunk out of order is rejected, so a lost
/// chunk leaves the load incomplete until the sender starts again. The blob is accepted only
/// when every byte arrived and the whole matches the CRC that every chunk carries.
#[derive(Debug)]
pub struct ModelLoader<'b> {
    buf: &'b mut [u8],
    /// Length and CRC of the blob being loaded.
    blob: Option<(u32, u32)>,
    /// Bytes received so far, in order.
    received: u32,
    /// Offset the next chunk must have.
    next_offset: u32,
}

impl<'b> ModelLoader<'b> {
    /// A loader writing into `buf`; blobs longer than `buf` are rejected.
    pub const fn new(buf: &'b mut [u8]) -> Self {
        Self { buf, blob: None, received: 0, next_offset: 0 }
    }

    /// Takes one chunk.
    pub fn accept(&mut self, chunk: &ModelChunk) -> ChunkOutcome {
        let fits = usize::try_from(chunk.blob_len).is_ok_and(|n| n <= self.buf.len());
        if !fits {
            return ChunkOutcome::Rejected(ModelRefusal::TooLarge {
                capacity: u32::try_from(self.buf.len()).unwrap_or(u32::MAX),
            });
        }
        if !chunk.is_within_blob() {
            return ChunkOutcome::Rejected(ModelRefusal::OutOfOrder);
        }
        if self.blob != Some((chunk.blob_len, chunk.blob_crc)) || chunk.offset == 0 {
            self.blob = Some((chunk.blob_len, chunk.blob_crc));
            self.received = 0;
            self.next_offset = 0;
        }
        if chunk.offset != self.next_offset {
            return ChunkOutcome::Rejected(ModelRefusal::OutOfOrder);
        }
        let at = chunk.offset as usize;
        let Some(dst) = self.buf.get_mut(at..at + chunk.data.len()) else {
            return ChunkOutcome::Rejected(ModelRefusal::OutOfOrder);
        };
        dst.copy_from_slice(&chunk.data);
        let len = u32::try_from(chunk.data.len()).unwrap_or(u32::MAX);
        self.next_offset = self.next_offset.saturating_add(len);
        self.received = self.next_offset;
        if self.received < chunk.blob_len {
            return ChunkOutcome::Stored;
        }
        let whole = self.buf.get(..chunk.blob_len as usize).unwrap_or(&[]);
        if crc32(whole) == chunk.blob_crc {
            ChunkOutcome::Complete
        } else {
            self.blob = None;
            ChunkOutcome::CrcMismatch
        }
    }

    /// The blob, if complete and checked, and the rest of the buffer after it (room for the
    /// model of another agent type); gives up the buffer for as long as it was lent.
    #[must_use]
    pub fn finish(self) -> Option<(&'b [u8], &'b mut [u8])> {
        let (len, crc) = self.blob?;
        if self.received != len || len as usize > self.buf.len() {
            return None;
        }
        let (blob, rest) = self.buf.split_at_mut(len as usize);
        let blob: &'b [u8] = blob;
        (crc32(blob) == crc).then_some((blob, rest))
    }
}
