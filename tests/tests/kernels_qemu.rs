//! The int8 products on the Cortex-M4 (QEMU mps2-an386): the firmware crate's `dynotraj-kernels`
//! program checks the SMLAD products (dynotraj-dsp) against the portable ones bit for bit, over
//! every input length, row counts with and without remainders and extreme bytes, and whole
//! forecasts of int8 blobs with both; it exits non-zero on any difference. Its figures
//! (instructions per forecast: f32, int8 portable, int8 on SMLAD) are printed here, not asserted.

use std::process::Command;

use dynotraj_tests::edge_fixture::firmware_program;

#[test]
fn smlad_products_equal_the_portable_ones_on_the_mcu() {
    let script = dynotraj_tests::manifest_dir().join("../scripts/qemu-edge.sh");
    let out = Command::new("bash")
        .arg(script)
        .args(["--port", "none", "--elf"])
        .arg(firmware_program("dynotraj-kernels"))
        .output()
        .unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    println!("{log}");
    assert!(out.status.success(), "dynotraj-kernels exit {}: {log}", out.status);
    assert!(log.contains("int8 products on SMLAD"), "the program was built with the SMLAD products: {log}");
    let products = log.lines().find(|l| l.contains("products:")).expect("the products line");
    assert!(products.contains(" 0 differ"), "{products}");
    let cases: usize = products.split("products: ").nth(1).and_then(|r| r.split(' ').next()).unwrap().parse().unwrap();
    // Three byte patterns for every input length 0..=MAX_AFFINE_IN.
    let expected = 3 * (dynotraj_core::model::kernel::MAX_AFFINE_IN + 1);
    assert_eq!(cases, expected, "every length checked ({cases} cases)");
    let forecasts: Vec<&str> = log.lines().filter(|l| l.contains("forecast ")).collect();
    assert_eq!(forecasts.len(), 3, "three widths timed: {log}");
    assert!(forecasts.iter().all(|l| l.contains("equal bit for bit")), "{forecasts:?}");
}
