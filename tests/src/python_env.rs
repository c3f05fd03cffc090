//! The Python environment of the tests that read files back with another ecosystem's own
//! readers (Python's `mcap` and `mcap-ros2-support`): a virtual environment outside the
//! repository (`$DYNOTRAJ_VENV`, else `$HOME/.cache/dynotraj-venv`), made once from
//! tests/python/requirements.txt and made again when the pins change.

use std::path::PathBuf;
use std::process::Command;
use std::sync::Mutex;

use crate::manifest_dir;

/// The Python of the tests' virtual environment, made on first use; `Err` says why there is
/// none (no python3, no venv module or pip, no network for the packages).
///
/// # Errors
/// Why there is no environment, for the test to say it skipped.
pub fn python() -> Result<PathBuf, String> {
    // The tests of one binary run in one process: the environment is made once, not twice at
    // the same time.
    static MADE: Mutex<Option<Result<PathBuf, String>>> = Mutex::new(None);
    let mut made = MADE.lock().unwrap_or_else(std::sync::PoisonError::into_inner);
    made.get_or_insert_with(make_venv).clone()
}

fn make_venv() -> Result<PathBuf, String> {
    let requirements = manifest_dir().join("python/requirements.txt");
    let wanted = std::fs::read_to_string(&requirements).map_err(|e| format!("{}: {e}", requirements.display()))?;
    let venv = std::env::var_os("DYNOTRAJ_VENV")
        .map(PathBuf::from)
        .or_else(|| std::env::var_os("HOME").map(|h| PathBuf::from(h).join(".cache").join("dynotraj-venv")));
    let venv = venv.ok_or("neither DYNOTRAJ_VENV nor HOME is set")?;
    let python = venv.join("bin").join("python");
    // The requirements the environment was completed with: a change of pins installs again.
    let stamp = venv.join("dynotraj-requirements.txt");
    if python.exists() && std::fs::read_to_string(&stamp).is_ok_and(|s| s == wanted) {
        return Ok(python);
    }
    let run = |cmd: &mut Command, what: &str| -> Result<(), String> {
        let out = cmd.output().map_err(|e| format!("{what}: {e}"))?;
        if out.status.success() {
            Ok(())
        } else {
            Err(format!("{what}: {}\n{}", out.status, String::from_utf8_lossy(&out.stderr).trim()))
        }
    };
    run(Command::new("python3").arg("--version"), "python3")?;
    if !python.exists() {
        run(Command::new("python3").args(["-m", "venv"]).arg(&venv), "python3 -m venv")?;
    }
    run(Command::new(&python).args(["-m", "pip", "--version"]), "pip in the virtual environment")?;
    run(
        Command::new(&python)
            .args(["-m", "pip", "install", "--quiet", "--disable-pip-version-check", "-r"])
            .arg(&requirements),
        "pip install -r tests/python/requirements.txt",
    )?;
    std::fs::write(&stamp, wanted).map_err(|e| format!("{}: {e}", stamp.display()))?;
    Ok(python)
}
