//! The host build of the edge keeps serving: sessions one after another over TCP, each answered
//! as a fresh edge answers; a client that stays idle is told so and its session ended; a client
//! that connects during a session is told the edge is busy; SIGTERM ends the edge with exit 0
//! and its totals.

use std::io::Read;
use std::net::TcpStream;
use std::process::{Command, Stdio};
use std::time::{Duration, Instant};

use dynotraj_core::model::Dims;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::wire::{FrameDecoder, Message, Notice};
use dynotraj_edge::{NoClock, Session};
use dynotraj_formats::tracks_file::Tracks;
use dynotraj_link::endpoint::{Endpoint, connect};
use dynotraj_link::stream::{StreamOptions, StreamResult, stream};
use dynotraj_sim::cost_inputs::random_blob;
use dynotraj_tests::edge_fixture::{
    MemLink, dynotraj_command, encode_all, host_messages, outputs, reference_replies, scene_tracks,
    spawn_listening_edge, write_tracks_file,
};

fn lockstep(tracks: &Tracks, addr: &str) -> StreamResult {
    let (rx, tx) = connect(&Endpoint::Tcp(addr.to_string()), Duration::from_secs(10)).unwrap();
    let opt = StreamOptions { lockstep: true, ..StreamOptions::default() };
    stream(tracks, rx, tx, &opt)
}

/// Every notice in the bytes a client reads until the edge closes the connection.
fn notices_until_closed(mut client: TcpStream) -> Vec<Notice> {
    client.set_read_timeout(Some(Duration::from_secs(20))).unwrap();
    let mut bytes = Vec::new();
    client.read_to_end(&mut bytes).unwrap();
    let mut decoder = FrameDecoder::new();
    decoder.feed(&bytes).filter_map(|m| if let Message::Notice(n) = m { Some(n) } else { None }).collect()
}

#[test]
fn the_edge_serves_sessions_in_a_row_survives_an_idle_client_and_stops_on_sigterm() {
    let tracks = scene_tracks(6);
    let reference = outputs(&reference_replies(&encode_all(&host_messages(&tracks, None)), &[]));
    let (mut edge, lines, addr) = spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--idle-timeout", "1.5"]);

    let one = lockstep(&tracks, &addr);
    assert_eq!(outputs(&one.replies), reference, "session 1 answers as a fresh edge");

    // A client that connects and says nothing holds the edge only until the idle limit; one
    // that connects meanwhile is told the edge is busy.
    let idle = TcpStream::connect(&addr).unwrap();
    std::thread::sleep(Duration::from_millis(400));
    let busy = lockstep(&tracks, &addr);
    assert!(busy.busy(), "the second client is told the edge is busy: {:?}", busy.notices);
    assert!(busy.frames.iter().all(|f| f.stats.is_none()), "and gets no answers");
    let started = Instant::now();
    assert_eq!(notices_until_closed(idle), [Notice::IdleTimeout { seconds: 1 }], "the idle client is told why");
    assert!(started.elapsed() < Duration::from_secs(10), "the idle session ended at its limit");

    for k in [3, 4] {
        let again = lockstep(&tracks, &addr);
        assert_eq!(outputs(&again.replies), reference, "session {k} answers as a fresh edge");
        assert!(again.edge_link.is_some(), "session {k} ends with the edge's goodbye");
    }

    let status = Command::new("kill").args(["-TERM", &edge.id().to_string()]).status().unwrap();
    assert!(status.success());
    let exit = edge.wait().unwrap();
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(exit.success(), "SIGTERM ends the edge cleanly: {exit} {rest:#?}");
    let last = rest.last().unwrap();
    assert!(
        last.contains("stopped by a signal after 4 sessions (1 ended idle, 0 failed), 1 clients refused busy"),
        "{rest:#?}"
    );
    assert!(rest.iter().any(|l| l.contains("session 2 from") && l.contains("ended idle")), "{rest:#?}");
    assert!(rest.iter().any(|l| l.contains("refused 127.0.0.1:")), "{rest:#?}");
    assert_eq!(rest.iter().filter(|l| l.contains("ended by the host's goodbye")).count(), 3, "{rest:#?}");
}

#[test]
fn the_stream_command_fails_with_the_reason_for_a_refused_model_and_keeps_what_an_interrupted_stream_got() {
    let dir = tempfile::tempdir().unwrap();
    let tracks = scene_tracks(30);
    let dtt = dir.path().join("scene.dtt");
    write_tracks_file(&tracks, &dtt);
    let blob = dir.path().join("unsigned.blob");
    std::fs::write(&blob, random_blob(&Dims::DEFAULT, Precision::Int8, 0.05)).unwrap();
    let (mut edge, edge_lines, addr) = spawn_listening_edge(&["--listen", "tcp://localhost:0", "--sessions", "2"]);
    let to = format!("tcp://{addr}");
    let out_dir = dir.path().join("stream");
    let (out, report) = (out_dir.join("forecasts.csv"), out_dir.join("frames.csv"));

    let refused = dynotraj_command()
        .args(["stream", "--tracks"])
        .arg(&dtt)
        .args(["--frames", "6", "--rate", "0", "--lockstep", "--to", &to, "--model"])
        .arg(&blob)
        .arg("--out")
        .arg(&out_dir)
        .output()
        .unwrap();
    let (stdout, stderr) = (String::from_utf8_lossy(&refused.stdout), String::from_utf8_lossy(&refused.stderr));
    assert_eq!(refused.status.code(), Some(1), "{stdout}{stderr}");
    assert!(stderr.contains("refused --model") && stderr.contains("the model is not signed"), "{stderr}");
    assert!(stdout.contains("edge said: model refused: the model is not signed"), "{stdout}");
    let frames_csv = std::fs::read_to_string(&report).unwrap();
    assert!(frames_csv.lines().next().unwrap().contains(",forecaster,"), "{frames_csv}");
    assert_eq!(frames_csv.lines().skip(1).filter(|l| l.contains(",constant_velocity,")).count(), 6, "{frames_csv}");
    assert!(std::fs::read_to_string(&out).unwrap().lines().count() > 1, "forecasts written");

    // Interrupted at 5 frames a second: what arrived is written, and the exit says so.
    std::fs::remove_file(&out).unwrap();
    let slow = dynotraj_command()
        .args(["stream", "--tracks"])
        .arg(&dtt)
        .args(["--rate", "5", "--to", &to, "--out"])
        .arg(&out_dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    std::thread::sleep(Duration::from_millis(2500));
    assert!(Command::new("kill").args(["-INT", &slow.id().to_string()]).status().unwrap().success());
    let slow = slow.wait_with_output().unwrap();
    let stderr = String::from_utf8_lossy(&slow.stderr);
    assert_eq!(slow.status.code(), Some(1), "{stderr}");
    assert!(stderr.contains("interrupted after") && stderr.contains("of 30 frames"), "{stderr}");
    let forecasts = std::fs::read_to_string(&out).unwrap();
    assert!(forecasts.lines().count() > 1, "the forecasts received before the interrupt are written");
    assert!(edge.wait().unwrap().success(), "the edge served its two sessions");
    // The edge logs the refusal on its own stderr too, in the firmware's terse form.
    let edge_log: Vec<String> = edge_lines.map_while(Result::ok).collect();
    assert!(edge_log.iter().any(|l| l.starts_with("W dynotraj_edge::session: model refused")), "{edge_log:#?}");
}

#[test]
fn a_session_reset_in_place_answers_as_a_new_one() {
    // The firmware keeps its session in a static and resets it between streams: the reset must
    // forget everything (the estimator's windows, runs and joint-solve scratch among them).
    let tracks = scene_tracks(12);
    let stream = encode_all(&host_messages(&tracks, None));
    let mut session: Box<Session<'static>> = Box::default();
    let mut first = MemLink { input: &stream, chunk: 256, output: Vec::new() };
    session.run(&mut first, &mut NoClock).unwrap();
    session.reset();
    let mut second = MemLink { input: &stream, chunk: 97, output: Vec::new() };
    session.run(&mut second, &mut NoClock).unwrap();
    assert!(!first.output.is_empty());
    assert_eq!(first.output, second.output, "the reset session answers bit for bit as the new one");
}

/// A host streaming faster than the edge's 100 ms poll leaves no quiet read; a second client is
/// still told at once that the edge is busy, not served when the first session ends.
#[test]
fn a_client_is_told_the_edge_is_busy_while_another_streams_fast() {
    let tracks = scene_tracks(80);
    let (mut edge, lines, addr) = spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--sessions", "1"]);
    let first_addr = addr.clone();
    let first = std::thread::spawn(move || {
        let (rx, tx) = connect(&Endpoint::Tcp(first_addr), Duration::from_secs(10)).unwrap();
        let opt = StreamOptions { rate_hz: Some(20.0), ..StreamOptions::default() };
        stream(&tracks, rx, tx, &opt)
    });
    std::thread::sleep(Duration::from_secs(1));
    let started = Instant::now();
    let second = TcpStream::connect(&addr).unwrap();
    assert_eq!(notices_until_closed(second), [Notice::Busy], "the second client is told the edge is busy");
    let waited = started.elapsed();
    let one = first.join().unwrap();
    assert!(one.edge_link.is_some(), "the first session ran to its goodbye");
    assert!(waited < Duration::from_millis(1500), "told within the poll, not after the session: {waited:?}");
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(edge.wait().unwrap().success(), "{rest:#?}");
    assert!(rest.iter().any(|l| l.contains("refused 127.0.0.1:")), "{rest:#?}");
}

/// Bytes that decode to no frame do not keep a session alive: a client trickling garbage is
/// told it is idle at the limit, as a silent one is.
#[test]
fn a_client_trickling_garbage_is_idle_all_the_same() {
    use std::io::Write as _;
    let (mut edge, lines, addr) =
        spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--idle-timeout", "1", "--sessions", "1"]);
    let mut client = TcpStream::connect(&addr).unwrap();
    let reader = client.try_clone().unwrap();
    let started = Instant::now();
    let told = std::thread::spawn(move || notices_until_closed(reader));
    while started.elapsed() < Duration::from_secs(6) && !told.is_finished() {
        if client.write_all(&[0x55]).is_err() {
            break;
        }
        std::thread::sleep(Duration::from_millis(40));
    }
    let notices = told.join().unwrap();
    let waited = started.elapsed();
    assert_eq!(notices, [Notice::IdleTimeout { seconds: 1 }], "the garbage client is told why");
    assert!(waited < Duration::from_secs(4), "ended near its limit, not held: {waited:?}");
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(edge.wait().unwrap().success(), "{rest:#?}");
}
