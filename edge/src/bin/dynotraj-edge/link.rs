//! The host's byte links as edge transports: a TCP client, a serial port, stdin/stdout. Reads
//! and writes wake every [`POLL`] so that a stop request or an idle link is noticed while
//! waiting.

use std::io::{ErrorKind, Read, Write};
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, AtomicU64, Ordering};
use std::time::{Duration, Instant};

use dynotraj_core::wire::ComputeUnit;
use dynotraj_edge::embedded_io::{self, ErrorType};
use dynotraj_edge::{Clock, Transport};

/// How often a waiting read looks at the stop flag, the idle limit and (TCP) waiting clients.
pub const POLL: Duration = Duration::from_millis(100);

/// Why a link stopped.
#[derive(Debug)]
pub enum LinkError {
    /// The link failed.
    Io(std::io::Error),
    /// Nothing arrived for this long (the idle limit).
    Idle(Duration),
    /// SIGINT or SIGTERM.
    Stopped,
}

impl std::fmt::Display for LinkError {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Io(e) if e.kind() == ErrorKind::ConnectionReset => f.write_str("the peer reset the connection"),
            Self::Io(e) => write!(f, "{e}"),
            Self::Idle(d) => write!(f, "nothing arrived for {} s (--idle-timeout)", d.as_secs_f64()),
            Self::Stopped => f.write_str("stopped by a signal"),
        }
    }
}

impl std::error::Error for LinkError {}

impl embedded_io::Error for LinkError {
    fn kind(&self) -> embedded_io::ErrorKind {
        match self {
            Self::Io(e) => e.kind().into(),
            Self::Idle(_) => embedded_io::ErrorKind::TimedOut,
            Self::Stopped => embedded_io::ErrorKind::Interrupted,
        }
    }
}

/// What a waiting read does on each [`POLL`] without bytes.
pub trait OnPoll {
    /// Called while no byte arrives; an error ends the read.
    ///
    /// # Errors
    /// The link should stop waiting.
    fn on_poll(&mut self, idle_for: Duration) -> Result<(), LinkError>;

    /// Called after each read that brought bytes: a busy link is never quiet, and what a poll
    /// does that cannot wait for quiet (answering waiting clients, an idle limit that counts
    /// frames, not bytes) happens here too; an error ends the read.
    ///
    /// # Errors
    /// The link should stop.
    fn on_bytes(&mut self) -> Result<(), LinkError> {
        Ok(())
    }
}

/// Waits only for the stop flag (serial, stdio).
pub struct UntilStopped<'s>(pub &'s AtomicBool);

impl OnPoll for UntilStopped<'_> {
    fn on_poll(&mut self, _: Duration) -> Result<(), LinkError> {
        if self.0.load(Ordering::Relaxed) { Err(LinkError::Stopped) } else { Ok(()) }
    }
}

/// Any std reader/writer pair as a transport; the reader must time out (a socket or port read
/// timeout of about [`POLL`]) or block, and `poll` decides whether to go on waiting.
pub struct Link<R, W, P> {
    /// Where the bytes come from.
    pub rx: R,
    /// Where the answers go.
    pub tx: W,
    /// What to do while the link is quiet.
    pub poll: P,
}

impl<R, W, P> ErrorType for Link<R, W, P> {
    type Error = LinkError;
}

impl<R: Read, W, P: OnPoll> embedded_io::Read for Link<R, W, P> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        let quiet_since = Instant::now();
        loop {
            match self.rx.read(buf) {
                Err(e) if waited(&e) => self.poll.on_poll(quiet_since.elapsed())?,
                Ok(n) => {
                    self.poll.on_bytes()?;
                    return Ok(n);
                }
                Err(e) => return Err(LinkError::Io(e)),
            }
        }
    }
}

/// Whether `e` is a timed-out (or interrupted) wait, after which the link polls and tries again.
fn waited(e: &std::io::Error) -> bool {
    matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted)
}

/// Writes wake every [`POLL`] as reads do (the writer must time out: a socket write timeout),
/// so that a host that sends and never reads cannot hold the edge: the idle limit, a stop
/// request and waiting clients are seen while a write waits.
impl<R, W: Write, P: OnPoll> embedded_io::Write for Link<R, W, P> {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Self::Error> {
        let blocked_since = Instant::now();
        loop {
            match self.tx.write(bytes) {
                Err(e) if waited(&e) => self.poll.on_poll(blocked_since.elapsed())?,
                other => return other.map_err(LinkError::Io),
            }
        }
    }

    fn write_all(&mut self, mut bytes: &[u8]) -> Result<(), Self::Error> {
        while !bytes.is_empty() {
            let n = embedded_io::Write::write(self, bytes)?;
            if n == 0 {
                return Err(LinkError::Io(ErrorKind::WriteZero.into()));
            }
            bytes = bytes.get(n..).unwrap_or_default();
        }
        Ok(())
    }

    fn flush(&mut self) -> Result<(), Self::Error> {
        let blocked_since = Instant::now();
        loop {
            match self.tx.flush() {
                Err(e) if waited(&e) => self.poll.on_poll(blocked_since.elapsed())?,
                other => return other.map_err(LinkError::Io),
            }
        }
    }
}

impl<R: Read, W: Write, P: OnPoll> Transport for Link<R, W, P> {}

/// Nanoseconds since the edge started. The session reads it around the work of every frame
/// part it decoded, so its last reading is also when a frame last arrived whole
/// ([`WallClock::last_frame`]).
pub struct WallClock {
    start: Instant,
    last: Arc<AtomicU64>,
}

impl WallClock {
    /// A clock from now.
    pub fn new() -> Self {
        Self { start: Instant::now(), last: Arc::new(AtomicU64::new(0)) }
    }

    /// When a frame part was last decoded and worked on, as the shared reading and the instant
    /// it counts from.
    pub fn last_frame(&self) -> (Arc<AtomicU64>, Instant) {
        (Arc::clone(&self.last), self.start)
    }
}

impl Clock for WallClock {
    const UNIT: ComputeUnit = ComputeUnit::Nanoseconds;
    fn now(&mut self) -> u64 {
        let now = u64::try_from(self.start.elapsed().as_nanos()).unwrap_or(u64::MAX);
        self.last.store(now, Ordering::Relaxed);
        now
    }
}
