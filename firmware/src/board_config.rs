//! The board this build is for: its crystal, the ADC inputs its headers expose, and the input of each channel.
//!
//! Chosen at build time with `OCTAVAR_BOARD` (default `f405-8mhz`):
//!
//! | `OCTAVAR_BOARD` | crystal | channel inputs (scan order)          | boards                                  |
//! |-----------------|---------|--------------------------------------|-----------------------------------------|
//! | `f405-8mhz`     | 8 MHz   | PA0 PA1 PA2 PA3 PA4 (ADC1 IN0-4)     | STM32F405RG cores with every pin out    |
//! | `f405-12mhz`    | 12 MHz  | PA4 PA5 PA6 PA7 PC4 (IN4-7, IN14)    | Adafruit Feather STM32F405 Express      |
//!
//! The Feather's analog headers are A0-A5 = PA4, PA5, PA6, PA7, PC4, PC5; PA3 is its battery divider
//! (VOLTAGE_MONITOR) and PA0-PA2 are not on its headers (Adafruit's schematic, CircuitPython's board pins). A
//! build fails if a channel names an input that its board does not expose, that is not an ADC1 input, or that
//! another channel already uses.
//!
//! The PLL always runs its VCO from a 2 MHz input (M = crystal / 2 MHz), so any even crystal from 4 to 26 MHz
//! gives the same 168 MHz core and 48 MHz USB clocks; `board.rs` proves the limits at build time.

/// A GPIO port with ADC1 inputs.
#[derive(Clone, Copy, PartialEq, Eq)]
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub enum Port {
    A,
    B,
    C,
}

/// One analog input: its pin and the ADC1 channel it feeds.
#[derive(Clone, Copy)]
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub struct AdcPin {
    pub port: Port,
    pub pin: u8,
    /// ADC1 channel (IN0..IN15).
    pub channel: u8,
}

const fn a(pin: u8) -> AdcPin {
    AdcPin { port: Port::A, pin, channel: pin }
}

/// The STM32F405's ADC1 inputs (RM0090 / DS8626 pin tables): PA0-PA7 = IN0-7, PB0-PB1 = IN8-9, PC0-PC5 = IN10-15.
const ADC1_INPUTS: [AdcPin; 16] = [
    a(0),
    a(1),
    a(2),
    a(3),
    a(4),
    a(5),
    a(6),
    a(7),
    AdcPin { port: Port::B, pin: 0, channel: 8 },
    AdcPin { port: Port::B, pin: 1, channel: 9 },
    AdcPin { port: Port::C, pin: 0, channel: 10 },
    AdcPin { port: Port::C, pin: 1, channel: 11 },
    AdcPin { port: Port::C, pin: 2, channel: 12 },
    AdcPin { port: Port::C, pin: 3, channel: 13 },
    AdcPin { port: Port::C, pin: 4, channel: 14 },
    AdcPin { port: Port::C, pin: 5, channel: 15 },
];

/// One board variant (the QEMU build reads only its name).
#[derive(Clone, Copy)]
#[cfg_attr(feature = "qemu", allow(dead_code))]
pub struct BoardConfig {
    /// Board name in the hello frame.
    pub name: &'static str,
    /// The HSE crystal, Hz.
    pub hse_hz: u32,
    /// The ADC1 inputs the board's headers expose.
    pub exposes: &'static [AdcPin],
    /// The input of each channel, in scan order.
    pub adc_pins: [AdcPin; 5],
}

/// The board of this build (`OCTAVAR_BOARD`).
pub const BOARD: BoardConfig = match option_env!("OCTAVAR_BOARD") {
    None => F405_8MHZ,
    Some(name) => {
        if eq(name, "f405-8mhz") {
            F405_8MHZ
        } else if eq(name, "f405-12mhz") {
            FEATHER_F405
        } else {
            panic!("OCTAVAR_BOARD must be f405-8mhz or f405-12mhz")
        }
    }
};

/// A bare STM32F405RG core board: every pin on a header.
const F405_8MHZ: BoardConfig = BoardConfig {
    name: "STM32F405RG",
    hse_hz: 8_000_000,
    exposes: &ADC1_INPUTS,
    adc_pins: [a(0), a(1), a(2), a(3), a(4)],
};

/// The Feather's A0-A5 headers.
const FEATHER_ANALOG: [AdcPin; 6] = [a(4), a(5), a(6), a(7), ADC1_INPUTS[14], ADC1_INPUTS[15]];

/// Adafruit Feather STM32F405 Express: A0-A4 for the five channels.
const FEATHER_F405: BoardConfig = BoardConfig {
    name: "Feather STM32F405",
    hse_hz: 12_000_000,
    exposes: &FEATHER_ANALOG,
    adc_pins: [a(4), a(5), a(6), a(7), ADC1_INPUTS[14]],
};

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

const fn same(x: AdcPin, y: AdcPin) -> bool {
    x.port as u8 == y.port as u8 && x.pin == y.pin && x.channel == y.channel
}

const fn listed(p: AdcPin, list: &[AdcPin]) -> bool {
    let mut i = 0;
    while i < list.len() {
        if same(p, list[i]) {
            return true;
        }
        i += 1;
    }
    false
}

/// The board's map proved at build time: every channel's input is an ADC1 input with its right channel number,
/// on the board's headers, and used once.
const fn check(b: &BoardConfig) {
    let mut i = 0;
    while i < b.exposes.len() {
        assert!(listed(b.exposes[i], &ADC1_INPUTS), "a board exposes an input that is not an ADC1 input");
        i += 1;
    }
    let mut i = 0;
    while i < b.adc_pins.len() {
        let p = b.adc_pins[i];
        assert!(listed(p, &ADC1_INPUTS), "a channel's pin is not an ADC1 input (or has the wrong channel)");
        assert!(listed(p, b.exposes), "a channel names an input the board does not expose");
        let mut j = 0;
        while j < i {
            assert!(b.adc_pins[j].channel != p.channel, "two channels name the same input");
            j += 1;
        }
        i += 1;
    }
}

const _: () = {
    check(&F405_8MHZ);
    check(&FEATHER_F405);
    check(&BOARD);
};
