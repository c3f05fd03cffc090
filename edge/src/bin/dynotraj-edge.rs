//! Host build of the edge loop over stdin/stdout: `dynotraj-edge < frames.bin > replies.bin`.

use std::io::{Read, Write};

use dynotraj_edge::{EdgeLoop, Transport};

struct Stdio;

impl Transport for Stdio {
    type Error = std::io::Error;
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        std::io::stdin().read(buf)
    }
    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error> {
        let mut out = std::io::stdout();
        out.write_all(bytes)?;
        out.flush()
    }
}

fn main() -> std::process::ExitCode {
    let mut edge = EdgeLoop::new();
    let result = edge.run(&mut Stdio);
    let l = edge.link_stats().received;
    let s = edge.stats();
    eprintln!(
        "edge: frames {} complete, {} incomplete | msgs ok {} | rejected crc {} cobs {} version {} decode {} overflow {} | bytes dropped {}",
        s.frames_complete, s.frames_incomplete, l.frames_ok, l.crc_errors, l.cobs_errors, l.version_errors, l.decode_errors, l.overflows, l.bytes_discarded
    );
    match result {
        Ok(()) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("edge: stopped: {e:?}");
            std::process::ExitCode::FAILURE
        }
    }
}
