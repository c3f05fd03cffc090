//! SMLAD products (ARMv7E-M DSP extension). The only `unsafe` in this crate: two one-instruction
//! `asm!` wrappers (SXTB16, register to register) and two multiply-accumulate loops ([`block4`],
//! [`block1`]) that read rows of weights through raw pointers, each called right after a safe
//! check that the rows it reads are inside their slice. SMLAD may set the sticky Q flag on
//! overflow, which nothing here or in inference reads. The weights are read with unaligned word
//! loads, which the M4 performs while the unaligned-access trap (SCB CCR.UNALIGN_TRP) is off, as
//! it is out of reset; the activations' groups are word-aligned, as LDRD needs.
#![allow(unsafe_code)]

use core::arch::asm;

use dynotraj_core::model::kernel::MAX_AFFINE_IN;

/// Groups of four activations unpacked once per call: an `x` of up to this many groups is
/// unpacked into a buffer of this size (the recurrent inputs of the 8- and 16-wide networks)...
const TINY_GROUPS: usize = 4;
/// ... of up to this many into one of this size (every input of those networks), a longer one
/// into one of [`LONG_GROUPS`] (clearing the long buffer on every call would cost more than a
/// small network's products).
const SHORT_GROUPS: usize = 12;
/// Groups of the longest input.
const LONG_GROUPS: usize = MAX_AFFINE_IN / 4;

/// Bytes 0 and 2 of `v`, sign-extended into the low and high 16-bit lanes.
#[inline(always)]
fn even_lanes(v: u32) -> u32 {
    let out: u32;
    // SAFETY: SXTB16 is a register-to-register instruction of ARMv7E-M (the `smlad` feature is
    // enabled only for such cores); it touches no memory and no flags.
    unsafe {
        asm!("sxtb16 {o}, {v}", o = lateout(reg) out, v = in(reg) v, options(pure, nomem, nostack, preserves_flags))
    };
    out
}

/// Bytes 1 and 3 of `v`, sign-extended into the low and high 16-bit lanes.
#[inline(always)]
fn odd_lanes(v: u32) -> u32 {
    let out: u32;
    // SAFETY: as in `even_lanes`; the rotation is part of the instruction.
    unsafe {
        asm!("sxtb16 {o}, {v}, ror #8", o = lateout(reg) out, v = in(reg) v, options(pure, nomem, nostack, preserves_flags))
    };
    out
}

/// The product of the remainder (fewer than four) of one row with that of `x`.
#[inline(always)]
fn tail(w: &[u8], x: &[i8]) -> i32 {
    w.iter().zip(x).fold(0i32, |acc, (&a, &b)| acc.wrapping_add(i32::from(a as i8).wrapping_mul(i32::from(b))))
}

/// See [`dynotraj_core::model::Int8Dot::rows`].
pub fn rows(w: &[u8], stride: usize, x: &[i8], out: &mut [i32]) {
    if x.len() <= 4 * TINY_GROUPS {
        rows_unpacked::<TINY_GROUPS>(w, stride, x, out);
    } else if x.len() <= 4 * SHORT_GROUPS {
        rows_unpacked::<SHORT_GROUPS>(w, stride, x, out);
    } else {
        rows_unpacked::<LONG_GROUPS>(w, stride, x, out);
    }
}

/// [`rows`] with `x` unpacked into `G` groups of lane pairs first (each group unpacked once for
/// all rows), then the rows four at a time through [`block4`] and one at a time through
/// [`block1`] over the whole groups, and the remainder of each row (fewer than four columns) in
/// plain arithmetic. Addition modulo 2^32 is the same in any order, so the sums are the portable
/// code's.
fn rows_unpacked<const G: usize>(w: &[u8], stride: usize, x: &[i8], out: &mut [i32]) {
    let len = x.len();
    let whole = len - len % 4;
    let n = whole / 4;
    let mut groups = [[0u32; 2]; G];
    let (Some(xw), Some(xr)) = (x.get(..whole), x.get(whole..)) else { return };
    if n > G {
        return;
    }
    for (g, b) in groups.iter_mut().zip(xw.chunks_exact(4)) {
        if let Ok(b) = <[i8; 4]>::try_from(b) {
            let v = u32::from_le_bytes(b.map(|v| v as u8));
            *g = [even_lanes(v), odd_lanes(v)];
        }
    }
    let blocks = out.len() / 4;
    let (blocked, rest) = out.split_at_mut(4 * blocks);
    if n == 0 {
        blocked.fill(0);
    } else if blocks > 0 {
        // The blocks read up to the whole groups of row 4 * blocks - 1.
        let Some(span) = (4 * blocks - 1).checked_mul(stride).and_then(|s| s.checked_add(whole)) else { return };
        if w.len() < span {
            return;
        }
        // SAFETY: `w` holds the whole groups of every row of the blocks (checked just above),
        // `groups` holds n >= 1 groups (n <= G), `stride` is the distance between rows, and
        // `blocked` is 4 * blocks >= 4 aligned i32.
        unsafe { blocks4(w.as_ptr(), stride, groups.as_ptr(), n, blocked.as_mut_ptr(), blocks) };
    }
    let mut start = 4 * blocks * stride;
    for o in rest {
        let Some(row) = w.get(start..) else { return };
        *o = if n > 0 && row.len() >= whole {
            // SAFETY: `row` holds the whole groups (checked in the condition), `groups` holds
            // n >= 1 groups.
            unsafe { block1(row.as_ptr(), groups.as_ptr(), n) }
        } else {
            0
        };
        start = start.saturating_add(stride);
    }
    if !xr.is_empty() {
        for (o, row) in out.iter_mut().zip(w.chunks(stride.max(1))) {
            *o = o.wrapping_add(tail(row.get(whole..len).unwrap_or(&[]), xr));
        }
    }
}

/// The sums of `blocks` blocks of four rows of `4 * n` weights (rows `stride` bytes apart from
/// `p` on) with `n` groups of unpacked activations at `g`, written to `out[0..4 * blocks]`: per
/// group a doubleword load of the activations, and per row a word load (unaligned loads are
/// allowed on the M4), two unpacks and two SMLADs. The inner loop needs every allocatable
/// register, so the block loop keeps its state in five words of stack.
///
/// # Safety
/// `n >= 1` and `blocks >= 1`; the first `4 * n` bytes of each of the `4 * blocks` rows are
/// readable; `g` points to `n` readable, word-aligned groups; `out` to `4 * blocks` writable,
/// word-aligned `i32`.
#[inline(always)]
unsafe fn blocks4(p: *const u8, stride: usize, g: *const [u32; 2], n: usize, out: *mut i32, blocks: usize) {
    // SAFETY: the caller's contract. Each block's loop reads exactly its four rows' whole groups
    // and the n groups, and runs n >= 1 times (the test is at its end); the stores are the sums
    // to `out`, one block after the other, and the stack words pushed at the start, all popped
    // (sp restored) at the end. Stack layout in the block loop: [sp] the next block's first row,
    // [sp + 4] n, [sp + 8] the groups, [sp + 12] blocks left, [sp + 16] where the sums go.
    unsafe {
        asm!(
            "push {{{t}}}",
            "push {{{u}}}",
            "push {{{g}}}",
            "push {{{n}}}",
            "3:",
            "add {t}, {p}, {s}, lsl #2",
            "push {{{t}}}",
            "ldr {g}, [sp, #8]",
            "ldr {n}, [sp, #4]",
            "movs {a0}, #0",
            "movs {a1}, #0",
            "movs {a2}, #0",
            "movs {a3}, #0",
            "2:",
            "ldrd {xe}, {xo}, [{g}], #8",
            "ldr {t}, [{p}, {s}]",
            "sxtb16 {u}, {t}",
            "sxtb16 {t}, {t}, ror #8",
            "smlad {a1}, {u}, {xe}, {a1}",
            "smlad {a1}, {t}, {xo}, {a1}",
            "ldr {t}, [{p}, {s}, lsl #1]",
            "sxtb16 {u}, {t}",
            "sxtb16 {t}, {t}, ror #8",
            "smlad {a2}, {u}, {xe}, {a2}",
            "smlad {a2}, {t}, {xo}, {a2}",
            "add {t}, {p}, {s}, lsl #1",
            "ldr {t}, [{t}, {s}]",
            "sxtb16 {u}, {t}",
            "sxtb16 {t}, {t}, ror #8",
            "smlad {a3}, {u}, {xe}, {a3}",
            "smlad {a3}, {t}, {xo}, {a3}",
            "ldr {t}, [{p}], #4",
            "sxtb16 {u}, {t}",
            "sxtb16 {t}, {t}, ror #8",
            "smlad {a0}, {u}, {xe}, {a0}",
            "smlad {a0}, {t}, {xo}, {a0}",
            "subs {n}, {n}, #1",
            "bne 2b",
            "pop {{{p}}}",
            "ldr {t}, [sp, #12]",
            "strd {a0}, {a1}, [{t}]",
            "strd {a2}, {a3}, [{t}, #8]",
            "adds {t}, {t}, #16",
            "str {t}, [sp, #12]",
            "ldr {t}, [sp, #8]",
            "subs {t}, {t}, #1",
            "str {t}, [sp, #8]",
            "bne 3b",
            "add sp, sp, #16",
            p = inout(reg) p => _,
            g = inout(reg) g => _,
            n = inout(reg) n => _,
            s = in(reg) stride,
            t = inout(reg) out => _,
            u = inout(reg) blocks => _,
            a0 = out(reg) _,
            a1 = out(reg) _,
            a2 = out(reg) _,
            a3 = out(reg) _,
            xe = out(reg) _,
            xo = out(reg) _,
        );
    }
}

/// The sum of one row of `4 * n` weights at `p` with `n` groups of unpacked activations at `g`.
///
/// # Safety
/// `n >= 1`; the `4 * n` bytes at `p` are readable; `g` points to `n` readable, word-aligned
/// groups.
#[inline(always)]
unsafe fn block1(p: *const u8, g: *const [u32; 2], n: usize) -> i32 {
    let mut a = 0i32;
    // SAFETY: as in `blocks4`, for one row.
    unsafe {
        asm!(
            "2:",
            "ldrd {xe}, {xo}, [{g}], #8",
            "ldr {t}, [{p}], #4",
            "sxtb16 {u}, {t}",
            "sxtb16 {t}, {t}, ror #8",
            "smlad {a}, {u}, {xe}, {a}",
            "smlad {a}, {t}, {xo}, {a}",
            "subs {n}, {n}, #1",
            "bne 2b",
            p = inout(reg) p => _,
            g = inout(reg) g => _,
            n = inout(reg) n => _,
            a = inout(reg) a,
            xe = out(reg) _,
            xo = out(reg) _,
            t = out(reg) _,
            u = out(reg) _,
            options(nostack, readonly),
        );
    }
    a
}
