//! What the firmware's programs share on QEMU's mps2-an386: the instruction clock, stack
//! painting, the semihosting logger, UART0's registers, the device interrupt vectors, and the
//! semihosting exit (a panic or a HardFault is exit status 1).
#![no_std]

pub mod clock;
pub mod exit;
pub mod interrupts;
pub mod logger;
pub mod session;
pub mod stack;
pub mod uart0;

/// The model blobs linked into flash by `DYNOTRAJ_FW_MODEL` at build time, one per agent type
/// (empty: none; no blob at all: constant-velocity forecasts).
pub static LINKED_MODELS: [&[u8]; 2] =
    [include_bytes!(concat!(env!("OUT_DIR"), "/model0.bin")), include_bytes!(concat!(env!("OUT_DIR"), "/model1.bin"))];
