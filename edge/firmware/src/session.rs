//! What every program that runs the edge session does around it: the boot (stack paint, clock,
//! logger, the session taken from its static, the linked model set) and the close (the session's
//! summary, the peak stack, the semihosting exit).

use core::fmt::Debug;

use cortex_m_semihosting::hprintln;
use dynotraj_edge::{RunError, Session};
use static_cell::ConstStaticCell;

use crate::exit::{fail, fail_with, succeed};
use crate::{clock, logger, stack};

/// Boots: paints the stack, starts and checks the instruction clock, installs the logger, takes
/// the session from `slot` and gives it the models linked in ([`crate::LINKED_MODELS`]). Returns
/// the core peripherals (for the UART's interrupt) and the session; any failure exits with
/// status 1.
pub fn boot(
    slot: &'static ConstStaticCell<Session<'static>>,
) -> (cortex_m::Peripherals, &'static mut Session<'static>) {
    stack::paint();
    let cp = start();
    let Some(session) = slot.try_take() else { fail("session taken twice") };
    for model in crate::LINKED_MODELS.into_iter().filter(|m| !m.is_empty()) {
        if let Err(e) = session.set_model(model) {
            fail_with(format_args!("linked model rejected: {e:?}"));
        }
    }
    (cp, session)
}

/// What every program does first: takes the core peripherals, starts and checks the instruction
/// clock and installs the logger; returns the peripherals. Any failure exits with status 1.
pub fn start() -> cortex_m::Peripherals {
    let Some(mut cp) = cortex_m::Peripherals::take() else { fail("core peripherals taken twice") };
    clock::start(&mut cp.SYST);
    logger::init();
    clock::check();
    cp
}

/// Closes: prints `program`'s summary of `session` (with the link's `bytes_lost` and the high
/// water of its receive buffer, named `buffer`) and its peak stack, then exits with status 0
/// after a clean session, 1 after `result`'s failure or a stack that reached the statics.
pub fn close<E: Debug>(
    program: &str,
    session: &Session<'_>,
    (bytes_lost, buffer, high_water): (u32, &str, usize),
    result: Result<(), RunError<E>>,
) -> ! {
    let e = session.pipeline().stats();
    let l = session.link_stats();
    hprintln!(
        "{}: frames estimated {} lost {} | forecasts {} (fallback {}, failed {}) | frames received {} rejected {} | \
            bytes dropped {} | uart overruns {} | {} high water {} B",
        program,
        e.frames_estimated,
        e.frames_lost,
        e.forecasts,
        e.forecasts_fallback,
        e.forecasts_failed,
        l.received.frames_ok,
        l.received.frames_rejected(),
        l.received.bytes_discarded,
        bytes_lost,
        buffer,
        high_water
    );
    let peak = stack::peak();
    hprintln!("{}: peak stack {} B of {} B", program, peak, stack::available());
    if peak >= stack::available() {
        fail("stack overflow: the stack reached the statics");
    }
    match result {
        Ok(()) => succeed(),
        Err(err) => fail_with(format_args!("session stopped: {err:?}")),
    }
}
