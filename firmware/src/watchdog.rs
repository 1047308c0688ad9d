//! The independent watchdog: resets the MCU if sampling stops reaching characterize for
//! [`WATCHDOG_TIMEOUT_MS`], which is longer than any flash stall (a 128 KiB erase takes at most 2 s), since the
//! IWDG's own oscillator counts on through a stall.
//!
//! It is fed once a second, and only while characterize has taken a block since the last feed: a hung sampler,
//! a dead converter that its recovery cannot revive, or a characterize stuck in a loop all end in a reset, and
//! the field log then pools the last checkpoint into the new session. QEMU does not emulate the IWDG; the same
//! code runs there and its writes go nowhere.

use core::sync::atomic::Ordering;

use embassy_stm32::pac;
use embassy_time::Timer;

use crate::characterize::BLOCKS_TAKEN;

/// The watchdog's timeout, ms: LSI (32 kHz) / 64 = 500 Hz, reload 4000.
pub const WATCHDOG_TIMEOUT_MS: u32 = 8_000;
const RELOAD: u16 = (WATCHDOG_TIMEOUT_MS / 2) as u16;

/// The IWDG key register's commands (RM0090 section 19.4.1).
const KEY_UNLOCK: u16 = 0x5555;
const KEY_FEED: u16 = 0xAAAA;
const KEY_START: u16 = 0xCCCC;

fn key(k: u16) {
    pac::IWDG.kr().write_value(pac::iwdg::regs::Kr(u32::from(k)));
}

/// Start the watchdog, then feed it once a second while blocks keep flowing.
#[embassy_executor::task]
pub async fn watchdog_task() {
    key(KEY_START);
    key(KEY_UNLOCK);
    pac::IWDG.pr().write(|w| w.set_pr(pac::iwdg::vals::Pr::DIVIDE_BY64));
    pac::IWDG.rlr().write(|w| w.set_rl(RELOAD));
    key(KEY_FEED);
    let mut seen = BLOCKS_TAKEN.load(Ordering::Relaxed);
    loop {
        Timer::after_secs(1).await;
        let now = BLOCKS_TAKEN.load(Ordering::Relaxed);
        if now != seen {
            key(KEY_FEED);
            seen = now;
        }
    }
}

const _: () = assert!(RELOAD < 4096, "the IWDG reload is 12 bits");
