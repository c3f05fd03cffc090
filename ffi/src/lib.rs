//! dynotraj-ffi: the edge [`Session`] for ECU code written in C.
//!
//! A C program links `libdynotraj_ffi.a` and includes `ffi/include/dynotraj.h` (generated from
//! this file by `scripts/gen-header.sh`). It owns the session's memory
//! ([`DYNOTRAJ_SESSION_SIZE`] bytes aligned to [`DYNOTRAJ_SESSION_ALIGN`], normally a static),
//! hands received link bytes to [`dynotraj_session_feed`] and gets every reply as one encoded
//! wire frame through its [`DynotrajWriteFn`], ready to forward to the host verbatim. Nothing
//! allocates; every function validates its pointers and lengths and answers with a
//! [`DynotrajStatus`], and no input makes the session panic (the core is built to that rule),
//! so no panic can reach the C side.
//!
//! All of the ABI's `unsafe` is in this crate. It is `no_std`: the same code builds the
//! staticlib for `thumbv7em-none-eabihf` (which brings its own panic handler) and for the host
//! (which links std).
#![no_std]

#[cfg(not(target_os = "none"))]
extern crate std;

use core::ffi::c_void;

use dynotraj_core::wire::ComputeUnit;
use dynotraj_edge::embedded_io;
use dynotraj_edge::{Clock, RunError, Session, Transport};

/// Bytes of a `DynotrajSession` on targets with 32-bit pointers (Cortex-M).
#[cfg(target_pointer_width = "32")]
pub const DYNOTRAJ_SESSION_SIZE: usize = 107_248;
/// Bytes of a `DynotrajSession` on targets with 64-bit pointers (the host).
#[cfg(target_pointer_width = "64")]
pub const DYNOTRAJ_SESSION_SIZE: usize = 108_488;
/// Alignment a `DynotrajSession`'s memory must have, bytes.
pub const DYNOTRAJ_SESSION_ALIGN: usize = 8;

// A build whose session does not match the header's figures fails here rather than writing
// past the caller's memory (the header states the figures of every supported target).
const _: () = assert!(core::mem::size_of::<DynotrajSession>() == DYNOTRAJ_SESSION_SIZE);
const _: () = assert!(core::mem::align_of::<DynotrajSession>() == DYNOTRAJ_SESSION_ALIGN);

/// `DynotrajConfig::clock_unit`: the clock counts nanoseconds.
pub const DYNOTRAJ_UNIT_NANOSECONDS: u32 = 0;
/// `DynotrajConfig::clock_unit`: the clock counts instructions or cycles (a cycle counter
/// such as the Cortex-M DWT's CYCCNT).
pub const DYNOTRAJ_UNIT_INSTRUCTIONS: u32 = 1;

/// What a call did.
#[repr(C)]
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DynotrajStatus {
    /// Done.
    Ok = 0,
    /// The host said goodbye: every byte before it was taken and answered, the rest of the
    /// chunk was not. Not an error: call `dynotraj_session_finish` next.
    Ended = 1,
    /// A pointer that must not be null was null (a zero length allows a null buffer).
    NullPointer = 2,
    /// The session's memory is not aligned to `DYNOTRAJ_SESSION_ALIGN`, or the configuration
    /// not to its own type.
    Misaligned = 3,
    /// An argument is out of range: an unknown clock unit, or a length over `PTRDIFF_MAX`.
    InvalidArgument = 4,
    /// The write callback returned non-zero. The reply it was given and the rest of the chunk
    /// were dropped; the session stays consistent and takes the next chunk.
    WriteFailed = 5,
    /// A reply could not be encoded (no wire message is larger than a frame, so this is not
    /// expected); the rest of the chunk was dropped.
    EncodeFailed = 6,
    /// The model blob is not a valid blob for this build; the previous model stays in use.
    InvalidModel = 7,
}

/// Sends one encoded wire frame (`frame`, `len` bytes, delimiters included) to the host;
/// returns 0 when it was sent, anything else when it could not be. `frame` is valid only during
/// the call.
pub type DynotrajWriteFn = Option<unsafe extern "C" fn(ctx: *mut c_void, frame: *const u8, len: usize) -> i32>;

/// Reads a monotonic counter (nanoseconds or instructions, see `DynotrajConfig::clock_unit`);
/// the session reports the difference around each frame's work as that frame's compute.
pub type DynotrajClockFn = Option<unsafe extern "C" fn(ctx: *mut c_void) -> u64>;

/// How the session reaches its platform; copied by `dynotraj_session_init`.
#[repr(C)]
#[derive(Debug, Clone, Copy)]
pub struct DynotrajConfig {
    /// Where replies go; required.
    pub write: DynotrajWriteFn,
    /// Passed to `write` as is.
    pub write_ctx: *mut c_void,
    /// The compute clock; null reports zero compute for every frame (outputs that must match
    /// another build byte for byte).
    pub clock: DynotrajClockFn,
    /// Passed to `clock` as is.
    pub clock_ctx: *mut c_void,
    /// `DYNOTRAJ_UNIT_NANOSECONDS` or `DYNOTRAJ_UNIT_INSTRUCTIONS`: what one count of `clock`
    /// is, as the host is told.
    pub clock_unit: u32,
}

/// One edge session in caller-owned memory: opaque to C, which allocates
/// `DYNOTRAJ_SESSION_SIZE` bytes aligned to `DYNOTRAJ_SESSION_ALIGN` and passes a pointer.
#[derive(Debug)]
pub struct DynotrajSession {
    session: Session<'static>,
    io: Io,
}

/// The C side's callbacks, checked.
#[derive(Debug)]
struct Io {
    write: unsafe extern "C" fn(ctx: *mut c_void, frame: *const u8, len: usize) -> i32,
    write_ctx: *mut c_void,
    clock: DynotrajClockFn,
    clock_ctx: *mut c_void,
    unit: ComputeUnit,
    /// Bytes the C side's receiver dropped so far, as last reported.
    lost: u32,
}

/// Replies through the C side's write callback.
struct Link<'a>(&'a Io);

/// The write callback's non-zero return.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
struct WriteFailed(i32);

impl core::fmt::Display for WriteFailed {
    fn fmt(&self, f: &mut core::fmt::Formatter<'_>) -> core::fmt::Result {
        write!(f, "the write callback returned {}", self.0)
    }
}

impl core::error::Error for WriteFailed {}

impl embedded_io::Error for WriteFailed {
    fn kind(&self) -> embedded_io::ErrorKind {
        embedded_io::ErrorKind::Other
    }
}

impl embedded_io::ErrorType for Link<'_> {
    type Error = WriteFailed;
}

impl embedded_io::Read for Link<'_> {
    /// The session is fed by [`dynotraj_session_feed`]; it never reads.
    fn read(&mut self, _: &mut [u8]) -> Result<usize, WriteFailed> {
        Ok(0)
    }
}

impl embedded_io::Write for Link<'_> {
    /// Hands the whole of `bytes` to the callback: it takes a frame or fails.
    fn write(&mut self, bytes: &[u8]) -> Result<usize, WriteFailed> {
        self.write_all(bytes).map(|()| bytes.len())
    }

    fn write_all(&mut self, bytes: &[u8]) -> Result<(), WriteFailed> {
        let io = self.0;
        // SAFETY: `write` and `write_ctx` are the pair the caller of dynotraj_session_init
        // promised to be callable for the session's life; `bytes` is valid for the call.
        match unsafe { (io.write)(io.write_ctx, bytes.as_ptr(), bytes.len()) } {
            0 => Ok(()),
            e => Err(WriteFailed(e)),
        }
    }

    fn flush(&mut self) -> Result<(), WriteFailed> {
        Ok(())
    }
}

impl Transport for Link<'_> {
    fn bytes_lost(&self) -> u32 {
        self.0.lost
    }
}

/// The C side's clock; `INSTRUCTIONS` picks the unit, which the edge takes as a constant.
struct CallbackClock<'a, const INSTRUCTIONS: bool>(&'a Io);

impl<const INSTRUCTIONS: bool> Clock for CallbackClock<'_, INSTRUCTIONS> {
    const UNIT: ComputeUnit = if INSTRUCTIONS { ComputeUnit::Instructions } else { ComputeUnit::Nanoseconds };

    fn now(&mut self) -> u64 {
        let io = self.0;
        // SAFETY: as for `write` in `Link::write_all`: the pair the caller promised callable.
        io.clock.map_or(0, |f| unsafe { f(io.clock_ctx) })
    }
}

impl From<RunError<WriteFailed>> for DynotrajStatus {
    fn from(e: RunError<WriteFailed>) -> Self {
        match e {
            RunError::Transport(_) => Self::WriteFailed,
            RunError::Wire(_) => Self::EncodeFailed,
        }
    }
}

/// Writes a new session at `slot`: a copy of the session [`Session::new`] builds at compile
/// time, so no stack temporary of the session's size (about 100 KiB, more than an ECU's
/// stack) is ever built; the image it is copied from is read-only data of the library.
///
/// # Safety
/// `slot` is valid for writes of a session and aligned.
unsafe fn write_new_session(slot: *mut Session<'static>) {
    // SAFETY: the caller's promise.
    unsafe { slot.write(const { Session::new() }) }
}

/// The session behind `session`, checked for null and alignment.
///
/// # Safety
/// A non-null, aligned `session` points to a session initialised by `dynotraj_session_init`
/// that nothing else uses during `'a`.
unsafe fn session_mut<'a>(session: *mut DynotrajSession) -> Result<&'a mut DynotrajSession, DynotrajStatus> {
    if session.is_null() {
        return Err(DynotrajStatus::NullPointer);
    }
    if !session.is_aligned() {
        return Err(DynotrajStatus::Misaligned);
    }
    // SAFETY: non-null and aligned; initialised and unshared by the caller's promise.
    Ok(unsafe { &mut *session })
}

/// `len` bytes at `bytes`, checked: null is allowed for an empty buffer only.
///
/// # Safety
/// A non-null `bytes` points to `len` readable bytes that stay unchanged during `'a`.
unsafe fn bytes_in<'a>(bytes: *const u8, len: usize) -> Result<&'a [u8], DynotrajStatus> {
    if len == 0 {
        return Ok(&[]);
    }
    if bytes.is_null() {
        return Err(DynotrajStatus::NullPointer);
    }
    if isize::try_from(len).is_err() {
        return Err(DynotrajStatus::InvalidArgument);
    }
    // SAFETY: non-null, u8 needs no alignment, the length fits isize, and the caller promises
    // `len` readable bytes.
    Ok(unsafe { core::slice::from_raw_parts(bytes, len) })
}

/// Initialises a session in `session`'s memory with `config`'s callbacks: no camera model yet,
/// no learned model (constant-velocity forecasts), models over the link refused. Also starts a
/// used session afresh (its model is dropped).
///
/// # Safety
/// - `session` points to `DYNOTRAJ_SESSION_SIZE` writable bytes that no other call uses
///   meanwhile; what they held is overwritten, not dropped.
/// - `config` points to a readable `DynotrajConfig`, whose `write` (and `clock`, when not
///   null) may be called with its context from any later call on this session until it is
///   initialised again.
/// - The stack has room for one session (about 100 KiB) beside the caller's frames.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn dynotraj_session_init(
    session: *mut DynotrajSession,
    config: *const DynotrajConfig,
) -> DynotrajStatus {
    if session.is_null() || config.is_null() {
        return DynotrajStatus::NullPointer;
    }
    if !session.is_aligned() || !config.is_aligned() {
        return DynotrajStatus::Misaligned;
    }
    // SAFETY: non-null, aligned and readable (the caller's promise); every bit pattern of the
    // fields is valid (a null callback is None).
    let config = unsafe { *config };
    let Some(write) = config.write else { return DynotrajStatus::NullPointer };
    let unit = match config.clock_unit {
        DYNOTRAJ_UNIT_NANOSECONDS => ComputeUnit::Nanoseconds,
        DYNOTRAJ_UNIT_INSTRUCTIONS => ComputeUnit::Instructions,
        _ => return DynotrajStatus::InvalidArgument,
    };
    let io = Io { write, write_ctx: config.write_ctx, clock: config.clock, clock_ctx: config.clock_ctx, unit, lost: 0 };
    // SAFETY: `session` is non-null, aligned and writable for a whole DynotrajSession (the
    // caller's promise); the fields are written through raw pointers, never read.
    unsafe {
        (&raw mut (*session).io).write(io);
        write_new_session(&raw mut (*session).session);
    }
    DynotrajStatus::Ok
}

/// Forecasts the agents of the model blob's dynamics (vehicles and cyclists: unicycle;
/// pedestrians: single integrator) with `blob` (`len` bytes, int8 or f32) from now on, instead
/// of constant velocity. Call once per agent type; a blob of a type already set replaces it.
///
/// # Safety
/// - `session` was initialised by `dynotraj_session_init` and no other call uses it meanwhile.
/// - `blob` points to `len` readable bytes that stay valid and unchanged until the session is
///   initialised again or given another model (normally a blob in flash).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn dynotraj_session_set_model(
    session: *mut DynotrajSession,
    blob: *const u8,
    len: usize,
) -> DynotrajStatus {
    // SAFETY: the caller's promises, passed on.
    let (this, blob) = match unsafe { (session_mut(session), bytes_in(blob, len)) } {
        (Ok(this), Ok(blob)) => (this, blob),
        (Err(e), _) | (_, Err(e)) => return e,
    };
    match this.session.set_model(blob) {
        Ok(()) => DynotrajStatus::Ok,
        Err(_) => DynotrajStatus::InvalidModel,
    }
}

/// Takes `len` received bytes (any split of the stream: frames may span calls) and answers
/// every whole message in them, each reply a call of the write callback before this returns.
/// `bytes_lost` is how many bytes the caller's receiver dropped so far (overruns), reported to
/// the host with the decoder's own drops; 0 when it cannot lose bytes.
///
/// Returns `DYNOTRAJ_STATUS_ENDED` once the host said goodbye (and for every call after).
///
/// # Safety
/// - `session` was initialised by `dynotraj_session_init` and no other call uses it meanwhile.
/// - `bytes` points to `len` readable bytes (or is anything when `len` is 0).
#[unsafe(no_mangle)]
pub unsafe extern "C" fn dynotraj_session_feed(
    session: *mut DynotrajSession,
    bytes: *const u8,
    len: usize,
    bytes_lost: u32,
) -> DynotrajStatus {
    // SAFETY: the caller's promises, passed on.
    let (this, chunk) = match unsafe { (session_mut(session), bytes_in(bytes, len)) } {
        (Ok(this), Ok(chunk)) => (this, chunk),
        (Err(e), _) | (_, Err(e)) => return e,
    };
    if this.session.ended() {
        return DynotrajStatus::Ended;
    }
    this.io.lost = bytes_lost;
    let DynotrajSession { session, io } = this;
    let io = &*io;
    let result = match io.unit {
        ComputeUnit::Nanoseconds => session.on_bytes(chunk, &mut Link(io), &mut CallbackClock::<false>(io)),
        ComputeUnit::Instructions => session.on_bytes(chunk, &mut Link(io), &mut CallbackClock::<true>(io)),
    };
    match result {
        Ok(()) if session.ended() => DynotrajStatus::Ended,
        Ok(()) => DynotrajStatus::Ok,
        Err(e) => e.into(),
    }
}

/// Ends the session's stream: unless the host said goodbye, an unfinished frame's bytes are
/// counted as dropped; then the edge's link statistics go out through the write callback (the
/// session's last reply). Initialise the session again before another stream.
///
/// # Safety
/// `session` was initialised by `dynotraj_session_init` and no other call uses it meanwhile.
#[unsafe(no_mangle)]
pub unsafe extern "C" fn dynotraj_session_finish(session: *mut DynotrajSession) -> DynotrajStatus {
    // SAFETY: the caller's promise, passed on.
    let this = match unsafe { session_mut(session) } {
        Ok(this) => this,
        Err(e) => return e,
    };
    match this.session.finish(&mut Link(&this.io)) {
        Ok(()) => DynotrajStatus::Ok,
        Err(e) => e.into(),
    }
}

/// The staticlib for a bare-metal target has no std to take a panic. None can happen: the core
/// and this crate are written so that no input panics, and such targets build with
/// panic=abort. Reaching this is therefore a bug, and it traps (an undefined instruction) so the
/// C side's fault handler learns of it instead of the program spinning unseen.
#[cfg(target_os = "none")]
#[panic_handler]
fn panic(_: &core::panic::PanicInfo<'_>) -> ! {
    loop {
        #[cfg(target_arch = "arm")]
        // SAFETY: UDF raises an UsageFault (escalated to HardFault); it touches no memory.
        unsafe {
            core::arch::asm!("udf #0", options(nomem, nostack));
        }
    }
}

#[cfg(test)]
#[allow(clippy::unwrap_used, clippy::panic, clippy::indexing_slicing)]
mod tests;
