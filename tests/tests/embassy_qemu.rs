//! The Embassy example (edge/firmware/src/bin/embassy.rs: UART0's receive interrupt feeding an
//! embassy-sync pipe, an async task running the session) under QEMU, fed over its UART0 by the
//! host's streaming client: its replies equal, byte for byte, what the host build of the edge
//! answers to the same stream, and it ends with status 0 on the host's goodbye.

use dynotraj_core::wire::{ComputeUnit, Message};
use dynotraj_tests::edge_fixture::{
    encode_all, firmware_program, host_messages, outputs, reference_replies, scene_tracks, stream_to_qemu,
};
use dynotraj_tests::firmware_memory::check_memory;

#[test]
fn embassy_example_under_qemu_matches_the_host_edge_byte_for_byte() {
    let elf = firmware_program("dynotraj-embassy");
    let frames = 12;
    let tracks = scene_tracks(frames);
    let reference = reference_replies(&encode_all(&host_messages(&tracks, None)), &[]);

    let (result, status, log) = stream_to_qemu(&elf, &tracks);
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
    let ram = check_memory(&elf, &log, Some("memory-embassy.golden"));
    println!("embassy example: RAM {ram} B");
}
