//! The fleet driver (fleet/dynotraj_fleet.py) on a local Ray cluster of a head and one joined
//! worker, as on a real cluster: drives estimated and units trained as Ray tasks, then the
//! gather; the report's tables are byte for byte those of `dynotraj benchmark` on one machine,
//! with the drives listed by a manifest over two folders and a ROS 2 bag on the cluster and
//! by one over one folder and the bag on the one machine.
//! Ray is installed into a virtual environment by the test (fleet/requirements.txt); without
//! Python or the network the test says it skipped.

use std::path::Path;
use std::process::Command;

use dynotraj_tests::edge_fixture::dynotraj_command;
use dynotraj_tests::manifest_dir;
use dynotraj_tests::python_env::{or_skip, ray_python};
use dynotraj_tests::synthetic_kitti::{FOUR_DRIVES, write_drives};

/// One cluster at a time: `ray stop` ends every Ray process of the machine, so the tests of
/// this file take turns (within one test process; nextest, which runs each test in a process
/// of its own, puts them in one test group instead: .config/nextest.toml).
static ONE_CLUSTER: std::sync::Mutex<()> = std::sync::Mutex::new(());

/// `ray stop` when the test ends, however it ends.
struct Cluster {
    ray: std::path::PathBuf,
}

impl Cluster {
    /// Ends every Ray process of the machine.
    fn stop(&self) {
        let _ = Command::new(&self.ray).args(["stop", "--force"]).output();
    }
}

impl Drop for Cluster {
    fn drop(&mut self) {
        self.stop();
    }
}

fn ok(cmd: &mut Command, what: &str) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{what}: {}\n{text}", out.status);
    text
}

const BENCHMARK: [&str; 10] =
    ["--arms", "gt,estimated", "--folds", "2", "--seeds", "1,2", "--dims", "8,8,2,8", "--epochs", "1"];

/// The data flags: what a drive's estimate depends on, given to every stage.
const DATA: [&str; 4] = ["--ours-input", "tracks", "--rate", "10"];

/// Four synthetic drives in `dir`/kitti.
fn drives(dir: &Path) -> std::path::PathBuf {
    let kitti = dir.join("kitti");
    write_drives(&kitti, &FOUR_DRIVES);
    kitti
}

/// A local cluster: a head and a second worker process joined to it, one CPU each; its address.
/// A worker that cannot reach the head's GCS retries for many minutes: each `ray start` gets
/// [`RAY_START_LIMIT`], and a cluster that did not come up is stopped and started once more on
/// a new port, the first attempt's log printed (seen once on a fresh machine: the worker found
/// no GCS for 14 minutes).
fn start_cluster(python: &Path) -> (Cluster, String) {
    let ray = python.parent().unwrap().join("ray");
    let cluster = Cluster { ray: ray.clone() };
    let mut failed = String::new();
    for attempt in 1..=2 {
        match try_start_cluster(&ray) {
            Ok(address) => {
                if !failed.is_empty() {
                    eprintln!("the local cluster came up at its second attempt; the first:\n{failed}");
                }
                return (cluster, address);
            }
            Err(log) => {
                cluster.stop();
                failed.push_str(&format!("attempt {attempt}: {log}\n"));
            }
        }
    }
    panic!("the local Ray cluster did not come up:\n{failed}");
}

/// Seconds each `ray start` may take.
const RAY_START_LIMIT: &str = "120";

/// One attempt at [`start_cluster`]: the address, or what `ray start` said.
fn try_start_cluster(ray: &Path) -> Result<String, String> {
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port().to_string();
    // Every process of the local cluster on loopback (Ray's services bind the node's address).
    let common = ["--num-cpus", "1", "--disable-usage-stats", "--node-ip-address", "127.0.0.1"];
    let head = ["start", "--head", "--port", &port, "--include-dashboard", "false"];
    let worker_address = format!("127.0.0.1:{port}");
    let worker = ["start", "--address", &worker_address];
    for (what, args) in [("ray start --head", &head[..]), ("ray start (worker)", &worker[..])] {
        let out = Command::new("timeout")
            .arg(RAY_START_LIMIT)
            .arg(ray)
            .args(args)
            .args(common)
            .output()
            .unwrap_or_else(|e| panic!("{what}: {e}"));
        if !out.status.success() {
            let said = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
            return Err(format!("{what}: {} (124: over {RAY_START_LIMIT} s)\n{said}", out.status));
        }
    }
    Ok(worker_address)
}

/// The driver's command for the drives of `data` (`--kitti DIR` or `--drives MANIFEST`), report
/// in `out`, benchmark flags `flags`.
fn driver(python: &Path, address: &str, data: [&str; 2], dir: &Path, out: &Path, flags: &[&str]) -> Command {
    let mut cmd = Command::new(python);
    cmd.arg(manifest_dir().join("../fleet/dynotraj_fleet.py"))
        .args(["--address", address, "--dynotraj"])
        .arg(dynotraj_command().get_program())
        .args(data)
        .args(["--store", dir.join("store").to_str().unwrap()])
        .args(["--out", out.to_str().unwrap(), "--units", "8", "--drive-flags", &DATA.join(" "), "--"])
        .args(flags);
    cmd
}

/// `dynotraj benchmark` on one machine over the drives of `data` with `flags`, report in `out`.
fn one_machine(data: [&str; 2], out: &Path, flags: &[&str]) {
    ok(dynotraj_command().arg("benchmark").args(data).arg("--out").arg(out).args(DATA).args(flags), "one machine");
}

/// The report tables of `a` and `b` are the same bytes, and `b` read every fold from its cache.
fn same_tables(a: &Path, b: &Path) {
    let report = std::fs::read_to_string(b.join("REPORT.md")).unwrap();
    assert!(report.contains("8 of 8 folds were read from the fold cache"), "the gather trained again:\n{report}");
    for stem in ["weighted", "goal", "deployment_weighted", "per_sequence_seed1", "table_i"] {
        let read = |d: &Path| std::fs::read_to_string(d.join(format!("{stem}.csv"))).ok();
        assert!(read(a).is_some() || stem == "deployment_weighted", "{stem}: missing on one machine");
        assert!(read(a) == read(b), "{stem}: the cluster's report differs from one machine's");
    }
}

fn ray_or_skip(test: &str) -> Option<std::path::PathBuf> {
    or_skip(ray_python(), test, "no Python environment with Ray")
}

#[test]
fn a_local_ray_cluster_gathers_the_one_machine_report() {
    let _turn = ONE_CLUSTER.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(python) = ray_or_skip("fleet_ray") else { return };
    let dir = tempfile::tempdir().unwrap();
    drives(dir.path());
    // The same drives in two folders, listed by a manifest.
    write_drives(&dir.path().join("part-a"), &FOUR_DRIVES[..2]);
    write_drives(&dir.path().join("part-b"), &FOUR_DRIVES[2..]);
    // And a drive without labels: the committed rendering as a ROS 2 bag, which the cluster's
    // drive task imports into the store.
    let fixture = manifest_dir().join("../sim/data/image_sim");
    let bags = dir.path().join("bags");
    ok(
        dynotraj_command().args(["export-bag", "--sequences", "0000", "--kitti"]).arg(&fixture).arg("--out").arg(&bags),
        "export-bag",
    );
    std::fs::rename(bags.join("0000"), bags.join("run7")).unwrap();
    let manifest = dir.path().join("drives.txt");
    std::fs::write(&manifest, "part-a\npart-b 0002,0003\nbags\n").unwrap();
    let one_folder = dir.path().join("one-folder.txt");
    std::fs::write(&one_folder, "kitti\nbags/run7\n").unwrap();
    let one = dir.path().join("one");
    one_machine(["--drives", one_folder.to_str().unwrap()], &one, &BENCHMARK);
    let (cluster, address) = start_cluster(&python);
    let out = dir.path().join("fleet");
    let data = ["--drives", manifest.to_str().unwrap()];
    let said = ok(&mut driver(&python, &address, data, dir.path(), &out, &BENCHMARK), "the fleet driver");
    eprintln!("{said}");
    assert!(said.contains("drives: 5/5 done") && said.contains("training units: 8/8 done"), "{said}");
    let store: Vec<String> = std::fs::read_dir(dir.path().join("store"))
        .unwrap()
        .map(|e| e.unwrap().file_name().to_string_lossy().into_owned())
        .collect();
    assert!(store.iter().any(|n| n.starts_with("imported-run7-")), "the bag was not imported: {store:?}");
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(
        report.contains("No deployment or truth-scored tables: 1 drive(s)") && report.contains("(run7)"),
        "{report}"
    );
    assert!(said.contains("retries: 0 "), "{said}");
    drop(cluster);
    same_tables(&one, &out);
}

/// A Ray worker killed by its PID while it trains a unit costs that unit a retry; the report is
/// the same.
#[test]
fn a_worker_killed_mid_task_costs_a_retry_and_the_report_is_the_same() {
    let _turn = ONE_CLUSTER.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    let Some(python) = ray_or_skip("fleet_ray_fault") else { return };
    let dir = tempfile::tempdir().unwrap();
    let kitti = drives(dir.path());
    // Units long enough to be killed in the middle of.
    let slow: Vec<&str> = BENCHMARK.iter().map(|f| if *f == "1" { "30" } else { f }).collect();
    let slow: Vec<&str> = slow.iter().enumerate().map(|(i, f)| if i == 7 { "16,16,2,16" } else { f }).collect();
    let one = dir.path().join("one");
    one_machine(["--kitti", kitti.to_str().unwrap()], &one, &slow);
    let (cluster, address) = start_cluster(&python);
    let out = dir.path().join("fleet");
    let mut child = driver(&python, &address, ["--kitti", kitti.to_str().unwrap()], dir.path(), &out, &slow)
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Kill the first worker seen running a training unit. The drives are estimated first; once,
    // in a cold run of the whole suite, none was seen within two minutes, so the wait is longer
    // and a driver that never trains says what it did instead.
    let waited = std::time::Instant::now();
    let mut killed = None;
    while killed.is_none()
        && waited.elapsed() < std::time::Duration::from_secs(300)
        && child.try_wait().unwrap().is_none()
    {
        let ps = Command::new("ps").args(["-eo", "pid=,args="]).output().unwrap();
        killed = String::from_utf8_lossy(&ps.stdout)
            .lines()
            .find(|l| l.contains("ray::train_unit"))
            .and_then(|l| l.split_whitespace().next().map(str::to_string));
        if killed.is_none() {
            std::thread::sleep(std::time::Duration::from_millis(100));
        }
    }
    let Some(pid) = killed else {
        let _ = child.kill();
        let done = child.wait_with_output().unwrap();
        panic!(
            "no worker was seen training a unit in {:.0?}; the driver said:\n{}{}",
            waited.elapsed(),
            String::from_utf8_lossy(&done.stdout),
            String::from_utf8_lossy(&done.stderr)
        );
    };
    assert!(Command::new("kill").args(["-9", &pid]).status().unwrap().success());
    let done = child.wait_with_output().unwrap();
    let said = format!("{}{}", String::from_utf8_lossy(&done.stdout), String::from_utf8_lossy(&done.stderr));
    eprintln!("killed worker {pid}\n{said}");
    assert!(done.status.success(), "{said}");
    assert!(said.contains("training units: 8/8 done"), "{said}");
    assert!(said.contains("retries: 1 "), "the killed worker's unit ran again: {said}");
    let attempts = std::fs::read_to_string(dir.path().join("store/attempts.log")).unwrap();
    assert!(attempts.lines().any(|l| l.ends_with(&format!(" {pid}"))), "{pid} not in\n{attempts}");
    drop(cluster);
    same_tables(&one, &out);
}

/// What the driver can check without a cluster is checked first, each in one line and exit 2:
/// a missing binary (a Python traceback before), a count of units below 1 (`--units 0` became
/// 12, `--units -1` ran everything and then failed), a benchmark flag the binary refuses (found
/// after the whole drive stage before), an address where no cluster answers (retried for over
/// two minutes before).
#[test]
fn the_drivers_arguments_are_checked_before_the_cluster_is_used() {
    let Some(python) = ray_or_skip("fleet_ray arguments") else { return };
    let dir = tempfile::tempdir().unwrap();
    let kitti = drives(dir.path());
    let data = ["--kitti", kitti.to_str().unwrap()];
    let out = dir.path().join("out");
    let closed = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().to_string();
    // The driver's arguments with `change` applied to each.
    let with = |address: &str, flags: &[&str], change: &dyn Fn(std::ffi::OsString) -> std::ffi::OsString| {
        let args: Vec<std::ffi::OsString> = driver(&python, address, data, dir.path(), &out, flags)
            .get_args()
            .map(std::ffi::OsStr::to_os_string)
            .collect();
        let mut next_is_binary = false;
        let args: Vec<_> = args
            .into_iter()
            .map(|a| {
                // The binary (the value after --dynotraj) and the units (`8`) are what `change`
                // may replace.
                let is_binary = std::mem::replace(&mut next_is_binary, a == "--dynotraj");
                if is_binary || a == "8" { change(a) } else { a }
            })
            .collect();
        let started = std::time::Instant::now();
        let o = Command::new(&python).args(args).output().unwrap();
        let err = String::from_utf8_lossy(&o.stderr).into_owned();
        assert!(started.elapsed() < std::time::Duration::from_secs(60), "{err}");
        (o.status.code(), err)
    };
    let keep = |a| a;
    let missing = dir.path().join("no-such-dynotraj");
    let (code, err) = with("auto", &BENCHMARK, &|a| if a == "8" { a } else { missing.clone().into() });
    assert!(code == Some(2) && err.contains("no such program") && !err.contains("Traceback"), "{err}");
    for units in ["0", "-1"] {
        let (code, err) = with("auto", &BENCHMARK, &|a| if a == "8" { units.into() } else { a });
        assert!(code == Some(2) && err.contains("--units") && err.contains(&format!("found {units}")), "{err}");
    }
    let (code, err) = with("auto", &["--arms", "bogus"], &keep);
    assert!(code == Some(2) && err.contains("the benchmark flags --arms bogus"), "{err}");
    let (code, err) = with(&closed, &BENCHMARK, &keep);
    assert!(code == Some(2) && err.contains("no Ray cluster answers there"), "{err}");
    assert!(!out.exists(), "nothing written");
}
