//! The commit `dynotraj --version` names: the checkout's HEAD when built from a git checkout,
//! "unknown" otherwise.

use std::process::Command;

fn main() {
    let commit = Command::new("git")
        .args(["rev-parse", "--short=12", "HEAD"])
        .output()
        .ok()
        .filter(|o| o.status.success())
        .and_then(|o| String::from_utf8(o.stdout).ok())
        .map(|s| s.trim().to_string())
        .filter(|s| !s.is_empty());
    println!("cargo:rustc-env=DYNOTRAJ_COMMIT={}", commit.as_deref().unwrap_or("unknown"));
    // A new commit or a checkout moves HEAD or a branch's ref.
    for path in ["../.git/HEAD", "../.git/refs/heads", "../.git/packed-refs"] {
        println!("cargo:rerun-if-changed={path}");
    }
}
