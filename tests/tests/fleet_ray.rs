//! The fleet driver (fleet/dynotraj_fleet.py) on a local Ray cluster of a head and one joined
//! worker, as on a real cluster: drives estimated and units trained as Ray tasks, then the
//! gather; the report's tables are byte for byte those of `dynotraj benchmark` on one machine.
//! Ray is installed into a virtual environment by the test (fleet/requirements.txt); without
//! Python or the network the test says it skipped.

use std::path::Path;
use std::process::Command;

use dynotraj_sim::drive::{DriveSpec, generate};
use dynotraj_tests::edge_fixture::dynotraj_command;
use dynotraj_tests::manifest_dir;
use dynotraj_tests::python_env::ray_python;
use dynotraj_tests::synthetic_kitti::write_sequence;

/// `ray stop` when the test ends, however it ends.
struct Cluster {
    ray: std::path::PathBuf,
}

impl Drop for Cluster {
    fn drop(&mut self) {
        let _ = Command::new(&self.ray).args(["stop", "--force"]).output();
    }
}

fn ok(cmd: &mut Command, what: &str) -> String {
    let out = cmd.output().unwrap_or_else(|e| panic!("{what}: {e}"));
    let text = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    assert!(out.status.success(), "{what}: {}\n{text}", out.status);
    text
}

const BENCHMARK: [&str; 12] =
    ["--arms", "gt,estimated", "--folds", "2", "--seeds", "1,2", "--dims", "8,8,2,8", "--epochs", "1", "--rate", "10"];

#[test]
fn a_local_ray_cluster_gathers_the_one_machine_report() {
    let python = match ray_python() {
        Ok(p) => p,
        Err(why) => {
            dynotraj_testkit::skipped("fleet_ray", &format!("no Python environment with Ray: {why}"));
            return;
        }
    };
    let dir = tempfile::tempdir().unwrap();
    let kitti = dir.path().join("kitti");
    for (id, seed) in [("0000", 1), ("0001", 8), ("0002", 9), ("0003", 4)] {
        write_sequence(&kitti, id, &generate(&DriveSpec { seed, label_noise_m: 0.05, ..DriveSpec::default() }));
    }
    let k = kitti.to_str().unwrap();
    let one = dir.path().join("one");
    let drive = ["--ours-input", "tracks"];
    ok(
        dynotraj_command()
            .args(["benchmark", "--kitti", k, "--out", one.to_str().unwrap()])
            .args(BENCHMARK)
            .args(drive),
        "one machine",
    );
    // The cluster: a head and a second worker process joined to it, one CPU each.
    let ray = python.parent().unwrap().join("ray");
    let cluster = Cluster { ray: ray.clone() };
    let port = std::net::TcpListener::bind("127.0.0.1:0").unwrap().local_addr().unwrap().port().to_string();
    let common = ["--num-cpus", "1", "--disable-usage-stats"];
    ok(
        Command::new(&ray).args(["start", "--head", "--port", &port, "--include-dashboard", "false"]).args(common),
        "ray start --head",
    );
    ok(
        Command::new(&ray).args(["start", "--address", &format!("127.0.0.1:{port}")]).args(common),
        "ray start (worker)",
    );
    let out = dir.path().join("fleet");
    let binary = dynotraj_command().get_program().to_owned();
    let said = ok(
        Command::new(&python)
            .arg(manifest_dir().join("../fleet/dynotraj_fleet.py"))
            .args(["--address", &format!("127.0.0.1:{port}"), "--dynotraj"])
            .arg(&binary)
            .args(["--kitti", k, "--store", dir.path().join("store").to_str().unwrap()])
            .args(["--out", out.to_str().unwrap(), "--units", "8", "--drive-flags", "--ours-input tracks", "--"])
            .args(BENCHMARK),
        "the fleet driver",
    );
    eprintln!("{said}");
    assert!(said.contains("drives: 4/4 done") && said.contains("training units: 8/8 done"), "{said}");
    drop(cluster);
    let report = std::fs::read_to_string(out.join("REPORT.md")).unwrap();
    assert!(report.contains("8 of 8 folds were read from the fold cache"), "the gather trained again:\n{report}");
    for stem in ["weighted", "goal", "deployment_weighted", "per_sequence_seed1", "table_i"] {
        let read = |d: &Path| std::fs::read_to_string(d.join(format!("{stem}.csv"))).unwrap();
        assert!(read(&one) == read(&out), "{stem}: the cluster's report differs from one machine's");
    }
}
