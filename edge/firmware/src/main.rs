//! The dynotraj edge as Cortex-M4F firmware for QEMU's mps2-an386: the same [`Session`] as the
//! host build, over UART0, with instructions as its compute clock.
//!
//! Boot: paint the stack, start SysTick, check the instruction clock, enable the UART; then
//! serve one session (the host's `LinkStats` goodbye ends it) and exit through semihosting:
//! status 0 after a clean session, 1 after a transport or encoding failure, a panic (the
//! `panic-semihosting` exit feature) or a HardFault. The model blobs named by
//! `DYNOTRAJ_FW_MODEL` at build time (one per agent type) are linked into flash; without any the
//! edge forecasts with constant velocity. Logs go to the semihosting console (QEMU's stdout/stderr): the
//! edge's events through the `log` facade ([`logger`]), the closing summary and peak stack as
//! plain lines whatever the log level (tests/tests/edge_qemu.rs reads them).
#![no_std]
#![no_main]

mod uart;

use cortex_m_rt::entry;
use dynotraj_edge::{ModelStatus, Session};
use dynotraj_firmware::{clock, logger, session, stack};
use static_cell::ConstStaticCell;

// The device interrupt vectors: UART0 RX (IRQ 0) only.
dynotraj_firmware::device_interrupts!(uart0_rx);

unsafe extern "C" fn uart0_rx() {
    uart::uart0_rx();
}

/// The session, most of the RAM budget, built at compile time by the `const` [`Session::new`]:
/// the startup code copies its image into RAM, so no stack temporary of its size (about
/// 100 KiB, more than the stack) is ever built, and no `unsafe` is needed to reach it.
static SESSION: ConstStaticCell<Session<'static>> = ConstStaticCell::new(Session::new());

#[entry]
fn main() -> ! {
    let (mut cp, session) = session::boot(&SESSION);
    let mut link = uart::Uart::new(&mut cp.NVIC);
    log::info!(
        "ready: model {}, int8 products {}, stack {} B, log level {}",
        describe(session.model()),
        if cfg!(feature = "dsp") { "on SMLAD" } else { "portable" },
        stack::available(),
        logger::level()
    );
    let result = session.run(&mut link, &mut clock::Instructions);
    let lost = dynotraj_edge::Transport::bytes_lost(&link);
    session::close("dynotraj-firmware", session, (lost, "rx ring", link.high_water()), result)
}

fn describe(m: ModelStatus) -> &'static str {
    match m {
        ModelStatus::None => "none (constant velocity)",
        ModelStatus::Loaded { .. } => "linked in (int8)",
        ModelStatus::Rejected(_) => "rejected",
        ModelStatus::SignatureRejected(_) => "refused (signature)",
    }
}
