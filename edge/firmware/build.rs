//! Puts memory.x and device.x on the linker's path, links with cortex-m-rt's link.x, and links
//! in the model blobs named by `DYNOTRAJ_FW_MODEL`, comma-separated, one per agent type (none:
//! constant-velocity forecasts).

use std::path::PathBuf;

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").unwrap());
    for f in ["memory.x", "device.x"] {
        std::fs::copy(f, out.join(f)).unwrap();
        println!("cargo:rerun-if-changed={f}");
    }
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rustc-link-arg=-Tlink.x");
    println!("cargo:rustc-link-arg=--nmagic");
    let list = std::env::var("DYNOTRAJ_FW_MODEL").unwrap_or_default();
    let paths: Vec<PathBuf> = list.split(',').filter(|p| !p.is_empty()).map(PathBuf::from).collect();
    // As many files as the firmware has slots (src/lib.rs `LINKED_MODELS`), empty where unused.
    const SLOTS: usize = 2;
    assert!(paths.len() <= SLOTS, "DYNOTRAJ_FW_MODEL names {} blobs: at most {SLOTS}, one per agent type", paths.len());
    for slot in 0..SLOTS {
        let bytes = paths.get(slot).map_or_else(Vec::new, |p| {
            std::fs::read(p).unwrap_or_else(|e| panic!("DYNOTRAJ_FW_MODEL {}: {e}", p.display()))
        });
        std::fs::write(out.join(format!("model{slot}.bin")), bytes).unwrap();
    }
    println!("cargo:rerun-if-env-changed=DYNOTRAJ_FW_MODEL");
    for p in paths {
        println!("cargo:rerun-if-changed={}", p.display());
    }
}
