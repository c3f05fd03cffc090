//! The memory a firmware image uses, from its ELF sections and the peak stack it reports,
//! held against a golden file beside the firmware crate.

use std::path::Path;

use crate::edge_fixture::elf_sections;

/// A kibibyte.
pub const KIB: u32 = 1024;

/// Prints the image's sections and peak stack, checks flash against the budget and the figures
/// against `golden` (a file beside the firmware crate) when given, and returns the RAM used
/// (.data + .bss + peak stack).
#[must_use]
pub fn check_memory(elf: &Path, log: &str, golden: Option<&str>) -> u32 {
    let peak: u32 = log
        .lines()
        .find_map(|l| l.split_once(": peak stack ").map(|(_, rest)| rest))
        .and_then(|l| l.split(' ').next())
        .and_then(|n| n.parse().ok())
        .expect("the firmware reports its peak stack");
    let sections = elf_sections(elf);
    let size = |name: &str| sections.iter().find(|(n, _)| n == name).map_or(0, |(_, s)| *s);
    let figures = [
        ("vector_table", size(".vector_table")),
        ("text", size(".text")),
        ("rodata", size(".rodata")),
        ("data", size(".data")),
        ("bss", size(".bss") + size(".uninit")),
        ("peak_stack", peak),
    ];
    let flash = size(".vector_table") + size(".text") + size(".rodata") + size(".data");
    let ram = size(".data") + size(".bss") + size(".uninit") + peak;
    for (n, v) in figures {
        println!("{n:<12} {v:>7} B");
    }
    println!("flash {flash} B of {} B; RAM {ram} B of {} B", 512 * KIB, 128 * KIB);
    assert!(flash <= 512 * KIB, "flash {flash} B over the 512 KiB budget");

    let Some(golden) = golden else { return ram };
    let golden_path = crate::manifest_dir().join("../edge/firmware").join(golden);
    let now: String = figures.iter().map(|(n, v)| format!("{n} {v}\n")).collect();
    if std::env::var_os("DYNOTRAJ_BLESS").is_some() {
        std::fs::write(
            &golden_path,
            format!("# bytes; checked by the QEMU tests (DYNOTRAJ_BLESS=1 rewrites it)\n{now}"),
        )
        .unwrap();
        return ram;
    }
    let golden = std::fs::read_to_string(&golden_path).unwrap();
    for line in golden.lines().filter(|l| !l.starts_with('#')) {
        let (name, value) = line.split_once(' ').unwrap();
        let want: f64 = value.trim().parse().unwrap();
        let got = f64::from(figures.iter().find(|(n, _)| *n == name).unwrap().1);
        // 2% or 256 B either way: a change to core that moves a figure further must be looked
        // at, and blessed.
        assert!(
            (got - want).abs() <= (0.02 * want).max(256.0),
            "{name}: {got} B, golden {want} B (DYNOTRAJ_BLESS=1 after a deliberate change)"
        );
    }
    ram
}
