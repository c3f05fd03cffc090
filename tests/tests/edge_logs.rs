//! What the edge logs for an integrator (through the `log` facade, as the firmware's logger
//! prints it): a model accepted or refused with the reason, frames lost, and the session's start
//! and end with its totals; nothing per frame above debug level. The host build of the edge runs
//! in process on the 16-car fixture, with each test's records captured on its own thread.

use std::cell::RefCell;

use dynotraj_core::model::Dims;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::wire::{STATIC_OBJECT_ID, Track, frame_parts};
use dynotraj_formats::model_signing::{development_signing_key, sign};
use dynotraj_sim::cost_inputs::random_blob;
use dynotraj_tests::edge_fixture::{encode_all, host_messages, run_in_process, scene_tracks};
use log::{Level, LevelFilter, Log, Metadata, Record};

thread_local! {
    static RECORDS: RefCell<Vec<(Level, String)>> = const { RefCell::new(Vec::new()) };
}

/// Keeps every record of the edge crate, on the thread that logged it.
struct Capture;

impl Log for Capture {
    fn enabled(&self, _: &Metadata<'_>) -> bool {
        true
    }
    fn log(&self, record: &Record<'_>) {
        if record.target().starts_with("dynotraj_edge") {
            RECORDS.with(|r| r.borrow_mut().push((record.level(), record.args().to_string())));
        }
    }
    fn flush(&self) {}
}

static CAPTURE: Capture = Capture;

/// The edge's records at `Info` or more severe for `stream`, run in process.
fn logged(stream: &[u8]) -> Vec<(Level, String)> {
    // Every test installs the same logger; only the first call succeeds, the others find it.
    let _ = log::set_logger(&CAPTURE);
    log::set_max_level(LevelFilter::Trace);
    RECORDS.with(|r| r.borrow_mut().clear());
    let _ = run_in_process(stream, &[]);
    RECORDS.with(|r| r.borrow().iter().filter(|(l, _)| *l <= Level::Info).cloned().collect())
}

fn has(records: &[(Level, String)], level: Level, text: &str) -> bool {
    records.iter().any(|(l, m)| *l == level && m.contains(text))
}

#[test]
fn the_session_logs_its_start_and_its_totals_and_nothing_per_frame_at_info() {
    let tracks = scene_tracks(6);
    let records = logged(&encode_all(&host_messages(&tracks, None)));
    println!("{records:#?}");
    assert!(has(&records, Level::Info, "session start: forecasting with constant velocity"), "{records:?}");
    assert!(has(&records, Level::Info, "stream start: camera 1242x375 at 20.00 Hz"), "{records:?}");
    let end = records.iter().find(|(_, m)| m.starts_with("session end:")).expect("the closing totals");
    assert!(end.1.contains("frames 6 lost 0") && end.1.contains("host said goodbye"), "{end:?}");
    assert!(records.len() <= 4, "a handful of lines for a clean session of 6 frames, none per frame: {records:#?}");
    assert!(records.iter().all(|(l, _)| *l == Level::Info), "a clean session warns of nothing: {records:#?}");
}

#[test]
fn a_frame_missing_from_the_stream_is_logged_as_lost() {
    let mut tracks = scene_tracks(6);
    tracks.frames.remove(3);
    let records = logged(&encode_all(&host_messages(&tracks, None)));
    println!("{records:#?}");
    assert!(has(&records, Level::Warn, "frames lost: 1 before frame 4 (1 in all)"), "{records:#?}");
    let end = records.iter().find(|(_, m)| m.starts_with("session end:")).expect("the closing totals");
    assert!(end.1.contains("frames 5 lost 1"), "{end:?}");
}

#[test]
fn a_model_is_logged_as_accepted_or_refused_with_the_reason() {
    let tracks = scene_tracks(3);
    let blob = random_blob(&Dims::DEFAULT, Precision::Int8, 0.05);

    let refused = logged(&encode_all(&host_messages(&tracks, Some(&blob))));
    println!("{refused:#?}");
    assert!(has(&refused, Level::Warn, "model refused: signature Unsigned"), "{refused:#?}");

    if !dynotraj_edge::provisioned::MODEL_KEY_IS_DEVELOPMENT {
        dynotraj_testkit::skipped("edge_logs", "the edge was built with DYNOTRAJ_MODEL_PUBKEY: no signed case");
        return;
    }
    let signed = sign(&blob, &development_signing_key().unwrap());
    let accepted = logged(&encode_all(&host_messages(&tracks, Some(&signed))));
    println!("{accepted:#?}");
    assert!(has(&accepted, Level::Info, &format!("model accepted len={}", blob.len())), "{accepted:#?}");
    assert!(!accepted.iter().any(|(l, _)| *l == Level::Warn), "{accepted:#?}");
}

#[test]
fn a_capacity_reached_is_logged_once_not_every_frame() {
    // Every frame swaps one car's tracks for 40 more static tracks than the edge keeps.
    let mut tracks = scene_tracks(4);
    for f in &mut tracks.frames {
        let mut all: Vec<Track> = f.parts.iter().flat_map(|p| p.tracks.iter().copied()).collect();
        let last_car = all.iter().filter(|t| !t.is_static()).map(|t| t.object_id).max().unwrap();
        all.retain(|t| t.object_id != last_car);
        let extra: Vec<Track> = all
            .iter()
            .filter(|t| t.is_static())
            .take(40)
            .map(|t| Track { track_id: t.track_id + 1_000_000, ..*t })
            .collect();
        assert_eq!((extra.len(), extra[0].object_id), (40, STATIC_OBJECT_ID));
        all.extend(extra);
        f.parts = frame_parts(f.frame, f.timestamp_us, &all).unwrap().collect();
    }
    let records = logged(&encode_all(&host_messages(&tracks, None)));
    println!("{records:#?}");
    let warnings: Vec<&String> = records.iter().filter(|(l, _)| *l == Level::Warn).map(|(_, m)| m).collect();
    assert_eq!(warnings.len(), 1, "one warning for a capacity exceeded in every frame: {warnings:#?}");
    assert!(warnings[0].starts_with("capacity reached at frame 0:"), "{warnings:?}");
    assert!(warnings[0].contains("static tracks dropped (static capacity)"), "{warnings:?}");
}
