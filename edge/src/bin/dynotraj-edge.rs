//! Host build of the edge: the same session as the firmware, over TCP, a serial port or stdio.
//!
//! ```text
//! dynotraj-edge --listen tcp://127.0.0.1:7878     # one session from one TCP client
//! dynotraj-edge --serial /dev/ttyUSB0              # one session over a serial port
//! dynotraj-edge < frames.dtt > replies.bin         # stdin/stdout
//! ```

use std::io::{Read, Write};
use std::net::{SocketAddr, TcpListener, TcpStream};
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::{Duration, Instant};

use clap::Parser;
use dynotraj_core::wire::ComputeUnit;
use dynotraj_edge::provisioned::{MODEL_KEY, MODEL_KEY_IS_DEVELOPMENT};
use dynotraj_edge::{Clock, ModelStatus, Session, Transport};

/// Bytes of the buffer a model sent over the link is loaded into (the default int8 model is
/// about 52 KB; the flash budget of the MCU image is 512 KiB).
const MODEL_BUFFER_LEN: usize = 512 * 1024;

/// The dynotraj edge loop on the host: decodes feature-track frames, estimates, forecasts and
/// answers with object states, forecasts and per-frame statistics.
#[derive(Debug, Parser)]
#[command(name = "dynotraj-edge", version, about)]
struct Args {
    /// Serve one session from one TCP client at this address, `tcp://HOST:PORT` (port 0 picks
    /// a free port; the bound address is printed on stderr).
    #[arg(long, conflicts_with = "serial")]
    listen: Option<String>,
    /// Allow --listen on an address other than loopback.
    #[arg(long)]
    allow_remote: bool,
    /// Serve one session over this serial device (or pseudo-terminal).
    #[arg(long)]
    serial: Option<PathBuf>,
    /// Baud rate of --serial (ignored by pseudo-terminals).
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// Forecast with this int8/f32 model blob (a file on the edge's own disk, trusted as a
    /// model linked into firmware is) instead of waiting for one over the link. A model sent
    /// over the link is accepted only when signed with the key provisioned at build time
    /// (`DYNOTRAJ_MODEL_PUBKEY`; `dynotraj sign`).
    #[arg(long)]
    model: Option<PathBuf>,
}

/// Nanoseconds since the edge started.
struct WallClock(Instant);

impl Clock for WallClock {
    const UNIT: ComputeUnit = ComputeUnit::Nanoseconds;
    fn now(&mut self) -> u64 {
        u64::try_from(self.0.elapsed().as_nanos()).unwrap_or(u64::MAX)
    }
}

/// Any std reader/writer pair as a transport.
struct Io<R, W> {
    rx: R,
    tx: W,
}

impl<R: Read, W: Write> Transport for Io<R, W> {
    type Error = std::io::Error;
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        loop {
            match self.rx.read(buf) {
                // A serial port's read times out when the line is idle: keep waiting.
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut || e.kind() == std::io::ErrorKind::Interrupted => {}
                other => return other,
            }
        }
    }
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error> {
        self.tx.write_all(bytes)?;
        self.tx.flush()
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    match serve(&args) {
        Ok(code) => code,
        Err(e) => {
            eprintln!("dynotraj-edge: {e}");
            ExitCode::FAILURE
        }
    }
}

fn serve(args: &Args) -> Result<ExitCode, String> {
    let model: Option<&'static [u8]> = match &args.model {
        Some(path) => Some(std::fs::read(path).map_err(|e| format!("{}: {e}", path.display()))?.leak()),
        None => None,
    };
    let mut buffer = vec![0u8; MODEL_BUFFER_LEN];
    let mut session: Session<'_> = match model {
        Some(blob) => Session::with_model(blob).map_err(|e| format!("model blob: {e:?}"))?,
        None => Session::with_model_buffer(&mut buffer, MODEL_KEY),
    };
    // Said once the link is up (the first line stays the listening address, which callers
    // read), and only when a model may come over the link.
    let key_note = || {
        if model.is_none() {
            let id: String =
                dynotraj_core::model::signed::key_id(&MODEL_KEY).iter().map(|b| format!("{b:02x}")).collect();
            let dev =
                if MODEL_KEY_IS_DEVELOPMENT { " (the repository's development key: its secret is public)" } else { "" };
            eprintln!("dynotraj-edge: a model sent over the link must be signed by key {id}{dev}");
        }
    };
    let mut clock = WallClock(Instant::now());
    let result = if let Some(url) = &args.listen {
        let stream = accept(url, args.allow_remote)?;
        let rx = stream.try_clone().map_err(|e| e.to_string())?;
        let _ = stream.set_nodelay(true);
        key_note();
        session.run(&mut Io { rx, tx: stream }, &mut clock)
    } else if let Some(path) = &args.serial {
        let name = path.to_string_lossy();
        let port = serialport::new(name.as_ref(), args.baud)
            .timeout(Duration::from_secs(3600))
            .open_native()
            .map_err(|e| format!("{name}: {e}"))?;
        let rx = port.try_clone_native().map_err(|e| format!("{name}: {e}"))?;
        key_note();
        session.run(&mut Io { rx, tx: port }, &mut clock)
    } else {
        key_note();
        session.run(&mut Io { rx: std::io::stdin().lock(), tx: std::io::stdout().lock() }, &mut clock)
    };
    report(&session);
    match result {
        Ok(()) => Ok(ExitCode::SUCCESS),
        Err(e) => Err(format!("stopped: {e:?}")),
    }
}

/// Binds `tcp://HOST:PORT` (loopback only unless allowed) and accepts one client.
fn accept(url: &str, allow_remote: bool) -> Result<TcpStream, String> {
    let addr = url.strip_prefix("tcp://").ok_or_else(|| format!("--listen {url}: expected tcp://HOST:PORT"))?;
    let addr: SocketAddr = addr.parse().map_err(|e| format!("--listen {url}: {e}"))?;
    if !addr.ip().is_loopback() && !allow_remote {
        return Err(format!("--listen {url}: not a loopback address (pass --allow-remote to serve other hosts)"));
    }
    let listener = TcpListener::bind(addr).map_err(|e| format!("--listen {url}: {e}"))?;
    let bound = listener.local_addr().map_err(|e| e.to_string())?;
    eprintln!("dynotraj-edge: listening on tcp://{bound}");
    let (stream, peer) = listener.accept().map_err(|e| e.to_string())?;
    eprintln!("dynotraj-edge: session from {peer}");
    Ok(stream)
}

fn report(session: &Session<'_>) {
    let e = session.edge().stats();
    let l = session.link_stats().received;
    let m = match session.model() {
        ModelStatus::None => "none (constant velocity)".to_string(),
        ModelStatus::Loaded { len } => format!("{len} B"),
        ModelStatus::Rejected(err) => format!("rejected: {err:?}"),
        ModelStatus::SignatureRejected(err) => format!("refused, signature: {err:?}"),
    };
    let ld = session.load_stats();
    eprintln!(
        "dynotraj-edge: frames estimated {} lost {} | forecasts {} (fallback {}, failed {}) | model {m} (unsigned {} bad signature {}) | msgs ok {} rejected {} | bytes dropped {}",
        e.frames_estimated,
        e.frames_lost,
        e.forecasts,
        e.forecasts_fallback,
        e.forecasts_failed,
        ld.unsigned,
        ld.bad_signatures,
        l.frames_ok,
        l.frames_rejected(),
        l.bytes_discarded
    );
}
