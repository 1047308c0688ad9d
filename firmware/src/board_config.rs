//! The board this build is for: its crystal and the ADC inputs of the channels, in one place.
//!
//! Chosen at build time with `OCTAVAR_BOARD` (default `f405-8mhz`):
//!
//! | `OCTAVAR_BOARD` | crystal | analog inputs (scan order)        | boards                                  |
//! |-----------------|---------|-----------------------------------|-----------------------------------------|
//! | `f405-8mhz`     | 8 MHz   | PA0 PA1 PA2 PA3 PA4 (ADC1 IN0-4)  | STM32F4DISCOVERY-style, most F405 cores |
//! | `f405-12mhz`    | 12 MHz  | PA0 PA1 PA2 PA3 PA4 (ADC1 IN0-4)  | Adafruit Feather STM32F405, pyboard     |
//!
//! The PLL always runs its VCO from a 2 MHz input (M = crystal / 2 MHz), so any even crystal from 4 to 26 MHz
//! gives the same 168 MHz core and 48 MHz USB clocks; `board.rs` proves the limits at build time.

/// One board variant (the QEMU build reads only its name).
#[derive(Clone, Copy)]
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub struct BoardConfig {
    /// Board name in the hello frame.
    pub name: &'static str,
    /// The HSE crystal, Hz.
    pub hse_hz: u32,
    /// Port A pin (= ADC1 input number, IN0..IN7 are PA0..PA7) of each channel, in scan order.
    pub adc_pins: [u8; 5],
}

const PA0_TO_PA4: [u8; 5] = [0, 1, 2, 3, 4];

/// The board of this build (`OCTAVAR_BOARD`).
pub const BOARD: BoardConfig = match option_env!("OCTAVAR_BOARD") {
    None => F405_8MHZ,
    Some(name) => {
        if eq(name, "f405-8mhz") {
            F405_8MHZ
        } else if eq(name, "f405-12mhz") {
            BoardConfig { name: "STM32F405RG 12 MHz", hse_hz: 12_000_000, adc_pins: PA0_TO_PA4 }
        } else {
            panic!("OCTAVAR_BOARD must be f405-8mhz or f405-12mhz")
        }
    }
};

const F405_8MHZ: BoardConfig = BoardConfig { name: "STM32F405RG", hse_hz: 8_000_000, adc_pins: PA0_TO_PA4 };

const fn eq(a: &str, b: &str) -> bool {
    let (a, b) = (a.as_bytes(), b.as_bytes());
    if a.len() != b.len() {
        return false;
    }
    let mut i = 0;
    while i < a.len() {
        if a[i] != b[i] {
            return false;
        }
        i += 1;
    }
    true
}

const _: () = {
    let mut i = 0;
    while i < BOARD.adc_pins.len() {
        assert!(BOARD.adc_pins[i] < 8, "ADC1 IN0..IN7 are PA0..PA7");
        i += 1;
    }
};
