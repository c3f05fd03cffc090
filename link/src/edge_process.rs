//! A host build of the edge (`dynotraj-edge`) started as a child process listening on a free
//! loopback port, for a soak: started, connected to, and waited for.

use std::io::{BufRead as _, BufReader, Lines};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStderr, Command, Stdio};
use std::time::Duration;

use anyhow::Context as _;

use crate::endpoint::{Endpoint, LinkReader, LinkWriter, connect};

/// A running edge process with one session to give.
#[derive(Debug)]
pub struct EdgeProcess {
    child: Child,
    stderr: Lines<BufReader<ChildStderr>>,
    /// Where it listens.
    pub endpoint: Endpoint,
}

/// The edge binary beside this program (`cargo build --release --bins` builds both).
///
/// # Errors
/// This program's path cannot be found.
pub fn edge_beside_this_program() -> anyhow::Result<PathBuf> {
    Ok(std::env::current_exe().context("locating this program")?.with_file_name("dynotraj-edge"))
}

impl EdgeProcess {
    /// Starts the edge `binary` on a free loopback port for one session, and reads where it
    /// listens from its first line.
    ///
    /// # Errors
    /// The binary cannot be started, or its first line names no address (its error, then).
    pub fn start(binary: &Path) -> anyhow::Result<Self> {
        let mut child = Command::new(binary)
            .args(["--listen", "tcp://127.0.0.1:0", "--sessions", "1"])
            .stderr(Stdio::piped())
            .spawn()
            .with_context(|| {
                format!(
                    "starting the edge {} (build it with `cargo build --release --bins`, or give --edge)",
                    binary.display()
                )
            })?;
        let mut stderr = BufReader::new(child.stderr.take().context("edge stderr")?).lines();
        let first = stderr.next().context("the edge said nothing")?.context("reading the edge's stderr")?;
        let Some((_, addr)) = first.rsplit_once("tcp://") else {
            // Not an edge (or one that failed to start): what it said is its error, not an address.
            let _ = child.kill();
            let _ = child.wait();
            anyhow::bail!(
                "the edge {} did not say where it listens: expected its first line to end in tcp://HOST:PORT, found \
                 `{}`",
                binary.display(),
                first.trim()
            );
        };
        let endpoint = Endpoint::Tcp(addr.trim().to_string());
        Ok(Self { child, stderr, endpoint })
    }

    /// The process id (its memory is read from /proc during a soak).
    #[must_use]
    pub fn id(&self) -> u32 {
        self.child.id()
    }

    /// Connects to the edge's session.
    ///
    /// # Errors
    /// The connection fails, named.
    pub fn connect(&self) -> anyhow::Result<(LinkReader, LinkWriter)> {
        connect(&self.endpoint, Duration::from_secs(10))
    }

    /// Waits for the edge to exit; returns its last words (its session summary) and whether it
    /// exited successfully, with its status.
    ///
    /// # Errors
    /// Waiting fails.
    pub fn wait(mut self) -> anyhow::Result<(Vec<String>, std::process::ExitStatus)> {
        let said = self.stderr.by_ref().map_while(Result::ok).collect();
        let status = self.child.wait().context("waiting for the edge")?;
        Ok((said, status))
    }
}
