//! The ABI called as C calls it, from Rust: statuses, replies, layout against the header.

use core::mem::MaybeUninit;
use std::boxed::Box;
use std::vec::Vec;

use dynotraj_core::wire::{
    CameraInfo, ComputeUnit, Forecaster, FrameBuf, FrameDecoder, LinkStats, MAX_FRAME_LEN, Message, Notice, encode,
    frame_parts,
};

use super::*;

/// Appends each frame to the `Vec<u8>` behind `ctx`.
unsafe extern "C" fn collect(ctx: *mut c_void, frame: *const u8, len: usize) -> i32 {
    // SAFETY: the tests pass a live Vec<u8> as ctx; the session passes a valid frame.
    unsafe { (*ctx.cast::<Vec<u8>>()).extend_from_slice(core::slice::from_raw_parts(frame, len)) };
    0
}

/// A link that is down.
unsafe extern "C" fn refuse(_: *mut c_void, _: *const u8, _: usize) -> i32 {
    -1
}

/// A counter that advances by one per read.
unsafe extern "C" fn tick(ctx: *mut c_void) -> u64 {
    // SAFETY: the tests pass a live u64 as ctx.
    let n = unsafe { &mut *ctx.cast::<u64>() };
    *n += 1;
    *n
}

fn wire(messages: &[Message]) -> Vec<u8> {
    let mut out = Vec::new();
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    for m in messages {
        let n = encode(m, &mut buf).unwrap();
        out.extend_from_slice(&buf[..n]);
    }
    out
}

fn camera() -> Message {
    Message::CameraInfo(CameraInfo {
        fx: 721.5,
        fy: 721.5,
        cx: 609.6,
        cy: 172.9,
        stereo_fb: 387.6,
        width: 1242,
        height: 375,
        frame_rate_hz: 20.0,
    })
}

fn goodbye() -> Message {
    Message::LinkStats(LinkStats::default())
}

/// A session's memory, its configuration, and where its replies go.
struct Harness {
    memory: Box<MaybeUninit<DynotrajSession>>,
    /// Boxed: the write callback's context, whose address must not move with the harness.
    #[allow(clippy::box_collection)]
    replies: Box<Vec<u8>>,
    ticks: Box<u64>,
}

impl Harness {
    fn new() -> Self {
        Self { memory: Box::new_uninit(), replies: Box::default(), ticks: Box::default() }
    }

    fn session(&mut self) -> *mut DynotrajSession {
        self.memory.as_mut_ptr()
    }

    fn config(&mut self) -> DynotrajConfig {
        DynotrajConfig {
            write: Some(collect),
            write_ctx: (&raw mut *self.replies).cast(),
            clock: None,
            clock_ctx: core::ptr::null_mut(),
            clock_unit: DYNOTRAJ_UNIT_NANOSECONDS,
        }
    }

    fn init(&mut self, config: &DynotrajConfig) -> DynotrajStatus {
        // SAFETY: memory for one session, a live configuration whose contexts outlive the session.
        unsafe { dynotraj_session_init(self.session(), config) }
    }

    fn feed(&mut self, bytes: &[u8]) -> DynotrajStatus {
        // SAFETY: an initialised session, a live slice.
        unsafe { dynotraj_session_feed(self.session(), bytes.as_ptr(), bytes.len(), 0) }
    }

    fn finish(&mut self) -> DynotrajStatus {
        // SAFETY: an initialised session.
        unsafe { dynotraj_session_finish(self.session()) }
    }

    fn messages(&self) -> Vec<Message> {
        FrameDecoder::new().feed(&self.replies).collect()
    }
}

#[test]
fn a_camera_model_split_across_calls_is_answered_with_one_frame() {
    let mut h = Harness::new();
    let config = h.config();
    assert_eq!(h.init(&config), DynotrajStatus::Ok);
    let bytes = wire(&[camera()]);
    let (a, b) = bytes.split_at(bytes.len() / 2);
    assert_eq!(h.feed(a), DynotrajStatus::Ok);
    assert!(h.replies.is_empty(), "no reply to half a frame");
    assert_eq!(h.feed(b), DynotrajStatus::Ok);
    assert_eq!(h.messages(), [Message::Notice(Notice::Forecasting(Forecaster::ConstantVelocity))]);
    assert_eq!(*h.replies, wire(&h.messages()), "the callback gets whole encoded frames");
}

#[test]
fn goodbye_ends_the_session_and_finish_sends_the_link_statistics() {
    let mut h = Harness::new();
    let config = h.config();
    assert_eq!(h.init(&config), DynotrajStatus::Ok);
    assert_eq!(h.feed(&wire(&[camera(), goodbye(), camera()])), DynotrajStatus::Ended);
    assert_eq!(h.feed(&wire(&[camera()])), DynotrajStatus::Ended, "nothing is taken after goodbye");
    assert_eq!(h.finish(), DynotrajStatus::Ok);
    let replies = h.messages();
    assert_eq!(replies.len(), 2, "{replies:?}");
    let Message::LinkStats(stats) = replies[1] else { panic!("{replies:?}") };
    assert_eq!((stats.frames_sent, stats.received.frames_ok), (1, 2));
}

#[test]
fn finish_without_goodbye_counts_an_unfinished_frame_as_dropped() {
    let mut h = Harness::new();
    let config = h.config();
    assert_eq!(h.init(&config), DynotrajStatus::Ok);
    let bytes = wire(&[camera()]);
    assert_eq!(h.feed(&bytes[..bytes.len() - 1]), DynotrajStatus::Ok);
    assert_eq!(h.finish(), DynotrajStatus::Ok);
    let Some(Message::LinkStats(stats)) = h.messages().pop() else { panic!() };
    // The frame less its closing delimiter, which never came, and its opening one, which the
    // decoder takes as the end of the (empty) frame before it.
    assert_eq!(stats.received.bytes_discarded as usize, bytes.len() - 2);
}

#[test]
fn the_callers_clock_and_unit_reach_the_frame_statistics() {
    let mut h = Harness::new();
    let mut config = h.config();
    config.clock = Some(tick);
    config.clock_ctx = (&raw mut *h.ticks).cast();
    config.clock_unit = DYNOTRAJ_UNIT_INSTRUCTIONS;
    assert_eq!(h.init(&config), DynotrajStatus::Ok);
    let parts = frame_parts(0, 0, &[]).unwrap().map(Message::FrameTracks);
    let messages: Vec<Message> = core::iter::once(camera()).chain(parts).collect();
    assert_eq!(h.feed(&wire(&messages)), DynotrajStatus::Ok);
    let stats: Vec<_> =
        h.messages().into_iter().filter_map(|m| if let Message::FrameStats(s) = m { Some(s) } else { None }).collect();
    assert_eq!(stats.len(), 1, "one frame estimated");
    assert_eq!(stats[0].unit, ComputeUnit::Instructions);
    assert!(stats[0].compute > 0, "the clock advanced during the frame");
    assert!(*h.ticks >= 2, "the clock was read");
}

#[test]
fn a_failing_write_is_reported_and_the_session_goes_on() {
    let mut h = Harness::new();
    let mut config = h.config();
    config.write = Some(refuse);
    assert_eq!(h.init(&config), DynotrajStatus::Ok);
    assert_eq!(h.feed(&wire(&[camera()])), DynotrajStatus::WriteFailed);
    assert_eq!(h.feed(&wire(&[goodbye()])), DynotrajStatus::Ended);
    assert_eq!(h.finish(), DynotrajStatus::WriteFailed);
}

#[test]
fn bad_pointers_and_arguments_are_refused_with_a_status() {
    let mut h = Harness::new();
    let config = h.config();
    let null_session = core::ptr::null_mut();
    // SAFETY: in every call below null or misaligned pointers are checked before any access;
    // the others point to live memory.
    unsafe {
        assert_eq!(dynotraj_session_init(null_session, &config), DynotrajStatus::NullPointer);
        assert_eq!(dynotraj_session_init(h.session(), core::ptr::null()), DynotrajStatus::NullPointer);
        let misaligned = h.session().cast::<u8>().add(1).cast::<DynotrajSession>();
        assert_eq!(dynotraj_session_init(misaligned, &config), DynotrajStatus::Misaligned);
        assert_eq!(
            dynotraj_session_init(h.session(), &DynotrajConfig { write: None, ..config }),
            DynotrajStatus::NullPointer
        );
        assert_eq!(
            dynotraj_session_init(h.session(), &DynotrajConfig { clock_unit: 2, ..config }),
            DynotrajStatus::InvalidArgument
        );
        assert_eq!(dynotraj_session_feed(null_session, [0u8].as_ptr(), 1, 0), DynotrajStatus::NullPointer);
        assert_eq!(dynotraj_session_finish(null_session), DynotrajStatus::NullPointer);
        assert_eq!(dynotraj_session_set_model(null_session, [0u8].as_ptr(), 1), DynotrajStatus::NullPointer);

        assert_eq!(h.init(&config), DynotrajStatus::Ok);
        assert_eq!(dynotraj_session_feed(h.session(), core::ptr::null(), 5, 0), DynotrajStatus::NullPointer);
        assert_eq!(dynotraj_session_feed(h.session(), core::ptr::null(), 0, 0), DynotrajStatus::Ok);
        assert_eq!(dynotraj_session_feed(h.session(), [0u8].as_ptr(), usize::MAX, 0), DynotrajStatus::InvalidArgument);
        assert_eq!(dynotraj_session_set_model(h.session(), core::ptr::null(), 4), DynotrajStatus::NullPointer);
        static NOT_A_MODEL: [u8; 64] = [0x5a; 64];
        assert_eq!(dynotraj_session_set_model(h.session(), NOT_A_MODEL.as_ptr(), 64), DynotrajStatus::InvalidModel);
    }
    assert!(h.replies.is_empty(), "refused calls reply nothing");
}

/// The figures the committed header gives C for this build's pointer width.
#[test]
fn the_header_states_this_builds_session_layout() {
    let header = include_str!("../include/dynotraj.h");
    let guard = if cfg!(target_pointer_width = "64") { "DYNOTRAJ_POINTER_64" } else { "DYNOTRAJ_POINTER_32" };
    let define = |name: &str, after: &str| -> usize {
        let from = header.find(after).unwrap_or_else(|| panic!("{after} in the header"));
        let line = header[from..]
            .lines()
            .find_map(|l| l.trim().strip_prefix(&std::format!("#define {name} ")))
            .unwrap_or_else(|| panic!("#define {name} after {after}"));
        line.trim().parse().unwrap()
    };
    let size = define("DYNOTRAJ_SESSION_SIZE", &std::format!("#if defined({guard})"));
    let align = define("DYNOTRAJ_SESSION_ALIGN", "");
    assert_eq!(size, core::mem::size_of::<DynotrajSession>(), "header size for {guard}");
    assert_eq!(align, core::mem::align_of::<DynotrajSession>(), "header alignment");
}

#[test]
fn a_model_blob_is_taken_and_a_bad_one_leaves_it_in_use() {
    use dynotraj_core::model::Dims;
    use dynotraj_core::model::blob::{Precision, write_blob};
    let dims = Dims { enc: 4, edge: 3, k: 2, dec: 5 };
    let weights: Vec<Vec<f32>> = dims
        .tensors()
        .into_iter()
        .enumerate()
        .map(|(t, (rows, cols))| (0..rows * cols).map(|j| ((t * 31 + j) as f32).sin() * 0.5).collect())
        .collect();
    let tensors: Vec<&[f32]> = weights.iter().map(Vec::as_slice).collect();
    let mut blob = std::vec![0u8; 1 << 16];
    let len =
        write_blob(&dims, Precision::Int8, 0.05, &dynotraj_core::predict::PriorSettings::DEFAULT, &tensors, &mut blob)
            .unwrap();
    let model = Notice::Forecasting(Forecaster::Model { len: u32::try_from(len).unwrap() });

    let mut h = Harness::new();
    let config = h.config();
    assert_eq!(h.init(&config), DynotrajStatus::Ok);
    // SAFETY: an initialised session; `blob` outlives it and is not changed meanwhile.
    unsafe {
        assert_eq!(dynotraj_session_set_model(h.session(), blob.as_ptr(), len), DynotrajStatus::Ok);
        assert_eq!(dynotraj_session_set_model(h.session(), blob.as_ptr(), len - 1), DynotrajStatus::InvalidModel);
    }
    assert_eq!(h.feed(&wire(&[camera()])), DynotrajStatus::Ok);
    assert_eq!(h.messages(), [Message::Notice(model)]);
}
