//! Peak stack use, from the paint cortex-m-rt's `paint-stack` puts on the whole stack region
//! (`_stack_end` up to `_stack_start`) before `main`: the stack grows down from `_stack_start`,
//! and the lowest word no longer holding the paint marks the deepest the stack has been.

use cortex_m_rt::STACK_PAINT_VALUE;

unsafe extern "C" {
    /// Top of the stack (its first push goes below it), from cortex-m-rt's link.x.
    static _stack_start: u32;
    /// Bottom of the stack region (just above .bss), from cortex-m-rt's link.x.
    static _stack_end: u32;
}

/// Bytes of the stack region.
pub fn region_bytes() -> usize {
    let (start, end) = bounds();
    start - end
}

/// Deepest stack use since reset, bytes.
pub fn peak_bytes() -> usize {
    let (start, end) = bounds();
    let mut addr = end;
    while addr < start {
        // SAFETY: `addr` is word-aligned (both symbols are, link.x asserts it) and inside the
        // stack region of RAM, which is always mapped; a volatile read of a u32 there is sound
        // (words above the current stack pointer are plain painted memory).
        let word = unsafe { core::ptr::read_volatile(addr as *const u32) };
        if word != STACK_PAINT_VALUE {
            break;
        }
        addr += 4;
    }
    start - addr
}

fn bounds() -> (usize, usize) {
    // Only the symbols' addresses are taken, never their values.
    (
        core::ptr::addr_of!(_stack_start) as usize,
        core::ptr::addr_of!(_stack_end) as usize,
    )
}
