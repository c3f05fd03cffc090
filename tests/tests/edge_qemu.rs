//! The firmware under QEMU (Cortex-M4F, mps2-an386), fed over its UART0 by the host's
//! streaming client: its estimates and forecasts for a 16-car fixture stream, and for the same
//! scene with 8 of the cars pedestrians (each agent type on its own model), are equal, bit for
//! bit, to what the host build of the edge computes from the same stream. The same run checks
//! the image against the ECU budgets of docs/architecture.md (flash <= 512 KiB; .data + .bss + the peak
//! stack measured by painting <= 128 KiB) and against the golden figures in
//! `edge/firmware/memory.golden` (`DYNOTRAJ_BLESS=1` rewrites them after a deliberate change),
//! and reports the instructions per frame (QEMU -icount) against 20 frames/s at 200 MHz, and
//! checks that the firmware's logger prints the edge's session totals.

use std::path::Path;

use dynotraj_core::wire::{ComputeUnit, Message};
use dynotraj_formats::tracks_file::Tracks;
use dynotraj_tests::edge_fixture::{
    default_model_blob, default_pedestrian_model_blob, encode_all, firmware_elf, firmware_program, host_messages,
    mixed_scene_tracks, outputs, reference_replies, scene_tracks, stream_to_qemu,
};
use dynotraj_tests::firmware_memory::{KIB, check_memory};

#[test]
fn firmware_under_qemu_matches_the_host_edge_bit_for_bit() {
    // A firmware built with DYNOTRAJ_FW_MODEL=BLOB is compared with the host edge running BLOB:
    // name the same file in DYNOTRAJ_FIRMWARE_MODEL (and the image in DYNOTRAJ_FIRMWARE).
    let model = std::env::var_os("DYNOTRAJ_FIRMWARE_MODEL").map(|p| std::fs::read(p).unwrap());
    let log = run_and_compare(&firmware_elf(), &scene_tracks(frames()), model.as_slice().iter().map(Vec::as_slice));
    let ram = check_memory(&firmware_elf(), &log, model.is_none().then_some("memory.golden"));
    assert!(ram <= 128 * KIB, "RAM {ram} B (.data + .bss + peak stack) over the 128 KiB budget");
}

/// The default models (sim/data/models: seeded weights, the memory and arithmetic of trained
/// models of those widths), vehicles' and pedestrians'.
fn default_models() -> [Vec<u8>; 2] {
    [default_model_blob(), default_pedestrian_model_blob()].map(|p| std::fs::read(p).unwrap())
}

/// The image `scripts/build-firmware.sh` builds with the default models linked in: it forecasts
/// the cars with the vehicles' model, bit for bit as the host edge does, and leaves at least
/// 13.5 KiB of the 128 KiB of RAM free (16 KiB before each object's last forecast was kept for
/// consistent forecasts, 2.2 KiB, and a model slot per agent type, 0.4 KiB; docs/decisions.md).
#[test]
fn firmware_with_the_default_models_matches_the_host_edge_and_leaves_13_kib_of_ram() {
    let elf = firmware_program("dynotraj-firmware-model");
    let models = default_models();
    let log = run_and_compare(&elf, &scene_tracks(frames()), models.iter().map(Vec::as_slice));
    assert!(log.contains("model linked in (int8)"), "the image runs its linked model: {log}");
    let ram = check_memory(&elf, &log, Some("memory-model.golden"));
    assert!(ram <= RAM_WITH_MODELS, "RAM {ram} B: less than 13.5 KiB of the 128 KiB left with the models linked in");
}

/// The same image on a frame of both agent types, 8 cars and 8 pedestrians, each on its own
/// model: bit for bit as the host edge, within the same RAM; its instructions per frame are
/// printed beside the cars-only figure.
#[test]
fn firmware_forecasts_a_mixed_frame_with_a_model_per_agent_type() {
    let elf = firmware_program("dynotraj-firmware-model");
    let models = default_models();
    let tracks = mixed_scene_tracks(frames());
    let log = run_and_compare(&elf, &tracks, models.iter().map(Vec::as_slice));
    let ram = check_memory(&elf, &log, None);
    assert!(ram <= RAM_WITH_MODELS, "RAM {ram} B on a mixed frame: less than 13.5 KiB of the 128 KiB left");
    // The pedestrians' model is the one that forecasts them: without it they get other answers.
    let cars_only = reference_replies(&encode_all(&host_messages(&tracks, None)), &[&models[0]]);
    let both = reference_replies(&encode_all(&host_messages(&tracks, None)), &[&models[0], &models[1]]);
    assert_ne!(outputs(&cars_only), outputs(&both), "the pedestrian model changes the pedestrians' forecasts");
}

/// Frames streamed: 24 (the compute figure is taken from frame STEADY_FROM on, once the windows
/// have filled); DYNOTRAJ_QEMU_FRAMES streams more.
fn frames() -> usize {
    std::env::var("DYNOTRAJ_QEMU_FRAMES").ok().and_then(|v| v.parse().ok()).unwrap_or(24).max(STEADY_FROM + 2)
}

/// Streams `tracks` to the firmware `elf` under QEMU in lockstep and checks its answers against
/// the host edge's (with `models` linked in); prints the compute per frame and returns the
/// firmware's log.
fn run_and_compare<'a>(elf: &Path, tracks: &Tracks, models: impl Iterator<Item = &'a [u8]>) -> String {
    let frames = tracks.frames.len();
    let models: Vec<&[u8]> = models.collect();
    let reference = reference_replies(&encode_all(&host_messages(tracks, None)), &models);

    let (result, status, log) = stream_to_qemu(elf, tracks);
    assert!(status.success(), "firmware exit {status}: {log}");

    let forecasts = result.replies.iter().filter(|m| matches!(m, Message::Prediction(_))).count();
    assert!(forecasts >= 16 * 5, "the firmware forecasts the 16 objects ({forecasts})");
    assert_eq!(outputs(&result.replies), outputs(&reference), "firmware answers differ from the host edge");
    for f in &result.frames {
        let s = f.stats.expect("every frame answered");
        assert_eq!((s.frames_lost, s.bytes_dropped, s.unit), (0, 0, ComputeUnit::Instructions));
        assert!(s.compute > 0, "frame {} compute measured", f.frame);
    }
    let compute: Vec<u32> = result.frames.iter().map(|f| f.stats.unwrap().compute).collect();
    println!("compute per frame (instructions): {compute:?}");
    let mut steady = compute[STEADY_FROM..].to_vec();
    steady.sort_unstable();
    let median = steady[steady.len() / 2];
    let budget = 200_000_000 / 20;
    println!(
        "16-object frame (frames {STEADY_FROM}-{}): median {median} instructions, max {} (budget at 20 frames/s on \
            200 MHz: {budget} cycles; {:.2}x)",
        compute.len() - 1,
        steady.last().unwrap(),
        f64::from(median) / f64::from(budget)
    );
    // The images log at info (the firmware's `log-info` feature); another one named in
    // DYNOTRAJ_FIRMWARE may log at another level.
    if std::env::var_os("DYNOTRAJ_FIRMWARE").is_none() {
        check_log_lines(&log, frames);
    }
    log
}

/// The firmware's logger prints `LEVEL INSTRUCTIONS CRATE: MESSAGE`, the edge's session totals
/// among them.
fn check_log_lines(log: &str, frames: usize) {
    let end = log
        .lines()
        .find(|l| l.contains(" edge: session end: "))
        .unwrap_or_else(|| panic!("the edge logs its session totals: {log}"));
    let mut fields = end.splitn(3, ' ');
    assert_eq!(fields.next(), Some("I"), "at info level: {end}");
    assert!(fields.next().is_some_and(|t| t.parse::<u64>().is_ok()), "an instruction-clock timestamp: {end}");
    let message = fields.next().unwrap_or_default();
    assert!(message.starts_with(&format!("edge: session end: frames {frames} lost 0 |")), "{end}");
    assert!(!log.lines().any(|l| l.starts_with("D ")), "nothing at debug level in the default image: {log}");
}

/// The most RAM the image with the default models may take: 13.5 KiB of the 128 KiB left for
/// what the next change needs.
const RAM_WITH_MODELS: u32 = 114 * KIB + KIB / 2;

/// First frame of the compute figure: after the edge's smoothing window (8 frames) and the
/// forecast histories have filled (measured over 40 frames: the cost rises until about frame 12
/// and stays within 2% from there on).
const STEADY_FROM: usize = 12;
