//! What the edge prints on stderr: one line per session, and the totals when it stops.

use dynotraj_edge::{ModelStatus, RunError, Session};

use crate::link::LinkError;

/// How a session ended, in words.
pub fn ending(result: &Result<(), RunError<LinkError>>, said_goodbye: bool) -> String {
    match result {
        Ok(()) if said_goodbye => "ended by the host's goodbye".into(),
        Ok(()) => "ended: the host closed the link".into(),
        Err(RunError::Transport(LinkError::Idle(d))) => {
            format!("ended idle: nothing arrived for {} s", d.as_secs_f64())
        }
        Err(RunError::Transport(LinkError::Stopped)) => "ended by a stop signal".into(),
        Err(RunError::Transport(e)) => format!("failed: {e}"),
        Err(RunError::Wire(e)) => format!("failed: a reply could not be encoded ({e})"),
    }
}

/// The model's status, in words.
pub fn model(status: ModelStatus) -> String {
    match (status, status.refusal()) {
        (ModelStatus::Rejected(err), _) => format!("refused, not a model this edge runs: {err}"),
        (_, Some(why)) => format!("refused: {why}"),
        (ModelStatus::Loaded { len }, None) => format!("{len} B"),
        _ => "none (constant velocity)".to_string(),
    }
}

/// One session's line: how it ended and its counters.
pub fn session_line(who: &str, session: &Session<'_>, ended: &str) -> String {
    let e = session.pipeline().stats();
    let l = session.link_stats().received;
    let ld = session.load_stats();
    format!(
        "dynotraj-edge: session {who} {ended} | frames estimated {} lost {} | forecasts {} (fallback {}, failed \
            {}) | model {} (unsigned {} bad signature {}) | msgs ok {} rejected {} | bytes dropped {}",
        e.frames_estimated,
        e.frames_lost,
        e.forecasts,
        e.forecasts_fallback,
        e.forecasts_failed,
        model(session.model()),
        ld.unsigned,
        ld.bad_signatures,
        l.frames_ok,
        l.frames_rejected(),
        l.bytes_discarded
    )
}

/// Counters over every session the edge served.
#[derive(Debug, Default)]
pub struct Totals {
    /// Sessions served.
    pub sessions: u32,
    /// Sessions that ended idle.
    pub idle: u32,
    /// Sessions whose link failed.
    pub failed: u32,
    /// Clients refused because a session was in progress.
    pub refused: u32,
    /// Camera frames estimated.
    pub frames_estimated: u64,
    /// Forecasts sent.
    pub forecasts: u64,
    /// Bytes the receivers dropped.
    pub bytes_dropped: u64,
}

impl Totals {
    /// Adds one session.
    pub fn add(&mut self, session: &Session<'_>, result: &Result<(), RunError<LinkError>>) {
        let e = session.pipeline().stats();
        self.sessions += 1;
        self.frames_estimated += u64::from(e.frames_estimated);
        self.forecasts += u64::from(e.forecasts);
        self.bytes_dropped += u64::from(session.link_stats().received.bytes_discarded);
        match result {
            Err(RunError::Transport(LinkError::Idle(_))) => self.idle += 1,
            Err(RunError::Transport(LinkError::Stopped)) | Ok(()) => {}
            Err(_) => self.failed += 1,
        }
    }

    /// The closing line.
    pub fn line(&self, why: &str) -> String {
        format!(
            "dynotraj-edge: {why} after {} sessions ({} ended idle, {} failed), {} clients refused busy | frames \
                estimated {} | forecasts {} | bytes dropped {}",
            self.sessions,
            self.idle,
            self.failed,
            self.refused,
            self.frames_estimated,
            self.forecasts,
            self.bytes_dropped
        )
    }
}
