//! Ending a program under QEMU through semihosting: status 0 on success, 1 on a failure, a
//! panic (`panic-semihosting`'s exit feature) or a HardFault, so that a fault is a failed test.

use core::cell::Cell;

use cortex_m::interrupt::Mutex;
use cortex_m_semihosting::{debug, hprintln};
use panic_semihosting as _;

/// Exits with status 0.
pub fn succeed() -> ! {
    debug::exit(debug::EXIT_SUCCESS);
    halt()
}

/// Logs `why` and exits with status 1.
pub fn fail(why: &str) -> ! {
    fail_with(format_args!("{why}"))
}

/// Logs `why` and exits with status 1.
pub fn fail_with(why: core::fmt::Arguments<'_>) -> ! {
    hprintln!("dynotraj-firmware: error: {}", why);
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

/// A program's report after a HardFault.
type Report = Option<fn()>;

/// What the program wants said after a HardFault, before the exit.
static LAST_WORDS: Mutex<Cell<Report>> = Mutex::new(Cell::new(None));

/// Has the HardFault handler call `report` before it exits (a program checking its statics
/// after a fault, for instance). It runs on a fresh stack.
pub fn on_hard_fault(report: fn()) {
    cortex_m::interrupt::free(|cs| LAST_WORDS.borrow(cs).set(Some(report)));
}

// The HardFault vector (cortex-m-rt's vector table calls the symbol `HardFault`). A stack
// overflow faults when the stack runs off the start of RAM (flip-link's layout), and the
// exception frame could then not be stacked either: Rust code would fault again on its first
// push and lock the core up. So this entry, in assembly, takes the faulting stack pointer
// (r0) and, when the frame lies within the stack region, the faulting pc (r1, else 0), then
// moves MSP back to the top of the stack region, giving up the faulted stack (the program
// ends here), and only then enters Rust.
core::arch::global_asm!(
    ".section .HardFault.user, \"ax\"",
    ".global HardFault",
    ".type HardFault,%function",
    ".thumb_func",
    "HardFault:",
    "tst lr, #4",
    "ite eq",
    "mrseq r0, msp",
    "mrsne r0, psp",
    "movs r1, #0",
    "movw r2, #:lower16:_stack_end",
    "movt r2, #:upper16:_stack_end",
    "cmp r0, r2",
    "it hs",
    "ldrhs r1, [r0, #24]",
    "movw r2, #:lower16:_stack_start",
    "movt r2, #:upper16:_stack_start",
    "msr msp, r2",
    "b {handler}",
    ".size HardFault, . - HardFault",
    handler = sym hard_fault,
);

/// The HardFault handler proper, on a fresh stack: says what faulted and exits with status 1.
/// `sp` is the stack pointer at the fault, `pc` the faulting instruction (0 when the frame
/// could not be stacked).
extern "C" fn hard_fault(sp: u32, pc: u32) -> ! {
    let limit = crate::stack::limit();
    if (sp as usize) < limit {
        hprintln!(
            "dynotraj-firmware: HardFault: stack overflow (sp {:#010x} below the stack's limit {:#010x})",
            sp,
            limit
        );
    } else {
        hprintln!("dynotraj-firmware: HardFault at pc {:#010x} (sp {:#010x})", pc, sp);
    }
    if let Some(report) = cortex_m::interrupt::free(|cs| LAST_WORDS.borrow(cs).get()) {
        report();
    }
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

/// Where the program rests if semihosting did not end it (no debugger attached).
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
