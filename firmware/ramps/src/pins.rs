//! The RAMPS 1.4 pin map on the Arduino Mega 2560.
//!
//! Each Arduino pin number is one bit of one of the chip's ports. A port has three registers:
//! PINx (read the pins), DDRx (1 = output) and PORTx (drive an output high or low, or switch
//! the pull-up of an input on). The numbers follow Marlin's `pins_RAMPS.h` and the Mega's
//! schematic (which port bit each header pin is):
//! <https://github.com/MarlinFirmware/Marlin/blob/2.1.x/Marlin/src/pins/ramps/pins_RAMPS.h>.

use gweave_controller::board::{self, Driver};

use crate::regs::{interrupt_free, reg8, Reg8};

/// One port (A..L): its PINx address; DDRx and PORTx follow it.
#[derive(Clone, Copy)]
pub struct Port(usize);

const PORT_A: Port = Port(0x20);
const PORT_B: Port = Port(0x23);
const PORT_C: Port = Port(0x26);
const PORT_D: Port = Port(0x29);
const PORT_E: Port = Port(0x2C);
const PORT_F: Port = Port(0x2F);
const PORT_G: Port = Port(0x32);
const PORT_H: Port = Port(0x100);
const PORT_J: Port = Port(0x103);
const PORT_K: Port = Port(0x106);
const PORT_L: Port = Port(0x109);

/// One pin: a bit of a port.
#[derive(Clone, Copy)]
pub struct Pin {
    port: Port,
    mask: u8,
}

impl Pin {
    const fn new(port: Port, bit: u8) -> Self {
        Pin { port, mask: 1 << bit }
    }

    fn pin_reg(self) -> Reg8 {
        reg8(self.port.0)
    }
    fn ddr_reg(self) -> Reg8 {
        reg8(self.port.0 + 1)
    }
    fn port_reg(self) -> Reg8 {
        reg8(self.port.0 + 2)
    }

    /// Drive an output from inside an interrupt (interrupts are already off there).
    #[inline(always)]
    pub fn write_in_interrupt(self, high: bool) {
        if high {
            self.port_reg().set_bits(self.mask);
        } else {
            self.port_reg().clear_bits(self.mask);
        }
    }
}

impl board::Pin for Pin {
    /// An output, driven low (the safe level of every output here: heaters and fans off, STEP
    /// idle; RAMPS's driver ENABLE is active low, and `board::set_up_pins` drives it high
    /// first).
    fn make_output(self) {
        interrupt_free(|| {
            self.ddr_reg().set_bits(self.mask);
        });
    }

    /// The chip's pull-up is about 35 kOhm to 5 V.
    fn make_input_pullup(self) {
        interrupt_free(|| {
            self.ddr_reg().clear_bits(self.mask);
            self.port_reg().set_bits(self.mask);
        });
    }

    /// The read-modify-write of PORTx runs with interrupts off: the step interrupt writes other
    /// bits of the same ports.
    fn write(self, high: bool) {
        interrupt_free(|| self.write_in_interrupt(high));
    }

    fn read(self) -> bool {
        self.pin_reg().read() & self.mask != 0
    }
}

/// The driver sockets, in the order X, Y, Z, E0, E1 (D54/D55/D38, D60/D61/D56, D46/D48/D62,
/// D26/D28/D24, D36/D34/D30), then the inputs E2 and E3 of a mixing hotend on external driver
/// boards wired to the AUX-2 header (STEP/DIR/ENABLE D63/D40/D59 and D65/D42/D64: A9, D40, A5,
/// A11, D42, A10). RAMPS has only five sockets and Marlin's `pins_RAMPS.h` names no E2 or E3
/// pins; AUX-2's pins are the ones it leaves free when no TMC driver is wired over SPI
/// (`HAS_FREE_AUX2_PINS`), and they are set up only in a build whose printer has those inputs
/// (`config::DRIVERS`), so the base image leaves the header alone.
pub const DRIVERS: [Driver<Pin>; 7] = [
    Driver { step: Pin::new(PORT_F, 0), dir: Pin::new(PORT_F, 1), enable: Pin::new(PORT_D, 7) },
    Driver { step: Pin::new(PORT_F, 6), dir: Pin::new(PORT_F, 7), enable: Pin::new(PORT_F, 2) },
    Driver { step: Pin::new(PORT_L, 3), dir: Pin::new(PORT_L, 1), enable: Pin::new(PORT_K, 0) },
    Driver { step: Pin::new(PORT_A, 4), dir: Pin::new(PORT_A, 6), enable: Pin::new(PORT_A, 2) },
    Driver { step: Pin::new(PORT_C, 1), dir: Pin::new(PORT_C, 3), enable: Pin::new(PORT_C, 7) },
    Driver { step: Pin::new(PORT_K, 1), dir: Pin::new(PORT_G, 1), enable: Pin::new(PORT_F, 5) },
    Driver { step: Pin::new(PORT_K, 3), dir: Pin::new(PORT_L, 7), enable: Pin::new(PORT_K, 2) },
];

/// Minimum endstops of X, Y and Z: D3, D14, D18.
pub const ENDSTOPS_MIN: [Pin; 3] = [Pin::new(PORT_E, 5), Pin::new(PORT_J, 1), Pin::new(PORT_D, 3)];

/// Hotend heater (D10, the MOSFET next to the power input on RAMPS "EFB").
pub const HEATER_0: Pin = Pin::new(PORT_B, 4);
/// Heated bed (D8, the big MOSFET on its own 11 A input).
pub const HEATER_BED: Pin = Pin::new(PORT_H, 5);
/// D9: the part fan on "EFB", the second hotend heater on "EEB".
pub const D9: Pin = Pin::new(PORT_H, 6);
/// The Mega's own LED (D13): lit while any heater is on.
pub const LED: Pin = Pin::new(PORT_B, 7);

/// The analog inputs of the thermistors: TEMP_0 on A13, TEMP_BED on A14, TEMP_1 on A15
/// (ADC channels 13, 14, 15).
pub const ADC_TEMP_0: u8 = 13;
pub const ADC_TEMP_BED: u8 = 14;
pub const ADC_TEMP_1: u8 = 15;

/// The InkShield's inputs, wired to RAMPS for an inkjet build (`inkshield.rs`): the address
/// lines A, B, C, D of its nozzle decoder, bit 0 first, on the AUX-4 header (D17, D16, D23,
/// D25; D17 and D16 are the address lines A and B of Steve Kelly's Marlin patch too).
#[cfg(feature = "inkjet")]
pub const INKSHIELD_ADDRESS: [Pin; 4] =
    [Pin::new(PORT_H, 0), Pin::new(PORT_H, 1), Pin::new(PORT_A, 1), Pin::new(PORT_A, 3)];
/// The pulse line of each head (`M700 P0`, `P1`): D19 (the Z_MAX endstop socket's signal, the
/// patch's head 0) and D2 (X_MAX, the InkShield library's examples' pulse pin). This firmware
/// homes to the minimum endstops only, so the maximum sockets are free.
#[cfg(feature = "inkjet")]
pub const INKSHIELD_PULSE: [Pin; 2] = [Pin::new(PORT_D, 2), Pin::new(PORT_E, 4)];
