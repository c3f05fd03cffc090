//! The registers of mps2-an386's CMSDK APB UART0 (0x4000_4000), shared by the programs that
//! talk over it; each program keeps its own receive ring and interrupt handler.
//!
//! Registers (ARM CMSDK APB UART, as QEMU models it for mps2-an386): DATA +0x00, STATE +0x04 (bit 0 TX
//! full, bit 1 RX full, bit 3 RX overrun, write 1 to clear), CTRL +0x08 (bit 0 TX enable, bit 1
//! RX enable, bit 3 RX interrupt enable), INTSTATUS/INTCLEAR +0x0C (bit 1 RX), BAUDDIV +0x10.

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;

const BASE: usize = 0x4000_4000;
const DATA: usize = 0x00;
const STATE: usize = 0x04;
const CTRL: usize = 0x08;
const INTCLEAR: usize = 0x0C;
const BAUDDIV: usize = 0x10;
const STATE_TX_FULL: u32 = 1 << 0;
const STATE_RX_FULL: u32 = 1 << 1;
const STATE_RX_OVERRUN: u32 = 1 << 3;
const CTRL_TX_EN: u32 = 1 << 0;
const CTRL_RX_EN: u32 = 1 << 1;
const CTRL_RX_INT_EN: u32 = 1 << 3;
const INT_RX: u32 = 1 << 1;
/// Smallest divider the UART accepts; QEMU ignores the line rate.
const BAUD_DIVIDER: u32 = 16;

/// UART0's receive interrupt on mps2-an386 (QEMU hw/arm/mps2.c).
#[derive(Clone, Copy)]
pub struct Uart0Rx;

// SAFETY: 0 is UART0 RX's line on this board; the programs that unmask it have a vector table
// entry for it.
unsafe impl InterruptNumber for Uart0Rx {
    fn number(self) -> u16 {
        0
    }
}

fn read(reg: usize) -> u32 {
    // SAFETY: an aligned register of the UART, which exists at this address on the board.
    unsafe { core::ptr::read_volatile((BASE + reg) as *const u32) }
}

fn write(reg: usize, value: u32) {
    // SAFETY: as in `read`; the writes done here have no effect beyond the UART.
    unsafe { core::ptr::write_volatile((BASE + reg) as *mut u32, value) }
}

/// Enables the UART with its receive interrupt and unmasks that interrupt. Call once the
/// handler's ring is ready.
pub fn enable(nvic: &mut NVIC) {
    let _ = nvic;
    write(BAUDDIV, BAUD_DIVIDER);
    write(CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INT_EN);
    // SAFETY: the handler and its ring are ready (the caller's promise); unmasking cannot break
    // a critical section because none is in progress here.
    unsafe { NVIC::unmask(Uart0Rx) };
}

/// Acknowledges the receive interrupt. Call first in the handler: a byte arriving after the
/// last read raises it again.
pub fn clear_rx_interrupt() {
    write(INTCLEAR, INT_RX);
}

/// Whether a received byte waits in the UART.
pub fn rx_ready() -> bool {
    read(STATE) & STATE_RX_FULL != 0
}

/// Takes the received byte out of the UART (check [`rx_ready`] first).
pub fn read_byte() -> u8 {
    read(DATA) as u8
}

/// Whether the UART lost a byte since the last call (its overrun flag, cleared here).
pub fn take_overrun() -> bool {
    let overrun = read(STATE) & STATE_RX_OVERRUN != 0;
    if overrun {
        write(STATE, STATE_RX_OVERRUN);
    }
    overrun
}

/// Stops the receive interrupt (the ring is full): the byte stays in the UART, and the sender
/// is held back by the line until [`resume_rx`].
pub fn pause_rx() {
    write(CTRL, read(CTRL) & !CTRL_RX_INT_EN);
}

/// Restarts the receive interrupt after [`pause_rx`] and runs the handler for the byte the
/// UART kept meanwhile.
pub fn resume_rx() {
    cortex_m::interrupt::free(|_| write(CTRL, read(CTRL) | CTRL_RX_INT_EN));
    NVIC::pend(Uart0Rx);
}

/// Sends `bytes`, waiting while the UART's one-byte transmit holding register is full.
pub fn write_bytes(bytes: &[u8]) {
    for &b in bytes {
        while read(STATE) & STATE_TX_FULL != 0 {}
        write(DATA, u32::from(b));
    }
}
