//! The dynotraj edge as Cortex-M4F firmware for QEMU's mps2-an386: the same [`Session`] as the
//! host build, over UART0, with instructions as its compute clock.
//!
//! Boot: paint the stack, start SysTick, check the instruction clock, enable the UART; then
//! serve one session (the host's `LinkStats` goodbye ends it) and exit through semihosting:
//! status 0 after a clean session, 1 after a transport or encoding failure, a panic (the
//! `panic-semihosting` exit feature) or a HardFault. The model blob named by
//! `DYNOTRAJ_FW_MODEL` at build time is linked into flash; without one the edge forecasts
//! with constant velocity. Logs go to the semihosting console (QEMU's stdout/stderr): the
//! edge's events through the `log` facade ([`logger`]), the closing summary and peak stack as
//! plain lines whatever the log level (tests/tests/edge_qemu.rs reads them).
#![no_std]
#![no_main]

mod uart;

use cortex_m_rt::entry;
use cortex_m_semihosting::hprintln;
use dynotraj_edge::{ModelStatus, Session};
use dynotraj_firmware::exit::{fail, fail_with, succeed};
use dynotraj_firmware::{clock, logger, stack};
use static_cell::ConstStaticCell;

/// The model linked into flash (empty: none).
static MODEL: &[u8] = include_bytes!(concat!(env!("OUT_DIR"), "/model.bin"));

/// The device interrupt vectors: only UART0 RX (IRQ 0) is used; IRQ 1 (UART0 TX) is not.
#[unsafe(link_section = ".vector_table.interrupts")]
#[unsafe(no_mangle)]
static __INTERRUPTS: [unsafe extern "C" fn(); 2] = [uart0_rx, DefaultHandler];

unsafe extern "C" {
    fn DefaultHandler();
}

unsafe extern "C" fn uart0_rx() {
    uart::uart0_rx();
}

/// The session, most of the RAM budget, built at compile time by the `const` [`Session::new`]:
/// the startup code copies its image into RAM, so no stack temporary of its size (about
/// 100 KiB, more than the stack) is ever built, and no `unsafe` is needed to reach it.
static SESSION: ConstStaticCell<Session<'static>> = ConstStaticCell::new(Session::new());

#[entry]
fn main() -> ! {
    stack::paint();
    let Some(mut cp) = cortex_m::Peripherals::take() else { fail("core peripherals taken twice") };
    clock::start(&mut cp.SYST);
    logger::init();
    clock::check();

    let Some(session) = SESSION.try_take() else { fail("session taken twice") };
    if !MODEL.is_empty()
        && let Err(e) = session.set_model(MODEL)
    {
        fail_with(format_args!("linked model rejected: {e:?}"));
    }
    let mut link = uart::Uart::new(&mut cp.NVIC);
    log::info!(
        "ready: model {}, int8 products {}, stack {} B, log level {}",
        describe(session.model()),
        if cfg!(feature = "dsp") { "on SMLAD" } else { "portable" },
        stack::available(),
        logger::level()
    );

    let result = session.run(&mut link, &mut clock::Instructions);

    let e = session.edge().stats();
    let l = session.link_stats();
    hprintln!(
        "dynotraj-firmware: frames estimated {} lost {} | forecasts {} (fallback {}, failed {}) | frames received \
            {} rejected {} | bytes dropped {} | uart overruns {} | rx ring high water {} B",
        e.frames_estimated,
        e.frames_lost,
        e.forecasts,
        e.forecasts_fallback,
        e.forecasts_failed,
        l.received.frames_ok,
        l.received.frames_rejected(),
        l.received.bytes_discarded,
        dynotraj_edge::Transport::bytes_lost(&link),
        link.high_water()
    );
    let peak = stack::peak();
    hprintln!("dynotraj-firmware: peak stack {} B of {} B", peak, stack::available());
    if peak >= stack::available() {
        fail("stack overflow: the stack reached the statics");
    }
    match result {
        Ok(()) => succeed(),
        Err(err) => fail_with(format_args!("session stopped: {err:?}")),
    }
}

fn describe(m: ModelStatus) -> &'static str {
    match m {
        ModelStatus::None => "none (constant velocity)",
        ModelStatus::Loaded { .. } => "linked in (int8)",
        ModelStatus::Rejected(_) => "rejected",
        ModelStatus::SignatureRejected(_) => "refused (signature)",
    }
}
