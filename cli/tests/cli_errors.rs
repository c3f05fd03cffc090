//! The `dynotraj` binary on bad input: every case exits non-zero with one clear line naming the
//! flag or value and what was expected, never a panic (exit code 101) or a silent fallback.

use std::path::Path;
use std::process::Command;

use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_sim::kitti_layout::write_sequence;

/// Runs the binary with `args`; returns its exit code and stderr.
fn run(args: &[&str]) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynotraj"))
        .args(args)
        .env("RAYON_NUM_THREADS", "1")
        .env_remove("DYNOTRAJ_KITTI")
        .output()
        .expect("runs the binary");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

fn refused(args: &[&str], code: i32, says: &str) {
    let (got, err) = run(args);
    assert_eq!(got, code, "dynotraj {}: exit {got}, stderr:\n{err}", args.join(" "));
    assert!(err.contains(says), "dynotraj {}: expected `{says}` in:\n{err}", args.join(" "));
    assert!(!err.contains("panicked"), "dynotraj {}: panicked:\n{err}", args.join(" "));
}

#[test]
fn float_flags_are_checked_when_parsed() {
    let to = ["--to", "tcp://127.0.0.1:9"];
    for (flag, value, says) in [
        ("--timeout", "inf", "expected a finite number, found `inf`"),
        ("--timeout", "1e20", "expected a time in seconds"),
        ("--timeout", "0", "expected a time in seconds"),
        ("--timeout", "NaN", "expected a finite number"),
        ("--rate", "1e-20", "expected 0 (as fast as possible) or a rate in Hz"),
        ("--rate", "-1", "expected 0 (as fast as possible) or a rate in Hz"),
        ("--rate", "inf", "expected a finite number"),
    ] {
        let arg = format!("{flag}={value}");
        refused(&["stream", &arg, to[0], to[1]], 2, says);
    }
    refused(&["estimate", "--outliers", "2"], 2, "expected a fraction in [0, 1]");
    refused(&["dataset", "--kitti", ".", "--rate", "0"], 2, "expected a frame rate in Hz");
    refused(
        &["train", "--kitti", ".", "--source", "gt", "--out", "model", "--lr=-0.1"],
        2,
        "expected a positive number",
    );
}

fn synthetic_kitti(root: &Path) {
    write_sequence(root, "0000", &generate(&DriveSpec { frames: 40, ..DriveSpec::default() })).expect("writes");
    write_sequence(root, "0001", &generate(&DriveSpec { frames: 40, seed: 2, ..DriveSpec::default() }))
        .expect("writes");
}

#[test]
fn sequences_given_twice_and_unknown_exclusions_are_errors() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    refused(&["dataset", "--kitti", kitti, "--sequences", "0000,0000"], 1, "--sequences: 0000 is given twice");
    let out = dir.path().join("model");
    let out = out.to_str().expect("utf-8");
    refused(
        &["train", "--kitti", kitti, "--source", "gt", "--exclude", "9999", "--out", out],
        1,
        "--exclude 9999: no such sequence was loaded (loaded: 0000, 0001)",
    );
    assert!(!Path::new(out).exists(), "nothing trained");
    // A test sequence the folder holds but --sequences left out is named as not loaded, with the
    // way out, not as missing from the folder.
    let report = dir.path().join("report");
    refused(
        &[
            "experiment",
            "--kitti",
            kitti,
            "--sequences",
            "0000",
            "--tests",
            "0001",
            "--arms",
            "gt",
            "--out",
            report.to_str().expect("utf-8"),
        ],
        1,
        "test sequence 0001 is not among the sequences loaded (0000): add it to --sequences",
    );
}

#[test]
fn a_soak_edge_that_is_no_edge_is_named() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    // `sleep` refuses the edge's arguments with an error line, which is not an address.
    refused(
        &["soak", "--kitti", kitti, "--sequences", "0000", "--edge", "/bin/sleep", "--frames", "2"],
        1,
        "the edge /bin/sleep did not say where it listens: expected its first line to end in tcp://HOST:PORT, found `",
    );
}

#[test]
fn a_stream_no_edge_answers_fails() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    // A server that accepts and reads but never answers.
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("binds");
    let port = listener.local_addr().expect("address").port();
    std::thread::spawn(move || {
        if let Ok((mut conn, _)) = listener.accept() {
            let _ = std::io::copy(&mut conn, &mut std::io::sink());
        }
    });
    let to = format!("tcp://127.0.0.1:{port}");
    let kitti = dir.path().to_str().expect("utf-8");
    let args = [
        "stream",
        "--kitti",
        kitti,
        "--sequence",
        "0000",
        "--frames",
        "5",
        "--rate",
        "0",
        "--timeout",
        "1",
        "--to",
        &to,
    ];
    refused(&args, 1, "5 frames sent and none answered within --timeout 1 s");
}

#[test]
fn a_blob_with_bytes_after_it_is_refused_by_sign_and_verify() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    let model = dir.path().join("model");
    let blob = model.join("model.blob");
    let blob_s = blob.to_str().expect("utf-8");
    let train = ["train", "--kitti", kitti, "--source", "gt", "--exclude", "0001", "--out", model.to_str().unwrap()];
    let (code, err) = run(&[&train[..], &["--dims", "8,8,2,16", "--epochs", "1", "--rate", "10"]].concat());
    assert_eq!(code, 0, "{err}");
    let signed_dir = dir.path().join("signed");
    let signed_dir_s = signed_dir.to_str().expect("utf-8");
    let (code, err) = run(&["sign", "--key", "dev", "--model", blob_s, "--out", signed_dir_s]);
    assert_eq!(code, 0, "{err}");
    let signed = signed_dir.join("model.blob.signed");
    let signed_s = signed.to_str().expect("utf-8");
    // Signing the signed file again (beside it, the default): its trailer is bytes after the
    // blob.
    let twice = signed_dir.join("model.blob.signed.signed");
    let twice_s = twice.to_str().expect("utf-8");
    refused(&["sign", "--key", "dev", "--model", signed_s], 1, "bytes after the model blob's CRC");
    assert!(!twice.exists(), "a refused blob is not signed");
    // A doubly signed file made anyway verifies as a signature, and is refused as a blob.
    let key = dynotraj_formats::model_signing::development_signing_key().expect("dev key");
    let bytes = std::fs::read(&signed).expect("reads");
    std::fs::write(&twice, dynotraj_formats::model_signing::sign(&bytes, &key)).expect("writes");
    refused(&["verify", "--key", "dev", "--model", twice_s], 1, "bytes after the model blob's CRC");
    let (code, err) = run(&["verify", "--key", "dev", "--model", signed_s]);
    assert_eq!(code, 0, "{err}");
}

#[test]
fn a_key_of_the_wrong_kind_is_refused_by_sign_and_verify() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().to_str().expect("utf-8");
    let (code, err) = run(&["keygen", "--out", out, "--name", "k"]);
    assert_eq!(code, 0, "{err}");
    let (secret, public) = (dir.path().join("k.key"), dir.path().join("k.pub"));
    let (secret, public) = (secret.to_str().expect("utf-8"), public.to_str().expect("utf-8"));
    let model = dir.path().join("absent.blob");
    let model = model.to_str().expect("utf-8");
    refused(
        &["sign", "--key", public, "--model", model],
        1,
        "k.pub: this is a public key; signing needs the secret key",
    );
    refused(
        &["verify", "--key", secret, "--model", model],
        1,
        "k.key: this is a secret key; checking a signature needs",
    );
}

#[test]
fn the_command_runs_as_one_process_so_killing_it_leaves_nothing_running() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let listener = std::net::TcpListener::bind("127.0.0.1:0").expect("binds");
    let to = format!("tcp://{}", listener.local_addr().expect("address"));
    let kitti = dir.path().to_str().expect("utf-8");
    let mut child = Command::new(env!("CARGO_BIN_EXE_dynotraj"))
        .args(["stream", "--kitti", kitti, "--sequence", "0000", "--rate", "1", "--to", &to])
        .env_remove("RAYON_NUM_THREADS")
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
        .expect("starts");
    let _conn = listener.accept().expect("the command connects");
    let pid = child.id();
    let children = std::fs::read_to_string(format!("/proc/{pid}/task/{pid}/children")).expect("reads /proc");
    child.kill().expect("kills");
    child.wait().expect("reaps");
    assert_eq!(children.trim(), "", "dynotraj started child processes: {children}");
}

#[test]
fn a_bad_object_is_refused_naming_the_flag_before_anything_is_trained() {
    for (value, says) in
        [("0000", "expected SEQ:ID"), ("0000:x", "found the object `x`"), ("0000:0", "object numbers start at 1")]
    {
        refused(&["experiment", "--kitti", ".", "--object", value], 2, says);
    }
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().expect("utf-8");
    let out = dir.path().join("report");
    let out_s = out.to_str().expect("utf-8");
    let experiment = ["experiment", "--kitti", kitti, "--tests", "0000", "--out", out_s];
    refused(
        &[&experiment[..], &["--object", "0000:2,0007:1"]].concat(),
        1,
        "--object 0007:1: sequence 0007 is not loaded (loaded: 0000, 0001)",
    );
    // The drive's objects are KITTI tracks 1-3: objects 2-4.
    refused(
        &[&experiment[..], &["--object", "0001:1"]].concat(),
        1,
        "--object 0001:1: sequence 0001 has no object 1 (object numbers are KITTI track id + 1; its objects: 2, 3, 4)",
    );
    assert!(!out.join("models").exists(), "nothing trained");
}

#[test]
fn forecast_names_a_model_that_is_no_model_and_writes_nothing() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().unwrap();
    let bad = dir.path().join("bad.model");
    std::fs::write(&bad, b"garbage").unwrap();
    let out = dir.path().join("out");
    let args = ["forecast", "--kitti", kitti, "--sequences", "0000", "--model", bad.to_str().unwrap()];
    refused(&[&args[..], &["--out", out.to_str().unwrap()]].concat(), 1, "expected a model blob, model blob too short");
    assert!(!out.exists(), "nothing written for a refused model");
    let (code, err) = run(&["forecast", "--kitti", kitti, "--sequences", "0000", "--out", out.to_str().unwrap()]);
    assert_eq!(code, 0, "{err}");
    let table = std::fs::read_to_string(out.join("forecasts.csv")).unwrap();
    assert!(table.starts_with("frame,object_id,step,x,y\n") && table.lines().count() > 30, "{table}");
}

/// Runs the binary with its standard output going to `stdout`; returns its exit code and stderr.
fn run_into(args: &[&str], stdout: std::process::Stdio) -> (i32, String) {
    let out = Command::new(env!("CARGO_BIN_EXE_dynotraj"))
        .args(args)
        .env_remove("DYNOTRAJ_KITTI")
        .stdout(stdout)
        .output()
        .expect("runs the binary");
    (out.status.code().unwrap_or(-1), String::from_utf8_lossy(&out.stderr).into_owned())
}

#[test]
fn output_that_cannot_be_written_ends_the_command_without_a_panic() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().unwrap();
    // A full disk: `println!` (dataset's table) and a writer's error (completions) alike.
    for args in [&["dataset", "--kitti", kitti][..], &["completions", "bash"][..], &["man"][..]] {
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full").expect("/dev/full");
        let (code, err) = run_into(args, full.into());
        assert_eq!(code, 1, "dynotraj {}: exit {code}, stderr:\n{err}", args.join(" "));
        assert!(err.contains("No space left on device"), "dynotraj {}: stderr:\n{err}", args.join(" "));
        assert!(!err.contains("panicked"), "dynotraj {}: panicked:\n{err}", args.join(" "));
    }
    // A reader that closed the pipe before the command wrote: the exit code of SIGPIPE, quietly.
    let mut child = Command::new(env!("CARGO_BIN_EXE_dynotraj"))
        .args(["completions", "bash"])
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("spawns");
    drop(child.stdout.take());
    let out = child.wait_with_output().expect("waits");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(141), "stderr:\n{err}");
    assert!(!err.contains("panicked") && !err.contains("error"), "stderr:\n{err}");
}

#[test]
fn every_command_help_and_the_version_written_to_a_full_disk_exit_1_without_a_panic() {
    use clap::CommandFactory as _;
    let mut invocations: Vec<Vec<String>> = vec![vec!["--version".into()], vec!["--help".into()]];
    for sub in dynotraj_cli::Cli::command().get_subcommands() {
        invocations.push(vec![sub.get_name().to_string(), "--help".into()]);
    }
    assert!(invocations.len() > 20, "{} invocations", invocations.len());
    for args in &invocations {
        let args: Vec<&str> = args.iter().map(String::as_str).collect();
        let full = std::fs::OpenOptions::new().write(true).open("/dev/full").expect("/dev/full");
        let (code, err) = run_into(&args, full.into());
        assert_eq!(code, 1, "dynotraj {}: exit {code}, stderr:\n{err}", args.join(" "));
        assert!(
            err.contains("error: writing to stdout: No space left on device"),
            "dynotraj {}: {err}",
            args.join(" ")
        );
        assert!(!err.contains("panicked"), "dynotraj {}: panicked:\n{err}", args.join(" "));
    }
}

#[test]
fn a_command_without_a_stop_of_its_own_is_ended_by_sigterm_and_says_so() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("sim");
    let child = Command::new(env!("CARGO_BIN_EXE_dynotraj"))
        .args(["simulate", "--drive", "--sequences", "0000", "--frames", "2000", "--scale", "1"])
        .args(["--out", out.to_str().unwrap()])
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .expect("starts");
    // Rendering has begun once the first frame's image is there.
    let first = out.join("image_02/0000/000000.png");
    let waited = std::time::Instant::now();
    while !first.exists() && waited.elapsed() < std::time::Duration::from_secs(60) {
        std::thread::sleep(std::time::Duration::from_millis(50));
    }
    assert!(first.exists(), "simulate did not start rendering");
    let killed = Command::new("kill").args(["-TERM", &child.id().to_string()]).status().expect("kill");
    assert!(killed.success());
    let out = child.wait_with_output().expect("waits");
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("error: dynotraj simulate interrupted by SIGTERM"), "{err}");
}

#[test]
fn a_sequence_id_that_is_a_path_is_refused_before_anything_is_written() {
    let dir = tempfile::tempdir().expect("temp dir");
    let out = dir.path().join("sim");
    let sim = out.to_str().unwrap();
    refused(
        &["simulate", "--drive", "--sequences", "../../escape", "--out", sim, "--frames", "2", "--scale", "0.5"],
        2,
        "expected a sequence id of 1 to 64 letters, digits, `_` or `-` (it names files), e.g. 0003, found `../../escape`",
    );
    refused(&["dataset", "--kitti", ".", "--sequences", "0000,a/b"], 2, "found `a/b`");
    refused(&["train", "--kitti", ".", "--source", "gt", "--exclude", "..", "--out", sim], 2, "found `..`");
    assert!(!out.exists() && !dir.path().join("escape").exists(), "nothing written");
}

#[test]
fn an_outlier_share_that_swamps_the_tracks_is_warned_about() {
    let dir = tempfile::tempdir().expect("temp dir");
    synthetic_kitti(dir.path());
    let kitti = dir.path().to_str().unwrap();
    let base = ["estimate", "--kitti", kitti, "--sequences", "0000", "--ours-input", "tracks", "--frames", "10"];
    let (code, err) = run(&[&base[..], &["--outliers", "1"]].concat());
    assert_eq!(code, 0, "{err}");
    assert!(
        err.contains("warning: --outliers 1: at least 50 % of every frame's simulated tracks are outliers"),
        "{err}"
    );
    let (code, err) = run(&base);
    assert_eq!(code, 0, "{err}");
    assert!(!err.contains("warning: --outliers"), "{err}");
}

/// Flags that need no data are checked before any: a bad one must not cost the loading (or the
/// decoding of a bag) first.
#[test]
fn flags_are_checked_before_any_work() {
    let dir = tempfile::tempdir().unwrap();
    write_sequence(dir.path(), "0000", &generate(&DriveSpec { frames: 30, ..DriveSpec::default() })).unwrap();
    let kitti = dir.path().to_str().unwrap();
    let bag = dir.path().join("missing.mcap");
    let out = dir.path().join("out");
    refused(
        &["import", "--bag", bag.to_str().unwrap(), "--out", out.to_str().unwrap(), "--frames", "0"],
        2,
        "expected a count of at least 1, found 0",
    );
    let started = std::time::Instant::now();
    refused(
        &["benchmark", "--kitti", kitti, "--arms", "gt", "--ours-input", "tracks", "--shard", "0/2"],
        1,
        "--shard: needs a fold cache (--out DIR, without --no-cache)",
    );
    assert!(!out.exists(), "nothing written");
    println!("benchmark --shard without --out refused in {:.2} s", started.elapsed().as_secs_f64());
}
