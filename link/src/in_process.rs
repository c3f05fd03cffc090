//! The edge's session run in this process as the link's other end: the host's side of the link
//! (camera model, every frame's parts, the goodbye) as bytes into [`Session::run`], its replies
//! decoded as a stream collects them. No edge process, no socket, no pacing: the same bytes the
//! edge would receive, the same session code, the same answers.

use std::path::Path;

use anyhow::Context as _;
use dynotraj_core::model::signed;
use dynotraj_core::wire::{DecoderStats, FrameDecoder, LinkStats, Message};
use dynotraj_edge::{NoClock, Session, Split};
use dynotraj_formats::model_file::read_model_file;
use dynotraj_formats::tracks_file::Tracks;

use crate::stream::StreamResult;
use crate::wire_io::WireSender;

/// What an in-process session answered.
#[derive(Debug)]
pub struct Forecasts {
    /// The edge's replies, decoded, as a stream would have collected them.
    pub result: StreamResult,
    /// Camera frames sent.
    pub frames: usize,
}

/// The model blob of the file at `path`, as the edge would take it: a signed one verified
/// against the key this build's edge is provisioned with, an unsigned one as a model linked
/// into the edge.
///
/// # Errors
/// A file that cannot be read, a bad signature, or bytes that are no model blob, named.
pub fn edge_model_blob(path: &Path) -> anyhow::Result<Vec<u8>> {
    let bytes = read_model_file(path).context("--model")?;
    let blob = match signed::verify(&bytes, &dynotraj_edge::provisioned::MODEL_KEY) {
        Ok(blob) => blob.to_vec(),
        Err(signed::SignatureError::Unsigned) => bytes,
        Err(e) => anyhow::bail!("--model {}: {}", path.display(), dynotraj_formats::model_signing::describe(&e)),
    };
    dynotraj_core::model::blob::ModelBlob::parse_exact(&blob)
        .map_err(|e| anyhow::anyhow!("--model {}: expected a model blob, {e}", path.display()))?;
    Ok(blob)
}

/// The edge's session over `tracks` in this process. With `model`, the session forecasts with
/// it; without, with constant velocity.
///
/// # Errors
/// A model the edge refuses, or a message that cannot be encoded.
pub fn forecast(tracks: &Tracks, model: Option<&[u8]>) -> anyhow::Result<Forecasts> {
    let mut host = WireSender::new(Vec::new());
    host.send(&Message::CameraInfo(tracks.camera))?;
    for frame in &tracks.frames {
        for part in &frame.parts {
            host.send(&Message::FrameTracks(part.clone()))?;
        }
    }
    let frames_sent = u32::try_from(host.sent() + 1).unwrap_or(u32::MAX);
    host.send(&Message::LinkStats(LinkStats { frames_sent, received: DecoderStats::default() }))?;
    let input = host.into_writer();
    let mut session: Box<Session<'_>> = Box::new(match model {
        Some(blob) => Session::with_model(blob).map_err(|e| anyhow::anyhow!("--model: the edge refuses it: {e}"))?,
        None => Session::new(),
    });
    let mut link = Split(input.as_slice(), Vec::new());
    session.run(&mut link, &mut NoClock).map_err(|e| anyhow::anyhow!("the in-process edge: {e:?}"))?;
    let raw = link.1;
    let replies: Vec<Message> = FrameDecoder::new().feed(&raw).collect();
    let notices = replies.iter().filter_map(|m| if let Message::Notice(n) = m { Some(*n) } else { None }).collect();
    let edge_link = replies.iter().find_map(|m| if let Message::LinkStats(l) = m { Some(*l) } else { None });
    let result = StreamResult { replies, raw, notices, edge_link, ..StreamResult::default() };
    Ok(Forecasts { result, frames: tracks.frames.len() })
}
