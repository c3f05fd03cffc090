//! What `dynotraj stream` and `dynotraj soak` report: the forecasts and per-frame figures as
//! typed tables (written as CSV or JSON), and the closing summaries.

use std::fmt::Write as _;
use std::path::Path;

use anyhow::Context as _;

use dynotraj_core::wire::{ComputeUnit, Forecaster, Message};

use super::data::{Cell, ColumnKind, Data};
use super::write_table_files;
use dynotraj_link::endpoint::Endpoint;
use dynotraj_link::soak::SoakReport;
use dynotraj_link::stream::StreamResult;

/// A soak's figures as one row: what was sent and damaged, what was answered and lost, both
/// decoders' rejects, the edge's resident memory after the first frames and at the end (KiB;
/// empty when they could not be read).
#[must_use]
pub fn soak_data(r: &SoakReport) -> Data {
    let mut d = Data::new([
        ("seconds", ColumnKind::Num),
        ("frames_sent", ColumnKind::Int),
        ("wire_frames_sent", ColumnKind::Int),
        ("bytes_flipped", ColumnKind::Int),
        ("tails_dropped", ColumnKind::Int),
        ("frames_duplicated", ColumnKind::Int),
        ("damaged_frames", ColumnKind::Int),
        ("answered", ColumnKind::Int),
        ("clean_unanswered", ColumnKind::Int),
        ("edge_frames_lost", ColumnKind::Int),
        ("edge_wire_frames_ok", ColumnKind::Int),
        ("edge_wire_frames_rejected", ColumnKind::Int),
        ("edge_bytes_discarded", ColumnKind::Int),
        ("host_wire_frames_rejected", ColumnKind::Int),
        ("host_bytes_discarded", ColumnKind::Int),
        ("edge_rss_start_kib", ColumnKind::Int),
        ("edge_rss_end_kib", ColumnKind::Int),
        ("edge_rss_peak_kib", ColumnKind::Int),
    ]);
    let edge = r.edge_link.map(|l| l.received);
    let edge_cell =
        |f: fn(&dynotraj_core::wire::DecoderStats) -> u32| edge.as_ref().map_or(Cell::Missing, |s| Cell::int(f(s)));
    let mem = |f: fn(&(dynotraj_link::soak::Memory, dynotraj_link::soak::Memory)) -> u64| {
        r.edge_memory.as_ref().map_or(Cell::Missing, |m| Cell::int(f(m)))
    };
    d.push(vec![
        Cell::num(r.seconds, 1),
        Cell::int(r.frames_sent),
        Cell::int(r.wire_frames_sent),
        Cell::int(r.faults[0]),
        Cell::int(r.faults[1]),
        Cell::int(r.faults[2]),
        Cell::int(r.damaged_frames),
        Cell::int(r.answered),
        Cell::int(r.clean_unanswered),
        Cell::int(r.edge_frames_lost),
        edge_cell(|s| s.frames_ok),
        edge_cell(dynotraj_core::wire::DecoderStats::frames_rejected),
        edge_cell(|s| s.bytes_discarded),
        Cell::int(r.host_received.frames_rejected()),
        Cell::int(r.host_received.bytes_discarded),
        mem(|(a, _)| a.rss_kib),
        mem(|(_, b)| b.rss_kib),
        mem(|(_, b)| b.peak_kib),
    ]);
    d
}

/// The forecasts, one row per forecast point: `frame`, `object_id`, `step` (1 = the next
/// frame), `x`, `y` (world bird's-eye, metres).
#[must_use]
pub fn predictions_data(result: &StreamResult) -> Data {
    let mut d = Data::new([
        ("frame", ColumnKind::Int),
        ("object_id", ColumnKind::Int),
        ("step", ColumnKind::Int),
        ("x", ColumnKind::Num),
        ("y", ColumnKind::Num),
    ]);
    for msg in &result.replies {
        if let Message::Prediction(p) = msg {
            for (k, q) in p.points.iter().enumerate() {
                d.push(vec![
                    Cell::int(p.frame),
                    Cell::int(p.object_id),
                    Cell::int(k + 1),
                    Cell::real32(q.x),
                    Cell::real32(q.y),
                ]);
            }
        }
    }
    d
}

/// One row per frame sent: when it was sent, its latency, what forecast it and the edge's
/// statistics of it (compute in `unit`, counts, the edge's loss counters so far). A frame the
/// edge did not answer has only `frame` and `sent_ms`.
#[must_use]
pub fn frames_data(result: &StreamResult) -> Data {
    let mut d = Data::new([
        ("frame", ColumnKind::Int),
        ("sent_ms", ColumnKind::Num),
        ("latency_ms", ColumnKind::Num),
        ("forecaster", ColumnKind::Text),
        ("compute", ColumnKind::Int),
        ("unit", ColumnKind::Text),
        ("objects", ColumnKind::Int),
        ("predictions", ColumnKind::Int),
        ("frames_lost", ColumnKind::Int),
        ("objects_dropped", ColumnKind::Int),
        ("tracks_dropped", ColumnKind::Int),
        ("bytes_dropped", ColumnKind::Int),
    ]);
    for f in &result.frames {
        let by = match f.forecaster {
            Some(Forecaster::Model { .. }) => Cell::text("model"),
            Some(Forecaster::ConstantVelocity) => Cell::text("constant_velocity"),
            None => Cell::Missing,
        };
        let mut row = vec![
            Cell::int(f.frame),
            Cell::num(f.sent.as_secs_f64() * 1e3, 3),
            Cell::opt(f.latency().map(|l| l.as_secs_f64() * 1e3), 3),
            by,
        ];
        match &f.stats {
            Some(st) => row.extend([
                Cell::int(st.compute),
                Cell::text(unit_name(st.unit)),
                Cell::int(st.objects),
                Cell::int(st.predictions),
                Cell::int(st.frames_lost),
                Cell::int(st.objects_dropped),
                Cell::int(st.tracks_dropped),
                Cell::int(st.bytes_dropped),
            ]),
            None => row.resize(d.columns.len(), Cell::Missing),
        }
        d.push(row);
    }
    d
}

const fn unit_name(u: ComputeUnit) -> &'static str {
    match u {
        ComputeUnit::Nanoseconds => "ns",
        ComputeUnit::Instructions => "instructions",
    }
}

/// A stream's closing report: frames answered, latency quantiles, compute, losses.
#[must_use]
pub fn summary(result: &StreamResult, to: &Endpoint) -> String {
    let mut lat: Vec<f64> = result.frames.iter().filter_map(|f| f.latency()).map(|l| l.as_secs_f64() * 1e3).collect();
    lat.sort_by(f64::total_cmp);
    let q = |p: f64| lat.get(((lat.len() as f64 - 1.0) * p).round() as usize).copied().unwrap_or(f64::NAN);
    let answered = result.frames.iter().filter(|f| f.stats.is_some()).count();
    let last = result.frames.iter().rev().find_map(|f| f.stats);
    let forecasts = result.replies.iter().filter(|m| matches!(m, Message::Prediction(_))).count();
    let mut compute: Vec<u32> = result.frames.iter().filter_map(|f| f.stats.map(|s| s.compute)).collect();
    compute.sort_unstable();
    let mut s = String::new();
    let _ = writeln!(s, "edge {to}: {} frames sent, {answered} answered, {forecasts} forecasts", result.frames.len());
    for n in &result.notices {
        let _ = writeln!(s, "edge said: {n}");
    }
    if lat.is_empty() {
        let _ = writeln!(s, "latency ms: none measured (no frame was answered)");
    } else {
        let _ = writeln!(
            s,
            "latency ms (last part sent -> frame stats received): median {:.2}, p95 {:.2}, max {:.2}",
            q(0.5),
            q(0.95),
            q(1.0)
        );
    }
    if let Some(l) = last {
        let med = compute.get(compute.len() / 2).copied().unwrap_or(0);
        let max = compute.last().copied().unwrap_or(0);
        let _ = writeln!(s, "edge compute per frame ({}): median {med}, max {max}", unit_name(l.unit));
        let _ = writeln!(
            s,
            "edge losses: frames lost {}, objects dropped {}, tracks dropped {}, bytes dropped {}",
            l.frames_lost, l.objects_dropped, l.tracks_dropped, l.bytes_dropped
        );
    }
    match result.edge_link {
        Some(l) => {
            let r = l.received;
            let _ = writeln!(
                s,
                "edge link: {} of our {} frames received intact, {} rejected, {} bytes dropped",
                r.frames_ok,
                result.frames_sent,
                r.frames_rejected(),
                r.bytes_discarded
            );
        }
        None => s.push_str("edge link: no goodbye from the edge (it stopped or timed out)\n"),
    }
    let r = result.received;
    let _ = writeln!(s, "host link: {} frames rejected, {} bytes dropped", r.frames_rejected(), r.bytes_discarded);
    s
}

/// A soak run's report as text.
#[must_use]
pub fn soak_summary(r: &SoakReport) -> String {
    let mem = r.edge_memory.map_or_else(
        || "edge memory: not read".to_string(),
        |(a, b)| {
            format!(
                "edge memory: resident {} KiB after the first frames, {} KiB at the end (peak {} KiB)",
                a.rss_kib, b.rss_kib, b.peak_kib
            )
        },
    );
    let link = r.edge_link.map_or_else(
        || "edge goodbye: none".to_string(),
        |l| {
            format!(
                "edge decoder: {} wire frames accepted, {} rejected, {} bytes discarded",
                l.received.frames_ok,
                l.received.frames_rejected(),
                l.received.bytes_discarded
            )
        },
    );
    format!(
        "soak: {} camera frames ({} wire frames) in {:.1} s\nfaults injected: {} ({} flipped bytes, {} dropped \
            tails, {} duplicated frames) in {} damaged camera frames\nanswered: {} frames; clean frames \
            unanswered: {}; edge's frames lost: {}\n{link}\n{mem}\n",
        r.frames_sent,
        r.wire_frames_sent,
        r.seconds,
        r.faults_injected(),
        r.faults[0],
        r.faults[1],
        r.faults[2],
        r.damaged_frames,
        r.answered,
        r.clean_unanswered,
        r.edge_frames_lost
    )
}

/// The forecasts' file stem in `--out` (`.csv` and `.json`).
pub const FORECASTS: &str = "forecasts";
/// Per-frame latency, compute and losses (`.csv` and `.json`).
pub const FRAMES: &str = "frames";
/// The edge's replies as received.
pub const REPLIES_BIN: &str = "replies.bin";

/// Writes what came back into the folder `dir`: the forecasts and per-frame tables as CSV and
/// JSON, the raw replies.
///
/// # Errors
/// A file that cannot be written, named.
pub fn write_stream_outputs(dir: &Path, result: &StreamResult) -> anyhow::Result<()> {
    write_table_files(dir, FORECASTS, &predictions_data(result))?;
    write_table_files(dir, FRAMES, &frames_data(result))?;
    let path = dir.join(REPLIES_BIN);
    dynotraj_formats::atomic::write_file(&path, &result.raw)
        .with_context(|| format!("--out: writing {}", path.display()))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_stream_without_answers_says_so_instead_of_printing_nan() {
        let s = summary(&StreamResult::default(), &Endpoint::Tcp("127.0.0.1:1".into()));
        assert!(s.contains("latency ms: none measured") && !s.contains("NaN"), "{s}");
    }
}
