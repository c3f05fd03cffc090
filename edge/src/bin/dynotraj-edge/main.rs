//! Host build of the edge: the same session as the firmware, over TCP, a serial port or stdio.
//!
//! ```text
//! dynotraj-edge --listen tcp://127.0.0.1:7878     # TCP clients, one session after another
//! dynotraj-edge --serial /dev/ttyUSB0              # sessions over a serial port
//! dynotraj-edge < frames.dtt > replies.bin         # one session on stdin/stdout
//! ```
//!
//! Over TCP and serial the edge serves until SIGINT or SIGTERM (or `--sessions N`), then prints
//! its totals and exits 0.

mod link;
mod report;
mod tcp;

use std::path::PathBuf;
use std::process::ExitCode;
use std::sync::Arc;
use std::sync::atomic::{AtomicBool, Ordering};
use std::time::Duration;

use clap::Parser;
use dynotraj_core::model::blob::ModelBlob;
use dynotraj_core::predict::Dynamics;
use dynotraj_core::wire::Notice;
use dynotraj_edge::provisioned::{MODEL_KEY, MODEL_KEY_IS_DEVELOPMENT};
use dynotraj_edge::{RunError, Session, Transport, send_notice};

use crate::link::{Link, LinkError, POLL, UntilStopped, WallClock};
use crate::report::Totals;

/// Bytes of the buffer a model sent over the link is loaded into (the default int8 model is
/// about 52 KB; the flash budget of the MCU image is 512 KiB).
const MODEL_BUFFER_LEN: usize = 512 * 1024;

/// The dynotraj edge loop on the host: decodes feature-track frames, estimates, forecasts and
/// answers with object states, forecasts and per-frame statistics.
#[derive(Debug, Parser)]
#[command(name = "dynotraj-edge", version, about)]
struct Args {
    /// Serve TCP clients at this address, `tcp://HOST:PORT` (HOST a name such as localhost or
    /// an address; port 0 picks a free port; the bound address is the first line on stderr),
    /// one session after another. A client that connects during a session is told the edge
    /// is busy and closed.
    #[arg(long, conflicts_with = "serial")]
    listen: Option<String>,
    /// Allow --listen on an address other than loopback.
    #[arg(long)]
    allow_remote: bool,
    /// Serve sessions over this serial device (or pseudo-terminal), one after another.
    #[arg(long)]
    serial: Option<PathBuf>,
    /// Baud rate of --serial (ignored by pseudo-terminals).
    #[arg(long, default_value_t = 115_200)]
    baud: u32,
    /// Forecast with this int8/f32 model blob (a file on the edge's own disk, trusted as a
    /// model linked into firmware is) instead of waiting for one over the link. A model sent
    /// over the link is accepted only when signed with the key provisioned at build time
    /// (`DYNOTRAJ_MODEL_PUBKEY`; `dynotraj sign`). Once per agent type: each blob forecasts the
    /// objects of its dynamics (vehicles: unicycle; pedestrians: single integrator), the others
    /// constant velocity.
    #[arg(long)]
    model: Vec<PathBuf>,
    /// End a TCP session when nothing arrived for this many seconds.
    #[arg(long, value_parser = idle_seconds, default_value = "60", value_name = "S")]
    idle_timeout: Duration,
    /// Exit after serving this many sessions (default: serve until SIGINT or SIGTERM).
    #[arg(long, value_parser = clap::value_parser!(u32).range(1..), value_name = "N")]
    sessions: Option<u32>,
    /// More log detail on stderr: -v info (sessions, models), -vv debug (every frame).
    #[arg(short, long, action = clap::ArgAction::Count, conflicts_with = "quiet")]
    verbose: u8,
    /// Errors only (the default shows warnings: refused models, capacity reached).
    #[arg(short, long)]
    quiet: bool,
}

impl Args {
    /// The log level the flags ask for (`RUST_LOG`, when set, chooses instead).
    const fn log_level(&self) -> log::LevelFilter {
        dynotraj_core::log_level::from_flags(self.quiet, self.verbose)
    }
}

/// The edge's log lines in the firmware's terse form: level letter, target, message
/// (`W dynotraj_edge::session: model refused: …`).
fn init_log(level: log::LevelFilter) {
    use std::io::Write as _;
    let mut logger = env_logger::Builder::new();
    logger.filter_level(level).format(|f, r| {
        let letter = r.level().as_str().chars().next().unwrap_or('?');
        writeln!(f, "{letter} {}: {}", r.target(), r.args())
    });
    if let Ok(filters) = std::env::var("RUST_LOG") {
        logger.parse_filters(&filters);
    }
    logger.init();
}

/// Parses `--idle-timeout`: seconds, a finite number above zero and at most a day.
fn idle_seconds(text: &str) -> Result<Duration, String> {
    match text.trim().parse::<f64>() {
        Ok(s) if s.is_finite() && s > 0.0 && s <= 86_400.0 => Ok(Duration::from_secs_f64(s)),
        _ => Err(format!("expected seconds above 0 and at most 86400, found `{text}`")),
    }
}

fn main() -> ExitCode {
    let args = Args::parse();
    init_log(args.log_level());
    match serve(&args) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("dynotraj-edge: {e}");
            ExitCode::FAILURE
        }
    }
}

/// The model file of `--model`, checked, and the agent type it forecasts.
fn model_file(path: &std::path::Path) -> Result<(&'static [u8], Dynamics), String> {
    let bytes: &'static [u8] =
        dynotraj_formats::model_file::read_model_file(path).map_err(|e| format!("--model {e:#}"))?.leak();
    let blob = ModelBlob::parse(bytes)
        .map_err(|e| format!("--model {}: not a model blob this edge runs: {e}", path.display()))?;
    Ok((bytes, blob.dynamics()))
}

/// The edge's state across sessions: the model it was given, the buffer a model sent over the
/// link is loaded into, its clock and totals.
struct Edge {
    models: Vec<&'static [u8]>,
    buffer: Vec<u8>,
    clock: WallClock,
    totals: Totals,
}

impl Edge {
    /// Runs one session over `io` and prints its line.
    fn session<T: Transport<Error = LinkError>>(&mut self, io: &mut T, who: &str) -> Result<(), RunError<LinkError>> {
        let mut session: Session<'_> = if self.models.is_empty() {
            Session::with_model_buffer(&mut self.buffer, MODEL_KEY)
        } else {
            // Checked when the edge started.
            Session::with_models(&self.models).unwrap_or_default()
        };
        let result = session.run(io, &mut self.clock);
        eprintln!("{}", report::session_line(who, &session, &report::ending(&result, session.ended())));
        self.totals.add(&session, &result);
        result
    }

    /// The closing line: why the edge stops (`stop` set by a signal, else `--sessions`) and its
    /// totals.
    fn say_totals(&self, stop: &AtomicBool) {
        let why = if stop.load(Ordering::Relaxed) { "stopped by a signal" } else { "served --sessions" };
        eprintln!("{}", self.totals.line(why));
    }

    /// Says which key a model over the link must be signed with (once the link is up: the
    /// first line stays the listening address, which callers read).
    fn key_note(&self) {
        if self.models.is_empty() {
            let id: String =
                dynotraj_core::model::signed::key_id(&MODEL_KEY).iter().map(|b| format!("{b:02x}")).collect();
            let dev =
                if MODEL_KEY_IS_DEVELOPMENT { " (the repository's development key: its secret is public)" } else { "" };
            eprintln!("dynotraj-edge: a model sent over the link must be signed by key {id}{dev}");
        }
    }
}

fn serve(args: &Args) -> Result<(), String> {
    let models = args.model.iter().map(|p| model_file(p)).collect::<Result<Vec<_>, _>>()?;
    for (i, (_, a)) in models.iter().enumerate() {
        if let Some(j) = models.iter().skip(i + 1).position(|(_, b)| b == a) {
            return Err(format!(
                "--model {} and {} both forecast {}: give one blob per agent type",
                args.model[i].display(),
                args.model[i + 1 + j].display(),
                a.agents()
            ));
        }
    }
    let models = models.into_iter().map(|(bytes, _)| bytes).collect();
    let mut edge =
        Edge { models, buffer: vec![0u8; MODEL_BUFFER_LEN], clock: WallClock::new(), totals: Totals::default() };
    if let Some(url) = &args.listen {
        serve_tcp(&mut edge, url, args)
    } else if let Some(path) = &args.serial {
        serve_serial(&mut edge, path, args)
    } else {
        edge.key_note();
        let never = AtomicBool::new(false);
        let mut io = Link { rx: std::io::stdin().lock(), tx: std::io::stdout().lock(), poll: UntilStopped(&never) };
        edge.session(&mut io, "on stdio").map_err(|e| format!("stopped: {}", report::ending(&Err(e), false)))
    }
}

/// A flag that SIGINT and SIGTERM set.
fn stop_flag() -> Result<Arc<AtomicBool>, String> {
    let stop = Arc::new(AtomicBool::new(false));
    for signal in [signal_hook::consts::SIGINT, signal_hook::consts::SIGTERM] {
        signal_hook::flag::register(signal, Arc::clone(&stop))
            .map_err(|e| format!("installing a signal handler: {e}"))?;
    }
    Ok(stop)
}

/// Whether `--sessions` is reached.
fn enough(edge: &Edge, args: &Args) -> bool {
    args.sessions.is_some_and(|n| edge.totals.sessions >= n)
}

fn serve_tcp(edge: &mut Edge, url: &str, args: &Args) -> Result<(), String> {
    let stop = stop_flag()?;
    let listener = tcp::bind(url, args.allow_remote)?;
    let bound = listener.local_addr().map_err(|e| format!("--listen {url}: {e}"))?;
    eprintln!("dynotraj-edge: listening on tcp://{bound}");
    edge.key_note();
    while !enough(edge, args) {
        let Some((client, peer)) = tcp::next_client(&listener, &stop)? else { break };
        let who = format!("{} from {peer}", edge.totals.sessions + 1);
        eprintln!("dynotraj-edge: session {who} started");
        let mut io = match tcp::session_link(client, peer, &listener, &stop, args.idle_timeout, edge.clock.last_frame())
        {
            Ok(io) => io,
            Err(e) => {
                eprintln!("dynotraj-edge: session {who} failed: setting up the socket: {e}");
                continue;
            }
        };
        let result = edge.session(&mut io, &who);
        edge.totals.refused += io.poll.refused;
        if let Err(RunError::Transport(LinkError::Idle(d))) = result {
            let seconds = u32::try_from(d.as_secs()).unwrap_or(u32::MAX);
            // Best effort: the idle client may be gone.
            let _ = send_notice(&mut io, Notice::IdleTimeout { seconds });
        }
    }
    edge.say_totals(&stop);
    Ok(())
}

fn serve_serial(edge: &mut Edge, path: &std::path::Path, args: &Args) -> Result<(), String> {
    let stop = stop_flag()?;
    let name = path.to_string_lossy();
    let port =
        serialport::new(name.as_ref(), args.baud).timeout(POLL).open_native().map_err(|e| format!("{name}: {e}"))?;
    let rx = port.try_clone_native().map_err(|e| format!("{name}: {e}"))?;
    edge.key_note();
    let mut io = Link { rx, tx: port, poll: UntilStopped(&stop) };
    while !enough(edge, args) {
        let who = format!("{} on {name}", edge.totals.sessions + 1);
        match edge.session(&mut io, &who) {
            Ok(()) => {}
            Err(RunError::Transport(LinkError::Stopped)) => break,
            Err(e) => return Err(format!("{name}: {}", report::ending(&Err(e), false))),
        }
    }
    edge.say_totals(&stop);
    Ok(())
}
