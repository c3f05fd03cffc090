//! A fixture stream for the edge tests: the estimator benchmark's scene (16 cars around a
//! moving camera, 256 static tracks, 128 points per car) through the track simulator, and the
//! host build of the edge run in process as the reference.

use std::convert::Infallible;
use std::path::PathBuf;

use dynotraj_core::estimate::Intrinsics;
use dynotraj_core::limits::PAPER_FRAME_RATE_HZ;
use dynotraj_core::wire::{FrameBuf, FrameDecoder, LinkStats, MAX_FRAME_LEN, Message, encode, model_chunks};
use dynotraj_edge::{NoClock, Session, Transport};
use dynotraj_formats::tracks_file::{Tracks, TracksFrame};
use dynotraj_sim::track_sim::{SimSpec, simulate};
use dynotraj_sources::estimation::cost::scene;
use dynotraj_sources::estimation::input::KITTI_IMAGE_SIZE;

/// `frames` frames of the 16-car scene at the paper's 20 Hz.
#[must_use]
pub fn scene_tracks(frames: usize) -> Tracks {
    tracks_of(scene(frames))
}

/// `frames` frames of the same scene with every other car a pedestrian (8 of each).
#[must_use]
pub fn mixed_scene_tracks(frames: usize) -> Tracks {
    tracks_of(dynotraj_sim::cost_inputs::mixed_agents_scene(frames))
}

/// The track simulator's stream of a scene at the paper's 20 Hz.
fn tracks_of((cams, boxes): (Vec<nalgebra::Isometry3<f64>>, Vec<dynotraj_sim::track_sim::LabelBox>)) -> Tracks {
    let i = Intrinsics::KITTI_0926;
    let dt = 1.0 / f64::from(PAPER_FRAME_RATE_HZ);
    let sim = simulate(&cams, &boxes, &SimSpec::kitti(i, KITTI_IMAGE_SIZE, dt, 3));
    let camera = dynotraj_sources::estimation::simulated::camera_info(&i, PAPER_FRAME_RATE_HZ);
    let frames = sim.iter().map(|f| TracksFrame::split(f.frame, f.timestamp_us, &f.tracks).unwrap()).collect();
    Tracks { camera, frames }
}

/// The host's messages for `tracks` as `dynotraj stream` sends them: camera, model chunks,
/// every frame's parts, goodbye.
#[must_use]
pub fn host_messages(tracks: &Tracks, model: Option<&[u8]>) -> Vec<Message> {
    let mut out = vec![Message::CameraInfo(tracks.camera)];
    if let Some(blob) = model {
        out.extend(model_chunks(blob).unwrap().map(Message::ModelChunk));
    }
    for f in &tracks.frames {
        out.extend(f.parts.iter().cloned().map(Message::FrameTracks));
    }
    out.push(Message::LinkStats(LinkStats::default()));
    out
}

/// Encodes messages into one byte stream.
#[must_use]
pub fn encode_all(messages: &[Message]) -> Vec<u8> {
    let mut bytes = Vec::new();
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    for m in messages {
        let n = encode(m, &mut buf).unwrap();
        bytes.extend_from_slice(&buf[..n]);
    }
    bytes
}

/// Decodes a byte stream into messages.
#[must_use]
pub fn decode_all(bytes: &[u8]) -> Vec<Message> {
    FrameDecoder::new().feed(bytes).collect()
}

/// An in-memory link: reads `input` in chunks of `chunk` bytes, collects what is written.
pub struct MemLink<'a> {
    /// Bytes not read yet.
    pub input: &'a [u8],
    /// Largest read.
    pub chunk: usize,
    /// Everything written.
    pub output: Vec<u8>,
}

impl embedded_io::ErrorType for MemLink<'_> {
    type Error = Infallible;
}

impl embedded_io::Read for MemLink<'_> {
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = self.input.len().min(buf.len()).min(self.chunk);
        buf[..n].copy_from_slice(&self.input[..n]);
        self.input = &self.input[n..];
        Ok(n)
    }
}

impl embedded_io::Write for MemLink<'_> {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Infallible> {
        self.output.extend_from_slice(bytes);
        Ok(bytes.len())
    }
    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl Transport for MemLink<'_> {}

/// What the host build of the edge answers to `stream`, run in process (the reference).
#[must_use]
pub fn reference_replies(stream: &[u8], models: &[&[u8]]) -> Vec<Message> {
    run_in_process(stream, models).replies
}

/// An in-process session's answers and where its model load ended.
#[derive(Debug)]
pub struct InProcess {
    /// Every message the edge sent.
    pub replies: Vec<Message>,
    /// The session's model at the end.
    pub model: dynotraj_edge::ModelStatus,
    /// The model load's counters.
    pub load: dynotraj_edge::LoadStats,
}

/// Runs the host build of the edge in process on `stream`: with `models` linked in (one per
/// agent type), or else (none) loading them from the stream (signed by the provisioned key).
#[must_use]
pub fn run_in_process(stream: &[u8], models: &[&[u8]]) -> InProcess {
    let mut buffer = vec![0u8; 512 * 1024];
    let mut session: Box<Session<'_>> = Box::new(if models.is_empty() {
        Session::with_model_buffer(&mut buffer, dynotraj_edge::provisioned::MODEL_KEY)
    } else {
        Session::with_models(models).unwrap()
    });
    let mut link = MemLink { input: stream, chunk: 256, output: Vec::new() };
    session.run(&mut link, &mut NoClock).unwrap();
    InProcess { replies: decode_all(&link.output), model: session.model(), load: session.load_stats() }
}

/// The estimates and forecasts among `replies`, each as its encoded frame: comparing these
/// compares every bit of every float.
#[must_use]
pub fn outputs(replies: &[Message]) -> Vec<Vec<u8>> {
    let mut buf: FrameBuf = [0; MAX_FRAME_LEN];
    replies
        .iter()
        .filter(|m| matches!(m, Message::ObjectStates(_) | Message::Prediction(_)))
        .map(|m| {
            let n = encode(m, &mut buf).unwrap();
            buf[..n].to_vec()
        })
        .collect()
}

/// The host build of the edge, `dynotraj-edge`, beside the test binaries: `cargo test
/// --workspace` builds it (the edge package has integration tests, so its binary is built).
#[must_use]
pub fn edge_binary() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let path = exe.parent().unwrap().parent().unwrap().join("dynotraj-edge");
    assert!(
        path.exists(),
        "{} is missing: run `cargo build -p dynotraj-edge` (cargo test --workspace builds it)",
        path.display()
    );
    path
}

/// The `dynotraj` command beside the test binaries (`cargo test --workspace` builds it), on
/// one rayon thread as the scripts run it.
///
/// # Panics
/// When the binary is missing.
#[must_use]
pub fn dynotraj_command() -> std::process::Command {
    let exe = std::env::current_exe().unwrap();
    let path = exe.parent().unwrap().parent().unwrap().join("dynotraj");
    assert!(path.exists(), "{} is missing: run `cargo build -p dynotraj-cli`", path.display());
    let mut cmd = std::process::Command::new(path);
    cmd.env("RAYON_NUM_THREADS", "1");
    cmd
}

/// Writes `tracks` as a tracks file (.dtt) at `path`, as `dynotraj track` would.
///
/// # Panics
/// On a write error.
pub fn write_tracks_file(tracks: &Tracks, path: &std::path::Path) {
    let mut w = dynotraj_formats::tracks_file::TracksWriter::create(path, &tracks.camera).unwrap();
    for f in &tracks.frames {
        w.write_frame(f.frame, f.timestamp_us, &f.tracks().copied().collect::<Vec<_>>()).unwrap();
    }
    w.finish().unwrap();
}

/// The host build of the edge started with `args` (a `--listen` among them), its stderr piped:
/// the child, the rest of its stderr lines, and the address it listens on (`HOST:PORT`, from
/// its first line).
///
/// # Panics
/// When the edge cannot start or does not say where it listens.
pub fn spawn_listening_edge(
    args: &[&str],
) -> (std::process::Child, std::io::Lines<std::io::BufReader<std::process::ChildStderr>>, String) {
    use std::io::BufRead as _;
    let mut edge =
        std::process::Command::new(edge_binary()).args(args).stderr(std::process::Stdio::piped()).spawn().unwrap();
    let mut lines = std::io::BufReader::new(edge.stderr.take().unwrap()).lines();
    let first = lines.next().unwrap().unwrap();
    let addr = first.rsplit("tcp://").next().unwrap().to_string();
    (edge, lines, addr)
}

/// The firmware image: `$DYNOTRAJ_FIRMWARE`, else where `scripts/build-firmware.sh` puts it in
/// the same build cache as the tests.
#[must_use]
pub fn firmware_elf() -> PathBuf {
    std::env::var_os("DYNOTRAJ_FIRMWARE")
        .map_or_else(|| firmware_program("dynotraj-firmware"), |p| checked_elf(p.into()))
}

/// The firmware crate's program `name` (`dynotraj-firmware`, `dynotraj-kernels`) where
/// `scripts/build-firmware.sh` puts it in the same build cache as the tests.
#[must_use]
pub fn firmware_program(name: &str) -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    let release = exe.parent().unwrap().parent().unwrap().parent().unwrap().join("thumbv7em-none-eabihf/release");
    checked_elf(release.join(name))
}

fn checked_elf(path: PathBuf) -> PathBuf {
    assert!(
        path.exists(),
        "{} is missing: run `bash scripts/build-firmware.sh` (scripts/test.sh does)",
        path.display()
    );
    path
}

/// The int8 model blob of the default widths that `scripts/build-firmware.sh` links into the
/// `dynotraj-firmware-model` image for vehicles.
#[must_use]
pub fn default_model_blob() -> PathBuf {
    crate::manifest_dir().join("../sim/data/models/default-dims.int8")
}

/// Its twin for pedestrians (single integrator), linked into the same image.
#[must_use]
pub fn default_pedestrian_model_blob() -> PathBuf {
    crate::manifest_dir().join("../sim/data/models/default-dims-pedestrian.int8")
}

/// A free loopback port (free when this returns; QEMU binds it right after).
#[must_use]
pub fn free_port() -> u16 {
    std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port()
}

/// The firmware under QEMU via `scripts/qemu-edge.sh`, its UART0 on `port`, logs piped.
#[must_use]
pub fn spawn_qemu(port: u16) -> std::process::Child {
    spawn_qemu_elf(port, &firmware_elf())
}

/// The firmware image `elf` under QEMU, as [`spawn_qemu`].
#[must_use]
pub fn spawn_qemu_elf(port: u16, elf: &std::path::Path) -> std::process::Child {
    let script = crate::manifest_dir().join("../scripts/qemu-edge.sh");
    std::process::Command::new("bash")
        .arg(script)
        .args(["--port", &port.to_string(), "--elf"])
        .arg(elf)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap()
}

/// Waits for the firmware under QEMU to exit, at most `limit` (QEMU's own wall time, so
/// generous): a firmware that hangs is killed and fails the test with its logs instead of
/// holding the run until CI's limit (`scripts/qemu-edge.sh` execs QEMU, so the child is QEMU).
///
/// # Panics
/// When QEMU has not exited within `limit`.
pub fn wait_for_firmware(qemu: &mut std::process::Child, limit: std::time::Duration) -> std::process::ExitStatus {
    let start = std::time::Instant::now();
    loop {
        if let Some(status) = qemu.try_wait().unwrap() {
            return status;
        }
        if start.elapsed() > limit {
            qemu.kill().ok();
            qemu.wait().ok();
            let mut log = String::new();
            if let Some(mut out) = qemu.stdout.take() {
                std::io::Read::read_to_string(&mut out, &mut log).ok();
            }
            panic!("the firmware did not exit within {limit:?} after the stream ended (killed); its log:\n{log}");
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// Sizes of the named sections of a 32-bit little-endian ELF file (the firmware).
#[must_use]
pub fn elf_sections(path: &std::path::Path) -> Vec<(String, u32)> {
    let b = std::fs::read(path).unwrap();
    let u16_at = |o: usize| u16::from_le_bytes([b[o], b[o + 1]]) as usize;
    let u32_at = |o: usize| u32::from_le_bytes([b[o], b[o + 1], b[o + 2], b[o + 3]]);
    assert_eq!(&b[..5], b"\x7fELF\x01", "a 32-bit ELF");
    let (shoff, shentsize, shnum, shstrndx) = (u32_at(0x20) as usize, u16_at(0x2E), u16_at(0x30), u16_at(0x32));
    let header = |i: usize| shoff + i * shentsize;
    let strtab = u32_at(header(shstrndx) + 16) as usize;
    (0..shnum)
        .map(|i| {
            let h = header(i);
            let name_at = strtab + u32_at(h) as usize;
            let end = b[name_at..].iter().position(|&c| c == 0).unwrap();
            (String::from_utf8_lossy(&b[name_at..name_at + end]).into_owned(), u32_at(h + 20))
        })
        .collect()
}

/// Streams `tracks` in lockstep to the firmware image `elf` under QEMU and waits for it to
/// exit: what the host received, the firmware's exit status and its log (also printed).
#[must_use]
pub fn stream_to_qemu(
    elf: &std::path::Path,
    tracks: &Tracks,
) -> (dynotraj_link::stream::StreamResult, std::process::ExitStatus, String) {
    use std::io::Read as _;
    use std::time::Duration;

    use dynotraj_link::endpoint::{Endpoint, connect};
    use dynotraj_link::stream::{StreamOptions, stream};

    let port = free_port();
    let mut qemu = spawn_qemu_elf(port, elf);
    let (rx, tx) = connect(&Endpoint::Tcp(format!("127.0.0.1:{port}")), Duration::from_secs(20)).unwrap();
    let opt = StreamOptions { lockstep: true, reply_timeout: Duration::from_secs(60), ..StreamOptions::default() };
    let result = stream(tracks, rx, tx, &opt);
    let status = wait_for_firmware(&mut qemu, Duration::from_secs(120));
    let mut log = String::new();
    qemu.stdout.take().unwrap().read_to_string(&mut log).unwrap();
    qemu.stderr.take().unwrap().read_to_string(&mut log).unwrap();
    println!("{log}");
    (result, status, log)
}
