//! The board's wiring: which pin of which GPIO port drives what.
//!
//! The pin map is BIGTREETECH's SKR Pro 1.x (STM32F407ZGT6), as Marlin's
//! `Marlin/src/pins/stm32f4/pins_BTT_SKR_PRO_common.h` lists it. A port is 16 pins; each pin
//! is configured by two bits of MODER (input, output, alternate function) and PUPDR (pull-up),
//! read in IDR, and driven through BSRR, whose low half sets pins and high half clears them in
//! one write: no read-modify-write, so the main loop and the interrupts never race on a port.

use gweave_controller::board::{self, Driver};

use crate::regs::{reg, Reg, RCC_AHB1ENR};

/// GPIO port A's registers; port n is 0x400 further.
const GPIO_BASE: usize = 0x4002_0000;
const MODER: usize = 0x00;
const PUPDR: usize = 0x0C;
const IDR: usize = 0x10;
const BSRR: usize = 0x18;
const AFRH: usize = 0x24;
/// Ports A to G: the pins below use no other.
pub const PORTS: usize = 7;

/// One pin: port (0 = A) and bit.
#[derive(Clone, Copy)]
pub struct Pin {
    pub port: u8,
    pub bit: u8,
}

impl Pin {
    const fn new(port: u8, bit: u8) -> Pin {
        Pin { port: port - b'A', bit }
    }

    fn reg(self, offset: usize) -> Reg {
        reg(GPIO_BASE + 0x400 * usize::from(self.port) + offset)
    }

    /// The pin's bit in BSRR's low half (set); shifted by 16 it clears.
    #[inline(always)]
    pub fn mask(self) -> u32 {
        1 << self.bit
    }

    /// Alternate function `af` (MODER 10; pins 8-15, AFRH). Start-up only.
    pub fn make_alternate_high(self, af: u32) {
        let shift = 2 * u32::from(self.bit);
        self.reg(MODER).modify(0b11 << shift, 0b10 << shift);
        let af_shift = 4 * (u32::from(self.bit) - 8);
        self.reg(AFRH).modify(0xF << af_shift, af << af_shift);
    }
}

impl board::Pin for Pin {
    /// A push-pull output (MODER 01). Start-up only.
    fn make_output(self) {
        let shift = 2 * u32::from(self.bit);
        self.reg(MODER).modify(0b11 << shift, 0b01 << shift);
    }

    /// MODER 00, PUPDR 01. Start-up only.
    fn make_input_pullup(self) {
        let shift = 2 * u32::from(self.bit);
        self.reg(MODER).modify(0b11 << shift, 0);
        self.reg(PUPDR).modify(0b11 << shift, 0b01 << shift);
    }

    /// One write of BSRR: safe against the step interrupt, which writes the same ports.
    #[inline(always)]
    fn write(self, high: bool) {
        write_port(usize::from(self.port), if high { self.mask() } else { self.mask() << 16 });
    }

    fn read(self) -> bool {
        self.reg(IDR).read() & self.mask() != 0
    }
}

/// Write port `port`'s BSRR: the low half's bits go high, the high half's low.
#[inline(always)]
pub fn write_port(port: usize, bsrr: u32) {
    reg(GPIO_BASE + 0x400 * port + BSRR).write(bsrr);
}

/// Switch the ports' clocks on (a port's registers do nothing until then).
pub fn enable_ports() {
    RCC_AHB1ENR.modify((1 << PORTS) - 1, (1 << PORTS) - 1);
}

/// The drivers in the core's motor order: X, Y, Z, E0, then E1 and E2 (the second and third
/// inputs of a mixing hotend). The board has no seventh driver for a fourth mixing input.
pub const DRIVERS: [Driver<Pin>; 6] = [
    Driver { step: Pin::new(b'E', 9), dir: Pin::new(b'F', 1), enable: Pin::new(b'F', 2) },
    Driver { step: Pin::new(b'E', 11), dir: Pin::new(b'E', 8), enable: Pin::new(b'D', 7) },
    Driver { step: Pin::new(b'E', 13), dir: Pin::new(b'C', 2), enable: Pin::new(b'C', 0) },
    Driver { step: Pin::new(b'E', 14), dir: Pin::new(b'A', 0), enable: Pin::new(b'C', 3) },
    Driver { step: Pin::new(b'D', 15), dir: Pin::new(b'E', 7), enable: Pin::new(b'A', 3) },
    Driver { step: Pin::new(b'D', 13), dir: Pin::new(b'G', 9), enable: Pin::new(b'F', 0) },
];

/// The X, Y and Z minimum endstops.
pub const ENDSTOPS_MIN: [Pin; 3] = [Pin::new(b'B', 10), Pin::new(b'E', 12), Pin::new(b'G', 8)];

/// The outputs of the heaters' and fan's MOSFETs, in the order of `clock::set_duty`: hotend 0,
/// hotend 1, bed, part fan.
pub const POWER: [Pin; 4] = [Pin::new(b'B', 1), Pin::new(b'D', 14), Pin::new(b'D', 12), Pin::new(b'C', 8)];

/// USART1's transmit and receive pins (alternate function 7), the SKR Pro's TFT header.
pub const USART1_TX: Pin = Pin::new(b'A', 9);
pub const USART1_RX: Pin = Pin::new(b'A', 10);
