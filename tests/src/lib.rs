//! Shared helpers of the workspace-level integration tests.

pub mod alloc_counter;
pub mod edge_fixture;
pub mod firmware_memory;
pub mod python_env;
pub mod synthetic_kitti;

use std::path::PathBuf;

/// This crate's folder (`tests/`) as the running test sees it: cargo sets `CARGO_MANIFEST_DIR`
/// when it runs a test too, and that value is read first because the compile-time one goes stale
/// when a shared `CARGO_TARGET_DIR` reuses a test binary built from another checkout (cargo keys
/// artifacts by workspace-relative paths, so a clone elsewhere does not rebuild them).
#[must_use]
pub fn manifest_dir() -> PathBuf {
    std::env::var_os("CARGO_MANIFEST_DIR").map_or_else(|| PathBuf::from(env!("CARGO_MANIFEST_DIR")), PathBuf::from)
}

/// The KITTI tracking training folder: `$DYNOTRAJ_KITTI`, else `../shared/kitti/tracking/training`
/// beside the workspace. `None` (with a note on stderr) when it is absent, so that tests which
/// need real data skip clearly instead of failing on a machine without it.
#[must_use]
pub fn kitti_training_dir() -> Option<PathBuf> {
    shared_data("DYNOTRAJ_KITTI", "kitti/tracking/training", "label_02", "kitti_training_dir", "real KITTI data")
}

/// The folder `$env` names, else `../shared/<default>` beside the workspace, when it holds
/// `probe`; else `None`, the skip recorded under the running test (or `fallback`) with `what`.
fn shared_data(env: &str, default: &str, probe: &str, fallback: &str, what: &str) -> Option<PathBuf> {
    let dir = std::env::var_os(env).map_or_else(|| manifest_dir().join("../../shared").join(default), PathBuf::from);
    if dir.join(probe).is_dir() {
        Some(dir)
    } else {
        dynotraj_testkit::skipped(fallback, &format!("{what} not found at {} (set {env})", dir.display()));
        None
    }
}

/// The shared KITTI folder (odometry/, stereo2015/, tracking/): `$DYNOTRAJ_KITTI_ROOT`, else two
/// levels above `$DYNOTRAJ_KITTI` (which names tracking/training), else `../shared/kitti` beside
/// the workspace. `None` (with a note on stderr naming `what`) when
/// `sub` is absent inside it.
#[must_use]
pub fn shared_kitti(sub: &str, what: &str) -> Option<PathBuf> {
    let root = std::env::var_os("DYNOTRAJ_KITTI_ROOT").map(PathBuf::from).unwrap_or_else(|| {
        std::env::var_os("DYNOTRAJ_KITTI")
            .map_or_else(|| manifest_dir().join("../../shared/kitti"), |t| PathBuf::from(t).join("../.."))
    });
    if root.join(sub).is_dir() {
        Some(root)
    } else {
        dynotraj_testkit::skipped(
            what,
            &format!("{} not found (set DYNOTRAJ_KITTI_ROOT to the shared kitti folder)", root.join(sub).display()),
        );
        None
    }
}

/// The ETH/UCY folder (all_data/, train/, val/): `$DYNOTRAJ_ETH_UCY`, else
/// `../shared/trajectories/eth_ucy` beside the workspace. `None` (with a skip naming `what`)
/// when it is absent.
#[must_use]
pub fn shared_eth_ucy(what: &str) -> Option<PathBuf> {
    shared_data("DYNOTRAJ_ETH_UCY", "trajectories/eth_ucy", "all_data", what, "the ETH/UCY recordings")
}
