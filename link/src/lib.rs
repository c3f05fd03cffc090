//! dynotraj-link: the host's end of the link to an edge.
//!
//! - [`endpoint`]: where the edge is (TCP or a serial port) and the two halves of a connection.
//! - [`wire_io`]: the one path from messages to the link's bytes ([`wire_io::WireSender`]) and
//!   from the link's bytes back to messages ([`wire_io::read_link`]).
//! - [`fault`]: a writer that damages whole wire frames at random ([`fault::FaultInjector`]),
//!   wrapped around a link's writer the way a fault-injecting device wraps a network device.
//! - [`stream`]: a recording sent to an edge, paced or in lockstep, with every answer kept.
//! - [`soak`]: a long stream through the fault injector, with counters only.
//! - [`in_process`]: the edge's session in this process as the link's other end.
//! - [`edge_process`]: a host build of the edge started as a child process, for a soak.

pub mod edge_process;
pub mod endpoint;
pub mod fault;
pub mod in_process;
pub mod soak;
pub mod stream;
pub mod wire_io;

use std::sync::Arc;

pub use endpoint::{Endpoint, LinkReader, LinkWriter, connect};

/// Told the number of camera frames sent, after each (a progress display, say).
#[derive(Clone)]
pub struct OnFrame(pub Arc<dyn Fn(u64) + Send + Sync>);

impl std::fmt::Debug for OnFrame {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("OnFrame(..)")
    }
}
