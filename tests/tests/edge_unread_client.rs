//! A host that sends and never reads cannot hold the edge: once the edge's answers fill the
//! socket, its writes wait like its reads, so the idle limit ends the session (and a signal or
//! a waiting client is seen) instead of the edge blocking until the host goes.

use std::io::Write as _;
use std::net::TcpStream;
use std::time::{Duration, Instant};

use dynotraj_core::wire::{FrameBuf, MAX_FRAME_LEN, Message, encode};
use dynotraj_tests::edge_fixture::{scene_tracks, spawn_listening_edge};

#[test]
fn a_host_that_never_reads_ends_at_the_idle_limit() {
    let tracks = scene_tracks(100);
    let (mut edge, lines, addr) =
        spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--sessions", "1", "--idle-timeout", "1"]);
    let mut host = TcpStream::connect(&addr).unwrap();
    host.set_write_timeout(Some(Duration::from_millis(200))).unwrap();
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    let mut send = |m: &Message| -> std::io::Result<()> {
        let n = encode(m, &mut buf).unwrap();
        host.write_all(&buf[..n])
    };
    send(&Message::CameraInfo(tracks.camera)).unwrap();
    let started = Instant::now();
    let mut frames_sent = 0u64;
    // Fresh frames without end (the scene's, renumbered) until the edge stops taking them.
    'sending: for lap in 0u32.. {
        for f in &tracks.frames {
            for part in &f.parts {
                let mut part = part.clone();
                part.frame += lap * 100;
                part.timestamp_us += u64::from(lap) * 5_000_000;
                if send(&Message::FrameTracks(part)).is_err() {
                    break 'sending;
                }
            }
            frames_sent += 1;
        }
        assert!(started.elapsed() < Duration::from_secs(60), "the edge took frames for a minute without reads");
    }
    let blocked_at = started.elapsed();
    let deadline = Instant::now() + Duration::from_secs(20);
    let exit = loop {
        if let Some(status) = edge.try_wait().unwrap() {
            break status;
        }
        assert!(Instant::now() < deadline, "the edge is still held by a host that does not read");
        std::thread::sleep(Duration::from_millis(50));
    };
    let said: Vec<String> = lines.map_while(Result::ok).collect();
    println!(
        "{frames_sent} frames sent in {:.1} s; the edge exited {exit} {:.1} s later",
        blocked_at.as_secs_f64(),
        (started.elapsed() - blocked_at).as_secs_f64()
    );
    assert!(exit.success(), "{exit}: {said:#?}");
    assert!(said.iter().any(|l| l.contains("session 1 from") && l.contains("ended idle")), "{said:#?}");
}
