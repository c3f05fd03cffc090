//! Ending a program under QEMU through semihosting: status 0 on success, 1 on a failure, a
//! panic (`panic-semihosting`'s exit feature) or a HardFault, so that a fault is a failed test.

use cortex_m_rt::{ExceptionFrame, exception};
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

#[exception]
unsafe fn HardFault(frame: &ExceptionFrame) -> ! {
    hprintln!("dynotraj-firmware: HardFault at pc {:#010x}", frame.pc());
    debug::exit(debug::EXIT_FAILURE);
    halt()
}

/// Where the program rests if semihosting did not end it (no debugger attached).
fn halt() -> ! {
    loop {
        cortex_m::asm::wfi();
    }
}
