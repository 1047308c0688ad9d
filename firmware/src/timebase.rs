//! The free-running time base of both builds: TIM2, a 32-bit hardware counter at 1 MHz, extended to 64 bits.
//!
//! A flash erase stalls every instruction fetch for up to two seconds, interrupts included, so a clock that
//! counts SysTick interrupts loses the stall for good. TIM2 counts on in hardware through any stall; it wraps
//! every 71.6 minutes, and every read extends it (the SysTick interrupt reads it each millisecond), so only a
//! stall of more than an hour could lose time. The embassy time driver (`systick.rs`) and the status frame's
//! uptime both come from here. QEMU's netduinoplus2 emulates TIM2 too, with its own timer clock.

use core::cell::Cell;

use critical_section::{CriticalSection, Mutex};
use embassy_stm32::pac;

/// The last 32-bit reading and the number of wraps before it.
static EXTENDED: Mutex<Cell<(u32, u32)>> = Mutex::new(Cell::new((0, 0)));

/// Start TIM2 counting microseconds from a timer kernel clock of `timer_clock_hz`.
pub fn init(timer_clock_hz: u32) {
    pac::RCC.apb1enr().modify(|w| w.set_tim2en(true));
    let t = pac::TIM2;
    t.cr1().modify(|w| w.set_cen(false));
    t.psc().write_value((timer_clock_hz / 1_000_000 - 1) as u16);
    t.arr().write_value(u32::MAX);
    // The update event loads the prescaler and clears the counter.
    t.egr().write(|w| w.set_ug(true));
    t.cr1().modify(|w| w.set_cen(true));
}

/// Microseconds since [`init`], inside a critical section.
pub fn now_us_cs(cs: CriticalSection) -> u64 {
    let cell = EXTENDED.borrow(cs);
    let (last, mut wraps) = cell.get();
    let low = pac::TIM2.cnt().read();
    if low < last {
        wraps = wraps.wrapping_add(1);
    }
    cell.set((low, wraps));
    (u64::from(wraps) << 32) | u64::from(low)
}

/// Microseconds since [`init`].
pub fn now_us() -> u64 {
    critical_section::with(now_us_cs)
}
