//! The stack's high-water mark: the stack's memory below the live stack is painted with a pattern at boot, and
//! the deepest the stack has been is where the paint first gives way, counted from the floor. The status frame
//! reports it (`stack_peak_bytes`), so a board shows how close it came to overflowing its stack.
//!
//! The stack runs from `_stack_start` (its top) down to `__stack_floor`: all of CCM on the board (`memory.x`), the
//! SRAM above the statics in QEMU (`qemu/memory.x`).

/// The paint: a word a live stack frame is unlikely to hold.
const PAINT: u32 = 0x5AFE_57AC;
/// Bytes below the live stack pointer left unpainted at boot (the painting function's own frame).
const MARGIN: usize = 256;

extern "C" {
    /// The lowest address of the stack (`memory.x`).
    static mut __stack_floor: u32;
    /// The top of the stack, where it starts (cortex-m-rt's `_stack_start`, `memory.x`).
    static _stack_start: u32;
}

/// Paint the stack's memory from its floor up to [`MARGIN`] bytes below the live stack pointer. Called once, first
/// thing at boot.
pub fn paint() {
    let floor = core::ptr::addr_of_mut!(__stack_floor);
    let sp = cortex_m::register::msp::read() as usize;
    let mut p = floor;
    // SAFETY: the words between the stack's floor and MARGIN bytes below the live stack belong to no frame yet.
    while (p as usize) + MARGIN < sp {
        unsafe { p.write_volatile(PAINT) };
        p = unsafe { p.add(1) };
    }
}

/// Bytes of stack never touched since [`paint`]: from the floor up to the first word that lost its paint.
pub fn unused_bytes() -> usize {
    let top = core::ptr::addr_of!(_stack_start) as usize;
    let mut p = core::ptr::addr_of_mut!(__stack_floor) as *const u32;
    let mut n = 0;
    // SAFETY: reads the stack's own memory, from its floor up, never past its top.
    while (p as usize) < top && unsafe { p.read_volatile() } == PAINT {
        p = unsafe { p.add(1) };
        n += 4;
    }
    n
}

/// The stack's size, bytes.
pub fn size_bytes() -> usize {
    core::ptr::addr_of!(_stack_start) as usize - core::ptr::addr_of!(__stack_floor) as usize
}

/// The deepest the stack has been since [`paint`], bytes.
pub fn peak_bytes() -> u32 {
    (size_bytes() - unused_bytes()) as u32
}
