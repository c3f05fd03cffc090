//! A driver that only implements the embedded-io traits plugs into the edge with no code of
//! its own: `Split(rx, tx)` for a receive and a transmit half, `Io(driver)` for one object. A
//! byte slice and a `Vec` (embedded-io's own implementations) carry the 16-car fixture stream,
//! and the replies equal the in-memory reference link's, byte for byte.

use dynotraj_edge::{Io, NoClock, Session, Split};
use dynotraj_tests::edge_fixture::{decode_all, encode_all, host_messages, outputs, reference_replies, scene_tracks};

#[test]
fn embedded_io_halves_and_whole_drivers_plug_in_and_answer_as_the_reference_link() {
    let tracks = scene_tracks(6);
    let stream = encode_all(&host_messages(&tracks, None));
    let reference = outputs(&reference_replies(&stream, &[]));
    assert!(reference.len() > 16, "the fixture is answered ({} replies)", reference.len());

    let mut halves_out = Vec::new();
    let mut session: Box<Session<'static>> = Box::default();
    session.run(&mut Split(&stream[..], &mut halves_out), &mut NoClock).unwrap();
    assert_eq!(outputs(&decode_all(&halves_out)), reference, "Split(rx, tx)");

    let mut whole_out = Vec::new();
    session.reset();
    session.run(&mut Io(Split(&stream[..], &mut whole_out)), &mut NoClock).unwrap();
    assert_eq!(whole_out, halves_out, "Io(driver), after a reset in place");
}
