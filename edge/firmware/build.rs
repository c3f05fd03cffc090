//! Puts memory.x and device.x on the linker's path, links with cortex-m-rt's link.x, and links
//! in the model blob named by `DYNOTRAJ_FW_MODEL` (none: constant-velocity forecasts).

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
    let model = std::env::var_os("DYNOTRAJ_FW_MODEL").map(PathBuf::from);
    let bytes = model.as_ref().map_or_else(Vec::new, |p| {
        std::fs::read(p).unwrap_or_else(|e| panic!("DYNOTRAJ_FW_MODEL {}: {e}", p.display()))
    });
    std::fs::write(out.join("model.bin"), bytes).unwrap();
    println!("cargo:rerun-if-env-changed=DYNOTRAJ_FW_MODEL");
    if let Some(p) = model {
        println!("cargo:rerun-if-changed={}", p.display());
    }
}
