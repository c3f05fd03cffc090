//! dynotraj-edge: the firmware loop that runs the core on a stream of wire frames.
//!
//! `no_std` and allocation-free so that the same loop runs as a host process
//! (`dynotraj-edge`, over TCP, serial or stdio) and as Cortex-M firmware (`firmware/`, over
//! the UART). Per camera frame the edge decodes the [`FrameTracks`] parts, runs the estimator
//! ([`dynotraj_core::estimate`]), keeps each object's causal history ([`history`]), forecasts
//! with the learned int8 model (or constant velocity when none is loaded) and sends back
//! [`ObjectStates`], one [`Prediction`] per object and a [`FrameStats`].
//!
//! - [`transport`]: the [`Transport`] (any `embedded-io` byte stream, through [`Io`]) and
//!   [`Clock`] the platform provides;
//! - [`link_decoder`]: decoding ([`LinkDecoder`]; the estimator assembles the frame parts);
//! - [`pipeline`]: the per-frame work ([`Pipeline`]);
//! - [`model_load`]: a model blob over the link into a fixed buffer, checked by CRC;
//! - [`provisioned`]: the Ed25519 key a model over the link must be signed with (build time);
//! - [`session`]: one link session tying them together ([`Session::run`]).
//!
//! [`FrameTracks`]: dynotraj_core::wire::FrameTracks
//! [`ObjectStates`]: dynotraj_core::wire::ObjectStates
//! [`Prediction`]: dynotraj_core::wire::Prediction
//! [`FrameStats`]: dynotraj_core::wire::FrameStats
#![no_std]

pub mod history;
pub mod link_decoder;
pub mod model_load;
pub mod pipeline;

/// The build-time provisioning of this edge (edge/build.rs, `DYNOTRAJ_MODEL_PUBKEY`).
pub mod provisioned {
    include!(concat!(env!("OUT_DIR"), "/model_key.rs"));
}

pub mod session;
pub mod transport;

/// docs/integration.md, whose Rust examples are compiled as doctests.
#[cfg(doctest)]
#[doc = include_str!("../../docs/integration.md")]
pub struct IntegrationGuide;

pub use embedded_io;
#[cfg(feature = "async")]
pub use embedded_io_async;
pub use link_decoder::LinkDecoder;
pub use pipeline::{EDGE_WINDOW, ESTIMATOR_SEED, EdgeStats, Pipeline};
pub use session::{LoadStats, ModelStatus, RunError, Session, send_notice};
pub use transport::{Clock, Io, NoClock, Split, Transport};
