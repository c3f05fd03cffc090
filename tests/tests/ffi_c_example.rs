//! The C example (ffi/examples/c) linked against the ffi staticlib, on the host (cc) and on a
//! Cortex-M4F under QEMU mps2-an386 (arm-none-eabi-gcc + newlib): fed the 16-car fixture
//! stream, each writes exactly the bytes the Rust edge answers to it, every reply frame of the
//! session in order (notice, estimates, forecasts, frame statistics, link statistics).
//!
//! The replies include each frame's compute figure, which comes from a clock: the C example
//! passes none, so it reports zero compute in nanoseconds, as the reference's `NoClock` does.
//! Both sides read the stream in 256-byte chunks. The test builds the staticlibs itself
//! (`cargo build -p dynotraj-ffi --release`, and `--target thumbv7em-none-eabihf`), so it never
//! runs a stale one.

use std::io::Read as _;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::time::Duration;

use dynotraj_core::wire::Message;
use dynotraj_tests::edge_fixture::{
    decode_all, encode_all, host_messages, reference_replies, scene_tracks, wait_for_firmware,
};

/// Camera frames in the stream: past the edge's 8-frame window, so smoothed estimates and
/// forecasts of every car are among the replies.
const FRAMES: usize = 16;

const MCU_TARGET: &str = "thumbv7em-none-eabihf";

#[test]
fn c_example_on_the_host_answers_as_the_rust_edge() {
    let fixture = Fixture::new("host");
    build_staticlib(None);
    make(&fixture.dir, "host");
    let out = Command::new(fixture.dir.join("dynotraj-c"))
        .args(["stream.bin", "replies.bin"])
        .current_dir(&fixture.dir)
        .output()
        .unwrap();
    let log = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "C example exit {}: {log}", out.status);
    fixture.check("host", &log);
}

#[test]
fn c_example_on_a_cortex_m4f_under_qemu_answers_as_the_rust_edge() {
    for tool in ["arm-none-eabi-gcc", "qemu-system-arm"] {
        if Command::new(tool).arg("--version").stdout(Stdio::null()).stderr(Stdio::null()).status().is_err() {
            dynotraj_testkit::skipped(
                "ffi_c_example_qemu",
                &format!(
                    "{tool} not found (bash scripts/setup.sh installs gcc-arm-none-eabi, libnewlib-arm-none-eabi, qemu-system-arm)"
                ),
            );
            return;
        }
    }
    let fixture = Fixture::new("mps2");
    build_staticlib(Some(MCU_TARGET));
    make(&fixture.dir, "mps2");
    let elf = fixture.dir.join("dynotraj-c-mps2.elf");
    let size = Command::new("arm-none-eabi-size").arg(&elf).output().unwrap();
    println!("{}", String::from_utf8_lossy(&size.stdout));
    // Semihosting opens stream.bin and replies.bin relative to QEMU's working directory.
    let mut qemu = Command::new("qemu-system-arm")
        .args(["-cpu", "cortex-m4", "-machine", "mps2-an386", "-nographic", "-monitor", "none"])
        .args(["-semihosting-config", "enable=on,target=native", "-kernel"])
        .arg(&elf)
        .current_dir(&fixture.dir)
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    let status = wait_for_firmware(&mut qemu, Duration::from_secs(300));
    let mut log = String::new();
    qemu.stdout.take().unwrap().read_to_string(&mut log).unwrap();
    qemu.stderr.take().unwrap().read_to_string(&mut log).unwrap();
    assert!(status.success(), "C example under QEMU exit {status}: {log}");
    fixture.check("mps2", &log);
}

/// The fixture stream in a fresh folder, and the Rust edge's replies to it.
struct Fixture {
    dir: PathBuf,
    reference: Vec<u8>,
    _tmp: tempfile::TempDir,
}

impl Fixture {
    fn new(name: &str) -> Self {
        let tmp = tempfile::Builder::new().prefix(&format!("dynotraj-ffi-{name}-")).tempdir().unwrap();
        let stream = encode_all(&host_messages(&scene_tracks(FRAMES), None));
        // The edge's frames decoded and encoded again: encoding is deterministic, so these are
        // the bytes it wrote.
        let reference = encode_all(&reference_replies(&stream, &[]));
        std::fs::write(tmp.path().join("stream.bin"), &stream).unwrap();
        Self { dir: tmp.path().to_path_buf(), reference, _tmp: tmp }
    }

    /// The C example's replies against the reference, byte for byte.
    fn check(&self, build: &str, log: &str) {
        let replies = std::fs::read(self.dir.join("replies.bin")).unwrap();
        let messages = decode_all(&self.reference);
        let count = |f: fn(&Message) -> bool| messages.iter().filter(|m| f(m)).count();
        let forecasts = count(|m| matches!(m, Message::Prediction(_)));
        let frames = count(|m| matches!(m, Message::FrameStats(_)));
        assert!(forecasts >= 16 * 5, "the reference forecasts the cars ({forecasts})");
        assert_eq!(frames, FRAMES, "the reference answers every camera frame");
        println!(
            "{build}: {} bytes, {} frames ({forecasts} forecasts over {frames} camera frames); {}",
            replies.len(),
            decode_all(&replies).len(),
            log.trim()
        );
        assert_eq!(replies.len(), self.reference.len(), "{build}: reply bytes");
        let first = replies.iter().zip(&self.reference).position(|(a, b)| a != b);
        assert_eq!(first, None, "{build}: the C example's replies differ from the Rust edge's at byte {first:?}");
    }
}

/// The workspace's build folder, where the tests run from (`$CARGO_TARGET_DIR`).
fn target_root() -> PathBuf {
    let exe = std::env::current_exe().unwrap();
    exe.parent().unwrap().parent().unwrap().parent().unwrap().to_path_buf()
}

/// Builds the ffi staticlib in release for `target` (the host when `None`) into the tests' build
/// folder.
fn build_staticlib(target: Option<&str>) {
    let root = target_root();
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    // The library as a user builds it: not with the lint flags and clippy's compiler that
    // scripts/test.sh builds the tests with, which would also replace the MCU target's own flags.
    cmd.env_remove("RUSTFLAGS").env_remove("RUSTC_WORKSPACE_WRAPPER");
    cmd.args(["build", "--locked", "--release", "-p", "dynotraj-ffi", "--manifest-path"])
        .arg(dynotraj_tests::manifest_dir().join("../Cargo.toml"))
        .arg("--target-dir")
        .arg(&root);
    if let Some(t) = target {
        cmd.args(["--target", t]);
    }
    let status = cmd.status().unwrap();
    assert!(status.success(), "cargo build -p dynotraj-ffi {target:?}: {status}");
    let lib = target.map_or_else(|| root.clone(), |t| root.join(t)).join("release/libdynotraj_ffi.a");
    println!("{}: {} bytes", lib.display(), std::fs::metadata(&lib).unwrap().len());
}

/// Builds the C example's `goal` (host, mps2) into `out` with its Makefile, against the
/// staticlib [`build_staticlib`] made.
fn make(out: &Path, goal: &str) {
    let example = dynotraj_tests::manifest_dir().join("../ffi/examples/c");
    let status = Command::new("make")
        .arg("-C")
        .arg(&example)
        .arg(goal)
        .arg(format!("OUT={}", out.display()))
        .arg(format!("TARGET_DIR={}", target_root().display()))
        .status()
        .unwrap();
    assert!(status.success(), "make {goal}: {status}");
}
