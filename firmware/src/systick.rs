//! The embassy time driver of both builds: SysTick, one interrupt per millisecond, 1 MHz ticks.
//!
//! embassy-stm32's TIM2 driver cannot run under QEMU (its `init` needs RCC and PWR, which QEMU does not emulate),
//! and the application's timing should be the code CI runs. So the board uses this driver too: SysTick counts
//! the core clock (168 MHz on the board; QEMU's netduinoplus2 models the same), interrupts every millisecond,
//! and `now()` adds the count within the millisecond, so ticks are microseconds. Alarms are checked on each
//! millisecond interrupt: a timer fires at most 1 ms late.

use core::cell::{Cell, RefCell};
use core::sync::atomic::{AtomicU32, Ordering};
use core::task::Waker;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::{SCB, SYST};
use cortex_m_rt::exception;
use critical_section::{CriticalSection, Mutex};
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

struct SysTickDriver {
    /// Milliseconds since start.
    ms: Mutex<Cell<u64>>,
    /// The next alarm in ticks (u64::MAX: none).
    alarm: Mutex<Cell<u64>>,
    queue: Mutex<RefCell<Queue>>,
    /// Core clock cycles per millisecond (SysTick reload + 1).
    cycles_per_ms: AtomicU32,
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    ms: Mutex::new(Cell::new(0)),
    alarm: Mutex::new(Cell::new(u64::MAX)),
    queue: Mutex::new(RefCell::new(Queue::new())),
    cycles_per_ms: AtomicU32::new(1),
});

/// Start the driver on `syst`, counting a core clock of `core_hz`.
pub fn init(mut syst: SYST, core_hz: u32) {
    let per_ms = core_hz / 1000;
    DRIVER.cycles_per_ms.store(per_ms, Ordering::Relaxed);
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(per_ms - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

#[allow(dead_code)] // used by the QEMU benchmark
/// Core clock cycles since start (for benchmarks): milliseconds and the count within the current one.
pub fn cycles() -> u64 {
    critical_section::with(|cs| {
        let (ms, within) = DRIVER.read(cs);
        ms * u64::from(DRIVER.cycles_per_ms.load(Ordering::Relaxed)) + u64::from(within)
    })
}

impl SysTickDriver {
    /// (milliseconds, cycles into the current millisecond), consistent even while the SysTick interrupt is
    /// pending (a wrap inside a critical section).
    fn read(&self, cs: CriticalSection) -> (u64, u32) {
        let per_ms = self.cycles_per_ms.load(Ordering::Relaxed);
        let mut ms = self.ms.borrow(cs).get();
        let mut current = SYST::get_current();
        if SCB::is_pendst_pending() {
            // Wrapped and not yet counted: re-read after the wrap.
            current = SYST::get_current();
            ms += 1;
        }
        (ms, per_ms.saturating_sub(1).saturating_sub(current))
    }

    fn now_cs(&self, cs: CriticalSection) -> u64 {
        let (ms, within) = self.read(cs);
        let per_ms = u64::from(self.cycles_per_ms.load(Ordering::Relaxed));
        ms * 1000 + u64::from(within) * 1000 / per_ms
    }

    fn on_tick(&self) {
        critical_section::with(|cs| {
            let ms = self.ms.borrow(cs).get() + 1;
            self.ms.borrow(cs).set(ms);
            let now = self.now_cs(cs);
            if now >= self.alarm.borrow(cs).get() {
                let next = self.queue.borrow(cs).borrow_mut().next_expiration(now);
                self.alarm.borrow(cs).set(next);
            }
        });
    }
}

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        critical_section::with(|cs| self.now_cs(cs))
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let mut queue = self.queue.borrow(cs).borrow_mut();
            if queue.schedule_wake(at, waker) {
                let next = queue.next_expiration(self.now_cs(cs));
                self.alarm.borrow(cs).set(next);
            }
        });
    }
}

#[exception]
fn SysTick() {
    DRIVER.on_tick();
}
