//! Compute measured in instructions: SysTick counts the core clock, and the runner starts QEMU
//! with `-icount shift=0`, which advances virtual time by exactly 1 ns per instruction executed.
//! mps2-an386's core clock is 25 MHz, so one SysTick count is 40 instructions. [`calibrate`]
//! checks that ratio at boot against a loop of known length.

use core::sync::atomic::{AtomicU32, Ordering};

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};
use cortex_m_rt::exception;
use dynotraj_core::wire::ComputeUnit;
use dynotraj_edge::Clock;

/// Instructions per SysTick count under `-icount shift=0` (1 ns each) at the board's 25 MHz.
pub const INSTRUCTIONS_PER_TICK: u64 = 40;
/// SysTick's 24-bit reload.
const RELOAD: u32 = 0x00FF_FFFF;

/// SysTick wraps so far.
static WRAPS: AtomicU32 = AtomicU32::new(0);

#[exception]
fn SysTick() {
    WRAPS.fetch_add(1, Ordering::Relaxed);
}

/// Starts SysTick on the core clock, free-running with its wrap interrupt.
pub fn start(syst: &mut SYST) {
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(RELOAD);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
    // The count reads 0 until the first reload: wait for it, so that counts only go down.
    while SYST::get_current() == 0 {}
}

/// Core clock counts since [`start`].
pub fn ticks() -> u64 {
    cortex_m::interrupt::free(|_| {
        let wraps = WRAPS.load(Ordering::Relaxed);
        let before = SYST::get_current();
        // A wrap whose interrupt is still pending is not in WRAPS yet; the count read after
        // seeing it pending is past the reload.
        if SCB::is_pendst_pending() {
            let after = SYST::get_current();
            ((u64::from(wraps) + 1) << 24) + u64::from(RELOAD - after)
        } else {
            (u64::from(wraps) << 24) + u64::from(RELOAD - before)
        }
    })
}

/// Instructions executed, as [`Clock`] for the edge.
pub struct Instructions;

impl Clock for Instructions {
    const UNIT: ComputeUnit = ComputeUnit::Instructions;
    fn now(&mut self) -> u64 {
        ticks() * INSTRUCTIONS_PER_TICK
    }
}

/// Loop iterations of the boot-time clock check (2 instructions each).
const CALIBRATION_LOOPS: u32 = 1_000_000;

/// Checks at boot that SysTick counts instructions (QEMU under `-icount shift=0`) and logs the
/// outcome.
pub fn check() {
    let ticks = calibrate(CALIBRATION_LOOPS);
    let expected = u64::from(2 * CALIBRATION_LOOPS) / INSTRUCTIONS_PER_TICK;
    if ticks.abs_diff(expected) * 100 <= expected {
        log::info!("clock check: {} instructions in {} SysTick counts: exact within 1%", 2 * CALIBRATION_LOOPS, ticks);
    } else {
        log::warn!(
            "clock check: {} instructions in {} SysTick counts: NOT instructions, run under -icount shift=0",
            2 * CALIBRATION_LOOPS,
            ticks
        );
    }
}

/// Runs a loop of exactly `2 * iterations` instructions (`subs`, `bne`) and returns the SysTick
/// counts it took: with `-icount shift=0` that is `2 * iterations / 40`.
fn calibrate(iterations: u32) -> u64 {
    let t0 = ticks();
    // SAFETY: a register-only countdown loop.
    unsafe {
        core::arch::asm!(
            "1:",
            "subs {n}, {n}, #1",
            "bne 1b",
            n = inout(reg) iterations => _,
            options(nomem, nostack),
        );
    }
    ticks().saturating_sub(t0)
}
