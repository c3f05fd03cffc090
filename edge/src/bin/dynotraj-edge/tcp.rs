//! Serving TCP clients one session after another. A client that connects while a session is
//! in progress is told [`Notice::Busy`] and closed (one host drives an edge at a time, as on the
//! vehicle); a client that sends nothing for the idle limit is told [`Notice::IdleTimeout`] and
//! its session ends, so a stuck or forgotten client cannot hold the edge.

use std::io::Write as _;
use std::net::{SocketAddr, TcpListener, TcpStream, ToSocketAddrs as _};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use dynotraj_core::wire::{FrameBuf, MAX_FRAME_LEN, Message, Notice, encode};

use crate::link::{Link, LinkError, OnPoll, POLL};

/// A TCP session's link: reads wake every [`POLL`] to refuse waiting clients and watch the
/// idle limit and the stop flag.
pub type TcpLink<'a> = Link<TcpStream, TcpStream, TcpPoll<'a>>;

/// What a quiet TCP session does on each poll.
pub struct TcpPoll<'a> {
    listener: &'a TcpListener,
    stop: &'a AtomicBool,
    idle_limit: Duration,
    serving: SocketAddr,
    /// When waiting clients were last refused.
    refused_at: Instant,
    /// When the session started.
    started: Instant,
    /// The clock's last reading (nanoseconds from `clock_start`): when a frame last decoded.
    last_frame: Arc<AtomicU64>,
    clock_start: Instant,
    /// Clients refused while this session ran.
    pub refused: u32,
}

impl TcpPoll<'_> {
    fn refuse(&mut self) {
        self.refused += refuse_waiting(self.listener, self.serving);
        self.refused_at = Instant::now();
    }

    /// Time since a frame last decoded (or since the session started): bytes that decode to
    /// nothing do not keep a session alive.
    fn idle_for(&self) -> Duration {
        let last = self.clock_start + Duration::from_nanos(self.last_frame.load(Ordering::Relaxed));
        self.started.max(last).elapsed()
    }

    fn idle(&self) -> Result<(), LinkError> {
        if self.idle_for() >= self.idle_limit { Err(LinkError::Idle(self.idle_limit)) } else { Ok(()) }
    }
}

impl OnPoll for TcpPoll<'_> {
    fn on_poll(&mut self, _quiet_for: Duration) -> Result<(), LinkError> {
        if self.stop.load(Ordering::Relaxed) {
            return Err(LinkError::Stopped);
        }
        self.refuse();
        self.idle()
    }

    /// A host streaming faster than [`POLL`] leaves no quiet read: waiting clients are refused
    /// every [`POLL`] all the same, and a client trickling bytes that decode to no frame is
    /// idle all the same.
    fn on_bytes(&mut self) -> Result<(), LinkError> {
        if self.refused_at.elapsed() >= POLL {
            self.refuse();
            return self.idle();
        }
        Ok(())
    }
}

/// Binds `tcp://HOST:PORT` (HOST a name such as `localhost` or an address; loopback only
/// unless `allow_remote`) for non-blocking accepts.
///
/// # Errors
/// The address does not parse or resolve, is not loopback, or cannot be bound; the message
/// names the `--listen` value.
pub fn bind(url: &str, allow_remote: bool) -> Result<TcpListener, String> {
    let host_port = url.strip_prefix("tcp://").ok_or_else(|| format!("--listen {url}: expected tcp://HOST:PORT"))?;
    let addrs: Vec<SocketAddr> = host_port
        .to_socket_addrs()
        .map_err(|e| format!("--listen {url}: expected tcp://HOST:PORT with a host name or address and a port ({e})"))?
        .collect();
    let Some(first) = addrs.first() else { return Err(format!("--listen {url}: the host name has no address")) };
    if !allow_remote && let Some(remote) = addrs.iter().find(|a| !a.ip().is_loopback()) {
        return Err(format!(
            "--listen {url}: {} is not a loopback address (pass --allow-remote to serve other hosts)",
            remote.ip()
        ));
    }
    let listener = TcpListener::bind(first).map_err(|e| format!("--listen {url}: {e}"))?;
    listener.set_nonblocking(true).map_err(|e| format!("--listen {url}: {e}"))?;
    Ok(listener)
}

/// Waits for the next client: `Ok(None)` once `stop` is set.
///
/// # Errors
/// The listener failed.
pub fn next_client(listener: &TcpListener, stop: &AtomicBool) -> Result<Option<(TcpStream, SocketAddr)>, String> {
    loop {
        if stop.load(Ordering::Relaxed) {
            return Ok(None);
        }
        match listener.accept() {
            Ok(client) => return Ok(Some(client)),
            Err(e) if matches!(e.kind(), std::io::ErrorKind::WouldBlock | std::io::ErrorKind::Interrupted) => {
                std::thread::sleep(POLL);
            }
            // A client that gave up between its connect and our accept: wait for the next.
            Err(e) if e.kind() == std::io::ErrorKind::ConnectionAborted => {}
            Err(e) => return Err(format!("accepting a client: {e}")),
        }
    }
}

/// The link of a session with `client` (from `peer`).
///
/// # Errors
/// The socket cannot be set up.
pub fn session_link<'a>(
    client: TcpStream,
    peer: SocketAddr,
    listener: &'a TcpListener,
    stop: &'a AtomicBool,
    idle_limit: Duration,
    (last_frame, clock_start): (Arc<AtomicU64>, Instant),
) -> std::io::Result<TcpLink<'a>> {
    client.set_nonblocking(false)?;
    client.set_read_timeout(Some(POLL))?;
    // Writes time out too: a client that sends and never reads fills the socket's buffer.
    client.set_write_timeout(Some(POLL))?;
    client.set_nodelay(true)?;
    let rx = client.try_clone()?;
    let now = Instant::now();
    let poll = TcpPoll {
        listener,
        stop,
        idle_limit,
        serving: peer,
        refused_at: now,
        started: now,
        last_frame,
        clock_start,
        refused: 0,
    };
    Ok(Link { rx, tx: client, poll })
}

/// Tells every client waiting on `listener` that the edge is busy with `serving`, and closes
/// them; returns how many.
fn refuse_waiting(listener: &TcpListener, serving: SocketAddr) -> u32 {
    let mut refused = 0;
    while let Ok((mut other, peer)) = listener.accept() {
        let mut frame: FrameBuf = [0; MAX_FRAME_LEN];
        // Best effort: a client that is already gone needs no answer.
        if other.set_nonblocking(false).and_then(|()| other.set_write_timeout(Some(POLL))).is_ok()
            && let Ok(n) = encode(&Message::Notice(Notice::Busy), &mut frame)
        {
            let _ = other.write_all(frame.get(..n).unwrap_or_default());
        }
        eprintln!("dynotraj-edge: refused {peer}: busy with the session from {serving}");
        refused += 1;
    }
    refused
}
