//! The host build of the edge over TCP: `dynotraj-edge --listen` fed by the host's streaming
//! client answers a 16-car fixture stream with exactly the bits the in-process edge computes,
//! once with constant velocity and once with an int8 model loaded over the link.

use std::time::Duration;

use dynotraj_core::model::Dims;
use dynotraj_core::model::blob::Precision;
use dynotraj_core::wire::{Forecaster, Message, ModelRefusal, Notice};
use dynotraj_formats::model_signing::{development_signing_key, sign};
use dynotraj_link::endpoint::{Endpoint, connect};
use dynotraj_link::stream::{StreamOptions, stream};
use dynotraj_sim::cost_inputs::random_blob;
use dynotraj_tests::edge_fixture::{
    encode_all, host_messages, outputs, reference_replies, scene_tracks, spawn_listening_edge,
};

/// Streams the fixture over TCP with `sent` over the link and compares with the in-process
/// edge that has `expected` linked in; returns the edge's stderr after its first line and the
/// notices the edge sent.
fn over_tcp(sent: Option<Vec<u8>>, expected: Option<&[u8]>) -> (Vec<String>, Vec<Notice>) {
    let tracks = scene_tracks(10);
    let reference = reference_replies(&encode_all(&host_messages(&tracks, None)), expected.as_slice());
    let forecasts = reference.iter().filter(|m| matches!(m, Message::Prediction(_))).count();
    assert!(forecasts >= 16 * 5, "the reference forecasts the cars ({forecasts} forecasts)");

    let (mut edge, lines, addr) = spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--sessions", "1"]);
    let (rx, tx) = connect(&Endpoint::Tcp(addr), Duration::from_secs(10)).unwrap();
    let opt = StreamOptions { lockstep: true, model: sent, ..StreamOptions::default() };
    let result = stream(&tracks, rx, tx, &opt);
    assert_eq!(result.link_error, None, "the link held");
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(edge.wait().unwrap().success(), "edge failed: {rest:?}");

    assert_eq!(outputs(&result.replies), outputs(&reference), "TCP edge answers differ from the in-process edge");
    assert!(
        result.frames.iter().all(|f| f.stats.is_some_and(|s| s.frames_lost == 0)),
        "every frame answered, none lost"
    );
    let link = result.edge_link.expect("edge goodbye");
    assert_eq!((link.received.frames_ok, link.received.frames_rejected()), (result.frames_sent, 0));
    let notices =
        result.replies.iter().filter_map(|m| if let Message::Notice(n) = m { Some(*n) } else { None }).collect();
    (rest, notices)
}

/// Streams the fixture over TCP with `model` (a blob, signed with the development key before it
/// is sent) and compares with the in-process edge that has the blob linked in.
fn run_over_tcp(model: Option<Vec<u8>>) {
    if model.is_some() && !dynotraj_edge::provisioned::MODEL_KEY_IS_DEVELOPMENT {
        dynotraj_testkit::skipped(
            "edge_tcp",
            "the edge was built with DYNOTRAJ_MODEL_PUBKEY; this test signs with the development key",
        );
        return;
    }
    let signed = model.as_deref().map(|b| sign(b, &development_signing_key().unwrap()));
    let (rest, notices) = over_tcp(signed, model.as_deref());
    let first = Notice::Forecasting(Forecaster::ConstantVelocity);
    match &model {
        Some(m) => {
            let loaded = format!("model {} B", m.len());
            assert!(rest.iter().any(|l| l.contains(&loaded)), "edge reports the loaded model ({loaded}): {rest:?}");
            let len = u32::try_from(m.len()).unwrap();
            assert_eq!(notices, [first, Notice::Forecasting(Forecaster::Model { len })], "the host is told");
        }
        None => assert_eq!(notices, [first], "the host is told it gets constant-velocity forecasts"),
    }
}

#[test]
fn tcp_edge_refuses_an_unsigned_model_counts_it_and_forecasts_with_constant_velocity() {
    let (rest, notices) = over_tcp(Some(random_blob(&Dims::DEFAULT, Precision::Int8, 0.05)), None);
    assert_eq!(
        notices,
        [Notice::Forecasting(Forecaster::ConstantVelocity), Notice::ModelRefused(ModelRefusal::Unsigned)],
        "the host is told why its model was refused"
    );
    let id: String = dynotraj_edge::provisioned::MODEL_KEY[..8].iter().map(|b| format!("{b:02x}")).collect();
    assert!(
        rest.iter().any(|l| l.contains(&format!("must be signed by key {id}"))),
        "edge names the key it trusts: {rest:?}"
    );
    assert!(
        rest.iter().any(|l| l.contains("model refused: the model is not signed")
            && l.contains("(unsigned 1 bad signature 0)")),
        "{rest:?}"
    );
}

#[test]
fn tcp_edge_matches_the_in_process_edge_with_constant_velocity() {
    run_over_tcp(None);
}

#[test]
fn tcp_edge_matches_the_in_process_edge_with_a_model_sent_over_the_link() {
    run_over_tcp(Some(random_blob(&Dims::DEFAULT, Precision::Int8, 0.05)));
}

/// `dynotraj forecast` (the session in process) writes the forecasts `dynotraj stream` collects
/// from a `dynotraj-edge` process given the same signed model, byte for byte.
#[test]
fn forecast_in_process_writes_what_the_tcp_edge_answers() {
    if !dynotraj_edge::provisioned::MODEL_KEY_IS_DEVELOPMENT {
        dynotraj_testkit::skipped(
            "forecast_in_process_writes_what_the_tcp_edge_answers",
            "the edge was built with DYNOTRAJ_MODEL_PUBKEY; this test signs with the development key",
        );
        return;
    }
    use clap::Parser as _;
    let dir = tempfile::tempdir().unwrap();
    let tracks = scene_tracks(10);
    let dtt = dir.path().join("scene.dtt");
    let mut w = dynotraj_formats::tracks_file::TracksWriter::create(&dtt, &tracks.camera).unwrap();
    for f in &tracks.frames {
        let all: Vec<_> = f.tracks().copied().collect();
        w.write_frame(f.frame, f.timestamp_us, &all).unwrap();
    }
    w.finish().unwrap();
    let blob = random_blob(&Dims::DEFAULT, Precision::Int8, 0.05);
    let signed = sign(&blob, &development_signing_key().unwrap());
    let model = dir.path().join("model.signed");
    std::fs::write(&model, &signed).unwrap();

    let out = dir.path().join("forecast");
    let args = ["dynotraj", "forecast", "--tracks", dtt.to_str().unwrap(), "--model", model.to_str().unwrap()];
    let cli = dynotraj_cli::Cli::try_parse_from(args.into_iter().chain(["--out", out.to_str().unwrap()])).unwrap();
    dynotraj_cli::run(cli).unwrap();
    let in_process = std::fs::read_to_string(out.join("forecasts.csv")).unwrap();

    let (mut edge, lines, addr) = spawn_listening_edge(&["--listen", "tcp://127.0.0.1:0", "--sessions", "1"]);
    let (rx, tx) = connect(&Endpoint::Tcp(addr), Duration::from_secs(10)).unwrap();
    let opt = StreamOptions { lockstep: true, model: Some(signed), ..StreamOptions::default() };
    let result = stream(&tracks, rx, tx, &opt);
    let rest: Vec<String> = lines.map_while(Result::ok).collect();
    assert!(edge.wait().unwrap().success(), "edge failed: {rest:?}");
    let streamed = dir.path().join("stream");
    dynotraj_eval::report::write_table_files(
        &streamed,
        "forecasts",
        &dynotraj_eval::report::stream_report::predictions_data(&result),
    )
    .unwrap();
    let over_tcp = std::fs::read_to_string(streamed.join("forecasts.csv")).unwrap();
    assert!(in_process.lines().count() > 16 * 5 * 30, "the cars are forecast: {} rows", in_process.lines().count());
    assert_eq!(in_process, over_tcp, "forecast and stream wrote different forecasts");
}
