//! The edge session on Embassy, for QEMU's mps2-an386: what a user's firmware on an async
//! executor looks like. UART0's receive interrupt pushes bytes into an embassy-sync [`Pipe`]
//! (the interrupt-fed ring); one task awaits the pipe and runs the session from it
//! ([`Session::run_async`]), writing the replies to the UART (blocking); the host's goodbye ends
//! the session and the program exits through semihosting, status 0 (1 on a failure, a panic or
//! a HardFault), like the main firmware.
//!
//! The session lives in a static, as in the main firmware: the task's future holds only
//! references and the session's 256-byte read buffer.
#![no_std]
#![no_main]

use core::convert::Infallible;
use core::sync::atomic::{AtomicBool, AtomicU32, AtomicUsize, Ordering};

use cortex_m_rt::entry;
use dynotraj_edge::{Session, Transport, embedded_io, embedded_io_async};
use dynotraj_firmware::exit::fail_with;
use dynotraj_firmware::{clock, logger, session, stack, uart0};
use embassy_executor::Executor;
use embassy_sync::blocking_mutex::raw::CriticalSectionRawMutex;
use embassy_sync::pipe::Pipe;
use static_cell::{ConstStaticCell, StaticCell};

/// Bytes of the receive pipe: as the main firmware's ring (src/uart.rs), room for what the line
/// delivers while a frame is computed; when it is full the interrupt holds the sender back.
const RX_PIPE_LEN: usize = 2048;

/// The interrupt-fed ring: the UART0 receive interrupt writes, the session's task reads.
static RX: Pipe<CriticalSectionRawMutex, RX_PIPE_LEN> = Pipe::new();
/// Set by the interrupt when it paused on a full pipe.
static PAUSED: AtomicBool = AtomicBool::new(false);
/// Bytes the UART lost to overrun.
static OVERRUNS: AtomicU32 = AtomicU32::new(0);
/// Largest pipe fill seen, bytes.
static HIGH_WATER: AtomicUsize = AtomicUsize::new(0);

/// The session, built at compile time (see src/main.rs).
static SESSION: ConstStaticCell<Session<'static>> = ConstStaticCell::new(Session::new());
static EXECUTOR: StaticCell<Executor> = StaticCell::new();

// The device interrupt vectors: UART0 RX (IRQ 0) only.
dynotraj_firmware::device_interrupts!(uart0_rx);

/// UART0's receive interrupt: every received byte into the pipe (which wakes the task); on a
/// full pipe it pauses, leaving the byte in the UART, until the task has read.
unsafe extern "C" fn uart0_rx() {
    uart0::clear_rx_interrupt();
    while uart0::rx_ready() {
        if RX.is_full() {
            uart0::pause_rx();
            PAUSED.store(true, Ordering::Release);
            break;
        }
        // Never refused: only this handler writes, and the pipe had room.
        let _ = RX.try_write(&[uart0::read_byte()]);
        HIGH_WATER.fetch_max(RX.len(), Ordering::Relaxed);
    }
    if uart0::take_overrun() {
        OVERRUNS.fetch_add(1, Ordering::Relaxed);
    }
}

/// UART0 as the session's transport: reads from the pipe (awaited, or blocking), writes to the
/// UART.
struct Uart;

impl Uart {
    /// After a read: room in the pipe again, so a paused interrupt resumes.
    fn resume_if_paused(n: usize) {
        if n > 0 && PAUSED.swap(false, Ordering::AcqRel) {
            uart0::resume_rx();
        }
    }
}

impl embedded_io::ErrorType for Uart {
    type Error = Infallible;
}

impl embedded_io_async::Read for Uart {
    async fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        let n = RX.read(buf).await;
        Self::resume_if_paused(n);
        Ok(n)
    }
}

impl embedded_io::Read for Uart {
    /// For callers without an executor; the task awaits the pipe instead.
    fn read(&mut self, buf: &mut [u8]) -> Result<usize, Infallible> {
        loop {
            if let Ok(n) = RX.try_read(buf) {
                Self::resume_if_paused(n);
                return Ok(n);
            }
            if buf.is_empty() {
                return Ok(0);
            }
            // As in src/uart.rs: a byte arriving between the check and the WFI still wakes it.
            cortex_m::interrupt::free(|_| {
                if RX.is_empty() {
                    cortex_m::asm::wfi();
                }
            });
        }
    }
}

impl embedded_io::Write for Uart {
    fn write(&mut self, bytes: &[u8]) -> Result<usize, Infallible> {
        uart0::write_bytes(bytes);
        Ok(bytes.len())
    }

    fn flush(&mut self) -> Result<(), Infallible> {
        Ok(())
    }
}

impl Transport for Uart {
    fn bytes_lost(&self) -> u32 {
        OVERRUNS.load(Ordering::Relaxed)
    }
}

#[entry]
fn main() -> ! {
    let (mut cp, session) = session::boot(&SESSION);
    uart0::enable(&mut cp.NVIC);
    log::info!("ready on embassy: stack {} B, log level {}", stack::available(), logger::level());

    let executor = EXECUTOR.init(Executor::new());
    executor.run(|spawner| match serve(session, Uart) {
        Ok(task) => spawner.spawn(task),
        // The task's one slot is taken only here.
        Err(e) => fail_with(format_args!("session task not spawned: {e:?}")),
    })
}

/// Runs the session from the pipe, then reports and exits.
#[embassy_executor::task]
async fn serve(session: &'static mut Session<'static>, mut link: Uart) {
    let result = session.run_async(&mut link, &mut clock::Instructions).await;
    let high_water = HIGH_WATER.load(Ordering::Relaxed);
    session::close("dynotraj-embassy", session, (link.bytes_lost(), "rx pipe", high_water), result)
}
