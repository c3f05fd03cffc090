//! The host's end of the link to an edge: a TCP socket or a serial port, as a reader and a
//! writer that can live on different threads.

use std::io::{Read, Write};
use std::net::TcpStream;
use std::path::PathBuf;
use std::time::{Duration, Instant};

use anyhow::{Context as _, bail};

/// Where the edge is.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Endpoint {
    /// `tcp://HOST:PORT`.
    Tcp(String),
    /// `serial:PATH` (a serial device or a pseudo-terminal).
    Serial(PathBuf),
}

impl std::str::FromStr for Endpoint {
    type Err = anyhow::Error;
    fn from_str(s: &str) -> anyhow::Result<Self> {
        if let Some(addr) = s.strip_prefix("tcp://") {
            Ok(Self::Tcp(addr.to_string()))
        } else if let Some(path) = s.strip_prefix("serial:") {
            Ok(Self::Serial(PathBuf::from(path)))
        } else {
            bail!("{s}: expected tcp://HOST:PORT or serial:PATH")
        }
    }
}

impl std::fmt::Display for Endpoint {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Self::Tcp(a) => write!(f, "tcp://{a}"),
            Self::Serial(p) => write!(f, "serial:{}", p.display()),
        }
    }
}

/// The receiving half of a link.
pub type LinkReader = Box<dyn Read + Send>;
/// The sending half of a link.
pub type LinkWriter = Box<dyn Write + Send>;

/// Serial line speed (pseudo-terminals ignore it).
pub const SERIAL_BAUD: u32 = 115_200;
/// How long a serial read waits before reporting an idle line (the reader then tries again).
const SERIAL_READ_TIMEOUT: Duration = Duration::from_millis(100);

/// Opens the link. A TCP edge that is still starting (a QEMU runner, a fresh process) is
/// retried until `connect_timeout` has passed.
///
/// # Errors
/// When the edge cannot be reached; the message names the endpoint.
pub fn connect(endpoint: &Endpoint, connect_timeout: Duration) -> anyhow::Result<(LinkReader, LinkWriter)> {
    match endpoint {
        Endpoint::Tcp(addr) => {
            let start = Instant::now();
            let stream = loop {
                match TcpStream::connect(addr) {
                    Ok(s) => break s,
                    Err(e) if start.elapsed() < connect_timeout => {
                        log::debug!("{endpoint}: {e}; retrying");
                        std::thread::sleep(Duration::from_millis(50));
                    }
                    Err(e) => return Err(e).with_context(|| format!("connecting to {endpoint}")),
                }
            };
            stream.set_nodelay(true).ok();
            let rx = stream.try_clone().with_context(|| format!("{endpoint}"))?;
            Ok((Box::new(rx), Box::new(stream)))
        }
        Endpoint::Serial(path) => {
            let name = path.to_string_lossy();
            let port = serialport::new(name.as_ref(), SERIAL_BAUD)
                .timeout(SERIAL_READ_TIMEOUT)
                .open_native()
                .with_context(|| format!("opening {endpoint}"))?;
            let rx = port.try_clone_native().with_context(|| format!("{endpoint}"))?;
            Ok((Box::new(rx), Box::new(port)))
        }
    }
}

/// Reads the next bytes of the link into `buf`, waiting through read time-outs and
/// interruptions (serial ports and sockets with a read time-out report those); `None` once the
/// link is closed or fails.
pub fn read_some(rx: &mut LinkReader, buf: &mut [u8]) -> Option<usize> {
    loop {
        match rx.read(buf) {
            Ok(0) => return None,
            Ok(n) => return Some(n),
            Err(e)
                if matches!(
                    e.kind(),
                    std::io::ErrorKind::TimedOut | std::io::ErrorKind::Interrupted | std::io::ErrorKind::WouldBlock
                ) => {}
            Err(e) => {
                log::debug!("link read: {e}");
                return None;
            }
        }
    }
}
