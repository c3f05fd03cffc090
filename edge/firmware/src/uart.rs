//! CMSDK APB UART0 of mps2-an386 (0x4000_4000) as the edge's transport: an interrupt fills a
//! receive ring, the main loop drains it.
//!
//! Registers (ARM CMSDK APB UART; ../shared/TOOLCHAIN.md): DATA +0x00, STATE +0x04 (bit 0 TX
//! full, bit 1 RX full, bit 3 RX overrun, write 1 to clear), CTRL +0x08 (bit 0 TX enable, bit 1
//! RX enable, bit 3 RX interrupt enable), INTSTATUS/INTCLEAR +0x0C (bit 1 RX), BAUDDIV +0x10.
//!
//! The UART holds one received byte. The receive interrupt moves bytes into [`RX_RING_LEN`]
//! bytes of ring as they arrive, so reception never waits for the pipeline: while a frame is
//! being estimated the next frame's bytes keep arriving. When the ring is full the interrupt
//! pauses (leaves the byte in the UART, RX interrupt off) until the main loop has taken bytes:
//! the sender is then held back by the line (QEMU back-pressures its socket; on silicon that is
//! RTS flow control), and a byte the UART itself could not keep is counted from its overrun flag
//! and reported as lost.

use core::cell::UnsafeCell;
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};

use cortex_m::interrupt::InterruptNumber;
use cortex_m::peripheral::NVIC;
use dynotraj_edge::Transport;

/// Bytes of the receive ring: what a 1 Mbit/s line delivers in about 20 ms, the time a 200 MHz
/// M4 spends on a 16-object frame (edge_qemu: about 4.5 million instructions). A faster line
/// or a slower part needs more, or flow control (which the ring uses when full).
pub const RX_RING_LEN: usize = 2048;

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

// SAFETY: 0 is UART0 RX's line on this board, and the vector table has an entry for it.
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

/// Single-producer (the interrupt), single-consumer (the main loop) byte ring.
struct Ring {
    buf: UnsafeCell<[u8; RX_RING_LEN]>,
    /// Total bytes written (by the interrupt only).
    head: AtomicUsize,
    /// Total bytes read (by the main loop only).
    tail: AtomicUsize,
}

// SAFETY: the interrupt only writes slots in [head, tail + LEN) and then publishes head; the
// main loop only reads slots in [tail, head) and then publishes tail, so no slot is ever
// accessed from both sides at once.
unsafe impl Sync for Ring {}

static RX: Ring = Ring { buf: UnsafeCell::new([0; RX_RING_LEN]), head: AtomicUsize::new(0), tail: AtomicUsize::new(0) };
/// Set by the interrupt when it paused on a full ring.
static PAUSED: AtomicBool = AtomicBool::new(false);
/// Bytes the UART lost to overrun.
static OVERRUNS: AtomicU32 = AtomicU32::new(0);
/// Largest ring fill seen, bytes.
static HIGH_WATER: AtomicUsize = AtomicUsize::new(0);

/// The UART0 receive interrupt: moves every received byte into the ring.
pub extern "C" fn uart0_rx() {
    // Clear first: a byte arriving after the last read raises the interrupt again.
    write(INTCLEAR, INT_RX);
    while read(STATE) & STATE_RX_FULL != 0 {
        let head = RX.head.load(Ordering::Relaxed);
        let tail = RX.tail.load(Ordering::Acquire);
        let used = head.wrapping_sub(tail);
        if used >= RX_RING_LEN {
            write(CTRL, read(CTRL) & !CTRL_RX_INT_EN);
            PAUSED.store(true, Ordering::Release);
            break;
        }
        let byte = read(DATA) as u8;
        // SAFETY: slot `head` is free (used < LEN) and only this handler writes slots.
        unsafe { (*RX.buf.get())[head % RX_RING_LEN] = byte };
        RX.head.store(head.wrapping_add(1), Ordering::Release);
        HIGH_WATER.fetch_max(used + 1, Ordering::Relaxed);
    }
    if read(STATE) & STATE_RX_OVERRUN != 0 {
        write(STATE, STATE_RX_OVERRUN);
        OVERRUNS.fetch_add(1, Ordering::Relaxed);
    }
}

/// The UART as the edge's transport.
pub struct Uart {
    _private: (),
}

impl Uart {
    /// Enables UART0 with its receive interrupt.
    pub fn new(nvic: &mut NVIC) -> Self {
        let _ = nvic;
        write(BAUDDIV, BAUD_DIVIDER);
        write(CTRL, CTRL_TX_EN | CTRL_RX_EN | CTRL_RX_INT_EN);
        // SAFETY: the handler and the ring are ready; unmasking cannot break a critical section
        // because none is in progress here.
        unsafe { NVIC::unmask(Uart0Rx) };
        Self { _private: () }
    }

    /// Largest ring fill seen, bytes.
    pub fn high_water(&self) -> usize {
        HIGH_WATER.load(Ordering::Relaxed)
    }

    /// Takes up to `buf.len()` bytes from the ring; 0 when it is empty.
    fn take(buf: &mut [u8]) -> usize {
        let tail = RX.tail.load(Ordering::Relaxed);
        let head = RX.head.load(Ordering::Acquire);
        let n = head.wrapping_sub(tail).min(buf.len());
        for (i, b) in buf.iter_mut().take(n).enumerate() {
            // SAFETY: slots in [tail, head) were published by the handler and are not written
            // until `tail` moves past them.
            *b = unsafe { (*RX.buf.get())[tail.wrapping_add(i) % RX_RING_LEN] };
        }
        RX.tail.store(tail.wrapping_add(n), Ordering::Release);
        if n > 0 && PAUSED.swap(false, Ordering::AcqRel) {
            // Room again: resume, and run the handler for the byte the UART kept meanwhile.
            cortex_m::interrupt::free(|_| write(CTRL, read(CTRL) | CTRL_RX_INT_EN));
            NVIC::pend(Uart0Rx);
        }
        n
    }
}

impl Transport for Uart {
    type Error = core::convert::Infallible;

    /// Waits (asleep) for at least one byte; a UART never ends.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Self::Error> {
        loop {
            let n = Self::take(buf);
            if n > 0 || buf.is_empty() {
                return Ok(n);
            }
            // Sleep with interrupts masked so that a byte arriving between the check and the
            // WFI still wakes it (a pending interrupt ends WFI even when masked).
            cortex_m::interrupt::free(|_| {
                if RX.head.load(Ordering::Acquire) == RX.tail.load(Ordering::Relaxed) {
                    cortex_m::asm::wfi();
                }
            });
        }
    }

    fn write_all(&mut self, bytes: &[u8]) -> Result<(), Self::Error> {
        for &b in bytes {
            while read(STATE) & STATE_TX_FULL != 0 {}
            write(DATA, u32::from(b));
        }
        Ok(())
    }

    fn bytes_lost(&self) -> u32 {
        OVERRUNS.load(Ordering::Relaxed)
    }
}
