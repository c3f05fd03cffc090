//! UART0 of mps2-an386 as the edge's transport: an interrupt fills a receive ring, the main
//! loop drains it (the registers: [`dynotraj_firmware::uart0`]).
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

use dynotraj_edge::{Transport, embedded_io};
use dynotraj_firmware::uart0;

/// Bytes of the receive ring: what a 1 Mbit/s line delivers in about 20 ms, the time a 200 MHz
/// M4 spends on a 16-object frame (edge_qemu: about 4.5 million instructions). A faster line
/// or a slower part needs more, or flow control (which the ring uses when full).
pub const RX_RING_LEN: usize = 2048;

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
    uart0::clear_rx_interrupt();
    while uart0::rx_ready() {
        let head = RX.head.load(Ordering::Relaxed);
        let tail = RX.tail.load(Ordering::Acquire);
        let used = head.wrapping_sub(tail);
        if used >= RX_RING_LEN {
            uart0::pause_rx();
            PAUSED.store(true, Ordering::Release);
            break;
        }
        let byte = uart0::read_byte();
        // SAFETY: slot `head` is free (used < LEN) and only this handler writes slots.
        unsafe { (*RX.buf.get())[head % RX_RING_LEN] = byte };
        RX.head.store(head.wrapping_add(1), Ordering::Release);
        HIGH_WATER.fetch_max(used + 1, Ordering::Relaxed);
    }
    if uart0::take_overrun() {
        OVERRUNS.fetch_add(1, Ordering::Relaxed);
    }
}

/// The UART as the edge's transport.
pub struct Uart {
    _private: (),
}

impl Uart {
    /// Enables UART0 with its receive interrupt.
    pub fn new(nvic: &mut cortex_m::peripheral::NVIC) -> Self {
        uart0::enable(nvic);
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
            uart0::resume_rx();
        }
        n
    }
}

impl embedded_io::ErrorType for Uart {
    type Error = core::convert::Infallible;
}

impl embedded_io::Read for Uart {
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
}

impl embedded_io::Write for Uart {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Self::Error> {
        uart0::write_bytes(bytes);
        Ok(bytes.len())
    }

    /// Every byte is in the UART once `write` returns: nothing is buffered here.
    fn flush(&mut self) -> Result<(), Self::Error> {
        Ok(())
    }
}

impl Transport for Uart {
    fn bytes_lost(&self) -> u32 {
        OVERRUNS.load(Ordering::Relaxed)
    }
}
