//! Peak stack by painting: every free word of the stack region below the stack pointer gets a
//! pattern at boot; the lowest word that lost it marks the deepest the stack has been.
//!
//! The firmware is linked with flip-link (../../.cargo/config.toml): the statics sit at the
//! top of RAM and the stack grows down from just below them towards the start of RAM, so an
//! overflow runs off RAM and faults instead of overwriting a static. The stack region is
//! [`_stack_end`, `_stack_start`): flip-link sets them to the start of RAM and the start of
//! `.data`; linked without it, cortex-m-rt sets them to the end of the statics and the end of
//! RAM. Both layouts are measured the same way.

/// The paint.
const PAINT: u32 = 0x5EED_57AC;
/// Words just below the live stack left unpainted (the painting code's own frame).
const MARGIN: usize = 64;

unsafe extern "C" {
    /// Lowest address of the stack region (its limit).
    static mut _stack_end: u32;
    /// Highest address of the stack region, where the stack starts.
    static _stack_start: u32;
}

fn bottom() -> *mut u32 {
    &raw mut _stack_end
}

fn top() -> usize {
    (&raw const _stack_start) as usize
}

/// Lowest address of the stack region: a stack pointer below it has overflowed.
#[must_use]
pub fn limit() -> usize {
    bottom() as usize
}

/// Paints the free stack. Call first thing in `main`.
pub fn paint() {
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = bottom();
    while (p as usize) < sp - MARGIN * 4 {
        // SAFETY: words of the stack region below the live stack belong to no one.
        unsafe {
            p.write_volatile(PAINT);
            p = p.add(1);
        }
    }
}

/// Stack bytes available (the whole stack region).
pub fn available() -> usize {
    top() - bottom() as usize
}

/// Deepest stack use so far, bytes; equal to [`available`] when the stack reached its limit.
pub fn peak() -> usize {
    let mut p = bottom() as *const u32;
    // SAFETY: reads of RAM within the stack region.
    while (p as usize) < top() && unsafe { p.read_volatile() } == PAINT {
        p = unsafe { p.add(1) };
    }
    top() - p as usize
}
