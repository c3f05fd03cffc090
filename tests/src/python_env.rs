//! The Python environments of the tests that use another ecosystem's own tools: the readers
//! (Python's `mcap` and `mcap-ros2-support`, tests/python/requirements.txt), Ray
//! (fleet/requirements.txt), rerun and kitti2mcap. scripts/python-env.sh makes each one, a
//! virtual environment outside the repository, once and again when its pins change; it is the
//! one place that knows their requirements and folders.

use std::path::PathBuf;
use std::process::Command;
use std::sync::Mutex;

use crate::manifest_dir;

/// The Python of the readers' environment, made on first use; `Err` says why there is none
/// (no python3, no venv module or pip, no network for the packages).
///
/// # Errors
/// Why there is no environment, for the test to say it skipped.
pub fn python() -> Result<PathBuf, String> {
    static MADE: Made = Mutex::new(None);
    made_once(&MADE, "readers")
}

/// The Python of the Ray environment (fleet/requirements.txt), made on first use.
///
/// # Errors
/// Why there is no environment, for the test to say it skipped.
pub fn ray_python() -> Result<PathBuf, String> {
    static MADE: Made = Mutex::new(None);
    made_once(&MADE, "ray")
}

/// The Python of rerun's environment (tests/python/rerun-requirements.txt), made on first use.
///
/// # Errors
/// Why there is no environment, for the test to say it skipped.
pub fn rerun_python() -> Result<PathBuf, String> {
    static MADE: Made = Mutex::new(None);
    made_once(&MADE, "rerun")
}

/// The Python of kitti2mcap's environment (tests/python/kitti2mcap-requirements.txt), made on
/// first use.
///
/// # Errors
/// Why there is no environment, for the test to say it skipped.
pub fn kitti2mcap_python() -> Result<PathBuf, String> {
    static MADE: Made = Mutex::new(None);
    made_once(&MADE, "kitti2mcap")
}

/// The environment `env` gave, or `None` once the running test (`test` where its thread has
/// no name) is recorded as skipped because `missing` is missing.
pub fn or_skip(env: Result<PathBuf, String>, test: &str, missing: &str) -> Option<PathBuf> {
    env.map_err(|why| dynotraj_testkit::skipped(test, &format!("{missing}: {why}"))).ok()
}

/// An environment made once per test process, or why it could not be.
type Made = Mutex<Option<Result<PathBuf, String>>>;

/// The environment `name` of scripts/python-env.sh, asked for once per process (the script's
/// own lock orders the processes).
fn made_once(made: &Made, name: &str) -> Result<PathBuf, String> {
    let mut made = made.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    made.get_or_insert_with(|| make_venv(name)).clone()
}

fn make_venv(name: &str) -> Result<PathBuf, String> {
    let script = manifest_dir().join("../scripts/python-env.sh");
    let out =
        Command::new("bash").arg(&script).arg(name).output().map_err(|e| format!("bash {}: {e}", script.display()))?;
    if out.status.success() {
        Ok(PathBuf::from(String::from_utf8_lossy(&out.stdout).trim()))
    } else {
        Err(format!("{} {name}: {}\n{}", script.display(), out.status, String::from_utf8_lossy(&out.stderr).trim()))
    }
}

/// The version of Foxglove's official schemas (the npm package `@foxglove/schemas`) that
/// recordings are validated against.
pub const FOXGLOVE_SCHEMAS_VERSION: &str = "2.1.0";

/// A folder of Foxglove's official JSON Schemas, `<Name>.json` per type, made on first use
/// from the npm package (`npm pack`, then `node` writes each exported schema) and kept beside
/// the virtual environments; `Err` says why there is none (no npm or node, no network).
///
/// # Errors
/// Why there are no schemas, for the test to say it skipped.
pub fn foxglove_json_schemas() -> Result<PathBuf, String> {
    static MADE: Made = Mutex::new(None);
    let mut made = MADE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    made.get_or_insert_with(make_foxglove_schemas).clone()
}

fn make_foxglove_schemas() -> Result<PathBuf, String> {
    let home = std::env::var_os("HOME").ok_or("HOME is not set")?;
    let dir = PathBuf::from(home).join(".cache").join(format!("dynotraj-foxglove-schemas-{FOXGLOVE_SCHEMAS_VERSION}"));
    if dir.join("SceneUpdate.json").is_file() {
        return Ok(dir);
    }
    let staging = dir.with_extension(format!("partial-{}", std::process::id()));
    let _ = std::fs::remove_dir_all(&staging);
    std::fs::create_dir_all(&staging).map_err(|e| format!("{}: {e}", staging.display()))?;
    let run = |cmd: &mut Command, what: &str| -> Result<(), String> {
        let out = cmd.current_dir(&staging).output().map_err(|e| format!("{what}: {e}"))?;
        if out.status.success() {
            Ok(())
        } else {
            Err(format!("{what}: {}\n{}", out.status, String::from_utf8_lossy(&out.stderr).trim()))
        }
    };
    let package = format!("@foxglove/schemas@{FOXGLOVE_SCHEMAS_VERSION}");
    run(Command::new("npm").args(["pack", "--silent", &package]), "npm pack")?;
    let tarball = format!("foxglove-schemas-{FOXGLOVE_SCHEMAS_VERSION}.tgz");
    run(Command::new("tar").args(["xzf", &tarball]), "tar")?;
    let dump = "const s = require('./package/dist/jsonschema/index.js'); const fs = require('fs'); \
        for (const [name, schema] of Object.entries(s)) fs.writeFileSync(name + '.json', JSON.stringify(schema));";
    run(Command::new("node").args(["-e", dump]), "node")?;
    match std::fs::rename(&staging, &dir) {
        Ok(()) => Ok(dir),
        // Another test process made them first (each test runs in a process of its own).
        Err(_) if dir.join("SceneUpdate.json").is_file() => {
            let _ = std::fs::remove_dir_all(&staging);
            Ok(dir)
        }
        Err(e) => Err(format!("{}: {e}", dir.display())),
    }
}
