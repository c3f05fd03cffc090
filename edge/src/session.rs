//! One session of the edge over a transport: the model load, then the stream of frames.

use dynotraj_core::model::blob::{BlobError, ModelBlob};
use dynotraj_core::model::signed::SignatureError;
#[cfg(feature = "model-over-link")]
use dynotraj_core::model::signed::{self, PublicKey};
#[cfg(feature = "model-over-link")]
use dynotraj_core::wire::ModelChunk;
use dynotraj_core::wire::{
    Forecaster, FrameBuf, LinkStats, MAX_FRAME_LEN, Message, ModelRefusal, Notice, WireError, encode,
};

use crate::link_decoder::LinkDecoder;
#[cfg(feature = "model-over-link")]
use crate::model_load::{ChunkOutcome, ModelLoader};
use crate::pipeline::{EDGE_WINDOW, Pipeline};
use crate::transport::{Clock, Transport};

/// Bytes read from the transport at a time.
pub const READ_CHUNK: usize = 256;

/// Where the session's model stands.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum ModelStatus {
    /// No learned model: constant-velocity forecasts.
    None,
    /// A model is in use (linked in, or loaded over the link and checked).
    Loaded {
        /// Blob length, bytes.
        len: u32,
    },
    /// A model arrived complete with a good CRC and a good signature but is not a valid blob
    /// for this build.
    Rejected(BlobError),
    /// A model arrived complete with a good CRC but without a valid signature by the
    /// provisioned key ([`crate::provisioned::MODEL_KEY`]); the previous model stays in use.
    SignatureRejected(SignatureError),
}

impl ModelStatus {
    /// What forecasts with this status.
    #[must_use]
    pub const fn forecaster(&self) -> Forecaster {
        match self {
            Self::Loaded { len } => Forecaster::Model { len: *len },
            Self::None | Self::Rejected(_) | Self::SignatureRejected(_) => Forecaster::ConstantVelocity,
        }
    }

    /// Why the model was refused, as the host is told; `None` when none was.
    #[must_use]
    pub const fn refusal(&self) -> Option<ModelRefusal> {
        match self {
            Self::None | Self::Loaded { .. } => None,
            Self::Rejected(_) => Some(ModelRefusal::InvalidBlob),
            Self::SignatureRejected(e) => Some(match e {
                SignatureError::Unsigned => ModelRefusal::Unsigned,
                SignatureError::OtherKey { found, expected } => {
                    ModelRefusal::OtherKey { found: *found, expected: *expected }
                }
                SignatureError::BadKey | SignatureError::BadSignature => ModelRefusal::BadSignature,
            }),
        }
    }

    /// What the host is told of this status after a load over the link: the refusal, or how
    /// the edge forecasts now.
    #[must_use]
    pub const fn notice(&self) -> Notice {
        match self.refusal() {
            Some(why) => Notice::ModelRefused(why),
            None => Notice::Forecasting(self.forecaster()),
        }
    }
}

/// Counters of the model load.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct LoadStats {
    /// Chunks stored.
    pub chunks_stored: u32,
    /// Chunks rejected (out of order, too big for the buffer, outside the blob) or arriving
    /// after the frames began.
    pub chunks_rejected: u32,
    /// Blobs whose bytes all arrived but whose CRC did not match.
    pub crc_mismatches: u32,
    /// Complete blobs refused for carrying no signature trailer.
    pub unsigned: u32,
    /// Complete blobs refused because their signature does not verify under the provisioned
    /// key (signed by another key, or changed after signing).
    pub bad_signatures: u32,
}

impl LoadStats {
    /// Every counter at zero.
    pub const ZERO: Self =
        Self { chunks_stored: 0, chunks_rejected: 0, crc_mismatches: 0, unsigned: 0, bad_signatures: 0 };
}

impl Default for LoadStats {
    fn default() -> Self {
        Self::ZERO
    }
}

/// Why [`Session::run`] stopped.
#[derive(Debug)]
pub enum RunError<E> {
    /// The transport failed.
    Transport(E),
    /// A message could not be encoded.
    Wire(WireError),
}

/// The edge over one link: the link layer, the pipeline and the model loader. A model may be
/// sent in [`Message::ModelChunk`]s before the first frame; a host [`Message::LinkStats`] ends
/// the session (the host's goodbye), as does the end of the byte stream. The edge then answers
/// with its own [`LinkStats`].
#[derive(Debug)]
pub struct Session<'m, const W: usize = EDGE_WINDOW> {
    link: LinkDecoder,
    edge: Pipeline<'m, W>,
    /// The loader of a model sent over the link, with the key it must be signed with.
    #[cfg(feature = "model-over-link")]
    loader: Option<(ModelLoader<'m>, PublicKey)>,
    model: ModelStatus,
    load: LoadStats,
    frames_sent: u32,
    ended: bool,
    /// Whether the host was told that a chunk was refused (told once a session, not per chunk).
    chunk_refusal_told: bool,
}

impl<const W: usize> Default for Session<'_, W> {
    fn default() -> Self {
        Self::new()
    }
}

impl<'m, const W: usize> Session<'m, W> {
    /// A session without a model and without room to load one.
    #[must_use]
    pub const fn new() -> Self {
        Self {
            link: LinkDecoder::new(),
            edge: Pipeline::new(),
            #[cfg(feature = "model-over-link")]
            loader: None,
            model: ModelStatus::None,
            load: LoadStats::ZERO,
            frames_sent: 0,
            ended: false,
            chunk_refusal_told: false,
        }
    }

    /// Back to the state of [`Session::new`], in place (see [`Pipeline::reset`]).
    pub fn reset(&mut self) {
        // Every field named (no `..`), as in `Estimator::reset`.
        let Self {
            link,
            edge,
            #[cfg(feature = "model-over-link")]
            loader,
            model,
            load,
            frames_sent,
            ended,
            chunk_refusal_told,
        } = self;
        *link = LinkDecoder::new();
        edge.reset();
        #[cfg(feature = "model-over-link")]
        {
            *loader = None;
        }
        *model = ModelStatus::None;
        *load = LoadStats::ZERO;
        *frames_sent = 0;
        *ended = false;
        *chunk_refusal_told = false;
    }

    /// Forecasts with the model `blob` (linked into the image) from now on. Never inlined: the
    /// blob's parse runs once, on a stack frame of its own.
    ///
    /// # Errors
    /// When `blob` is not a valid model blob; the session keeps its previous model.
    #[inline(never)]
    pub fn set_model(&mut self, blob: &'m [u8]) -> Result<(), BlobError> {
        let parsed = ModelBlob::parse(blob);
        if let Err(e) = &parsed {
            log::warn!("model refused: linked-in blob {e:?}");
        }
        self.edge.set_model(parsed?);
        self.model = ModelStatus::Loaded { len: u32::try_from(blob.len()).unwrap_or(u32::MAX) };
        log::info!("model linked in len={}", blob.len());
        #[cfg(feature = "model-over-link")]
        {
            self.loader = None;
        }
        Ok(())
    }

    /// A session that loads a model sent over the link into `buf` (room for the blob and its
    /// [`signed::TRAILER_LEN`]-byte signature trailer) and accepts it only when it is signed
    /// with `key` (normally [`crate::provisioned::MODEL_KEY`]).
    #[cfg(feature = "model-over-link")]
    #[must_use]
    pub fn with_model_buffer(buf: &'m mut [u8], key: PublicKey) -> Self {
        let mut s = Self::new();
        s.loader = Some((ModelLoader::new(buf), key));
        s
    }

    /// A session forecasting with the model `blob` (linked into the image).
    ///
    /// # Errors
    /// When `blob` is not a valid model blob.
    pub fn with_model(blob: &'m [u8]) -> Result<Self, BlobError> {
        Self::with_models(&[blob])
    }

    /// A session forecasting with the models `blobs` (linked into the image), one per agent
    /// type; a later blob of an agent type replaces an earlier one.
    ///
    /// # Errors
    /// The first of `blobs` that is not a valid model blob.
    pub fn with_models(blobs: &[&'m [u8]]) -> Result<Self, BlobError> {
        let mut s = Self::new();
        for blob in blobs {
            s.set_model(blob)?;
        }
        Ok(s)
    }

    /// The pipeline (for its counters).
    #[must_use]
    pub const fn pipeline(&self) -> &Pipeline<'m, W> {
        &self.edge
    }

    /// The link layer (for its counters).
    #[must_use]
    pub const fn link(&self) -> &LinkDecoder {
        &self.link
    }

    /// Where the model stands.
    #[must_use]
    pub const fn model(&self) -> ModelStatus {
        self.model
    }

    /// The model load's counters.
    #[must_use]
    pub const fn load_stats(&self) -> LoadStats {
        self.load
    }

    /// Whether the host said goodbye.
    #[must_use]
    pub const fn ended(&self) -> bool {
        self.ended
    }

    /// The link statistics message for the peer.
    #[must_use]
    pub const fn link_stats(&self) -> LinkStats {
        LinkStats { frames_sent: self.frames_sent, received: self.link.decoder_stats() }
    }

    /// Feeds received bytes; replies go to `io`. `lost` is what the transport itself dropped
    /// so far (receive overruns), reported with the decoder's drops.
    ///
    /// # Errors
    /// A transport failure, or a message that cannot be encoded.
    #[inline(never)]
    pub fn on_bytes<T: Transport, C: Clock>(
        &mut self,
        chunk: &[u8],
        io: &mut T,
        clock: &mut C,
    ) -> Result<(), RunError<T::Error>> {
        let Self {
            link,
            edge,
            #[cfg(feature = "model-over-link")]
            loader,
            model,
            load,
            frames_sent,
            ended,
            chunk_refusal_told,
            ..
        } = self;
        let lost = io.bytes_lost();
        let mut result = Ok(());
        let dropped = link.decoder_stats().bytes_discarded;
        link.on_bytes_with(chunk, |msg| {
            match msg {
                Message::ModelChunk(c) => {
                    #[cfg(feature = "model-over-link")]
                    let outcome = on_chunk(c, loader, model, load, edge);
                    #[cfg(not(feature = "model-over-link"))]
                    let outcome = {
                        let _ = c;
                        load.chunks_rejected += 1;
                        Some(Notice::ModelRefused(ModelRefusal::NotAccepted))
                    };
                    if let Some(notice) = outcome
                        && !(*chunk_refusal_told && is_chunk_refusal(&notice))
                    {
                        if is_chunk_refusal(&notice) {
                            // Once a session, as the host is told; every chunk at debug level.
                            log::warn!("{notice} (further chunks refused silently)");
                        }
                        *chunk_refusal_told |= is_chunk_refusal(&notice);
                        if let Err(e) = send_built(io, frames_sent, || Message::Notice(notice)) {
                            result = Err(e);
                            return false;
                        }
                    }
                }
                Message::LinkStats(_) => {
                    *ended = true;
                    return false;
                }
                _ => {
                    let mut handled = edge
                        .handle(msg, clock, dropped.saturating_add(lost), &mut |m: &Message| send(io, frames_sent, m));
                    if handled.is_ok() && matches!(msg, Message::CameraInfo(_)) {
                        handled =
                            send_built(io, frames_sent, || Message::Notice(Notice::Forecasting(model.forecaster())));
                    }
                    if let Err(e) = handled {
                        result = Err(e);
                        return false;
                    }
                }
            }
            true
        });
        result
    }

    /// Runs until the host says goodbye or the stream ends, then reports link statistics to
    /// the peer.
    ///
    /// # Errors
    /// A transport failure, or a message that cannot be encoded.
    pub fn run<T: Transport, C: Clock>(&mut self, io: &mut T, clock: &mut C) -> Result<(), RunError<T::Error>> {
        log::info!("session start: forecasting with {}", self.model.forecaster());
        let mut buf = [0u8; READ_CHUNK];
        while !self.ended {
            let n = embedded_io::Read::read(io, &mut buf).map_err(RunError::Transport)?;
            let chunk = buf.get(..n).unwrap_or_default();
            if chunk.is_empty() {
                break;
            }
            self.on_bytes(chunk, io, clock)?;
        }
        self.finish(io)
    }

    /// [`Session::run`] with the reads awaited: `io` reads through [`embedded_io_async::Read`]
    /// (an executor's UART or the pipe its receive interrupt fills) and writes the replies with
    /// the blocking [`embedded_io::Write`] of its [`Transport`]. The future holds only the
    /// [`READ_CHUNK`]-byte read buffer and references; the session stays where the caller keeps
    /// it.
    ///
    /// Replies are not awaited because they are sent from inside a frame's work (a frame's
    /// states, forecasts and statistics, each encoded when it is ready): awaiting them would
    /// need that work itself to be a future, or a buffer for every reply of a frame.
    ///
    /// # Errors
    /// A transport failure, or a message that cannot be encoded.
    ///
    /// [`embedded_io::Write`]: embedded_io::Write
    #[cfg(feature = "async")]
    pub async fn run_async<T, C>(&mut self, io: &mut T, clock: &mut C) -> Result<(), RunError<T::Error>>
    where
        T: Transport + embedded_io_async::Read,
        C: Clock,
    {
        log::info!("session start: forecasting with {}", self.model.forecaster());
        let mut buf = [0u8; READ_CHUNK];
        while !self.ended {
            let n = embedded_io_async::Read::read(io, &mut buf).await.map_err(RunError::Transport)?;
            let chunk = buf.get(..n).unwrap_or_default();
            if chunk.is_empty() {
                break;
            }
            self.on_bytes(chunk, io, clock)?;
        }
        self.finish(io)
    }

    /// Ends the session: unless the host said goodbye, the stream ended and an unfinished
    /// frame's bytes are counted as dropped; then the edge's [`LinkStats`] go to the peer. For
    /// callers that feed bytes themselves ([`Session::on_bytes`]); [`Session::run`] ends with it.
    ///
    /// # Errors
    /// A transport failure, or a message that cannot be encoded.
    pub fn finish<T: Transport>(&mut self, io: &mut T) -> Result<(), RunError<T::Error>> {
        if !self.ended {
            self.link.end_of_stream();
        }
        self.log_totals(io.bytes_lost());
        let stats = self.link_stats();
        send_built(io, &mut self.frames_sent, || Message::LinkStats(stats))
    }

    /// The session's totals, at its end: what an integrator checks first.
    fn log_totals(&self, bytes_lost: u32) {
        let e = self.edge.stats();
        let r = self.link.decoder_stats();
        log::info!(
            "session end: frames {} lost {} | forecasts {} fallback {} failed {} | link frames {} rejected {} \
                bytes dropped {} lost {} | {}",
            e.frames_estimated,
            e.frames_lost,
            e.forecasts,
            e.forecasts_fallback,
            e.forecasts_failed,
            r.frames_ok,
            r.frames_rejected(),
            r.bytes_discarded,
            bytes_lost,
            if self.ended { "host said goodbye" } else { "stream ended" }
        );
    }
}

/// Takes one model chunk: stores it, or counts its refusal; returns what the host must be told
/// (the model loaded or refused).
#[cfg(feature = "model-over-link")]
fn on_chunk<'m, const W: usize>(
    chunk: &ModelChunk,
    loader: &mut Option<(ModelLoader<'m>, PublicKey)>,
    model: &mut ModelStatus,
    load: &mut LoadStats,
    edge: &mut Pipeline<'m, W>,
) -> Option<Notice> {
    let Some((l, _)) = loader.as_mut().filter(|_| edge.stats().frames_estimated == 0) else {
        log::debug!("model chunk at {} refused: not accepted now", chunk.offset);
        load.chunks_rejected += 1;
        return Some(Notice::ModelRefused(ModelRefusal::NotAccepted));
    };
    match l.accept(chunk) {
        ChunkOutcome::Stored => {
            load.chunks_stored += 1;
            None
        }
        ChunkOutcome::Rejected(why) => {
            log::debug!("model chunk at {} refused: {why}", chunk.offset);
            load.chunks_rejected += 1;
            Some(Notice::ModelRefused(why))
        }
        ChunkOutcome::CrcMismatch => {
            log::warn!("model refused: CRC mismatch over {} B, the load starts over", chunk.blob_len);
            load.crc_mismatches += 1;
            Some(Notice::ModelRefused(ModelRefusal::Crc))
        }
        ChunkOutcome::Complete => {
            load.chunks_stored += 1;
            let (l, key) = loader.take()?;
            let (bytes, rest) = l.finish()?;
            *model = accept_signed(bytes, &key, load, edge);
            // What the blob left of the buffer takes the model of another agent type.
            if matches!(model, ModelStatus::Loaded { .. }) {
                *loader = Some((ModelLoader::new(rest), key));
            }
            Some(model.notice())
        }
    }
}

/// Whether `notice` refuses a chunk rather than a whole blob.
const fn is_chunk_refusal(notice: &Notice) -> bool {
    matches!(
        notice,
        Notice::ModelRefused(ModelRefusal::NotAccepted | ModelRefusal::TooLarge { .. } | ModelRefusal::OutOfOrder)
    )
}

/// The status after a complete, CRC-checked load of `bytes`: the signature by `key` first, then
/// the blob; a refusal is counted in `load` and leaves `edge`'s model as it was. Never inlined:
/// the verifier's large locals then live on the stack only while a model is checked, not in
/// the frame that also runs every camera frame.
#[cfg(feature = "model-over-link")]
#[inline(never)]
fn accept_signed<'m, const W: usize>(
    bytes: &'m [u8],
    key: &PublicKey,
    load: &mut LoadStats,
    edge: &mut Pipeline<'m, W>,
) -> ModelStatus {
    let blob = match signed::verify(bytes, key) {
        Ok(blob) => blob,
        Err(e) => {
            if e == SignatureError::Unsigned {
                load.unsigned = load.unsigned.saturating_add(1);
            } else {
                load.bad_signatures = load.bad_signatures.saturating_add(1);
            }
            log::warn!("model refused: signature {e:?}");
            return ModelStatus::SignatureRejected(e);
        }
    };
    match ModelBlob::parse_exact(blob) {
        Ok(b) => {
            edge.set_model(b);
            log::info!("model accepted len={}", blob.len());
            ModelStatus::Loaded { len: u32::try_from(blob.len()).unwrap_or(u32::MAX) }
        }
        Err(e) => {
            log::warn!("model refused: signed but not a valid blob {e:?}");
            ModelStatus::Rejected(e)
        }
    }
}

/// Tells the host `notice` now (the platform's own events: the link busy, idle).
///
/// # Errors
/// A transport failure, or a message that cannot be encoded.
pub fn send_notice<T: Transport>(io: &mut T, notice: Notice) -> Result<(), RunError<T::Error>> {
    send_built(io, &mut 0, || Message::Notice(notice))
}

/// Encodes `msg` and writes it to `io`. Never inlined: its frame buffer then lives on the
/// stack only while a message is sent.
#[inline(never)]
fn send<T: Transport>(io: &mut T, frames_sent: &mut u32, msg: &Message) -> Result<(), RunError<T::Error>> {
    let mut frame: FrameBuf = [0; MAX_FRAME_LEN];
    let n = encode(msg, &mut frame).map_err(RunError::Wire)?;
    // Flushed frame by frame: a host waiting for the reply to its frame gets it now, not when
    // a buffer fills.
    io.write_all(frame.get(..n).unwrap_or_default()).and_then(|()| io.flush()).map_err(RunError::Transport)?;
    *frames_sent = frames_sent.saturating_add(1);
    Ok(())
}

/// Builds a message and sends it, in a stack frame of its own (a [`Message`] is about 2 KiB).
#[inline(never)]
fn send_built<T: Transport>(
    io: &mut T,
    frames_sent: &mut u32,
    build: impl FnOnce() -> Message,
) -> Result<(), RunError<T::Error>> {
    send(io, frames_sent, &build())
}
