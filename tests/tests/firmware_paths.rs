//! The MCU images are the same bytes from any checkout: none names an absolute path of the
//! machine that built it (the checkout, cargo's registry), which panic locations would
//! otherwise carry (scripts/env.sh remaps them). A path in the image made its memory goldens
//! depend on the length of the clone's path.

use dynotraj_tests::edge_fixture::firmware_program;

/// Whether `needle` occurs in `haystack`.
fn contains(haystack: &[u8], needle: &[u8]) -> bool {
    !needle.is_empty() && haystack.windows(needle.len()).any(|w| w == needle)
}

#[test]
fn no_firmware_image_names_a_path_of_the_build_machine() {
    let checkout = std::fs::canonicalize(dynotraj_tests::manifest_dir().join("..")).unwrap();
    let cargo_home = std::env::var_os("CARGO_HOME")
        .map(std::path::PathBuf::from)
        .unwrap_or_else(|| std::path::PathBuf::from(std::env::var_os("HOME").unwrap()).join(".cargo"));
    let forbidden = [checkout.to_string_lossy().into_owned(), cargo_home.to_string_lossy().into_owned()];
    for program in ["dynotraj-firmware", "dynotraj-firmware-model", "dynotraj-embassy", "dynotraj-kernels"] {
        let image = std::fs::read(firmware_program(program)).unwrap();
        for path in &forbidden {
            assert!(!contains(&image, path.as_bytes()), "{program} names {path}: it depends on where it was built");
        }
        assert!(contains(&image, b"/dynotraj/"), "{program}: no remapped source path at all (is the remap applied?)");
    }
}
