//! The embassy time driver of both builds: time from the free-running TIM2 counter (`timebase.rs`), alarms
//! checked on a SysTick interrupt every millisecond.
//!
//! embassy-stm32's TIM2 driver cannot run under QEMU (its `init` needs RCC and PWR, which QEMU does not emulate),
//! and the application's timing should be the code CI runs. So both builds use this driver: `now()` reads the
//! hardware counter, so a stall of the CPU (a flash erase) costs alarms their punctuality but never costs the
//! clock any time, and SysTick interrupts every millisecond to fire due alarms (at most 1 ms late).

use core::cell::{Cell, RefCell};
use core::task::Waker;

use cortex_m::peripheral::syst::SystClkSource;
use cortex_m::peripheral::SYST;
use cortex_m_rt::exception;
use critical_section::Mutex;
use embassy_time_driver::Driver;
use embassy_time_queue_utils::Queue;

use crate::timebase;

struct SysTickDriver {
    /// The next alarm in ticks (u64::MAX: none).
    alarm: Mutex<Cell<u64>>,
    queue: Mutex<RefCell<Queue>>,
}

embassy_time_driver::time_driver_impl!(static DRIVER: SysTickDriver = SysTickDriver {
    alarm: Mutex::new(Cell::new(u64::MAX)),
    queue: Mutex::new(RefCell::new(Queue::new())),
});

/// Start the driver: the time base on a timer clock of `timer_clock_hz`, SysTick every millisecond of a core
/// clock of `core_hz`.
pub fn init(mut syst: SYST, core_hz: u32, timer_clock_hz: u32) {
    timebase::init(timer_clock_hz);
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(core_hz / 1000 - 1);
    syst.clear_current();
    syst.enable_interrupt();
    syst.enable_counter();
}

impl SysTickDriver {
    fn on_tick(&self) {
        critical_section::with(|cs| {
            let now = timebase::now_us_cs(cs);
            if now >= self.alarm.borrow(cs).get() {
                let next = self.queue.borrow(cs).borrow_mut().next_expiration(now);
                self.alarm.borrow(cs).set(next);
            }
        });
    }
}

impl Driver for SysTickDriver {
    fn now(&self) -> u64 {
        timebase::now_us()
    }

    fn schedule_wake(&self, at: u64, waker: &Waker) {
        critical_section::with(|cs| {
            let mut queue = self.queue.borrow(cs).borrow_mut();
            if queue.schedule_wake(at, waker) {
                let next = queue.next_expiration(timebase::now_us_cs(cs));
                self.alarm.borrow(cs).set(next);
            }
        });
    }
}

#[exception]
fn SysTick() {
    DRIVER.on_tick();
}
