//! The Embassy example (edge/firmware/src/bin/embassy.rs: UART0's receive interrupt feeding an
//! embassy-sync pipe, an async task running the session) under QEMU, fed over its UART0 by the
//! host's streaming client: its replies equal, byte for byte, what the host build of the edge
//! answers to the same stream, and it ends with status 0 on the host's goodbye.

use std::io::Read as _;
use std::time::Duration;

use dynotraj_core::wire::{ComputeUnit, Message};
use dynotraj_host::link::{Endpoint, connect};
use dynotraj_host::stream::{StreamOptions, stream};
use dynotraj_tests::edge_fixture::{
    encode_all, firmware_program, free_port, host_messages, outputs, reference_replies, scene_tracks, spawn_qemu_elf,
    wait_for_firmware,
};

#[test]
fn embassy_example_under_qemu_matches_the_host_edge_byte_for_byte() {
    let elf = firmware_program("dynotraj-embassy");
    let frames = 12;
    let tracks = scene_tracks(frames);
    let reference = reference_replies(&encode_all(&host_messages(&tracks, None)), None);

    let port = free_port();
    let mut qemu = spawn_qemu_elf(port, &elf);
    let (rx, tx) = connect(&Endpoint::Tcp(format!("127.0.0.1:{port}")), Duration::from_secs(20)).unwrap();
    let opt = StreamOptions { lockstep: true, reply_timeout: Duration::from_secs(60), ..StreamOptions::default() };
    let result = stream(&tracks, rx, tx, &opt);
    let status = wait_for_firmware(&mut qemu, Duration::from_secs(120));
    let mut log = String::new();
    qemu.stdout.take().unwrap().read_to_string(&mut log).unwrap();
    qemu.stderr.take().unwrap().read_to_string(&mut log).unwrap();
    println!("{log}");
    assert!(status.success(), "embassy example exit {status}: {log}");
    assert_eq!(result.link_error, None, "the link held");

    let forecasts = result.replies.iter().filter(|m| matches!(m, Message::Prediction(_))).count();
    assert!(forecasts >= 16 * 5, "the example forecasts the cars ({forecasts})");
    assert_eq!(outputs(&result.replies), outputs(&reference), "embassy answers differ from the host edge");
    assert_eq!(result.frames.len(), frames);
    for f in &result.frames {
        let s = f.stats.expect("every frame answered");
        assert_eq!((s.frames_lost, s.bytes_dropped, s.unit), (0, 0, ComputeUnit::Instructions));
        assert!(s.compute > 0, "frame {} compute measured", f.frame);
    }
    let link = result.edge_link.expect("the edge's goodbye");
    assert_eq!(link.received.frames_rejected(), 0);
    assert_eq!(link.received.bytes_discarded, 0);
    assert!(log.contains(&format!("dynotraj-embassy: frames estimated {frames} lost 0")), "its summary: {log}");
    assert!(log.contains("uart overruns 0"), "no byte lost at the UART: {log}");
}
