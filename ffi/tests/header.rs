//! The committed C header, ffi/include/dynotraj.h, is what cbindgen makes of ffi/src with
//! ffi/cbindgen.toml. With `DYNOTRAJ_WRITE_HEADER=1` the test writes the header instead of
//! checking it (`bash scripts/gen-header.sh`).

use std::path::Path;

#[test]
fn the_committed_header_is_what_the_sources_make() -> Result<(), String> {
    let crate_dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let header = crate_dir.join("include").join("dynotraj.h");
    let config = cbindgen::Config::from_file(crate_dir.join("cbindgen.toml"))?;
    let bindings = cbindgen::Builder::new()
        .with_config(config)
        .with_crate(crate_dir)
        .generate()
        .map_err(|e| format!("cbindgen over {}: {e}", crate_dir.display()))?;
    let mut fresh = Vec::new();
    bindings.write(&mut fresh);
    if std::env::var_os("DYNOTRAJ_WRITE_HEADER").is_some() {
        return std::fs::write(&header, &fresh).map_err(|e| format!("{}: {e}", header.display()));
    }
    let committed = std::fs::read(&header).map_err(|e| format!("{}: {e}", header.display()))?;
    if committed == fresh {
        Ok(())
    } else {
        Err(format!("{} is stale; run bash scripts/gen-header.sh and commit it", header.display()))
    }
}
