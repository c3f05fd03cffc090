//! A stack overflow on the MCU faults instead of overwriting the statics: the firmware crate's
//! `dynotraj-overflow` program (linked with flip-link, as every firmware program is) patterns a
//! static in `.data` and one in `.bss`, recurses until the stack runs out, and must end in the
//! HardFault handler with exit status 1, saying it was a stack overflow and that both statics
//! kept their patterns.

use std::process::Command;

use dynotraj_tests::edge_fixture::firmware_program;

#[test]
fn stack_overflow_faults_and_leaves_the_statics_intact() {
    let script = dynotraj_tests::manifest_dir().join("../scripts/qemu-edge.sh");
    let out = Command::new("timeout")
        .arg("120")
        .arg("bash")
        .arg(script)
        .args(["--port", "none", "--elf"])
        .arg(firmware_program("dynotraj-overflow"))
        .output()
        .unwrap();
    let log = format!("{}{}", String::from_utf8_lossy(&out.stdout), String::from_utf8_lossy(&out.stderr));
    println!("{log}");
    assert_eq!(out.status.code(), Some(1), "exit status 1 from the HardFault handler: {log}");
    assert!(log.contains("recursing until the stack runs out"), "the program started: {log}");
    let fault = log.lines().find(|l| l.contains("HardFault")).expect("the HardFault handler ran");
    assert!(fault.contains("HardFault: stack overflow"), "the fault is recognised as a stack overflow: {fault}");
    assert!(log.contains("statics intact (256 words of .data, 256 of .bss checked)"), "statics untouched: {log}");
    assert!(!log.contains("CORRUPTED"), "{log}");
    let depth: u32 = log
        .lines()
        .find_map(|l| l.split("fault at recursion depth ").nth(1))
        .and_then(|d| d.trim().parse().ok())
        .expect("the depth reached");
    // 256-byte frames in the stack region of a program with 2 KiB of statics: the recursion
    // used nearly all of the 128 KiB of RAM before it faulted.
    assert!(depth >= 400, "the recursion went deep before it faulted ({depth} levels)");
}
