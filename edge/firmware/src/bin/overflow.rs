//! A stack overflow on purpose: the program fills two statics (one in `.data`, one in `.bss`)
//! with known patterns, then recurses until the stack runs out. Linked with flip-link, the
//! stack lies below the statics and runs off the start of RAM: the core faults, the HardFault
//! handler says so, checks both patterns and exits with status 1. Run by
//! tests/tests/stack_overflow_qemu.rs, which asserts the fault, the exit status and that the
//! statics came through untouched.
#![no_std]
#![no_main]

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use dynotraj_firmware::exit::{fail, on_hard_fault};
use dynotraj_firmware::stack;

// The device interrupt vectors: none is used.
dynotraj_firmware::device_interrupts!();

/// Words of each guarded static.
const WORDS: usize = 256;

/// The pattern of word `i` of a guarded static.
const fn pattern(seed: u32, i: usize) -> u32 {
    (seed ^ (i as u32).wrapping_mul(0x9E37_79B9)).rotate_left(i as u32 % 32)
}

const fn patterned(seed: u32) -> [u32; WORDS] {
    let mut a = [0; WORDS];
    let mut i = 0;
    while i < WORDS {
        a[i] = pattern(seed, i);
        i += 1;
    }
    a
}

const DATA_SEED: u32 = 0xDA7A_5EED;
const BSS_SEED: u32 = 0xB55_5EED;

/// Initialised from flash at boot: `.data`.
static DATA_GUARD: [AtomicU32; WORDS] = {
    let p = patterned(DATA_SEED);
    let mut a = [const { AtomicU32::new(0) }; WORDS];
    let mut i = 0;
    while i < WORDS {
        a[i] = AtomicU32::new(p[i]);
        i += 1;
    }
    a
};
/// Zeroed at boot (`.bss`), patterned by `main`.
static BSS_GUARD: [AtomicU32; WORDS] = [const { AtomicU32::new(0) }; WORDS];
/// Deepest recursion reached.
static DEPTH: AtomicU32 = AtomicU32::new(0);

#[entry]
fn main() -> ! {
    for (i, w) in BSS_GUARD.iter().enumerate() {
        w.store(pattern(BSS_SEED, i), Ordering::Relaxed);
    }
    on_hard_fault(report);
    hprintln!(
        "dynotraj-overflow: {} B of stack; statics patterned; recursing until the stack runs out",
        stack::available()
    );
    core::hint::black_box(descend(1));
    fail("the recursion returned: the stack never overflowed")
}

/// Recurses with a 256-byte frame per level; never returns in practice.
#[inline(never)]
fn descend(depth: u32) -> u32 {
    let mut frame = [0u8; 256];
    frame[0] = depth as u8;
    core::hint::black_box(&mut frame);
    DEPTH.store(depth, Ordering::Relaxed);
    if depth == u32::MAX {
        return 0;
    }
    descend(depth + 1).wrapping_add(u32::from(frame[1]))
}

/// Counts the words of a guarded static that lost their pattern.
fn damaged(guard: &[AtomicU32; WORDS], seed: u32) -> usize {
    guard.iter().enumerate().filter(|(i, w)| w.load(Ordering::Relaxed) != pattern(seed, *i)).count()
}

/// The HardFault handler's last words: how deep the recursion went and whether the statics
/// kept their patterns.
fn report() {
    let (data, bss) = (damaged(&DATA_GUARD, DATA_SEED), damaged(&BSS_GUARD, BSS_SEED));
    hprintln!("dynotraj-overflow: fault at recursion depth {}", DEPTH.load(Ordering::Relaxed));
    if data == 0 && bss == 0 {
        hprintln!("dynotraj-overflow: statics intact ({} words of .data, {} of .bss checked)", WORDS, WORDS);
    } else {
        hprintln!(
            "dynotraj-overflow: statics CORRUPTED: {} of {} .data words, {} of {} .bss words",
            data,
            WORDS,
            bss,
            WORDS
        );
    }
}
