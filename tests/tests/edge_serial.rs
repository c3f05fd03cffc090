//! Over a serial line: the host's link (as `dynotraj stream --to serial:PATH` opens it, through
//! the serialport crate) on one end of a pseudo-terminal pair, the host build of the edge on
//! the other. The answers equal, bit for bit, the in-process edge's.

use std::io::{Read, Write};
use std::time::Duration;

use dynotraj_edge::{NoClock, Session, Transport};
use dynotraj_link::endpoint::{Endpoint, connect};
use dynotraj_link::stream::{StreamOptions, stream};
use dynotraj_tests::edge_fixture::{encode_all, host_messages, outputs, reference_replies, scene_tracks};
use serialport::{SerialPort, TTYPort};

/// The master end of the pseudo-terminal as the edge's transport.
struct Pty(TTYPort);

impl embedded_io::ErrorType for Pty {
    type Error = std::io::Error;
}

impl embedded_io::Read for Pty {
    fn read(&mut self, buf: &mut [u8]) -> std::io::Result<usize> {
        loop {
            match self.0.read(buf) {
                Err(e) if e.kind() == std::io::ErrorKind::TimedOut => {}
                other => return other,
            }
        }
    }
}

impl embedded_io::Write for Pty {
    fn write(&mut self, bytes: &[u8]) -> std::io::Result<usize> {
        Write::write(&mut self.0, bytes)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        Write::flush(&mut self.0)
    }
}

impl Transport for Pty {}

#[test]
fn serial_pty_edge_matches_the_in_process_edge() {
    let tracks = scene_tracks(6);
    let reference = reference_replies(&encode_all(&host_messages(&tracks, None)), &[]);

    let (mut master, slave) = TTYPort::pair().unwrap();
    master.set_timeout(Duration::from_millis(100)).unwrap();
    let path = slave.name().unwrap();
    let edge = std::thread::spawn(move || {
        let mut session: Box<Session<'static>> = Box::default();
        let mut pty = Pty(master);
        session.run(&mut pty, &mut NoClock).unwrap();
        // Both ends stay open until the host has read everything: closing the master hangs up
        // the line and discards what the host has not read yet.
        (session.pipeline().stats().frames_estimated, pty, slave)
    });
    let (rx, tx) = connect(&Endpoint::Serial(path.into()), Duration::from_secs(5)).unwrap();
    let opt = StreamOptions { lockstep: true, ..StreamOptions::default() };
    let result = stream(&tracks, rx, tx, &opt);
    assert_eq!(result.link_error, None, "the link held");
    let (frames, _pty, _slave) = edge.join().unwrap();
    assert_eq!(frames, 6);
    assert_eq!(outputs(&result.replies), outputs(&reference), "serial edge answers differ from the in-process edge");
    assert!(result.frames.iter().all(|f| f.stats.is_some()));
    assert_eq!(result.edge_link.expect("goodbye").received.frames_rejected(), 0);
}
